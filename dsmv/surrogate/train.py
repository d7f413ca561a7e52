"""``dsmv-train``: train and evaluate one surrogate on a study's tracked runs, log it to MLflow.

Steps (the reference study's (I)–(IV)): read the ``ok`` runs of ``train.study`` into a hashed
dataset; build ``train.features``; split 90/10 (``train.test_fraction``, ``train.seed``); grid
search the surrogate's hyper-parameters by k-fold CV on the training split; fit the best on the
training split and score train and test (Table 5); 10-fold CV over the whole dataset (Figure 19);
``train.mc_splits`` random re-splits (Figure 20); Kendall τ (Figure 15), feature importance and
plots. The registered model is the one fitted on the training split, the one the test scores
describe. Outputs go to the Hydra run dir (``metrics.json``, ``summary.json``, CSVs, PNGs) and to
MLflow experiment ``dsmv-<train.experiment>``: the same metrics, params, the dataset and its
hash, the plots, and the model in its MLflow flavour, registered as ``surrogate.registered_model``.
"""

from __future__ import annotations

import functools
import json
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Callable, Literal, Optional

import numpy as np
import pandas as pd
from omegaconf import DictConfig
from pydantic import Field

from dsmv import registry
from dsmv.config.scene import _resolve, build_tracking
from dsmv.config.schema import Count, Number, Schema, _validate
from dsmv.errors import ConfigError
from dsmv.surrogate import evaluate
from dsmv.surrogate.base import Surrogate, SurrogateConfig
from dsmv.surrogate.dataset import PARAMETERS, TARGET_METRIC, Dataset, DatasetError, load_dataset, study_command
from dsmv.surrogate.fast_model import default_settings
from dsmv.surrogate.features import TARGET, FeatureSet, StudyFeatures, target
from dsmv.surrogate.intervals import (
    CALIBRATION_FILE, SCORE_BINS, ConformalRegressor, calibration_record, coverage_over_resplits,
)
from dsmv.surrogate.model import feature_set
from dsmv.tracking import runs
from dsmv.tracking.run_writer import experiment_id as find_experiment

METRICS_FILE = "metrics.json"
SUMMARY_FILE = "summary.json"
MIN_RUNS = 20  # fewer ok runs cannot give a 10 % test split and 10 folds of at least 2 rows
IMPLICIT_RANGE = 2.0  # the study set's implicit solve searches z in [0, IMPLICIT_RANGE·max z_train]


class TrainSettings(Schema):
    """The ``train`` block of ``conf/train.yaml``."""

    study: str = Field(description="study whose tracked runs train the surrogate (tag dsmv.study)")
    solver: Optional[str] = Field(None, description=(
        "the solver whose runs train (cel2d: the 2D section, cel3d: the 3D track, …); null: the one the "
        "study's runs share"))
    features: Literal["physics", "leak_free", "study"] = Field(description="feature set (dsmv.surrogate.features)")
    seed: Count = Field(ge=0, description="seed of the split, the folds and the estimator (-)")
    test_fraction: Number = Field(gt=0, lt=1, description="test share of the split (-), the study's 0.1")
    cv_folds: Count = Field(ge=2, description="folds of the cross-validation over the dataset (-)")
    mc_splits: Count = Field(ge=1, description="Monte Carlo re-splits (-), the study's 200")
    learning_curve_fractions: list[Annotated[float, Field(gt=0, le=1)]] = Field(
        description="learning curve: fractions of each fold's training runs to fit on (-); [] for none")
    n_jobs: Count = Field(ge=1, description="parallel fits (-)")
    experiment: str = Field(description="MLflow experiment dsmv-<experiment> of the surrogate runs")
    register_model: bool = Field(description="register the model in MLflow's model registry")
    implicit_points: Count = Field(ge=10, description="depths on which the study set's implicit equation is solved (-)")
    interval_confidence: Number = Field(0.9, gt=0, lt=1, description="level of the prediction intervals (-)")
    interval_method: Literal["auto", "pooled", "oob"] = Field(
        "auto", description="auto: out-of-bag residuals for bagged models (one fit), pooled cross-conformal otherwise")
    interval_folds: Count = Field(5, ge=2, description="folds of the pooled cross-conformal residuals (-)")
    interval_score: Literal["auto", "binned", "scaled", "absolute"] = Field(
        "auto", description="conformal score: binned (width ∝ the mean residual in bins of ŷ), scaled "
                            "(width a + b·ŷ, fitted), absolute (constant width in z/B), or auto: binned once "
                            "the training runs fill each bin, scaled before")


