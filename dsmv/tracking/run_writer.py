"""The process that writes jobs' MLflow runs.

Importing MLflow and opening its store cost about 4 s of CPU, more than a standard-mesh solve. A
job hands its run to a writer process, which does that work on the other core while the job
computes. The job waits only for what it needs: the run's id, and the end of its last write.

One writer serves a whole sweep on one machine: the sweep's main process starts it, and it listens
on a Unix socket named in the sweep dir (:data:`SOCKET_FILE`), so that jobs in worker processes
(joblib, submitit, Ray on this host) hand their runs to it instead of importing MLflow each. A job
that cannot reach it (another host, a plain ``dsmv`` run) starts its own. The sweep's parent run is
opened by the writer too; a job's run takes the parent's id when the writer opens it, without the
job waiting for it.

Requests and answers are plain tuples over a connection, and the writer's log records travel back
with the answers into the job's log. The writer ignores SIGINT and SIGTERM (the process that owns
it decides how a run ends) and exits when its owner's end of the pipe closes.

This module also holds what both sides need of the store: :func:`resolve_uri`, :func:`open_client`,
:func:`experiment_id`. It imports nothing heavy at module level.
"""

from __future__ import annotations

import fcntl
import json
import logging
import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from contextlib import contextmanager
from multiprocessing.connection import Connection
from pathlib import Path

#: MLflow 3's UI opens an experiment by its kind: without it, an experiment of plain runs opens on
#: the GenAI overview (traces), and a newcomer sees no runs
EXPERIMENT_KIND = {"mlflow.experimentKind": "custom_model_development"}
#: MLflow's batch limits: params and tags per call, metrics per call
PARAMS_PER_BATCH, METRICS_PER_BATCH = 100, 1000
#: in a sweep dir: where the sweep's writer listens ({"socket": path, "host": name})
SOCKET_FILE = "mlflow_writer.json"
#: how long a job's run waits for its sweep's parent run to exist before it opens without it (s)
PARENT_WAIT_S = 300.0


def resolve_uri(uri: str) -> str:
    """Make a relative ``sqlite:///`` store absolute, so every process and the UI agree."""
    prefix = "sqlite:///"
    if uri.startswith(prefix) and not uri.startswith(prefix + "/"):
        path = Path(uri[len(prefix) :]).resolve()
        path.parent.mkdir(parents=True, exist_ok=True)
        return prefix + str(path)
    return uri


def store_missing(uri: str) -> bool:
    """A ``sqlite:///`` store whose file does not exist yet (opening it would create it)."""
    prefix = "sqlite:///"
    return uri.startswith(prefix) and not Path(uri[len(prefix):]).exists()


def artifact_uri(artifact_location: str) -> str:
    """An artifact location as a URI: a folder (``runs/mlartifacts``) as an absolute ``file://`` URI."""
    return artifact_location if "://" in artifact_location else Path(artifact_location).resolve().as_uri()


def open_client(uri: str):
    """A client of the store, the store created or upgraded first if need be (one process at a time)."""
    from mlflow.tracking import MlflowClient

    uri = resolve_uri(uri)
    with _schema_lock(uri):
        return MlflowClient(tracking_uri=uri)  # (the client opens its store, migrating it if it must)


