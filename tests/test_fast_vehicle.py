"""The fast vehicle model (``solver=analytic_dynamic`` on a vehicle, :mod:`dsmv.analytic.vehicle`).

Truths: a level vehicle with its centre of gravity over its middle is each track's fast landing with
half the weight (the step's error first order, shrinking with the step); mirror symmetry (a centre of
gravity at +e and −e rolls the vehicle as mirror images, its tracks' sinkages swapped, to round-off);
the sense of the turns.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from dsmv.analytic import vehicle
from dsmv.analytic.dynamic import AnalyticDynamicSolver, fast_vehicle
from dsmv.config.scene import build_scene

VEHICLE = ["geometry=vehicle_pioneer_i", "solver=analytic_dynamic", "tracking=disabled"]


def land(compose_cfg, *overrides):
    return AnalyticDynamicSolver(build_scene(compose_cfg([*VEHICLE, *overrides]))).solve()


def test_a_level_vehicle_is_each_track_s_fast_landing_with_half_the_weight(compose_cfg, monkeypatch):
    """The default vehicle, upright, its centre of gravity over its middle: its sinkage is one track's
    fast landing with half the weight (2250 kg, ``analytic_dynamic_3d``) within 0.3 % (measured
    0.27 %, then 0.13 % and 0.064 %), the gap halving with the step (first order); it does not tilt."""
    one = build_scene(compose_cfg(["solver=analytic_dynamic_3d", "tracking=disabled", "landing.mass_kg=2250"]))
    track = AnalyticDynamicSolver(one).solve()
    reference = track.metrics["max_sinkage_m"]
    gaps = []
    for fraction in (0.05, 0.025, 0.0125):
        monkeypatch.setattr(vehicle, "STEP_FRACTION", fraction)
        result = land(compose_cfg)
        assert result.status == "ok", result.message
        assert result.metrics["max_rotation_deg"] == 0.0
        assert result.metrics["max_sinkage_left_track_m"] == result.metrics["max_sinkage_right_track_m"]
        gaps.append(result.metrics["max_sinkage_m"] / reference - 1.0)
    assert 0.0 < gaps[0] <= 3e-3
    assert gaps[1] == pytest.approx(gaps[0] / 2, rel=0.1) and gaps[2] == pytest.approx(gaps[1] / 2, rel=0.1)


def test_a_vehicle_heavier_on_one_side_rolls_as_its_mirror_image(compose_cfg):
    """The centre of gravity 0.3 m towards either track, free to roll: the rolls are mirror images and the
    tracks' sinkages swap, to round-off; the heavier side sinks deeper."""
    right, left = (land(compose_cfg, "landing.free=[z,ry]", f"landing.cg_offset_m=[{e},0,0]") for e in (0.3, -0.3))
    assert right.status == left.status == "ok"
    assert right.metrics["max_rotation_deg"] > 0.1 and right.metrics["rotation_deg"] > 0.0
    assert right.metrics["max_sinkage_right_track_m"] > right.metrics["max_sinkage_left_track_m"]
    assert left.metrics["rotation_deg"] == pytest.approx(-right.metrics["rotation_deg"], rel=1e-12)
    for a, b in (("max_sinkage_right_track_m", "max_sinkage_left_track_m"),
                 ("final_sinkage_right_track_m", "final_sinkage_left_track_m")):
        assert right.metrics[a] == pytest.approx(left.metrics[b], rel=1e-12), a
    a, b = np.asarray(right.history["rotation_deg"]), -np.asarray(left.history["rotation_deg"])
    assert np.abs(a - b).max() <= 1e-12 * np.abs(a).max()


def test_a_vehicle_heavier_at_its_front_pitches_nose_down_and_a_rolled_one_rights_itself(compose_cfg):
    """The centre of gravity 0.5 m forward (+y): it pitches its front down (− about x, the front ends
    deeper than the rear); touching down rolled 4° it turns back through level."""
    nose = land(compose_cfg, "landing.free=[z,rx]", "landing.cg_offset_m=[0,0.5,0]")
    assert nose.status == "ok" and nose.metrics["pitch_deg"] < 0.0
    assert nose.metrics["max_pitch_deg"] >= -nose.metrics["pitch_deg"] and nose.metrics["max_roll_deg"] == 0.0
    assert nose.metrics["max_sinkage_left_track_front_m"] > nose.metrics["max_sinkage_left_track_rear_m"]
    rolled = land(compose_cfg, "landing.free=[z,ry]", "landing.roll_deg=4")
    assert rolled.status == "ok" and rolled.metrics["max_rotation_deg"] == pytest.approx(4.0)
    assert abs(rolled.metrics["rotation_deg"]) < 4.0


