"""The CEL core against independent truths, on coarse meshes (fine meshes: -m slow).

Truths: conservation (soil mass, to round-off), the exact translate (advection), rest under
gravity (geostatic), Prandtl's 2 + π for a strip on weightless Tresca soil (small strain),
and, at large deformation, the capacity of the same strip wished in place at the depth it
has reached: a check that the Eulerian remap adds no error of its own.
"""

import inspect

import numpy as np
import pytest

from dsmv.verify import canonical
from dsmv.analytic.bearing import (NOTCHED_STRIP_LOWER_BOUND_AT_0P05B, NOTCHED_STRIP_UPPER_BOUND_AT_0P05B, PRANDTL_NC,
                                   TBAR_NC, embedded_strip_upper_bound)
from dsmv.cel.checks2d import Cel2DCheckSolver
from dsmv.cel.solver2d import Cel2DSolver
from dsmv.config.scene import build_scene

PRANDTL = PRANDTL_NC
#: Prandtl's strip with the soil tied to its walls (dsmv.verify.canonical), on B/25 cells unless a test says
STRIP = [*canonical.PRANDTL_BONDED, "mesh.cell_size_m=0.04", "solver.progress=off"]


def solve(compose_cfg, solver_cls, overrides):
    return solver_cls(build_scene(compose_cfg(overrides))).solve()


def nc_at(result, s_m, width_m=1.0, su_pa=1e4, area_m2=1.0):
    """Bearing factor q/su at the history sample nearest to sinkage s (m)."""
    h = result.history
    return h["force_n"][np.argmin(np.abs(h["sinkage_m"] - s_m))] / (area_m2 * su_pa)


def test_advection_conserves_bounds_and_converges(compose_cfg):
    r = solve(compose_cfg, Cel2DCheckSolver, ["solver=cel2d_check", "solver.case=advection", "mesh.cell_size_m=0.05"])
    m = r.metrics
    assert m["mass_error"] < 1e-10
    assert m["phi_min"] >= 0.0 and m["phi_max"] <= 1.0 + 1e-12
    assert m["shape_error_fine"] < m["shape_error"] / 3  # the sharp square converges (order > 1.5 seen)
    assert m["shape_order"] > 1.0
    assert m["smooth_order"] > 1.6  # MUSCL on a smooth field: second order


def test_first_order_advection_is_first_order(compose_cfg):
    r = solve(compose_cfg, Cel2DCheckSolver,
              ["solver=cel2d_check", "solver.case=advection", "mesh.cell_size_m=0.05", "solver.advection_order=1"])
    assert 0.6 < r.metrics["smooth_order"] < 1.2


def test_geostatic_soil_stays_at_rest(compose_cfg):
    r = solve(compose_cfg, Cel2DCheckSolver, ["solver=cel2d_check", "solver.case=geostatic", "mesh=coarse"])
    assert r.metrics["max_speed_m_s"] < 1e-4
    assert r.metrics["mass_error"] < 1e-10


@pytest.fixture(scope="module")
def small_strain_prandtl():
    """Small-strain Prandtl pushes at B/10 and B/20 (geometry fixed: the exact limit is 2 + π)."""
    from hydra import compose, initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra

    from dsmv.config.tree import CONFIG_DIR

    out = {}
    for h in (0.1, 0.05):
        GlobalHydra.instance().clear()
        with initialize_config_dir(config_dir=CONFIG_DIR, version_base="1.3"):
            cfg = compose("config", overrides=STRIP + ["solver.remap=false", "landing.displacement_m=0.06",
                                                       f"mesh.cell_size_m={h}", "solver.initial_travel_m=0.1"])
        out[h] = Cel2DSolver(build_scene(cfg)).solve()
    GlobalHydra.instance().clear()
    return out


def test_small_strain_prandtl_converges_to_two_plus_pi(small_strain_prandtl):
    errors = {h: r.metrics["nc_at_0p05B"] / PRANDTL - 1 for h, r in small_strain_prandtl.items()}
    # from below and shrinking: -0.76 %, -0.58 %, -0.47 % at B/10, B/20, B/40 (the hourglass force everywhere
    # read +0.9 %, +0.4 %, +0.1 %: decision 0016)
    assert abs(errors[0.05]) < abs(errors[0.1])
    assert abs(errors[0.05]) < 0.01
    for r in small_strain_prandtl.values():
        assert r.status == "ok" and r.metrics["mass_error"] == 0.0


