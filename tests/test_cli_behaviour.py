"""The real ``dsmv`` command as a user meets it: exit codes per status, and interrupts.

SIGTERM (a timeout, a cancelled job) and SIGINT (Ctrl-C) stop a CEL run within seconds: result.json
says ``interrupted``, the MLflow run is closed KILLED with the reason, one line is printed and no
traceback, and the exit code is the documented one (dsmv.results.EXIT_CODES).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from dsmv.results import EXIT_CODES, RESULT_FILE

BIN = Path(sys.executable).parent
QUICK = ["solver=cel2d", "mesh=coarse", "output.plots=false", "solver.progress=off"]


def dsmv(tmp_path, *overrides, tracking="disabled"):
    env = dict(os.environ, NUMBA_NUM_THREADS="1", HYDRA_FULL_ERROR="0")
    run_dir = tmp_path / "run"
    proc = subprocess.run([str(BIN / "dsmv"), *QUICK, f"tracking={tracking}", *overrides, f"hydra.run.dir={run_dir}",
                           f"paths.runs_dir={tmp_path / 'runs'}"], cwd=tmp_path, env=env, capture_output=True,
                          text=True, timeout=600)
    result = json.loads((run_dir / RESULT_FILE).read_text()) if (run_dir / RESULT_FILE).exists() else None
    return proc, result


@pytest.mark.parametrize("overrides, status", [
    ((), "ok"),
    (("solver.cfl=1.0",), "unstable"),
    (("solver.initial_travel_m=0.03",), "out_of_domain"),
    (("soil.su0_pa=2000", "soil.ks_pa_per_m=0", "landing.mass_kg=10500"), "bearing_failure"),
])
def test_the_exit_code_tells_the_status(tmp_path, overrides, status):
    proc, result = dsmv(tmp_path, *overrides)
    assert result["status"] == status, result["message"]
    assert proc.returncode == EXIT_CODES[status], proc.stderr
    assert "Traceback" not in proc.stderr


def test_a_config_error_exits_2_in_one_line(tmp_path):
    proc, result = dsmv(tmp_path, "landing.mass_kg=-1")
    assert proc.returncode == 2 and result is None
    assert len(proc.stderr.strip().splitlines()) == 1 and "landing.mass_kg" in proc.stderr


def _store_status(runs_dir: Path) -> str:
    from mlflow.tracking import MlflowClient

    client = MlflowClient(f"sqlite:///{runs_dir / 'mlflow.db'}")
    runs = [r for e in client.search_experiments() for r in client.search_runs([e.experiment_id])]
    assert len(runs) == 1
    return runs[0].info.status, runs[0].data.tags.get("dsmv.status")


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_a_signal_stops_the_run_and_keeps_its_record(tmp_path, sig):
    """A fine mesh keeps the run busy for minutes; the signal comes once it steps (its log says so)."""
    env = dict(os.environ, NUMBA_NUM_THREADS="1")
    run_dir, runs = tmp_path / "run", tmp_path / "runs"
    proc = subprocess.Popen([str(BIN / "dsmv"), "solver=cel2d", "mesh.cell_size_m=0.005", "output.plots=false",
                             "solver.progress=on", "tracking=local", f"paths.runs_dir={runs}",
                             f"hydra.run.dir={run_dir}"], cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 300
    while time.time() < deadline and not (run_dir / "config_resolved.yaml").exists():
        time.sleep(0.2)
    time.sleep(3.0)  # compiled or loaded from the cache, stepping
    proc.send_signal(sig)
    sent = time.time()
    out, err = proc.communicate(timeout=60)
    assert time.time() - sent < 5.0
    assert proc.returncode == EXIT_CODES["interrupted"], err
    assert "Traceback" not in err + out
    result = json.loads((run_dir / RESULT_FILE).read_text())
    assert result["status"] == "interrupted" and signal.Signals(sig).name in result["message"]
    assert [line for line in err.splitlines() if line.startswith("dsmv:")] == [
        f"dsmv: {result['message']}; result.json written in {run_dir}"]
    assert _store_status(runs) == ("KILLED", "interrupted")


def test_the_cost_guard_refuses_a_run_of_hours_at_once(tmp_path):
    """0.5 mm cells: 4.6 million cells × 290 000 steps. Refused before any state is allocated."""
    started = time.time()
    proc, result = dsmv(tmp_path, "mesh.cell_size_m=0.0005")
    assert time.time() - started < 5.0 + 3.0  # + the interpreter's and Hydra's start-up
    assert proc.returncode == 2 and result is None
    assert len(proc.stderr.strip().splitlines()) == 1 and "solver.max_wall_s" in proc.stderr


def test_the_estimate_is_kept_beside_the_wall_time(tmp_path):
    proc, result = dsmv(tmp_path)
    assert result["status"] == "ok" and result["units"]["estimated_wall_s"] == "s"
    assert 0.0 < result["metrics"]["estimated_wall_s"] < 3600.0


def test_a_sweep_exits_with_its_worst_job():
    from dsmv.tracking import sweep_exit_code

    assert sweep_exit_code(["ok"] * 12 + ["bearing_failure", "failed"]) == ("12 ok, 1 bearing_failure, 1 failed", 1)
    assert sweep_exit_code(["ok", "bearing_failure"]) == ("1 ok, 1 bearing_failure", 0)  # an answer
    assert sweep_exit_code(["ok", "out_of_domain", "unstable"])[1] == EXIT_CODES["unstable"]
    assert sweep_exit_code(["ok", "interrupted", "unstable"])[1] == EXIT_CODES["interrupted"]


# --------------------------------------------------------------------------- physically meaningful values


def test_the_stress_suites_fast_scenes_stay_legal_and_the_limits_are_stated(compose_cfg):
    """10 m/s on the default soil is 0.037 c (c = 267 m/s); the table 3 design's fastest, 8 m/s on su0 = 2 kPa,
    is 0.047 c; a cone's cells are sized to its penetration, so the core-cell bound leaves it alone."""
    from dsmv.errors import ConfigError
    from dsmv.scene import build_scene, elastic_wave_speed_m_s

    for overrides in (["landing.velocity_m_s=10", "landing.mass_kg=10500"],
                      ["soil.law=einav_randolph", "soil.rate.eta=0.15", "landing.velocity_m_s=10"],
                      ["soil.su0_pa=2000", "landing.velocity_m_s=8"],
                      ["geometry=fall_cone_30deg", "landing.velocity_m_s=1"], ["mesh=coarse", "geometry=tbar"]):
        build_scene(compose_cfg(["solver=cel2d", "tracking=disabled", *overrides]))
    scene = build_scene(compose_cfg(["tracking=disabled"]))
    assert elastic_wave_speed_m_s(scene.soil) == pytest.approx(267.04, abs=0.01)
    with pytest.raises(ConfigError, match=r"landing.velocity_m_s = 27.0: must be at most 26.7 m/s"):
        build_scene(compose_cfg(["tracking=disabled", "landing.velocity_m_s=27"]))
    with pytest.raises(ConfigError, match=r"mesh.cell_size_m = 0.3: must be at most 0.25 m"):
        build_scene(compose_cfg(["tracking=disabled", "solver=cel2d", "geometry=tbar", "mesh.cell_size_m=0.3"]))
    # the energy method has no mesh: its cells are not judged
    build_scene(compose_cfg(["tracking=disabled", "solver=analytic_energy", "mesh.cell_size_m=0.5"]))

