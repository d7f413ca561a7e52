"""Look at the MLflow UI as a user would: a small sweep, the UI on loopback, screenshots in headless Chromium.

``make mlflow-screenshots`` (or ``python -m dsmv.tracking.mlflow_check OUTDIR``) runs two landings as a
sweep into a fresh store, starts ``mlflow ui`` on a free loopback port, and saves three PNGs
into OUTDIR: the experiment's runs list (``runs_list.png``), one run's page (``run.png``) and
the sweep's overlaid sinkage histories (``histories.png``; the x axis "Step" is simulated time
in µs). It needs Chromium (Debian's ``chromium`` package; ``apt-get install chromium``) and exits
2 with one line if it is missing.
"""

from __future__ import annotations

import json
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

#: the sweep: the default landing at two masses, on the coarse mesh (a few seconds each)
SWEEP = ["-m", "landing.mass_kg=4500,6500", "mesh=coarse"]
#: Chromium's flags for a headless page on a closed network (no background lookups, no sandbox as root)
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--hide-scrollbars"]
#: the UI's own switch to its classic (machine-learning) side bar, where MLflow 3 would open on GenAI's
CLASSIC = "workflowType=machine_learning"
#: simulated milliseconds Chromium lets the single-page app fetch and render before the shot
RENDER_BUDGET_MS = 20000


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for(url: str, timeout_s: float) -> None:
    deadline = time.time() + timeout_s
    while True:
        try:
            urllib.request.urlopen(url, timeout=2).read()
            return
        except OSError:
            if time.time() > deadline:
                raise RuntimeError(f"{url} did not answer within {timeout_s:.0f} s") from None
            time.sleep(0.5)


def screenshot(chromium: str, url: str, path: Path, profile: Path, height_px: int) -> Path:
    subprocess.run([chromium, *CHROMIUM_FLAGS, f"--window-size=1600,{height_px}", f"--user-data-dir={profile}",
                    f"--screenshot={path}", f"--virtual-time-budget={RENDER_BUDGET_MS}", url],
                   check=True, capture_output=True, timeout=180)
    return path


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    out = Path(argv[0] if argv else "runs/mlflow_screenshots").resolve()
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        print("mlflow_check: Chromium not found: apt-get install chromium", file=sys.stderr)
        return 2
    out.mkdir(parents=True, exist_ok=True)
    bin_dir = Path(sys.executable).parent
    with tempfile.TemporaryDirectory() as tmp:
        runs = Path(tmp) / "runs"
        subprocess.run([str(bin_dir / "dsmv"), *SWEEP, f"paths.runs_dir={runs}"], check=True, capture_output=True)
        store = f"sqlite:///{runs / 'mlflow.db'}"
        from mlflow.tracking import MlflowClient

        client = MlflowClient(store)
        (experiment,) = [e for e in client.search_experiments() if e.name.startswith("dsmv-")]
        jobs = [r for r in client.search_runs([experiment.experiment_id]) if r.data.tags.get("dsmv.role") != "sweep"]
        port = free_port()
        ui = subprocess.Popen([str(bin_dir / "mlflow"), "ui", "--backend-store-uri", store, "--host", "127.0.0.1",
                               "--port", str(port)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            base = f"http://127.0.0.1:{port}"
            wait_for(base, 120)
            eid = experiment.experiment_id
            ids = json.dumps([r.info.run_id for r in jobs], separators=(",", ":"))
            # the jobs (a filter on a job's metric lists them flat, not folded under the sweep's run), deepest first
            jobs_filter = "searchFilter=metrics.max_sinkage_m%20%3E%200&orderByKey=metrics.%60max_sinkage_m%60"
            pages = {
                "runs_list.png": (f"{base}/#/experiments/{eid}/runs?{CLASSIC}&{jobs_filter}", 1000),
                "run.png": (f"{base}/#/experiments/{eid}/runs/{jobs[0].info.run_id}?{CLASSIC}", 2600),
                "histories.png": (f"{base}/#/metric/?runs={ids}&metric=%22history.sinkage_m%22"
                                  f"&experiments=[%22{eid}%22]&plot_metric_keys=%5B%22history.sinkage_m%22%5D"
                                  f"&x_axis=step&{CLASSIC}", 1000),
            }
            for name, (url, height_px) in pages.items():
                screenshot(chromium, url, out / name, Path(tmp) / "profile", height_px)
                print(f"mlflow_check: {out / name}  ({url})")
        finally:
            ui.terminate()
            ui.wait(timeout=30)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
