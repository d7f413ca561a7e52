"""The surrogates' dataset: tracked runs of one study → a typed table with a content hash.

Runs are found with MLflow's run search (``MlflowClient.search_runs``, the query behind
``mlflow.search_runs``) filtered by the study tag ``dsmv.study``; their status tag ``dsmv.status``
decides what trains. Only ``ok`` runs feed surrogates (DESIGN §4); every other run is kept in
:attr:`Dataset.excluded` with its status and message, and counted. A scene tracked twice (same
``dsmv.config_hash``) counts once, the latest run: a duplicate in both a training and a test set
would flatter the test score.

The table has one float64 column per parameter in :data:`PARAMETERS` (read from the run's
params, the flattened config) plus the target :data:`TARGET_METRIC` (m) and the run id. Its
:attr:`~Dataset.content_hash` covers the numbers only, in a canonical row order: the same runs
give the same hash whatever their ids or the order MLflow returns them in.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from dsmv.errors import DsmvError
from dsmv.tracking.run_writer import open_client, store_missing

#: table column → the config key it is read from (MLflow param), units in the column name
PARAMETERS: dict[str, str] = {
    "mass_kg": "landing.mass_kg",  # wet weight as a mass m (kg)
    "inertial_mass_kg": "landing.inertial_mass_kg",  # mass for inertia (kg); NaN: m
    "velocity_m_s": "landing.velocity_m_s",  # touchdown velocity vi (m/s)
    "n_tracks": "landing.n_tracks",  # tracks sharing the weight (-)
    "gravity_m_s2": "landing.gravity_m_s2",  # g (m/s²)
    "width_m": "geometry.width_m",  # track width B (m)
    "contact_length_m": "geometry.contact_length_m",  # contact length L (m); A = B·L
    "su0_pa": "soil.su0_pa",  # mudline strength su0 (Pa)
    "ks_pa_per_m": "soil.ks_pa_per_m",  # strength gradient ks (Pa/m)
    "sensitivity": "soil.sensitivity",  # St (-)
    "xi95": "soil.xi95",  # ξ95 (-)
    "eta": "soil.rate.eta",  # η (-)
}
#: config key → its table column (the inverse of PARAMETERS)
COLUMNS: dict[str, str] = {key: column for column, key in PARAMETERS.items()}
TARGET_METRIC = "max_sinkage_m"  # the CEL run's maximum sinkage z (m)
OPTIONAL = {"inertial_mass_kg"}  # may be null in the config
#: config choices that are not features but define what the runs computed; a dataset records
#: the ones all its runs share, so a prediction can be checked by a CEL run of the same kind
SETTING_GROUPS = {"solver.name": "solver", "soil.law": "soil.law", "mesh.name": "mesh"}
DATASET_FILE = "dataset.csv"
EXCLUDED_FILE = "dataset_excluded.csv"


class DatasetError(DsmvError):
    """No usable tracked runs (a user mistake: wrong study, store or nothing run yet)."""


@dataclass(frozen=True)
class Dataset:
    """The ``ok`` runs of a study as a typed table, and the runs left out with their reasons."""

    study: str
    table: pd.DataFrame  # run_id, PARAMETERS columns (float64), TARGET_METRIC (m)
    excluded: pd.DataFrame  # run_id, status, message
    settings: dict = field(default_factory=dict)  # SETTING_GROUPS override → value shared by every ok run

    @property
    def content_hash(self) -> str:
        """Short SHA-256 of the numbers (parameters and target) in a canonical row order."""
        return table_hash(self.table)

    @property
    def excluded_counts(self) -> dict[str, int]:
        """Runs left out, by status (``bearing_failure``, ``unstable``, ``duplicate``, …)."""
        return {str(k): int(v) for k, v in self.excluded["status"].value_counts().sort_index().items()}

    def save(self, folder: Path) -> list[Path]:
        """Write ``dataset.csv`` and ``dataset_excluded.csv`` into ``folder``; return the paths."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        paths = [folder / DATASET_FILE, folder / EXCLUDED_FILE]
        self.table.to_csv(paths[0], index=False, float_format="%.17g")
        self.excluded.to_csv(paths[1], index=False)
        return paths


def table_hash(table: pd.DataFrame) -> str:
    """Content hash of the numeric columns of a dataset table (order- and run-id-independent)."""
    columns = [*PARAMETERS, TARGET_METRIC]
    values = table[columns].to_numpy(dtype=float)
    rows = sorted(",".join(repr(float(v)) for v in row) for row in values)
    text = ",".join(columns) + "\n" + "\n".join(rows)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _number(text: str | None, column: str) -> float:
    if text is None or text in ("None", "null", ""):
        if column in OPTIONAL:
            return math.nan
        raise ValueError(f"param {PARAMETERS[column]} missing")
    return float(text)


def search_study_runs(tracking_uri: str, study: str) -> list:
    """Every job run tagged ``dsmv.study = study`` (runs with a ``dsmv.role``, sweep parents and
    surrogate trainings, are not jobs)."""
    client = open_client(tracking_uri)
    experiment_ids = [e.experiment_id for e in client.search_experiments()]
    if not experiment_ids:
        return []
    escaped = study.replace("'", "\\'")
    runs, token = [], None
    while True:
        page = client.search_runs(experiment_ids, filter_string=f"tags.`dsmv.study` = '{escaped}'",
                                  max_results=1000, page_token=token)
        runs += [r for r in page if "dsmv.role" not in r.data.tags]  # jobs only: no sweep parents, no surrogates
        token = page.token
        if not token:
            return runs


