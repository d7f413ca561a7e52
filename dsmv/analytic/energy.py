"""The energy method for the landing of a track on clay (reference study, Eq. 3).

Per track, with n tracks sharing the wet weight m·g:

    ½·M·v² + W·z = ∫0^z R(z') dz',     R(z) = Nc·sc·f·A·(su0 + ks·z)

M = m/n the mass per track (the study uses the wet weight m for inertia too), W = m·g/n
the wet weight per track, A = B·L the contact area, Nc = 2 + π (Prandtl's strip
factor), sc the shape factor and f the soil law's strength factor at an operative
plastic strain and strain rate (1 unless asked for; always 1 for Tresca).

The same resistance drives the equation of motion M·z̈ = W − R(z), whose closed-form
solution gives the time history; its first integral is the energy equation above, so
the two agree exactly. If ks = 0 and R(0) ≤ W the soil cannot carry the weight at any
depth: status ``bearing_failure``.

Shape factor: Skempton (1951), "The bearing capacity of clays", Building Research
Congress, London: Nc(rectangle) = Nc(strip)·(1 + 0.2·B/L) for a track; 1 for a strip (plane
strain).
Operative strain rate for the rate factor: γ̇_op = v/B, the usual normalisation of
penetration rate by the body's size (Einav & Randolph 2005 use v/D for a T-bar).
"""

from __future__ import annotations

import math
from typing import Annotated, Literal, Optional, Union

import numpy as np
from pydantic import BeforeValidator, Field

from dsmv import registry
from dsmv.analytic.bearing import PRANDTL_NC
from dsmv.config.profile import refuse_a_bent_profile, refuse_a_layered_law
from dsmv.errors import ConfigError
from dsmv.results import SolveResult, add_plate_sinkage
from dsmv.config.scene import Scene
from dsmv.config.schema import Count, Number, Schema


def _check_shape_factor(value):
    if value == "skempton" or (isinstance(value, (int, float)) and not isinstance(value, bool) and value > 0):
        return value
    raise ValueError("must be 'skempton' (sc = 1 + 0.2·B/L) or a number > 0")


class AnalyticEnergyConfig(Schema):
    """Config of ``solver=analytic_energy``."""

    name: Literal["analytic_energy"]
    bearing_factor: Number = Field(PRANDTL_NC, gt=0, description="Nc (-); Prandtl 2 + π")
    shape_factor: Annotated[Union[str, float], BeforeValidator(_check_shape_factor)] = Field(
        "skempton", description="skempton: 1 + 0.2·B/L for a track, 1 for a strip (plane strain) | a number"
    )
    operative_shear_strain: Optional[Number] = Field(
        None, ge=0, description="ξ at which the law's softening is evaluated (-); null: no softening"
    )
    rate_effect: bool = Field(False, description="apply the law's rate factor at γ̇_op = v/B")
    history_points: Count = Field(200, ge=2, description="samples in the time history (-)")


def skempton_shape_factor(body) -> float:
    """Skempton's (1951) sc (-): 1 + 0.2·B/L for a rectangle or track, 1.2 for a circle (as a
    square), 1 for a strip or T-bar (plane strain: contact_length_m is per metre run)."""
    if body.kind in ("strip", "tbar"):
        return 1.0
    if body.kind == "circular_plate":
        return 1.2
    return 1.0 + 0.2 * body.width_m / body.contact_length_m


def refuse_beyond_the_closed_form(scene: Scene, model: str, bent_profile: bool = False,
                                  layered_law: bool = False) -> None:
    """What the analytic models' closed forms cannot take, refused in one line naming the key: a bent
    strength profile (unless the model reads one: ``bent_profile``), a table that layers the law's values
    (unless the model reads it: ``layered_law``), a body that may slide or turn."""
    if not bent_profile:
        refuse_a_bent_profile(scene.soil, model)
    if not layered_law:
        refuse_a_layered_law(scene.soil, model)
    if scene.landing.moves_beyond_vertical:
        key = scene.landing.beyond_vertical_key
        raise ConfigError(key, scene.landing.model_dump()[key.split(".")[1]], f"{model} lands a body vertically; "
                          "a body that slides or turns runs in solver=cel2d or cel3d")


