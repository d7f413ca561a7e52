"""MLflow tracking of jobs and sweeps.

One MLflow experiment per study (``dsmv-<study>``). Each job is one run: the flattened
resolved config as params, scalar results as metrics, the time history as metric
history (step = simulated time in microseconds, so the MLflow UI overlays curves on a
physical axis), result.json / the resolved config / the history CSV as artifacts, and
tags for status, soil law, solver, geometry and config hash. A completed job is FINISHED
whatever its physics status; FAILED means the code raised.

A multirun gets one parent run, opened for the sweep callback (:class:`dsmv.app.sweep.MlflowSweepCallback`)
before the jobs start; each job's run, in whatever process a launcher puts it, is tagged with its
``mlflow.parentRunId`` from the sweep dir (nested runs only work within one process).
The runs are written by a writer process beside the solve (:mod:`dsmv.tracking.run_writer`), through
``MlflowClient`` with explicit run ids: no global "active run" state.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from omegaconf import DictConfig, OmegaConf

from dsmv.config.scene import RESULT_NEUTRAL_SOLVER_KEYS, TrackingConfig, build_tracking
from dsmv.numba_cache import source_hash
from dsmv.results import SolveResult, history_columns
from dsmv.tracking.run_writer import WriterError, for_job, open_client, resolve_uri, serve_sweep

PARENT_RUN_FILE = "mlflow_parent_run.json"
#: how many jobs a sweep has, in its sweep dir (written before they start), for the jobs' progress
SWEEP_SIZE_FILE = "sweep_size.json"
#: the sweep's finished jobs, numbered in the order they finished (:func:`job_done`), in its sweep dir
JOBS_DONE_DIR = ".jobs_done"
#: a job's MLflow run id, in its job dir (``reused``: a run of an earlier sweep, resume=true)
JOB_RUN_FILE = "mlflow_run.json"
#: statuses that are the solver's answer: a finished run with one of these is not run again on resume
ANSWER_STATUSES = ("ok", "bearing_failure", "out_of_domain", "unstable")
MAX_HISTORY_POINTS = 1000  # per curve logged to MLflow; the CSV artifact keeps every sample


def experiment_name(study: str) -> str:
    return f"dsmv-{study}"


#: command-line overrides that say where and how a run is kept, not what it computes: left out of run names
BOOKKEEPING_KEYS = ("paths", "tracking", "hydra", "output", "resume")
#: overrides a job's run name leaves out because it names them otherwise: the solver and the soil law lead
#: it, and the study is the MLflow experiment the run is in
NAMED_OTHERWISE = ("solver", "solver.name", "soil.law", "experiment")
#: the longest run name MLflow's database store keeps (its runs table's name column)
RUN_NAME_CHARS = 250


def _key(override: str) -> str:
    """An override's key as typed, without ``+``, ``++`` or ``~`` (``landing.mass_kg``, ``hydra/launcher``)."""
    return override.split("=", 1)[0].lstrip("+~")


def _computing(overrides) -> list[str]:
    """The overrides that change what a run computes, as typed."""
    return [o for o in overrides if _key(o).split(".", 1)[0].split("/", 1)[0] not in BOOKKEEPING_KEYS]


def short_overrides(overrides) -> list[str]:
    """Overrides as a run's name shows them: each key by its last part unless two would read alike
    (``landing.mass_kg=6500`` as ``mass_kg=6500``, ``soil=sample_II`` as typed)."""
    last = [_key(o).rsplit(".", 1)[-1] for o in overrides]
    return [f"{'~' if o.startswith('~') else ''}{short if last.count(short) == 1 else _key(o)}"
            f"{'=' + o.split('=', 1)[1] if '=' in o else ''}" for o, short in zip(overrides, last)]


def run_name(scene, overrides) -> str:
    """A job's MLflow run name: the overrides it was given that change what it computes (a sweep's job:
    what the sweep varies), keys shortened (:func:`short_overrides`), then its solver and soil law:
    ``mass_kg=5000 velocity_m_s=1.0 cel3d einav_randolph``. What differs between the jobs of a sweep
    comes first, as MLflow's runs list shows a name's first 20 characters or so. Settings that change no result
    (``solver.max_wall_s`` …) are left out; the scene in words is the run's tag ``dsmv.scene``."""
    def shown(override: str) -> bool:
        key = _key(override)
        neutral = key.startswith("solver.") and key.split(".", 1)[1] in RESULT_NEUTRAL_SOLVER_KEYS
        return key not in NAMED_OTHERWISE and not neutral

    words = short_overrides([o for o in _computing(overrides) if shown(o)])
    return " ".join([*words, scene.solver.name, scene.soil.law])[:RUN_NAME_CHARS]