def test_embedment_raises_the_capacity_by_about_the_upper_bound(compose_cfg, small_strain_prandtl):
    """A rough strip wished in place 0.05 B deep (one cell at B/20) carries more than on the
    surface. The rise is bounded by 2 + π ≤ N ≤ 2 + π + (16/3)·d/B (dsmv.analytic.bearing): at most
    +0.267. Small strain gives +0.274, +0.277, +0.264, +0.258 at B/20 to B/160, falling under the
    bound as the cells shrink; one-point quadrature is stiff by O(h) (+3 % at B/20 on the flat
    surface), hence the 5 % allowance at B/20."""
    depth_over_width = 0.05
    placed = solve(compose_cfg, Cel2DSolver, STRIP + ["solver.remap=false", "landing.displacement_m=0.06",
                                                      f"landing.initial_depth_m={depth_over_width}",
                                                      "mesh.cell_size_m=0.05", "solver.initial_travel_m=0.1"])
    rise = placed.metrics["nc_at_0p05B"] - small_strain_prandtl[0.05].metrics["nc_at_0p05B"]
    bound = embedded_strip_upper_bound(depth_over_width, rough_walls=True) - PRANDTL
    assert 0.8 * bound < rise < 1.05 * bound


# Limit analysis of the rough strip wished in place at depth D, soil bonded to base and walls
# (`python -m dsmv.analytic.limit_analysis --depth D --roughness rough --bonded`, default mesh):
# rigorous lower and upper bounds on q/su
BONDED_ROUGH_STRIP_BRACKET = {0.1: (5.5321, 5.6598), 0.2: (5.6608, 6.0870)}


@pytest.mark.parametrize("depth_m", [0.1, 0.2])
def test_large_deformation_carries_the_strip_wished_in_place_at_that_depth(compose_cfg, depth_m):
    """A strip pushed to s = D carries at least what the same strip wished in place at depth D
    carries once it has yielded, and little more: the heave only adds soil, which in weightless
    soil can carry zero stress (B/10: +0.9 % at 0.1 B, +2.1 % at 0.2 B). The one wished in place,
    without any remap, lies in limit analysis's bracket for it (1 % allowed for B/10)."""
    pushed = solve(compose_cfg, Cel2DSolver, STRIP + ["landing.displacement_m=" + str(depth_m + 0.005),
                                                      "mesh.cell_size_m=0.1"])
    assert pushed.status == "ok" and pushed.metrics["mass_error"] < 1e-10
    placed = solve(compose_cfg, Cel2DSolver, STRIP + ["solver.remap=false", f"landing.initial_depth_m={depth_m}",
                                                      "landing.displacement_m=0.05", "solver.initial_travel_m=0.1",
                                                      "mesh.cell_size_m=0.1"])
    nc_pushed = nc_at(pushed, depth_m)
    nc_placed = nc_at(placed, 0.04)  # fully yielded, geometry still that of depth D
    lower, upper = BONDED_ROUGH_STRIP_BRACKET[depth_m]
    assert 0.99 * lower < nc_placed < 1.01 * upper
    assert nc_placed < nc_pushed < 1.04 * nc_placed
    assert nc_pushed > PRANDTL  # embedment raises the capacity (lower bound 2 + π, dsmv.analytic.bearing)


def test_push_speed_does_not_change_the_result(compose_cfg):
    runs = [solve(compose_cfg, Cel2DSolver, STRIP + [f"landing.velocity_m_s={v}", "landing.displacement_m=0.06",
                                                     "mesh.cell_size_m=0.1"]) for v in (0.05, 0.1)]
    assert runs[0].metrics["nc_at_0p05B"] == pytest.approx(runs[1].metrics["nc_at_0p05B"], rel=0.01)


