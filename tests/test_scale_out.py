"""Sweeps beyond one process into a shared tracking server on a real database, and on a local Ray
cluster (``-m server``).

The test starts a PostgreSQL server (the system's ``initdb`` and ``pg_ctl``; as the ``postgres``
user when run as root, which ``initdb`` refuses) and an MLflow server whose backend store is that
database, both on loopback, and stops them at the end. Eight jobs run at once in worker processes
(``hydra/launcher=dsmv_local``) and log to the server: every run and every metric must arrive.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import pytest

from dsmv.tracking.ui import free_port
from tests.conftest import mlflow_runs, mlflow_server

pytestmark = pytest.mark.server

#: eight jobs at once: two workers' worth of four rounds, all writing to the server together
MASSES_KG = (4000, 4500, 5000, 5500)
SU0_PA = (4000, 6000)


def _as_postgres(*command: str) -> list[str]:
    """``initdb`` and the server refuse to run as root: run them as the ``postgres`` user then."""
    return ["runuser", "-u", "postgres", "--", *command] if os.geteuid() == 0 else list(command)


@pytest.fixture
def postgres():
    """A PostgreSQL server on a free loopback port with an empty database ``mlflow``; its URI."""
    missing = [tool for tool in ("initdb", "pg_ctl", "psql") if shutil.which(tool) is None]
    if missing:
        pytest.fail(f"PostgreSQL's {', '.join(missing)} not found: install PostgreSQL (.ci/run does)")
    folder = Path(tempfile.mkdtemp(prefix="dsmv-pg-"))
    if os.geteuid() == 0:
        shutil.chown(folder, "postgres", "postgres")
    data, port = folder / "data", free_port()
    subprocess.run(_as_postgres("initdb", "-D", str(data), "-A", "trust", "-U", "postgres"), check=True,
                   capture_output=True)
    options = f"-p {port} -k {folder} -c listen_addresses=127.0.0.1"
    subprocess.run(_as_postgres("pg_ctl", "-D", str(data), "-o", options, "-l", str(folder / "log"), "-w", "start"),
                   check=True, capture_output=True)
    try:
        subprocess.run(["psql", "-h", "127.0.0.1", "-p", str(port), "-U", "postgres", "-c", "create database mlflow"],
                       check=True, capture_output=True)
        yield f"postgresql+psycopg2://postgres@127.0.0.1:{port}/mlflow"  # the driver of dsmv[server]
    finally:
        subprocess.run(_as_postgres("pg_ctl", "-D", str(data), "-m", "fast", "-w", "stop"), capture_output=True)
        shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture
def server_on_postgres(postgres, tmp_path):
    """An MLflow server whose backend store is the database; its URI."""
    with mlflow_server(postgres, tmp_path, workers=2) as uri:
        yield uri


def test_eight_worker_processes_log_every_run_and_metric_to_a_server_on_postgresql(run_cli, server_on_postgres):
    from mlflow.tracking import MlflowClient

    masses, su0s = ",".join(map(str, MASSES_KG)), ",".join(map(str, SU0_PA))
    proc = run_cli("dsmv", "-m", "hydra/launcher=dsmv_local", f"landing.mass_kg={masses}", f"soil.su0_pa={su0s}",
                   "mesh=coarse", "tracking=server", f"tracking.uri={server_on_postgres}", timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "sweep done: 8 ok" in proc.stdout

    client = MlflowClient(server_on_postgres)
    (experiment,) = [e for e in client.search_experiments() if e.name == "dsmv-default_scene"]
    runs = client.search_runs([experiment.experiment_id], max_results=100)
    (parent,) = [r for r in runs if r.data.tags.get("dsmv.role") == "sweep"]
    children = [r for r in runs if r.data.tags.get("mlflow.parentRunId") == parent.info.run_id]
    assert len(runs) == 9 and len(children) == 8
    assert all(r.info.status == "FINISHED" and r.data.tags["dsmv.status"] == "ok" for r in children)
    assert parent.info.status == "FINISHED" and parent.data.metrics["jobs_ok"] == 8
    got = sorted((float(r.data.params["landing.mass_kg"]), float(r.data.params["soil.su0_pa"])) for r in children)
    assert got == sorted((float(m), float(s)) for m in MASSES_KG for s in SU0_PA)
    metric_counts = {len(r.data.metrics) for r in children}
    assert len(metric_counts) == 1 and "max_sinkage_m" in children[0].data.metrics  # no job lost a metric
    for run in children:
        history = client.get_metric_history(run.info.run_id, "history.sinkage_m")
        assert len(history) > 10
        assert {"result.json", "history.csv"} <= {a.path for a in client.list_artifacts(run.info.run_id)}


def test_a_sweep_runs_on_a_local_ray_cluster(run_cli, tmp_path):
    """hydra/launcher=ray (pip install dsmv[ray]) starts a local Ray cluster of two cpus; each job is a
    Ray task with one Numba thread, tracked like any other job."""
    pytest.importorskip("hydra_plugins.hydra_ray_launcher", reason="hydra/launcher=ray needs pip install dsmv[ray]")

    proc = run_cli("dsmv", "-m", "hydra/launcher=ray", "+hydra.launcher.ray.init.num_cpus=2",
                   "landing.velocity_m_s=1.0,1.5", "mesh=coarse", "output.plots=false", timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "sweep done: 2 ok" in proc.stdout
    runs = mlflow_runs(tmp_path)
    children = [r for r in runs if "mlflow.parentRunId" in r.data.tags]
    assert len(runs) == 3 and len(children) == 2
    assert all(r.info.status == "FINISHED" and r.data.tags["dsmv.status"] == "ok" for r in children)
    assert sorted(float(r.data.params["landing.velocity_m_s"]) for r in children) == [1.0, 1.5]
