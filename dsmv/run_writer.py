"""The process that writes jobs' MLflow runs.

Importing MLflow and opening its store cost about 4 s of CPU, more than a standard-mesh solve. A
job hands its run to a writer process started before the solve, which does that work on the other
core while the job computes; a sweep's worker process keeps its writer for all its jobs, so MLflow
is imported once per worker. The job waits only for what it needs: the run's id, and the end of
its last write. Requests and answers are plain tuples over a pipe, and the writer's log records
travel back with the answers into the job's log. The writer ignores SIGINT and SIGTERM (the job
that owns it decides how a run ends) and exits when the job's end of the pipe closes.

This module also holds what both sides need of the store: :func:`resolve_uri`, :func:`open_client`,
:func:`experiment_id`. It imports nothing heavy at module level.
"""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
from multiprocessing.connection import Connection
from pathlib import Path

#: MLflow 3's UI opens an experiment by its kind: without it, an experiment of plain runs opens on
#: the GenAI overview (traces), and a newcomer sees no runs
EXPERIMENT_KIND = {"mlflow.experimentKind": "custom_model_development"}
#: MLflow's batch limits: params and tags per call, metrics per call
PARAMS_PER_BATCH, METRICS_PER_BATCH = 100, 1000


def resolve_uri(uri: str) -> str:
    """Make a relative ``sqlite:///`` store absolute, so every process and the UI agree."""
    prefix = "sqlite:///"
    if uri.startswith(prefix) and not uri.startswith(prefix + "/"):
        path = Path(uri[len(prefix) :]).resolve()
        path.parent.mkdir(parents=True, exist_ok=True)
        return prefix + str(path)
    return uri


def open_client(uri: str):
    from mlflow.tracking import MlflowClient

    return MlflowClient(tracking_uri=resolve_uri(uri))


def experiment_description(name: str) -> str:
    """What an experiment holds, in the words the MLflow UI shows under its name."""
    return (f"{name}: one run per dsmv job. Params: the resolved config (dotted keys); metrics: the result "
            f"contract, SI units in the names; tag dsmv.status: ok, bearing_failure, out_of_domain, unstable, "
            f"failed or interrupted. The history.* curves are logged with step = simulated time in "
            f"microseconds. Surrogate runs carry dsmv.role = surrogate.")


def experiment_id(client, name: str, artifact_location: str | None) -> str:
    """The experiment's id, created (with its kind and description) if it does not exist yet."""
    found = client.get_experiment_by_name(name)
    if found is not None:
        return found.experiment_id
    location = None
    if artifact_location:
        location = Path(artifact_location).resolve().as_uri() if "://" not in artifact_location else artifact_location
    tags = EXPERIMENT_KIND | {"mlflow.note.content": experiment_description(name)}
    try:
        return client.create_experiment(name, artifact_location=location, tags=tags)
    except Exception:  # created meanwhile by a parallel job
        found = client.get_experiment_by_name(name)
        if found is None:
            raise
        return found.experiment_id


def _chunks(items: list, size: int):
    for start in range(0, len(items), size):
        yield items[start : start + size]


# ---- the writer's side: one function per request --------------------------------------------------

def _open(clients: dict, uri: str, artifact_location: str | None, experiment: str, run_name: str,
          params: dict[str, str], tags: dict[str, str]) -> str:
    from mlflow.entities import Param

    client = clients.get(uri) or clients.setdefault(uri, open_client(uri))
    run_id = client.create_run(experiment_id(client, experiment, artifact_location), tags=tags,
                               run_name=run_name).info.run_id
    for chunk in _chunks([Param(k, v) for k, v in params.items()], PARAMS_PER_BATCH):
        client.log_batch(run_id, params=chunk)
    return run_id


def _finish(clients: dict, uri: str, run_id: str, metrics: list[tuple], params: dict[str, str],
            tags: dict[str, str], files: list[str], end_status: str) -> None:
    from mlflow.entities import Metric, Param, RunTag

    client = clients[uri]
    for chunk in _chunks([Metric(*m) for m in metrics], METRICS_PER_BATCH):
        client.log_batch(run_id, metrics=chunk)
    client.log_batch(run_id, params=[Param(k, v) for k, v in params.items()],
                     tags=[RunTag(k, v) for k, v in tags.items()])
    for path in files:
        client.log_artifact(run_id, path)
    client.set_terminated(run_id, end_status)


def _terminate(clients: dict, uri: str, run_id: str, end_status: str) -> None:
    clients[uri].set_terminated(run_id, end_status)


