"""Site tests as dsmv models them: the T-bar's penetration resistance and the fall cone's depth.

The calibration (:mod:`dsmv.calibration`) fits a soil law's parameters to such tests; these are its
fast forward models. Both read the soil law through its NumPy twin (``strength_factor``), so any
law plugin calibrates, and both follow Zhou & Randolph (2009): the resistance in a rate-dependent,
softening soil is the ideal (Tresca) resistance times the law's strength factor at an operative
strain and strain rate of the mechanism.

**T-bar** (diameter D, net resistance q per projected area, steady full flow at depth z), after p
passes through this soil before (a cyclic test's strokes: the penetration stroke of cycle j follows
2(j − 1) passes):

    q = N_T · su(z) · ⟨f(X·(ξ_T + p·ξ_pass), c_T·v/D)⟩,   X ~ Gamma(shape k, mean 1)

- N_T: the rough bar's flow-round factor in Tresca soil (Randolph & Houlsby 1984; Martin &
  Randolph 2006: 11.94), which dsmv's CEL reproduces (the report's check ``tbar_rough``).
- ξ_T: the mean plastic shear strain of the soil round the bar; ξ_pass: the mean strain a pass adds.
  The soil flowing round gathers strains from nil to many times the mean, and a streamline that
  shears more in one pass does so in every pass: the law's factor is averaged over a Gamma
  distribution of one multiplier X of both (generalised Gauss–Laguerre, :data:`STRAIN_POINTS`). For
  the Einav–Randolph law that is (1 + 3·ξ/(k·ξ95))^−k in place of exp(−3·ξ/ξ95): k = 1 is an
  exponential spread, k → ∞ one operative strain.
- c_T: the operative strain rate's factor on v/D.

ξ_T, ξ_pass, k and c_T are measured on dsmv's CEL (values and sources in ``conf/calibrate.yaml``;
docs: site tests): one set fits five softening soils and seven strokes of a cyclic push within 4 %,
where one operative strain (k → ∞) or an exponential spread (k = 1), each with its best ξ_T and
ξ_pass, misses by up to 6 %. The fitted ξ_pass (6.5) is near the mean strain the CEL leaves in the
bar's wake (7.55).

**Fall cone** (mass m, apex angle 2α, released from rest with its tip on the sample at depth z_s):
the equation of motion to the first rest, with

    F = N_c · su(z_s) · ⟨f(X·ξ_c, c_c·v/z)⟩ · π·(z·tan α)²,   X ~ Gamma(k_c, mean 1)

- N_c: the cone factor in Tresca soil. The energy balance at rest gives Hansbo's su = K·m·g/d² with
  K = 3/(N_c·π·tan²α); dsmv's axisymmetric CEL gives K = 1.33 for the 30° cone (report, fall cone).
- ξ_c, c_c: the cone's mean strain and strain-rate factor on v/z (the cone is self-similar: the
  strain round it does not grow with depth).

References: Randolph, M. F. & Houlsby, G. T. (1984), Géotechnique 34(4), 613–623. Martin, C. M. &
Randolph, M. F. (2006), Géotechnique 56(2), 141–145. Zhou, H. & Randolph, M. F. (2009),
Géotechnique 59(2), 79–86. Hansbo, S. (1957), Proc. R. Swed. Geotech. Inst. 14.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from pydantic import Field

from dsmv.analytic.landing_model import REST_SPEED_FRACTION
from dsmv.config.profile import StrengthSegments
from dsmv.config.schema import Number, Schema

#: steps of each phase of the cone's motion (in phase 1 a step is this share of the time to fall the
#: rate-free depth): against 3000, 30 change the depth by under 1e-6 (power law, St = 3, 60–400 g);
#: Tresca's K = 3/(N_c·π·tan²α) comes out to 1e-6, what the rest speed leaves
CONE_STEPS = 30


#: quadrature points of the strain average: sixteen give ⟨exp(−a·ξ)⟩ = (1 + a·ξ_mean/k)^−k to 1e-6 for
#: a·ξ_mean up to 3 and to 2e-5 (k = 2) or 1e-3 (k = 1) at 6.4, a T-bar's sixth pass in soil of ξ95 = 20
STRAIN_POINTS = 16


@lru_cache(maxsize=16)
def _strain_points(shape: float) -> tuple[np.ndarray, np.ndarray]:
    """Nodes (as multiples of the mean) and weights of a Gamma distribution of shape k with mean 1
    (generalised Gauss–Laguerre)."""
    from scipy.special import roots_genlaguerre

    nodes, weights = roots_genlaguerre(STRAIN_POINTS, shape - 1.0)
    return nodes / shape, weights / weights.sum()


def mean_factor(law, mean_strain, rate_per_s, shape: float = 1.0) -> np.ndarray:
    """The law's strength factor averaged over strains Gamma-distributed with mean ``mean_strain`` and
    shape ``shape`` (1: exponential), at the strain rate given (arrays broadcast)."""
    nodes, weights = _strain_points(float(shape))
    mean, rate = np.broadcast_arrays(np.asarray(mean_strain, dtype=float), np.asarray(rate_per_s, dtype=float))
    expand = (-1,) + (1,) * mean.ndim
    strains = mean[None] * nodes.reshape(expand)
    factors = law.strength_factor(strains, np.broadcast_to(rate[None], strains.shape))
    return np.tensordot(weights, factors, axes=1)


class PenetrometerModel(Schema):
    """The forward models' dimensionless constants (values and their measurements: ``conf/calibrate.yaml``)."""

    tbar_factor: Number = Field(gt=0, description="N_T, the rough T-bar's factor in Tresca soil (-)")
    tbar_strain: Number = Field(ge=0, description="ξ_T, operative plastic shear strain round the bar (-)")
    tbar_rate_coefficient: Number = Field(gt=0, description="c_T in γ̇ = c_T·v/D (-)")
    tbar_pass_strain: Number = Field(ge=0, description="ξ_pass, the strain a pass adds to the soil's (-)")
    tbar_strain_shape: Number = Field(gt=0, description="k, the shape of the strains' Gamma distribution (-)")
    cone_factor: Number = Field(gt=0, description="N_c, the cone's factor in Tresca soil (-)")
    cone_strain: Number = Field(ge=0, description="ξ_c, operative plastic shear strain round the cone (-)")
    cone_rate_coefficient: Number = Field(gt=0, description="c_c in γ̇ = c_c·v/z (-)")
    cone_strain_shape: Number = Field(gt=0, description="k of the cone's strains (-)")


