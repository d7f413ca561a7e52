"""Fit a soil law's parameters to site tests, with their uncertainty (``dsmv-calibrate``).

The fit minimises the squared log misfit Σ ln²(model/measured) over every row of every test: the
tests' errors are relative (a resistance read to a few per cent at any strength), so a log residual
weighs a soft and a stiff layer alike. The models are :mod:`dsmv.analytic.penetrometer`'s; the
parameters are config keys (``soil.su0_pa``, ``soil.rate.eta``, a plugin law's ``soil.params.*``), each
between bounds, searched by a bounded trust-region least squares (scipy ``least_squares``, ``trf``).

**Uncertainty: a residual bootstrap.** Each of ``bootstrap`` resamples keeps the best fit's model
values and multiplies them by residuals drawn with replacement from the same test's own residuals
(inflated by √(n/(n − p)) for the degrees of freedom the fit used), and is fitted again. The
interval is the basic bootstrap's, the draws' percentiles reflected about the best fit: on 20 noise
draws of the synthetic site it held the truth 92 times in 100 (percentiles: 89; the strength su0,
whose estimate leans, 19 in 20 against 16). Why a
bootstrap: the models are nonlinear and the parameters bounded (St ≥ 1, η ≥ 0), where a linearised
covariance misstates an interval that reaches a bound; the draws are a joint sample that keeps the
parameters' correlations (T-bar data fix su·R(γ̇), so su0 and η trade), and ``dsmv-predict
task=exceedance`` samples them jointly. Each resample refits from the best fit, which makes it a
few Jacobians.

**Resolved or not.** A parameter is resolved when its 90 % interval is narrower than
``resolved_width`` times its best value, both the bootstrap's and the linearised one, from the
Jacobian of the log residuals in ln p at the best fit: C = σ²·(JᵀJ)⁻¹. The bootstrap sees a
parameter the data pin loosely wander across the resamples (ξ95 without a cyclic test); the
Jacobian sees a direction the data do not pin at all, along which a refit does not move from where
it starts (γ̇ref beside η: a power law sees only η·γ̇ref^−n, a valley with a flat floor).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.optimize import least_squares

from dsmv import registry
from dsmv.analytic.penetrometer import PenetrometerModel, fall_cone_depth, tbar_resistance
from dsmv.calibration.data import SiteTest
from dsmv.config.scene import SoilConfig
from dsmv.config.schema import _validate
from dsmv.errors import ConfigError

#: bounds of the parameters a calibration may fit when the config gives none: the soil's schema limits
#: and the widest ranges soft clays show (St up to quick clays; ξ95 and η beyond Table 3's ranges)
DEFAULT_BOUNDS = {
    "soil.su0_pa": (1.0, 1.0e6), "soil.ks_pa_per_m": (0.0, 1.0e6), "soil.sensitivity": (1.0, 100.0),
    "soil.xi95": (1.0, 500.0), "soil.rate.eta": (0.0, 10.0), "soil.rate.n": (0.01, 1.0),
    "soil.rate.gamma_dot_ref": (1e-12, 1.0), "soil.rate.mu": (0.0, 5.0), "soil.profile_scale": (0.05, 20.0),
}
#: a table's strengths are its own (soil.profile_scale sets their level); a straight line's are su0 and ks
TABLE_SETS = ("soil.su0_pa", "soil.ks_pa_per_m")


def _get(tree: dict, key: str):
    node = tree
    for part in key.split(".")[1:]:
        if not isinstance(node, dict) or part not in node:
            raise ConfigError("calibrate.parameters", key, "not a number of the soil (e.g. soil.su0_pa, soil.rate.eta, "
                              "soil.params.NAME)")
        node = node[part]
    if isinstance(node, bool) or not isinstance(node, (int, float)):
        raise ConfigError("calibrate.parameters", key, "not a number of the soil (e.g. soil.su0_pa, soil.rate.eta, "
                          "soil.params.NAME)")
    return node


def _set(tree: dict, key: str, value: float) -> None:
    parts = key.split(".")[1:]
    node = tree
    for part in parts[:-1]:
        node = node[part]
    node[parts[-1]] = float(value)


@dataclass
class Problem:
    """The tests, the soil they are fitted in, the parameters fitted and the models' constants."""

    tests: list[SiteTest]
    soil: dict                  # the starting soil (a resolved ``soil`` group), every value not fitted
    keys: list[str]             # the config keys fitted
    bounds: list[tuple[float, float]]
    model: PenetrometerModel
    gravity_m_s2: float = 9.81
    #: each test's rows' factors, the CEL's values over the models' at a fit (None: the models alone)
    correction: list[np.ndarray] | None = None

    def __post_init__(self):
        if not self.keys:
            raise ConfigError("calibrate.parameters", [], "name at least one soil key to fit")
        if self.soil.get("profile") is not None and (fixed := [k for k in self.keys if k in TABLE_SETS]):
            raise ConfigError("calibrate.parameters", fixed, "the soil's table (soil.profile) sets its strengths: "
                              "fit soil.profile_scale, their level")
        if self.soil.get("profile") is None and "soil.profile_scale" in self.keys:
            raise ConfigError("calibrate.parameters", "soil.profile_scale", "scales a table (soil.profile); this "
                              "soil is su0 + ks·z: fit soil.su0_pa and soil.ks_pa_per_m")
        self._law_cls = registry.load("soil_laws", self.soil["law"], "soil.law")
        self.start = np.array([float(_get(self.soil, k)) for k in self.keys])
        for key, value, (low, high) in zip(self.keys, self.start, self.bounds):
            if not low <= value <= high:
                raise ConfigError(key, value, f"the starting value lies outside its bounds [{low:g}, {high:g}]")
        self.measured = np.concatenate([t.measured for t in self.tests])

    def soil_at(self, values) -> SoilConfig:
        tree = {**self.soil, "rate": dict(self.soil["rate"]), "params": dict(self.soil.get("params", {}))}
        for key, value in zip(self.keys, values):
            _set(tree, key, value)
        return _validate(SoilConfig, tree, "soil")

    def predict(self, values, tests: list[SiteTest] | None = None, corrected: bool = True) -> list[np.ndarray]:
        """Each test's modelled values (its measured quantity, SI) in the soil at ``values``: this problem's
        tests, or ``tests`` of the same kinds. This problem's own are times its CEL correction, if it has
        one and ``corrected`` (:mod:`dsmv.calibration.correction`)."""
        soil = self.soil_at(values)
        law, strength = self._law_cls(soil), soil.strength
        out = []
        for test in self.tests if tests is None else tests:
            c = test.columns
            if test.kind == "tbar":
                passes = 2.0 * (c["cycle"] - 1.0)
                out.append(tbar_resistance(self.model, law, strength, c["depth"], c["velocity"], test.diameter_m,
                                           passes))
            else:
                out.append(fall_cone_depth(self.model, law, strength, c["mass"], test.apex_angle_deg,
                                           c["sample_depth"], self.gravity_m_s2))
        if self.correction is not None and corrected and tests is None:
            out = [modelled * factors for modelled, factors in zip(out, self.correction)]
        return out

    def residuals(self, values, measured=None) -> np.ndarray:
        modelled = np.concatenate(self.predict(values))
        return np.log(modelled / (self.measured if measured is None else measured))


