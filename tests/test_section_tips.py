"""The cross-section of the track cel3d lands (``geometry.section_base=grouser_tips``): the grousers'
envelope in plane strain, its base at their tips.

Truths: a free fall through the grousers' height (v² = v0² + 2·(W/m)·gh, the thin blades' resistance
neglected, as cel3d starts); the trapped soil's share of each wall, which adds up to the grouser height
whatever the cell; the mirror (a section on a slope falling towards +x and one falling towards −x slide
as mirror images); and the study's section on its plates left as it was (its scene hash)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from dsmv.cel.solver2d import Cel2DSolver
from dsmv.config.scene import build_scene
from dsmv.errors import ConfigError

TIPS = "geometry.section_base=grouser_tips"


def test_the_study_s_section_on_its_plates_keeps_its_hash(compose_cfg):
    """Naming the default base changes nothing: the same scene, the same hash, no trapped soil."""
    default = build_scene(compose_cfg(["solver=cel2d"]))
    plates = build_scene(compose_cfg(["solver=cel2d", "geometry.section_base=plates"]))
    tips = build_scene(compose_cfg(["solver=cel2d", TIPS]))
    assert plates.config_hash == default.config_hash != tips.config_hash
    assert Cel2DSolver(default).trapped_soil_m() == 0.0 and Cel2DSolver(default).plates_above_base_m() == 0.0


def test_the_section_at_the_tips_starts_once_its_grousers_have_cut_in(compose_cfg):
    """Its base gh below the mudline, falling at √(v0² + 2·(W/m)·gh), carrying the trapped soil's mass
    ρ·B·L·gh; each wall's ties hold a share that adds up to gh (the base's node its half cell) on cells
    of gh/2 and of gh."""
    for cell in (0.025, 0.05):
        scene = build_scene(compose_cfg(["solver=cel2d", TIPS, "soil.law=tresca", f"mesh.cell_size_m={cell}"]))
        solver, body, landing = Cel2DSolver(scene), scene.geometry, scene.landing
        gh = body.grouser_height_m
        start = solver.start()
        trapped_kg = scene.soil.density_kg_m3 * body.width_m * body.contact_length_m * gh
        fall = math.sqrt(landing.velocity_m_s**2 + 2.0 * landing.weight_per_track_n / landing.inertia_per_track_kg * gh)
        assert start.sinkage_m == gh and start.velocity_m_s == pytest.approx(fall, rel=1e-14)
        assert start.inertia_kg == pytest.approx(landing.inertia_per_track_kg + trapped_kg, rel=1e-14)
        grid = solver.build()
        contact = solver.body_contact(grid).contact
        i, j = np.divmod(contact.node[: len(contact.node) - len(contact.split_node)], len(grid.y))  # grid ties
        wall = (np.abs(np.abs(grid.x[i]) - 0.5 * body.width_m) < 1e-9) & (j > grid.row_of(0.0))
        held, side_of = contact.bond[: len(i)][wall], np.sign(grid.x[i][wall])
        sides = np.unique(side_of)  # the half model's one wall, or both
        assert len(sides) >= 1
        for side in sides:
            on_side = side_of == side
            assert grid.h * (held[on_side].sum() + 0.5) == pytest.approx(gh, rel=1e-12), (cell, side)


def test_the_section_at_the_tips_slides_downhill_as_its_mirror_image(compose_cfg):
    """The vehicle's section at the tips (B/8) set down on a 30° slope of uniform Tresca soil falling
    towards +x and towards −x: mirror images, slide and tilt, to round-off (5e-11 of the largest, as the
    study's section on a slope), the slide downhill, and soil mass kept."""
    runs = []
    for direction in (0, 180):
        scene = build_scene(compose_cfg([
            "geometry=vehicle_pioneer_i", "solver=cel2d", TIPS, "soil.law=tresca", "soil.su0_pa=20000",
            "soil.ks_pa_per_m=0", "soil.youngs_modulus_pa=1e7", "landing.velocity_m_s=0.05", "landing.mass_kg=30000",
            "landing.free=[z,x,ry]", "soil.slope_deg=30", f"soil.downslope_direction_deg={direction}",
            "mesh.cell_size_m=0.075", "solver.initial_travel_m=0.15", "solver.progress=off"]))
        runs.append(Cel2DSolver(scene).solve())
    down_x, down_minus_x = runs
    assert down_x.status == down_minus_x.status == "ok"
    assert down_x.metrics["horizontal_displacement_m"] > 0.005
    for name, sign in (("horizontal_displacement_m", -1), ("sinkage_m", 1), ("rotation_deg", -1),
                       ("horizontal_force_n", -1)):
        a, b = np.asarray(down_x.history[name]), sign * np.asarray(down_minus_x.history[name])
        assert np.abs(a - b).max() <= 5e-11 * np.abs(a).max(), name
    assert abs(down_x.metrics["mass_error"]) <= 1e-12


@pytest.mark.parametrize("overrides, says", [
    (["solver=cel3d", TIPS], "cel3d models the grousers' envelope itself"),
    (["solver=cel2d", TIPS, "geometry.grousers=cells"], "geometry.grousers=trapped_soil"),
    (["solver=cel2d", TIPS, "geometry.view=longitudinal"], "the side view models the grousers itself"),
])
def test_a_base_at_the_tips_outside_cel2d_s_cross_section_is_refused(compose_cfg, overrides, says):
    with pytest.raises(ConfigError, match="geometry.section_base") as refused:
        build_scene(compose_cfg(overrides))
    assert says in str(refused.value)
