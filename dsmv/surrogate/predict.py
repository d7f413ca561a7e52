"""``dsmv-predict``: sinkage of a scene with its conformal interval, and the inverse question.

    dsmv-predict                                           # default scene, latest dsmv-sinkage-rf
    dsmv-predict soil.su0_pa=1500 landing.velocity_m_s=2 surrogate=xgboost
    dsmv-predict task=max_velocity sinkage_limit_m=0.3 confidence=0.9
    dsmv-predict task=min_contact_length sinkage_limit_m=0.3
    dsmv-predict csv=scenes.csv                            # → scenes_predictions.csv beside it

The scene is composed and validated like ``dsmv``'s (``conf/predict.yaml`` has the same scene
groups), turned into a dataset row (:func:`dsmv.surrogate.model.scene_table`) and fed to the
registered model ``surrogate.registered_model`` (:func:`dsmv.surrogate.model.load_registered`).

Intervals (:mod:`dsmv.surrogate.intervals`, pooled cross-conformal): the model's MLflow run
carries the out-of-fold conformal scores of its training data, either in the model metadata
under ``conformal`` or as the run artifact ``conformal.json`` (the record written by
:func:`dsmv.surrogate.intervals.calibration_record`)::

    {"method": "out_of_bag_pooled", "target": "z_over_b", "folds": 5, "seed": 0, "n": 231,
     "score": "scaled", "scale_intercept": 0.008, "scale_slope": 0.09,
     "residuals": [...n floats, |y − ŷ₋ₖ| / (scale_intercept + scale_slope·|ŷ₋ₖ|)...], "quantiles": {...}}

With q the ⌈c·(n+1)⌉-th smallest score and ``target = z_over_b``, the interval of z is
``B·(ŷ ± q·(scale_intercept + scale_slope·ŷ))`` for the scaled score (dsmv-train's default: the
width grows with the predicted sinkage, as the surrogates' errors do) and ``B·(ŷ ± q)`` for the absolute one
(records without ``score`` are absolute). The lower bound is clipped at 0 m (a sinkage is never
negative; clipping cannot lose coverage). Without a calibration the sinkage is printed without an
interval, and the inverse tasks (which need upper bounds) stop with a one-line error. The calibration
and the predictor are :mod:`dsmv.surrogate.predictor`'s (the served model uses them too); the
console script is :func:`dsmv.app.cli.predict`.

User mistakes (no store, no registered model, no calibration for an inverse task, unknown
task, a limit ≤ 0, a bad CSV) end in one line ``dsmv-predict: error: …`` and exit status 2.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from pathlib import Path
from typing import Literal

import numpy as np
import pandas as pd
from omegaconf import DictConfig, OmegaConf
from pydantic import Field

from dsmv.analytic.landing_model import LARGEST_SINKAGE_WIDTHS
from dsmv.analytic.vehicle import check_vehicle_scene
from dsmv.config.profile import refuse_a_bent_profile, refuse_a_layered_density, refuse_a_layered_law
from dsmv.config.scene import _resolve, build_scene, build_tracking
from dsmv.config.schema import Count, Number, Schema, _validate
from dsmv.errors import ConfigError, DsmvError
from dsmv.surrogate.dataset import COLUMNS, PARAMETERS
from dsmv.surrogate.evaluate import pyplot
from dsmv.surrogate.fast_model import fast_sinkage
from dsmv.surrogate.intervals import CALIBRATION_FILE
from dsmv.surrogate.inverse import GOALS, TASK_PARAMETERS, InverseResult, solve_inverse
from dsmv.surrogate.model import TrainedSurrogate, scene_table
from dsmv.surrogate.predictor import CALIBRATION_KEY, PredictError, Predictor, load_predictor
from dsmv.surrogate.reliability import exceedance, sample_scenes, uncertainty_from
from dsmv.surrogate.vehicle_exceedance import check_uncertain, fast_model_exceedance

PROG = "dsmv-predict"


class SearchSettings(Schema):
    low: Number | None = Field(None, description="low end of the searched range (parameter units); null: training min")
    high: Number | None = Field(None, description="high end (parameter units); null: training max")
    points: Count = Field(101, ge=3, description="grid points and subdivisions per refinement round (-)")


class PredictSettings(Schema):
    """The top-level keys of ``conf/predict.yaml``."""

    task: Literal["predict", "max_velocity", "min_contact_length", "exceedance"] = Field(description="what to answer")
    sinkage_limit_m: Number | None = Field(None, gt=0, description="limit on the upper bound of z (m)")
    confidence: Number = Field(0.9, gt=0, lt=1, description="two-sided interval level (-)")
    csv: str | None = Field(None, description="CSV of scenes to predict in bulk")
    model_version: str = Field("latest", description="registered model version")
    search: SearchSettings = Field(default_factory=SearchSettings)
    plot: bool = Field(True, description="inverse tasks: write inverse.png into the run dir")
    verify: bool = Field(True, description="inverse tasks: check the answer with the CEL (and 20 % beyond it), "
                                           "refined by CEL bisection when it fails")
    refine_tolerance: Number = Field(0.02, gt=0, lt=1, description="CEL bisection: stop when the bracket is this "
                                                                   "fraction of the answer (-)")
    spot_checks: list[Number] = Field(default_factory=lambda: [0.5, 0.9], description="exceedance with verify: "
                                      "the CEL at the samples nearest these quantiles of the predicted sinkage (-)")


def settings_from(cfg: DictConfig) -> PredictSettings:
    """Validate the prediction keys; the task and the limit must fit together."""
    container = OmegaConf.to_container(cfg, resolve=False)
    data = {k: container.get(k) for k in PredictSettings.model_fields if k in container}
    try:
        settings = _validate(PredictSettings, data, "")
    except ConfigError as error:  # paths are top-level keys: "task", not ".task"
        raise ConfigError(error.path.lstrip("."), error.value, error.allowed) from None
    if settings.task != "predict" and settings.sinkage_limit_m is None:
        raise ConfigError("sinkage_limit_m", None, f"task={settings.task} needs a limit (m) > 0, "
                                                   "e.g. sinkage_limit_m=0.3")
    return settings


# ----------------------------------------------------------------------------- tables and CSV


def csv_table(path: Path, base: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(the CSV as read, its dataset table): columns named like PARAMETERS or their config keys
    (``velocity_m_s`` or ``landing.velocity_m_s``); a parameter the CSV lacks comes from ``base``."""
    if not path.is_file():
        raise PredictError(f"csv = {str(path)!r}: no such file")
    try:
        frame = pd.read_csv(path)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as error:
        raise PredictError(f"csv = {str(path)!r}: not a readable CSV ({str(error).splitlines()[0]})") from None
    table = pd.DataFrame({c: np.repeat(base[c].to_numpy(float), len(frame)) for c in PARAMETERS})
    for column in frame.columns:
        key = COLUMNS.get(column, column)
        name = column if column in PARAMETERS else COLUMNS.get(column)
        if name is None:
            continue  # an id or a note: carried through to the output untouched
        values = pd.to_numeric(frame[column], errors="coerce").to_numpy(float)
        bad = np.flatnonzero(~np.isfinite(values) & ~(name == "inertial_mass_kg" and frame[column].isna()))
        if len(bad):
            raise PredictError(f"csv {path.name}: column {column} ({key}) row {int(bad[0]) + 2} "
                               f"= {frame[column].iloc[bad[0]]!r}: must be a number")
        table[name] = values
    return frame, table