@dataclass
class Calibration:
    """A fit's answer: best values, the bootstrap draws, intervals, what the data resolved."""

    keys: list[str]
    best: np.ndarray
    draws: np.ndarray           # (bootstrap, parameters)
    confidence: float
    resolved_width: float
    residuals: np.ndarray       # log residuals at the best fit, tests concatenated
    test_slices: list[slice]
    failed_resamples: int = 0
    linear_width: np.ndarray | None = None   # the linearised interval's width over the best value (-)
    bounds: list | None = None               # the parameters' bounds, which the intervals keep to
    lower: np.ndarray = field(init=False)
    upper: np.ndarray = field(init=False)

    def __post_init__(self):
        """The basic bootstrap interval: the draws' spread reflected about the best fit, [2θ̂ − q_hi, 2θ̂ − q_lo],
        which takes off the estimator's own bias to first order (the draws sit about θ̂ as θ̂ sits about
        the truth); kept within the bounds."""
        tail = 100.0 * (1.0 - self.confidence) / 2.0
        low, high = np.percentile(self.draws, [tail, 100.0 - tail], axis=0)
        self.lower, self.upper = 2.0 * self.best - high, 2.0 * self.best - low
        if self.bounds is not None:
            edges = np.array(self.bounds, dtype=float)
            self.lower, self.upper = np.maximum(self.lower, edges[:, 0]), np.minimum(self.upper, edges[:, 1])

    @property
    def resolved(self) -> list[bool]:
        width = self.upper - self.lower
        linear = self.linear_width if self.linear_width is not None else np.zeros(len(self.best))
        return [bool(w <= self.resolved_width * abs(b) and lw <= self.resolved_width)
                for w, b, lw in zip(width, self.best, linear)]

    def rms(self, k: int) -> float:
        """Test k's root-mean-square log misfit at the best fit (≈ its relative scatter)."""
        return float(np.sqrt(np.mean(self.residuals[self.test_slices[k]] ** 2)))


