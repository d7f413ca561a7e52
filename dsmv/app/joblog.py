"""A job's log: what it shows on the console, and the warnings of the libraries it calls, in its Hydra
``<job>.log`` (``cli.log``).

Hydra's job logging (``conf/hydra/job_logging/dsmv.yaml``) sends log records to the job's log file,
and to the console only from ERROR up. :func:`job_output` then, for the job's duration,

- copies every line the job prints on stdout and stderr (the summary, progress lines, errors) into
  the log's file handlers, as records of the loggers ``dsmv.stdout`` and ``dsmv.stderr``; the
  console shows them unchanged. A progress bar redrawn in place (``\\r``, on a terminal) is written as
  a line every :data:`BAR_EVERY_S` and once when it closes;
- routes Python warnings (``warnings.warn``, e.g. matplotlib's and Numba's) to the logger
  ``py.warnings``, so they go to the log instead of the console;
- replays into the log what the command line's checks caught before Hydra configured logging
  (:func:`keep_early_output`).

A sweep's main process logs, outside its jobs, into the sweep's own log, ``<sweep dir>/sweep.log``:
Hydra's launcher lines (also shown on the console as ``[HYDRA]`` lines), MLflow's messages when the
sweep's parent run is made, library warnings of the sweep-level plots (:class:`SweepLogHandler`, in
``conf/hydra/hydra_logging/dsmv.yaml``; :func:`log_sweep_to` points it at the sweep).
"""

from __future__ import annotations

import logging
import sys
import time
import warnings
from contextlib import contextmanager
from pathlib import Path

#: a progress bar redrawn in place is logged at most this often (s), and when it closes
BAR_EVERY_S = 10.0

_early_warnings: list[warnings.WarningMessage] = []
_early_records: list[logging.LogRecord] = []


class _Keep(logging.Handler):
    def emit(self, record: logging.LogRecord) -> None:
        _early_records.append(record)


@contextmanager
def keep_early_output():
    """Hold the warnings and log records (WARNING and up) raised inside, for the job's log, instead of
    printing them: a command line refused in one line stays one line."""
    root = logging.getLogger()
    keeper = _Keep(logging.WARNING)
    root.addHandler(keeper)
    try:
        with warnings.catch_warnings(record=True) as caught:
            yield
    finally:
        root.removeHandler(keeper)
        _early_warnings.extend(caught)


#: the log file of the sweep running in this process (None: no sweep, records dropped)
_sweep_log: Path | None = None


def log_sweep_to(path: Path | None) -> None:
    """Point every :class:`SweepLogHandler` at ``path`` (None: no sweep)."""
    global _sweep_log
    _sweep_log = Path(path).resolve() if path is not None else None


class SweepLogHandler(logging.Handler):
    """Writes into the running sweep's log (:func:`log_sweep_to`), opened at its first record; outside a
    sweep it drops records. Hydra's logging config creates it anew at each (re)configuration; the
    sweep's path is the module's, so every instance writes to the same file."""

    def __init__(self, level: int = logging.NOTSET):
        super().__init__(level)
        self._file: logging.FileHandler | None = None

    def emit(self, record: logging.LogRecord) -> None:
        if _sweep_log is None:
            return
        if self._file is None or Path(self._file.baseFilename) != _sweep_log:
            if self._file is not None:
                self._file.close()
            self._file = logging.FileHandler(_sweep_log, delay=True)
        self._file.setFormatter(self.formatter)
        self._file.emit(record)

    def flush(self) -> None:
        if self._file is not None:
            self._file.flush()

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None
        super().close()


def replay_early_output() -> None:
    """Log what :func:`keep_early_output` held (warnings through ``py.warnings`` when captured)."""
    for message in _early_warnings:
        warnings.showwarning(message.message, message.category, message.filename, message.lineno)
    for record in _early_records:
        logging.getLogger(record.name).handle(record)
    _early_warnings.clear()
    _early_records.clear()


def _file_handlers() -> list[logging.Handler]:
    return [h for h in logging.getLogger().handlers if isinstance(h, logging.FileHandler)]


class ConsoleCopy:
    """A text stream that writes through to ``stream`` and copies its lines into log file handlers."""

    def __init__(self, stream, name: str, handlers: list[logging.Handler]):
        self.stream, self.name, self.handlers = stream, name, handlers
        self.pending = ""          # text after the last line end
        self.bar: str | None = None  # the last state of a line redrawn in place, not yet logged
        self.bar_logged = 0.0
        self.busy = False

    # the stream's own face: what tqdm, print and isatty() see
    def write(self, text: str) -> int:
        written = self.stream.write(text)
        if not self.busy:
            self.busy = True
            try:
                self._copy(text)
            finally:
                self.busy = False
        return written

    def flush(self) -> None:
        self.stream.flush()

    def isatty(self) -> bool:
        return self.stream.isatty()

    def __getattr__(self, name):
        return getattr(self.stream, name)

    # the copy
    def _copy(self, text: str) -> None:
        self.pending += text
        while True:
            cut = min((i for i in (self.pending.find("\n"), self.pending.find("\r")) if i >= 0), default=-1)
            if cut < 0:
                return
            segment, end, self.pending = self.pending[:cut], self.pending[cut], self.pending[cut + 1:]
            if end == "\n":
                if segment.strip():
                    self._log(segment)
                self.bar = None
            elif segment.strip():  # a bar's state, about to be redrawn
                now = time.monotonic()
                if now - self.bar_logged >= BAR_EVERY_S:
                    self._log(segment)
                    self.bar_logged, self.bar = now, None
                else:
                    self.bar = segment
            elif self.bar is not None:  # the bar cleared: its last state
                self._log(self.bar)
                self.bar = None

    def _log(self, line: str) -> None:
        record = logging.LogRecord(self.name, logging.INFO, "(console)", 0, line.rstrip(), None, None)
        for handler in self.handlers:
            if record.levelno >= handler.level:
                handler.handle(record)

    def close_copy(self) -> None:
        for rest in (self.bar, self.pending):
            if rest and rest.strip():
                self._log(rest)
        self.bar, self.pending = None, ""
        for handler in self.handlers:
            handler.flush()


@contextmanager
def job_output():
    """For one Hydra job: its console lines and Python warnings also in its log file (module docstring)."""
    handlers = _file_handlers()
    logging.captureWarnings(True)
    replay_early_output()
    if not handlers:
        try:
            yield
        finally:
            logging.captureWarnings(False)
        return
    out, err = sys.stdout, sys.stderr
    sys.stdout, sys.stderr = ConsoleCopy(out, "dsmv.stdout", handlers), ConsoleCopy(err, "dsmv.stderr", handlers)
    try:
        yield
    finally:
        for copy in (sys.stdout, sys.stderr):
            if isinstance(copy, ConsoleCopy):
                copy.flush()
                copy.close_copy()
        sys.stdout, sys.stderr = out, err
        logging.captureWarnings(False)