def test_default_landing_comes_to_rest_with_mass_conserved(compose_cfg):
    r = solve(compose_cfg, Cel2DSolver, ["solver=cel2d", "mesh=coarse", "solver.progress=off"])
    assert r.status == "ok", r.message
    assert r.metrics["mass_error"] < 1e-10
    assert 0.0 <= r.metrics["phi_min"] and r.metrics["phi_max"] < 1.01
    assert r.metrics["max_sinkage_m"] > 0.0
    assert r.history["velocity_m_s"][-1] <= 0.0 < r.history["velocity_m_s"][0]
    assert r.metrics["energy_hourglass_j"] == 0.0  # a flat track cuts no cell: no hourglass force (decision 0016)


@pytest.mark.parametrize("region,must_matter", [
    ("cut_cells", {"energy_plastic_j", "energy_elastic_change_j"}),  # a flat track: no hourglass force
    ("everywhere", {"energy_plastic_j", "energy_elastic_change_j", "energy_hourglass_j"}),
])
def test_energy_audit_closes_and_fails_when_a_term_is_dropped(compose_cfg, region, must_matter):
    r = solve(compose_cfg, Cel2DSolver, ["solver=cel2d", "mesh=coarse", "solver.progress=off",
                                         f"solver.hourglass_region={region}"])
    m = r.metrics
    assert m["energy_error"] < 0.02
    inputs = {k: v for k, v in m.items() if k.startswith("energy_in_")}
    outputs = {k: v for k, v in m.items() if k.startswith("energy_") and k not in inputs and k != "energy_error"}
    delivered = sum(abs(v) for v in inputs.values())
    # the balance recomputed from the reported terms is the reported error
    assert abs(sum(inputs.values()) - sum(outputs.values())) / delivered == pytest.approx(m["energy_error"], abs=1e-9)
    big = [k for k, v in outputs.items() if abs(v) > 0.03 * delivered]
    assert must_matter <= set(big)
    for dropped in big:  # leaving out any term that matters breaks the 2 % bound
        rest = sum(v for k, v in outputs.items() if k != dropped)
        assert abs(sum(inputs.values()) - rest) / delivered > 0.02, dropped


#: the canonical T-bar (dsmv.verify.canonical) on D/10 cells, pushed 0.4 D
TBAR = [*canonical.TBAR, "landing.displacement_m=0.2", "mesh.cell_size_m=0.05", "solver.progress=off"]


def test_rough_tbar_approaches_the_exact_deep_factor(compose_cfg):
    """A rough cylinder 3 D deep in weightless Tresca soil: 11.94 (Randolph & Houlsby 1984).
    D/10 and a 0.4 D push keep it quick (experiment verify_tbar runs 2 D at D/20)."""
    r = solve(compose_cfg, Cel2DSolver, [*TBAR, "geometry.roughness=rough"])
    assert r.status == "ok" and r.metrics["mass_error"] < 1e-10
    assert r.metrics["nc_deep"] == pytest.approx(TBAR_NC["rough"], rel=0.06)


def test_smooth_tbar_holds_steady_just_below_the_exact_factor(compose_cfg):
    """A smooth cylinder: 9.20 (Martin & Randolph 2006). Cut cells carry the circle, slivers
    merged with a neighbour. Pushed, it holds what small strain gives on the same mesh (8.51 at
    D/10), from below: 8.55 (−7.1 %) at D/10, 8.75 (−4.9 %) at D/20. Before the merging the
    rear slivers drained and the factor fell to 6.85 within 0.03 m; the last 0.1 m must stay
    within 1 %."""
    r = solve(compose_cfg, Cel2DSolver, [*TBAR, "geometry.roughness=smooth"])
    assert r.status == "ok" and r.metrics["mass_error"] < 1e-10 and r.metrics["energy_error"] < 0.02
    s, nc = r.history["sinkage_m"], r.history["force_n"] / (1e4 * 0.5 * 1.0)
    late = nc[s > s[-1] - 0.1]
    assert late.max() - late.min() < 0.01 * late.mean(), (late.min(), late.max())
    assert 0.92 * TBAR_NC["smooth"] < late.mean() < TBAR_NC["smooth"], late.mean()