def test_a_tilting_vehicle_s_summary_names_its_assumed_mass_layout_and_each_track(run_cli):
    """The study gives no vehicle: a vehicle free to turn names its centre of gravity and its default
    inertia as assumed, and the summary gives each track's deepest point and the tilt."""
    done = run_cli("dsmv", *VEHICLE, "landing.free=[z,ry]", "landing.cg_offset_m=[0.3,0,0]")
    assert done.returncode == 0, done.stderr
    assumed = next(line for line in done.stdout.splitlines() if line.strip().startswith("assumed"))
    assert "geometry.gauge_m = 2.6 m" in assumed and "landing.cg_offset_m = [0.3, 0.0, 0.0] m" in assumed
    assert "landing.rotational_inertia_kg_m2 = a uniform box" in assumed
    assert "(the base's middle)" in done.stdout and "its tracks" in done.stdout and "turned" in done.stdout


def test_a_yaw_in_the_fast_vehicle_model_is_refused_naming_its_key(run_cli):
    """It sinks, slides, pitches and rolls: a yaw runs in cel3d (one line, exit 2)."""
    result = run_cli("dsmv", *VEHICLE, "landing.free=[z,rz]")
    assert result.returncode == 2
    assert "landing.free" in result.stderr and len(result.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("overrides", [
    ["landing.free=[z,ry]", "landing.cg_offset_m=[0.3,0,0]"],
    ["landing.free=[z,rx,ry]", "landing.cg_offset_m=[0.2,-0.4,0.1]", "landing.pitch_deg=2", "soil.law=tresca"],
    ["landing.free=[z,x,y,rx,ry]", "landing.cg_offset_m=[0.2,0,0.5]", "soil.slope_deg=10",
     "soil.downslope_direction_deg=30", "landing.lateral_velocity_m_s=0.3"],
])
def test_vehicles_landed_together_land_as_each_alone(compose_cfg, overrides):
    """task=exceedance lands a block of vehicles at once (one row each): the scene's own vehicle among
    them, beside others with their strength, speed and mass drawn, lands as it does alone, and each of
    the others as its own scene alone, to round-off."""
    from dsmv.surrogate.model import scene_table
    from dsmv.surrogate.vehicle_exceedance import land_samples

    scene = build_scene(compose_cfg([*VEHICLE, *overrides]))
    others = [build_scene(compose_cfg([*VEHICLE, *overrides, *drawn])) for drawn in (
        ["soil.su0_pa=3500", "soil.youngs_modulus_pa=1750000", "landing.velocity_m_s=2.2"],
        ["landing.mass_kg=6000", "soil.ks_pa_per_m=900", "soil.sensitivity=3.5", "soil.xi95=18"])]
    landed = land_samples(scene, scene_table([scene, *others]))
    for k, alone in enumerate(AnalyticDynamicSolver(s).solve() for s in (scene, *others)):
        assert landed.status[k] == alone.status == "ok"
        deepest = max(alone.metrics["max_sinkage_m"], alone.metrics["max_edge_sinkage_m"])
        assert landed.sinkage_m[k] == pytest.approx(deepest, rel=1e-12)
        assert landed.tilt_deg[k] == pytest.approx(alone.metrics["max_rotation_deg"], rel=1e-12)
        assert landed.slide_m[k] == pytest.approx(alone.metrics["max_horizontal_displacement_m"], rel=1e-12, abs=1e-15)
    assert len(set(np.round(landed.tilt_deg, 6))) == 3  # the draws changed the landings


def test_a_vehicles_exceedance_gives_its_tilts_beside_its_sinkage_and_its_mirror_the_same(run_cli, tmp_path):
    """dsmv-predict task=exceedance on a vehicle: the fast vehicle model lands each sample (no registered
    model needed) and gives P(tilt > limit) beside P(sinkage > limit); its centre of gravity on the other
    side gives the same probabilities exactly (mirror images)."""
    import json

    answers = []
    for side in ("0.3", "-0.3"):
        done = run_cli("dsmv-predict", "task=exceedance", "sinkage_limit_m=0.12", *VEHICLE[:2],
                       "landing.free=[z,ry]", f"landing.cg_offset_m=[{side},0,0]", "safety.max_tilt_deg=0.7",
                       "uncertainty.samples=200", f"hydra.run.dir=answer{side}")
        assert done.returncode == 0, done.stderr
        assert "P(tilt > 0.7°)" in done.stdout and "P(sinkage > 0.12 m)" in done.stdout
        answers.append(json.loads((tmp_path / f"answer{side}" / "prediction.json").read_text()))
        assert (tmp_path / f"answer{side}" / "exceedance.png").stat().st_size > 10_000
    right, left = answers
    assert 0.0 < right["tilt_exceedance_probability"] < 1.0 and 0.0 < right["exceedance_probability"] < 1.0
    for key in ("exceedance_probability", "tilt_exceedance_probability", "unsafe_probability"):
        assert left[key] == right[key], key
    assert left["tilt_median_deg"] == pytest.approx(right["tilt_median_deg"], rel=1e-12)
    assert right["unsafe_probability"] >= max(right["exceedance_probability"], right["tilt_exceedance_probability"])


def test_a_vehicles_exceedance_on_a_slope_gives_its_slides_and_the_mirrored_slope_the_same(run_cli, tmp_path):
    """On a 20° slope, drawing the soil and the touchdown: P(slide > limit) beside the others, the same
    exactly whether the slope falls towards +x or −x; P(any limit) at least each one's."""
    import json

    answers = []
    for direction in ("0", "180"):
        done = run_cli("dsmv-predict", "task=exceedance", "sinkage_limit_m=0.12", *VEHICLE[:2],
                       "landing.free=[z,x,ry]", "soil.slope_deg=20", f"soil.downslope_direction_deg={direction}",
                       "safety.max_slide_m=0.003", "uncertainty.samples=200", f"hydra.run.dir=answer{direction}")
        assert done.returncode == 0, done.stderr
        assert "P(slide > 0.003 m)" in done.stdout and "P(any limit)" in done.stdout
        answers.append(json.loads((tmp_path / f"answer{direction}" / "prediction.json").read_text()))
    down, up = answers
    assert 0.0 < down["slide_exceedance_probability"] < 1.0
    for key in ("exceedance_probability", "slide_exceedance_probability", "unsafe_probability"):
        assert up[key] == down[key], key
    assert down["unsafe_probability"] >= max(down["exceedance_probability"], down["slide_exceedance_probability"])


@pytest.mark.parametrize("args, message", [
    (["task=predict"], "task = 'predict': a vehicle scene answers task=exceedance"),
    (["task=exceedance", "sinkage_limit_m=0.1", "landing.free=[z,rz]"], "landing.free"),
    (["task=exceedance", "sinkage_limit_m=0.1", "soil.slope_deg=35"], "soil.slope_deg = 35.0: the seabed would slide"),
])
def test_a_vehicle_question_the_fast_model_cannot_answer_is_one_line_with_exit_2(run_cli, args, message):
    done = run_cli("dsmv-predict", "geometry=vehicle_pioneer_i", *args)  # (its solver: cel3d, which takes a slope)
    assert done.returncode == 2, done.stderr
    assert message in done.stderr and len(done.stderr.strip().splitlines()) == 1, done.stderr


# ------------------------------------------------------------------ along the seabed: slope, drift, slide

#: a heavy vehicle set down slowly on strong uniform Tresca soil, free to sink, slide and roll: it slides
#: long before its slope would fail (su ≫ ρ'·g·B), as the strip of decision 0032's check does
SET_DOWN = ["soil.law=tresca", "soil.su0_pa=20000", "soil.ks_pa_per_m=0", "soil.youngs_modulus_pa=1e7",
            "landing.velocity_m_s=0.05", "landing.mass_kg=20000", "landing.free=[z,x,ry]"]


def test_a_vehicle_set_down_slowly_slides_where_green_s_envelope_says(compose_cfg):
    """Set down at 0.05 m/s on slopes across its tracks: each track carries V = W·cos β and H = W·sin β.
    Green's (1954) envelope, the base sliding at A·su, with the trapped soil's rough faces (the face behind
    held over the grousers' height, decision 0042) and the end arcs' runs (decision 0044), at the embedment
    the vehicle reaches on a slope it holds (45°), holds it up to 61.5°. The vehicle rests at 0.9 of that
    and slides away at 1.02 (the acceptance: within 10 % in slope angle). Measured: it starts to slide
    between 59° and 60°, 2.4–4.1 % below the envelope."""
    level = build_scene(compose_cfg([*VEHICLE, *SET_DOWN]))
    held = land(compose_cfg, *SET_DOWN, "soil.slope_deg=45")
    envelope = fast_vehicle(level).sliding_slope_deg(held.metrics["max_edge_sinkage_m"])
    assert held.status == "ok" and 55.0 < envelope < 65.0
    stays = land(compose_cfg, *SET_DOWN, f"soil.slope_deg={0.9 * envelope}")
    slides = land(compose_cfg, *SET_DOWN, f"soil.slope_deg={1.02 * envelope}")
    assert stays.status == "ok" and stays.message.startswith("came to rest")  # having slid 0.19 B
    assert slides.status == "bearing_failure" and "slides" in slides.message
    assert slides.metrics["max_horizontal_displacement_m"] > 10.0 * level.geometry.width_m


@pytest.mark.parametrize("mass_kg", [10000, 20000, 30000, 45000])
def test_the_slope_a_track_holds_is_bounded_by_its_base_sliding_with_the_faces(compose_cfg, mass_kg):
    """Upper-bound theorem: the base sliding on its plane, with the passive wedge ahead over the embedment
    and the active one behind over the grousers' height, is a mechanism whatever V, so no slope past
    sin β = (A·su + faces)/W holds a track, W its share of the weight (the end arcs' runs summed slice by
    slice as the flat run's section). The envelope reaches that bound on Green's sliding branch (V at most
    (1 + π/2)·A·s) and lies under it past the branch. (With the base at the bearing strength A·s, as first
    written, the 30 t vehicle's envelope at 0.09 m stood 9° past it.)"""
    level = fast_vehicle(build_scene(compose_cfg([*VEHICLE, *SET_DOWN[:-2], f"landing.mass_kg={mass_kg}",
                                                  "landing.free=[z,x,ry]"])))
    body, weight = level.scene.geometry, 0.5 * float(level.weight_n[0])
    for depth in (0.06, 0.09, 0.12):
        d = np.array([[depth]])
        bound = float(level.base_shear_n(d, level.patch_soil)[0, 0]) + sum(
            float(arc[0, 0]) for arc in level.end_arcs_n(d, level.patch_soil)) + \
            float(level.passive_push(d, level.patch_soil)[0, 0]) * body.contact_length_m
        slope = level.sliding_slope_deg(depth)
        strength = body.contact_area_m2 * float(level.pressure(d, np.zeros_like(d))[0, 0]) / vehicle.PRANDTL_NC
        on_branch = weight * math.cos(math.radians(slope)) <= (1.0 + 0.5 * math.pi) * strength
        held = weight * math.sin(math.radians(slope))
        if slope == 90.0:  # held on any slope: the bound is the weight's whole pull or more
            assert bound >= weight, (mass_kg, depth)
        elif on_branch:
            assert held == pytest.approx(bound, rel=1e-9), (mass_kg, depth)
        else:
            assert held < bound, (mass_kg, depth)


def test_a_vehicle_slides_down_its_slope_as_its_mirror_image(compose_cfg):
    """A slope falling towards +x and one towards −x (10°), the centre of gravity high above the base:
    the vehicle slides downhill and rolls the same, mirrored, to round-off."""
    down, up = (land(compose_cfg, "landing.free=[z,x,ry]", "landing.cg_offset_m=[0,0,0.8]", "soil.slope_deg=10",
                     f"soil.downslope_direction_deg={a}") for a in (0, 180))
    assert down.status == up.status == "ok"
    assert down.history["horizontal_displacement_m"][-1] > 1e-3
    np.testing.assert_allclose(up.history["horizontal_displacement_m"], -down.history["horizontal_displacement_m"],
                               rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(up.history["rotation_deg"], -down.history["rotation_deg"], rtol=1e-12, atol=1e-13)
    assert up.metrics["max_sinkage_m"] == pytest.approx(down.metrics["max_sinkage_m"], rel=1e-12)


def test_a_symmetric_vehicle_free_to_slide_lands_as_one_held(compose_cfg):
    """Level, upright, no drift: free to slide along x and y as well, it lands exactly as one held to
    sink, and does not slide."""
    held, free = land(compose_cfg), land(compose_cfg, "landing.free=[z,x,y,rx,ry]")
    assert free.metrics["max_horizontal_displacement_m"] == 0.0
    for name in ("max_sinkage_m", "max_edge_sinkage_m", "time_to_rest_s"):
        assert free.metrics[name] == held.metrics[name]


def test_a_drifting_vehicle_slides_the_farther_the_faster_it_drifts(compose_cfg):
    """Touching down drifting across its tracks at 0.5 and 1 m/s: it comes to rest having slid, farther
    the faster; drifting the other way it slides as its mirror image."""
    slow, fast, back = (land(compose_cfg, "landing.free=[z,x,ry]", f"landing.horizontal_velocity_m_s={v}")
                        for v in (0.5, 1.0, -0.5))
    assert slow.status == fast.status == "ok"
    assert 0.0 < slow.metrics["max_horizontal_displacement_m"] < fast.metrics["max_horizontal_displacement_m"]
    assert back.history["horizontal_displacement_m"][-1] == pytest.approx(
        -slow.history["horizontal_displacement_m"][-1], rel=1e-12)


def test_a_strength_table_s_level_drawn_lands_each_vehicle_as_its_own_scene(compose_cfg):
    """On the CCZ box-core table, ``soil.profile_scale`` drawn (a calibration's uncertainty draws it): each
    vehicle of the block lands as the scene with that scale does alone, to round-off, and a weaker table
    sinks it deeper."""
    from dsmv.surrogate.model import scene_table
    from dsmv.surrogate.vehicle_exceedance import land_samples

    overrides = ["soil=ccz_box_core", "landing.free=[z,ry]", "landing.cg_offset_m=[0.3,0,0]"]
    scene = build_scene(compose_cfg([*VEHICLE, *overrides]))
    table = scene_table([scene] * 3)
    table["profile_scale"] = scales = [0.7, 1.0, 1.4]
    landed = land_samples(scene, table)
    for k, scale in enumerate(scales):
        alone = land(compose_cfg, *overrides, f"soil.profile_scale={scale}")
        assert landed.status[k] == alone.status == "ok"
        deepest = max(alone.metrics["max_sinkage_m"], alone.metrics["max_edge_sinkage_m"])
        assert landed.sinkage_m[k] == pytest.approx(deepest, rel=1e-12)
        assert landed.tilt_deg[k] == pytest.approx(alone.metrics["max_rotation_deg"], rel=1e-12)
    assert landed.sinkage_m[0] > landed.sinkage_m[1] > landed.sinkage_m[2]


def test_a_strength_table_s_level_drawn_lands_each_track_as_its_own_scene(compose_cfg):
    """One track (the 3D track's fast landing model) on the CCZ box-core table, ``soil.profile_scale``
    drawn: each track of the block lands as the scene with that scale does alone, to round-off, and a
    weaker table sinks it deeper."""
    from dsmv.surrogate.model import scene_table
    from dsmv.surrogate.vehicle_exceedance import land_samples

    track = ["solver=analytic_dynamic_3d", "tracking=disabled", "soil=ccz_box_core"]
    scene = build_scene(compose_cfg(track))
    assert not scene.geometry.vehicle and scene.soil.bent_strength is not None
    table = scene_table([scene] * 3)
    table["profile_scale"] = scales = [0.7, 1.0, 1.4]
    landed = land_samples(scene, table)
    for k, scale in enumerate(scales):
        alone = AnalyticDynamicSolver(build_scene(compose_cfg([*track, f"soil.profile_scale={scale}"]))).solve()
        assert landed.status[k] == alone.status == "ok"
        assert landed.sinkage_m[k] == pytest.approx(alone.metrics["max_sinkage_m"], rel=1e-12)
    assert landed.sinkage_m[0] > landed.sinkage_m[1] > landed.sinkage_m[2]
    assert not landed.tilt_deg.any() and not landed.slide_m.any()


@pytest.mark.parametrize("args, message", [
    (["task=exceedance", "geometry=vehicle_pioneer_i", "soil=ccz_box_core"],
     "uncertainty.soil.su0_pa = 'a distribution': the soil's strength is a table"),
    (["task=exceedance", "soil=ccz_box_core"], "uncertainty.soil.su0_pa = 'a distribution': the soil's strength "
                                               "is a table"),
    (["task=exceedance", "geometry=vehicle_pioneer_i", "uncertainty=ccz_box_core"],
     "uncertainty.soil.profile_scale = 'a distribution': scales a strength table"),
    (["task=exceedance", "uncertainty=ccz_box_core"], "uncertainty.soil.profile_scale = 'a distribution': scales "
                                                      "a strength table"),
    (["task=predict", "soil=ccz_box_core"], "soil.profile = 'a table': the surrogates (trained on straight-line soils"),
])
def test_a_table_soil_s_exceedance_draws_its_level_and_the_surrogates_refuse_it(run_cli, args, message):
    """A strength table sets su0 and ks (drawing them is refused: its level is drawn); a straight line has
    no level to draw; the surrogates learn straight lines, so a bent table's prediction is refused before a
    model is sought: each one line, exit 2."""
    done = run_cli("dsmv-predict", "sinkage_limit_m=0.1", *args)
    assert done.returncode == 2, done.stderr
    assert message in done.stderr and len(done.stderr.strip().splitlines()) == 1, done.stderr


def test_a_track_s_exceedance_on_the_box_core_draws_the_table_s_level(run_cli, tmp_path):
    """One track on ``soil=ccz_box_core uncertainty=ccz_box_core``: the fast landing model lands every
    sample, no registered model needed (tracking off); the answer lies strictly between 0 and 1 for a
    limit inside the samples' spread, and the histogram is drawn."""
    import json

    done = run_cli("dsmv-predict", "task=exceedance", "sinkage_limit_m=0.12", "soil=ccz_box_core",
                   "uncertainty=ccz_box_core", "uncertainty.samples=500", "tracking=disabled", "hydra.run.dir=answer")
    assert done.returncode == 0, done.stderr
    assert "fast landing model" in done.stdout and "P(sinkage > 0.12 m)" in done.stdout
    answer = json.loads((tmp_path / "answer" / "prediction.json").read_text())
    assert 0.0 < answer["exceedance_probability"] < 1.0 and answer["model"] == "fast landing model"
    assert (tmp_path / "answer" / "exceedance.png").stat().st_size > 0


def test_a_vehicles_exceedance_on_the_box_core_draws_the_table_s_level(run_cli, tmp_path):
    """``soil=ccz_box_core uncertainty=ccz_box_core``: the table's level is drawn (cov 0.2), so the samples'
    sinkages spread; the answer is a probability strictly between 0 and 1 for a limit inside the spread."""
    import json

    done = run_cli("dsmv-predict", "task=exceedance", "sinkage_limit_m=0.08", "geometry=vehicle_pioneer_i",
                   "soil=ccz_box_core", "uncertainty=ccz_box_core", "uncertainty.samples=300", "hydra.run.dir=answer")
    assert done.returncode == 0, done.stderr
    answer = json.loads((tmp_path / "answer" / "prediction.json").read_text())
    assert 0.0 < answer["exceedance_probability"] < 1.0


def test_the_faces_earth_pressure_lies_between_rankine_and_coulomb_s_wedge():
    """The trapped soil's face coefficient K(α) (σv ± K·su): Rankine's 2 on a smooth wall, a statically
    admissible state whatever the adhesion, so a lower bound; Coulomb's planar wedge with the wall's
    adhesion, 2·√(1 + α), an upper bound. K(α) lies between, on both at α = 0 and 1 + π/2 at α = 1."""
    from dsmv.analytic.bearing import undrained_wall_coefficient

    alphas = np.linspace(0.0, 1.0, 21)
    k = np.array([undrained_wall_coefficient(a) for a in alphas])
    assert k[0] == 2.0 and k[-1] == pytest.approx(1.0 + math.pi / 2, rel=1e-15)
    assert np.all(k[1:] > 2.0) and np.all(k[1:] < 2.0 * np.sqrt(1.0 + alphas[1:]))
    assert np.all(np.diff(k) > 0.0)


@pytest.mark.parametrize("depth", [0.03, 0.085, 0.2])
def test_the_end_arcs_runs_are_the_sprocket_arcs_below_the_mudline(compose_cfg, depth):
    """The end arcs' sliding resistance (decision 0044) against its closed form on uniform soil: the arcs
    (radius ρ = R + gh, lowest point at the tips' depth D) lie d(s) = D − ρ + √(ρ² − s²) deep at s past the
    flat run, to the mudline at s_D; their underside is the arc's length ρ·arccos(1 − D/ρ) times B·su, their
    sides' push K·su·(d + min(d, gh)) + ρ'·g·(d² − min(d, gh)²)/2 per metre, integrated in s by
    ∫√(ρ² − s²) ds = (s·√(ρ² − s²) + ρ²·arcsin(s/ρ))/2; two ends. Tips shallower than the grousers' height
    (0.03 m), just past it, and well past it. Measured: they agree to 1e-16 (underside) and 6e-14 (faces)."""
    from dsmv.analytic.bearing import undrained_wall_coefficient

    level = fast_vehicle(build_scene(compose_cfg([*VEHICLE, *SET_DOWN])))
    body, soil = level.scene.geometry, level.patch_soil
    su, density, g = 20000.0, float(np.ravel(soil.density_kg_m3)[0]), float(np.ravel(soil.gravity_m_s2)[0])
    rho, gh, k = body.sprocket_radius_m + body.grouser_height_m, body.grouser_height_m, \
        undrained_wall_coefficient(body.adhesion_factor)
    c = depth - rho
    reach, held_to = (math.sqrt(rho**2 - c**2), math.sqrt(rho**2 - (gh - c) ** 2) if depth > gh else 0.0)

    def root_area(s):
        return 0.5 * (s * math.sqrt(rho**2 - s**2) + rho**2 * math.asin(s / rho))

    def depth_integral(a, b):  # ∫ d ds
        return c * (b - a) + root_area(b) - root_area(a)

    def square_integral(a, b):  # ∫ d² ds
        return (c * c + rho**2) * (b - a) - (b**3 - a**3) / 3.0 + 2.0 * c * (root_area(b) - root_area(a))

    underside = 2.0 * body.width_m * su * rho * math.acos(1.0 - depth / rho)
    faces = 2.0 * (k * su * (depth_integral(0.0, reach) + gh * held_to + depth_integral(held_to, reach))
                   + 0.5 * density * g * (square_integral(0.0, held_to) - gh * gh * held_to))
    measured = level.end_arcs_n(np.array([[depth]]), soil)
    assert float(measured[0][0, 0]) == pytest.approx(underside, rel=1e-15)
    assert float(measured[1][0, 0]) == pytest.approx(faces, rel=2e-13)


def test_a_patch_bears_once_its_plates_reach_the_mudline_not_its_grousers_tips(compose_cfg):
    """Decision 0045: the blades cut in freely (the soil between them follows only past s·Nc/2, eight
    grouser heights), so a patch presses nothing until its tips are gh deep, then the fast landing
    model's pressure. A pitched vehicle's first force then acts under its low end alone, where cel3d's
    envelope bears from the tips along the whole stretch already in the soil."""
    model = fast_vehicle(build_scene(compose_cfg([*VEHICLE, "landing.pitch_deg=1", "landing.free=[z,rx]"])))
    gh = model.grouser_height_m
    depth = np.array([[0.0, 0.5 * gh, gh, gh * (1 + 1e-9), 2 * gh]])
    p = model.pressure(depth, np.full_like(depth, 1.5))
    assert (p[0, :3] == 0.0).all() and (p[0, 3:] > 0.0).all()