def _outside_text(model: TrainedSurrogate, outside: dict[str, list[int]], table: pd.DataFrame, rows=None) -> str:
    parts = []
    for column, idx in outside.items():
        lo, hi = model.metadata["ranges"][column]
        if rows is None:
            value = table[column].iloc[idx[0]]
            parts.append(f"{PARAMETERS[column]} = {value:g} not in [{lo:g}, {hi:g}]")
        else:
            parts.append(f"{PARAMETERS[column]} ({len(idx)} rows) outside [{lo:g}, {hi:g}]")
    return "; ".join(parts)


# ----------------------------------------------------------------------------- plot


def plot_band(values, mid, lower, upper, parameter: str, confidence: float, path: Path,
              sinkage_limit_m: float | None = None, answer: float | None = None,
              training_range: tuple[float, float] | None = None, title: str = "") -> Path:
    """Predicted sinkage (m) and its interval against one parameter, for descent planning.

    Depth is drawn downwards (the seabed at the top, as the vehicle sees it); the limit is a
    horizontal line, the answer of the inverse question a vertical one, and the parameter values
    outside the training data are hatched (extrapolation).
    """
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.2), constrained_layout=True)
    ax.fill_between(values, lower, upper, color="tab:blue", alpha=0.25, lw=0,
                    label=f"{confidence:.0%} interval")
    ax.plot(values, mid, color="tab:blue", lw=1.8, label="predicted sinkage")
    if sinkage_limit_m is not None:
        ax.axhline(sinkage_limit_m, color="tab:red", ls="--", lw=1.4, label=f"limit {sinkage_limit_m:g} m")
    if answer is not None and math.isfinite(answer):
        ax.axvline(answer, color="k", ls=":", lw=1.4, label=f"answer {answer:.4g}")
    if training_range is not None:
        lo, hi = training_range
        spans = [(a, b) for a, b in ((min(values), lo), (hi, max(values))) if b > a]
        for i, (a, b) in enumerate(spans):
            ax.axvspan(a, b, facecolor="none", edgecolor="0.6", hatch="//", lw=0,
                       label="outside training data" if i == 0 else None)
    ax.set_xlabel(parameter)
    ax.set_ylabel("sinkage z (m)")
    ax.set_ylim(bottom=0.0)
    ax.invert_yaxis()
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower left")
    ax.set_title(title, fontsize=9)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)
    return Path(path)


