"""Features and target of the sinkage surrogates.

Target: the dimensionless sinkage z/B (z the CEL run's maximum sinkage, B the track width).
The reference study writes its target as "z/A" with A the contact area (m²): z/A has units of
1/m and is not dimensionless. With B fixed (0.6 m) in its dataset, z/B carries the same
information and is what the study's own normalisation ``E_total/(A·B·(su0 + ks·z))`` implies.

The feature sets (``train.features``; by name: :func:`dsmv.surrogate.model.feature_set`):

``study`` — the reference study's Eq. (3) inputs: δrem = 1/St, ξ95, η and the energy ratio
    Π_E = E_total / (A·B·(su0 + ks·z)),  E_total = ½·M·vi² + W·z,
    with M = m/n and W = m·g/n per track (n = 1 in the study). Π_E contains the target z itself:
    a model trained on it is told part of the answer, so its test scores flatter it. At
    prediction time z is unknown; :meth:`FeatureSet.predict_sinkage` then solves the implicit
    equation z = B·f(δrem, ξ95, η, Π_E(z)) on a grid of z (the forest is piecewise constant in z,
    so a root is a sign change of B·f − z, refined linearly) and reports how often a root exists
    and is unique.
``leak_free`` — inputs only: the raw parameters (m, A, vi, su0, ks, δrem, ξ95, η) and the groups
    Π_kin = ½·M·vi²/(A·B·su0), Π_W = W/(A·su0), Π_ks = ks·B/su0.
``physics`` (the default) — the leak-free inputs and the fast landing model's z/B: built on the
    fast model, it lives beside it (:class:`dsmv.surrogate.fast_model.PhysicsFeatures`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from dsmv.surrogate.dataset import TARGET_METRIC

TARGET = "z_over_b"  # z/B (-)


def physics(table: pd.DataFrame) -> dict[str, np.ndarray]:
    """Per-track quantities of a dataset table (SI): A (m²), M (kg), W (N), B (m), δrem (-)."""
    n = table["n_tracks"].to_numpy(float)
    mass = table["mass_kg"].to_numpy(float)
    inertial = table["inertial_mass_kg"].to_numpy(float) if "inertial_mass_kg" in table else np.full_like(mass, np.nan)
    return {
        "area_m2": table["width_m"].to_numpy(float) * table["contact_length_m"].to_numpy(float),
        "inertia_kg": np.where(np.isnan(inertial), mass, inertial) / n,
        "weight_n": mass * table["gravity_m_s2"].to_numpy(float) / n,
        "width_m": table["width_m"].to_numpy(float),
        "delta_rem": 1.0 / table["sensitivity"].to_numpy(float),
    }


def target(table: pd.DataFrame) -> np.ndarray:
    """z/B (-) of each run."""
    return table[TARGET_METRIC].to_numpy(float) / table["width_m"].to_numpy(float)


def energy_ratio(table: pd.DataFrame, sinkage_m) -> np.ndarray:
    """Π_E = (½·M·vi² + W·z) / (A·B·(su0 + ks·z)) (-) at sinkage z (m)."""
    p = physics(table)
    z = np.asarray(sinkage_m, dtype=float)
    e_total = 0.5 * p["inertia_kg"] * table["velocity_m_s"].to_numpy(float) ** 2 + p["weight_n"] * z
    strength = table["su0_pa"].to_numpy(float) + table["ks_pa_per_m"].to_numpy(float) * z
    return e_total / (p["area_m2"] * p["width_m"] * strength)


@dataclass(frozen=True)
class ImplicitSolve:
    """How the study set's implicit equation z = B·f(Π_E(z)) was solved, row by row."""

    sinkage_m: np.ndarray  # the first root (m); where none, the z of smallest |B·f − z|
    solved: np.ndarray  # bool: a sign change of B·f(z) − z was found
    n_roots: np.ndarray  # number of sign changes on the grid (-)