def test_tbar_adhesion_lies_between_smooth_and_rough(compose_cfg):
    """α = 0.5 in the interface layer: the deep factor lies between the smooth and rough ones
    (the exact factors rise monotonically with α: Martin & Randolph 2006)."""
    nc = {a: solve(compose_cfg, Cel2DSolver, [*TBAR, f"geometry.roughness={a}", "landing.displacement_m=0.1"])
          .metrics["nc_deep"] for a in ("smooth", 0.5, "rough")}
    assert nc["smooth"] + 0.5 < nc[0.5] < nc["rough"] - 0.5, nc


@pytest.mark.parametrize("roughness,exact", [("rough", 6.05), ("smooth", 5.69)])
def test_circular_plate_converges_to_the_exact_factor(compose_cfg, roughness, exact):
    """Axisymmetric check: a rigid circular plate on weightless Tresca soil (small strain). Exact: Nc
    = 6.05 rough (Eason & Shield 1960, J. Appl. Math. Phys. 11), 5.69 smooth (Cox, Eason & Hopkins
    1961). Measured: rough +0.8 %, +0.2 % at B/10, B/20; smooth +3.1 %, +1.6 % (with the hourglass
    force in every cell, before decision 0016: rough +3.1 %, +1.6 %, smooth +7.3 %, +4.8 %; a J2
    return would converge 9 % below: Tresca matters here)."""
    errors = {}
    for h in (0.1, 0.05):
        r = solve(compose_cfg, Cel2DSolver, STRIP + ["solver.mode=axisymmetric", "solver.remap=false",
                                                     f"geometry.roughness={roughness}",
                                                     "landing.displacement_m=0.11", "solver.initial_travel_m=0.15",
                                                     f"mesh.cell_size_m={h}"])
        assert r.status == "ok" and r.metrics["mass_error"] == 0.0
        errors[h] = r.metrics["nc_at_0p1B"] / exact - 1
    assert 0 < errors[0.05] < 0.6 * errors[0.1]  # from above, at first order or better
    assert errors[0.05] < 0.02


@pytest.mark.parametrize(
    "overrides,status,says",
    [
        (["solver.cfl=1.0"], "unstable", "solver.cfl"),  # beyond the 2D stability limit (≈ 1/√2)
        # no hourglass control, no bulk viscosity, at the limit, medium cells: the soil outruns a cell
        # at step 302, a step after its kinetic energy passed ten times the energy put in (a scan, which
        # looks every SCAN_STEPS steps); on the coarse mesh this one stays just stable since the corner twin
        (["solver.cfl=1.0", "solver.hourglass=0", "solver.bulk_viscosity_linear=0",
          "solver.bulk_viscosity_quadratic=0", "mesh.cell_size_m=0.04"], "unstable", "solver.cfl"),
        (["solver.initial_travel_m=0.03"], "out_of_domain", "travel the domain was sized for"),
        # 500 Pa: even with embedment and side shear the soil cannot stop the track
        (["soil.su0_pa=500", "soil.ks_pa_per_m=0"], "bearing_failure", "without slowing down"),
    ],
)
def test_landings_end_with_the_right_status_and_no_nan(compose_cfg, overrides, status, says):
    r = solve(compose_cfg, Cel2DSolver, ["solver=cel2d", "mesh=coarse", "solver.progress=off", *overrides])
    assert r.status == status, r.message
    assert says in r.message
    assert all(np.isfinite(v) for v in r.metrics.values())
    assert r.metrics["mass_error"] < 1e-10


def test_a_non_finite_value_ends_unstable_with_finite_outputs(compose_cfg, monkeypatch):
    """The stepper's NaN guard: status unstable, a message that says what to change, no NaN out."""
    from dsmv.cel import stepper, stepper2d

    real = stepper2d.run_steps
    calls = {"n": 0}

    def poisoned(n_steps, *args):
        done, code = real(n_steps, *args)
        calls["n"] += 1
        if calls["n"] == 3:
            args[3].v[0, 0] = np.inf  # nodes: a velocity blows up
            return done, stepper.NOT_FINITE
        return done, code

    monkeypatch.setattr(stepper2d, "run_steps", poisoned)
    r = solve(compose_cfg, Cel2DSolver, ["solver=cel2d", "mesh=coarse", "solver.progress=off"])
    assert r.status == "unstable" and "solver.cfl" in r.message
    assert all(np.isfinite(v) for v in r.metrics.values())
    assert all(np.isfinite(col).all() for col in r.history.values())