# ----------------------------------------------------------------------------- the app


def _search_range(settings: PredictSettings, predictor: Predictor, parameter: str) -> tuple[float, float]:
    trained = predictor.model.metadata.get("ranges", {}).get(COLUMNS[parameter])
    low = settings.search.low if settings.search.low is not None else (trained[0] if trained else None)
    high = settings.search.high if settings.search.high is not None else (trained[1] if trained else None)
    if low is None or high is None:
        raise ConfigError("search", [low, high], f"the model has no training range of {parameter}: set search.low and "
                                                 "search.high")
    if not low < high:
        raise ConfigError("search", [low, high], "must have low < high")
    return float(low), float(high)


#: dsmv-predict's own settings and the stores it reads: any value
PREDICT_KEYS = ("task", "sinkage_limit_m", "confidence", "csv", "model_version", "search", "plot", "verify",
                "refine_tolerance", "spot_checks", "surrogate", "tracking", "paths", "uncertainty", "study", "hydra")
#: groups chosen whole (a soil profile, a landing, a body): their values are read as the model's inputs
SCENE_GROUPS = ("soil", "landing", "geometry")


def run_settings(predictor: Predictor) -> dict:
    """What the model's training runs computed: their shared solver, soil law and mesh (a model trained
    before they were recorded: the 2D section's)."""
    return predictor.model.metadata.get("run_settings") or {"solver": "cel2d"}


def describe_runs(settings: dict) -> str:
    """What a model predicts, in words: '3D track, grouser tips, cel3d coarse, einav_randolph'."""
    solver = settings.get("solver", "?")
    what = {"cel3d": "3D track, grouser tips", "cel2d": "2D cross-section"}.get(solver, "track")
    mesh = f" {settings['mesh']}" if settings.get("mesh") else ""
    return f"{what}, {solver}{mesh}, {settings.get('soil.law', 'soil law not recorded')}"


def check_overrides(predictor: Predictor, overrides: list[str]) -> None:
    """Refuse, as a ConfigError, an override the model cannot honour: another solver, soil law or mesh
    than its runs', a scene key that is not one of its inputs, or an input it was trained on one value of."""
    settings, ranges = run_settings(predictor), predictor.model.metadata.get("ranges", {})
    fixed = {"solver": "solver", "solver.name": "solver", "soil.law": "soil.law", "mesh": "mesh", "mesh.name": "mesh"}
    varied = [PARAMETERS[c] for c in PARAMETERS if c in ranges and ranges[c][0] < ranges[c][1]]
    for override in overrides:
        key, _, value = override.lstrip("+~").partition("=")
        if key.split(".")[0] in PREDICT_KEYS or key in SCENE_GROUPS:
            continue
        if key in fixed:
            if value == str(settings.get(fixed[key])):
                continue
            raise ConfigError(key, value, f"the model predicts {describe_runs(settings)} runs; for {key}={value} "
                                          f"train one on such runs (dsmv-train train.solver=…)")
        column = COLUMNS.get(key)
        if column is not None and column in ranges:
            low, high = ranges[column]
            if low < high or _same(value, low):
                continue
            raise ConfigError(key, value, f"the model was trained on {key} = {low:g} only, so it cannot say what "
                                          f"another value does")
        raise ConfigError(key, value, f"not an input of the model, which varies {', '.join(varied)}")