@contextmanager
def _schema_lock(uri: str):
    """Hold an exclusive lock on ``<store>.lock`` beside a SQLite store while it is opened. MLflow
    creates a new store's tables and then runs its schema migrations; two processes opening one new
    store at once (a sweep's writer and its sweeper reading the study) both migrate, and one fails
    ("Online migration expected to match one row"). Other stores need no lock."""
    prefix = "sqlite:///"
    if not uri.startswith(prefix):
        yield
        return
    path = Path(uri[len(prefix):])
    path.parent.mkdir(parents=True, exist_ok=True)  # (as MLflow would for the store itself)
    with open(path.with_name(path.name + ".lock"), "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


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
    location = artifact_uri(artifact_location) if artifact_location else None
    tags = EXPERIMENT_KIND | {"mlflow.note.content": experiment_description(name)}
    try:
        return client.create_experiment(name, artifact_location=location, tags=tags)
    except Exception:  # created meanwhile by a parallel job
        found = client.get_experiment_by_name(name)
        if found is None:
            raise
        return found.experiment_id


def write_atomically(path: Path, text: str) -> None:
    """Write a file others poll for: whole or not there (a reader that sees it half-written would fail)."""
    path = Path(path)
    partial = path.with_name(f".{path.name}.{os.getpid()}.partial")
    try:
        partial.write_text(text)
        os.replace(partial, path)
    finally:
        partial.unlink(missing_ok=True)  # gone once replaced; a failed write leaves nothing behind


def _chunks(items: list, size: int):
    for start in range(0, len(items), size):
        yield items[start : start + size]


class _Duplex:
    """One reading and one writing pipe end as a connection (recv/send of picklable objects)."""

    def __init__(self, read_fd: int, write_fd: int):
        self.reader = Connection(read_fd, writable=False)
        self.writer = Connection(write_fd, readable=False)

    def recv(self):
        return self.reader.recv()

    def send(self, obj) -> None:
        self.writer.send(obj)


class WriterError(RuntimeError):
    """The writer could not do what a job asked (the store is unreachable, a write failed)."""


# ---- the writer's side: one function per request --------------------------------------------------

class _Clients:
    """One MlflowClient per store URI, shared by the writer's connections."""

    def __init__(self):
        self._clients: dict = {}
        self._lock = threading.Lock()

    def __getitem__(self, uri: str):
        with self._lock:
            if uri not in self._clients:
                self._clients[uri] = open_client(uri)
            return self._clients[uri]


def _parent_id(parent_file: str | None) -> str | None:
    """The sweep's parent run id from its file, once the sweep's writer has written it."""
    if parent_file is None:
        return None
    path, deadline = Path(parent_file), time.monotonic() + PARENT_WAIT_S
    while not path.exists():
        if time.monotonic() > deadline:
            logging.getLogger("dsmv.tracking.run_writer").warning("no parent run in %s: the job's run is opened without it",
                                                          path.parent)
            return None
        time.sleep(0.05)
    return json.loads(path.read_text())["run_id"]


def _open(clients: _Clients, uri: str, artifact_location: str | None, experiment: str, run_name: str,
          params: dict[str, str], tags: dict[str, str], parent_file: str | None = None,
          write_to: str | None = None) -> str:
    """Create a run and log its params; ``parent_file``: tag it with the sweep's parent run (waiting for
    it); ``write_to``: write its id there (the parent run of a sweep, for its jobs)."""
    from mlflow.entities import Param

    parent = _parent_id(parent_file)  # first: the sweep's parent run sets the store up (its log is the sweep's)
    client = clients[uri]
    if parent is not None:
        tags = tags | {"mlflow.parentRunId": parent}
    run_id = client.create_run(experiment_id(client, experiment, artifact_location), tags=tags,
                               run_name=run_name).info.run_id
    if write_to is not None:
        write_atomically(Path(write_to), json.dumps({"run_id": run_id, "uri": client.tracking_uri}))
    for chunk in _chunks([Param(k, v) for k, v in params.items()], PARAMS_PER_BATCH):
        client.log_batch(run_id, params=chunk)
    return run_id


def _finish(clients: _Clients, uri: str, run_id: str, metrics: list[tuple], params: dict[str, str],
            tags: dict[str, str], files: list[str], end_status: str) -> None:
    from mlflow.entities import Metric, Param, RunTag

    client = clients[uri]
    for chunk in _chunks([Metric(*m) for m in metrics], METRICS_PER_BATCH):
        client.log_batch(run_id, metrics=chunk)
    if params or tags:
        client.log_batch(run_id, params=[Param(k, v) for k, v in params.items()],
                         tags=[RunTag(k, v) for k, v in tags.items()])
    for path in files:
        client.log_artifact(run_id, path)
    client.set_terminated(run_id, end_status)


def _terminate(clients: _Clients, uri: str, run_id: str, end_status: str) -> None:
    clients[uri].set_terminated(run_id, end_status)


REQUESTS = {"open": _open, "finish": _finish, "terminate": _terminate}


class _Collector(logging.Handler):
    """The writer's log records (MLflow's, alembic's, Python warnings), kept per serving thread to
    travel with that connection's next answer: the job logs them where its own messages go
    (dsmv.app.joblog), not on the writer's console."""

    def __init__(self):
        super().__init__(logging.INFO)
        self.local = threading.local()

    def emit(self, record: logging.LogRecord) -> None:
        record.msg, record.args = record.getMessage(), None  # picklable whatever its arguments were
        if record.exc_info:
            record.exc_text, record.exc_info = logging.Formatter().formatException(record.exc_info), None
        self._records().append(record)

    def _records(self) -> list:
        if not hasattr(self.local, "records"):
            self.local.records = []
        return self.local.records

    def take(self) -> list[logging.LogRecord]:
        taken, self.local.records = self._records(), []
        return taken


class _Service:
    """What the writer holds: its clients, its log collector, and whether MLflow could be imported."""

    def __init__(self):
        self.clients = _Clients()
        self.collector = _Collector()
        self.broken: str | None = None
        self.listener = None
        self.imported = threading.Event()

    def import_mlflow(self) -> None:
        """MLflow and its database store, in a thread: the writer listens and takes requests meanwhile."""
        try:
            import mlflow.tracking  # noqa: F401
            try:
                import mlflow.store.tracking.sqlalchemy_store  # noqa: F401  (SQLite and PostgreSQL stores)
            except ImportError:  # a store behind a server needs none
                pass
        except Exception as error:
            self.broken = f"MLflow cannot be imported: {type(error).__name__}: {error}"
        finally:
            self.imported.set()

    def serve(self, conn) -> None:
        """Answer one connection's requests until it closes: ``(status, value, records)``."""
        while True:
            try:
                kind, args = conn.recv()
            except (EOFError, OSError):
                return
            try:
                if kind == "listen":
                    value = self.listen(*args)
                else:
                    self.imported.wait()
                    if self.broken:
                        raise WriterError(self.broken)
                    value = REQUESTS[kind](self.clients, *args)
                answer = ("ok", value)
            except Exception as error:  # the job raises it where it asks for the answer
                answer = ("error", f"{type(error).__name__}: {error}")
            try:
                conn.send((*answer, self.collector.take()))
            except OSError:  # the job went away
                return

    def listen(self, path: str) -> str:
        """Accept jobs' connections on the Unix socket ``path``, each served in a thread of its own."""
        from multiprocessing.connection import Listener

        if self.listener is None:
            self.listener = Listener(path, family="AF_UNIX")
            threading.Thread(target=self._accept, daemon=True, name="accept").start()
        return str(self.listener.address)

    def _accept(self) -> None:
        while True:
            try:
                conn = self.listener.accept()
            except OSError:
                return
            threading.Thread(target=self.serve, args=(conn,), daemon=True, name="job").start()


def main() -> None:
    """The writer process: its owner's requests come on file descriptor argv[1], the answers go to
    argv[2]. MLflow and its database store are imported at once, while the owner composes and solves."""
    conn = _Duplex(int(sys.argv[1]), int(sys.argv[2]))
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    service = _Service()
    logging.getLogger().addHandler(service.collector)
    logging.getLogger().setLevel(logging.INFO)
    logging.captureWarnings(True)
    threading.Thread(target=service.import_mlflow, daemon=True, name="import").start()
    try:
        service.serve(conn)
    finally:
        if service.listener is not None:
            service.listener.close()  # removes the socket file


# ---- the job's side --------------------------------------------------------------------------------

class Writer:
    """A connection to a writer and the answers it owes, in the order they were asked: to a process of
    this one's own (``process``), or to a sweep's writer over its socket."""

    def __init__(self, conn, process: subprocess.Popen | None = None):
        self.conn, self.process = conn, process
        self.asked = 0      # requests sent
        self.answered = 0   # answers read
        self.answers: dict[int, tuple] = {}
        self.lost = False

    @classmethod
    def start(cls) -> "Writer":
        """A writer process of this process's own."""
        to_writer_r, to_writer_w = os.pipe()
        from_writer_r, from_writer_w = os.pipe()
        code = "from dsmv.tracking.run_writer import main; main()"
        process = subprocess.Popen([sys.executable, "-c", code, str(to_writer_r), str(from_writer_w)],
                                   pass_fds=(to_writer_r, from_writer_w), stdin=subprocess.DEVNULL,
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        os.close(to_writer_r)
        os.close(from_writer_w)
        return cls(_Duplex(from_writer_r, to_writer_w), process)

    @property
    def alive(self) -> bool:
        return not self.lost and (self.process is None or self.process.poll() is None)

    def ask(self, kind: str, *args) -> int:
        """Send a request; returns its ticket for :meth:`answer`."""
        try:
            self.conn.send((kind, args))
        except OSError as error:
            self.lost = True
            raise WriterError(f"the MLflow writer cannot be reached: {error}") from None
        self.asked += 1
        return self.asked

    def answer(self, ticket: int):
        """The answer to a request (waits for it); raises :class:`WriterError` if it failed. Each answer
        is handed out once: asking again would wait for ever."""
        if ticket <= self.answered and ticket not in self.answers:
            raise ValueError(f"the answer to request {ticket} was already taken")
        while ticket not in self.answers:
            try:
                self.answers[self.answered + 1] = self.conn.recv()
            except (EOFError, OSError):
                self.lost = True
                ended = f" (exit code {self.process.poll()})" if self.process is not None else ""
                raise WriterError(f"the MLflow writer ended{ended}") from None
            self.answered += 1
        status, value, records = self.answers.pop(ticket)
        for record in records:  # into the job's log, as if logged here
            logging.getLogger(record.name).handle(record)
        if status == "error":
            raise WriterError(value)
        return value


_writer: Writer | None = None
#: connections to sweeps' writers, by socket path
_sweep_writers: dict[str, Writer] = {}
#: (sweep dir, pid) of the sweep this process's writer serves (:func:`serve_sweep`)
_serving: tuple[str, int] | None = None


def writer() -> Writer:
    """This process's writer, started on first use (and again if it died)."""
    global _writer
    if _writer is None or not _writer.alive:
        _writer = Writer.start()
    return _writer


def serve_sweep(sweep_dir: Path) -> Writer:
    """The sweep's main process: its writer, listening for the sweep's jobs on a Unix socket named in
    the sweep dir. The socket lives in the temporary folder (a sweep dir's path can exceed the 107
    bytes a socket's path may have)."""
    global _serving
    own = writer()
    _serving = (str(sweep_dir), os.getpid())
    path = os.path.join(tempfile.gettempdir(), f"dsmv-writer-{os.getpid()}-{os.urandom(4).hex()}.sock")
    own.answer(own.ask("listen", path))
    write_atomically(Path(sweep_dir) / SOCKET_FILE, json.dumps({"socket": path, "host": socket.gethostname()}))
    return own


def for_job(sweep_dir: Path | None) -> Writer:
    """The writer a job hands its run to: its sweep's, when it runs on the sweep's host and the writer
    answers; else this process's own."""
    if sweep_dir is not None and (found := Path(sweep_dir) / SOCKET_FILE).exists():
        if _serving == (str(sweep_dir), os.getpid()) and _writer is not None and _writer.alive:
            return _writer  # the basic launcher: the job runs in the sweep's own process
        where = json.loads(found.read_text())
        path = where["socket"]
        known = _sweep_writers.get(path)
        if known is not None and known.alive:
            return known
        if where.get("host") == socket.gethostname():
            from multiprocessing.connection import Client

            try:
                _sweep_writers[path] = Writer(Client(path, family="AF_UNIX"))
                return _sweep_writers[path]
            except OSError:  # gone, or not reachable from here: a writer of the job's own
                pass
    return writer()