def sweep_name(study: str, overrides, sweep_dir: Path) -> str:
    """A sweep's parent run name: what it varies, keys shortened (``sweep mass_kg=4500,6500 mesh=coarse``);
    a study that varies nothing on the command line: ``sweep <study> <sweep dir's name>``."""
    varied = short_overrides([o for o in _computing(overrides) if _key(o) != "experiment"])
    return (f"sweep {' '.join(varied)}" if varied else f"sweep {study} {Path(sweep_dir).name}")[:RUN_NAME_CHARS]


def _client(tracking: TrackingConfig):
    return open_client(tracking.uri)


def flatten(tree: Any, prefix: str = "") -> dict[str, str]:
    """Nested config → ``{"soil.su0_pa": "5000.0", ...}`` (MLflow params are strings)."""
    if isinstance(tree, dict):
        flat: dict[str, str] = {}
        for key, value in tree.items():
            flat |= flatten(value, f"{prefix}{key}.")
        return flat
    return {prefix[:-1]: str(tree)}


def _git_sha(package_dir: Path | None = None) -> str | None:
    """The commit of the git checkout dsmv was imported from, whatever the working directory.

    None when dsmv's package directory is not tracked by a git checkout: installed from a wheel,
    including into a virtualenv that happens to sit inside some repository's work tree.
    """
    package_dir = Path(package_dir or Path(__file__).resolve().parents[1])
    env = {k: v for k, v in os.environ.items() if k not in ("GIT_DIR", "GIT_WORK_TREE")}
    git = ["git", "-C", str(package_dir)]
    try:
        tracked = subprocess.run([*git, "ls-files", "--error-unmatch", "--", "__init__.py"],
                                 capture_output=True, text=True, timeout=5, env=env)
        if tracked.returncode != 0:
            return None
        out = subprocess.run([*git, "rev-parse", "HEAD"], capture_output=True, text=True, timeout=5, env=env)
    except (OSError, subprocess.SubprocessError):
        return None
    if out.returncode != 0:
        return None
    return out.stdout.strip() or None


class JobTracker:
    """The MLflow run of one job, written by this process's writer (:mod:`dsmv.tracking.run_writer`): MLflow's
    import and store set-up overlap the solve. ``run_id`` waits for the run to exist; an error of the
    store is raised there or in :meth:`finish`."""

    def __init__(self, tracking: TrackingConfig, study: str, run_name: str, params: dict[str, str], tags: dict,
                 run_dir: Path, sweep_dir: Path | None = None):
        self.uri = resolve_uri(tracking.uri)
        self.run_dir = run_dir
        self.writer = for_job(sweep_dir)
        tags = {k: str(v)[:5000] for k, v in tags.items() if v is not None}
        parent_file = str(Path(sweep_dir) / PARENT_RUN_FILE) if sweep_dir is not None else None
        self._opened = self.writer.ask("open", self.uri, tracking.artifact_location, experiment_name(study), run_name,
                                       {k: v[:6000] for k, v in params.items()}, tags, parent_file)
        self._run_id: str | None = None
        self._open_error: str | None = None  # why the run could not be opened (its answer is taken once)

    @property
    def run_id(self) -> str:
        if self._run_id is None:
            if self._open_error is not None:
                raise WriterError(self._open_error)
            try:
                self._run_id = self.writer.answer(self._opened)
            except WriterError as error:
                self._open_error = str(error)
                raise
            record_job_run(self.run_dir, self._run_id, reused=False)
        return self._run_id

    def finish(self, result: SolveResult, files: list[Path], error: str | None = None, note: str = "",
               tags: dict | None = None) -> None:
        """Log the outcome and close the run: FINISHED unless the code raised. ``note`` becomes the run's
        description in the MLflow UI (the summary's answer line); ``tags`` are logged besides."""
        now = int(time.time() * 1000)
        metrics = [(k, float(v), now, 0) for k, v in result.metrics.items()]
        if result.history is not None:
            metrics += _history_metrics(result.history, now)
        tags = {"dsmv.status": result.status, "dsmv.message": result.message[:5000]} | {
            k: str(v)[:5000] for k, v in (tags or {}).items()}
        if error:
            tags["dsmv.error"] = error[:5000]
        if note:
            tags["mlflow.note.content"] = note[:5000]
        # FAILED: the code raised; KILLED: a signal stopped the run (its reason is the message)
        end_status = "FAILED" if error else ("KILLED" if result.status == "interrupted" else "FINISHED")
        self.writer.answer(self.writer.ask("finish", self.uri, self.run_id, metrics, {"status": result.status}, tags,
                                           [str(path) for path in files], end_status))

    def terminate(self, end_status: str) -> None:
        """Close the run without its outcome (the job was stopped while writing it, or the store failed):
        as far as the store lets it; a run never opened has nothing to close."""
        try:
            run_id = self.run_id
        except WriterError:  # never opened: nothing to close
            return
        try:
            self.writer.answer(self.writer.ask("terminate", self.uri, run_id, end_status))
        except WriterError as error:
            print(f"dsmv: warning: MLflow run {run_id} could not be closed {end_status} ({error})", file=sys.stderr)