def _same(text: str, number: float) -> bool:
    try:
        return float(text) == number
    except ValueError:
        return False


def check_command(predictor: Predictor, base: pd.DataFrame, key: str, value: float) -> str:
    """The ``dsmv`` command of a CEL run of the scene with ``key = value``, of the kind the model
    was trained on: its runs' shared solver, soil law and mesh, and every scene parameter the
    training data vary, written out (what the surrogate saw is what CEL gets)."""
    settings, ranges = run_settings(predictor), predictor.model.metadata.get("ranges", {})
    parts = [f"{k}={v}" for k, v in settings.items()]
    for column, config_key in PARAMETERS.items():
        varied = column in ranges and ranges[column][0] < ranges[column][1]
        if config_key != key and varied:
            parts.append(f"{config_key}={float(base[column].iloc[0]):.6g}")
    return "dsmv " + " ".join([*parts, f"{key}={value:.4g}"])


#: "20 % beyond the answer", on the unsafe side: faster, or a shorter track
BEYOND = {"landing.velocity_m_s": 1.2, "geometry.contact_length_m": 1.0 / 1.2}


def cel_check(predictor: Predictor, base: pd.DataFrame, parameter: str, value: float, limit: float,
              folder: Path) -> dict:
    """One CEL run (``dsmv``, as :func:`check_command` writes it) of the scene with ``parameter = value``
    into ``folder``: its status and max sinkage against the limit."""
    import subprocess

    command = check_command(predictor, base, parameter, value).split()[1:]
    completed = subprocess.run([str(Path(sys.executable).parent / "dsmv"), *command, "output.plots=false",
                                "solver.progress=off", f"hydra.run.dir={folder}"], capture_output=True, text=True)
    try:
        answer = json.loads((folder / "result.json").read_text())
    except (OSError, ValueError):
        last = ((completed.stderr or completed.stdout).strip().splitlines() or ["no output"])[-1]
        raise PredictError(f"the CEL check at {parameter} = {value:.4g} did not finish "
                           f"(exit {completed.returncode}): {last}") from None
    sinkage = answer["metrics"].get("max_sinkage_m", math.nan)
    return {"value": value, "status": answer["status"], "max_sinkage_m": sinkage,
            "under_limit": bool(answer["status"] == "ok" and sinkage <= limit), "run_dir": str(folder)}


def verify_answer(predictor: Predictor, base: pd.DataFrame, result: InverseResult, run_dir: Path,
                  safe_end: float, tolerance: float) -> dict:
    """Check the surrogate's answer with the CEL; when the CEL at the answer is over the limit, bisect
    with the CEL between the searched range's safe end and the answer until the bracket is
    ``tolerance`` of the answer. Then the CEL 20 % beyond the answer found, on the unsafe side.
    Returns the CEL's answer (NaN when even the safe end fails), how it was found, and every run."""
    parameter, limit = result.parameter, result.sinkage_limit_m
    runs = []

    def run(value: float, role: str) -> dict:
        check = cel_check(predictor, base, parameter, value, limit, run_dir / f"check_{len(runs)}") | {"role": role}
        runs.append(check)
        return check

    answer, how = result.value, "the surrogate's answer holds"
    if not run(answer, "answer")["under_limit"]:
        if not run(safe_end, "safe end")["under_limit"]:
            return {"value": math.nan, "how": f"no value passes: the CEL at the safe end {safe_end:.4g} is over the "
                                              "limit too", "cel_runs": len(runs), "checks": runs}
        safe, unsafe = safe_end, answer  # bisection on the CEL itself, from the surrogate's bracket
        while abs(unsafe - safe) > tolerance * abs(answer):
            middle = 0.5 * (safe + unsafe)
            if run(middle, "bisection")["under_limit"]:
                safe = middle
            else:
                unsafe = middle
        answer, how = safe, f"refined by CEL bisection to {tolerance:.0%} (the surrogate's answer was over the limit)"
    run(answer * BEYOND[parameter], "20 % beyond")
    return {"value": answer, "how": how, "cel_runs": len(runs), "checks": runs}