def sinkage_from_energy(weight_n, inertia_kg, velocity_m_s, resistance_area_m2, su0_pa, ks_pa_per_m) -> float:
    """Depth z (m) where the soil has absorbed the touchdown kinetic energy and the work of W.

    Solves ½·M·v² + W·z = Ra·(su0·z + ½·ks·z²) for z ≥ 0, with Ra = Nc·sc·f·A (m²).
    Returns ``math.inf`` when the soil cannot stop the body (ks = 0 and Ra·su0 ≤ W, moving
    or overloaded).
    """
    stiffness = resistance_area_m2 * ks_pa_per_m  # dR/dz (N/m)
    excess = resistance_area_m2 * su0_pa - weight_n  # R(0) − W (N)
    kinetic = 0.5 * inertia_kg * velocity_m_s**2  # (J)
    if stiffness == 0.0:
        if excess > 0.0:
            return kinetic / excess
        return 0.0 if (excess == 0.0 and kinetic == 0.0) else math.inf
    # ½·k·z² + excess·z − kinetic = 0, in the form free of cancellation for either sign.
    root = math.sqrt(excess * excess + 2.0 * stiffness * kinetic)
    if excess >= 0.0:
        return 2.0 * kinetic / (excess + root)
    return (root - excess) / stiffness


def sinkage_in_profile(weight_n, inertia_kg, velocity_m_s, resistance_area_m2, strength) -> float:
    """:func:`sinkage_from_energy` in a strength profile (:class:`dsmv.config.profile.StrengthSegments`): a
    straight line by the closed form, a bent one segment by segment, each by the closed form with its own
    su at its top and its slope, carrying the energy left over to the next."""
    if strength.straight:
        return sinkage_from_energy(weight_n, inertia_kg, velocity_m_s, resistance_area_m2,
                                   float(strength.su(0.0)), float(strength.slope[0]))
    kinetic = 0.5 * inertia_kg * velocity_m_s**2  # the energy left to absorb at the segment's top (J)
    bottoms = [*strength.depth[1:], math.inf]
    top = 0.0
    for start, bottom, slope in zip(strength.depth, bottoms, strength.slope):
        if bottom <= top:
            continue
        speed = math.sqrt(2.0 * kinetic / inertia_kg) if inertia_kg > 0 else 0.0
        dz = sinkage_from_energy(weight_n, inertia_kg, speed, resistance_area_m2, float(strength.su(top)), float(slope))
        if top + dz <= bottom:
            return top + dz
        span = bottom - top
        kinetic += weight_n * span - resistance_area_m2 * (float(strength.su(top)) * span + 0.5 * slope * span**2)
        top = bottom
    return math.inf


#: bodies the energy method estimates for other solvers (domain sizing, features); a cone has Hansbo's
ESTIMATED_KINDS = ("track", "strip", "tbar", "rectangular_plate", "circular_plate")


def energy_estimate(scene: Scene) -> "AnalyticEnergySolver":
    """The energy method with its default settings, as an estimate for any track, strip, plate or T-bar scene.

    It sizes the CEL domain and the history sampling of a landing, and gives the surrogates'
    features. A T-bar, which ``solver=analytic_energy`` refuses, is estimated as a strip of width D
    per metre of bar (Nc = 2 + π): deep, a cylinder carries about twice that (Nc ≈ 9-12), so the
    estimate overstates a deep landing's sinkage and sizes the domain on the safe side.
    """
    if scene.geometry.kind not in ESTIMATED_KINDS:
        raise ConfigError("geometry.kind", scene.geometry.kind,
                          f"the energy method estimates {', '.join(ESTIMATED_KINDS)} bodies")
    return AnalyticEnergySolver(scene, AnalyticEnergyConfig(name="analytic_energy"), check=False)


