"""Richardson extrapolation with the observed order (dsmv.convergence), against exact series."""

from __future__ import annotations

import math

import pytest

from dsmv.convergence import FALLBACK_FACTOR, first_order, observed_order, richardson


@pytest.mark.parametrize("p", [0.7, 1.0, 2.0, 2.9])
@pytest.mark.parametrize("h", [(0.01, 0.02, 0.04), (0.0375, 0.075, 0.15), (0.05, 0.1, 0.25)])
def test_an_exact_power_law_is_extrapolated_exactly(h, p):
    """z = z* + C·h^p on any three cell sizes: the order and the limit come back to round-off."""
    z = tuple(0.15 - 0.4 * hi**p for hi in h)
    estimate = richardson(h, z)
    assert estimate.asymptotic and estimate.order == pytest.approx(p, rel=1e-9)
    assert estimate.extrapolated == pytest.approx(0.15, rel=1e-9)
    assert estimate.error == pytest.approx(0.4 * h[0] ** p, rel=1e-6)


def test_outside_the_regime_first_order_and_a_safety_factor():
    h = (0.01, 0.02, 0.04)
    wobbly = (0.140, 0.134, 0.136)  # the differences change sign
    assert math.isnan(observed_order(h, wobbly))
    estimate = richardson(h, wobbly)
    assert not estimate.asymptotic and estimate.order == 1.0
    assert estimate.error == pytest.approx(FALLBACK_FACTOR * 0.006)
    assert estimate.extrapolated == pytest.approx(0.140 + 0.006)
    slow = tuple(1.0 - hi**0.2 for hi in h)  # order 0.2: below the range, so not trusted
    assert not richardson(h, slow).asymptotic


@pytest.mark.parametrize("h", [(0.0375, 0.075), (0.02, 0.0375)])
def test_two_meshes_extrapolate_a_first_order_series_exactly(h):
    """z = z* + C·h on two cell sizes of any ratio: the limit back to round-off, the error three times
    the last change."""
    z = tuple(0.115 + 0.02 * hi for hi in h)
    estimate = first_order(h, z)
    assert estimate.extrapolated == pytest.approx(0.115, rel=1e-12)
    assert estimate.error == pytest.approx(FALLBACK_FACTOR * 0.02 * (h[1] - h[0]), rel=1e-9)
    assert not estimate.asymptotic and estimate.order == 1.0


@pytest.mark.parametrize("cell_m, grouser_m, factors", [
    (0.0375, 0.05, (2,)),      # B/16: 2h = 0.075 m measures the 0.05 m grousers' soil, 4h = 0.15 m does not
    (0.025, 0.05, (2, 4)),     # 4h = 0.1 m = 2·gh: the held wall is still the grousers'
    (0.075, 0.05, ()),         # the default mesh: 2h = 0.15 m would not
    (0.075, 0.075, (2,)),
    (0.15, 0.0, (2, 4)),       # no grousers: no bound
])
def test_the_mesh_error_uses_only_meshes_that_measure_the_trapped_soil(compose_cfg, cell_m, grouser_m, factors):
    """cel3d's trapped soil holds a wall of the grouser height gh only on cells up to 2·gh
    (dsmv.cel.contact.trapped_shares): the coarser meshes of the mesh error stop there."""
    from dsmv.cel.solver3d import Cel3DSolver
    from dsmv.config.scene import build_scene

    solver = Cel3DSolver(build_scene(compose_cfg(["solver=cel3d", f"mesh.cell_size_m={cell_m}",
                                                  f"geometry.grouser_height_m={grouser_m}"])))
    assert solver.coarsening_factors() == factors
    for factor in factors:  # each coarser mesh: cells of at most 2·gh (with grousers)
        coarse = solver.coarser(factor).scene.mesh.cell_size_m
        assert coarse == pytest.approx(factor * cell_m) and (grouser_m == 0 or coarse <= 2 * grouser_m + 1e-12)


def test_a_track_on_cells_too_coarse_for_its_trapped_soil_says_why_it_has_no_mesh_error(compose_cfg):
    """The default 3D track on cells wider than its 0.05 m grousers (0.15 m here; its default 0.075 m alike):
    2h would not measure their soil, so no coarser run is made, no error reported, and the message says
    why and which cells give one."""
    from dsmv.cel.solver3d import Cel3DSolver
    from dsmv.config.scene import build_scene

    result = Cel3DSolver(build_scene(compose_cfg(["solver=cel3d", "solver.progress=off", "mesh.cell_size_m=0.15",
                                                  "solver.error_estimate=true"]))).solve()
    assert result.status == "ok" and "max_sinkage_error_m" not in result.metrics
    assert "no mesh error: cells of 2h would be wider than twice the grousers' 0.05 m" in result.message
    assert "core cells of at most 0.05 m give one" in result.message


def test_every_answer_can_carry_its_mesh_error(compose_cfg):
    """solver.error_estimate=true: the default landing on h, 2h and 4h, its extrapolated sinkage and
    error (the interval holds the fine answer's distance to the limit by construction), and the same
    for a push's bearing factors."""
    from dsmv.cel.solver2d import Cel2DSolver
    from dsmv.config.scene import build_scene

    landing = Cel2DSolver(build_scene(compose_cfg(["solver=cel2d", "solver.progress=off",
                                                   "solver.error_estimate=true"]))).solve()
    m = landing.metrics
    assert landing.status == "ok"
    assert m["max_sinkage_error_m"] == pytest.approx(abs(m["max_sinkage_extrapolated_m"] - m["max_sinkage_m"]),
                                                     rel=1e-12) or m["max_sinkage_order"] == 1.0
    assert m["max_sinkage_error_m"] > 0.0 and landing.units["max_sinkage_error_m"] == "m"
    push = Cel2DSolver(build_scene(compose_cfg(["experiment=verify_prandtl", "hydra.mode=RUN", "solver.progress=off",
                                                "mesh.cell_size_m=0.1", "landing.displacement_m=0.06",
                                                "solver.error_estimate=true"]))).solve()
    assert push.status == "ok" and {"nc_at_0p05B_extrapolated", "nc_at_0p05B_error", "nc_at_0p05B_order"} <= set(
        push.metrics)