def _print_checks(verified: dict, result: InverseResult) -> None:
    limit = result.sinkage_limit_m
    for check in verified["checks"]:
        where = f"{check['role']} ({result.parameter} = {check['value']:.4g})"
        if check["status"] != "ok":
            print(f"  verify   : CEL {where}: {check['status']}")
            continue
        verdict = "≤" if check["under_limit"] else ">"
        print(f"  verify   : CEL {where}: max sinkage {check['max_sinkage_m']:.4f} m {verdict} {limit:g} m")
    value = "none" if math.isnan(verified["value"]) else f"{result.parameter} = {verified['value']:.4g}"
    print(f"  CEL      : {value}: {verified['how']} ({verified['cel_runs']} CEL runs)")


def _print_inverse(result: InverseResult, predictor: Predictor, confidence: float, base: pd.DataFrame) -> None:
    key, limit = result.parameter, result.sinkage_limit_m
    word = "largest" if GOALS[key] == "max" else "smallest"
    if result.status == "no_value_passes":
        safe = result.grid[0] if GOALS[key] == "max" else result.grid[-1]
        print(f"  answer   : none: even {key} = {safe:g} gives an upper bound over {limit:g} m "
              f"({confidence:.0%} confidence)")
        return
    print(f"  answer   : {word} {key} = {result.value:.4g} with upper bound {result.upper_at_value:.4f} m "
          f"≤ {limit:g} m ({confidence:.0%} confidence)")
    if result.status == "whole_range_passes":
        print(f"  note     : the whole searched range passes: the limit lies beyond {result.value:g}, "
              "where the surrogate has no training data (widen search.low/high at your own risk)")
    if not result.monotone:
        print(f"warning: the predicted upper bound is not monotone in {key} over the range: "
              "the answer is the first crossing from the safe end (conservative)")
    print(f"  check    : {check_command(predictor, base, key, result.value)}")


def exceedance_answer(cfg: DictConfig, settings: PredictSettings, predictor: Predictor, base: pd.DataFrame,
                      run_dir: Path | None) -> dict:
    """``task=exceedance``: P(z > limit) over the ``uncertainty`` group's samples (dsmv.surrogate.reliability),
    its sinkage distribution drawn, and CEL runs at chosen quantiles of it (``verify``)."""
    limit, c = settings.sinkage_limit_m, settings.confidence
    uncertainty = uncertainty_from(OmegaConf.to_container(cfg, resolve=True))
    table = sample_scenes(base, uncertainty)
    mid, lower, upper = predictor.interval(table, c)
    answer = exceedance(mid, lower, upper, limit)
    print(f"  exceed   : P(z > {limit:g} m) = {answer.probability:.4f} ± {answer.monte_carlo_error:.4f} (Monte Carlo, "
          f"{answer.samples} samples); {answer.model_low:.4f} to {answer.model_high:.4f} on the {c:.0%} interval's bounds")
    outside = predictor.model.out_of_range(table)
    if outside:
        rows = len(set().union(*outside.values()))
        print(f"warning: {rows} of {len(table)} samples lie outside the training data "
              f"({', '.join(PARAMETERS[k] for k in outside)})")
    out = {"exceedance_probability": answer.probability, "monte_carlo_error": answer.monte_carlo_error,
           "model_low": answer.model_low, "model_high": answer.model_high, "samples": answer.samples,
           "sinkage_limit_m": limit, "uncertain": sorted(uncertainty.keys)}
    if settings.plot and run_dir is not None:
        run_dir.mkdir(parents=True, exist_ok=True)
        out["plot"] = str(plot_exceedance(mid, lower, upper, limit, answer, c, run_dir / "exceedance.png",
                                          predictor.describe()))
        print(f"  plot     : {out['plot']}")
    if settings.verify:
        key = uncertainty.keys[0]
        checks = []
        for quantile in settings.spot_checks:
            row = int(np.argmin(np.abs(mid - np.quantile(mid, quantile))))
            scene = table.iloc[[row]].reset_index(drop=True)
            folder = (run_dir or Path.cwd() / "predict_checks") / f"check_{len(checks)}"
            check = cel_check(predictor, scene, key, float(scene[COLUMNS[key]].iloc[0]), limit, folder)
            checks.append(check | {"quantile": quantile, "predicted_m": float(mid[row]), "lower_m": float(lower[row]),
                                   "upper_m": float(upper[row])})
            within = lower[row] <= check["max_sinkage_m"] <= upper[row]
            print(f"  verify   : CEL at the {quantile:.0%} quantile: max sinkage {check['max_sinkage_m']:.4f} m, "
                  f"predicted {mid[row]:.4f} m [{lower[row]:.4f}, {upper[row]:.4f}]: "
                  f"{'within' if within else 'outside'} the interval")
        out["verify"] = checks
    return out


