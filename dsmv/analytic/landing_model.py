"""The fast landing model: the equation of motion with the resistance the CEL shows matters.

Per track, with n tracks sharing the wet weight m·g, the body's kinetic energy K falls with depth z
as the resistance R does work against it (the energy balance of the reference study's Eq. 3, with
a resistance that depends on where and how fast the body moves):

    dK/dz = W − R(z, v),     K(0) = ½·M·v0²,     v = √(2K/M)

and the sinkage is the depth where K reaches zero. The resistance, on the contact area A = B·L:

    R = A·{ m(z)·Nc·sc·G(κ)·d(z)·f(ξ_op, γ̇_op)·su(z) + ρ'·g·z + ½·Cd·ρ'·v² }

- su(z) = su0 + ks·z, the intact strength at the base's depth; or a table's (``soil.profile``).
- G(κ), κ = ks·B/su(z): the rise of a rough strip's bearing factor with the strength gradient
  below it (Davis & Booker 1973; a table's at the base's depth), q/su0 normalised by the weightless
  surface value. The table :data:`GRADIENT_FACTOR` is this project's finite-element limit analysis
  (the midpoints of the rigorous brackets of ``python -m dsmv.analytic.limit_analysis --roughness rough --gradient K``,
  each divided by the κ = 0 midpoint): it matches Davis & Booker's chart where the two overlap.
- d(z) = 1 + a·√(z/B): the rise with embedment and the heave beside the body. Salgado et al. (2004)
  give a ≈ 0.27 for a strip wished in place; a landing also heaves the soil beside it, and a is
  fitted to the CEL.
- f: the soil law's strength factor at an operative plastic shear strain ξ_op = c_ξ·z/B and strain
  rate γ̇_op = c_γ·v/B: the plugin's own NumPy twin (``strength_factor``), so any law runs. γ̇ = v/B
  is the usual normalisation (Einav & Randolph 2005 use v/D for a T-bar): c_γ = 1. The shear strain
  the soil in the mechanism has gathered when the base is z deep is c_ξ·z/B, c_ξ fitted to the CEL.
- m(z) = 1 − exp(−z/z_e), z_e = c_e·Nc·B·su0/E: the resistance is mobilised over the elastic
  settlement of a strip carrying Nc·su0 (of order q·B/E); c_e = 1.
- ρ'·g·z: the buoyancy of the embedded body (Archimedes, on the buoyant density the CEL carries).
- ½·Cd·ρ'·v²: the inertial drag of the soil set moving, as in the free-fall penetrometer models
  (True 1976; O'Loughlin et al. 2013); Cd on ρ' fitted to the CEL.
- sc: 1 (plane strain, the 2D section the CEL models), ``skempton`` (1 + 0.2·B/L) for a 3D estimate,
  or a number.

The coefficients fitted to the CEL (least squares on log sinkage, the 257 landings of
``experiment=dataset_table3`` on the standard mesh) and their values are in
``conf/solver/analytic_dynamic.yaml``; ``python -m dsmv.surrogate.fast_model DATASET.csv`` repeats
the fit and reports the error, in sample and held out (5-fold).

References: Davis, E. H. & Booker, J. R. (1973), Géotechnique 23(4), 551–563. Salgado, R., Lyamin,
A. V., Sloan, S. W. & Yu, H. S. (2004), Géotechnique 54(5), 279–291. Einav, I. & Randolph, M. F.
(2005), IJNME 63, 1991–2016. True, D. G. (1976), PhD thesis, UC Berkeley. O'Loughlin, C. D.,
Richardson, M. D., Randolph, M. F. & Gaudin, C. (2013), Géotechnique 63(11), 909–919.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from functools import lru_cache
from pathlib import Path
from typing import Annotated, Callable, Literal, Union

import numpy as np
from pydantic import BeforeValidator, Field

from dsmv.analytic.bearing import PRANDTL_NC
from dsmv.config.location import CONFIG_DIR
from dsmv.config.profile import DensityLayers, StrengthSegments, weighed
from dsmv.config.schema import Count, Number, Schema

#: (κ = ks·B/su, G): a rough surface strip's q/su0 over its weightless value. The midpoints of the
#: limit-analysis brackets (default mesh, 8480 triangles): κ = 0 [5.1254, 5.1765], 0.25 [5.5722,
#: 5.6350], 0.5 [5.9468, 6.0230], 1 [6.5688, 6.6730], 2 [7.5404, 7.6898]; beyond κ = 2 G grows on
#: (Davis & Booker's chart: 1.47 at 4), held at the last value here
GRADIENT_FACTOR = ((0.0, 0.25, 0.5, 1.0, 2.0), (1.0, 1.0879, 1.1619, 1.2854, 1.4784))
#: depth steps per body width (fewer near rest, where K may at most halve per step): against 8000,
#: 1000 changes the sinkage by at most 6e-4 relative on the 257 landings of the Table 3 design
#: (500: 2e-3, 2000: 1.8e-4)
STEPS_PER_WIDTH = 1000
#: the body is at rest once its speed falls below this fraction of the touchdown speed. A rate-
#: dependent soil whose static capacity is just below the weight lets the body creep on at a
#: vanishing speed (the power law's terminal speed scales with the excess force to the power 1/n):
#: the CEL, whose soil rebounds elastically, ends such a landing at its first rest
REST_SPEED_FRACTION = 1e-3
#: a body whose fall has stopped is at rest once it also slides, and turns at its reach, no faster than this
#: fraction of its speed at touchdown (cel3d's rule and the fast vehicle model's)
REST_SPEED_AFTER_FALL = 0.01
#: a dropped body is at rest only once the soil bears it: its force on the body at least its weight less
#: this fraction of it (a body stopped for an instant at the top of a bounce, borne by less, falls again),
#: and, for a body free to turn, its moment about the centre of gravity, where the weight acts, under this
#: fraction of the weight times the body's reach (a vehicle rocked onto one track stops for an instant with
#: its weight's whole moment about that track still turning it): cel3d's rule
#: (:class:`dsmv.cel.controller.Rest`) and the fast vehicle model's
REST_OUT_OF_BALANCE = 0.05
#: the depth (in body widths) beyond which the body is said not to stop
LARGEST_SINKAGE_WIDTHS = 20.0


def gradient_factor(kappa):
    """G(κ) (-): the bearing factor's rise with the strength gradient κ = ks·B/su (-)."""
    return np.interp(kappa, *GRADIENT_FACTOR)