def test_nodal_masses_stay_those_of_the_cells(compose_cfg, monkeypatch):
    """The stepper computes nodal masses only after a remap, the one place φ changes: after
    every chunk of steps they must equal a fresh computation from the cells (a kernel that
    changed φ mid-step would leave them stale). The split corner nodes' shares count too."""
    from dsmv.cel import stepper2d
    from dsmv.cel.kernels.nodes import nodal_mass

    real = stepper2d.run_steps
    worst = []

    signature = inspect.signature(real.py_func)

    def checked(n_steps, *args):
        out = real(n_steps, *args)
        named = signature.bind(n_steps, *args).arguments
        mesh, cells, nodes, par = (named[k] for k in ("mesh", "cells", "nodes", "par"))
        assert len(nodes.mass) > mesh.n_grid  # the track's corners are split
        fresh = np.zeros_like(nodes.mass)
        nodal_mass(mesh, cells, par.density, fresh)
        worst.append(np.abs(nodes.mass - fresh).max() / fresh.max())
        return out

    monkeypatch.setattr(stepper2d, "run_steps", checked)
    r = solve(compose_cfg, Cel2DSolver, ["solver=cel2d", "mesh=coarse", "solver.progress=off"])
    assert r.status == "ok" and len(worst) > 10
    assert max(worst) == 0.0


def test_a_body_at_rest_without_weight_stays_put(compose_cfg):
    r = solve(compose_cfg, Cel2DSolver, ["solver=cel2d", "mesh=coarse", "solver.progress=off",
                                         "landing.velocity_m_s=0", "landing.gravity_m_s2=0"])
    assert r.status == "ok" and r.metrics["max_sinkage_m"] == 0.0


def test_hourglass_diagnostic_separates_the_zigzag_from_smooth_motion():
    """A linear velocity field (any rigid motion, any uniform strain rate) has no hourglass
    mode; a pure checkerboard of nodal velocities is all hourglass. Values by hand: the mode
    amplitudes are a quarter of the signed sums of the four nodal velocities."""
    from dsmv.cel.kernels.elements2d import hourglass_modes as modes
    from dsmv.cel.layout import Mesh2D, structured_corners

    n = 6
    xs, ys = np.meshgrid(np.linspace(0.0, 1.0, n + 1), np.linspace(0.0, 1.0, n + 1), indexing="ij")
    phi = np.ones((n, n))
    h = 1.0 / n
    mesh = Mesh2D(xs[:, 0], ys[0], np.full((n, n), h * h), structured_corners((n, n)), (n + 1) ** 2,
                np.zeros((n, n), dtype=bool))

    def hourglass_modes(phi, vx, vy, full):
        return modes(mesh.corner, phi, np.stack([vx.ravel(), vy.ravel()]), full)

    # rigid rotation plus a uniform strain rate: a (1/s) and b (1/s)
    vx, vy = -0.3 * ys + 0.2 * xs + 1.0, 0.3 * xs - 0.1 * ys
    hourglass_sq, linear_sq = hourglass_modes(phi, vx, vy, 0.99)
    assert hourglass_sq == pytest.approx(0.0, abs=1e-28)
    # per cell: b_ξ = (h/2)·(0.2, 0.3), b_η = (h/2)·(−0.3, −0.1)
    assert linear_sq == pytest.approx(n * n * (h / 2) ** 2 * (0.04 + 0.09 + 0.09 + 0.01), rel=1e-12)
    zigzag = np.where((np.arange(n + 1)[:, None] + np.arange(n + 1)[None, :]) % 2 == 0, 1.0, -1.0)
    hourglass_sq, linear_sq = hourglass_modes(phi, 0.5 * zigzag, 0 * zigzag, 0.99)
    assert (hourglass_sq, linear_sq) == (pytest.approx(n * n * 0.25), pytest.approx(0.0, abs=1e-28))
    phi[:, 3:] = 0.5  # partly filled cells do not count
    assert hourglass_modes(phi, 0.5 * zigzag, 0 * zigzag, 0.99)[0] == pytest.approx(n * 3 * 0.25)