def plot_exceedance(mid, lower, upper, limit: float, answer, confidence: float, path: Path,
                    model: tuple[str, ...] = ()) -> Path:
    """The predicted sinkage's distribution over the samples, the interval bounds' beside it, the limit;
    the title names the model that predicted it (``model``: :meth:`Predictor.describe`'s lines)."""
    plt = pyplot()

    fig, ax = plt.subplots(figsize=(6.5, 4.2), constrained_layout=True)
    bins = np.linspace(0.0, max(float(np.quantile(upper, 0.999)), limit) * 1.05, 60)
    ax.hist(mid, bins=bins, color="tab:blue", alpha=0.7, label="predicted")
    ax.hist(lower, bins=bins, histtype="step", color="tab:green", label=f"lower bound ({confidence:.0%})")
    ax.hist(upper, bins=bins, histtype="step", color="tab:red", label=f"upper bound ({confidence:.0%})")
    ax.axvline(limit, color="k", linestyle="--", label=f"limit {limit:g} m")
    ax.set(xlabel="max sinkage (m)", ylabel=f"samples (of {answer.samples})")
    ax.set_title("\n".join([*model, f"P(z > {limit:g} m) = {answer.probability:.3f} ± {answer.monte_carlo_error:.3f}, "
                                     f"{answer.model_low:.3f} to {answer.model_high:.3f} on the bounds"]), fontsize=9)
    ax.legend()
    fig.savefig(path, dpi=120, bbox_inches="tight")  # the title's lines whole
    plt.close(fig)
    return path


def landed_by_the_fast_model(scene) -> bool:
    """Whether an exceedance of this scene lands its samples by a fast model rather than a registered
    surrogate: a vehicle's, or one track's on a strength table that is not one straight line."""
    return scene.geometry.vehicle or scene.soil.bent_strength is not None


def check_config(cfg: DictConfig) -> tuple[PredictSettings, object]:
    """Everything a prediction can know is wrong before it loads the model, each mistake a one-line
    ConfigError: the prediction's keys (:func:`settings_from`), tracking on, the scene (as ``dsmv`` builds
    it) and, for ``task=exceedance``, the ``uncertainty`` group. ``dsmv-predict``'s command line runs it
    before Hydra creates the run dir (dsmv.app.command_line.APPS). Returns the settings and the scene."""
    settings = settings_from(cfg)
    scene = build_scene(cfg)
    refuse_a_layered_law(scene.soil, "dsmv-predict")
    refuse_a_layered_density(scene.soil, "dsmv-predict")
    if scene.geometry.vehicle:  # the fast vehicle model lands its samples: no registered model
        if settings.task != "exceedance":
            raise ConfigError("task", settings.task, "a vehicle scene answers task=exceedance (the fast vehicle "
                              "model over the uncertainty's samples); land it once with solver=analytic_dynamic_3d "
                              "or cel3d")
        check_vehicle_scene(scene)
    elif settings.task != "exceedance":  # one track on a table: its exceedance is the fast landing model's
        refuse_a_bent_profile(scene.soil, "the surrogates (trained on straight-line soils; task=exceedance lands a "
                                          "table by the fast model)")
    if landed_by_the_fast_model(scene):
        check_uncertain(uncertainty_from({"uncertainty": _resolve(cfg.get("uncertainty"))}).keys,
                        table_soil=scene.soil.profile is not None)
        return settings, scene
    if not build_tracking(cfg).enabled:
        raise ConfigError("tracking.enabled", False, "dsmv-predict reads the registered model: use tracking=local or server")
    if settings.task == "exceedance":
        keys = uncertainty_from({"uncertainty": _resolve(cfg.get("uncertainty"))}).keys
        if "soil.profile_scale" in keys:
            raise ConfigError("uncertainty.soil.profile_scale", "a distribution", "scales a strength table "
                              "(soil.profile); a straight line su0 + ks·z draws soil.su0_pa and soil.ks_pa_per_m")
    return settings, scene


