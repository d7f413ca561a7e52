"""The fast vehicle model: the vehicle's rigid-body equations, each track's resistance from the fast
landing model patch by patch of its base (docs/decisions/0033).

The vehicle (``landing.mass_kg`` on its two tracks, their centres ``geometry.gauge_m`` apart) sinks,
pitches and rolls about its centre of gravity (``landing.cg_offset_m`` from the middle of its base),
from its attitude and rates at first contact, each turn moving if it is free (``landing.free``), as
cel3d lands it. Each track's base is cut into :data:`PATCHES_ALONG` × :data:`PATCHES_ACROSS` patches.
The patch at r from the centre of gravity lies at depth d = d_cg − (R·r)_z, R = Ry·Rx the body's turn
(:meth:`dsmv.cel.body.Pose.turned`), and moves down at ḋ_cg − ωx·(R·r)_y + ωy·(R·r)_x.

On a patch the soil presses with the fast landing model's pressure at the patch's depth and downward
speed, p(d, v) = R(d, v)/A (:func:`dsmv.analytic.landing_model.resistance`, the track's width B in its
factors) of the 3D track (``solver=analytic_dynamic_3d``: its grousers cut in first, Skempton's shape
factor, its coefficients fitted to the 3D CEL; the section's ``analytic_dynamic`` lands a vehicle with
them too) while the patch goes
deeper than it has been; a patch that rises unloads, and reloads, along the elastic stiffness over
which the model mobilises its resistance (p/z_e, z_e = c_e·Nc·B·su0/E), and holds no tension. A level
vehicle with its centre of gravity over its middle is then each track's fast landing with half the
weight.

    M·d̈_cg = W − Σ p·a,      I·ω̇ = Σ (R·r) × (0, 0, p·a)

stepped with the symplectic Euler step, Δt a twentieth of the period of the patches' stiffness. As in
cel3d, the vehicle is at rest once its fall has stopped and it moves and turns (at its reach) no
faster than 1 % of its touchdown speed while the soil's moment about its centre of gravity is under
5 % of its weight times its reach (:data:`dsmv.analytic.landing_model.REST_MOMENT_FRACTION`).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from dsmv.analytic.landing_model import (
    LARGEST_SINKAGE_WIDTHS, REST_MOMENT_FRACTION, REST_SPEED_AFTER_FALL, Landing, cut_in, default_config, resistance,
)
from dsmv.config.scene import Scene
from dsmv.errors import ConfigError
from dsmv.results import SolveResult, add_plate_sinkage, add_vehicle_answers

#: patches along each track and across it: from 24 × 4 to 48 × 8 the tilts move by at most 0.3 % (the
#: vehicle with its centre of gravity 0.3 m across or 0.5 m forward, or touching down rolled 4°)
PATCHES_ALONG, PATCHES_ACROSS = 24, 4
#: the step as a fraction of the period √(M/K) of the patches' stiffness K
STEP_FRACTION = 0.05
#: the longest landing it steps (s): beyond, it has not settled
LONGEST_S = 30.0
#: history samples kept (at most)
HISTORY_SAMPLES = 400


def check_vehicle_scene(scene: Scene) -> None:
    """What the fast vehicle model does not move: a drift or slide, a yaw."""
    landing = scene.landing
    for name in ("x", "y", "rz"):
        if name in landing.freedoms or landing.given_velocity(name):
            key = "landing.free" if name in landing.freedoms else "landing." + {
                "x": "horizontal_velocity_m_s", "y": "lateral_velocity_m_s", "rz": "yaw_rate_rad_s"}[name]
            raise ConfigError(key, landing.free if name in landing.freedoms else landing.given_velocity(name),
                              "the fast vehicle model sinks, pitches and rolls; a drift, a slide or a yaw runs "
                              "in solver=cel3d")


def turn_rows(angle_x: float, angle_y: float) -> np.ndarray:
    """R = Ry·Rx, the body's turn about x then y (rad; :meth:`dsmv.cel.body.Pose.turned` without yaw)."""
    sx, cx, sy, cy = math.sin(angle_x), math.cos(angle_x), math.sin(angle_y), math.cos(angle_y)
    return np.array([[cy, sy * sx, sy * cx], [0.0, cx, -sx], [-sy, cy * sx, cy * cx]])