def measured_model() -> PenetrometerModel:
    """The constants as dsmv measured them: ``calibrate.models`` of ``conf/calibrate.yaml`` (their one home)."""
    from omegaconf import OmegaConf

    from dsmv.config.location import CONFIG_DIR

    models = OmegaConf.to_container(OmegaConf.load(f"{CONFIG_DIR}/calibrate.yaml").calibrate.models, resolve=True)
    return PenetrometerModel(**models)


def cone_softening(law, model: PenetrometerModel | None = None) -> float:
    """How much a cone's soil softens with no rate effect: the law's factor averaged over the cone's
    strains (-), 1 for a law that does not soften. A cone stops 1/√ of it deeper than in the intact soil."""
    model = measured_model() if model is None else model
    return float(mean_factor(law, model.cone_strain, 0.0, model.cone_strain_shape))


def tbar_resistance(model: PenetrometerModel, law, strength: StrengthSegments, depth_m, velocity_m_s,
                    diameter_m, passes_before=0) -> np.ndarray:
    """The T-bar's net penetration resistance q (Pa) at each depth (m), speed (m/s), diameter (m) and
    number of earlier passes (-), in the soil ``law`` describes (a :class:`dsmv.soil_law.SoilLaw`)."""
    strain = model.tbar_strain + np.asarray(passes_before, dtype=float) * model.tbar_pass_strain
    rate = model.tbar_rate_coefficient * np.asarray(velocity_m_s, dtype=float) / np.asarray(diameter_m, dtype=float)
    return model.tbar_factor * strength.su(depth_m) * mean_factor(law, strain, rate, model.tbar_strain_shape)


