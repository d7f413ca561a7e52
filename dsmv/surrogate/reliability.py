"""The reliability of a landing: P(max sinkage > limit) when the soil and the landing are uncertain.

``dsmv-predict task=exceedance sinkage_limit_m=…`` draws ``uncertainty.samples`` scenes from the
distributions of the config group ``uncertainty`` (nested as the scene is)::

    uncertainty:
      soil:
        su0_pa: {dist: lognormal, median: 5000, cov: 0.2}
      landing:
        velocity_m_s: {dist: uniform, low: 1.0, high: 2.0}

(``normal``: ``mean`` and ``cov``, truncated at zero; ``lognormal``: ``median`` and ``cov``, the
coefficient of variation of the variable itself; ``uniform``: ``low`` and ``high``), every other
scene value as the scene has it. Parameters known together, as a calibration knows them
(``dsmv-calibrate`` writes them), come as joint draws: ``uncertainty.joint: PATH``, a CSV whose
columns are config keys and whose rows are draws; each sample takes one row at random, so the
parameters keep their correlations. The registered surrogate predicts each scene's sinkage and its
interval. The answer:

- P = the fraction of samples whose predicted sinkage exceeds the limit, with its Monte Carlo
  standard error √(P(1 − P)/N);
- the model's uncertainty: the same fraction on the interval's lower and upper bounds (at the
  prediction's ``confidence``), a range P must lie in if the bounds hold for every scene.

Lognormal: σ_ln = √(ln(1 + cov²)), μ_ln = ln(median) (Ang & Tang 2007, §3.2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import pandas as pd
from pydantic import Field

from dsmv.config.schema import Count, Number, Schema, _validate
from dsmv.errors import ConfigError
from dsmv.surrogate.dataset import COLUMNS


class Distribution(Schema):
    """One uncertain parameter's distribution."""

    dist: Literal["normal", "lognormal", "uniform"] = Field(description="normal | lognormal | uniform")
    mean: Number | None = Field(None, gt=0, description="normal: the mean (the parameter's units)")
    median: Number | None = Field(None, gt=0, description="lognormal: the median (the parameter's units)")
    cov: Number | None = Field(None, ge=0, description="normal, lognormal: coefficient of variation (-)")
    low: Number | None = Field(None, description="uniform: the lower end")
    high: Number | None = Field(None, description="uniform: the upper end")

    def needs(self) -> tuple[str, ...]:
        return {"normal": ("mean", "cov"), "lognormal": ("median", "cov"), "uniform": ("low", "high")}[self.dist]

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        if self.dist == "lognormal":
            sigma = math.sqrt(math.log1p(self.cov**2))
            return self.median * np.exp(sigma * rng.standard_normal(n))
        if self.dist == "uniform":
            return rng.uniform(self.low, self.high, n)
        return np.maximum(self.mean * (1.0 + self.cov * rng.standard_normal(n)), 0.0)


@dataclass(frozen=True)
class Uncertainty:
    """The validated ``uncertainty`` group: distributions by config key, samples, seed."""

    distributions: dict[str, Distribution]
    samples: int
    seed: int
    joint: pd.DataFrame | None = None   # columns: config keys; rows: draws taken together

    @property
    def keys(self) -> list[str]:
        """The uncertain parameters' config keys: the distributions', then the joint draws'."""
        return [*self.distributions, *(() if self.joint is None else self.joint.columns)]


class UncertaintySettings(Schema):
    samples: Count = Field(10_000, ge=100, description="Monte Carlo samples (-)")
    seed: int = Field(0, description="random seed (-)")


def _flatten(node: dict, prefix: str = "") -> dict[str, dict]:
    """Nested groups → {config key: distribution mapping}; a mapping with ``dist`` is a leaf, a null is
    left out."""
    leaves = {}
    for key, value in node.items():
        path = f"{prefix}.{key}" if prefix else str(key)
        if value is None:  # an entry set to null is not drawn
            continue
        if isinstance(value, dict) and "dist" in value:
            leaves[path] = value
        elif isinstance(value, dict):
            leaves |= _flatten(value, path)
        else:
            raise ConfigError(f"uncertainty.{path}", value, "must be a distribution: {dist: normal | lognormal | "
                                                           "uniform, ...}")
    return leaves


#: what may be drawn, by config key: the surrogates' inputs, and a strength table's level, which the fast
#: vehicle model draws (the surrogates learn straight lines su0 + ks·z)
DRAWN: dict[str, str] = COLUMNS | {"soil.profile_scale": "profile_scale"}