class FeatureSet:
    """A named way of turning a dataset table into model inputs X and back into sinkage."""

    name: str = ""
    columns: tuple[str, ...] = ()
    uses_target = False  # True when the inputs need the sinkage itself (the study's set)

    def transform(self, table: pd.DataFrame, sinkage_m=None) -> pd.DataFrame:
        raise NotImplementedError

    def metadata(self) -> dict:
        """What a trained model must record to rebuild these features (beyond the set's name)."""
        return {}

    def predict_sinkage(self, estimator, table: pd.DataFrame, **solve) -> np.ndarray:
        """Sinkage z (m) predicted for each row (the study's set solves its implicit equation)."""
        return estimator.predict(self.transform(table)) * table["width_m"].to_numpy(float)


class LeakFreeFeatures(FeatureSet):
    name = "leak_free"
    columns = ("mass_kg", "contact_area_m2", "velocity_m_s", "su0_pa", "ks_pa_per_m", "delta_rem", "xi95", "eta",
               "kinetic_number", "weight_number", "gradient_number")

    def transform(self, table: pd.DataFrame, sinkage_m=None) -> pd.DataFrame:
        p = physics(table)
        su0 = table["su0_pa"].to_numpy(float)
        v = table["velocity_m_s"].to_numpy(float)
        return pd.DataFrame({
            "mass_kg": table["mass_kg"].to_numpy(float),
            "contact_area_m2": p["area_m2"],
            "velocity_m_s": v,
            "su0_pa": su0,
            "ks_pa_per_m": table["ks_pa_per_m"].to_numpy(float),
            "delta_rem": p["delta_rem"],
            "xi95": table["xi95"].to_numpy(float),
            "eta": table["eta"].to_numpy(float),
            "kinetic_number": 0.5 * p["inertia_kg"] * v**2 / (p["area_m2"] * p["width_m"] * su0),
            "weight_number": p["weight_n"] / (p["area_m2"] * su0),
            "gradient_number": table["ks_pa_per_m"].to_numpy(float) * p["width_m"] / su0,
        }, columns=list(self.columns))


class StudyFeatures(FeatureSet):
    name = "study"
    columns = ("delta_rem", "xi95", "eta", "energy_ratio")
    uses_target = True

    def transform(self, table: pd.DataFrame, sinkage_m=None) -> pd.DataFrame:
        """The study's inputs; ``sinkage_m`` defaults to the table's own (measured) sinkage."""
        z = table[TARGET_METRIC].to_numpy(float) if sinkage_m is None else sinkage_m
        return pd.DataFrame({
            "delta_rem": physics(table)["delta_rem"],
            "xi95": table["xi95"].to_numpy(float),
            "eta": table["eta"].to_numpy(float),
            "energy_ratio": energy_ratio(table, z),
        }, columns=list(self.columns))

    def solve(self, estimator, table: pd.DataFrame, z_max_m: float, points: int = 200) -> ImplicitSolve:
        """Solve z = B·f(features(z)) for each row on ``points`` depths in [0, z_max_m] (m)."""
        n = len(table)
        grid = np.linspace(0.0, z_max_m, points)
        repeated = table.loc[table.index.repeat(points)].reset_index(drop=True)
        z = np.tile(grid, n)
        width = repeated["width_m"].to_numpy(float)
        residual = (estimator.predict(self.transform(repeated, z)) * width - z).reshape(n, points)
        sign = residual > 0.0
        changes = sign[:, :-1] & ~sign[:, 1:]  # B·f − z goes from positive to not positive
        n_roots = changes.sum(axis=1)
        first = np.argmax(changes, axis=1)
        solved = n_roots > 0
        rows = np.arange(n)
        r0, r1 = residual[rows, first], residual[rows, first + 1]
        frac = np.where(r0 - r1 > 0, r0 / np.where(r0 - r1 > 0, r0 - r1, 1.0), 0.0)
        root = grid[first] + frac * (grid[1] - grid[0])
        closest = grid[np.argmin(np.abs(residual), axis=1)]
        return ImplicitSolve(np.where(solved, root, closest), solved, n_roots)

    def predict_sinkage(self, estimator, table: pd.DataFrame, z_max_m: float = 2.0, points: int = 200, **_):
        return self.solve(estimator, table, z_max_m, points).sinkage_m