def study_command(study: str) -> str:
    """The ``dsmv`` command whose runs make up ``study``: ``dsmv experiment=<name>`` for the experiment
    of conf/ (or of a plugin package's config tree) that sets ``study: <study>``, else a sweep tagged
    with it (``dsmv -m study=<study> …``)."""
    from omegaconf import OmegaConf
    from omegaconf.errors import OmegaConfBaseException

    from dsmv import registry
    from dsmv.config.tree import CONFIG_DIR

    for root in (CONFIG_DIR, *registry.config_dirs()):
        for path in sorted((Path(root) / "experiment").glob("*.yaml")):
            try:
                text = OmegaConf.to_container(OmegaConf.load(path))
            except (OSError, ValueError, OmegaConfBaseException):
                continue
            if isinstance(text, dict) and text.get("study") == study:
                return f"dsmv experiment={path.stem}"
    return f"dsmv -m study={study} …"


def load_dataset(tracking_uri: str, study: str, solver: str | None = None) -> Dataset:
    """The dataset of ``study`` from the store at ``tracking_uri``; DatasetError, saying what to run
    first, if the store does not exist, holds no run of the study or no ok run."""
    if store_missing(tracking_uri):  # (opening it would create an empty store)
        raise DatasetError(f"no MLflow store at {tracking_uri}: run `{study_command(study)}` first, whose runs "
                           f"train the surrogate, or point tracking.uri at the store that holds study '{study}'")
    runs = search_study_runs(tracking_uri, study)
    if not runs:
        raise DatasetError(f"no tracked runs of study '{study}' in {tracking_uri}: run "
                           f"`{study_command(study)}` first, or set train.study / tracking.uri")
    return build_dataset(study, runs, solver)


def solver_of(run) -> str:
    return str(run.data.params.get("solver.name", "unknown"))


def build_dataset(study: str, runs: list, solver: str | None = None) -> Dataset:
    """Split MLflow runs into the typed ``ok`` table and the excluded runs with their reasons. The runs
    of one solver train (``solver``, else the one the study's runs share): a study may hold the same
    scenes in 2D and 3D, which answer different questions; DatasetError when it holds several and
    none is named."""
    solvers = pd.Series([solver_of(r) for r in runs if r.data.tags.get("dsmv.status") == "ok"]).value_counts()
    if solver is None and len(solvers) > 1:
        raise DatasetError(f"study '{study}' holds runs of several solvers ("
                           + ", ".join(f"{n} ok of {name}" for name, n in solvers.items())
                           + "): name the one to train on with train.solver")
    if solver is not None:
        runs = [r for r in runs if solver_of(r) == solver]
        if not runs:
            raise DatasetError(f"study '{study}' has no run of solver {solver} (its solvers: "
                               f"{', '.join(solvers.index) or 'none ok'}): run `{study_command(study)} solver={solver}` "
                               f"first, or set train.solver")
    rows, excluded, seen, settings = [], [], {}, []
    for run in sorted(runs, key=lambda r: r.info.start_time or 0, reverse=True):  # latest first
        tags, info = run.data.tags, run.info
        status = tags.get("dsmv.status", "unknown")
        if info.status == "RUNNING":
            status = "running"
        elif info.status != "FINISHED" and status in ("ok", "running"):
            status = "failed"
        message = tags.get("dsmv.message", "")
        if status != "ok":
            excluded.append((info.run_id, status, message))
            continue
        key = tags.get("dsmv.config_hash")
        if key and key in seen:
            excluded.append((info.run_id, "duplicate", f"same scene as run {seen[key]}"))
            continue
        try:
            row = {"run_id": info.run_id}
            row |= {column: _number(run.data.params.get(key_), column) for column, key_ in PARAMETERS.items()}
            if TARGET_METRIC not in run.data.metrics:
                raise ValueError(f"metric {TARGET_METRIC} missing")
            row[TARGET_METRIC] = float(run.data.metrics[TARGET_METRIC])
        except ValueError as error:
            excluded.append((info.run_id, "unreadable", str(error)))
            continue
        if key:
            seen[key] = info.run_id
        rows.append(row)
        settings.append({override: run.data.params.get(param) for param, override in SETTING_GROUPS.items()})
    if not rows:
        counts = dict(sorted(pd.Series([e[1] for e in excluded]).value_counts().items(), key=lambda c: (-c[1], c[0])))
        raise DatasetError(f"study '{study}' has no ok run to train on ({len(runs)} runs: "
                           + ", ".join(f"{n} {s}" for s, n in counts.items())
                           + f"): a surrogate learns from ok runs only; run `{study_command(study)}` first "
                             "(each run's dsmv.message in MLflow says why it did not end ok)")
    table = pd.DataFrame(rows, columns=["run_id", *PARAMETERS, TARGET_METRIC])
    table = table.astype({c: np.float64 for c in [*PARAMETERS, TARGET_METRIC]})
    # canonical order (by content, not by run id): the same runs give the same splits and scores
    table = table.sort_values([*PARAMETERS, TARGET_METRIC], ignore_index=True)
    excluded_frame = pd.DataFrame(excluded, columns=["run_id", "status", "message"])
    shared = {override: settings[0][override] for override in SETTING_GROUPS.values()
              if settings[0][override] is not None and all(s[override] == settings[0][override] for s in settings)}
    return Dataset(study, table, excluded_frame, shared)