REQUESTS = {"open": _open, "finish": _finish, "terminate": _terminate}


class _Collector(logging.Handler):
    """The writer's log records (MLflow's, alembic's, Python warnings), kept to travel with the next
    answer: the job logs them where its own messages go (dsmv.joblog), not the writer's console."""

    def __init__(self):
        super().__init__(logging.INFO)
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        record.msg, record.args = record.getMessage(), None  # picklable whatever its arguments were
        if record.exc_info:
            record.exc_text, record.exc_info = logging.Formatter().formatException(record.exc_info), None
        self.records.append(record)

    def take(self) -> list[logging.LogRecord]:
        taken, self.records = self.records, []
        return taken


def serve(conn: "_Duplex", collector: _Collector, broken: str | None = None) -> None:
    """Answer requests until the job's end of the pipe closes: ``("ok", value, records)`` or
    ``("error", text, records)``; ``broken`` (MLflow could not be imported) answers every request."""
    clients: dict = {}
    while True:
        try:
            kind, args = conn.recv()
        except (EOFError, OSError):
            return
        try:
            if broken:
                raise WriterError(broken)
            answer = ("ok", REQUESTS[kind](clients, *args))
        except Exception as error:  # the job raises it where it asks for the answer
            answer = ("error", f"{type(error).__name__}: {error}")
        conn.send((*answer, collector.take()))


def main() -> None:
    """The writer process: its requests come on file descriptor argv[1], its answers go to argv[2].
    MLflow and its database store are imported at once, while the job composes its scene and solves."""
    conn = _Duplex(int(sys.argv[1]), int(sys.argv[2]))
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    collector = _Collector()
    logging.getLogger().addHandler(collector)
    logging.getLogger().setLevel(logging.INFO)
    logging.captureWarnings(True)
    broken = None
    try:
        import mlflow.tracking  # noqa: F401
        try:
            import mlflow.store.tracking.sqlalchemy_store  # noqa: F401  (SQLite and PostgreSQL stores)
        except ImportError:  # a store behind a server needs none
            pass
    except Exception as error:
        broken = f"MLflow cannot be imported: {type(error).__name__}: {error}"
    serve(conn, collector, broken)


# ---- the job's side --------------------------------------------------------------------------------

class _Duplex:
    """One reading and one writing pipe end as a connection (recv/send of picklable objects)."""

    def __init__(self, read_fd: int, write_fd: int):
        self.reader = Connection(read_fd, writable=False)
        self.writer = Connection(write_fd, readable=False)

    def recv(self):
        return self.reader.recv()

    def send(self, obj) -> None:
        self.writer.send(obj)

    def close(self) -> None:
        self.reader.close()
        self.writer.close()


class WriterError(RuntimeError):
    """The writer could not do what a job asked (the store is unreachable, a write failed)."""


class Writer:
    """A writer process and the answers it owes, in the order they were asked."""

    def __init__(self):
        to_writer_r, to_writer_w = os.pipe()
        from_writer_r, from_writer_w = os.pipe()
        code = "from dsmv.run_writer import main; main()"
        self.process = subprocess.Popen([sys.executable, "-c", code, str(to_writer_r), str(from_writer_w)],
                                        pass_fds=(to_writer_r, from_writer_w), stdin=subprocess.DEVNULL,
                                        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        os.close(to_writer_r)
        os.close(from_writer_w)
        self.conn = _Duplex(from_writer_r, to_writer_w)
        self.asked = 0      # requests sent
        self.answered = 0   # answers read
        self.answers: dict[int, tuple] = {}

    @property
    def alive(self) -> bool:
        return self.process.poll() is None

    def ask(self, kind: str, *args) -> int:
        """Send a request; returns its ticket for :meth:`answer`."""
        self.conn.send((kind, args))
        self.asked += 1
        return self.asked

    def answer(self, ticket: int):
        """The answer to a request (waits for it); raises :class:`WriterError` if it failed."""
        while ticket not in self.answers:
            try:
                self.answers[self.answered + 1] = self.conn.recv()
            except EOFError:
                raise WriterError(f"the MLflow writer process ended (exit code {self.process.poll()})") from None
            self.answered += 1
        status, value, records = self.answers.pop(ticket)
        for record in records:  # into the job's log, as if logged here
            logging.getLogger(record.name).handle(record)
        if status == "error":
            raise WriterError(value)
        return value


_writer: Writer | None = None


def writer() -> Writer:
    """This process's writer, started on first use (and again if it died)."""
    global _writer
    if _writer is None or not _writer.alive:
        _writer = Writer()
    return _writer