def _solve(fun: Callable, start, bounds) -> np.ndarray:
    low, high = np.array(bounds, dtype=float).T
    scale = np.where(start > 0, start, np.maximum(high, 1.0) * 1e-3)   # parameters of order one to the solver
    result = least_squares(lambda x: fun(x * scale), np.clip(start, low, high) / scale,
                           bounds=(low / scale, high / scale), method="trf", x_scale="jac")
    return result.x * scale


def linear_widths(problem: Problem, best, confidence: float, step: float = 1e-3) -> np.ndarray:
    """Each parameter's linearised interval, as its width over the best value (-): central differences
    of the log residuals in ln p (a parameter at zero: in p/its upper bound), C = σ²·(JᵀJ + εI)⁻¹ with
    ε = 1e-12 of JᵀJ's largest eigenvalue, so that a direction the data do not see gets a huge width."""
    from scipy.stats import norm

    residuals = problem.residuals(best)
    columns = []
    for j, value in enumerate(best):
        up, down = best.copy(), best.copy()
        if value > 0:
            up[j], down[j] = value * math.exp(step), value * math.exp(-step)
            scale = 1.0
        else:   # ln p is undefined at zero: relative to the bound instead, one-sided
            up[j] = step * problem.bounds[j][1]
            down[j] = value
            scale = 2.0
        columns.append((problem.residuals(up) - problem.residuals(down)) / (2.0 * step) * scale)
    jacobian = np.array(columns).T
    sigma2 = float(residuals @ residuals) / max(len(residuals) - len(best), 1)
    normal = jacobian.T @ jacobian
    normal += 1e-12 * max(np.linalg.eigvalsh(normal).max(), 1e-300) * np.eye(len(best))
    std = np.sqrt(sigma2 * np.diag(np.linalg.inv(normal)))
    return 2.0 * norm.ppf(0.5 + confidence / 2.0) * std


def best_fit(problem: Problem) -> np.ndarray:
    """The values that fit the data best, searched from the starting soil's."""
    return _solve(problem.residuals, problem.start, problem.bounds)


def calibrate(problem: Problem, bootstrap: int = 200, confidence: float = 0.9, resolved_width: float = 0.2,
              seed: int = 0, progress: Callable[[int, int], None] | None = None) -> Calibration:
    """The best fit and ``bootstrap`` refits on resampled residuals (see the module's docstring)."""
    best = best_fit(problem)
    residuals = problem.residuals(best)
    modelled = problem.measured * np.exp(residuals)
    slices, at = [], 0
    for test in problem.tests:
        slices.append(slice(at, at + len(test)))
        at += len(test)
    dof = max(len(residuals) - len(best), 1)
    inflate = np.sqrt(len(residuals) / dof)
    rng = np.random.default_rng(seed)
    draws, failed = [], 0
    for b in range(bootstrap):
        noise = np.empty_like(residuals)
        for s in slices:
            centred = residuals[s] - residuals[s].mean()
            noise[s] = rng.choice(centred, size=s.stop - s.start) * inflate
        resampled = modelled / np.exp(noise)
        try:
            draws.append(_solve(lambda v: problem.residuals(v, resampled), best, problem.bounds))
        except (ValueError, FloatingPointError):
            failed += 1
        if progress is not None:
            progress(b + 1, bootstrap)
    if not draws:
        raise ValueError("every bootstrap refit failed")
    return Calibration(problem.keys, best, np.array(draws), confidence, resolved_width, residuals, slices, failed,
                       linear_widths(problem, best, confidence), problem.bounds)


__all__ = ["Problem", "Calibration", "calibrate", "best_fit", "DEFAULT_BOUNDS"]
