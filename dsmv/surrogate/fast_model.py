"""The fast landing model (``solver=analytic_dynamic``) over a dataset table, its calibration, and the
physics feature set built on it (:class:`PhysicsFeatures`).

Each row of a dataset table (:mod:`dsmv.surrogate.dataset`) is a landing. The columns hold what the
study varied; the soil's other values are the default soil's (``conf/soil/nodule_field.yaml``:
ρ', the rate law's n and γ̇ref), with E/su0 held at the default's ratio (500, as every sample of the
reference study's Table 1). The law is the dataset's (``einav_randolph`` unless its runs shared
another); its NumPy twin runs on all rows at once, reading a soil whose varied values are arrays.

``python -m dsmv.surrogate.fast_model DATASET.csv`` fits the coefficients the module
:mod:`dsmv.analytic.landing_model` takes from the CEL (least squares on log sinkage) and prints the
model's error against the CEL, in sample and held out (5-fold).
"""

from __future__ import annotations

import argparse
from dataclasses import asdict, replace
from functools import lru_cache
from types import SimpleNamespace

import numpy as np
import pandas as pd

from dsmv import registry
from dsmv.analytic.landing_model import Coefficients, Landing, sinkage
from dsmv.surrogate.dataset import TARGET_METRIC
from dsmv.surrogate.features import LeakFreeFeatures, physics, target

#: the coefficients a calibration fits; the others keep their cited values
FITTED = ("depth_coefficient", "strain_coefficient", "drag_coefficient")


#: the fast model of what each CEL solver lands: the 2D cross-section, or the 3D track (its grousers
#: cut in first, Skempton's shape factor; coefficients fitted to the 3D CEL)
FAST_MODEL_CONFIG = {"cel2d": "analytic_dynamic", "cel3d": "analytic_dynamic_3d"}


@lru_cache(maxsize=2)
def _default_scene(option: str = "analytic_dynamic"):
    from dsmv.config.tree import compose_scene

    return compose_scene(["tracking=disabled", f"solver={option}"])


def default_settings(solver: str = "cel2d") -> dict:
    """What the model takes that a table does not hold, from the default config: the coefficients of
    ``conf/solver/analytic_dynamic.yaml`` (``_3d.yaml`` for the 3D track, ``solver="cel3d"``), its
    form (grousers, shape factor) and the default soil's and track's other values. A surrogate
    records them, so that its features stay what they were trained on if the defaults change."""
    scene = _default_scene(FAST_MODEL_CONFIG.get(solver, "analytic_dynamic"))
    return scene_settings(scene, scene.solver)


def scene_settings(scene, model) -> dict:
    """What the fast model ``model`` (an :class:`~dsmv.analytic.landing_model.AnalyticDynamicConfig`)
    takes that a table does not hold, from ``scene``: its coefficients and form, the soil's law and
    other values, E/su0 the scene's ratio (a row's E is its su0 times it)."""
    soil, rate = scene.soil, scene.soil.rate
    return {"coefficients": asdict(model.coefficients()), "law": soil.law,
            "density_kg_m3": soil.density_kg_m3,
            "youngs_modulus_over_su0": soil.youngs_modulus_pa / soil.su0_pa,
            "rate": {"law": rate.law, "n": rate.n, "gamma_dot_ref": rate.gamma_dot_ref, "mu": rate.mu},
            "shape_factor": model.shape_factor,
            "grouser_height_m": scene.geometry.grouser_height_m if model.grousers else 0.0}


def table_landing(table: pd.DataFrame, settings: dict | None = None) -> Landing:
    """The rows of a dataset table as landings (per track, SI)."""
    p, fill = physics(table), settings or default_settings()
    su0 = table["su0_pa"].to_numpy(float)
    return Landing(
        weight_n=p["weight_n"], inertia_kg=p["inertia_kg"], velocity_m_s=table["velocity_m_s"].to_numpy(float),
        width_m=p["width_m"], area_m2=p["area_m2"], su0_pa=su0, ks_pa_per_m=table["ks_pa_per_m"].to_numpy(float),
        density_kg_m3=fill["density_kg_m3"], youngs_modulus_pa=fill["youngs_modulus_over_su0"] * su0,
        gravity_m_s2=table["gravity_m_s2"].to_numpy(float), shape_factor=table_shape_factor(table, fill),
        grouser_height_m=fill.get("grouser_height_m", 0.0))


