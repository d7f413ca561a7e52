"""Shared fixtures: compose configs in-process, run the CLI in a scratch folder."""

from __future__ import annotations

import os
import subprocess
import sys
from contextlib import contextmanager
from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra

from dsmv.config.tree import CONFIG_DIR

BIN = Path(sys.executable).parent
CONF = Path(CONFIG_DIR)


def group_options(group: str) -> list[str]:
    """Every option (YAML file) of a config group."""
    return sorted(p.stem for p in (CONF / group).glob("*.yaml"))


@pytest.fixture
def compose_cfg():
    """compose_cfg(overrides) -> DictConfig, composed from conf/ like the CLI does."""

    def _compose(overrides=(), return_hydra_config=False):
        GlobalHydra.instance().clear()
        with initialize_config_dir(config_dir=CONFIG_DIR, version_base="1.3"):
            return compose("config", overrides=list(overrides), return_hydra_config=return_hydra_config)

    yield _compose
    GlobalHydra.instance().clear()


@pytest.fixture
def run_cli(tmp_path):
    """run_cli("dsmv", *args) runs a console script in tmp_path (its runs/ lands there)."""

    def _run(program: str, *args: str, timeout: float = 300) -> subprocess.CompletedProcess:
        env = dict(os.environ, NUMBA_NUM_THREADS="1", HYDRA_FULL_ERROR="0")
        return subprocess.run(
            [str(BIN / program), *args], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=timeout
        )

    return _run


def mlflow_runs(store_dir: Path):
    """All MLflow runs of every experiment in the local store under ``store_dir``."""
    from mlflow.tracking import MlflowClient

    client = MlflowClient(f"sqlite:///{(store_dir / 'runs' / 'mlflow.db').resolve()}")
    ids = [e.experiment_id for e in client.search_experiments()]
    return client.search_runs(ids, max_results=1000)


@pytest.fixture
def install_plugin(tmp_path, monkeypatch):
    """install_plugin(module, source, group, name, target): a one-module package registered by entry point.

    It goes into a folder on PYTHONPATH for the CLI subprocesses, with its dist-info, exactly as
    `pip install` would leave a third-party plugin.
    """
    site = tmp_path / "site"

    def _install(module: str, source: str, group: str, name: str, target: str) -> None:
        dist = site / f"{module}-0.1.dist-info"
        dist.mkdir(parents=True)
        (site / f"{module}.py").write_text(source)
        (dist / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {module.replace('_', '-')}\nVersion: 0.1\n")
        (dist / "entry_points.txt").write_text(f"[{group}]\n{name} = {module}:{target}\n")
        monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(site), os.environ.get("PYTHONPATH", "")]))

    return _install


@contextmanager
def mlflow_server(backend_uri: str, folder: Path, workers: int = 1):
    """An MLflow server on a free loopback port over ``backend_uri``, its artifacts in ``folder``; yields its
    URI once it answers, stops it at the end (:func:`dsmv.tracking.ui.serve`). A fresh virtualenv compiles
    the server's modules on first start: it gets 240 s."""
    from dsmv.tracking.ui import ServerError, free_port, serve

    with (folder / "server.log").open("w") as log:
        try:
            with serve(backend_uri, free_port(), folder / "server_artifacts", workers, log=log, cwd=folder) as (uri, _):
                yield uri
        except ServerError as error:
            pytest.fail(f"the MLflow server did not start: {error}: " + (folder / "server.log").read_text()[-2000:])
