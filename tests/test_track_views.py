"""The two 2D views of the Pioneering-I track: cross-section and longitudinal section."""

from __future__ import annotations

import json

import numpy as np
import pytest

from dsmv.cel.solver2d import Cel2DSolver
from dsmv.config.scene import build_scene
from dsmv.errors import ConfigError


def _solver(compose_cfg, *overrides):
    cfg = compose_cfg(["solver=cel2d", "mesh=medium", "geometry.view=longitudinal", "tracking=disabled", *overrides])
    return Cel2DSolver(build_scene(cfg))


def test_longitudinal_view_has_grousers_at_the_pitch_and_a_sprocket_arc(compose_cfg):
    solver = _solver(compose_cfg, "geometry.grousers=cells")
    grid = solver.build()
    track = solver.scene.geometry
    solid = solver.body_contact(grid).solid
    h = grid.x[1] - grid.x[0]
    half = 0.5 * track.contact_length_m
    assert solver.characteristic_width_m(0.1) == track.contact_length_m  # the in-plane width is L
    base_row = grid.row_of(0.0)
    grouser_columns = np.nonzero(solid[:, base_row])[0]
    # one grouser per plate pitch over the half length, from the axis
    assert len(grouser_columns) == int(np.floor(half / track.plate_pitch_m + 1e-9)) + 1
    assert np.allclose(np.diff(grid.x[grouser_columns]), track.plate_pitch_m, atol=h)
    # above the grousers the plates are solid out to L/2; the sprocket lifts the end
    plate_row = base_row + max(1, round(track.grouser_height_m / h))
    plate_end = grid.x[np.nonzero(solid[:, plate_row])[0].max() + 1]
    assert half - h < plate_end < half + track.sprocket_radius_m * 0.5
    top_row = int(np.searchsorted(grid.y, grid.y[plate_row] + track.sprocket_radius_m))  # the sprocket's top
    top_end = grid.x[np.nonzero(solid[:, top_row])[0].max() + 1]
    assert top_end == pytest.approx(half + track.sprocket_radius_m, abs=h)


@pytest.mark.parametrize("h", [0.04, 0.08, 0.16])
def test_trapped_soil_grousers_are_the_same_shape_and_start_on_every_mesh(compose_cfg, h):
    """``geometry.grousers=trapped_soil``: the track is its grousers' envelope (a flat base at their
    tips, sprocket arcs of radius R + gh), on any cell size; it starts with the grousers cut in, its base
    gh below a mudline that is not rounded to the grid, having fallen gh under its wet weight
    (½·m·v² grows by W·gh exactly) with the trapped soil's weight and mass added to its own."""
    solver = _solver(compose_cfg, f"mesh.cell_size_m={h}")
    track, landing, soil = solver.scene.geometry, solver.scene.landing, solver.scene.soil
    gh = track.grouser_height_m
    state = solver.initial_state()
    grid, solid = state.grid, state.cells.solid
    base_row = grid.row_of(0.0)
    under_run = 0.5 * (grid.x[:-1] + grid.x[1:]) < 0.5 * track.contact_length_m
    assert solid[under_run, base_row].all()  # no grouser columns: the whole run's base at the tips
    sprocket = solver.rules.shape(track, grid.h).sprocket_radius
    assert sprocket == track.sprocket_radius_m + gh
    far = state.cells.phi[-1]  # the column at the far side: soil up to the mudline
    soil_height = float((far * np.diff(grid.y)).sum())
    assert soil_height == pytest.approx(gh - grid.y[0], rel=1e-12)
    start = solver.start()
    trapped_kg = soil.density_kg_m3 * track.width_m * track.contact_length_m * gh
    assert start.sinkage_m == gh and start.depth_m == gh
    assert start.inertia_kg == pytest.approx(landing.inertia_per_track_kg + trapped_kg, rel=1e-12)
    assert start.weight_n == pytest.approx(landing.weight_per_track_n + trapped_kg * landing.gravity_m_s2, rel=1e-12)
    m = landing.inertia_per_track_kg
    assert 0.5 * m * start.velocity_m_s**2 == pytest.approx(0.5 * m * landing.velocity_m_s**2
                                                            + landing.weight_per_track_n * gh, rel=1e-12)


def test_longitudinal_view_rejects_a_smooth_track(compose_cfg):
    cfg = compose_cfg(["solver=cel2d", "geometry.view=longitudinal", "geometry.roughness=smooth", "tracking=disabled"])
    with pytest.raises(ConfigError, match="geometry.roughness"):
        build_scene(cfg)


def test_longitudinal_landing_conserves_mass_and_closes_the_energy_audit(run_cli, tmp_path):
    done = run_cli("dsmv", "solver=cel2d", "mesh=coarse", "geometry.view=longitudinal", "tracking=disabled",
                   "output.plots=false", "solver.domain_depth_widths=2", "solver.domain_half_width_widths=2",
                   "solver.core_margin_widths=0.3")
    assert done.returncode == 0, done.stderr[-2000:]
    result = json.loads(next((tmp_path / "runs" / "outputs").glob("*/*/result.json")).read_text())
    assert result["status"] == "ok", result["message"]
    metrics = result["metrics"]
    assert metrics["mass_error"] < 1e-10
    assert metrics["energy_error"] < 0.02
    assert 0.01 < metrics["max_sinkage_m"] < 0.6
