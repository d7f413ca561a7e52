"""A vehicle on two tracks (``geometry=vehicle_pioneer_i``, ``geometry.gauge_m``): cel3d lands both as one
rigid body, the weight shared by them (``landing.n_tracks = 2``)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from dsmv import registry
from dsmv.config.scene import build_scene
from dsmv.errors import ConfigError

QUIET = ["solver.progress=off", "tracking=disabled"]


def land(compose_cfg, *overrides):
    scene = build_scene(compose_cfg([*QUIET, *overrides]))
    solver = registry.load("solvers", scene.solver.name, "solver.name")(scene)
    result = solver.solve()
    assert result.status == "ok", result.message
    return solver, result


def test_a_symmetric_vehicle_s_tracks_each_land_as_one_track_with_half_the_weight(compose_cfg):
    """Centre of gravity over the middle, upright, no drift, level seabed, tracks 6 m apart (4.4 m of soil
    between them, 9 B): each track sinks as the one track carrying half the vehicle's mass (the same
    3D mesh), within the mesh's error (measured 0.6 % apart; the coarse mesh is within 1 % of the
    extrapolated answer). Free to slide and turn, the symmetric vehicle stays upright and in place:
    the quarter model's planes hold it, exactly."""
    solver, vehicle = land(compose_cfg, "geometry=vehicle_pioneer_i", "geometry.gauge_m=6",
                           "landing.free=[z,x,y,rx,ry,rz]")
    _, track = land(compose_cfg, "solver=cel3d", "landing.mass_kg=2250")
    assert vehicle.metrics["max_sinkage_m"] == pytest.approx(track.metrics["max_sinkage_m"], rel=0.01)
    assert vehicle.metrics["max_rotation_deg"] == 0.0 and vehicle.metrics["max_horizontal_displacement_m"] == 0.0
    assert solver.symmetry_planes() == (True, True) and solver.model_scale() == 2.0  # a quarter: half a track
    grid = solver.grid
    # each track's edges on node lines though its centre (3 m) is not a multiple of the cells from 0
    for edge in (3.0 - 0.3, 3.0 + 0.3):
        assert np.abs(grid.x - edge).min() < 1e-12


def test_the_tracks_closer_together_sink_less_and_the_gauge_is_in_the_summary(compose_cfg, run_cli, tmp_path):
    """At the assumed 2.6 m gauge (2 m of soil between the tracks) the soil between them bears on both
    (measured 1.2 % shallower than 6 m apart); the summary names the gauge as assumed."""
    done = run_cli("dsmv", "geometry=vehicle_pioneer_i", "tracking=disabled", "output.plots=false")
    assert done.returncode == 0, done.stderr
    assert "vehicle_pioneer_i (two tracks 2.6 m apart, each carrying half)" in done.stdout
    assert "geometry.gauge_m = 2.6 m" in done.stdout
    (result,) = (tmp_path / "runs").rglob("result.json")
    near = json.loads(result.read_text())["metrics"]["max_sinkage_m"]
    _, apart = land(compose_cfg, "geometry=vehicle_pioneer_i", "geometry.gauge_m=6")
    assert near < apart.metrics["max_sinkage_m"]


@pytest.mark.parametrize("overrides, key", [
    (["geometry=vehicle_pioneer_i", "landing.n_tracks=1"], "landing.n_tracks"),
    (["geometry=vehicle_pioneer_i", "geometry.gauge_m=0.5"], "geometry.gauge_m"),
])
def test_a_vehicle_s_tracks_must_share_its_weight_and_stand_apart(compose_cfg, overrides, key):
    with pytest.raises(ConfigError) as refused:
        build_scene(compose_cfg([*QUIET, *overrides]))
    assert refused.value.path == key


def test_the_vehicle_s_2d_section_holds_both_tracks(compose_cfg):
    """cel2d lands the vehicle's cross-section: its two tracks' sections side by side, a half model with
    one of them while symmetric. 6 m apart each sinks as the one track with half the mass (measured
    1.1e-5 apart); the whole section, both tracks drawn, gives the half model's answer to round-off;
    2.6 m apart the soil between them bears on both (5 % shallower in plane strain)."""
    _, apart = land(compose_cfg, "geometry=vehicle_pioneer_i", "solver=cel2d", "geometry.gauge_m=6")
    _, track = land(compose_cfg, "solver=cel2d", "landing.mass_kg=2250")
    assert apart.metrics["max_sinkage_m"] == pytest.approx(track.metrics["max_sinkage_m"], rel=1e-4)
    _, near = land(compose_cfg, "geometry=vehicle_pioneer_i", "solver=cel2d")
    assert near.metrics["max_sinkage_m"] < 0.97 * apart.metrics["max_sinkage_m"]
    # bonded Tresca soil: no tie switching on and off to carry the sums' last bits (the default landing's
    # whole and half sections, whose soil parts from the tracks, read 1.6e-5 apart)
    bonded = ["geometry=vehicle_pioneer_i", "solver=cel2d", "soil.law=tresca", "solver.contact_separation=false"]
    solver, half = land(compose_cfg, *bonded)
    whole_solver, whole = land(compose_cfg, *bonded, "solver.economies.symmetry=false")
    assert solver.half_model(solver.scene) and not whole_solver.half_model(whole_solver.scene)
    assert whole.metrics["max_sinkage_m"] == pytest.approx(half.metrics["max_sinkage_m"], rel=5e-9)  # 1.4e-9


