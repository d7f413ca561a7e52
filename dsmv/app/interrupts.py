"""Stopping a sweep: SIGINT (Ctrl-C) or SIGTERM end it cleanly, whatever the launcher.

- The sweep's main process (:class:`SweepSignals`, installed by the sweep callback) takes the first
  signal without dying: it marks the sweep interrupted (the file :data:`MARKER` in the sweep dir,
  holding the reason) and passes the signal on to the launcher's worker processes (joblib's loky
  workers; submitit's controllers as SIGTERM, which they forward to their tasks), which a signal
  sent to the main process alone does not reach. submitit's controllers ignore Ctrl-C
  (``dsmv_local`` starts them so): one that took it would kill its task a second later.
- A job that is running stops as a single run does (the CEL controller ends it ``interrupted``
  within about a second, result.json and its MLflow run KILLED); while it sets up or writes its
  outputs the signal only raises a flag (:func:`sweep_job_signals`), so a job that finished keeps
  its result and a half-written result.json cannot happen. An interrupted job marks the sweep too.
- A job that starts once the sweep is marked is not run: its result.json says ``interrupted``
  (``not started``), so every job of the sweep is accounted for in sweep_summary.csv.
- The sweep then ends as usual: the summary, the parent MLflow run closed (KILLED when interrupted),
  the tally, and the exit code of the worst job (130 for ``interrupted``).
- A second signal to the main process aborts at once (KeyboardInterrupt): the launcher kills its
  workers, and the parent run and the jobs' runs still RUNNING are closed KILLED
  (:func:`dsmv.app.sweep.abort_sweep`).

A joblib worker between two jobs keeps a handler that marks the sweep, so a Ctrl-C reaching it while
idle does not kill it (loky would then break the whole pool).
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
import threading
from contextlib import contextmanager
from pathlib import Path

#: the sweep-dir file that says the sweep was interrupted (its content: by what)
MARKER = "sweep_interrupted"
SIGNALS = (signal.SIGINT, signal.SIGTERM)


def mark(sweep_dir: Path, reason: str) -> None:
    """Mark the sweep interrupted (the first reason stays)."""
    path = Path(sweep_dir) / MARKER
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open("x") as fh:
            fh.write(reason + "\n")
    except FileExistsError:
        pass
    except OSError:  # an unwritable sweep dir: nothing to mark, the jobs say it themselves
        pass


def interrupted(sweep_dir: Path) -> str | None:
    """Why the sweep was interrupted, or None."""
    path = Path(sweep_dir) / MARKER
    try:
        return path.read_text().strip() or "interrupted"
    except OSError:
        return None


def _in_main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


def in_worker_process() -> bool:
    """A launcher's worker process (joblib's loky, a task of submitit's local controller), not the
    process that runs the sweep."""
    return (multiprocessing.current_process().name != "MainProcess" or multiprocessing.parent_process() is not None
            or "SUBMITIT_LOCAL_JOB_ID" in os.environ)


def worker_pids() -> dict[int, signal.Signals | None]:
    """The launcher's worker processes, each with the signal to pass it (None: the one received):
    this process's children running loky's worker or submitit's local controller (Linux /proc).
    loky's resource tracker is left out (it ignores signals anyway)."""
    pids: dict[int, signal.Signals | None] = {}
    me = os.getpid()
    try:
        tasks = os.listdir(f"/proc/{me}/task")
    except OSError:
        return pids
    for task in tasks:
        try:
            children = Path(f"/proc/{me}/task/{task}/children").read_text().split()
        except OSError:
            continue
        for pid in children:
            try:
                cmdline = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ")
            except OSError:
                continue
            if b"loky" in cmdline and b"resource_tracker" not in cmdline:
                pids[int(pid)] = None
            elif b"submitit.local._local" in cmdline:  # forwards SIGTERM to its task
                pids[int(pid)] = signal.SIGTERM
    return pids


class SweepSignals:
    """In the sweep's main process, from the sweep's start to its end (module docstring)."""

    def __init__(self, sweep_dir: Path):
        self.sweep_dir = Path(sweep_dir)
        self.previous: dict = {}
        self.count = 0

    def install(self) -> None:
        if _in_main_thread():
            self.previous = {s: signal.signal(s, self._handle) for s in SIGNALS}

    def uninstall(self) -> None:
        for s, handler in self.previous.items():
            signal.signal(s, handler)
        self.previous = {}

    def _handle(self, signum, frame) -> None:
        self.count += 1
        name = signal.Signals(signum).name
        if self.count > 1:
            raise KeyboardInterrupt(name)
        mark(self.sweep_dir, f"{name} to the sweep")
        for pid, passed in worker_pids().items():
            try:
                os.kill(pid, passed or signum)
            except OSError:
                pass
        print(f"dsmv: {name}: stopping the sweep (running jobs end 'interrupted', the others are not started; "
              f"a second signal aborts)", file=sys.stderr, flush=True)


@contextmanager
def children_ignore_ctrl_c():
    """Processes started inside start with SIGINT ignored (it survives exec, and Python keeps it
    ignored); this process's own handler is back afterwards."""
    if not _in_main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


@contextmanager
def sweep_job_signals(sweep_dir: Path):
    """For one job of a sweep: SIGINT and SIGTERM raise a flag (``caught["signal"]``) and mark the sweep,
    instead of killing the job half-way (the CEL controller takes them over while it steps). Afterwards a
    worker process keeps a handler that only marks the sweep; the main process gets its handlers back."""
    caught: dict = {"signal": None}
    if not _in_main_thread():
        yield caught
        return

    def flag(signum, frame):
        caught["signal"] = signum
        mark(sweep_dir, f"{signal.Signals(signum).name} to a job")

    flag.caught = caught  # a run the job starts after the signal ends at once (dsmv.cel.controller)

    previous = {s: signal.signal(s, flag) for s in SIGNALS}
    try:
        yield caught
    finally:
        worker = in_worker_process()
        for s, handler in previous.items():
            if worker and handler in (signal.SIG_DFL, signal.default_int_handler, None):
                signal.signal(s, lambda signum, frame: mark(sweep_dir, f"{signal.Signals(signum).name} to a worker"))
            else:
                signal.signal(s, handler)
