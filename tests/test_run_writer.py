"""The MLflow writer process (dsmv.tracking.run_writer): runs opened and closed through it arrive in the store,
a sweep's writer serves other connections over its socket and parents their runs, errors come back
as WriterError, and the writer's log records land in the asking process's logging."""

from __future__ import annotations

import json
import logging
from multiprocessing.connection import Client

import pytest

from dsmv.tracking import run_writer
from dsmv.tracking.run_writer import SOCKET_FILE, Writer, WriterError


@pytest.fixture
def store(tmp_path):
    return f"sqlite:///{tmp_path / 'mlflow.db'}"


def _runs(uri: str) -> dict:
    from mlflow.tracking import MlflowClient

    client = MlflowClient(uri)
    ids = [e.experiment_id for e in client.search_experiments()]
    return {r.info.run_name: r for r in client.search_runs(ids)}


def test_a_sweeps_writer_parents_the_runs_its_jobs_hand_it_over_the_socket(tmp_path, store, caplog):
    sweep_dir = tmp_path / "sweep"
    sweep_dir.mkdir()
    own = run_writer.serve_sweep(sweep_dir)
    parent_file = sweep_dir / "parent.json"
    parent = own.ask("open", store, None, "dsmv-test", "the sweep", {"sweep.overrides": "x=1,2"}, {}, None,
                     str(parent_file))
    # a job in another process connects through the socket the sweep dir names
    where = json.loads((sweep_dir / SOCKET_FILE).read_text())
    job = Writer(Client(where["socket"], family="AF_UNIX"))
    opened = job.ask("open", store, None, "dsmv-test", "a job", {"x": "1"}, {"dsmv.status": "running"},
                     str(parent_file))
    job_run = job.answer(opened)
    parent_run = own.answer(parent)
    assert json.loads(parent_file.read_text())["run_id"] == parent_run
    with caplog.at_level(logging.INFO):
        job.answer(job.ask("finish", store, job_run, [("max_sinkage_m", 0.1, 0, 0)], {"status": "ok"},
                           {"dsmv.status": "ok"}, [], "FINISHED"))
        own.answer(own.ask("finish", store, parent_run, [("jobs_total", 1.0, 0, 0)], {}, {}, [], "FINISHED"))

    runs = _runs(store)
    child, sweep = runs["a job"], runs["the sweep"]
    assert child.data.tags["mlflow.parentRunId"] == sweep.info.run_id
    assert child.info.status == sweep.info.status == "FINISHED"
    assert child.data.metrics == {"max_sinkage_m": 0.1} and child.data.params == {"x": "1", "status": "ok"}
    assert sweep.data.params == {"sweep.overrides": "x=1,2"} and sweep.data.metrics == {"jobs_total": 1.0}


def test_a_store_that_cannot_be_written_is_a_writer_error(tmp_path):
    (tmp_path / "afile").write_text("")
    writer = Writer.start()
    opened = writer.ask("open", f"sqlite:///{tmp_path / 'afile' / 'mlflow.db'}", None, "dsmv-test", "a run", {}, {})
    with pytest.raises(WriterError):
        writer.answer(opened)
    assert writer.alive  # one failed request leaves the writer serving


def test_a_run_the_store_could_not_open_fails_at_once_each_time_and_closes_without_waiting(tmp_path):
    """The open's failure is the job's answer to every later question about its run: finishing raises it,
    asking for the run's id again raises it at once (its answer was taken: waiting again would hang the
    job for ever), and closing the run is a no-op. The writer goes on serving."""
    from dsmv.config.scene import TrackingConfig
    from dsmv.results import SolveResult
    from dsmv.tracking.runs import JobTracker

    (tmp_path / "afile").write_text("")
    tracking = TrackingConfig(enabled=True, uri=f"sqlite:///{tmp_path / 'afile' / 'mlflow.db'}")
    tracker = JobTracker(tracking, "test", "a run", {}, {}, tmp_path)
    with pytest.raises(WriterError):
        tracker.finish(SolveResult("ok", "done"), [])
    with pytest.raises(WriterError):
        tracker.run_id
    tracker.terminate("FAILED")
    with pytest.raises(ValueError, match="already taken"):
        tracker.writer.answer(tracker._opened)
    assert tracker.writer.alive


def test_a_file_jobs_poll_for_is_never_seen_half_written(tmp_path):
    """The sweep's parent-run and socket files are polled for by jobs (exists, then read): written with
    write_atomically, a reader never finds one empty or cut short, however often it is rewritten."""
    import threading

    path, seen, torn, stop = tmp_path / "parent.json", [], [], threading.Event()

    def poll():
        while not stop.is_set():
            if path.exists():
                try:
                    seen.append(json.loads(path.read_text())["run_id"])
                except FileNotFoundError:  # removed between the two calls: not a torn read
                    pass
                except ValueError as error:  # empty or cut short (json.JSONDecodeError)
                    torn.append(error)

    reader = threading.Thread(target=poll)
    reader.start()
    try:
        for k in range(3000):
            run_writer.write_atomically(path, json.dumps({"run_id": "x" * 200 + str(k)}))
            if k % 2:
                path.unlink()
    finally:
        stop.set()
        reader.join()
    assert not torn and seen and all(value.startswith("x" * 200) for value in seen)
    assert [p.name for p in tmp_path.iterdir()] in ([], ["parent.json"])


OPEN_AT_THE_SIGNAL = """
import sys, time
from pathlib import Path
import mlflow.store.tracking.sqlalchemy_store, mlflow.tracking  # the slow imports before the start line
from dsmv.tracking.run_writer import open_client
ready, go = Path(sys.argv[1]), Path(sys.argv[2])
ready.touch()
while not go.exists():
    time.sleep(0.001)
print(len(open_client(sys.argv[3]).search_experiments()))
"""


def test_processes_opening_one_new_store_at_once_all_open_it(tmp_path):
    """A sweep's writer and its sweeper (or two jobs) may open a new SQLite store at the same instant:
    each would create its tables and run MLflow's migrations, and all but one failed ("Online
    migration expected to match one row"; 24 of 32 such openings without the lock). Opened through
    open_client, every one opens it."""
    import subprocess
    import sys
    import time

    uri, go = f"sqlite:///{tmp_path / 'mlflow.db'}", tmp_path / "go"
    openers = [subprocess.Popen([sys.executable, "-c", OPEN_AT_THE_SIGNAL, str(tmp_path / f"ready{k}"), str(go), uri],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for k in range(4)]
    deadline = time.monotonic() + 120
    while not all((tmp_path / f"ready{k}").exists() for k in range(4)) and time.monotonic() < deadline:
        time.sleep(0.05)
    go.touch()
    outcomes = [opener.communicate(timeout=120) for opener in openers]
    assert [opener.returncode for opener in openers] == [0] * 4, [err[-500:] for _, err in outcomes]
    assert [out.strip() for out, _ in outcomes] == ["1"] * 4  # MLflow's Default experiment, once