def fall_cone_depth(model: PenetrometerModel, law, strength: StrengthSegments, mass_kg, apex_angle_deg,
                    sample_depth_m=0.0, gravity_m_s2=9.81) -> np.ndarray:
    """The depth (m) at which each cone, released from rest on a sample from ``sample_depth_m``, stops.

    The motion m·dv/dt = m·g − F(z, v) in two phases, each by fourth-order Runge–Kutta on a fixed
    number of steps, so that the depth is smooth in the parameters (a calibration differentiates it):

    1. in time, dz/dt = v, from release until the cone has slowed to half its fastest;
    2. in speed, dz/dv = v/a (singular at the fastest, where a = 0: hence phase 1 goes past it), from there down to the rest speed, :data:`REST_SPEED_FRACTION` (the
       fast landing model's share) of the speed √(2·g·d₀) of a fall through the rate-free depth d₀,
       on steps even in ln v. In time this phase is stiff:
       the power law's rate factor falls steeply as v → 0, and a fixed time step either overshoots
       the rest or hands the stop to the next step. A soil whose static resistance is below the
       weight would let the cone creep on at a vanishing speed; the CEL, whose soil rebounds
       elastically, ends at the first rest, and so does this model.
    """
    shape = np.broadcast(np.asarray(mass_kg), np.asarray(apex_angle_deg), np.asarray(sample_depth_m)).shape or (1,)
    mass = np.broadcast_to(np.asarray(mass_kg, dtype=float), shape)
    tan2 = np.broadcast_to(np.tan(np.radians(np.asarray(apex_angle_deg, dtype=float)) / 2.0) ** 2, shape)
    su = np.broadcast_to(strength.su(sample_depth_m), shape)
    stiffness = model.cone_factor * su * math.pi * tan2            # F = stiffness·f·z² (N)
    strain, k = np.full(shape, float(model.cone_strain)), model.cone_strain_shape

    def acceleration(z, v):
        rate = model.cone_rate_coefficient * np.maximum(v, 0.0) / np.maximum(z, 1e-300)
        return gravity_m_s2 - stiffness * mean_factor(law, strain, rate, k) * z * z / mass

    # phase 1: the time step, a share of the time to fall the rate-free depth
    static_factor = mean_factor(law, strain, np.zeros(shape), k)
    reach = np.sqrt(3.0 * mass * gravity_m_s2 / (stiffness * static_factor))
    dt = np.sqrt(2.0 * reach / gravity_m_s2) / CONE_STEPS
    z, v, fastest = np.zeros(shape), np.zeros(shape), np.zeros(shape)
    braking = np.zeros(shape, dtype=bool)
    for _ in range(50 * CONE_STEPS):
        go = ~braking
        k1z, k1v = v, acceleration(z, v)
        k2z, k2v = v + 0.5 * dt * k1v, acceleration(z + 0.5 * dt * k1z, v + 0.5 * dt * k1v)
        k3z, k3v = v + 0.5 * dt * k2v, acceleration(z + 0.5 * dt * k2z, v + 0.5 * dt * k2v)
        k4z, k4v = v + dt * k3v, acceleration(z + dt * k3z, v + dt * k3v)
        z = np.where(go, z + dt / 6.0 * (k1z + 2 * k2z + 2 * k3z + k4z), z)
        v = np.where(go, v + dt / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v), v)
        fastest = np.maximum(fastest, v)
        braking |= go & (v < 0.5 * fastest)
        if braking.all():
            break
    else:
        raise ValueError("a fall cone did not slow down: the soil law's strength vanished")
    # phase 2: in ln v from half the fastest down to the rest speed (a < 0 all the way:
    # held at least 1e-3·g in magnitude where a creep would set in first)
    rest = REST_SPEED_FRACTION * np.sqrt(2.0 * gravity_m_s2 * reach)
    log_step = np.log(rest / v) / CONE_STEPS

    def slope(z, ln_v):  # dz/d(ln v) = v²/a
        speed = np.exp(ln_v)
        return speed * speed / np.minimum(acceleration(z, speed), -1e-3 * gravity_m_s2)

    ln_v = np.log(v)
    for _ in range(CONE_STEPS):
        k1 = slope(z, ln_v)
        k2 = slope(z + 0.5 * log_step * k1, ln_v + 0.5 * log_step)
        k3 = slope(z + 0.5 * log_step * k2, ln_v + 0.5 * log_step)
        k4 = slope(z + log_step * k3, ln_v + log_step)
        z = z + log_step / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        ln_v = ln_v + log_step
    return z


__all__ = ["PenetrometerModel", "measured_model", "cone_softening", "tbar_resistance", "fall_cone_depth", "mean_factor", "CONE_STEPS", "STRAIN_POINTS"]