@dataclass
class Training:
    """Everything one training produced; :func:`log_to_mlflow` and the summary read it."""

    surrogate: Surrogate
    config: SurrogateConfig
    settings: TrainSettings
    dataset: Dataset
    features: FeatureSet
    estimator: Any  # fitted on the training split
    best_params: dict
    train_idx: np.ndarray
    test_idx: np.ndarray
    metrics: dict[str, float] = field(default_factory=dict)
    frames: dict[str, pd.DataFrame] = field(default_factory=dict)  # CSV outputs by file stem
    plots: list[Path] = field(default_factory=list)
    predictions: dict[str, np.ndarray] = field(default_factory=dict)
    calibration: dict | None = None  # the registered model's conformal record (dsmv-predict reads it)

    @property
    def make(self) -> Callable:
        """A factory of unfitted estimators with the chosen hyper-parameters."""
        return functools.partial(self.surrogate.make, **self.config.params, **self.best_params)

    def metadata(self) -> dict:
        """What a predictor needs besides the estimator: features, target, training ranges."""
        table = self.dataset.table
        return {
            "surrogate": self.config.name,
            "feature_set": self.features.name,
            "features": list(self.features.columns),
            "target": TARGET,
            "study": self.dataset.study,
            "dataset_hash": self.dataset.content_hash,
            "run_settings": self.dataset.settings,  # e.g. {"solver": "cel2d", "soil.law": "einav_randolph"}
            "implicit_z_max_m": float(IMPLICIT_RANGE * table[TARGET_METRIC].iloc[self.train_idx].max()),
            "ranges": {c: [float(table[c].min()), float(table[c].max())] for c in PARAMETERS
                       if table[c].notna().any()},
        } | self.features.metadata() | ({"conformal": self.calibration} if self.calibration else {})


def dataset_metadata(dataset: Dataset) -> dict:
    """What the feature sets take from the dataset: the physics set's fast model runs the law the
    dataset's runs shared."""
    law = dataset.settings.get("soil.law") or "einav_randolph"
    return {"fast_model": default_settings(dataset.settings.get("solver", "cel2d")) | {"law": law}}


def settings_from(cfg: DictConfig) -> tuple[TrainSettings, SurrogateConfig]:
    """Validate ``train`` and ``surrogate``; an unknown surrogate lists the installed ones."""
    settings = _validate(TrainSettings, _resolve(cfg.get("train")), "train")
    surrogate = _validate(SurrogateConfig, _resolve(cfg.get("surrogate")), "surrogate")
    registry.check_name("surrogates", surrogate.name, "surrogate.name")
    return settings, surrogate


def check_config(cfg: DictConfig) -> tuple[TrainSettings, SurrogateConfig, Surrogate]:
    """Everything a training can know is wrong before it reads a run, each mistake a one-line
    ConfigError: ``train`` and ``surrogate`` (:func:`settings_from`), tracking on, and each fixed and
    grid-searched hyper-parameter as the surrogate's regressor takes it (:meth:`Surrogate.check_params`).
    ``dsmv-train``'s command line runs it before Hydra creates the run dir (dsmv.app.command_line.APPS).
    Returns the settings and the surrogate plugin."""
    settings, config = settings_from(cfg)
    if not build_tracking(cfg).enabled:
        raise ConfigError("tracking.enabled", False, "dsmv-train reads tracked runs: use tracking=local or server")
    plugin = registry.load("surrogates", config.name, "surrogate.name")(seed=settings.seed, n_jobs=1)
    for key, value in config.params.items():
        problem = plugin.check_params({key: value})
        if problem:
            raise ConfigError(f"surrogate.params.{key}", value, problem)
    problem = plugin.check_params(config.params)
    if problem:
        raise ConfigError("surrogate.params", config.params, problem)
    for key, values in config.grid.items():
        if not values:
            raise ConfigError(f"surrogate.grid.{key}", values, "needs at least one value to search")
        for value in values:
            problem = plugin.check_params(config.params | {key: value})
            if problem:
                raise ConfigError(f"surrogate.grid.{key}", values, problem)
    return settings, config, plugin