def test_hourglass_control_damps_the_zigzag_the_diagnostic_measures(compose_cfg):
    """The viscous hourglass force acts on exactly the mode hourglass_mode_ratio measures: a
    tenth of the coefficient lets more of it through (default landing, medium mesh: 0.33 at
    0.05 and 0.52 at 0.005). The sinkage moves by the hourglass work the coefficient takes out:
    +9.8 % on this coarse mesh, +5.4 % on the medium one (the README's hourglass study; most of
    the zig-zag sits in the cells at the track's corner, which the corner twin sets free: before
    it, +6.0 % and +3.1 %). The force acts in every cell here (``solver.hourglass_region=everywhere``):
    by default a flat track has none (decision 0016)."""
    runs = {hg: solve(compose_cfg, Cel2DSolver, ["solver=cel2d", "mesh=coarse", "solver.progress=off",
                                                 "solver.hourglass_region=everywhere", f"solver.hourglass={hg}"])
            for hg in (0.05, 0.005)}
    ratio = {hg: r.metrics["hourglass_mode_ratio"] for hg, r in runs.items()}
    assert all(r.status == "ok" for r in runs.values())
    assert 0.0 < ratio[0.05] < ratio[0.005] < 1.0, ratio
    sinkage = {hg: r.metrics["max_sinkage_m"] for hg, r in runs.items()}
    assert sinkage[0.05] < sinkage[0.005] < 1.15 * sinkage[0.05], sinkage


@pytest.mark.parametrize("roughness", ["smooth", "rough"])
def test_contact_separation_lets_the_soil_part_from_the_wall(compose_cfg, roughness):
    """A strip pushed 0.06 B into weightless soil, B/40. With solver.contact_separation the ties let
    go where the soil pulls away, and the strip opens a notch beside its wall: limit analysis
    brackets that strip's factor in [5.207, 5.270] (rough) and [5.206, 5.264] (smooth), flat surface
    beyond the notch, against at least 5.357 and 5.296 with the soil against the walls (README, "The
    pushed strip opens a wedge-shaped gap"). The factor must drop well below the tied one's and read
    inside the notched bracket (measured at B/40: rough 5.227, smooth 5.228), with the energy audit
    still closed and the mass kept."""
    push = STRIP + [f"geometry.roughness={roughness}", "mesh.cell_size_m=0.025", "landing.displacement_m=0.06"]
    tied = solve(compose_cfg, Cel2DSolver, push)
    parted = solve(compose_cfg, Cel2DSolver, push + ["solver.contact_separation=true"])
    lower, upper = NOTCHED_STRIP_LOWER_BOUND_AT_0P05B[roughness], NOTCHED_STRIP_UPPER_BOUND_AT_0P05B[roughness]
    assert parted.metrics["nc_at_0p05B"] < tied.metrics["nc_at_0p05B"] - 0.08
    assert lower < parted.metrics["nc_at_0p05B"] < upper
    # the gap cells' released elastic energy is a term of its own: nil without separation
    assert tied.metrics["energy_gap_release_j"] == 0.0 < parted.metrics["energy_gap_release_j"]
    assert parted.metrics["energy_error"] < 0.01
    assert parted.metrics["mass_error"] < 1e-10


def test_slicing_chunks_for_interrupts_changes_no_bit(compose_cfg, monkeypatch):
    """The controller steps each history chunk in slices of about POLL_S of wall time, to look at
    the interrupt flag between them; a slice of a few steps and one slice per chunk give the same
    result to the last bit (the compiled loop keeps its whole state in the containers)."""
    from dsmv.cel import controller

    scene = ["solver=cel2d", "mesh=coarse", "solver.progress=off", "soil.law=einav_randolph"]
    runs = []
    for poll_s in (1e-5, 1e9):
        monkeypatch.setattr(controller, "POLL_S", poll_s)
        runs.append(solve(compose_cfg, Cel2DSolver, scene))
    timing = {"wall_s", "compile_s", "cell_updates_per_s", "estimated_wall_s"}
    assert {k: v for k, v in runs[0].metrics.items() if k not in timing} == {
        k: v for k, v in runs[1].metrics.items() if k not in timing}
    for name, column in runs[0].history.items():
        assert (column == runs[1].history[name]).all(), name