def _check_shape_factor(value):
    if value in ("plane_strain", "skempton") or (
            isinstance(value, (int, float)) and not isinstance(value, bool) and value > 0):
        return value
    raise ValueError("must be 'plane_strain' (sc = 1), 'skempton' (sc = 1 + 0.2·B/L) or a number > 0")


@dataclass(frozen=True)
class Coefficients:
    """The model's dimensionless coefficients (values and sources: ``conf/solver/analytic_dynamic.yaml``)."""

    depth_coefficient: float    # a in d = 1 + a·√(z/B)
    strain_coefficient: float   # c_ξ in ξ_op = c_ξ·z/B
    rate_coefficient: float     # c_γ in γ̇_op = c_γ·v/B
    elastic_coefficient: float  # c_e in z_e = c_e·Nc·B·su0/E
    drag_coefficient: float     # Cd of ½·Cd·ρ'·v²


class AnalyticDynamicConfig(Schema):
    """Config of ``solver=analytic_dynamic``."""

    name: Literal["analytic_dynamic"]
    bearing_factor: Number = Field(PRANDTL_NC, gt=0, description="Nc (-); Prandtl 2 + π")
    shape_factor: Annotated[Union[str, float], BeforeValidator(_check_shape_factor)] = Field(
        "plane_strain", description="plane_strain: 1 (the CEL's 2D section) | skempton: 1 + 0.2·B/L | a number")
    depth_coefficient: Number = Field(ge=0, description="a in d = 1 + a·√(z/B) (-)")
    strain_coefficient: Number = Field(ge=0, description="c_ξ in ξ = c_ξ·z/B (-)")
    rate_coefficient: Number = Field(ge=0, description="c_γ in γ̇ = c_γ·v/B (-)")
    elastic_coefficient: Number = Field(ge=0,
                                        description="c_e in z_e = c_e·Nc·B·su0/E (-); 0: rigid-plastic")
    drag_coefficient: Number = Field(ge=0, description="Cd of ½·Cd·ρ'·v² (-)")
    buoyancy: bool = Field(True, description="the embedded body's buoyancy ρ'·g·z·A")
    grousers: bool = Field(False, description=(
        "a track's grousers cut in first, as the 3D CEL lands them (its tips start gh deep, carrying the soil "
        "they trap; the sinkage is the tips'); false: a flat base, the 2D cross-section's"))
    history_points: Count = Field(200, ge=2, description="samples in the time history (-)")

    def coefficients(self) -> Coefficients:
        return Coefficients(**{f.name: getattr(self, f.name) for f in fields(Coefficients)})