def fit_and_evaluate(surrogate: Surrogate, config: SurrogateConfig, settings: TrainSettings,
                     dataset: Dataset) -> Training:
    """Grid search, fit, score (split, CV, Monte Carlo), importance and Kendall τ; no I/O."""
    table = dataset.table
    n = len(table)
    if n < MIN_RUNS:
        raise DatasetError(f"study '{dataset.study}' has {n} ok runs; dsmv-train needs at least {MIN_RUNS}: "
                           f"add runs with `{study_command(dataset.study)}` first")
    features = feature_set(settings.features, dataset_metadata(dataset))
    X, y = features.transform(table), target(table)
    train_idx, test_idx = evaluate.split(n, settings.test_fraction, settings.seed)
    base = functools.partial(surrogate.make, **config.params)
    folds = min(config.grid_cv_folds, len(train_idx))
    clock = time.perf_counter()
    best, grid_results = evaluate.grid_search(base, config.grid, X.iloc[train_idx], y[train_idx], folds,
                                              settings.seed, settings.n_jobs)
    result = Training(surrogate, config, settings, dataset, features, None, best, train_idx, test_idx)
    grid_s = time.perf_counter() - clock

    started = time.perf_counter()
    result.estimator = result.make().fit(X.iloc[train_idx], y[train_idx])
    fit_s = time.perf_counter() - started
    p_train, p_test = result.estimator.predict(X.iloc[train_idx]), result.estimator.predict(X.iloc[test_idx])
    metrics = {f"train_{k}": v for k, v in evaluate.scores(y[train_idx], p_train).items()}
    metrics |= {f"test_{k}": v for k, v in evaluate.scores(y[test_idx], p_test).items()}
    result.predictions = {"y_train": y[train_idx], "p_train": p_train, "y_test": y[test_idx], "p_test": p_test}

    extra = None
    if isinstance(features, StudyFeatures):  # the honest score: z solved, not given
        extra = functools.partial(_implicit_scores, features=features, table=table, y=y,
                                  points=settings.implicit_points)
        metrics |= extra(result.estimator, train_idx, test_idx)
    clock = time.perf_counter()
    cv = evaluate.cross_validation(result.make, X, y, settings.cv_folds, settings.seed, settings.n_jobs, extra)
    cv_s, clock = time.perf_counter() - clock, time.perf_counter()
    mc = evaluate.monte_carlo(result.make, X, y, settings.mc_splits, settings.test_fraction, settings.seed,
                              settings.n_jobs)
    mc_s = time.perf_counter() - clock
    metrics |= cv.summary("cv") | mc.summary("mc")
    clock = time.perf_counter()
    curve = evaluate.learning_curve(result.make, X, y, settings.learning_curve_fractions, settings.cv_folds,
                                    settings.seed, settings.n_jobs)
    metrics["learning_curve_s"] = time.perf_counter() - clock
    clock = time.perf_counter()
    metrics |= _intervals(result, X, y, settings)
    metrics["interval_s"] = time.perf_counter() - clock
    metrics |= {"grid_best_cv_r2": float(grid_results["mean_test_score"].max()) if len(grid_results) else np.nan,
                "grid_combinations": len(grid_results), "n_samples": n, "n_train": len(train_idx),
                "n_test": len(test_idx), "n_excluded": len(dataset.excluded), "fit_s": fit_s, "grid_s": grid_s,
                "cv_s": cv_s, "mc_s": mc_s}
    result.metrics = metrics
    importance = evaluate.feature_importance(result.estimator, features.columns)
    result.frames = {"grid_search": grid_results, "cv_folds": cv.frame, "monte_carlo": mc.frame,
                     "kendall_tau": evaluate.kendall_tau(X, y, TARGET),
                     "feature_importance": importance.rename("importance").to_frame(),
                     "learning_curve": curve}
    result.frames["_cv"], result.frames["_mc"] = cv.frame, mc.frame
    return result


def interval_method(result: "Training", settings: TrainSettings) -> str:
    """The conformal method: ``oob`` for bagged models (one fit per re-split), else ``pooled``."""
    if settings.interval_method != "auto":
        return settings.interval_method
    return "oob" if "oob_score" in result.make().get_params() else "pooled"


#: ``train.interval_score=auto`` bins the scores once the training runs give each of the SCORE_BINS bins this
#: many: a bin's mean residual is the scale its runs are divided by, and on fewer runs its own sampling error
#: fattens the scores' tail. Measured on the 3D Table 3 runs, random forest, 90 % intervals over 200
#: re-splits: 40 runs (4.5 a bin) binned over-cover, 0.978, scaled 0.931; 64 runs (7 a bin) both 0.941, binned
#: wider (0.087 against 0.062 in z/B); 128 runs binned 0.931 (thirds 0.95, 0.91, 0.93), scaled 0.917 (0.91, 0.96,
#: 0.89); 257 runs binned 0.914 and scaled 0.910 (on the 2D section's runs scaled left the shallow third at
#: 0.78: the intervals module's docstring)
BINNED_RUNS_PER_BIN = 8