def table_shape_factor(table: pd.DataFrame, settings: dict):
    """sc of each row: 1 in plane strain, Skempton's 1 + 0.2·B/L for the 3D track, or the number given."""
    form = settings.get("shape_factor", "plane_strain")
    if form == "plane_strain":
        return 1.0
    if form == "skempton":
        return 1.0 + 0.2 * table["width_m"].to_numpy(float) / table["contact_length_m"].to_numpy(float)
    return float(form)


def table_factor(table: pd.DataFrame, settings: dict | None = None, column: bool = False):
    """The soil law's strength factor of each row, as f(ξ, γ̇, z) on arrays aligned with the rows (with
    ``column``, on arrays whose rows are the table's: one row per landing, a column per point of it); the
    rows' soils are not layered, so the base's depth z changes nothing."""
    settings = settings or default_settings()
    law = registry.load("soil_laws", settings.get("law", "einav_randolph"), "soil.law")

    def values(name: str) -> np.ndarray:
        return table[name].to_numpy(float).reshape((-1, 1) if column else -1)

    rows = SimpleNamespace(sensitivity=values("sensitivity"), xi95=values("xi95"),
                           rate=SimpleNamespace(**settings["rate"], eta=values("eta")))
    twin = SimpleNamespace(soil=rows, params=None)  # the twin reads self.soil, and broadcasts
    return lambda xi, gamma_dot, depth=None: np.broadcast_to(law.strength_factor(twin, xi, gamma_dot), np.shape(xi))


def fast_sinkage(table: pd.DataFrame, coefficients: Coefficients | None = None,
                 settings: dict | None = None) -> np.ndarray:
    """The fast model's sinkage (m) of every row (coefficients and soil fill: ``settings``, by default
    :func:`default_settings`; ``coefficients`` overrides the settings' own)."""
    settings = settings or default_settings()
    coefficients = coefficients or Coefficients(**settings["coefficients"])
    return sinkage(table_landing(table, settings), table_factor(table, settings), coefficients)


class PhysicsFeatures(LeakFreeFeatures):
    """The leak-free inputs and the fast landing model's z/B (``solver=analytic_dynamic``, in
    milliseconds from the same inputs): the forest learns the CEL's departure from the physics."""

    name = "physics"
    columns = (*LeakFreeFeatures.columns, "fast_model_z_over_b")

    def __init__(self, settings: dict | None = None):
        #: the fast model's coefficients and soil fill (recorded with a trained model)
        self.settings = settings or default_settings()

    def transform(self, table: pd.DataFrame, sinkage_m=None) -> pd.DataFrame:
        X = super().transform(table)
        X["fast_model_z_over_b"] = fast_sinkage(table, settings=self.settings) / table["width_m"].to_numpy(float)
        return X

    def metadata(self) -> dict:
        return {"fast_model": self.settings}


def errors(model_m, cel_m) -> dict[str, float]:
    """How the model's sinkage departs from the CEL's: median |error|, the fractions within 10 and
    15 %, the mean error and the RMS of log(model/CEL)."""
    relative = np.asarray(model_m) / np.asarray(cel_m) - 1.0
    return {"median_abs_error": float(np.median(np.abs(relative))),
            "within_10pct": float(np.mean(np.abs(relative) <= 0.10)),
            "within_15pct": float(np.mean(np.abs(relative) <= 0.15)),
            "mean_error": float(np.mean(relative)),
            "rms_log_error": float(np.sqrt(np.mean(np.log1p(relative) ** 2)))}


def calibrate(table: pd.DataFrame, start: Coefficients | None = None, settings: dict | None = None) -> Coefficients:
    """The :data:`FITTED` coefficients that minimise Σ log²(model/CEL) over the rows (the model's form
    and fill: ``settings``, by default the 2D cross-section's)."""
    from scipy.optimize import least_squares

    settings = settings or default_settings()
    start = start or Coefficients(**settings["coefficients"])
    landing, factor = table_landing(table, settings), table_factor(table, settings)
    cel = table[TARGET_METRIC].to_numpy(float)

    def residual(values):
        model = sinkage(landing, factor, replace(start, **dict(zip(FITTED, values))))
        return np.log(model / cel)

    fit = least_squares(residual, [getattr(start, name) for name in FITTED], bounds=(0.0, 50.0), diff_step=1e-3)
    return replace(start, **dict(zip(FITTED, fit.x)))


