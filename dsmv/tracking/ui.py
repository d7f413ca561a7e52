"""The MLflow UI on the loopback address: the server with few processes (:func:`serve`) and the link that
opens an experiment's runs list in the classic view (:func:`runs_list_url`). ``dsmv ui``
(:mod:`dsmv.app.ui`), ``make mlflow-screenshots`` (:mod:`~dsmv.tracking.mlflow_check`) and the tests'
servers start it here. It imports nothing heavy: the server is a process of its own."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
import urllib.parse
import urllib.request
from contextlib import contextmanager
from pathlib import Path

LOOPBACK = "127.0.0.1"
#: the UI's own switch to its classic (machine-learning) view, as its links write it: MLflow 3 opens an
#: experiment in its GenAI view without it, whatever the experiment holds (the built UI reads
#: ``workflowType`` from the query of the hash route, and its own links to a runs list are
#: ``#/experiments/<id>/runs?workflowType=machine_learning``)
CLASSIC = {"workflowType": "machine_learning"}
CLASSIC_QUERY = urllib.parse.urlencode(CLASSIC)
#: the server's environment: no job runner beside it (with it, and with the default workers, MLflow 3
#: starts about 15 processes and takes about 3 GB; with one worker and none, two processes)
SERVER_ENV = {"MLFLOW_SERVER_ENABLE_JOB_EXECUTION": "false"}
#: how long a server may take to answer: a fresh virtualenv compiles the server's modules on first start
START_TIMEOUT_S = 240.0


class ServerError(RuntimeError):
    """The MLflow server stopped before it answered, or did not answer in time."""


def runs_list_url(base: str, experiment_id: str, **query: str) -> str:
    """The link that opens an experiment's runs list in MLflow 3's classic view, with more of the UI's
    query parameters (``searchFilter``, ``orderByKey`` …) when given."""
    params = urllib.parse.urlencode(CLASSIC | query, quote_via=urllib.parse.quote)
    return f"{base}/#/experiments/{experiment_id}/runs?{params}"


def free_port() -> int:
    """A port nothing listens on at the loopback address now."""
    with socket.socket() as s:
        s.bind((LOOPBACK, 0))
        return s.getsockname()[1]


def port_in_use(port: int) -> bool:
    """Whether a server cannot listen on ``port`` at the loopback address (something listens on it). Bound as
    the server binds it, with SO_REUSEADDR: the connections a stopped server leaves waiting do not count."""
    with socket.socket() as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((LOOPBACK, port))
        except OSError:
            return True
    return False


def wait_for(url: str, timeout_s: float, process: subprocess.Popen | None = None) -> None:
    """Return once ``url`` answers; :class:`ServerError` if ``process`` ends first or time runs out."""
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            urllib.request.urlopen(url, timeout=2).read()
            return
        except OSError:
            if process is not None and process.poll() is not None:
                raise ServerError(f"the server stopped with exit code {process.returncode}") from None
            if time.monotonic() > deadline:
                raise ServerError(f"{url} did not answer within {timeout_s:.0f} s") from None
            time.sleep(0.5)


def server_command(backend_uri: str, port: int, artifacts: str | Path | None, workers: int = 1) -> list[str]:
    """``mlflow server`` on the loopback address over ``backend_uri``; the artifacts it is sent go to
    ``artifacts`` (None: MLflow's default, ``./mlartifacts``)."""
    command = [sys.executable, "-m", "mlflow", "server", "--host", LOOPBACK, "--port", str(port), "--workers",
               str(workers), "--backend-store-uri", backend_uri]
    return command + (["--artifacts-destination", str(artifacts)] if artifacts is not None else [])


def stop(process: subprocess.Popen, timeout_s: float = 30.0) -> None:
    """Stop a server :func:`serve` started, with the processes it started (its own process group)."""
    for sig in (signal.SIGTERM, signal.SIGKILL):
        try:
            os.killpg(process.pid, sig)
        except ProcessLookupError:
            return
        try:
            process.wait(timeout=timeout_s)
            return
        except subprocess.TimeoutExpired:
            continue


@contextmanager
def serve(backend_uri: str, port: int, artifacts: str | Path | None, workers: int = 1, log=subprocess.DEVNULL,
          cwd: str | Path | None = None, timeout_s: float = START_TIMEOUT_S):
    """An MLflow server (UI and REST API) on ``127.0.0.1:port`` over ``backend_uri``; yields its base URL
    and its process once it answers, and stops it at the end, whatever ends the block (Ctrl-C included). The server runs
    in a process group of its own: a Ctrl-C at the terminal reaches the caller, which stops it."""
    process = subprocess.Popen(server_command(backend_uri, port, artifacts, workers), env=os.environ | SERVER_ENV,
                               cwd=cwd, stdin=subprocess.DEVNULL, stdout=log, stderr=log, start_new_session=True)
    base = f"http://{LOOPBACK}:{port}"
    try:
        wait_for(f"{base}/health", timeout_s, process)
        yield base, process
    finally:
        stop(process)
