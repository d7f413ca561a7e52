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
which the model mobilises its resistance (p/z_e, z_e = c_e·Nc·B·su0/E), into tension down to the peak
pressure it bore: the soil trapped between its grousers, carried with the track (as in the CEL), pulls on
the soil below, undrained, as a skirted mudmat's does. A level
vehicle with its centre of gravity over its middle is then each track's fast landing with half the
weight.

    M·d̈_cg = W − Σ p·a,      I·ω̇ = Σ (R·r) × (0, 0, p·a)

stepped with the symplectic Euler step, Δt a twentieth of the period of the patches' stiffness. As in
cel3d, the vehicle is at rest once its fall has stopped and it moves and turns (at its reach) no
faster than 1 % of its touchdown speed while the soil bears at least 95 % of its weight and its moment
about the centre of gravity is under 5 % of the weight times the reach
(:data:`dsmv.analytic.landing_model.REST_OUT_OF_BALANCE`).
"""

from __future__ import annotations

import math
from dataclasses import fields, replace

import numpy as np

from dsmv.analytic.bearing import PRANDTL_NC, green_horizontal, green_vertical, undrained_wall_coefficient
from dsmv.analytic.landing_model import (
    LARGEST_SINKAGE_WIDTHS, REST_OUT_OF_BALANCE, REST_SPEED_AFTER_FALL, SHARED, Landing, cut_in, default_config,
    density_at, resistance, strength_at,
)
from dsmv.config.scene import Scene
from dsmv.errors import ConfigError
from dsmv.results import SolveResult, add_plate_sinkage, add_vehicle_answers

#: patches along each track and across it: from 24 × 4 to 48 × 8 the tilts move by at most 0.3 % (the
#: vehicle with its centre of gravity 0.3 m across or 0.5 m forward, or touching down rolled 4°)
PATCHES_ALONG, PATCHES_ACROSS = 24, 4
#: the step as a fraction of the period √(M/K) of the patches' stiffness K
STEP_FRACTION = 0.05
#: Gauss–Legendre nodes and weights on [−1, 1], six on each smooth piece of an end arc's run
#: (:meth:`VehicleModel.end_arcs_n`)
ARC_NODES, ARC_WEIGHTS = np.polynomial.legendre.leggauss(6)
#: the longest landing it steps (s): beyond, it has not settled
LONGEST_S = 30.0
#: history samples kept (at most)
HISTORY_SAMPLES = 400


def check_vehicle_scene(scene: Scene) -> None:
    """What the fast vehicle model does not move: a yaw."""
    landing = scene.landing
    if "rz" in landing.freedoms or landing.given_velocity("rz"):
        key = "landing.free" if "rz" in landing.freedoms else "landing.yaw_rate_rad_s"
        raise ConfigError(key, landing.free if "rz" in landing.freedoms else landing.given_velocity("rz"),
                          "the fast vehicle model sinks, slides, pitches and rolls; a yaw runs in solver=cel3d")


def gazetas_horizontal_ratios(poisson_ratio: float, length_m: float, width_m: float) -> tuple[float, float]:
    """A rigid rectangular footing's horizontal stiffness across (x, its width) and along it (y, its length)
    over its vertical one, on an elastic half-space (Gazetas 1991, J. Geotech. Eng. 117(9), Table 1; half
    length l, half width b, χ = A/(4·l²)): K_y = 2Gl/(2 − ν)·(2 + 2.5·χ^0.85), K_x = K_y − 0.2·G·l·(1 − b/l)
    /(0.75 − ν), K_z = 2Gl/(1 − ν)·(0.73 + 1.54·χ^0.75)."""
    nu, half_length, half_width = poisson_ratio, 0.5 * length_m, 0.5 * width_m
    chi = length_m * width_m / (4.0 * half_length**2)
    along = 2.0 / (2.0 - nu) * (2.0 + 2.5 * chi**0.85)
    across = along - 0.2 / (0.75 - nu) * (1.0 - half_width / half_length)
    vertical = 2.0 / (1.0 - nu) * (0.73 + 1.54 * chi**0.75)
    return across / vertical, along / vertical


def turn_rows(angle_x, angle_y) -> np.ndarray:
    """R = Ry·Rx, the body's turn about x then y (rad; :meth:`dsmv.cel.body.Pose.turned` without yaw): (3, 3),
    or (…, 3, 3) for arrays of angles."""
    sx, cx, sy, cy = np.sin(angle_x), np.cos(angle_x), np.sin(angle_y), np.cos(angle_y)
    zero = np.zeros_like(sx)
    return np.stack([np.stack([cy, sy * sx, sy * cx], -1), np.stack([zero, cx, -sx], -1),
                     np.stack([-sy, cy * sx, cy * cx], -1)], -2)


def vehicle_config(config):
    """The fast model's coefficients for a vehicle's tracks: the section's (plane strain) give way to the
    3D track's, for a vehicle's tracks are 3D tracks."""
    return default_config("analytic_dynamic_3d") if config.shape_factor == "plane_strain" else config


#: a landing's end, per vehicle of a batch (:meth:`VehicleModel.land`)
RUNNING, AT_REST, PASSED, UNSETTLED, SLID = 0, 1, 2, 3, 4
STATUS = {AT_REST: "ok", PASSED: "bearing_failure", UNSETTLED: "unstable", SLID: "bearing_failure"}


class VehicleModel:
    """The fast vehicle model of a vehicle scene (module docstring), with the fast landing model's
    coefficients ``config`` (:class:`dsmv.analytic.landing_model.AnalyticDynamicConfig`).

    ``tracks`` lands a batch of vehicles at once, the scene's geometry and attitude each, the rest per
    vehicle: one per entry of the per-track :class:`~dsmv.analytic.landing_model.Landing`'s arrays, and
    ``factor`` the soil law's strength factor of each (its arrays a column, one row per vehicle), and
    ``factor_of_rows(index)`` that of the vehicles ``index`` alone. By default the scene's own vehicle, one."""

    def __init__(self, scene: Scene, config, factor, tracks: Landing | None = None, factor_of_rows=None):
        check_vehicle_scene(scene)
        config = vehicle_config(config)
        self.scene, self.config, self.factor, self.factor_of_rows = scene, config, factor, factor_of_rows
        body, landing, soil = scene.geometry, scene.landing, scene.soil
        shape = 1.0 + 0.2 * body.width_m / body.contact_length_m if config.shape_factor == "skempton" \
            else float(config.shape_factor)
        if tracks is None:
            tracks = Landing(
                weight_n=landing.weight_per_track_n, inertia_kg=landing.inertia_per_track_kg,
                velocity_m_s=landing.velocity_m_s, width_m=body.width_m, area_m2=body.contact_area_m2,
                su0_pa=soil.su0_pa, ks_pa_per_m=soil.ks_pa_per_m, density_kg_m3=soil.density_kg_m3,
                youngs_modulus_pa=soil.youngs_modulus_pa, gravity_m_s2=landing.gravity_m_s2, shape_factor=shape,
                grouser_height_m=body.grouser_height_m,
                strength=soil.bent_strength, density=soil.density_layers)
        column = {f.name: np.asarray(getattr(tracks, f.name), dtype=float).reshape(-1, 1) for f in fields(Landing)
                  if f.name not in (*SHARED, "grouser_height_m")}
        count = max(len(a) for a in column.values())
        column = {k: np.broadcast_to(a, (count, 1)) for k, a in column.items()}
        # per track, its grousers cut in first (tips gh deep, the trapped soil carried); one row per vehicle
        track = cut_in(replace(tracks, grouser_height_m=body.grouser_height_m, **column))
        self.count = count
        self.patch_soil = replace(track, area_m2=np.ones((count, 1)))  # the pressure: the resistance of a unit area
        self.mass_kg, self.weight_n = 2.0 * track.inertia_kg[:, 0], 2.0 * track.weight_n[:, 0]
        self.speed_m_s = track.velocity_m_s[:, 0]
        self.grouser_height_m = body.grouser_height_m
        self.inertia = (np.broadcast_to(2.0 * np.asarray(landing.rotational_inertia_kg_m2, dtype=float), (count, 3))
                        if landing.rotational_inertia_kg_m2 is not None
                        else np.outer(self.mass_kg, body.box_inertia_kg_m2(1.0)))  # (a box's is linear in its mass)
        cg = np.asarray(landing.cg_offset_m, dtype=float)
        along = body.contact_length_m * ((np.arange(PATCHES_ALONG) + 0.5) / PATCHES_ALONG - 0.5)
        across = body.width_m * ((np.arange(PATCHES_ACROSS) + 0.5) / PATCHES_ACROSS - 0.5)
        x = np.concatenate([side * body.track_offset_m + np.repeat(across, PATCHES_ALONG) for side in (-1.0, 1.0)])
        y = np.tile(along, 2 * PATCHES_ACROSS)
        self.arms = np.stack([x - cg[0], y - cg[1], np.full_like(x, -cg[2])])  # patch from the centre of gravity (m)
        self.patch_area_m2 = body.contact_area_m2 / (PATCHES_ALONG * PATCHES_ACROSS)
        self.track_of_patch = np.repeat([0, 1], PATCHES_ALONG * PATCHES_ACROSS)
        half = body.half_span_m
        self.corners = np.array([[sx * half - cg[0], sy * 0.5 * body.contact_length_m - cg[1], -cg[2]]
                                 for sx in (-1.0, 1.0) for sy in (-1.0, 1.0)]).T
        self.middle = -cg  # the middle of the base from the centre of gravity
        self.reach_m = float(np.sqrt((self.corners**2).sum(axis=0)).max())
        self.coefficients = c = config.coefficients()
        su0, stiff = track.su0_pa[:, 0], track.youngs_modulus_pa[:, 0]
        self.elastic_depth_m = c.elastic_coefficient * config.bearing_factor * body.width_m * su0 / stiff
        # the soil's radiation dashpot per unit area under a footing moving up or down, Lysmer's analog
        # ρ'·V_La with V_La = 3.4·Vs/(π·(1 − ν)) (Gazetas 1991, J. Geotech. Eng. 117(9) 1363–1381): on the
        # buoyant density, the mass the CEL's soil carries
        density = track.density_kg_m3[:, 0]
        shear_pa = stiff / (2.0 * (1.0 + soil.poisson_ratio))
        wave_speed = 3.4 * np.sqrt(shear_pa / density) / (math.pi * (1.0 - soil.poisson_ratio))
        self.dashpot_pa_s_per_m = density * wave_speed
        self.floor_pa = config.bearing_factor * su0  # the weakest full pressure (Pa)
        self.free = np.array([name in landing.freedoms for name in ("rx", "ry")], dtype=float)
        # along the seabed (the grid's x and y; on a slope gravity turned, as in the CEL): each track's base
        # resists with Green's envelope at its load, elastic below it (stiffness: Gazetas's horizontal over
        # vertical, times the vertical one the patches have), and radiates shear waves, ρ'·Vs per unit area
        self.free_xy = np.array([name in landing.freedoms for name in ("x", "y")], dtype=float)
        g = landing.gravity_m_s2
        along_x, along_y, normal = soil.gravity_components(g) if g > 0.0 else (0.0, 0.0, 0.0)
        scale = 1.0 / g if g > 0.0 else 0.0
        self.normal_weight_n = self.weight_n * (normal * scale if g > 0.0 else 1.0)
        self.along_weight_n = np.outer(self.weight_n, [along_x * scale, along_y * scale])
        self.track_arms = np.stack([np.array([side * body.track_offset_m, 0.0, 0.0]) - cg for side in (-1.0, 1.0)],
                                   axis=1)  # each track's base middle from the centre of gravity (3, tracks)
        ratios = np.array(gazetas_horizontal_ratios(soil.poisson_ratio, body.contact_length_m, body.width_m))
        vertical = body.contact_area_m2 * self.floor_pa / np.maximum(self.elastic_depth_m, 1e-6 * body.width_m)
        self.slide_stiffness = np.outer(vertical, ratios)  # per track along x and y (N/m)
        self.slide_dashpot = np.sqrt(shear_pa * density) * body.contact_area_m2  # per track (N·s/m)
        # the envelope of its grousers' tips past the flat run: sprocket arcs of radius R + gh, as cel3d's
        self.arc_radius_m = body.sprocket_radius_m + body.grouser_height_m

    def pressure(self, depth: np.ndarray, speed: np.ndarray, soil: Landing | None = None, factor=None) -> np.ndarray:
        """The fast landing model's pressure (Pa) on patches (vehicles × patches) whose grousers' tips are
        ``depth`` deep, moving down at ``speed``; 0 until the grousers have cut in. ``soil`` and ``factor``:
        those of the vehicles the rows hold (by default all)."""
        gh, cfg = self.grouser_height_m, self.config
        bearing = depth > gh
        p = resistance(soil or self.patch_soil, np.where(bearing, depth, gh), np.maximum(speed, 0.0),
                       factor or self.factor, self.coefficients, cfg.bearing_factor, cfg.buoyancy)
        return np.where(bearing, np.maximum(p, 0.0), 0.0)

    def land(self, history: bool = False) -> dict:
        """Land the batch: per vehicle its end (:data:`STATUS`), time (s), steps, its base's middle's and
        lowest point's deepest (m), its largest turn from level and its roll and pitch at the end (rad);
        with ``history``, each step's samples of the first vehicle too. With ``factor_of_rows`` the
        vehicles that have ended leave the arrays once a quarter of them has (their rows then cost nothing)."""
        landing, body = self.scene.landing, self.scene.geometry
        n, area = self.count, self.patch_area_m2
        angles = np.tile(np.array(landing.attitude_rad[:2], dtype=float), (n, 1))
        rates = np.tile(np.array([landing.given_velocity("rx"), landing.given_velocity("ry")], dtype=float), (n, 1))
        rows = turn_rows(angles[:, 0], angles[:, 1])
        depth_cg = self.grouser_height_m + (rows[:, 2] @ self.corners).min(axis=1)  # its lowest corner gh deep
        speed, before = self.speed_m_s.copy(), np.full(n, np.nan)
        drift = np.tile(np.array([landing.given_velocity("x"), landing.given_velocity("y")], dtype=float), (n, 1))
        slide, inclined = np.zeros((n, 2)), np.ones((n, 2))
        slip = np.broadcast_to((rows @ self.track_arms)[:, :2] - self.track_arms[:2], (n, 2, 2)).copy()
        deepest = np.full((n, self.arms.shape[1]), -np.inf)  # each patch's deepest, and its pressure there
        pressed = np.zeros_like(deepest)
        time, steps, fell, end = np.zeros(n), np.zeros(n), np.zeros(n, dtype=bool), np.full(n, RUNNING)
        middle_most, edge_most, turn_most = np.full(n, -np.inf), np.full(n, -np.inf), np.hypot(*angles.T)
        slide_most = np.zeros(n)
        # per vehicle: what it is, then where it is; ``index``: the vehicles the arrays' rows hold
        touchdown = np.maximum(self.speed_m_s, np.hypot(*drift.T))
        given = {"mass": self.mass_kg, "weight": self.normal_weight_n, "along": self.along_weight_n,
                 "inertia": self.inertia[:, :2], "elastic": self.elastic_depth_m, "dashpot": self.dashpot_pa_s_per_m,
                 "floor": self.floor_pa, "slide_stiffness": self.slide_stiffness, "slide_dashpot": self.slide_dashpot,
                 "rest_speed": REST_SPEED_AFTER_FALL * touchdown,
                 "borne": (1.0 - REST_OUT_OF_BALANCE) * self.normal_weight_n,
                 "moment_limit": REST_OUT_OF_BALANCE * self.weight_n * self.reach_m}
        soil, factor, index = self.patch_soil, self.factor, np.arange(n)
        state = dict(angles=angles, rates=rates, depth_cg=depth_cg, speed=speed, before=before, deepest=deepest,
                     pressed=pressed, time=time, steps=steps, fell=fell, end=end, middle_most=middle_most,
                     edge_most=edge_most, turn_most=turn_most, drift=drift, slide=slide, slip=slip,
                     slide_most=slide_most, inclined=inclined)
        out = {name: np.empty((n, *value.shape[1:]), dtype=value.dtype) for name, value in state.items()
               if name in ("angles", "time", "steps", "end", "middle_most", "edge_most", "turn_most", "slide_most")}
        samples = []
        while True:
            (angles, rates, depth_cg, speed, before, deepest, pressed, time, steps, fell, end, middle_most, edge_most,
             turn_most, drift, slide, slip, slide_most, inclined) = state.values()
            if not (running := end == RUNNING).any():
                break
            rows = turn_rows(angles[:, 0], angles[:, 1])
            arm = rows @ self.arms  # (vehicles, 3, patches)
            depth = depth_cg[:, None] - arm[:, 2]
            down = speed[:, None] - rates[:, :1] * arm[:, 1] + rates[:, 1:] * arm[:, 0]
            # the track's pressure as its base is pushed along the seabed too: Green's inclination, V at h
            # over V at 0, so that a track pushed sideways sinks on until its load lies on the envelope
            load = self.pressure(depth, down, soil, factor) * inclined[:, self.track_of_patch]
            deeper = depth >= deepest
            below = np.where(deeper, 0.0, deepest - depth)  # how far each patch has risen from its deepest
            elastic_depth = given["elastic"][:, None]
            with np.errstate(divide="ignore", invalid="ignore"):  # no elastic depth: a risen patch lets go
                elastic = np.where(elastic_depth > 0.0, pressed - pressed / elastic_depth * below,
                                   np.where(below > 0.0, 0.0, pressed))
            elastic = elastic + given["dashpot"][:, None] * down  # the soil it rises from radiates
            # a patch whose grousers have cut in holds the soil between them as a skirt holds a mudmat's: undrained,
            # it pulls on the soil below as it pushed, down to its peak pressure (Tresca's yield is symmetric)
            p = np.where(deeper, load, np.maximum(np.minimum(elastic, load), -pressed))
            deepest, pressed = np.where(deeper, depth, deepest), np.where(deeper, load, pressed)
            force = p * area
            tracks = rows @ self.track_arms  # (vehicles, 3, tracks): where the base's resistance along it acts
            along, slip, pushed_ratio = self.along_seabed(tracks, rates, depth_cg, speed, slide, drift, slip, force,
                                                          given, soil, factor)
            inclined = green_vertical(pushed_ratio) / PRANDTL_NC
            moment = np.stack([(arm[:, 1] * force).sum(axis=1) - (tracks[:, 2] * along[:, 1]).sum(axis=1),
                               -(arm[:, 0] * force).sum(axis=1) + (tracks[:, 2] * along[:, 0]).sum(axis=1)], axis=1)
            total = force.sum(axis=1)
            pushed = along.sum(axis=2)  # (vehicles, x y)
            middle = depth_cg - rows[:, 2] @ self.middle
            middle_most = np.maximum(middle_most, middle)
            edge_most = np.maximum(edge_most, depth_cg - (rows[:, 2] @ self.corners).min(axis=1))
            turn_most = np.maximum(turn_most, np.hypot(*angles.T))
            slide_most = np.maximum(slide_most, np.hypot(*slide.T))
            if history:
                samples.append((time[0], middle[0], speed[0], total[0] / 2.0, *np.degrees(angles[0]), *(moment[0] / 2.0),
                                *slide[0], *(pushed[0] / 2.0)))
            stiffness = area * np.maximum(pressed, given["floor"][:, None]).sum(axis=1) / np.maximum(
                given["elastic"], 1e-6 * body.width_m)
            dt = STEP_FRACTION * np.sqrt(given["mass"] / stiffness)
            fell = fell | ((before > 0.0) & (speed <= 0.0))  # its fall has stopped
            turning = np.abs(rates * self.free).max(axis=1) * self.reach_m
            sliding = np.abs(drift * self.free_xy).max(axis=1)
            rest = (fell & (np.abs(speed) <= given["rest_speed"]) & (turning <= given["rest_speed"])
                    & (sliding <= given["rest_speed"]) & (total >= given["borne"])
                    & (np.abs(moment * self.free).max(axis=1) <= given["moment_limit"]))
            end = np.where(running & rest, AT_REST, end)
            end = np.where((end == RUNNING) & (middle > LARGEST_SINKAGE_WIDTHS * body.width_m), PASSED, end)
            end = np.where((end == RUNNING) & (slide_most > LARGEST_SINKAGE_WIDTHS * body.width_m), SLID, end)
            end = np.where((end == RUNNING) & (time > LONGEST_S), UNSETTLED, end)
            moving = (end == RUNNING)[:, None]
            steps = steps + running
            before = speed
            speed = np.where(moving[:, 0], speed + dt * (given["weight"] - total) / given["mass"], speed)
            rates = np.where(moving, rates + dt[:, None] * moment / given["inertia"] * self.free, rates)
            drift = np.where(moving, drift + dt[:, None] * (given["along"] + pushed) / given["mass"][:, None]
                             * self.free_xy, drift)
            depth_cg = np.where(moving[:, 0], depth_cg + dt * speed, depth_cg)
            slide = np.where(moving, slide + dt[:, None] * drift, slide)
            angles = np.where(moving, angles + dt[:, None] * rates, angles)
            time = np.where(moving[:, 0], time + dt, time)
            state = dict(angles=angles, rates=rates, depth_cg=depth_cg, speed=speed, before=before, deepest=deepest,
                         pressed=pressed, time=time, steps=steps, fell=fell, end=end, middle_most=middle_most,
                         edge_most=edge_most, turn_most=turn_most, drift=drift, slide=slide, slip=slip,
                         slide_most=slide_most, inclined=inclined)
            still = moving[:, 0]
            if self.factor_of_rows is not None and still.sum() < 0.75 * len(still):  # the ended leave the arrays
                for name in out:
                    out[name][index[~still]] = state[name][~still]
                index = index[still]
                state = {name: value[still] for name, value in state.items()}
                given = {name: value[still] for name, value in given.items()}
                soil = replace(soil, **{f.name: getattr(soil, f.name)[still] for f in fields(Landing)
                                        if f.name not in (*SHARED, "grouser_height_m")})
                factor = self.factor_of_rows(index)
        for name in out:
            out[name][index] = state[name]
        return {"end": out["end"], "time_s": out["time"], "steps": out["steps"], "middle_m": out["middle_most"],
                "edge_m": out["edge_most"], "turn_rad": out["turn_most"], "roll_rad": out["angles"][:, 1],
                "pitch_rad": out["angles"][:, 0], "slide_m": out["slide_most"],
                "samples": samples}

    def along_seabed(self, tracks, rates, depth_cg, speed, slide, drift, slip, force, given, soil, factor):
        """The soil's force along the seabed on each track's base (vehicles, x y, tracks) and the tracks' slip:
        elastic from where the base last slipped, up to Green's (1954) capacity of a rough strip at the
        track's load, h = H/(A·su) at v = V/(A·s) (:func:`dsmv.analytic.bearing.green_horizontal`), with s the
        strength for which the track's capacity is Prandtl's, the fast model's pressure at its depth and speed
        over 2 + π, and su the soil's at the base (:meth:`base_shear_n`; while it sinks, the envelope's point
        whose normal is its motion's, if larger), plus the
        passive push on the trapped soil's faces (:meth:`passive_push`, docs/decisions/0036); and the
        base's radiation dashpot while it bears and holds. Also each track's h (the base's share of the
        push), which the patches' next pressures are inclined by. ``tracks``: each track's base middle from the
        centre of gravity, turned (vehicles, 3, tracks)."""
        moved = slide[:, :, None] + tracks[:, :2] - self.track_arms[:2]
        swing = np.stack([rates[:, 1:] * tracks[:, 2], -rates[:, :1] * tracks[:, 2]], axis=1)  # ω × r along the seabed
        velocity = drift[:, :, None] + swing
        half = force.shape[1] // 2
        load = np.stack([force[:, :half].sum(axis=1), force[:, half:].sum(axis=1)], axis=1)  # (vehicles, tracks)
        depth = depth_cg[:, None] - tracks[:, 2]
        down = speed[:, None] - rates[:, :1] * tracks[:, 1] + rates[:, 1:] * tracks[:, 0]
        area = self.scene.geometry.contact_area_m2
        strength = area * self.pressure(depth, down, soil, factor) / PRANDTL_NC
        shear, *faces = self.sliding_resistance_n(depth, soil)
        bearing = (load > 0.0) & (strength > 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            capacity = green_horizontal(np.where(bearing, load / strength, 0.0))
            # a track sinking as it slides yields on the envelope where its normal is the motion's direction:
            # at the vertex h = 0 while it slides no faster than it sinks, else h = (r² − 1)/(r² + 1),
            # r = slide speed / sinking speed (normality on Green's envelope, whose slope is −(1 + h)/√(1 − h²))
            ratio2 = np.where(down > 0.0, (velocity[:, 0]**2 + velocity[:, 1]**2) / np.where(down > 0.0, down, 1.0)**2,
                              0.0)
            flowing = np.where(down > 0.0, np.maximum((ratio2 - 1.0) / (ratio2 + 1.0), 0.0), 0.0)
            base = np.where(bearing, shear * np.maximum(capacity, flowing), 0.0)
            stiffness = given["slide_stiffness"][:, :, None]
            trial = -stiffness * (moved - slip)
            size = np.hypot(trial[:, 0], trial[:, 1])
            # the trapped soil's faces a push along x and along y meets, weighed by its direction
            passive = (np.abs(trial) * np.stack(faces, axis=1)).sum(axis=1) / np.where(size > 0.0, size, 1.0)
            capacity = base + passive
            over = size > capacity
            resisted = trial * np.where(over, capacity / np.where(over, size, 1.0), 1.0)[:, None, :]
        slip = np.where(over[:, None, :], moved + resisted / stiffness, slip)
        with np.errstate(divide="ignore", invalid="ignore"):
            # the base's share of the push (base and faces mobilised alike: in proportion to their capacities)
            share = np.where(capacity > 0.0, base / np.where(capacity > 0.0, capacity, 1.0), 0.0)
            ratio = np.where(bearing, np.minimum(share * np.hypot(resisted[:, 0], resisted[:, 1]) / shear, 1.0),
                             0.0)
        # the dashpot radiates the base's vibration while it holds: a base slipping along the seabed radiates none
        holding = (bearing & ~over)[:, None, :]
        return resisted - given["slide_dashpot"][:, None, None] * velocity * holding, slip, ratio

    def base_shear_n(self, depth: np.ndarray, soil: Landing) -> np.ndarray:
        """A·su (N): the most the soil resists a track's base sliding along its plane, su the intact strength
        at the grousers' tips ``depth`` deep, without rate gain, as on the faces (:meth:`passive_push`). The
        base sliding with the faces' wedges is a mechanism whatever the load V, so A·su plus the faces bounds
        the push from above; the bearing strength p/(2 + π), depth and overburden in it, would not
        (decision 0035)."""
        return self.scene.geometry.contact_area_m2 * strength_at(soil, np.maximum(depth, 0.0))[0]

    def passive_push(self, depth: np.ndarray, soil: Landing) -> np.ndarray:
        """The push (N per m of face) the soil a track's grousers trap, its tips ``depth`` deep (m), meets on a
        face pushed into the soil ahead and pulled from the soil behind: the undrained passive pressure
        σv + K·su over the whole depth D ahead; behind, the active σv − K·su over the trapped soil's height gh
        only, which holds the soil behind it, while the steel above lets it go (contact separation, decision
        0042). So K·su over D, K·su over min(D, gh), and the overburden σv = ρ'·g·z on the face ahead where
        the one behind has let go; K = 1 + arcsin α + √(1 − α²) for the track's adhesion α (the slip-line
        field's, :func:`~dsmv.analytic.bearing.undrained_wall_coefficient`: Rankine's 2 smooth, 2.571 rough;
        decision 0036). Simpson's rule over each depth (exact on a straight line), from the intact strength,
        without rate gain."""
        d = np.maximum(depth, 0.0)
        held = np.minimum(d, self.grouser_height_m)
        k = undrained_wall_coefficient(self.scene.geometry.adhesion_factor)

        def strength_over(length):  # ∫ su dz from the mudline down ``length`` (N/m)
            su = [strength_at(soil, fraction * length)[0] for fraction in (0.0, 0.5, 1.0)]
            return length * (su[0] + 4.0 * su[1] + su[2]) / 6.0

        overburden = density_at(soil, 0.5 * (held + d)) * soil.gravity_m_s2 * 0.5 * (d * d - held * held)
        return k * (strength_over(d) + strength_over(held)) + overburden

    def end_arcs_n(self, depth: np.ndarray, soil: Landing) -> tuple[np.ndarray, np.ndarray]:
        """The track's ends (docs/decisions/0044), the two sprocket arcs' runs below the mudline past the flat
        run, the envelope of the grousers' tips, radius ρ = R + gh, as cel3d draws them: at the angle θ from
        the arc's lowest point the envelope lies d(θ) = D − ρ·(1 − cos θ) deep, ``depth`` = D at the tips.
        A push across the track shears their underside (su at d over the arc, B wide: B·∫ su ρ dθ) and meets
        their sides' faces (:meth:`passive_push` at d over the run, ∫ push ρ cos θ dθ). Returns both (N),
        the two ends together: the slice of each run pushed as the flat run's section is, whose neighbours'
        differing depths the sum leaves out. Gauss–Legendre over θ, split where d = gh (where the push's
        held face stops growing), so each piece is smooth."""
        rho, gh = self.arc_radius_m, self.grouser_height_m
        d = np.maximum(depth, 0.0)
        top = np.arccos(np.clip(1.0 - d / rho, 0.0, 1.0))  # where the arc meets the mudline (at most its side)
        kink = np.arccos(np.clip(1.0 - np.maximum(d - gh, 0.0) / rho, 0.0, 1.0))
        halves = 0.5 * np.stack([kink, top - kink], axis=-1)  # (…, pieces): each piece's half-width
        middles = np.stack([halves[..., 0], kink + halves[..., 1]], axis=-1)
        theta = (middles[..., None] + halves[..., None] * ARC_NODES).reshape(*d.shape, -1)  # (…, pieces · points)
        weight = (halves[..., None] * ARC_WEIGHTS).reshape(theta.shape) * rho
        deep = (d[..., None] - rho * (1.0 - np.cos(theta))).reshape(d.shape[0], -1)  # rows stay the soil's
        su = strength_at(soil, deep)[0].reshape(theta.shape)
        push = self.passive_push(deep, soil).reshape(theta.shape)
        return (2.0 * self.scene.geometry.width_m * (weight * su).sum(axis=-1),
                2.0 * (weight * push * np.cos(theta)).sum(axis=-1))

    def sliding_resistance_n(self, depth: np.ndarray, soil: Landing,
                             ends: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The most the soil resists a track, its tips ``depth`` deep, sliding along the seabed (N): its
        underside's (the flat run's A·su, :meth:`base_shear_n`, and the end arcs', :meth:`end_arcs_n`), and
        the push on the faces of the soil its grousers trap (:meth:`passive_push`) pushed along x (across
        the track: its sides, the flat run's length L and the end arcs' runs) and along y (along it: its
        ends, B wide). Without ``ends``: the flat run's alone, as the track's section has it."""
        body = self.scene.geometry
        arcs, arc_faces = self.end_arcs_n(depth, soil) if ends else (0.0, 0.0)
        push = self.passive_push(depth, soil)
        return self.base_shear_n(depth, soil) + arcs, push * body.contact_length_m + arc_faces, push * body.width_m

    def sliding_slope_deg(self, depth_m: float, ends: bool = True) -> float:
        """The seabed slope (degrees, across the tracks) at which a track whose grousers' tips are ``depth_m``
        deep reaches its capacity along the seabed, set down slowly: V = W·cos β and H = W·sin β per track,
        its base on Green's (1954) envelope, V over the strength of its bearing pressure at that depth,
        A·p/(2 + π), H over its underside's strength (A·su, :meth:`base_shear_n`, and with ``ends`` its end
        arcs', :meth:`end_arcs_n`), and the faces of the soil its grousers trap along its length
        (:meth:`passive_push`, and with ``ends`` along its end arcs' runs): where a vehicle with that
        embedment starts to slide, by the strip's inclined-load capacity; 90 where it holds the track on
        any slope. Without ``ends``: the flat run's, as the track's section (``section_base=grouser_tips``)."""
        from scipy.optimize import brentq

        weight, body = 0.5 * float(self.weight_n[0]), self.scene.geometry
        depth = np.array([[depth_m]])
        strength = body.contact_area_m2 * float(self.pressure(depth, np.zeros_like(depth))[0, 0]) / PRANDTL_NC
        shear, faces, _ = (float(force[0, 0]) for force in self.sliding_resistance_n(depth, self.patch_soil, ends))

        def unheld(slope):  # the push along the seabed over what the track holds there (N)
            return weight * math.sin(slope) - shear * float(green_horizontal(weight * math.cos(slope) / strength)) - faces

        if unheld(0.5 * math.pi) <= 0.0:  # a light track held on any slope (the seabed fails first)
            return 90.0
        return math.degrees(brentq(unheld, 1e-6, 0.5 * math.pi))

    def solve(self) -> SolveResult:
        body = self.scene.geometry
        landed = self.land(history=True)
        end, time, middle = int(landed["end"][0]), float(landed["time_s"][0]), float(landed["middle_m"][0])
        status = STATUS[end]
        message = {AT_REST: f"came to rest at {middle:.4g} m after {time:.3g} s",
                   PASSED: f"the vehicle passes {LARGEST_SINKAGE_WIDTHS:g} B without stopping",
                   SLID: f"the vehicle slides {LARGEST_SINKAGE_WIDTHS:g} B along the seabed without stopping",
                   UNSETTLED: f"the vehicle did not settle within {LONGEST_S:g} s"}[end]
        history = self._history(landed["samples"])
        metrics = {"max_sinkage_m": middle, "max_edge_sinkage_m": float(landed["edge_m"][0]),
                   "max_rotation_deg": math.degrees(landed["turn_rad"][0]), "max_horizontal_displacement_m": float(landed["slide_m"][0]),
                   "rotation_deg": float(history["rotation_deg"][-1]), "pitch_deg": float(history["pitch_deg"][-1]),
                   "time_to_rest_s": time, "sinkage_over_width": middle / body.width_m,
                   "weight_per_track_n": 0.5 * float(self.weight_n[0]), "steps": float(landed["steps"][0])}
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
        force and moments the soil puts on the vehicle; its slide along the seabed."""
        keep = np.unique(np.r_[np.linspace(0, len(samples) - 1, min(len(samples), HISTORY_SAMPLES)).astype(int)])
        table = np.array(samples)[keep]
        names = ("time_s", "sinkage_m", "velocity_m_s", "force_n", "pitch_deg", "rotation_deg", "pitch_moment_n_m",
                 "moment_n_m", "horizontal_displacement_m", "lateral_displacement_m", "horizontal_force_n",
                 "lateral_force_n")
        return dict(zip(names, table.T))