@dataclass
class Landing:
    """Arrays (one entry per landing, broadcast together) in SI units."""

    weight_n: np.ndarray          # W per track (N)
    inertia_kg: np.ndarray        # M per track (kg)
    velocity_m_s: np.ndarray      # v0 at touchdown (m/s)
    width_m: np.ndarray           # B (m)
    area_m2: np.ndarray           # A = B·L (m²)
    su0_pa: np.ndarray            # su at the mudline (Pa)
    ks_pa_per_m: np.ndarray       # strength gradient (Pa/m)
    density_kg_m3: np.ndarray     # ρ' buoyant (kg/m³)
    youngs_modulus_pa: np.ndarray  # E (Pa)
    gravity_m_s2: np.ndarray      # g (m/s²)
    shape_factor: np.ndarray      # sc (-)
    grouser_height_m: np.ndarray | float = 0.0  # gh: grousers cut in first (the 3D track), 0: a flat base
    strength: StrengthSegments | None = None  # a bent strength table shared by all (None: su0 + ks·z)
    strength_scale: np.ndarray | float = 1.0  # each landing's factor on that table (soil.profile_scale drawn)
    density: DensityLayers | None = None  # a density the table layers, shared by all (None: density_kg_m3)


#: the Landing fields shared by all its landings (a strength table, a layered density); the others are arrays
SHARED = ("strength", "density")


def density_at(landing: Landing, depth_m):
    """ρ' at the base's depth (kg/m³)."""
    if landing.density is None:
        return landing.density_kg_m3
    return landing.density.lightest_kg_m3 * landing.density.ratio_at(depth_m)


def strength_at(landing: Landing, depth_m):
    """su at the base's depth (Pa) and its gradient there (Pa/m): the straight line's su0 + ks·z and ks,
    or a table's, the gradient that of the segment below the base. (The table's mean gradient over the
    width B below the base, where the mechanism reaches, read the CCZ box-core landing 19 % deeper than
    the 2D CEL, the local one 6 %, as the straight line's default landing reads.)"""
    if landing.strength is None:
        return landing.su0_pa + landing.ks_pa_per_m * depth_m, landing.ks_pa_per_m
    scale = landing.strength_scale
    return scale * landing.strength.su(depth_m), scale * landing.strength.gradient(depth_m)


def resistance(landing: Landing, depth_m, speed_m_s, factor: Callable, c: Coefficients,
               bearing_factor: float = PRANDTL_NC, buoyancy: bool = True):
    """R(z, v) (N) per track: the module's formula at depth z (m) and speed v (m/s)."""
    b, z, v = landing.width_m, np.asarray(depth_m, dtype=float), np.asarray(speed_m_s, dtype=float)
    bearing_on = z - landing.grouser_height_m  # how far the base has gone since it began to bear (m)
    su, gradient = strength_at(landing, z)
    bearing = bearing_factor * landing.shape_factor * gradient_factor(gradient * b / su)
    bearing = bearing * (1.0 + c.depth_coefficient * np.sqrt(z / b))
    elastic_depth = c.elastic_coefficient * bearing_factor * b * landing.su0_pa / landing.youngs_modulus_pa
    mobilised = -np.expm1(-bearing_on / elastic_depth) if c.elastic_coefficient > 0.0 else 1.0
    strength = factor(c.strain_coefficient * bearing_on / b, c.rate_coefficient * v / b, z)
    pressure = mobilised * bearing * strength * su + 0.5 * c.drag_coefficient * density_at(landing, z) * v * v
    if buoyancy:  # ρ'·g·z, the column's buoyant weight
        rho, height = weighed(landing.density_kg_m3, landing.density, z)
        pressure = pressure + rho * landing.gravity_m_s2 * height
    return landing.area_m2 * pressure