def uncertainty_from(container: dict) -> Uncertainty:
    """The ``uncertainty`` group of a composed ``predict`` config, validated (one-line ConfigError)."""
    node = dict(container.get("uncertainty") or {})
    settings = _validate(UncertaintySettings, {k: node.pop(k) for k in ("samples", "seed") if k in node},
                         "uncertainty")
    joint_path = node.pop("joint", None)
    joint = _joint_draws(joint_path) if joint_path is not None else None
    distributions = {}
    for key, data in _flatten(node).items():
        if key not in DRAWN:
            raise ConfigError(f"uncertainty.{key}", data, f"not an uncertain parameter; one of {', '.join(DRAWN)}")
        dist = _validate(Distribution, data, f"uncertainty.{key}")
        for needed in dist.needs():
            if getattr(dist, needed) is None:
                raise ConfigError(f"uncertainty.{key}.{needed}", None, f"a {dist.dist} distribution needs it")
        if dist.dist == "uniform" and not dist.low < dist.high:
            raise ConfigError(f"uncertainty.{key}", [dist.low, dist.high], "a uniform distribution needs low < high")
        distributions[key] = dist
    if joint is not None:
        both = sorted(set(joint.columns) & set(distributions))
        if both:
            raise ConfigError(f"uncertainty.{both[0]}", "a distribution and a joint column", "give it one or the other")
    if not distributions and joint is None:
        raise ConfigError("uncertainty", None, "task=exceedance needs at least one uncertain parameter")
    return Uncertainty(distributions, settings.samples, settings.seed, joint)


def _joint_draws(path) -> pd.DataFrame:
    """``uncertainty.joint``'s CSV, checked: config keys of uncertain parameters as columns, numbers > 0."""
    file = Path(str(path))
    if not file.is_file():
        raise ConfigError("uncertainty.joint", str(path), "no such file")
    try:
        table = pd.read_csv(file, comment="#")
    except (ValueError, pd.errors.ParserError) as error:
        raise ConfigError("uncertainty.joint", str(path), f"not a CSV table ({error})") from None
    for key in table.columns:
        if key not in DRAWN:
            raise ConfigError("uncertainty.joint", f"{file.name}: column {key}",
                              f"not an uncertain parameter; one of {', '.join(DRAWN)}")
    values = table.to_numpy(dtype=float) if len(table) else np.zeros((0, 0))
    if len(table) == 0 or not np.isfinite(values).all() or (values < 0).any():
        raise ConfigError("uncertainty.joint", str(path), "needs rows of numbers ≥ 0")
    return table.astype(float)


def draw(uncertainty: Uncertainty, samples: int | None = None, seed: int | None = None) -> dict[str, np.ndarray]:
    """``samples`` values of each uncertain parameter, by config key, from one seeded generator: the
    distributions' draws, then the joint draws' rows (one row per sample, at random)."""
    samples = uncertainty.samples if samples is None else samples
    rng = np.random.default_rng(uncertainty.seed if seed is None else seed)
    values = {key: dist.sample(rng, samples) for key, dist in uncertainty.distributions.items()}
    if uncertainty.joint is not None:
        rows = rng.integers(0, len(uncertainty.joint), samples)
        values |= {key: uncertainty.joint[key].to_numpy()[rows] for key in uncertainty.joint.columns}
    return values


def sample_scenes(base: pd.DataFrame, uncertainty: Uncertainty) -> pd.DataFrame:
    """``uncertainty.samples`` rows: the base scene with each uncertain parameter drawn (seeded)."""
    table = base.loc[base.index.repeat(uncertainty.samples)].reset_index(drop=True)
    for key, values in draw(uncertainty).items():
        table[DRAWN[key]] = values
    return table


@dataclass(frozen=True)
class Exceedance:
    """P(z > limit) from the samples' predictions: the estimate, its Monte Carlo standard error,
    and the range the interval's bounds give."""

    probability: float
    monte_carlo_error: float
    model_low: float
    model_high: float
    samples: int


def exceedance(mid: np.ndarray, lower: np.ndarray, upper: np.ndarray, limit_m: float) -> Exceedance:
    """P(z > limit) on the predicted sinkages, with its errors (see the module's text)."""
    n = len(mid)
    p = float(np.mean(mid > limit_m))
    return Exceedance(p, math.sqrt(p * (1.0 - p) / n), float(np.mean(lower > limit_m)),
                      float(np.mean(upper > limit_m)), n)


def monte_carlo_cases(cfg) -> list[list[str]]:
    """``hydra.sweeper.cases_from`` of ``experiment=reliability_mc``: the CEL Monte Carlo that
    ``task=exceedance`` is checked against. ``monte_carlo.samples`` scenes drawn (seed
    ``monte_carlo.seed``) from ``conf/uncertainty/<monte_carlo.uncertainty>.yaml``, each a job."""
    from omegaconf import OmegaConf

    from dsmv.config.tree import CONFIG_DIR

    settings = OmegaConf.to_container(cfg.monte_carlo, resolve=True)
    path = Path(CONFIG_DIR) / "uncertainty" / f"{settings['uncertainty']}.yaml"
    if not path.is_file():
        raise ConfigError("monte_carlo.uncertainty", settings["uncertainty"], f"no {path}")
    samples, seed = settings["samples"], settings["seed"]
    if not isinstance(samples, int) or samples < 1:
        raise ConfigError("monte_carlo.samples", samples, "must be a whole number ≥ 1")
    uncertainty = uncertainty_from({"uncertainty": OmegaConf.to_container(OmegaConf.load(path), resolve=True)})
    draws = draw(uncertainty, samples, seed)
    return [[f"{key}={values[i]:.6g}" for key, values in draws.items()] for i in range(samples)]
