"""A sweep's life in its main process: the Hydra callback (:class:`MlflowSweepCallback`) that owns a
multirun's parent MLflow run (opened and closed through :mod:`dsmv.tracking.runs`), its summary
(``sweep_summary.csv``) and sweep-level plot, its log (:data:`SWEEP_LOG_FILE`), its signal handling
(:mod:`dsmv.app.interrupts`) and its exit code; and the abort on a second signal
(:func:`abort_sweep`)."""

from __future__ import annotations

import csv
import json
import logging
import sys
import time
from collections import Counter
from pathlib import Path

from hydra.experimental.callback import Callback
from omegaconf import DictConfig, OmegaConf

from dsmv import safety
from dsmv.app.interrupts import SweepSignals, interrupted, mark
from dsmv.app.joblog import log_sweep_to, replay_early_output
from dsmv.config.objective import ObjectiveConfig, objective_config
from dsmv.errors import DsmvError
from dsmv.post.optimum import optimum_summary
from dsmv.post.plots import SWEEP_PLOT_MAKERS
from dsmv.post.studies import sweep_jobs
from dsmv.results import EXIT_CODES, EXIT_SEVERITY
from dsmv.tracking import runs

#: the sweep's own log in its sweep dir: what the sweep's main process logs (library warnings, MLflow's
#: messages), beside each job's <job>.log
SWEEP_LOG_FILE = "sweep.log"
SWEEP_SUMMARY_FILE = "sweep_summary.csv"

#: the sweep running in this process, for :func:`abort_sweep`
_active_sweep: dict = {}


class MlflowSweepCallback(Callback):
    """Hydra callback owning a multirun's parent MLflow run, its summary, its log (SWEEP_LOG_FILE) and
    its signal handling (dsmv.app.interrupts)."""

    def on_multirun_start(self, config: DictConfig, **kwargs) -> None:
        sweep_dir = Path(str(config.hydra.sweep.dir))
        sweep_dir.mkdir(parents=True, exist_ok=True)
        self.signals = SweepSignals(sweep_dir)
        self.signals.install()
        _sweep_log(sweep_dir)
        _active_sweep.update(sweep_dir=sweep_dir, config=config)
        sweeper = str(config.hydra.sweeper.get("_target_", ""))
        if "optuna" in sweeper.lower():  # its trials, proposed batch by batch
            runs.write_sweep_size(sweep_dir, int(config.hydra.sweeper.n_trials))
        elif "cases" not in sweeper:  # the case sweeper counts its own
            # the basic sweeper sweeps the experiment's hydra.sweeper.params too, the command line winning
            task = list(config.hydra.overrides.task)
            given = {o.split("=", 1)[0].lstrip("+~") for o in task}
            params = config.hydra.sweeper.get("params") or {}
            swept = [f"{key}={value}" for key, value in params.items() if key not in given] + task
            runs.write_sweep_size(sweep_dir, runs.basic_sweep_size(swept))
        runs.open_sweep_run(config, sweep_dir)

    def on_multirun_end(self, config: DictConfig, **kwargs) -> None:
        """Summarise the sweep, close its parent run, print the tally and exit with the code of its
        worst job (:func:`sweep_exit_code`)."""
        sweep_dir = Path(str(config.hydra.sweep.dir))
        if getattr(self, "signals", None) is not None:
            self.signals.uninstall()
        _active_sweep.clear()
        _sweep_log(sweep_dir, config)  # jobs run in this process (the basic launcher) took the root logger over
        parent = runs.opened_sweep_run(sweep_dir)
        status, rows, metrics, files = "FAILED", [], [], []
        try:
            rows = summarize_sweep(sweep_dir)
            plot = sweep_plot(config, sweep_dir)
            now = int(time.time() * 1000)
            counts = {s: sum(r["status"] == s for r in rows) for s in {r["status"] for r in rows}}
            metrics = [(f"jobs_{job_status}", float(count), now, 0) for job_status, count in counts.items()]
            metrics.append(("jobs_total", float(len(rows)), now, 0))
            files = [str(path) for path in (sweep_dir / SWEEP_SUMMARY_FILE, plot)
                     if path is not None and Path(path).exists()]
            status = "KILLED" if interrupted(sweep_dir) else "FINISHED"
        finally:  # the parent run never stays RUNNING
            if parent is not None:
                runs.finish_sweep_run(parent, metrics, files, status)
        tally, code = sweep_exit_code([r["status"] for r in rows])
        line = f"dsmv: sweep done: {tally} — see {sweep_dir / SWEEP_SUMMARY_FILE}"
        verdicts = safety.sweep_tally(rows)
        for line in [line, *([f"dsmv: safety: {verdicts}"] if verdicts else []), *optimum_lines(config, sweep_dir)]:
            print(line)
            logging.getLogger("dsmv.sweep").info(line)
        if code != 0:
            sys.exit(code)


