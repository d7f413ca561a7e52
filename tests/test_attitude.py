"""A body that touches down tilted (``landing.pitch_deg``, ``landing.roll_deg``): drawn turned about its
centre of gravity with its lowest corner on the mudline, and redrawn as it turns.

Truths: the geometry of a turned rectangle (its lowest corner, from the turn's matrix applied to each
corner), mirror symmetry (a roll of +θ and of −θ land as mirror images, to round-off), and the
refusals of what a model cannot draw.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from dsmv.app.runner import BLADES_DRAWN_M, EARLY_TOUCH_SHALLOW, ENVELOPE_FROM_TIPS_M, attitude_note
from dsmv.cel.body import Pose
from dsmv.cel.layout import B_ROT_X, B_ROT_Y
from dsmv.cel.solver2d import Cel2DSolver
from dsmv.cel.solver3d import Cel3DSolver
from dsmv.config.scene import build_scene

QUIET = ["solver.progress=off", "tracking=disabled"]


def lowest_corner(half_x: float, half_y: float, cg, angles) -> float:
    """The lowest of the base's four corners (x = ±half_x, y = ±half_y, z = 0 from the middle of the
    base) turned by ``angles`` about the centre of gravity ``cg`` (m): the turn's matrix on each corner."""
    pose = Pose.turned(angles, cg)
    corners = np.array([(sx * half_x, sy * half_y, 0.0) for sx, sy in itertools.product((-1, 1), repeat=2)])
    turned = pose.to_grid(corners) + np.asarray(pose.origin)
    return float(turned[:, 2].min())


def test_a_rolled_section_meets_the_mudline_with_its_lowest_corner(compose_cfg):
    """The track's cross-section rolled 5° about a centre of gravity 0.4 m above the middle of its base:
    the mudline lies at its lowest corner, c·(1 − cos θ) − B/2·sin θ from the upright base, to round-off;
    it starts at its attitude and its base's lowest point at the mudline."""
    scene = build_scene(compose_cfg([*QUIET, "solver=cel2d", "landing.roll_deg=5", "landing.free=[x,z,ry]",
                                     "landing.cg_offset_m=[0,0,0.4]", "soil.law=tresca", "mesh=coarse"]))
    solver = Cel2DSolver(scene)
    state = solver.initial_state()
    theta, half = math.radians(5.0), 0.5 * scene.geometry.width_m
    assert solver.mudline == pytest.approx(0.4 * (1 - math.cos(theta)) - half * math.sin(theta), abs=1e-15)
    assert state.body[B_ROT_Y] == theta
    start = solver.start()
    assert start.depth_m == pytest.approx(solver.mudline, abs=1e-15)  # the upright base's depth below it


def test_a_pitched_and_rolled_vehicle_meets_the_mudline_with_its_lowest_corner(compose_cfg):
    """The 3D vehicle pitched 3° and rolled −2° about a centre of gravity off its middle: the mudline lies
    at the lowest corner of its tracks' footprint turned by the pose's matrix (the compiled loop's
    sinkage formula measured against it), less the grousers' cut; the body carries its attitude."""
    scene = build_scene(compose_cfg([*QUIET, "geometry=vehicle_pioneer_i", "landing.pitch_deg=3",
                                     "landing.roll_deg=-2", "landing.free=[z,x,y,rx,ry]",
                                     "landing.cg_offset_m=[0.2,-0.3,0.5]", "mesh.cell_size_m=0.3"]))
    solver = Cel3DSolver(scene)
    state = solver.initial_state()
    angles = (math.radians(3.0), math.radians(-2.0), 0.0)
    body = scene.geometry
    expected = lowest_corner(body.track_offset_m + 0.5 * body.width_m, 0.5 * body.contact_length_m,
                             scene.landing.cg_offset_m, angles)
    assert solver.mudline == pytest.approx(expected + body.grouser_height_m, abs=1e-14)
    assert (state.body[B_ROT_X], state.body[B_ROT_Y]) == angles[:2]


def test_a_level_touchdown_keeps_its_scene_and_its_answer(compose_cfg):
    """Attitude 0 is the level landing: the same scene hash, the mudline on the node row."""
    level = build_scene(compose_cfg(QUIET))
    zero = build_scene(compose_cfg([*QUIET, "landing.pitch_deg=0", "landing.roll_deg=0"]))
    assert zero.config_hash == level.config_hash
    assert not zero.landing.attitude_key and zero.landing.symmetric