def run_predict(cfg: DictConfig, run_dir: Path | None = None, overrides: list[str] = ()) -> dict:
    """Validate, load, predict (one scene, a CSV, or the inverse question), print; return the answer.
    ``overrides`` (the command line's) are held against what the model can honour (:func:`check_overrides`)."""
    settings, scene = check_config(cfg)
    base = scene_table([scene])
    if landed_by_the_fast_model(scene):
        table = sample_scenes(base, uncertainty_from(OmegaConf.to_container(cfg, resolve=True)))
        answer = fast_model_exceedance(scene, table, settings.sinkage_limit_m, run_dir, settings.plot, PROG)
        return write_answer({"task": settings.task} | answer, run_dir)
    tracking = build_tracking(cfg)
    name = str(cfg.surrogate.registered_model)

    started = time.perf_counter()
    predictor = load_predictor(name, tracking.uri, settings.model_version)
    load_s = time.perf_counter() - started
    meta = predictor.model.metadata
    c = settings.confidence
    print(f"{PROG}: {name} v{predictor.version} ({meta.get('feature_set')} features, "
          f"dataset {meta.get('dataset_hash')}), loaded in {load_s:.2f} s")
    print(f"  predicts : {describe_runs(run_settings(predictor))}")
    check_overrides(predictor, list(overrides))
    if predictor.calibration is None:
        message = (f"model run {predictor.run_id} has no interval calibration ({CALIBRATION_FILE} or metadata "
                   f"'{CALIBRATION_KEY}'): retrain it with a dsmv-train that logs one")
        if settings.task != "predict":
            raise PredictError(f"task={settings.task} needs upper bounds, but the {message}")
        print(f"warning: {message}; no interval")
    out: dict = {"model": name, "version": predictor.version, "run_id": predictor.run_id, "confidence": c,
                 "task": settings.task}

    if settings.csv is not None:
        path = Path(settings.csv).expanduser()
        frame, table = csv_table(path, base)
        started = time.perf_counter()
        mid, lower, upper = predictor.interval(table, c)
        outside = predictor.model.out_of_range(table)
        predict_s = time.perf_counter() - started
        flags = np.zeros(len(table), dtype=bool)
        for idx in outside.values():
            flags[idx] = True
        result = frame.assign(sinkage_m=mid, lower_m=lower, upper_m=upper, confidence=c, outside_training_range=flags)
        target = path.with_name(f"{path.stem}_predictions.csv")
        result.to_csv(target, index=False, float_format="%.6g")
        print(f"  {len(table)} scenes predicted in {predict_s * 1e3:.1f} ms → {target}")
        if outside:
            print(f"warning: {int(flags.sum())} scenes outside the training data: "
                  f"{_outside_text(predictor.model, outside, table, rows=True)}")
        return out | {"csv": str(target), "n": len(table), "predict_s": predict_s}

    if settings.task == "predict" and not np.isfinite(fast_sinkage(base, settings=meta.get("fast_model"))[0]):
        # the soil cannot stop the body: an answer, not a sinkage to predict (the surrogate's features
        # would hold the fast model's infinite sinkage)
        message = (f"the fast landing model (solver=analytic_dynamic) finds the body passes "
                   f"{LARGEST_SINKAGE_WIDTHS:g} B without stopping: the soil cannot stop it")
        print(f"  answer   : bearing_failure — {message}")
        return write_answer(out | {"status": "bearing_failure", "message": message}, run_dir)
    started = time.perf_counter()
    mid, lower, upper = predictor.interval(base, c)
    predict_s = time.perf_counter() - started
    interval = "" if math.isnan(upper[0]) else f", {c:.0%} interval [{lower[0]:.4f}, {upper[0]:.4f}] m"
    print(f"  sinkage  : {mid[0]:.4f} m{interval}  ({predict_s * 1e3:.1f} ms)")
    outside = predictor.model.out_of_range(base)
    if outside:
        # a forest does not extrapolate: beyond its data its answer and interval are its edge's
        column = next(iter(outside))
        fast = float(fast_sinkage(base, settings=meta.get("fast_model"))[0])
        print(f"warning: the scene lies outside the training data: {_outside_text(predictor.model, outside, base)}; "
              f"the surrogate's answer and interval do not hold there. The fast landing model says {fast:.4f} m; "
              f"the CEL: {check_command(predictor, base, PARAMETERS[column], float(base[column].iloc[0]))}")
        out["fast_model_sinkage_m"] = fast
    out |= {"sinkage_m": float(mid[0]), "lower_m": float(lower[0]), "upper_m": float(upper[0]),
            "outside_training_range": sorted(PARAMETERS[k] for k in outside)}

    if settings.task == "exceedance":
        out |= exceedance_answer(cfg, settings, predictor, base, run_dir)
    if settings.task in TASK_PARAMETERS:
        parameter = TASK_PARAMETERS[settings.task]
        low, high = _search_range(settings, predictor, parameter)
        answer = solve_inverse(predictor.upper(c), base, parameter, (low, high), settings.sinkage_limit_m,
                               points=settings.search.points)
        _print_inverse(answer, predictor, c, base)
        out |= {"parameter": parameter, "value": answer.value, "status": answer.status,
                "check": check_command(predictor, base, parameter, answer.value),
                "upper_at_value_m": answer.upper_at_value, "monotone": answer.monotone,
                "sinkage_limit_m": settings.sinkage_limit_m}
        if settings.verify and answer.status != "no_value_passes":
            safe_end = low if GOALS[parameter] == "max" else high
            verified = verify_answer(predictor, base, answer, run_dir or Path.cwd() / "predict_checks", safe_end,
                                     settings.refine_tolerance)
            _print_checks(verified, answer)
            out |= {"verify": verified["checks"], "cel_value": verified["value"], "cel_runs": verified["cel_runs"]}
        if settings.plot and run_dir is not None:
            column = COLUMNS[parameter]
            grid_table = base.loc[base.index.repeat(len(answer.grid))].reset_index(drop=True)
            grid_table[column] = answer.grid
            g_mid, g_low, g_up = predictor.interval(grid_table, c)
            run_dir.mkdir(parents=True, exist_ok=True)
            trained = meta.get("ranges", {}).get(column)
            png = plot_band(answer.grid, g_mid, g_low, g_up, parameter, c, run_dir / "inverse.png",
                            settings.sinkage_limit_m, answer.value, tuple(trained) if trained else None,
                            "\n".join([*predictor.describe(),
                                       f"{settings.task}, limit {settings.sinkage_limit_m:g} m"]))
            print(f"  plot     : {png}")
    return write_answer(out, run_dir)