def optimum_lines(config: DictConfig, sweep_dir: Path) -> list[str]:
    """An optimising sweep's answer in words and units (:func:`dsmv.post.optimum.optimum_summary`): the
    best trial's figures, the trials by status, the results file. [] for any other sweeper."""
    if "optuna" not in str(config.hydra.sweeper.get("_target_", "")).lower():
        return []
    try:
        try:
            objective = objective_config({"objective": OmegaConf.to_container(config.objective, resolve=True)
                                          if config.get("objective") is not None else None})
        except DsmvError:
            objective = ObjectiveConfig()
        trials = config.hydra.sweeper.get("n_trials")
        return optimum_summary(sweep_dir, objective, int(trials) if trials is not None else None,
                               str(config.get("study") or "optimum")) or []
    except Exception as error:  # the sweep's results stand without their summary
        logging.getLogger("dsmv.sweep").warning("no summary of the optimum: %s: %s", type(error).__name__, error)
        return []


def _sweep_log(sweep_dir: Path | None, config: DictConfig | None = None) -> None:
    """Log the sweep's main process into SWEEP_LOG_FILE (dsmv.app.joblog.SweepLogHandler), Python warnings
    included; with ``config``, first give the process Hydra's logging back (jobs the basic launcher ran
    here reconfigured it for theirs)."""
    if config is not None:
        from hydra.core.utils import configure_log

        configure_log(config.hydra.hydra_logging, config.hydra.verbose)
    log_sweep_to(Path(sweep_dir) / SWEEP_LOG_FILE if sweep_dir is not None else None)
    logging.captureWarnings(sweep_dir is not None)
    if sweep_dir is not None:
        replay_early_output()  # what the command line's checks met (dsmv.app.command_line.check_command_line)


def abort_sweep(reason: str) -> Path | None:
    """The sweep in this process was aborted (a second signal): close its parent MLflow run and its jobs'
    runs still RUNNING as KILLED, mark it interrupted, summarise what finished. Returns its dir, or None."""
    sweep_dir, config = _active_sweep.get("sweep_dir"), _active_sweep.get("config")
    _active_sweep.clear()
    if sweep_dir is None:
        return None
    mark(sweep_dir, reason)
    try:
        summarize_sweep(sweep_dir)
    except Exception:
        pass
    runs.kill_sweep_runs(config, sweep_dir)
    return sweep_dir


def sweep_exit_code(statuses: list[str]) -> tuple[str, int]:
    """A sweep's tally ('12 ok, 1 bearing_failure, 1 failed') and exit code: that of its worst job
    (dsmv.results.EXIT_SEVERITY). Jobs that failed, were interrupted, went unstable or left the
    domain make it non-zero; bearing failures are answers and leave it 0."""
    counts = Counter(statuses)
    tally = ", ".join(f"{counts[s]} {s}" for s in reversed(EXIT_SEVERITY) if counts[s]) or "no jobs"
    worst = next((s for s in EXIT_SEVERITY if counts[s]), "ok")
    return tally, EXIT_CODES[worst]


def sweep_plot(config: DictConfig, sweep_dir: Path) -> Path | None:
    """The sweep-level plot the experiment asks for (``sweep_plot: <name>``), written into the sweep dir."""
    name = config.get("sweep_plot")
    if not name:
        return None
    return SWEEP_PLOT_MAKERS[name](sweep_dir, sweep_dir / f"{name}.png")


def summarize_sweep(sweep_dir: Path) -> list[dict]:
    """Collect every job's result.json below a sweep dir into ``sweep_summary.csv``."""
    rows = []
    for job in sweep_jobs(sweep_dir):
        row = {"job": job.name, "overrides": " ".join(job.overrides), "status": job.result["status"]}
        recorded = job.path / runs.JOB_RUN_FILE
        if recorded.exists():  # the MLflow run that holds the job, and whether an earlier sweep made it
            row |= json.loads(recorded.read_text())
        row |= job.result["metrics"]
        row["message"] = job.result["message"]
        rows.append(row)
    if rows:
        columns = list(dict.fromkeys(k for row in rows for k in row))
        with (Path(sweep_dir) / SWEEP_SUMMARY_FILE).open("w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=columns)
            writer.writeheader()
            writer.writerows(rows)
    return rows