def test_a_roll_and_its_mirror_image_land_as_mirror_images(compose_cfg):
    """The track's cross-section (Tresca, cells 0.03 m) touching down rolled +8° and −8°, free to sink,
    slide and roll: it rights itself (to 3.2°), slides and sinks as mirror images, to round-off; its
    lowest corner starts on the mudline and the summary's tilt counts from level."""
    runs = []
    for roll in (8, -8):
        scene = build_scene(compose_cfg([*QUIET, "solver=cel2d", "soil.law=tresca", "mesh.cell_size_m=0.03",
                                         f"landing.roll_deg={roll}", "landing.free=[x,z,ry]"]))
        runs.append(Cel2DSolver(scene).solve())
    right, left = runs
    assert right.status == left.status == "ok", right.message
    assert right.metrics["redraws"] > 0 and 0.0 < right.metrics["rotation_deg"] < 8.0
    assert right.metrics["max_rotation_deg"] == pytest.approx(8.0, rel=1e-15)
    half = 0.5 * 0.6  # the track's half width (m)
    assert right.metrics["attitude_drop_m"] == pytest.approx(2 * half * math.sin(math.radians(8)), rel=1e-15)
    assert right.history["sinkage_m"][0] == pytest.approx(-half * math.sin(math.radians(8)), abs=1e-15)
    for name, sign in (("rotation_deg", -1), ("horizontal_displacement_m", -1), ("sinkage_m", 1), ("force_n", 1)):
        a, b = np.asarray(right.history[name]), sign * np.asarray(left.history[name])
        assert np.abs(a - b).max() <= 1e-12 * np.abs(a).max(), name


@pytest.mark.parametrize("overrides, key", [
    (["solver=cel2d", "landing.pitch_deg=2"], "landing.pitch_deg"),
    (["solver=cel2d", "landing.roll_deg=2", "solver.remap=false", "landing.free=[x,z,ry]"], "landing.roll_deg"),
    (["solver=analytic_dynamic", "landing.roll_deg=2"], "landing.roll_deg"),
    (["landing.roll_deg=30"], "landing.roll_deg"),
])
def test_an_attitude_a_model_cannot_draw_is_refused_naming_its_key(run_cli, overrides, key):
    """A pitch in plane strain, a tilt without the remap (it is drawn turned), a tilt in a fast model,
    a tilt of 30° or more: one line naming the key, exit 2."""
    result = run_cli("dsmv", "tracking=disabled", *overrides)
    assert result.returncode == 2
    assert key in result.stderr and len(result.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("drop_m, cell_m, expected", [
    (0.05, 0.075, "under one cell, the staircase draws it level"),
    (0.112, 0.075, "read 35 % shallow at 1.4 cells across"),
    (0.223, 0.075, "read 21 % shallow at 2.8 cells across"),
    (0.0835, 0.0075, "read 6 % shallow at 11.1 cells across"),
])
def test_the_summary_says_how_shallow_a_tilted_touchdown_reads_on_its_cells(drop_m, cell_m, expected):
    """A tilted base meets the soil about a cell early: the summary gives its drop in core cells and the
    rolled section's measured shallowness at the drop nearest to it (decision 0030's table)."""
    note = attitude_note(drop_m, cell_m)
    assert f"{drop_m / cell_m:.2g} core cells" in note and expected in note


def test_the_summary_says_a_tilted_envelope_bears_from_its_grousers_tips():
    """A track whose grousers are the soil they trap bears from their tips on a tilted touchdown, on any mesh:
    the note says so, with the side view's two landings (decision 0045); a base without them does not."""
    note = attitude_note(0.223, 0.075, envelope=True)
    assert "read 21 % shallow" in note and "envelope bears from their tips" in note
    assert f"{ENVELOPE_FROM_TIPS_M:g} m, its grousers drawn {BLADES_DRAWN_M:g} m" in note
    assert "envelope" not in attitude_note(0.223, 0.075)


def test_the_shallowness_the_summary_quotes_is_the_rolled_sections_own():
    """EARLY_TOUCH_SHALLOW is decision 0030's series: the deepest points 0.1250, 0.1533, 0.1684 and 0.1822 m
    on cells of 0.06 to 0.0075 m against 0.1936 m on 0.00375 m, the drop 0.6·sin 8° across."""
    drop = 0.6 * math.sin(math.radians(8.0))
    finest = 0.1936
    for (cells, shallow), (cell_m, deepest) in zip(EARLY_TOUCH_SHALLOW, ((0.06, 0.1250), (0.03, 0.1533),
                                                                        (0.015, 0.1684), (0.0075, 0.1822))):
        assert cells == pytest.approx(drop / cell_m, abs=0.05)
        assert shallow == pytest.approx(1.0 - deepest / finest, abs=0.005)