def _history_metrics(history: dict, timestamp_ms: int) -> list:
    """Histories as metric steps (key, value, timestamp, step): step = simulated time in µs, at most
    MAX_HISTORY_POINTS each."""
    import numpy as np

    time_s = np.asarray(history["time_s"], dtype=float)
    keep = np.unique(np.linspace(0, len(time_s) - 1, min(len(time_s), MAX_HISTORY_POINTS)).round().astype(int))
    steps = np.round(time_s[keep] * 1e6).astype(np.int64)
    out = []
    for column in history_columns(history)[1:]:
        values = np.asarray(history[column], dtype=float)[keep]
        out += [(f"history.{column}", float(v), timestamp_ms, int(s)) for v, s in zip(values, steps)]
    return out


def code_hash() -> str:
    """The hash of the solver code whose results a run records (every source file of ``dsmv.cel``,
    the kernels' own cache key): runs of other code are never taken for this code's."""
    return source_hash()


def identity(scene) -> str:
    """What makes two jobs the same computation: the scene's config hash (keys that do not change
    results left out) and the solver code's hash."""
    return f"{scene.config_hash}-{code_hash()}"


def finished_run(cfg: DictConfig, scene):
    """The latest FINISHED run in the store with this scene's identity and an answer status (None
    when tracking is off or there is none): what ``resume=true`` reuses."""
    tracking = build_tracking(cfg)
    if not tracking.enabled:
        return None
    client = _client(tracking)
    experiment = client.get_experiment_by_name(experiment_name(scene.study))
    if experiment is None:
        return None
    runs = client.search_runs([experiment.experiment_id], order_by=["attributes.start_time DESC"], max_results=20,
                              filter_string=f"tags.`dsmv.identity` = '{identity(scene)}' "
                                            f"and attributes.status = 'FINISHED'")
    return next((r for r in runs if r.data.tags.get("dsmv.status") in ANSWER_STATUSES), None)


def write_sweep_size(sweep_dir: Path, jobs: int | None) -> None:
    """Note the number of a sweep's jobs (None: unknown) for the jobs' progress line."""
    if jobs is not None:
        (Path(sweep_dir) / SWEEP_SIZE_FILE).write_text(json.dumps({"jobs": jobs}))


def basic_sweep_size(overrides: list[str]) -> int | None:
    """The jobs of Hydra's basic sweeper over these overrides: the product of each sweep's values
    (None for a sweep whose values it cannot count)."""
    from hydra.core.override_parser.overrides_parser import OverridesParser

    try:
        parsed = OverridesParser.create().parse_overrides(list(overrides))
        size = 1
        for o in parsed:
            if o.is_sweep_override():
                size *= len(list(o.sweep_string_iterator()))
        return size
    except Exception:  # an interval or a custom sweep: the size is the sweeper's to know
        return None


def sweep_progress(sweep_dir: Path, job: str) -> str:
    """`` (5 of 8 jobs done)``: where the finished ``job`` stands among the sweep's finished jobs, of the
    sweep's size ('' if unknown). Each finished job takes the next number of the sweep's
    :data:`JOBS_DONE_DIR` (:func:`job_done`), so two jobs that end together never print the same count."""
    done = job_done(sweep_dir, job)
    path = Path(sweep_dir) / SWEEP_SIZE_FILE
    if not path.exists():
        return ""
    return f" ({done} of {json.loads(path.read_text())['jobs']} jobs done)"