def test_the_vehicle_s_fields_and_figure_show_both_tracks(run_cli, tmp_path):
    """The contour figure of a vehicle's section draws both tracks: its core window is found from the cell
    size most cells have, though the axis opens with a leftover cell at the middle plane."""
    done = run_cli("dsmv", "geometry=vehicle_pioneer_i", "solver=cel2d", "output.fields=true", "tracking=disabled")
    assert done.returncode == 0, done.stderr
    (figure,) = tmp_path.glob("runs/outputs/*/*/fields_max_sinkage.png")
    assert figure.stat().st_size > 10_000
    from dsmv.cel.fields import read_frame
    from dsmv.post.plots import _core_window

    frame = read_frame(figure.with_name("fields") / "max_sinkage.vtu")
    half_width, _bottom, _top = _core_window(frame)
    assert half_width >= 0.5 * 2.6 + 0.5 * 0.6  # the window reaches past the track's outer wall


def test_a_vehicle_heavier_on_one_side_rolls_and_its_mirror_image_rolls_back(compose_cfg):
    """The vehicle's cross-section on Tresca soil, its centre of gravity 0.3 m towards one track, free to
    sink, slide and roll in large deformation (the body redrawn as it turns): the heavier side's track
    sinks deeper, and the mirrored vehicle gives the mirrored answers to round-off."""
    runs = [land(compose_cfg, "geometry=vehicle_pioneer_i", "solver=cel2d", "soil.law=tresca", "mesh=coarse",
                 "landing.free=[z,x,ry]", f"landing.cg_offset_m=[{e},0,0]")[1] for e in (0.3, -0.3)]
    right, left = (r.metrics for r in runs)
    assert right["max_rotation_deg"] > 0.1
    assert right["max_sinkage_right_track_m"] > right["max_sinkage_left_track_m"]
    assert left["max_sinkage_left_track_m"] == pytest.approx(right["max_sinkage_right_track_m"], rel=1e-12)
    assert left["max_sinkage_right_track_m"] == pytest.approx(right["max_sinkage_left_track_m"], rel=1e-12)
    assert left["max_rotation_deg"] == pytest.approx(right["max_rotation_deg"], rel=1e-12)
    # the largest roll from the history's samples: within the kernel's step by step, and mirrored
    assert 0.0 < right["max_roll_deg"] <= right["max_rotation_deg"] and "max_pitch_deg" not in right
    assert left["max_roll_deg"] == pytest.approx(right["max_roll_deg"], rel=1e-12)
    # the tilt at the end is the roll at the end, either way
    assert right["final_tilt_deg"] == pytest.approx(abs(right["rotation_deg"]), rel=1e-12)
    assert left["final_tilt_deg"] == pytest.approx(right["final_tilt_deg"], rel=1e-12)


@pytest.mark.slow  # 200 s: two 3D landings to rest; the default suite mirrors the 3D turn on a plate (test_turn)
def test_the_3d_vehicle_rolls_as_its_mirror_image(compose_cfg):  # and the vehicle's roll in its section (above)
    """cel3d, the vehicle with its centre of gravity 0.3 m towards either track (cells 0.15 m, half model:
    the plane across the tracks kept), free to sink, slide and roll, redrawn as it rolls (every 0.05 of a
    cell, so that its half-degree roll is redrawn): rolls and
    slides mirrored and the tracks' sinkages swapped, to round-off; the heavier side's track sinks deeper."""
    runs = [land(compose_cfg, "geometry=vehicle_pioneer_i", "mesh.cell_size_m=0.15", "landing.free=[z,x,ry]",
                 "solver.redraw_fraction=0.05", f"landing.cg_offset_m=[{e},0,0]")[1] for e in (0.3, -0.3)]
    right, left = runs
    assert right.metrics["redraws"] > 0 and right.metrics["max_rotation_deg"] > 0.1
    assert right.metrics["max_sinkage_right_track_m"] > right.metrics["max_sinkage_left_track_m"]
    for a, b in (("max_sinkage_right_track_m", "max_sinkage_left_track_m"),
                 ("final_sinkage_right_track_m", "final_sinkage_left_track_m")):
        assert right.metrics[a] == pytest.approx(left.metrics[b], rel=1e-12, abs=1e-15), a
    for name, sign in (("rotation_deg", -1), ("horizontal_displacement_m", -1), ("sinkage_m", 1), ("force_n", 1)):
        x, y = np.asarray(right.history[name]), sign * np.asarray(left.history[name])
        assert np.abs(x - y).max() <= 1e-12 * np.abs(x).max(), name