def write_answer(out: dict, run_dir: Path | None) -> dict:
    """The answer into ``run_dir/prediction.json`` (when there is a run dir); returns it."""
    if run_dir is not None:
        run_dir.mkdir(parents=True, exist_ok=True)
        (run_dir / "prediction.json").write_text(json.dumps(out, indent=2, default=float) + "\n")
    return out


def fail(error: Exception) -> None:
    """One line on stderr, exit status 2."""
    print(f"{PROG}: error: {error}", file=sys.stderr)
    sys.exit(2)


def predict(cfg: DictConfig) -> dict | None:
    """The body of the Hydra app: user mistakes end in one line and exit status 2."""
    from hydra.core.hydra_config import HydraConfig

    run_dir = Path(HydraConfig.get().runtime.output_dir) if HydraConfig.initialized() else None
    # MLflow draws a progress bar on stderr for every artifact it downloads (the model, its
    # calibration): a user mistake found after that would no longer be one line
    os.environ.setdefault("MLFLOW_ENABLE_ARTIFACTS_PROGRESS_BAR", "false")
    overrides = list(HydraConfig.get().overrides.task) if HydraConfig.initialized() else []
    try:
        return run_predict(cfg, run_dir, overrides)
    except DsmvError as error:
        fail(error)



__all__ = ["predict", "run_predict", "check_config", "plot_band", "PredictSettings"]
