"""``dsmv ui`` and what the runs list shows: the link to the classic view, the server on loopback with few
processes, one-line mistakes, and run names that say what a run computes."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest

from dsmv.app.ui import command_for
from dsmv.config.tree import compose_scene
from dsmv.tracking.runs import run_name, short_overrides, sweep_name
from dsmv.tracking.ui import port_in_use, runs_list_url

BIN = Path(sys.executable).parent


def ui(tmp_path: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(BIN / "dsmv"), "ui", *args], cwd=tmp_path, capture_output=True, text=True, timeout=120)


def test_the_link_opens_the_experiments_runs_in_the_classic_view():
    assert runs_list_url("http://127.0.0.1:5000", "7") == \
        "http://127.0.0.1:5000/#/experiments/7/runs?workflowType=machine_learning"
    assert runs_list_url("http://h:1", "7", searchFilter="metrics.max_sinkage_m > 0") == \
        "http://h:1/#/experiments/7/runs?workflowType=machine_learning&searchFilter=metrics.max_sinkage_m%20%3E%200"


def test_a_3d_and_a_2d_run_are_named_by_overrides_solver_and_soil_law():
    plate = ["solver=cel3d", "geometry=rectangular_plate", "landing.mass_kg=5000", "landing.velocity_m_s=1.0"]
    # where and how a run is kept, settings that change no result and the study name nothing
    kept = ["paths.runs_dir=/tmp/r", "hydra/launcher=joblib", "tracking=disabled", "solver.max_wall_s=7200",
            "experiment=study_mesh_3d", "output.plots=false"]
    assert run_name(compose_scene(plate), plate + kept) == \
        "geometry=rectangular_plate mass_kg=5000 velocity_m_s=1.0 cel3d einav_randolph"
    track = ["soil=sample_II", "soil.law=tresca", "landing.mass_kg=6500", "geometry.contact_length_m=5.2"]
    assert run_name(compose_scene(track), track) == "soil=sample_II mass_kg=6500 contact_length_m=5.2 cel2d tresca"
    assert run_name(compose_scene([]), []) == "cel2d einav_randolph"


def test_a_shortened_key_stays_whole_where_two_would_read_alike():
    assert short_overrides(["soil.params.x=1", "landing.x=2", "++soil.params.slope=0.05", "~mesh.y"]) == \
        ["soil.params.x=1", "landing.x=2", "slope=0.05", "~y"]


def test_a_sweep_is_named_by_what_it_varies():
    assert sweep_name("default_scene", ["landing.velocity_m_s=0.5,1.0", "soil.su0_pa=4000,6000",
                                        "hydra/launcher=joblib"], Path("/r/12-00-00")) == \
        "sweep velocity_m_s=0.5,1.0 su0_pa=4000,6000"
    assert sweep_name("study_strength", ["experiment=study_strength"], Path("/r/12-00-00")) == \
        "sweep study_strength 12-00-00"


def test_a_run_names_the_ui_command_that_opens_its_store():
    assert command_for(["landing.mass_kg=1", "paths.runs_dir=/data/my runs", "experiment=study_strength"]) == \
        ".venv/bin/dsmv ui 'paths.runs_dir=/data/my runs' experiment=study_strength"


def test_without_a_store_dsmv_ui_says_to_run_dsmv_first(tmp_path):
    proc = ui(tmp_path)
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and "run dsmv first" in proc.stderr, proc.stderr
    assert not (tmp_path / "runs").exists()  # nothing created


def test_a_port_in_use_is_one_line_and_exit_2(tmp_path):
    (tmp_path / "runs").mkdir()
    (tmp_path / "runs" / "mlflow.db").touch()
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        proc = ui(tmp_path, "--port", str(port))
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and f"--port = {port}" in proc.stderr and "in use" in proc.stderr, proc.stderr


def _process_group(pgid: int) -> list[int]:
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[2]) == pgid:  # (state, ppid, pgrp, …)
            found.append(int(stat.parent.name))
    return found


@pytest.mark.server  # an MLflow server process: 10 to 20 s
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="counts the server's processes in /proc")
def test_dsmv_ui_serves_the_store_on_loopback_with_two_processes_until_ctrl_c(tmp_path):
    from mlflow.tracking import MlflowClient

    from dsmv.app.ui import UserError, choose_experiment
    from dsmv.tracking.ui import free_port

    (tmp_path / "runs").mkdir()
    client = MlflowClient(f"sqlite:///{tmp_path / 'runs' / 'mlflow.db'}")
    experiment_id = client.create_experiment("dsmv-default_scene")
    client.create_run(experiment_id, run_name="cel2d einav_randolph")
    port = free_port()
    # as a terminal's foreground command: Ctrl-C at its default, whatever this process inherited (a shell
    # that runs the suite in the background ignores SIGINT, and its children would inherit that)
    proc = subprocess.Popen([str(BIN / "dsmv"), "ui", "--port", str(port)], cwd=tmp_path, text=True,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=dict(os.environ, NUMBA_NUM_THREADS="1"),
                           preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        url = next(line.strip() for line in proc.stdout if line.strip().startswith("http"))
        assert url == f"http://127.0.0.1:{port}/#/experiments/{experiment_id}/runs?workflowType=machine_learning"
        base = url.split("/#/")[0]
        with urllib.request.urlopen(f"{base}/api/2.0/mlflow/experiments/get?experiment_id={experiment_id}") as answer:
            assert answer.status == 200 and b"dsmv-default_scene" in answer.read()
        (server,) = [int(p) for p in Path(f"/proc/{proc.pid}/task/{proc.pid}/children").read_text().split()]
        assert 1 <= len(_process_group(server)) <= 2  # mlflow and one uvicorn worker, no job runner
        with pytest.raises(UserError, match="available: dsmv-default_scene"):
            choose_experiment(base, "nope", "default_scene")
        proc.send_signal(signal.SIGINT)  # Ctrl-C
        assert proc.wait(timeout=60) == 130
        deadline = time.monotonic() + 10
        while _process_group(server) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert not _process_group(server) and not port_in_use(port)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