def held_out(table: pd.DataFrame, folds: int = 5, seed: int = 0, settings: dict | None = None) -> np.ndarray:
    """Each row's sinkage (m) from coefficients calibrated on the other folds."""
    fold = np.random.default_rng(seed).permutation(len(table)) % folds
    out = np.empty(len(table))
    for k in range(folds):
        fitted = calibrate(table[fold != k].reset_index(drop=True), settings=settings)
        out[fold == k] = fast_sinkage(table[fold == k].reset_index(drop=True), fitted, settings)
    return out


def nested_r2(table: pd.DataFrame, folds: int = 10, seed: int = 0, settings: dict | None = None) -> dict[str, float]:
    """k-fold R² on z/B with the coefficients refitted on the training folds only: the fast model
    alone, and a random forest and XGBoost on the physics features (the hyper-parameters
    ``dsmv-train``'s grid picks on the Table 3 dataset)."""
    from sklearn.ensemble import RandomForestRegressor
    from sklearn.metrics import r2_score
    from sklearn.model_selection import KFold
    from xgboost import XGBRegressor

    y, inputs = target(table), LeakFreeFeatures().transform(table)
    models = {"random forest": lambda: RandomForestRegressor(146, max_depth=9, random_state=seed),
              "xgboost": lambda: XGBRegressor(n_estimators=400, max_depth=3, learning_rate=0.1, subsample=0.8,
                                              min_child_weight=3, random_state=seed)}
    predicted = {name: np.empty(len(y)) for name in ["fast model", *models]}
    for train, test in KFold(folds, shuffle=True, random_state=seed).split(inputs):
        fitted = calibrate(table.iloc[train].reset_index(drop=True), settings=settings)
        fast = fast_sinkage(table, fitted, settings) / table["width_m"].to_numpy(float)
        X = inputs.assign(fast_model_z_over_b=fast)
        predicted["fast model"][test] = fast[test]
        for name, make in models.items():
            predicted[name][test] = make().fit(X.iloc[train], y[train]).predict(X.iloc[test])
    return {name: float(r2_score(y, p)) for name, p in predicted.items()}


def _describe(label: str, e: dict) -> str:
    return (f"{label:<22} median |error| {e['median_abs_error']:.1%}, within 10 %: {e['within_10pct']:.0%}, "
            f"within 15 %: {e['within_15pct']:.0%}, mean {e['mean_error']:+.1%}, RMS log {e['rms_log_error']:.3f}")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(prog="python -m dsmv.surrogate.fast_model", description=__doc__.split("\n\n")[0])
    parser.add_argument("dataset", help="a dataset.csv (dsmv-train writes one beside its models)")
    parser.add_argument("--nested", action="store_true",
                        help="also the 10-fold R² on z/B with the coefficients refitted inside each fold")
    parser.add_argument("--solver", default="cel2d", choices=sorted(FAST_MODEL_CONFIG),
                        help="what the dataset's runs landed: cel2d, the 2D section (solver=analytic_dynamic); "
                             "cel3d, the 3D track (solver=analytic_dynamic_3d)")
    args = parser.parse_args(argv)
    table = pd.read_csv(args.dataset)
    cel = table[TARGET_METRIC].to_numpy(float)
    settings = default_settings(args.solver)
    fitted = calibrate(table, settings=settings)
    print(f"{len(table)} CEL landings; fitted " + ", ".join(f"{n} = {getattr(fitted, n):.3f}" for n in FITTED))
    print(_describe("defaults", errors(fast_sinkage(table, settings=settings), cel)))
    print(_describe("fitted, in sample", errors(fast_sinkage(table, fitted, settings), cel)))
    print(_describe("fitted, 5-fold held out", errors(held_out(table, settings=settings), cel)))
    if args.nested:
        scores = nested_r2(table, settings=settings)
        print("10-fold R² on z/B, coefficients refitted in each fold: "
              + ", ".join(f"{name} {r2:.4f}" for name, r2 in scores.items()))


if __name__ == "__main__":
    main()