def job_done(sweep_dir: Path, job: str) -> int:
    """Count ``job`` as finished: its number among the sweep's finished jobs (1, 2, ...), unique.

    The number is a file of :data:`JOBS_DONE_DIR` created exclusively, which no two processes can both
    create (on one machine or on a shared file system), holding the job's name. Counting the jobs that
    wrote result.json instead gave two jobs ending together the same count: both had written theirs
    before either counted."""
    folder = Path(sweep_dir) / JOBS_DONE_DIR
    folder.mkdir(parents=True, exist_ok=True)
    number = sum(1 for _ in folder.iterdir())  # the numbers below are taken
    while True:
        number += 1
        try:
            handle = os.open(folder / str(number), os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            continue
        with os.fdopen(handle, "w") as fh:
            fh.write(job)
        return number


def record_job_run(run_dir: Path, run_id: str, reused: bool) -> None:
    """Note a job's MLflow run id in its job dir (the sweep summary lists it)."""
    (Path(run_dir) / JOB_RUN_FILE).write_text(json.dumps({"run_id": run_id, "reused": reused}))


def start_job(cfg: DictConfig, scene, run_dir: Path, run_name: str, sweep_dir: Path | None) -> JobTracker | None:
    """Open the MLflow run of a job (a child of its sweep's parent run), or return None when tracking is
    disabled."""
    tracking = build_tracking(cfg)
    if not tracking.enabled:
        return None
    container = OmegaConf.to_container(cfg, resolve=True)
    params = flatten({k: v for k, v in container.items() if k not in ("tracking", "paths")})
    tags = {
        "mlflow.source.git.commit": _git_sha(),
        "dsmv.study": scene.study,
        "dsmv.soil_law": scene.soil.law,
        "dsmv.solver": scene.solver.name,
        "dsmv.geometry": scene.geometry.name,
        "dsmv.scene": scene.label,
        "dsmv.config_hash": scene.config_hash,
        "dsmv.code_hash": code_hash(),
        "dsmv.identity": identity(scene),
        "dsmv.run_dir": str(run_dir.resolve()),
        "dsmv.status": "running",
    }
    return JobTracker(tracking, scene.study, run_name, params, tags, run_dir, sweep_dir)


def parent_run_id(sweep_dir: Path) -> str | None:
    """The id of the sweep's parent run, if the sweep callback made one."""
    path = Path(sweep_dir) / PARENT_RUN_FILE
    return json.loads(path.read_text())["run_id"] if path.exists() else None


#: per sweep dir: the writer opening its parent run, the request's ticket and the store's URI
_parent_runs: dict = {}


def open_sweep_run(config: DictConfig, sweep_dir: Path) -> None:
    """Ask the sweep's writer to open the sweep's parent run (nothing when tracking is off); the writer
    then serves the jobs' runs too. :func:`opened_sweep_run` waits for it."""
    tracking = build_tracking(config)
    if not tracking.enabled:
        return
    writer = serve_sweep(sweep_dir)
    study = str(config.get("study", "default"))
    tags = {"dsmv.study": study, "dsmv.sweep_dir": str(sweep_dir.resolve()), "dsmv.role": "sweep"}
    sha = _git_sha()
    if sha:
        tags["mlflow.source.git.commit"] = sha
    name = sweep_name(study, config.hydra.overrides.task, sweep_dir)
    overrides = list(config.hydra.overrides.task)
    params = {"sweep.overrides": " ".join(overrides)[:6000]} if overrides else {}
    uri = resolve_uri(tracking.uri)
    ticket = writer.ask("open", uri, tracking.artifact_location, experiment_name(study), name, params, tags, None,
                        str(sweep_dir / PARENT_RUN_FILE))
    _parent_runs[str(sweep_dir)] = (writer, ticket, uri)  # (not on the callback: Hydra pickles its callbacks)


def opened_sweep_run(sweep_dir: Path):
    """The sweep's parent run once its writer has opened it: ``(writer, run id, store URI)``, or None
    (tracking off, or the run could not be opened)."""
    writer, ticket, uri = _parent_runs.pop(str(sweep_dir), (None, None, None))
    try:
        run_id = writer.answer(ticket) if writer is not None else None
    except WriterError as error:  # the sweep's summary and tally still come
        print(f"dsmv: warning: the sweep's MLflow run could not be opened ({error})", file=sys.stderr)
        return None
    return None if run_id is None else (writer, run_id, uri)


def finish_sweep_run(parent, metrics: list, files: list[str], status: str) -> None:
    """Close the parent run :func:`opened_sweep_run` gave with the sweep's metrics, files and status (a
    store that fails is said in one line: the sweep's summary and tally still come)."""
    writer, run_id, uri = parent
    try:
        writer.answer(writer.ask("finish", uri, run_id, metrics, {}, {}, files, status))
    except WriterError as error:
        print(f"dsmv: warning: the sweep's MLflow run {run_id} was not closed ({error})", file=sys.stderr)


def kill_sweep_runs(config: DictConfig, sweep_dir: Path) -> None:
    """Close a sweep's parent run and its jobs' runs still RUNNING as KILLED (the jobs' tagged
    ``interrupted``); nothing when tracking is off or the sweep has no parent run."""
    run_id = parent_run_id(sweep_dir)
    tracking = build_tracking(config)
    if run_id is None or not tracking.enabled:
        return
    client = _client(tracking)
    experiment_id = client.get_run(run_id).info.experiment_id
    children = client.search_runs([experiment_id], f"tags.mlflow.parentRunId = '{run_id}' and "
                                                   f"attributes.status = 'RUNNING'", max_results=10000)
    for child in children:
        client.set_tag(child.info.run_id, "dsmv.status", "interrupted")
        client.set_terminated(child.info.run_id, "KILLED")
    client.set_terminated(run_id, "KILLED")
