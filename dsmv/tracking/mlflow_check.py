"""Look at the MLflow UI as a user would: a small sweep, ``dsmv ui``, screenshots in headless Chromium.

``make mlflow-screenshots`` (or ``python -m dsmv.tracking.mlflow_check OUTDIR``) runs two landings as a
sweep into a fresh store, starts ``dsmv ui`` over it on a free loopback port, and saves four PNGs
into OUTDIR: the page of the link ``dsmv ui`` prints, the experiment's runs list (``runs_list.png``);
the sweep's jobs listed flat, deepest first (``jobs.png``); one run's page (``run.png``) and the
sweep's overlaid sinkage histories (``histories.png``; the x axis "Step" is simulated time in µs).
It needs Chromium (Debian's ``chromium`` package; ``apt-get install chromium``) and exits 2 with
one line if it is missing.
"""

from __future__ import annotations

import json
import shutil
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

from dsmv.tracking.ui import CLASSIC_QUERY, free_port, runs_list_url

#: the sweep: the default landing at two masses, on the coarse mesh (a few seconds each)
SWEEP = ["-m", "landing.mass_kg=4500,6500", "mesh=coarse"]
#: Chromium's flags for a headless page on a closed network (no background lookups, no sandbox as root)
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--hide-scrollbars"]
#: simulated milliseconds Chromium lets the single-page app fetch and render before the shot
RENDER_BUDGET_MS = 20000


def screenshot(chromium: str, url: str, path: Path, profile: Path, height_px: int) -> Path:
    subprocess.run([chromium, *CHROMIUM_FLAGS, f"--window-size=1600,{height_px}", f"--user-data-dir={profile}",
                    f"--screenshot={path}", f"--virtual-time-budget={RENDER_BUDGET_MS}", url],
                   check=True, capture_output=True, timeout=180)
    return path


def printed_url(ui: subprocess.Popen) -> str:
    """The link ``dsmv ui`` prints once its server answers (it ends the command's output if the server fails)."""
    for line in ui.stdout:
        if line.strip().startswith("http://"):
            return line.strip()
    raise RuntimeError(f"dsmv ui printed no link (exit code {ui.wait()}): {ui.stderr.read().strip()}")


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    out = Path(argv[0] if argv else "runs/mlflow_screenshots").resolve()
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        print("mlflow_check: Chromium not found: apt-get install chromium", file=sys.stderr)
        return 2
    out.mkdir(parents=True, exist_ok=True)
    dsmv = str(Path(sys.executable).parent / "dsmv")
    with tempfile.TemporaryDirectory() as tmp:
        runs = Path(tmp) / "runs"
        subprocess.run([dsmv, *SWEEP, f"paths.runs_dir={runs}"], check=True, capture_output=True)
        from dsmv.tracking.run_writer import open_client

        client = open_client(f"sqlite:///{runs / 'mlflow.db'}")
        (experiment,) = [e for e in client.search_experiments() if e.name.startswith("dsmv-")]
        jobs = [r for r in client.search_runs([experiment.experiment_id]) if r.data.tags.get("dsmv.role") != "sweep"]
        ui = subprocess.Popen([dsmv, "ui", "--port", str(free_port()), f"paths.runs_dir={runs}"],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            url = printed_url(ui)
            base, eid = url.split("/#/")[0], experiment.experiment_id
            ids = json.dumps([r.info.run_id for r in jobs], separators=(",", ":"))
            pages = {
                "runs_list.png": (url, 1000),
                # the jobs (a filter on a job's metric lists them flat, not folded under the sweep's run), deepest first
                "jobs.png": (runs_list_url(base, eid, searchFilter="metrics.max_sinkage_m > 0",
                                           orderByKey="metrics.`max_sinkage_m`"), 1000),
                "run.png": (f"{base}/#/experiments/{eid}/runs/{jobs[0].info.run_id}?{CLASSIC_QUERY}", 2600),
                "histories.png": (f"{base}/#/metric/?runs={ids}&metric=%22history.sinkage_m%22"
                                  f"&experiments=[%22{eid}%22]&plot_metric_keys=%5B%22history.sinkage_m%22%5D"
                                  f"&x_axis=step&{CLASSIC_QUERY}", 1000),
            }
            for name, (page, height_px) in pages.items():
                screenshot(chromium, page, out / name, Path(tmp) / "profile", height_px)
                print(f"mlflow_check: {out / name}  ({page})")
        finally:
            ui.send_signal(signal.SIGINT)  # as Ctrl-C: dsmv ui stops its server
            ui.wait(timeout=60)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