class AnalyticEnergySolver:
    """Solver plugin ``analytic_energy``: the energy method, closed form, microseconds."""

    name = "analytic_energy"
    config_model = AnalyticEnergyConfig

    @staticmethod
    def check_scene(scene: Scene) -> None:
        """The energy method bears a flat base (a track, a strip, a plate); anything else needs solver=cel2d."""
        if scene.geometry.kind not in ("track", "strip", "rectangular_plate", "circular_plate"):
            raise ConfigError("geometry.kind", scene.geometry.kind,
                              "the energy method models tracks, strips and plates; use solver=cel2d for this body")
        refuse_beyond_the_closed_form(scene, "the energy method", bent_profile=True)

    def __init__(self, scene: Scene, config: AnalyticEnergyConfig | None = None, check: bool = True):
        if check:  # off only for energy_estimate
            self.check_scene(scene)
        self.scene = scene
        self.config = cfg = config or scene.solver
        body, landing, soil = scene.geometry, scene.landing, scene.soil
        self.shape_factor = skempton_shape_factor(body) if cfg.shape_factor == "skempton" else cfg.shape_factor
        law = registry.load("soil_laws", soil.law, "soil.law")(soil)
        xi = cfg.operative_shear_strain or 0.0
        rate = landing.velocity_m_s / body.width_m if cfg.rate_effect else 0.0
        self.strength_factor = float(law.strength_factor(np.asarray(xi), np.asarray(rate), *law.initial_state()))
        #: Ra = Nc·sc·f·A (m²): resistance per unit of su
        self.resistance_area_m2 = cfg.bearing_factor * self.shape_factor * self.strength_factor * body.contact_area_m2

    def resistance_n(self, depth_m):
        """Soil resistance R(z) (N) on one track at depth z (m): Ra·su(z), su from the soil's profile."""
        soil = self.scene.soil
        if (strength := soil.bent_strength) is not None:
            return self.resistance_area_m2 * strength.su(depth_m)
        return self.resistance_area_m2 * (soil.su0_pa + soil.ks_pa_per_m * np.asarray(depth_m))

    def solve(self, run_dir=None) -> SolveResult:
        landing = self.scene.landing
        common = {
            "static_capacity_n": float(self.resistance_n(0.0)),
            "weight_per_track_n": landing.weight_per_track_n,
            "shape_factor": self.shape_factor,
            "strength_factor": self.strength_factor,
        }
        units = {"static_capacity_n": "N", "weight_per_track_n": "N", "shape_factor": "-", "strength_factor": "-"}
        if landing.kind == "push":
            return self._push(common, units)
        return self._drop(common, units)

    def _push(self, metrics, units) -> SolveResult:
        landing, soil, n = self.scene.landing, self.scene.soil, self.config.history_points
        depth = np.linspace(0.0, landing.displacement_m, n)
        force = self.resistance_n(depth)
        metrics |= {
            "max_sinkage_m": landing.displacement_m,
            "max_force_n": float(force[-1]),
            "bearing_factor_at_end": float(force[-1] / (self.scene.geometry.contact_area_m2 * soil.su0_pa)),
        }
        units |= {"max_sinkage_m": "m", "max_force_n": "N", "bearing_factor_at_end": "-"}
        history = {
            "time_s": depth / landing.velocity_m_s,
            "sinkage_m": depth,
            "velocity_m_s": np.full(n, landing.velocity_m_s),
            "force_n": force,
        }
        return SolveResult("ok", f"pushed to {landing.displacement_m:g} m", metrics, units, history)

    def _drop(self, metrics, units) -> SolveResult:
        landing, soil, body = self.scene.landing, self.scene.soil, self.scene.geometry
        weight, mass, v0 = landing.weight_per_track_n, landing.inertia_per_track_kg, landing.velocity_m_s
        z_max = sinkage_in_profile(weight, mass, v0, self.resistance_area_m2, soil.strength)
        metrics["touchdown_kinetic_energy_j"] = 0.5 * mass * v0**2
        units["touchdown_kinetic_energy_j"] = "J"
        if math.isinf(z_max):
            strength = soil.strength
            if strength.straight:
                message = (f"the soil cannot carry the track at any depth: capacity Nc·sc·f·A·su0 = "
                           f"{metrics['static_capacity_n']:.4g} N ≤ wet weight per track {weight:.4g} N and ks = 0")
            else:
                message = (f"the soil cannot carry the track: below {strength.depth[-1]:g} m its strength stays "
                           f"{strength.intercept[-1]:.4g} Pa, a capacity Nc·sc·f·A·su of "
                           f"{self.resistance_area_m2 * strength.intercept[-1]:.4g} N ≤ wet weight per track {weight:.4g} N")
            return SolveResult("bearing_failure", message, metrics, units, None)

        t_rest, time, depth, velocity = self._trajectory(z_max)
        metrics |= {
            "max_sinkage_m": z_max,
            "sinkage_over_width": z_max / body.width_m,
            "time_to_rest_s": t_rest,
            "final_resistance_n": float(self.resistance_n(z_max)),
        }
        units |= {"max_sinkage_m": "m", "sinkage_over_width": "-", "time_to_rest_s": "s", "final_resistance_n": "N"}
        history = {"time_s": time, "sinkage_m": depth, "velocity_m_s": velocity, "force_n": self.resistance_n(depth)}
        result = SolveResult("ok", f"came to rest at {z_max:.4g} m after {t_rest:.3g} s", metrics, units, history)
        if self.scene.geometry.kind == "track":  # a flat base: the plates, as the 2D section's
            add_plate_sinkage(result, 0.0)
        return result

    def _trajectory(self, z_max):
        """Closed-form motion z(t), v(t) of M·z̈ = W − R(z) from z = 0, v = v0 to rest at z_max; in a bent
        strength profile, segment by segment (:meth:`_trajectory_in_segments`)."""
        landing, soil = self.scene.landing, self.scene.soil
        if soil.bent_strength is not None:
            return self._trajectory_in_segments(z_max)
        return self._linear_motion(self.resistance_area_m2 * soil.su0_pa - landing.weight_per_track_n,
                                   self.resistance_area_m2 * soil.ks_pa_per_m, landing.velocity_m_s, z_max,
                                   self.config.history_points)

    def _trajectory_in_segments(self, z_max):
        """The motion through a bent profile: in each segment the resistance is linear in depth, so the
        closed form holds there, from the speed the body enters it with; it runs until the body leaves
        the segment (the time found by bisection on the monotone descent) or comes to rest."""
        landing, strength = self.scene.landing, self.scene.soil.strength
        weight, area = landing.weight_per_track_n, self.resistance_area_m2
        n = self.config.history_points
        bottoms = [*strength.depth[1:], math.inf]
        times, depths, speeds = [np.zeros(1)], [np.zeros(1)], [np.full(1, landing.velocity_m_s)]
        top, speed, clock = 0.0, landing.velocity_m_s, 0.0
        for bottom, slope in zip(bottoms, strength.slope):
            if bottom <= top:
                continue
            excess, stiffness = area * float(strength.su(top)) - weight, area * float(slope)
            end = min(bottom, z_max)
            if end >= z_max:  # it comes to rest in this segment
                t_end, t, z, v = self._linear_motion(excess, stiffness, speed, z_max - top, n)
            else:  # it passes through: the time at which it has gone the segment's span
                t_end = self._time_to_cover(excess, stiffness, speed, end - top)
                t = np.linspace(0.0, t_end, n)
                z, v = self._state_at(excess, stiffness, speed, t)
                z[-1] = end - top
            times.append(clock + t[1:])
            depths.append(top + z[1:])
            speeds.append(v[1:])
            clock, top, speed = clock + t_end, end, float(v[-1])
            if end >= z_max:
                break
        depth = np.concatenate(depths)
        depth[-1] = z_max  # the end point exactly, free of the round-off in top + (z_max − top)
        return clock, np.concatenate(times), depth, np.concatenate(speeds)

    def _time_to_cover(self, excess, stiffness, v0, span):
        """The time M·z̈ = −excess − stiffness·z takes from z = 0 at v0 to z = span, which it reaches
        moving down: closed form without stiffness, else bisection before the first rest, where z rises
        monotonically."""
        mass = self.scene.landing.inertia_per_track_kg
        accel = -excess / mass
        if stiffness == 0.0:
            return span / v0 if accel == 0.0 else (math.sqrt(v0 * v0 + 2.0 * accel * span) - v0) / accel
        omega = math.sqrt(stiffness / mass)
        low, high = 0.0, math.atan2(mass * omega * v0, excess) / omega
        for _ in range(200):
            mid = 0.5 * (low + high)
            low, high = (mid, high) if self._state_at(excess, stiffness, v0, mid)[0] < span else (low, mid)
        return high

    def _state_at(self, excess, stiffness, v0, t):
        """z(t), v(t) of M·z̈ = −excess − stiffness·z from z = 0, v = v0 (the closed form of :meth:`_linear_motion`)."""
        mass = self.scene.landing.inertia_per_track_kg
        omega = math.sqrt(stiffness / mass)
        accel0 = -excess / mass
        t = np.asarray(t, dtype=float)
        if omega == 0.0:
            return v0 * t + 0.5 * accel0 * t**2, v0 + accel0 * t
        # harmonic motion with ω² = k/M from the touchdown acceleration a0 = (W − R0)/M, written
        # with sin(ωt)/ω and sin²(ωt/2)/ω², which stay exact as ω → 0: the form about
        # z_eq = −excess/k overflows or cancels for a tiny ks (ks = 1e-300 Pa/m gave t_rest = 0,
        # ks = 2e-308 a NaN history; a hypothesis property found it)
        z = accel0 * 2.0 * (np.sin(0.5 * omega * t) / omega) ** 2 + v0 * np.sin(omega * t) / omega
        return z, accel0 * np.sin(omega * t) / omega + v0 * np.cos(omega * t)

    def _linear_motion(self, excess, stiffness, v0, z_max, n):
        """The motion of M·z̈ = −excess − stiffness·z from z = 0 at v0 to rest at z_max: (time to rest, t, z, v)."""
        mass = self.scene.landing.inertia_per_track_kg
        if z_max == 0.0:
            zeros = np.zeros(1)
            return 0.0, zeros, zeros, zeros
        omega = math.sqrt(stiffness / mass)
        if omega == 0.0:  # no ks (or one too small to register, 5e-324): constant deceleration a = (R0 − W)/M
            t_rest = v0 / (excess / mass)
            t = np.linspace(0.0, t_rest, n)
            return t_rest, t, *self._state_at(excess, stiffness, v0, t)
        t_rest = math.atan2(mass * omega * v0, excess) / omega  # first v = 0, ωt in (0, π]
        t = np.linspace(0.0, t_rest, n)
        z, v = self._state_at(excess, stiffness, v0, t)
        z[-1], v[-1] = z_max, 0.0  # the end point exactly, free of round-off in the phase
        return t_rest, t, z, v