def interval_score(training_runs: int, settings: TrainSettings) -> str:
    """The conformal score: the one asked, or for ``auto`` binned when the training runs fill each bin
    (:data:`BINNED_RUNS_PER_BIN`), scaled before."""
    if settings.interval_score != "auto":
        return settings.interval_score
    return "binned" if training_runs >= SCORE_BINS * BINNED_RUNS_PER_BIN else "scaled"


def _intervals(result: "Training", X, y, settings: TrainSettings) -> dict[str, float]:
    """Calibrate the registered model's intervals on the training split, and measure their
    coverage over the same Monte Carlo re-splits as ``mc_r2``."""
    method = interval_method(result, settings)
    c = settings.interval_confidence
    train = result.train_idx
    score = interval_score(len(train), settings)
    conformal = ConformalRegressor(result.make, settings.interval_folds, c, method, settings.seed, score)
    result.calibration = calibration_record(conformal.fit(X.iloc[train], y[train]), TARGET)
    coverage = coverage_over_resplits(result.make, X, y, settings.mc_splits, settings.test_fraction, c,
                                      settings.seed, settings.interval_folds, method, score)
    shallow, middle, deep = coverage.by_tercile
    return {"interval_coverage_mean": coverage.mean, "interval_coverage_band_low": coverage.band[0],
            "interval_coverage_band_high": coverage.band[1], "interval_width_mean": coverage.mean_width,
            "interval_coverage_shallow": shallow, "interval_coverage_middle": middle,
            "interval_coverage_deep": deep, "interval_confidence": c}


def _implicit_scores(model, train, test, *, features: StudyFeatures, table, y, points) -> dict[str, float]:
    """The study set with z solved from its implicit equation on the test rows (z/B scores)."""
    rows = table.iloc[test]
    solve = features.solve(model, rows, IMPLICIT_RANGE * table[TARGET_METRIC].iloc[train].max(), points)
    z_over_b = solve.sinkage_m / rows["width_m"].to_numpy(float)
    out = {f"implicit_{k}": v for k, v in evaluate.scores(y[test], z_over_b).items()}
    out["implicit_solved_fraction"] = float(solve.solved.mean())
    out["implicit_multiple_roots_fraction"] = float((solve.n_roots > 1).mean())
    return out


def write_outputs(result: Training, run_dir: Path) -> list[Path]:
    """metrics.json, summary.json, the dataset, the CSV tables and the plots, into ``run_dir``."""
    run_dir.mkdir(parents=True, exist_ok=True)
    files = result.dataset.save(run_dir)
    for stem, frame in result.frames.items():
        if not stem.startswith("_") and len(frame):
            path = run_dir / f"{stem}.csv"
            frame.to_csv(path, index=stem in ("kendall_tau", "feature_importance"))
            files.append(path)
    pred = result.predictions
    label = "z/B"
    result.plots = [
        evaluate.plot_kendall(result.frames["kendall_tau"], run_dir / "kendall_tau.png"),
        evaluate.plot_predicted(pred["y_train"], pred["p_train"], pred["y_test"], pred["p_test"],
                                run_dir / "predicted_vs_true.png", label),
        evaluate.plot_resampled(evaluate.Resampled(result.frames["_cv"]), evaluate.Resampled(result.frames["_mc"]),
                                run_dir / "cv_and_monte_carlo.png"),
        evaluate.plot_importance(result.frames["feature_importance"]["importance"], run_dir / "feature_importance.png"),
    ]
    if len(result.frames["learning_curve"]):
        result.plots.append(evaluate.plot_learning_curve(result.frames["learning_curve"], run_dir / "learning_curve.png"))
    if len(result.frames["grid_search"]):
        curves = evaluate.grid_curves(result.frames["grid_search"])
        result.plots.append(evaluate.plot_grid_curves(curves, run_dir / "grid_search.png"))
    files += result.plots
    (run_dir / METRICS_FILE).write_text(json.dumps(result.metrics, indent=2, sort_keys=True) + "\n")
    summary = {"best_params": result.best_params, "excluded": result.dataset.excluded_counts,
               **result.metadata()}
    (run_dir / SUMMARY_FILE).write_text(json.dumps(summary, indent=2, default=str) + "\n")
    if result.calibration:  # dsmv-predict reads it back from the run's artifacts
        (run_dir / CALIBRATION_FILE).write_text(json.dumps(result.calibration) + "\n")
        files.append(run_dir / CALIBRATION_FILE)
    return [run_dir / METRICS_FILE, run_dir / SUMMARY_FILE, *files]


