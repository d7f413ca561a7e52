"""``dsmv-calibrate``: validate, read the tests, fit, check with the CEL, write, log, summarise.

What it writes into its run dir (``runs/calibrate/<date>/<time>``):

- ``calibration.json``: the best fit, the intervals, what the data resolved, each test's misfit,
  the CEL check;
- ``draws.csv``: the bootstrap's joint draws (config keys as columns);
- ``conf/soil/<name>.yaml`` and ``conf/uncertainty/<name>.yaml``: a ``soil=`` profile at the best
  fit, and an ``uncertainty=`` file whose soil parameters are the joint draws (its landing entries
  those of ``calibrate.landing_uncertainty``), used as
  ``dsmv-predict hydra.searchpath=[file://<run dir>/conf] uncertainty=<name> task=exceedance …``;
- ``fit.png``: every test's data against the model at the best fit, with the draws' spread;
- the tests' data as read (SI units), and, for a synthetic calibration, as generated.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import Literal, Optional

import numpy as np
from omegaconf import DictConfig, OmegaConf
from pydantic import Field

from dsmv.analytic.penetrometer import PenetrometerModel, tbar_resistance
from dsmv.calibration.cel_tests import cyclic_push, measure, profile_push
from dsmv.calibration.correction import corrected
from dsmv.calibration.data import KINDS, MEASURED, SiteTest, read_test, write_test
from dsmv.calibration.fit import DEFAULT_BOUNDS, Calibration, Problem, _get, calibrate
from dsmv.config.location import CONFIG_DIR, data_path
from dsmv.config.profile import refuse_a_layered_density, refuse_a_layered_law
from dsmv.config.schema import Count, Number, Schema, _validate
from dsmv.errors import ConfigError
from dsmv.surrogate.reliability import DRAWN

RESULT_FILE = "calibration.json"
DRAWS_FILE = "draws.csv"
FIGURE_FILE = "fit.png"
EXPERIMENT = "calibration"  # MLflow experiment dsmv-calibration


class TestSpec(Schema):
    kind: Literal[tuple(KINDS)] = Field(description=" | ".join(KINDS))
    path: str = Field(description="the test's CSV (columns with units: see dsmv.calibration.data)")
    diameter_m: Number = Field(0.04, gt=0, description="tbar: the bar's diameter (m)")
    apex_angle_deg: Number = Field(30.0, gt=0, lt=180, description="fall_cone: the cone's apex angle (degrees)")


def _flat(tree: dict, prefix: str = "") -> dict:
    """{"soil": {"rate": {"eta": 0.1}}} → {"soil.rate.eta": 0.1}."""
    out = {}
    for key, value in tree.items():
        path = f"{prefix}.{key}" if prefix else str(key)
        out |= _flat(value, path) if isinstance(value, dict) else {path: value}
    return out


class Synthetic(Schema):
    truth: dict = Field(description="the soil values the data are generated from, nested as the soil is")
    noise: Number = Field(0.05, ge=0, description="relative scatter of the generated data (-), log-normal")
    seed: int = Field(0, description="the noise's random seed (-)")
    values: Literal["models", "files"] = Field("models", description=(
        "models: the fast models generate the tests' values at the truth; files: the files hold values "
        "measured at the truth without scatter (python -m dsmv.calibration.cel_site, on the CEL)"))


class ExceedanceSettings(Schema):
    sinkage_limit_m: Optional[Number] = Field(None, gt=0, description="the limit (m); null: no comparison")
    registered_model: str = Field("dsmv-sinkage-rf", description="the surrogate that predicts the sinkage")
    confidence: Number = Field(0.9, gt=0, lt=1, description="the interval's level (-)")


class CalibrateSettings(Schema):
    tests: list[TestSpec] = Field(description="the site tests")
    parameters: list[str] = Field(description="the soil keys fitted")
    bounds: dict[str, list[Number]] = Field(default_factory=dict, description="{key: [low, high]}")
    bootstrap: Count = Field(200, ge=10, description="residual-bootstrap refits (-)")
    confidence: Number = Field(0.9, gt=0, lt=1, description="the intervals' level (-)")
    resolved_width: Number = Field(0.2, gt=0, description="resolved: interval width / best value below this (-)")
    seed: int = Field(0, description="the bootstrap's seed (-)")
    name: str = Field("site", pattern=r"^[A-Za-z0-9_]+$", description="name of the soil= and uncertainty= files")
    cel_check: bool = Field(True, description="run the CEL T-bar at the best fit")
    cel_check_cells_per_diameter: Count = Field(10, ge=4, description=(
        "the CEL runs' core cells across the bar (the check's and the corrections')"))
    cel_check_cycles: Count = Field(2, ge=0, description="the cycles of a cyclic test the CEL check pushes (0: none)")
    cel_corrections: Count = Field(0, ge=0, description=(
        "rounds of CEL correction before the bootstrap: each measures every test on the CEL at the fit and fits "
        "the models times the CEL's values over theirs (0: the models alone; dsmv.calibration.correction)"))
    cel_correction_pushes: Count = Field(0, ge=0, description=(
        "the corrections read a T-bar profile by this many short pushes to its depths, as the site's CEL data "
        "were measured (python -m dsmv.calibration.cel_site --pushes); 0: one push through it"))
    models: PenetrometerModel
    landing_uncertainty: Optional[str] = Field("nodule_field", description="uncertainty= file whose landing entries are kept")
    synthetic: Optional[Synthetic] = Field(None, description="generate the tests' data from known values")
    exceedance: ExceedanceSettings = Field(default_factory=ExceedanceSettings)


def check_config(cfg: DictConfig) -> tuple[CalibrateSettings, Problem]:
    """The settings and the problem (tests read and checked), or a one-line ConfigError."""
    container = OmegaConf.to_container(cfg, resolve=True)
    settings = _validate(CalibrateSettings, container.get("calibrate") or {}, "calibrate")
    if not settings.tests:
        raise ConfigError("calibrate.tests", [], "name at least one test: [{kind: tbar, path: tbar.csv}, ...] "
                          "or a site (site=synthetic_ccz)")
    from dsmv.config.scene import SoilConfig

    validated = _validate(SoilConfig, container["soil"], "soil")
    refuse_a_layered_law(validated, "dsmv-calibrate")
    refuse_a_layered_density(validated, "dsmv-calibrate")
    soil = validated.model_dump()
    keys = list(dict.fromkeys(settings.parameters))
    if "soil.profile_scale" in keys and settings.exceedance.sinkage_limit_m is not None:
        check_table_comparison(settings)
    bounds = []
    for key in keys:
        _get(soil, key)   # a key the soil does not have: one line naming it
        given = settings.bounds.get(key, DEFAULT_BOUNDS.get(key))
        if given is None:
            raise ConfigError(f"calibrate.bounds.{key}", None, "give this parameter's bounds [low, high]")
        if len(given) != 2 or not given[0] < given[1]:
            raise ConfigError(f"calibrate.bounds.{key}", list(given), "must be [low, high] with low < high")
        bounds.append((float(given[0]), float(given[1])))
    tests = [read_test(spec.kind, data_path(spec.path), f"calibrate.tests[{i}]", diameter_m=spec.diameter_m,
                       apex_angle_deg=spec.apex_angle_deg) for i, spec in enumerate(settings.tests)]
    if settings.synthetic is not None:
        truth = _flat(settings.synthetic.truth)
        for key, value in truth.items():
            if key not in keys:
                raise ConfigError(f"calibrate.synthetic.truth.{key}", value, f"not a fitted parameter; one of {', '.join(keys)}")
            if not isinstance(value, (int, float)) or isinstance(value, bool):
                raise ConfigError(f"calibrate.synthetic.truth.{key}", value, "must be a number")
        truth_soil = dict(soil, rate=dict(soil["rate"]), params=dict(soil["params"]))
        generator = Problem(tests, truth_soil, keys, bounds, settings.models)
        values = [float(truth.get(k, generator.start[i])) for i, k in enumerate(keys)]
        rng = np.random.default_rng(settings.synthetic.seed)
        clean = generator.predict(values) if settings.synthetic.values == "models" else [t.measured for t in tests]
        tests = [SiteTest(t.kind, t.name, {**t.columns, MEASURED[t.kind]: c * np.exp(
            settings.synthetic.noise * rng.standard_normal(len(c)))}, t.diameter_m, t.apex_angle_deg)
                 for t, c in zip(tests, clean)]
    return settings, Problem(tests, soil, keys, bounds, settings.models)


# ----------------------------------------------------------------------------- the CEL check


def cel_check(problem: Problem, best, cells_per_diameter: int, run_dir: Path, cycles: int = 2) -> list[dict]:
    """The CEL T-bar at the best fit against the model and the data at the same depth
    (:mod:`dsmv.calibration.cel_tests`).

    Once per rate of the tests' first cycles: pushed to the middle of that rate's depths, the mean
    resistance over the last D (the data's rows within ±D/2 of that depth). And once per cyclic test:
    ``cycles`` strokes about its depth, the mean resistance over the middle D of each penetration stroke
    against its cycle's."""
    soil = problem.soil_at(best)
    law = problem._law_cls(soil)
    checks, seen = [], set()
    for test in problem.tests:
        if test.kind != "tbar":
            continue
        c, D = test.columns, test.diameter_m
        first = c["cycle"] == 1
        for velocity in np.unique(c["velocity"][first]):
            if (float(velocity), D) in seen or len(np.unique(c["cycle"])) > 1:
                continue
            seen.add((float(velocity), D))
            rows = first & (c["velocity"] == velocity)
            depth = float(np.median(c["depth"][rows]))
            push = profile_push(soil, D, velocity, depth, cells_per_diameter,
                                run_dir / "cel_check" / f"{test.name}_v{velocity:g}", shallowest_m=depth)
            entry = push.entry
            if push.ok:
                axis = depth
                q_cel = push.mean_at(axis)
                q_model = float(tbar_resistance(problem.model, law, soil.strength, axis, velocity, D))
                near = rows & (np.abs(c["depth"] - axis) <= D / 2.0)
                q_data = float(np.mean(c["resistance"][near])) if near.any() else None  # no datum within D/2
                entry |= {"depth_m": axis, "q_cel_pa": q_cel, "q_model_pa": q_model, "q_data_pa": q_data,
                          "model_over_cel": q_model / q_cel}
            checks.append(entry | {"test": test.name})
        if len(np.unique(c["cycle"])) > 1 and cycles > 0:
            checks += _cyclic_check(problem, law, soil, test, cycles, cells_per_diameter, run_dir)
    return checks


def _cyclic_check(problem: Problem, law, soil, test: SiteTest, cycles: int, cells: int, run_dir: Path) -> list[dict]:
    """The cyclic push about the test's depth: one entry per penetration stroke (cycle 1, 2, …)."""
    c, D = test.columns, test.diameter_m
    depth, velocity = float(np.median(c["depth"])), float(np.median(c["velocity"]))
    push = cyclic_push(soil, D, velocity, depth, cycles, cells, run_dir / "cel_check" / f"{test.name}_cycles")
    if not push.ok:
        return [push.entry | {"test": test.name}]
    out = []
    for cycle in range(1, cycles + 2):
        q_cel = push.mean_at(depth, 2 * (cycle - 1))
        if math.isnan(q_cel):
            continue
        q_model = float(tbar_resistance(problem.model, law, soil.strength, depth, velocity, D, 2 * (cycle - 1)))
        data = c["resistance"][c["cycle"] == cycle]
        out.append(push.entry | {"test": test.name, "cycle": cycle, "depth_m": depth, "q_cel_pa": q_cel,
                                 "q_model_pa": q_model, "q_data_pa": float(np.mean(data)) if len(data) else None,
                                 "model_over_cel": q_model / q_cel})
    return out


def cel_measure(settings: CalibrateSettings, run_dir: Path):
    """The CEL correction's measurement: a test's design run in a soil (:func:`dsmv.calibration.cel_tests.measure`,
    a profile one push through it or ``calibrate.cel_correction_pushes`` short ones), its runs under
    ``cel_correction/round_<k>``."""
    def run(test: SiteTest, soil, round_: int) -> SiteTest:
        return measure(test, soil, settings.cel_check_cells_per_diameter,
                       run_dir / "cel_correction" / f"round_{round_}", pushes=settings.cel_correction_pushes)

    return run


# ----------------------------------------------------------------------------- outputs


def _tree_set(tree: dict, key: str, value) -> None:
    parts = key.split(".")
    for part in parts[:-1]:
        tree = tree.setdefault(part, {})
    tree[parts[-1]] = value


def write_outputs(settings: CalibrateSettings, problem: Problem, cal: Calibration, checks: list[dict],
                  run_dir: Path, corrections: list[dict] | None = None) -> dict[str, Path]:
    """calibration.json, draws.csv, the soil= and uncertainty= files, fit.png and the tests' data."""
    run_dir.mkdir(parents=True, exist_ok=True)
    files = {}
    for test in problem.tests:
        files[f"data_{test.name}"] = write_test(run_dir / f"data_{test.name}.csv", test)
    header = ",".join(cal.keys)
    np.savetxt(run_dir / DRAWS_FILE, cal.draws, delimiter=",", header=header, comments="", fmt="%.10g")
    files["draws"] = run_dir / DRAWS_FILE

    soil = problem.soil_at(cal.best).model_dump()
    soil["name"] = settings.name
    soil_dir = run_dir / "conf" / "soil"
    soil_dir.mkdir(parents=True, exist_ok=True)
    fitted = ", ".join(f"{k} = {v:.6g}" for k, v in zip(cal.keys, cal.best))
    (soil_dir / f"{settings.name}.yaml").write_text(
        f"# Calibrated by dsmv-calibrate ({run_dir}): {fitted}"
        + (f", the models corrected by the CEL in {len(corrections)} rounds.\n" if corrections else ".\n")
        + f"# Every other value is the starting soil's ({problem.soil['name']}).\n"
        + OmegaConf.to_yaml(OmegaConf.create(soil)))
    files["soil"] = soil_dir / f"{settings.name}.yaml"

    uncertainty: dict = {}
    if settings.landing_uncertainty:
        base = OmegaConf.to_container(OmegaConf.load(landing_uncertainty_file(settings)), resolve=True)
        uncertainty = {k: v for k, v in base.items() if k != "soil"}
    surrogate_keys = [k for k in cal.keys if k in DRAWN]  # what an exceedance draws (a table's level too)
    joint = run_dir / "uncertainty_draws.csv"
    columns = [cal.keys.index(k) for k in surrogate_keys]
    np.savetxt(joint, cal.draws[:, columns], delimiter=",", header=",".join(surrogate_keys), comments="", fmt="%.10g")
    uncertainty["joint"] = str(joint.resolve())
    unc_dir = run_dir / "conf" / "uncertainty"
    unc_dir.mkdir(parents=True, exist_ok=True)
    left_out = [k for k in cal.keys if k not in DRAWN]
    (unc_dir / f"{settings.name}.yaml").write_text(
        f"# The calibration's joint draws ({len(cal.draws)} bootstrap refits) of {', '.join(surrogate_keys)}"
        + (f"; not drawn, since the models do not take them: {', '.join(left_out)}" if left_out else "")
        + (f".\n# The landing's entries are uncertainty={settings.landing_uncertainty}'s.\n"
           if settings.landing_uncertainty else ".\n") + OmegaConf.to_yaml(OmegaConf.create(uncertainty)))
    files["uncertainty"] = unc_dir / f"{settings.name}.yaml"

    summary = {
        "parameters": {k: {"best": float(b), "lower": float(lo), "upper": float(hi), "resolved": r,
                           "linearised_relative_width": float(lw)}
                       for k, b, lo, hi, r, lw in zip(cal.keys, cal.best, cal.lower, cal.upper, cal.resolved,
                                                      cal.linear_width)},
        "confidence": cal.confidence, "uncertainty_method": "residual bootstrap",
        "bootstrap": len(cal.draws), "failed_refits": cal.failed_resamples,
        "tests": [{"name": t.name, "kind": t.kind, "rows": len(t), "rms_log_misfit": cal.rms(i)}
                  for i, t in enumerate(problem.tests)],
        "held": _held(problem),
        "cel_check": checks,
        "cel_corrections": corrections or [],
        "synthetic": settings.synthetic.model_dump() if settings.synthetic else None,
    }
    (run_dir / RESULT_FILE).write_text(json.dumps(summary, indent=2) + "\n")
    files["result"] = run_dir / RESULT_FILE
    files["figure"] = plot_fit(problem, cal, run_dir / FIGURE_FILE)
    return files


def _held(problem: Problem) -> dict[str, float]:
    """The law's parameters the calibration did not fit, with the values they were held at."""
    soil = problem.soil
    keys = ["soil.sensitivity", "soil.xi95"]
    if soil["law"] != "tresca":
        keys += (["soil.rate.eta", "soil.rate.n", "soil.rate.gamma_dot_ref"] if soil["rate"]["law"] == "power"
                 else ["soil.rate.mu", "soil.rate.gamma_dot_ref"])
    keys += [f"soil.params.{k}" for k in soil.get("params", {})]
    out = {}
    for key in keys:
        if key not in problem.keys:
            node = soil
            for part in key.split(".")[1:]:
                node = node[part]
            out[key] = float(node)
    return out


def plot_fit(problem: Problem, cal: Calibration, path: Path) -> Path:
    """Each test's data against the model at the best fit, and the band of 50 bootstrap draws."""
    from dsmv.surrogate.evaluate import pyplot

    plt = pyplot()
    n = len(problem.tests)
    fig, axes = plt.subplots(1, n, figsize=(4.2 * n, 4.2), constrained_layout=True, squeeze=False)
    best = problem.predict(cal.best)
    step = max(len(cal.draws) // 50, 1)
    spread = [problem.predict(d) for d in cal.draws[::step]]
    for k, (ax, test) in enumerate(zip(axes[0], problem.tests)):
        c = test.columns
        if test.kind == "tbar":
            x_of = c["cycle"] if len(np.unique(c["cycle"])) > 1 else None
            groups = np.unique(c["velocity"]) if x_of is None else [None]
            for velocity in groups:
                rows = np.ones(len(test), bool) if velocity is None else c["velocity"] == velocity
                if x_of is None:
                    y = c["depth"][rows]
                    ax.plot(c["resistance"][rows] / 1e3, y, ".", ms=4, label=f"data, {velocity * 1e3:g} mm/s")
                    ax.plot(best[k][rows] / 1e3, y, "-", lw=1.2)
                    for draw in spread:
                        ax.plot(draw[k][rows] / 1e3, y, "-", color="0.6", lw=0.3, alpha=0.3)
                else:
                    ax.plot(x_of, c["resistance"] / 1e3, "o", ms=4, label="data")
                    ax.plot(x_of, best[k] / 1e3, "-", lw=1.2, label="model, best fit")
                    for draw in spread:
                        ax.plot(x_of, draw[k] / 1e3, "-", color="0.6", lw=0.3, alpha=0.3)
            if x_of is None:
                ax.invert_yaxis()
                ax.set_xlabel("net resistance q (kPa)")
                ax.set_ylabel("depth (m)")
            else:
                ax.set_xlabel("cycle")
                ax.set_ylabel("net resistance q (kPa)")
        else:
            ax.plot(c["mass"] * 1e3, c["penetration"] * 1e3, "o", label="data")
            order = np.argsort(c["mass"])
            ax.plot(c["mass"][order] * 1e3, best[k][order] * 1e3, "-", label="model, best fit")
            for draw in spread:
                ax.plot(c["mass"][order] * 1e3, draw[k][order] * 1e3, "-", color="0.6", lw=0.3, alpha=0.3)
            ax.set_xlabel("cone mass (g)")
            ax.set_ylabel("penetration (mm)")
        ax.set_title(f"{test.name}: misfit {cal.rms(k):.1%}", fontsize=9)
        ax.legend(fontsize=7)
    corrected_by = " (the models corrected by the CEL)" if problem.correction is not None else ""
    fig.suptitle(f"dsmv-calibrate: data, best fit (lines){corrected_by}, bootstrap draws (grey)", fontsize=10)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


# ----------------------------------------------------------------------------- what it changes


def landing_uncertainty_file(settings: CalibrateSettings) -> Path:
    """The ``uncertainty=`` file ``calibrate.landing_uncertainty`` names (one line if there is none)."""
    path = Path(CONFIG_DIR) / "uncertainty" / f"{settings.landing_uncertainty}.yaml"
    if not path.is_file():
        raise ConfigError("calibrate.landing_uncertainty", settings.landing_uncertainty, f"no {path}")
    return path


def read_uncertainty(path: Path):
    """An ``uncertainty=`` file, validated (:func:`dsmv.surrogate.reliability.uncertainty_from`)."""
    from dsmv.surrogate.reliability import uncertainty_from

    return uncertainty_from({"uncertainty": OmegaConf.to_container(OmegaConf.load(path), resolve=True)})


def check_table_comparison(settings: CalibrateSettings) -> None:
    """A fitted table's level is compared by the fast landing model against ``calibrate.landing_uncertainty``,
    which must then draw a table's (its level, not su0 and ks): one line if it does not."""
    from dsmv.surrogate.vehicle_exceedance import check_uncertain

    keys = read_uncertainty(landing_uncertainty_file(settings)).keys
    try:
        check_uncertain(keys, table_soil=True)
    except ConfigError:
        raise ConfigError("calibrate.landing_uncertainty", settings.landing_uncertainty,
                          "the fitted table's exceedance is compared against a file that draws a table's level "
                          "(soil.profile_scale), not su0 and ks: e.g. calibrate.landing_uncertainty=ccz_box_core") from None


def compare_exceedance(cfg: DictConfig, settings: CalibrateSettings, uncertainty_file: Path,
                       table_soil: dict | None = None) -> dict[str, dict]:
    """P(max sinkage > limit) for the default scene (``dsmv-predict task=exceedance``'s answer) with the
    calibrated uncertainty and with the file it replaces (``calibrate.landing_uncertainty``):
    {"calibrated": …, "default": …}, each the estimate and its errors. By the registered surrogate; on a
    fitted strength table (``table_soil``, the starting soil), by the fast landing model, each sample on the
    table at its drawn level (docs/decisions/0038), the surrogates learning straight lines."""
    from dsmv.config.tree import compose_scene
    from dsmv.surrogate.model import scene_table
    from dsmv.surrogate.reliability import exceedance, sample_scenes

    ask = settings.exceedance
    files = {"calibrated": uncertainty_file, "default": landing_uncertainty_file(settings)}
    if table_soil is not None:
        from dataclasses import replace

        from dsmv.config.scene import SoilConfig
        from dsmv.surrogate.vehicle_exceedance import land_samples, probability

        scene = replace(compose_scene(["tracking=disabled"]), soil=_validate(SoilConfig, table_soil, "soil"))
        out = {}
        for which, path in files.items():
            landed = land_samples(scene, sample_scenes(scene_table([scene]), read_uncertainty(path)))
            p, error = probability(landed.exceeds(ask.sinkage_limit_m, None)["sinkage"])
            out[which] = {"probability": p, "monte_carlo_error": error, "samples": len(landed.sinkage_m),
                          "uncertainty": str(path), "model": "fast landing model"}
        return out

    from dsmv.config.scene import build_tracking
    from dsmv.surrogate.predictor import load_predictor

    predictor = load_predictor(ask.registered_model, build_tracking(cfg).uri)
    base = scene_table([compose_scene(["tracking=disabled"])])
    out = {}
    for which, path in files.items():
        mid, lower, upper = predictor.interval(sample_scenes(base, read_uncertainty(path)), ask.confidence)
        answer = exceedance(mid, lower, upper, ask.sinkage_limit_m)
        out[which] = {"probability": answer.probability, "monte_carlo_error": answer.monte_carlo_error,
                      "model_low": answer.model_low, "model_high": answer.model_high, "samples": answer.samples,
                      "uncertainty": str(path), "model": f"{ask.registered_model} v{predictor.version}"}
    return out


# ----------------------------------------------------------------------------- the run


def log_to_mlflow(cfg: DictConfig, settings: CalibrateSettings, cal: Calibration, files: dict[str, Path],
                  metrics: dict[str, float]) -> dict[str, str]:
    """One MLflow run in experiment dsmv-calibration: the settings as params, the fit as metrics, the files."""
    import mlflow

    from dsmv.config.scene import build_tracking
    from dsmv.tracking import runs
    from dsmv.tracking.run_writer import experiment_id as find_experiment

    tracking = build_tracking(cfg)
    client = runs._client(tracking)
    experiment_id = find_experiment(client, runs.experiment_name(EXPERIMENT), tracking.artifact_location)
    mlflow.set_tracking_uri(client.tracking_uri)
    tags = {"dsmv.role": "calibration", "dsmv.status": "ok", "dsmv.soil_law": str(cfg.soil.law)}
    with mlflow.start_run(experiment_id=experiment_id, run_name=f"calibrate {settings.name}", tags=tags) as run:
        params = runs.flatten({"calibrate": settings.model_dump(exclude={"models"}), "models": settings.models.model_dump()})
        mlflow.log_params({k: str(v)[:6000] for k, v in params.items()})
        mlflow.log_metrics({k: float(v) for k, v in metrics.items() if np.isfinite(v)})
        for path in files.values():
            mlflow.log_artifact(str(path))
    return {"uri": client.tracking_uri, "experiment": runs.experiment_name(EXPERIMENT), "run_id": run.info.run_id}


def _metric_name(key: str) -> str:
    return key.removeprefix("soil.").replace(".", "_")


def run_calibration(cfg: DictConfig, run_dir: Path) -> dict:
    """``dsmv-calibrate``: check, fit with its bootstrap, check with the CEL, write, log, summarise."""
    started = time.perf_counter()
    settings, problem = check_config(cfg)
    rows = sum(len(t) for t in problem.tests)
    print(f"dsmv-calibrate: {', '.join(problem.keys)} of the {problem.soil['law']} law, from "
          f"{len(problem.tests)} tests ({rows} values){' generated from known values' if settings.synthetic else ''}")

    corrections, correcting = [], time.perf_counter()
    if settings.cel_corrections:
        problem, corrections = corrected(problem, settings.cel_corrections, cel_measure(settings, run_dir),
                                         lambda line: print(line, flush=True))
    correcting_s = time.perf_counter() - correcting
    fitting = time.perf_counter()

    def progress(done: int, total: int) -> None:
        if done == total or done % max(total // 10, 1) == 0:
            elapsed = time.perf_counter() - fitting
            print(f"  bootstrap {done}/{total} refits  [{elapsed:.0f} s elapsed, about "
                  f"{elapsed / done * (total - done):.0f} s left]", flush=True)

    cal = calibrate(problem, settings.bootstrap, settings.confidence, settings.resolved_width, settings.seed, progress)
    fit_s = time.perf_counter() - started - correcting_s
    checks = []
    if settings.cel_check and any(t.kind == "tbar" for t in problem.tests):
        print("  CEL check: the T-bar at the best fit, one push per rate …", flush=True)
        checks = cel_check(problem, cal.best, settings.cel_check_cells_per_diameter, run_dir,
                           settings.cel_check_cycles)
    files = write_outputs(settings, problem, cal, checks, run_dir, corrections)
    compared = {}
    if settings.exceedance.sinkage_limit_m is not None:
        compared = compare_exceedance(cfg, settings, files["uncertainty"],
                                      problem.soil if "soil.profile_scale" in problem.keys else None)
        summary = json.loads(files["result"].read_text())
        files["result"].write_text(json.dumps(summary | {"exceedance": compared}, indent=2) + "\n")
    metrics = {f"best_{_metric_name(k)}": float(b) for k, b in zip(cal.keys, cal.best)}
    metrics |= {f"lower_{_metric_name(k)}": float(v) for k, v in zip(cal.keys, cal.lower)}
    metrics |= {f"upper_{_metric_name(k)}": float(v) for k, v in zip(cal.keys, cal.upper)}
    metrics |= {f"misfit_{t.name}": cal.rms(i) for i, t in enumerate(problem.tests)}
    metrics |= {f"cel_check_{c['test']}_" + (f"cycle_{c['cycle']}" if "cycle" in c else f"{c['velocity_m_s']:g}"):
                c["model_over_cel"] for c in checks if "model_over_cel" in c}
    metrics |= {f"exceedance_{which}": answer["probability"] for which, answer in compared.items()}
    if corrections:   # how far the last round moved the fit: the rounds' convergence
        metrics |= {"cel_correction_rounds": float(len(corrections)), "cel_correction_wall_s": correcting_s,
                    "cel_correction_last_move": max(abs(m) for m in corrections[-1]["moved"].values())}
    metrics |= {"resolved_parameters": float(sum(cal.resolved)), "fit_wall_s": fit_s,
                "calibrate_wall_s": time.perf_counter() - started}
    logged = log_to_mlflow(cfg, settings, cal, files, metrics) if cfg.tracking.get("enabled", True) else None
    print_summary(settings, problem, cal, checks, compared, run_dir, logged, time.perf_counter() - started,
                  corrections)
    return {"calibration": cal, "checks": checks, "files": files, "metrics": metrics, "exceedance": compared}


def cel_check_line(check: dict) -> str:
    """One CEL check's summary line: the CEL's resistance against the fast model's and the data's there
    (the data may have no value within D/2 of the depth the check pushed to), or how the push ended."""
    head = f"  CEL check: {check['test']} at {check['velocity_m_s'] * 1e3:g} mm/s"
    if "model_over_cel" not in check:
        return f"{head} ended {check['status']}"
    cycle = f", cycle {check['cycle']}" if "cycle" in check else ""
    data = (f"data {check['q_data_pa'] / 1e3:.2f} kPa" if check["q_data_pa"] is not None
            else "no datum within D/2 of that depth")
    run = (f"; run at {check['run_velocity_m_s'] * 1e3:g} mm/s, gamma_dot_ref scaled alike"
           if check["run_velocity_m_s"] != check["velocity_m_s"] else "")
    return (f"{head}{cycle}, {check['depth_m']:.3f} m: CEL {check['q_cel_pa'] / 1e3:.2f} kPa, fast model "
            f"{check['q_model_pa'] / 1e3:.2f} kPa ({check['model_over_cel'] - 1:+.1%}), {data} "
            f"({check['wall_s']:.0f} s{run})")


def print_summary(settings, problem: Problem, cal: Calibration, checks, compared, run_dir: Path, logged, wall_s,
                  corrections=()) -> None:
    c = f"{cal.confidence:.0%}"
    print(f"\ndsmv-calibrate: {problem.soil['law']} fitted to {len(problem.tests)} tests in {wall_s:.0f} s "
          f"({len(cal.draws)} bootstrap refits: the {c} intervals and the joint draws)")
    width = max(len(k) for k in cal.keys)
    for key, best, lo, hi, ok, lw in zip(cal.keys, cal.best, cal.lower, cal.upper, cal.resolved, cal.linear_width):
        truth = _flat(settings.synthetic.truth).get(key) if settings.synthetic else None
        why = "" if ok else (" (the data see it only in a combination with another)" if lw > 10 else "")
        print(f"  {key:<{width}} : {best:.4g}  [{lo:.4g}, {hi:.4g}]  {'resolved' if ok else 'NOT resolved by these data'}{why}"
              + (f"  (true {truth:.4g}, {best / truth - 1:+.1%})" if truth else ""))
    held = _held(problem)
    if held:
        print("  held     : " + ", ".join(f"{k} = {v:g}" for k, v in held.items())
              + " (not fitted; a power law's gamma_dot_ref enters only as eta·gamma_dot_ref^-n: the data cannot tell it)")
    for i, test in enumerate(problem.tests):
        print(f"  misfit   : {test.name} ({test.kind}, {len(test)} values): {cal.rms(i):.1%} rms")
    for record in corrections:
        print(f"  CEL corr.: round {record['round']}, the models times the CEL's values over theirs, rows corrected: "
              + ", ".join(f"{t['test']} {t['rows_corrected']}/{t['rows']}" + (
                  f" {t['cel_over_model_min']:.3f}–{t['cel_over_model_max']:.3f}" if t["rows_corrected"] else
                  " (NOT corrected: the CEL read none)") for t in record["tests"]))
        print("             the refit moved " + ", ".join(f"{k.removeprefix('soil.')} {m:+.1%}"
                                                        for k, m in record["moved"].items()))
    for check in checks:
        print(cel_check_line(check))
    for which, answer in compared.items():
        print(f"  exceed   : P(z > {settings.exceedance.sinkage_limit_m:g} m) = {answer['probability']:.4f} "
              f"± {answer['monte_carlo_error']:.4f}, default scene, {which} uncertainty "
              f"({Path(answer['uncertainty']).name}; {answer['model']}, {answer['samples']} samples)")
    print(f"  outputs  : {run_dir}  ({RESULT_FILE}, {FIGURE_FILE}, conf/soil/{settings.name}.yaml, "
          f"conf/uncertainty/{settings.name}.yaml)")
    print(f"  use      : dsmv hydra.searchpath=[file://{(run_dir / 'conf').resolve()}] soil={settings.name}")
    table = "soil.profile_scale" in problem.keys  # its level is drawn by the fast models' exceedance
    print(f"             dsmv-predict hydra.searchpath=[file://{(run_dir / 'conf').resolve()}] task=exceedance "
          + (f"soil={settings.name} " if table else "") + f"uncertainty={settings.name} sinkage_limit_m=0.1"
          + ("  (add geometry=vehicle_pioneer_i for the vehicle)" if table else ""))
    if logged:
        print(f"  MLflow   : {logged['uri']}  (experiment {logged['experiment']}, run {logged['run_id']})")


__all__ = ["run_calibration", "check_config", "cel_check", "CalibrateSettings", "RESULT_FILE", "DRAWS_FILE", "FIGURE_FILE"]