def cut_in(landing: Landing) -> Landing:
    """A track whose grousers cut in first, as the 3D CEL lands it (``dsmv.cel.solver.CelSolver.start``):
    its tips gh deep at the speed gained falling gh under its wet weight (the blades' own resistance
    neglected), carrying the soil trapped between the grousers (its buoyant weight and mass)."""
    gh = landing.grouser_height_m
    rho, height = weighed(landing.density_kg_m3, landing.density, gh)
    trapped_kg = rho * landing.area_m2 * height
    speed = np.sqrt(landing.velocity_m_s**2 + 2.0 * landing.weight_n / landing.inertia_kg * gh)
    return replace(landing, velocity_m_s=speed, inertia_kg=landing.inertia_kg + trapped_kg,
                   weight_n=landing.weight_n + trapped_kg * landing.gravity_m_s2)


def sinkage(landing: Landing, factor: Callable, c: Coefficients, bearing_factor: float = PRANDTL_NC,
            buoyancy: bool = True, history: bool = False):
    """The depth (m) where each landing comes to rest (``inf`` if it would pass 20 B).

    Midpoint steps in depth of B/1000 on dK/dz = W − R(z, v); the rest depth is found by linear
    interpolation of K between the last two steps. With ``history``, also the (depth, speed) of
    every step (2D arrays, steps × landings; speed 0 after rest)."""
    fields_ = {f.name: np.asarray(getattr(landing, f.name), dtype=float) for f in fields(Landing)
               if f.name not in SHARED}
    shape = np.broadcast_shapes(*(a.shape for a in fields_.values()))
    lb = cut_in(Landing(**{k: np.broadcast_to(a, shape) for k, a in fields_.items()}, strength=landing.strength,
                         density=landing.density))
    step = lb.width_m / STEPS_PER_WIDTH
    kinetic = 0.5 * lb.inertia_kg * lb.velocity_m_s**2
    at_rest = REST_SPEED_FRACTION**2 * kinetic
    depth = np.array(lb.grouser_height_m, dtype=float)
    rest = np.full(shape, np.inf)
    moving = np.ones(shape, dtype=bool)
    trace = [(depth.copy(), lb.velocity_m_s.copy())] if history else None

    def force(z, k):
        v = np.sqrt(np.maximum(2.0 * k / lb.inertia_kg, 0.0))
        return lb.weight_n - resistance(lb, z, v, factor, c, bearing_factor, buoyancy)

    for _ in range(int(LARGEST_SINKAGE_WIDTHS * STEPS_PER_WIDTH)):
        slope = force(depth, kinetic)
        # near rest a rate law's resistance changes fast with the speed (γ̇^n): steps that let K
        # fall by at most a half there
        dz = np.where(slope < 0.0, np.minimum(step, -0.5 * kinetic / np.minimum(slope, -1e-300)), step)
        half = kinetic + 0.5 * dz * slope
        after = kinetic + dz * force(depth + 0.5 * dz, half)
        stops = moving & (after <= at_rest)
        rest[stops] = depth[stops] + dz[stops] * (kinetic[stops] - at_rest[stops]) / (kinetic[stops] - after[stops])
        moving &= ~stops
        kinetic = np.where(moving, after, 0.0)
        depth = np.where(moving, depth + dz, rest)
        if history:
            trace.append((depth.copy(), np.sqrt(2.0 * kinetic / lb.inertia_kg)))
        if not moving.any():
            break
    if history:
        return rest, np.array([t[0] for t in trace]), np.array([t[1] for t in trace])
    return rest


@lru_cache(maxsize=2)
def default_config(form: str = "analytic_dynamic") -> AnalyticDynamicConfig:
    """``conf/solver/<form>.yaml``: the coefficients the model was fitted with, to the 2D section's CEL
    landings (``analytic_dynamic``) or the 3D track's (``analytic_dynamic_3d``)."""
    from omegaconf import OmegaConf

    values = OmegaConf.to_container(OmegaConf.load(Path(CONFIG_DIR) / "solver" / f"{form}.yaml"))
    return AnalyticDynamicConfig.model_validate(values)