def log_to_mlflow(result: Training, cfg: DictConfig, files: list[Path]) -> dict[str, str]:
    """One MLflow run: params, metrics, dataset hash, files, and the model (registered)."""
    import mlflow

    from dsmv.surrogate.serving import scene_frame

    settings = build_tracking(cfg)
    client = runs._client(settings)
    experiment_id = find_experiment(client, runs.experiment_name(result.settings.experiment), settings.artifact_location)
    mlflow.set_tracking_uri(client.tracking_uri)
    tags = {"dsmv.study": result.dataset.study, "dsmv.role": "surrogate", "dsmv.surrogate": result.config.name,
            "dsmv.features": result.features.name, "dsmv.dataset_hash": result.dataset.content_hash,
            "dsmv.status": "ok"}
    run_name = f"{result.config.name} {result.features.name} on {result.dataset.study}"
    with mlflow.start_run(experiment_id=experiment_id, run_name=run_name, tags=tags) as run:
        params = runs.flatten({"train": result.settings.model_dump(), "surrogate": result.config.model_dump(),
                                   "best": result.best_params})
        params["dataset_hash"] = result.dataset.content_hash
        mlflow.log_params({k: v[:6000] for k, v in params.items()})
        mlflow.log_metrics({k: float(v) for k, v in result.metrics.items() if np.isfinite(v)})
        for path in files:
            mlflow.log_artifact(str(path))
        registered = result.config.registered_model if result.settings.register_model else None
        example = scene_frame(result.dataset.table.head(3))
        info = result.surrogate.log_model(result.estimator, "model", registered, example, result.metadata())
    version = getattr(info, "registered_model_version", None)
    if registered and version is not None:
        for key, value in (("feature_set", result.features.name), ("dataset_hash", result.dataset.content_hash)):
            client.set_model_version_tag(registered, str(version), key, value)
    return {"uri": client.tracking_uri, "experiment": runs.experiment_name(result.settings.experiment),
            "run_id": run.info.run_id, "model": f"{registered} v{version}" if registered else info.model_uri}


def run_training(cfg: DictConfig, run_dir: Path) -> Training:
    """``dsmv-train``: validate, load, fit and evaluate, write, log, print the summary."""
    started = time.perf_counter()
    settings, config, plugin = check_config(cfg)
    dataset = load_dataset(build_tracking(cfg).uri, settings.study, settings.solver)
    result = fit_and_evaluate(plugin, config, settings, dataset)
    result.metrics["train_wall_s"] = time.perf_counter() - started
    files = write_outputs(result, run_dir)
    logged = log_to_mlflow(result, cfg, files)
    print_summary(result, run_dir, logged, time.perf_counter() - started)
    return result


def print_summary(result: Training, run_dir: Path, logged: dict, wall_s: float) -> None:
    m, d = result.metrics, result.dataset
    excluded = ", ".join(f"{n} {s}" for s, n in d.excluded_counts.items()) or "none"
    print(f"\ndsmv-train: {result.config.name} on {result.features.name} features, study {d.study}: "
          f"{len(d.table)} ok runs (excluded: {excluded}), dataset {d.content_hash}")
    print(f"  best     : {result.best_params or result.config.params} "
          f"({m['grid_combinations']} combinations, best CV R² {m['grid_best_cv_r2']:.4f})")
    print(f"  z/B R²   : test {m['test_r2']:.4f} (train {m['train_r2']:.4f}), "
          f"{result.settings.cv_folds}-fold {m['cv_r2_mean']:.4f} ± {m['cv_r2_std']:.4f}, "
          f"{result.settings.mc_splits} re-splits {m['mc_r2_mean']:.4f} ± {m['mc_r2_std']:.4f}")
    if "implicit_r2" in m:
        print(f"  implicit : z solved from the study's equation: test R² {m['implicit_r2']:.4f}, "
              f"root found for {m['implicit_solved_fraction']:.0%}, "
              f"several roots for {m['implicit_multiple_roots_fraction']:.0%} "
              f"(CV {m['cv_implicit_r2_mean']:.4f})")
    print(f"  outputs  : {run_dir}  ({METRICS_FILE}, {wall_s:.0f} s)")
    print(f"  MLflow   : {logged['uri']}  (experiment {logged['experiment']}, run {logged['run_id']}, "
          f"model {logged['model']})")


__all__ = ["run_training", "check_config", "fit_and_evaluate", "Training", "TrainSettings", "METRICS_FILE"]