class VehicleModel:
    """The fast vehicle model of a vehicle scene (module docstring), with the fast landing model's
    coefficients ``config`` (:class:`dsmv.analytic.landing_model.AnalyticDynamicConfig`)."""

    def __init__(self, scene: Scene, config, factor):
        check_vehicle_scene(scene)
        if config.shape_factor == "plane_strain":  # the section's coefficients: a vehicle's tracks are 3D tracks
            config = default_config("analytic_dynamic_3d")
        self.scene, self.config, self.factor = scene, config, factor
        body, landing, soil = scene.geometry, scene.landing, scene.soil
        shape = 1.0 + 0.2 * body.width_m / body.contact_length_m if config.shape_factor == "skempton" \
            else float(config.shape_factor)
        track = cut_in(Landing(  # per track, its grousers cut in first (tips gh deep, the trapped soil carried)
            weight_n=np.asarray(landing.weight_per_track_n), inertia_kg=np.asarray(landing.inertia_per_track_kg),
            velocity_m_s=np.asarray(landing.velocity_m_s), width_m=np.asarray(body.width_m),
            area_m2=np.asarray(body.contact_area_m2), su0_pa=np.asarray(soil.su0_pa),
            ks_pa_per_m=np.asarray(soil.ks_pa_per_m), density_kg_m3=np.asarray(soil.density_kg_m3),
            youngs_modulus_pa=np.asarray(soil.youngs_modulus_pa), gravity_m_s2=np.asarray(landing.gravity_m_s2),
            shape_factor=np.asarray(shape), grouser_height_m=body.grouser_height_m,
            strength=soil.strength if soil.profile is not None and not soil.strength.straight else None))
        self.patch_soil = replace(track, area_m2=np.asarray(1.0))  # the pressure: the resistance of a unit area
        self.mass_kg, self.weight_n = 2.0 * float(track.inertia_kg), 2.0 * float(track.weight_n)
        self.speed_m_s = float(track.velocity_m_s)
        self.grouser_height_m = body.grouser_height_m
        self.inertia = (2.0 * np.asarray(landing.rotational_inertia_kg_m2, dtype=float)
                        if landing.rotational_inertia_kg_m2 is not None else np.array(body.box_inertia_kg_m2(self.mass_kg)))
        cg = np.asarray(landing.cg_offset_m, dtype=float)
        along = body.contact_length_m * ((np.arange(PATCHES_ALONG) + 0.5) / PATCHES_ALONG - 0.5)
        across = body.width_m * ((np.arange(PATCHES_ACROSS) + 0.5) / PATCHES_ACROSS - 0.5)
        x = np.concatenate([side * body.track_offset_m + np.repeat(across, PATCHES_ALONG) for side in (-1.0, 1.0)])
        y = np.tile(along, 2 * PATCHES_ACROSS)
        self.arms = np.stack([x - cg[0], y - cg[1], np.full_like(x, -cg[2])])  # patch from the centre of gravity (m)
        self.patch_area_m2 = body.contact_area_m2 / (PATCHES_ALONG * PATCHES_ACROSS)
        half = body.half_span_m
        self.corners = np.array([[sx * half - cg[0], sy * 0.5 * body.contact_length_m - cg[1], -cg[2]]
                                 for sx in (-1.0, 1.0) for sy in (-1.0, 1.0)]).T
        self.middle = -cg  # the middle of the base from the centre of gravity
        self.reach_m = float(np.sqrt((self.corners**2).sum(axis=0)).max())
        self.coefficients = c = config.coefficients()
        self.elastic_depth_m = (c.elastic_coefficient * config.bearing_factor * body.width_m * soil.su0_pa
                                / soil.youngs_modulus_pa)
        # the soil's radiation dashpot per unit area under a footing moving up or down, Lysmer's analog
        # ρ'·V_La with V_La = 3.4·Vs/(π·(1 − ν)) (Gazetas 1991, J. Geotech. Eng. 117(9) 1363–1381): on the
        # buoyant density, the mass the CEL's soil carries
        shear_pa = soil.youngs_modulus_pa / (2.0 * (1.0 + soil.poisson_ratio))
        wave_speed = 3.4 * math.sqrt(shear_pa / soil.density_kg_m3) / (math.pi * (1.0 - soil.poisson_ratio))
        self.dashpot_pa_s_per_m = soil.density_kg_m3 * wave_speed
        self.free = np.array([name in landing.freedoms for name in ("rx", "ry")], dtype=float)

    def pressure(self, depth: np.ndarray, speed: np.ndarray) -> np.ndarray:
        """The fast landing model's pressure (Pa) on patches whose grousers' tips are ``depth`` deep, moving
        down at ``speed``; 0 until the grousers have cut in."""
        gh, cfg = self.grouser_height_m, self.config
        bearing = depth > gh
        p = np.zeros_like(depth)
        if bearing.any():
            p[bearing] = resistance(self.patch_soil, depth[bearing], np.maximum(speed[bearing], 0.0), self.factor,
                                    self.coefficients, cfg.bearing_factor, cfg.buoyancy)
        return np.maximum(p, 0.0)

    def solve(self) -> SolveResult:
        landing, body = self.scene.landing, self.scene.geometry
        angles = np.array(landing.attitude_rad[:2])
        rates = np.array([landing.given_velocity("rx"), landing.given_velocity("ry")])
        rows = turn_rows(*angles)
        depth_cg = self.grouser_height_m + float((rows[2] @ self.corners).min())  # its lowest corner gh deep
        speed = self.speed_m_s
        deepest = np.full(self.arms.shape[1], -np.inf)  # each patch's deepest, and its pressure there
        pressed = np.zeros(self.arms.shape[1])
        area, mass, weight = self.patch_area_m2, self.mass_kg, self.weight_n
        floor = self.config.bearing_factor * self.scene.soil.su0_pa  # the weakest full pressure (Pa)
        rest_speed, moment_limit = REST_SPEED_AFTER_FALL * self.speed_m_s, REST_MOMENT_FRACTION * weight * self.reach_m
        time, fell, status, message = 0.0, False, "ok", ""
        samples = []
        largest = {"middle": -np.inf, "edge": -np.inf, "turn": float(np.hypot(*angles))}
        while True:
            arm = rows @ self.arms
            depth = depth_cg - arm[2]
            down = speed - rates[0] * arm[1] + rates[1] * arm[0]
            load = self.pressure(depth, down)
            deeper = depth >= deepest
            below = np.where(deeper, 0.0, deepest - depth)  # how far each patch has risen from its deepest
            elastic = (pressed - pressed / self.elastic_depth_m * below if self.elastic_depth_m > 0.0
                       else np.where(below > 0.0, 0.0, pressed))
            elastic = elastic + self.dashpot_pa_s_per_m * down  # the soil it rises from radiates
            p = np.where(deeper, load, np.clip(np.minimum(elastic, load), 0.0, None))
            deepest, pressed = np.where(deeper, depth, deepest), np.where(deeper, load, pressed)
            force = p * area
            moment = np.array([arm[1] @ force, -(arm[0] @ force)])
            middle = depth_cg - float(rows[2] @ self.middle)
            largest["middle"] = max(largest["middle"], middle)
            largest["edge"] = max(largest["edge"], depth_cg - float((rows[2] @ self.corners).min()))
            largest["turn"] = max(largest["turn"], float(np.hypot(*angles)))
            samples.append((time, middle, speed, force.sum() / 2.0, *np.degrees(angles), *(moment / 2.0)))
            stiffness = area * np.maximum(pressed, floor).sum() / max(self.elastic_depth_m, 1e-6 * body.width_m)
            dt = STEP_FRACTION * math.sqrt(mass / stiffness)
            fell |= len(samples) > 1 and samples[-2][2] > 0.0 >= speed  # its fall has stopped
            turning = np.abs(rates * self.free).max() * self.reach_m
            if fell and abs(speed) <= rest_speed and turning <= rest_speed and np.abs(moment * self.free).max() <= moment_limit:
                message = f"came to rest at {largest['middle']:.4g} m after {time:.3g} s"
                break
            if middle > LARGEST_SINKAGE_WIDTHS * body.width_m:
                status, message = "bearing_failure", f"the vehicle passes {LARGEST_SINKAGE_WIDTHS:g} B without stopping"
                break
            if time > LONGEST_S:
                status, message = "unstable", f"the vehicle did not settle within {LONGEST_S:g} s"
                break
            speed += dt * (weight - force.sum()) / mass
            rates += dt * moment / self.inertia[:2] * self.free
            depth_cg += dt * speed
            angles = angles + dt * rates
            rows = turn_rows(*angles)
            time += dt
        history = self._history(samples)
        metrics = {"max_sinkage_m": largest["middle"], "max_edge_sinkage_m": largest["edge"],
                   "max_rotation_deg": math.degrees(largest["turn"]), "max_horizontal_displacement_m": 0.0,
                   "rotation_deg": float(history["rotation_deg"][-1]), "pitch_deg": float(history["pitch_deg"][-1]),
                   "time_to_rest_s": time, "sinkage_over_width": largest["middle"] / body.width_m,
                   "weight_per_track_n": 0.5 * weight, "steps": float(len(samples))}
        units = {"max_sinkage_m": "m", "max_edge_sinkage_m": "m", "max_rotation_deg": "deg",
                 "max_horizontal_displacement_m": "m", "rotation_deg": "deg", "pitch_deg": "deg", "time_to_rest_s": "s",
                 "sinkage_over_width": "-", "weight_per_track_n": "N", "steps": "-"}
        add_vehicle_answers(metrics, units, history, body, self.grouser_height_m)
        result = SolveResult(status, message, metrics, units, history)
        add_plate_sinkage(result, self.grouser_height_m)
        return result

    @staticmethod
    def _history(samples: list) -> dict:
        """The steps' samples, thinned to at most :data:`HISTORY_SAMPLES` (the last kept): per track, the
        force and moments the soil puts on the vehicle."""
        keep = np.unique(np.r_[np.linspace(0, len(samples) - 1, min(len(samples), HISTORY_SAMPLES)).astype(int)])
        table = np.array(samples)[keep]
        names = ("time_s", "sinkage_m", "velocity_m_s", "force_n", "pitch_deg", "rotation_deg", "pitch_moment_n_m",
                 "moment_n_m")
        return dict(zip(names, table.T))
