"""``dsmv-bench --sweeps``: what tracking and the launchers cost a job, measured as whole commands.

Three figures, each a median over interleaved repeats of the same commands in one run (the machine's
load changes both sides alike):

1. **A single warm run, tracked against untracked**: the default scene with the local MLflow store
   (created beforehand) and with ``tracking=disabled``.
2. **Tracking's cost per job over a sweep**: 16 jobs on two joblib workers (8 per worker), tracked
   and untracked, the difference divided by 16.
3. **Launchers**: 8 landings on the ``medium`` (0.04 m) and the ``standard`` (0.02 m) mesh through
   ``hydra/launcher=dsmv_local`` (submitit: a worker process per core, one Numba thread each) against
   ``hydra/launcher=joblib`` with two workers, both tracked.

Writes ``bench_sweeps.md`` and ``bench_sweeps.json`` under ``--out``.
"""

from __future__ import annotations

import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: the swept values: landings that differ only in their touchdown velocity (m/s)
VELOCITIES_M_S = "1.0,1.25,1.5,1.75,2.0,2.25,2.5,2.75"
VELOCITIES_16_M_S = "1.0,1.1,1.2,1.3,1.4,1.5,1.6,1.7,1.8,1.9,2.0,2.1,2.2,2.3,2.4,2.5"
QUIET = ["solver.progress=off", "output.plots=false"]
#: the launchers' sweeps: on the medium mesh (0.04 m core cells, a 0.3 s solve) a job's own start
#: weighs most; on the standard mesh (0.02 m, the studies' and the dataset's) less
MESHES = ("medium", "standard")
LAUNCHERS = {
    "joblib, 2 workers": ["hydra/launcher=joblib", "hydra.launcher.n_jobs=2"],
    "dsmv_local (submitit)": ["hydra/launcher=dsmv_local"],
}


def _dsmv() -> str:
    return str(Path(sys.executable).parent / "dsmv")


def timed(command: list[str], cwd: Path) -> float:
    """Wall time of a whole ``dsmv`` command (s); stops the benchmark if it fails."""
    started = time.perf_counter()
    done = subprocess.run(command, cwd=cwd, capture_output=True, text=True,
                          env={**os.environ, "NUMBA_NUM_THREADS": "1"})
    wall = time.perf_counter() - started
    if done.returncode != 0:
        raise SystemExit(f"dsmv-bench: {' '.join(command[1:])} failed ({done.returncode}):\n{done.stderr[-2000:]}")
    return wall


def interleaved(commands: dict[str, list[str]], repeats: int, cwd: Path) -> dict[str, list[float]]:
    """Each command ``repeats`` times, in turn: A B A B …"""
    walls: dict[str, list[float]] = {name: [] for name in commands}
    for _ in range(repeats):
        for name, command in commands.items():
            walls[name].append(timed(command, cwd))
            print(f"  {name:<40} {walls[name][-1]:6.2f} s", flush=True)
    return walls


def measure(repeats: int, scratch: Path) -> dict:
    runs = scratch / "runs"
    store = [f"paths.runs_dir={runs}"]
    single = [_dsmv(), *store, *QUIET]
    print("dsmv-bench --sweeps: warming the kernels and creating the store", flush=True)
    timed(single, scratch)
    timed([*single, "tracking=disabled"], scratch)

    print("a single warm run", flush=True)
    one = interleaved({"tracked": single, "untracked": [*single, "tracking=disabled"]}, repeats, scratch)

    print("16 jobs on two joblib workers", flush=True)
    sweep = [_dsmv(), "-m", *store, *QUIET, f"landing.velocity_m_s={VELOCITIES_16_M_S}", "hydra/launcher=joblib",
             "hydra.launcher.n_jobs=2"]
    per_job = interleaved({"tracked": sweep, "untracked": [*sweep, "tracking=disabled"]}, max(1, repeats // 2), scratch)

    launchers = {}
    for mesh in MESHES:
        print(f"8 landings on the {mesh} mesh through each launcher", flush=True)
        base = [_dsmv(), "-m", *store, *QUIET, f"mesh={mesh}", f"landing.velocity_m_s={VELOCITIES_M_S}"]
        launchers[mesh] = interleaved({name: [*base, *extra] for name, extra in LAUNCHERS.items()},
                                      max(1, repeats // 2), scratch)

    parts = {"single": one, "sweep": per_job, **{f"launchers {m}": w for m, w in launchers.items()}}
    med = {part: {k: statistics.median(v) for k, v in walls.items()} for part, walls in parts.items()}
    return {
        "walls_s": {"single": one, "sweep": per_job, "launchers": launchers},
        "median_s": med,
        "single_run_overhead_s": med["single"]["tracked"] - med["single"]["untracked"],
        "sweep_overhead_per_job_s": (med["sweep"]["tracked"] - med["sweep"]["untracked"]) / 16,
        "dsmv_local_over_joblib": {m: med[f"launchers {m}"]["dsmv_local (submitit)"] /
                                   med[f"launchers {m}"]["joblib, 2 workers"] for m in MESHES},
    }


def report(figures: dict, repeats: int) -> str:
    med = figures["median_s"]
    lines = [
        "# Tracking and launcher overhead",
        "",
        f"`dsmv-bench --sweeps`: medians of {repeats} interleaved repeats (sweeps: {max(1, repeats // 2)}), whole "
        f"commands, one Numba thread per job; {platform.processor() or platform.machine()}, {os.cpu_count()} cores.",
        "",
        "| what | tracked or launcher A | untracked or launcher B | figure |",
        "|---|---|---|---|",
        f"| a single warm run of the default scene | {med['single']['tracked']:.2f} s | "
        f"{med['single']['untracked']:.2f} s | {figures['single_run_overhead_s']:+.2f} s tracked |",
        f"| 16 jobs on two joblib workers (8 each) | {med['sweep']['tracked']:.2f} s | "
        f"{med['sweep']['untracked']:.2f} s | "
        f"{figures['sweep_overhead_per_job_s']:+.3f} s per job tracked |",
        *(f"| 8 landings on the {mesh} mesh, tracked: dsmv_local against joblib (2 workers) | "
          f"{med[f'launchers {mesh}']['dsmv_local (submitit)']:.2f} s | "
          f"{med[f'launchers {mesh}']['joblib, 2 workers']:.2f} s | {figures['dsmv_local_over_joblib'][mesh]:.2f}× |"
          for mesh in MESHES),
        "",
        "A job's MLflow run is written by a writer process (`dsmv.tracking.run_writer`) that imports MLflow while the job "
        "composes its scene and solves; a sweep has one writer on its machine, which its jobs reach through a Unix "
        "socket whatever the launcher. `dsmv_local` starts a submitit worker per core, each taking the sweep's next "
        "job in turn: like joblib's workers, each pays Python's start, the imports and the kernels' loading from the "
        "Numba cache once, not once per job.",
        "",
    ]
    return "\n".join(lines)


def main(out: Path, quick: bool) -> None:
    repeats = 2 if quick else 6
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="dsmv-bench-sweeps-") as scratch:
        figures = measure(repeats, Path(scratch))
    (out / "bench_sweeps.json").write_text(json.dumps(figures, indent=1))
    text = report(figures, repeats)
    (out / "bench_sweeps.md").write_text(text)
    print(text)