def test_a_signal_a_sweep_job_caught_while_setting_up_ends_its_run_at_once(compose_cfg, tmp_path):
    """A sweep's job that takes SIGTERM after its last check and before the controller steps (building
    the grid, loading the kernels) ends its run 'interrupted' in the first chunk, not minutes later."""
    import os
    import signal

    from dsmv.app import interrupts

    with interrupts.sweep_job_signals(tmp_path) as caught:
        os.kill(os.getpid(), signal.SIGTERM)
        assert caught["signal"] == signal.SIGTERM
        result = solve(compose_cfg, Cel2DSolver, ["solver=cel2d", "mesh=coarse", "solver.progress=off"])
    assert result.status == "interrupted" and result.message.startswith("interrupted by SIGTERM at t = ")
    assert result.history["sinkage_m"].max() < 0.01  # the default landing comes to rest at 0.065 m

def test_strength_growing_with_depth_converges_into_the_limit_analysis_bracket(compose_cfg):
    """Davis & Booker's smooth strip, k·B/su0 = 4 (q/su0 = 7.80), small strain at 0.02 B: B/20 and
    B/40 read 8.659 and 8.263 (+11 %, +6 %: first order with a large constant, the shallow mechanism
    of a strong gradient is poorly resolved), and their first-order extrapolation, 7.866, lies in
    limit analysis's rigorous bracket [7.7254, 7.8915] and within 1.5 % of Davis & Booker."""
    from dsmv.analytic.bearing import DAVIS_BOOKER_NC, GRADIENT_STRIP_BRACKET

    nc = {h: solve(compose_cfg, Cel2DSolver, [*canonical.PRANDTL, "soil.ks_pa_per_m=40000", "soil.youngs_modulus_pa=1e7",
                                               "geometry.roughness=smooth", "solver.remap=false",
                                               "landing.displacement_m=0.04", "solver.initial_travel_m=0.1",
                                               "solver.progress=off", f"mesh.cell_size_m={h}"]).metrics["nc_at_0p02B"]
          for h in (0.05, 0.025)}
    extrapolated = 2 * nc[0.025] - nc[0.05]
    lower, upper = GRADIENT_STRIP_BRACKET["smooth", 4]
    assert nc[0.05] > nc[0.025] > upper  # from above
    assert lower <= extrapolated <= upper, nc
    assert extrapolated == pytest.approx(DAVIS_BOOKER_NC["smooth", 4], rel=0.015)


def test_the_pushed_plates_rise_is_its_embedment(compose_cfg):
    """A rough circular plate pushed 0.05 B with the remap reads 11 % above its small-strain value at
    the same travel; the same plate wished in place 0.05 B deep and loaded over the same travel in
    small strain reads within 2 % of it (measured 6.739 and 6.708 at B/20, 0.2 % apart at B/40):
    the rise is embedment, not remap error."""
    plate = [*canonical.PRANDTL_BONDED, "solver.mode=axisymmetric", "solver.progress=off", "mesh.cell_size_m=0.05"]
    pushed = solve(compose_cfg, Cel2DSolver, [*plate, "landing.displacement_m=0.06"])
    placed = solve(compose_cfg, Cel2DSolver, [*plate, "solver.remap=false", "landing.initial_depth_m=0.05",
                                               "landing.displacement_m=0.05", "solver.initial_travel_m=0.1"])
    surface = solve(compose_cfg, Cel2DSolver, [*plate, "solver.remap=false", "landing.displacement_m=0.06",
                                                "solver.initial_travel_m=0.1"])
    assert pushed.metrics["nc_at_0p05B"] > 1.08 * surface.metrics["nc_at_0p05B"]  # the rise to explain
    assert pushed.metrics["nc_at_0p05B"] == pytest.approx(placed.metrics["nc_at_0p05B"], rel=0.02)
