"""Solver plugin ``analytic_dynamic``: the fast landing model of a track or strip
(:mod:`dsmv.analytic.landing_model`), or of a vehicle, tilting (:mod:`dsmv.analytic.vehicle`).
"""

from __future__ import annotations

import math

import numpy as np

from dsmv import registry
from dsmv.analytic.energy import refuse_beyond_the_closed_form, skempton_shape_factor
from dsmv.analytic.landing_model import (
    LARGEST_SINKAGE_WIDTHS, AnalyticDynamicConfig, Landing, default_config, resistance, sinkage,
)
from dsmv.analytic.vehicle import VehicleModel, check_vehicle_scene
from dsmv.config.scene import Scene
from dsmv.errors import ConfigError
from dsmv.results import SolveResult, add_plate_sinkage


def fast_landing(scene: Scene, shape_factor: str = "plane_strain") -> "AnalyticDynamicSolver":
    """The fast landing model of a track or strip scene run by another solver, with the default
    coefficients: ``plane_strain`` for the 2D section, ``skempton`` for the whole track in 3D."""
    return AnalyticDynamicSolver(scene, default_config().model_copy(update={"shape_factor": shape_factor}),
                                 check=False)


def fast_vehicle(scene: Scene) -> VehicleModel:
    """The fast vehicle model of a vehicle scene run by another solver, with the 3D track's coefficients."""
    solver = AnalyticDynamicSolver(scene, default_config("analytic_dynamic_3d"), check=False)
    return VehicleModel(scene, solver.config, solver.factor)


def layered_factor(law):
    """The law's strength factor f(ξ, γ̇, z) of the soil at the base's depth z (m): the values of the layer
    there when ``soil.profile`` layers them (decision 0039), the mechanism's soil lying below the base."""
    laws, tops = law.layers(), law.layer_tops
    state = law.initial_state()

    def factor(xi, rate, depth):
        values = [each.strength_factor(xi, rate, *(np.full(np.shape(xi), s) for s in state)) for each in laws]
        if len(laws) == 1:
            return values[0]
        shape = np.broadcast(np.asarray(xi), np.asarray(depth)).shape
        layer = np.searchsorted(tops, np.broadcast_to(depth, shape), side="right") - 1
        return np.choose(layer, [np.broadcast_to(v, shape) for v in values])

    return factor


class AnalyticDynamicSolver:
    """Solver plugin ``analytic_dynamic``: the fast landing model, milliseconds."""

    name = "analytic_dynamic"
    config_model = AnalyticDynamicConfig

    @staticmethod
    def takes_slope(scene: Scene) -> bool:
        """The fast vehicle model lands on a sloping seabed; the one-track model on a level one."""
        return scene.geometry.vehicle

    @staticmethod
    def check_scene(scene: Scene) -> None:
        """The model was measured against the CEL's track section and strip landings."""
        if scene.geometry.kind not in ("track", "strip"):
            raise ConfigError("geometry.kind", scene.geometry.kind,
                              "the dynamic model lands tracks and strips; use solver=cel2d for this body")
        if scene.landing.kind == "push":
            raise ConfigError("landing.kind", "push", "the dynamic model lands bodies; a push is solver=analytic_energy")
        if scene.geometry.vehicle:  # the fast vehicle model: it sinks, slides, pitches and rolls
            check_vehicle_scene(scene)
            return
        refuse_beyond_the_closed_form(scene, "the dynamic model", bent_profile=True, layered_law=True)

    def __init__(self, scene: Scene, config: AnalyticDynamicConfig | None = None, check: bool = True):
        if check:  # off only for fast_landing, an estimate for another solver
            self.check_scene(scene)
        self.scene = scene
        # a vehicle scene of its own lands the vehicle (dsmv.analytic.vehicle); another solver's estimate, one track
        self.vehicle = check and scene.geometry.vehicle
        self.config = cfg = config or scene.solver
        body, landing, soil = scene.geometry, scene.landing, scene.soil
        if cfg.shape_factor == "plane_strain" or body.kind == "strip":
            shape = 1.0
        elif cfg.shape_factor == "skempton":
            shape = skempton_shape_factor(body)
        else:
            shape = cfg.shape_factor
        self.landing = Landing(
            weight_n=landing.weight_per_track_n, inertia_kg=landing.inertia_per_track_kg,
            velocity_m_s=landing.velocity_m_s, width_m=body.width_m, area_m2=body.contact_area_m2,
            su0_pa=soil.su0_pa, ks_pa_per_m=soil.ks_pa_per_m, density_kg_m3=soil.density_kg_m3,
            youngs_modulus_pa=soil.youngs_modulus_pa, gravity_m_s2=landing.gravity_m_s2, shape_factor=shape,
            grouser_height_m=body.grouser_height_m if cfg.grousers and body.kind == "track" else 0.0,
            strength=soil.bent_strength, density=soil.density_layers)
        self.factor = layered_factor(registry.load("soil_laws", soil.law, "soil.law")(soil))

    def solve(self, run_dir=None) -> SolveResult:
        if self.vehicle:
            return VehicleModel(self.scene, self.config, self.factor).solve()
        cfg, lb = self.config, self.landing
        coefficients = cfg.coefficients()
        rest, depth, speed = sinkage(lb, self.factor, coefficients, cfg.bearing_factor, cfg.buoyancy, history=True)
        z_max = float(rest)
        metrics = {"weight_per_track_n": float(lb.weight_n), "shape_factor": float(lb.shape_factor),
                   "touchdown_kinetic_energy_j": 0.5 * float(lb.inertia_kg) * float(lb.velocity_m_s) ** 2}
        units = {"weight_per_track_n": "N", "shape_factor": "-", "touchdown_kinetic_energy_j": "J"}
        if math.isinf(z_max):
            return SolveResult("bearing_failure", f"the body passes {LARGEST_SINKAGE_WIDTHS:g} B without stopping",
                               metrics, units, None)
        mean_speed = 0.5 * (speed[1:] + speed[:-1])
        time = np.concatenate([[0.0], np.cumsum(np.diff(depth) / np.where(mean_speed > 0, mean_speed, np.inf))])
        samples = np.linspace(0.0, time[-1], cfg.history_points)
        depth_s, speed_s = np.interp(samples, time, depth), np.interp(samples, time, speed)
        metrics |= {"max_sinkage_m": z_max, "sinkage_over_width": z_max / float(lb.width_m),
                    "time_to_rest_s": float(time[-1])}
        units |= {"max_sinkage_m": "m", "sinkage_over_width": "-", "time_to_rest_s": "s"}
        force = resistance(lb, depth_s, speed_s, self.factor, coefficients, cfg.bearing_factor, cfg.buoyancy)
        history = {"time_s": samples, "sinkage_m": depth_s, "velocity_m_s": speed_s, "force_n": np.asarray(force)}
        result = SolveResult("ok", f"came to rest at {z_max:.4g} m after {time[-1]:.3g} s", metrics, units, history)
        if self.scene.geometry.kind == "track":  # the plates: the tips, or a flat base's (the 2D section's)
            add_plate_sinkage(result, float(lb.grouser_height_m))
        return result
