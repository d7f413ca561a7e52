"""Strength profiles as data (``soil.profile``): a table of su against depth, inline or from a CSV file.

Truths: a tabulated straight line is the straight line su0 + ks·z, to the bit, in both CEL solvers and
the analytic models; a landing in a profile sinks no deeper than in a weaker soil everywhere and no
shallower than in a stronger one; a table is read as written (units, jumps) and a bad one is refused
in one line.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from dsmv import registry
from dsmv.config.profile import read_points, segments
from dsmv.config.scene import build_scene
from dsmv.errors import ConfigError
from dsmv.verify import canonical

#: Davis & Booker's smooth strip (k·B/su0 = 4) in small strain on B/10 cells, a short push
DAVIS_BOOKER = [*canonical.PRANDTL_BONDED, "solver.remap=false", "solver.progress=off", "geometry.roughness=smooth",
                "mesh.cell_size_m=0.1", "landing.displacement_m=0.03", "solver.initial_travel_m=0.1",
                "soil.youngs_modulus_pa=1e7"]
#: the same straight line, su = 10 kPa + 40 kPa/m·z, as a table reaching below every model's depth
LINE = "soil.ks_pa_per_m=40000"
TABLE = "soil.profile=[[0,10000],[100,4010000]]"


def solve(compose_cfg, overrides):
    scene = build_scene(compose_cfg(overrides))
    result = registry.load("solvers", scene.solver.name, "solver.name")(scene).solve()
    assert result.status == "ok", result.message
    return result


@pytest.mark.parametrize("solver", ["cel2d", "cel3d"])
def test_a_tabulated_straight_line_is_the_line_to_the_bit_in_the_cel(compose_cfg, solver):
    """Davis & Booker's strip through the table: the same numbers as through su0 + ks·z (the table's
    slope is exactly ks, so each segment's intercept + slope·z0 is su0 + ks·z0). The identity holds on any
    mesh: cel3d's slab runs on B/5 cells."""
    mesh = ["mesh.cell_size_m=0.2"] if solver == "cel3d" else []
    line = solve(compose_cfg, [*DAVIS_BOOKER, f"solver={solver}", LINE, *mesh])
    table = solve(compose_cfg, [*DAVIS_BOOKER, f"solver={solver}", "soil.ks_pa_per_m=0", TABLE, *mesh])
    assert table.metrics["nc_at_0p02B"] == line.metrics["nc_at_0p02B"]
    assert np.array_equal(table.history["force_n"], line.history["force_n"])


@pytest.mark.parametrize("solver", ["analytic_energy", "analytic_dynamic"])
def test_a_tabulated_straight_line_is_the_line_to_the_bit_in_the_analytic_models(compose_cfg, solver):
    base = [f"solver={solver}", "tracking=disabled"]
    line = solve(compose_cfg, [*base, "soil.su0_pa=5000", "soil.ks_pa_per_m=1500"])
    table = solve(compose_cfg, [*base, "soil.profile=[[0,5000],[10,20000]]"])
    assert table.metrics["max_sinkage_m"] == line.metrics["max_sinkage_m"]


def test_a_landing_in_a_bent_profile_sinks_between_the_lines_that_bound_it(compose_cfg):
    """The box-core profile (soil=ccz_box_core) rises steeply, then flattens: under the line of its first
    gradient and over the line to its last point, down to 0.45 m. The track's section lands deeper than
    in the first and shallower than in the second."""
    base = ["solver=cel2d", "mesh=coarse", "solver.progress=off", "soil=ccz_box_core", "landing.mass_kg=9000"]
    bent = solve(compose_cfg, base).metrics["max_sinkage_m"]
    stronger = solve(compose_cfg, [*base, "soil.profile=null", "soil.su0_pa=3447", "soil.ks_pa_per_m=30175.44"])
    weaker = solve(compose_cfg, [*base, "soil.profile=null", "soil.su0_pa=3447",
                                 f"soil.ks_pa_per_m={(9653 - 3447) / 0.45}"])
    assert stronger.metrics["max_sinkage_m"] < bent < weaker.metrics["max_sinkage_m"] < 0.45


def test_a_table_is_read_as_written(tmp_path):
    """Units from the CSV header, a repeated depth as a jump, constant below the last point, the first
    segment's line above the first."""
    path = tmp_path / "vane.csv"
    path.write_text("# a box core's vane\ndepth_cm,su_kpa\n0,3.4\n10,6.9\n10,8.0\n40,9.6\n")
    points = read_points(str(path))
    assert points.tolist() == [[0.0, 3400.0], [0.1, 6900.0], [0.1, 8000.0], [0.4, 9600.0]]
    strength = segments(points)
    assert strength.su([0.05, 0.0999999, 0.1, 0.25, 0.4, 3.0]) == pytest.approx(
        [5150.0, 6900.0 - 3.5e-3, 8000.0, 8800.0, 9600.0, 9600.0], rel=1e-9)
    assert strength.su(-0.02) == pytest.approx(3400.0 - 0.02 * 35000.0)
    assert not strength.straight and segments(np.array([[0.0, 5.0], [1.0, 6.0], [3.0, 8.0]])).straight


@pytest.mark.parametrize("table, words", [
    ([[0, 5000], [0.2, 7000], [0.1, 6000]], "must not decrease"),
    ([[0, 5000], [0.2, -10]], "must be > 0"),
    ([[-0.1, 5000]], "≥ 0"),
    ("no_such_profile.csv", "no such file"),
])
def test_a_bad_table_is_refused_in_one_line(table, words):
    with pytest.raises(ConfigError, match=words) as refused:
        read_points(table)
    assert refused.value.path == "soil.profile"


def test_a_csv_without_the_columns_names_them(tmp_path):
    path = tmp_path / "cpt.csv"
    path.write_text("depth_ft,qc_mpa\n0,0.1\n")
    with pytest.raises(ConfigError, match=r"depth_m \| depth_cm \| depth_mm.*su_pa \| su_kpa"):
        read_points(str(path))


@pytest.mark.parametrize("law, measured", [("einav_randolph", 0.062), ("tresca", 0.019)])
def test_the_fast_model_lands_in_a_bent_profile_as_the_2d_cel_does(compose_cfg, law, measured):
    """The box-core profile (su rising from 3.4 to 6.9 kPa in the top 0.11 m, slowly below): the fast
    model's sinkage, its gradient factor read from the segment under the base, is the 2D CEL's to
    within what it is on the straight default soil (measured ``measured`` deeper; the default landing
    +6.6 %)."""
    from dsmv.analytic.dynamic import AnalyticDynamicSolver
    from dsmv.cel.solver2d import Cel2DSolver

    case = ["soil=ccz_box_core", f"soil.law={law}", "tracking=disabled"]
    fast = AnalyticDynamicSolver(build_scene(compose_cfg([*case, "solver=analytic_dynamic"]))).solve()
    cel = Cel2DSolver(build_scene(compose_cfg([*case, "solver=cel2d", "solver.progress=off"]))).solve()
    assert fast.status == cel.status == "ok"
    ratio = fast.metrics["max_sinkage_m"] / cel.metrics["max_sinkage_m"]
    assert ratio - 1.0 == pytest.approx(measured, abs=0.01)


def test_every_cel_solver_reads_the_profile_it_is_given():
    """The profile the kernels read is the config's table, segment for segment."""
    strength = segments(read_points([[0, 3447], [0.114, 6895], [0.45, 9653]]))
    assert strength.depth[0] == -math.inf and strength.slope[-1] == 0.0
    assert strength.su([0.0, 0.114, 0.45, 1.0]) == pytest.approx([3447, 6895, 9653, 9653])


def test_the_energy_method_lands_through_a_bent_profile_on_its_energy_balance(compose_cfg):
    """In the box-core profile the energy method's sinkage z closes ½·M·v² + W·z = Ra·∫0^z su dz (the
    integral of the piecewise-linear table, exact by the trapezoids through its points) to 1e-12, and its
    trajectory goes down monotonically to rest there."""
    from dsmv.analytic.energy import AnalyticEnergySolver

    scene = build_scene(compose_cfg(["solver=analytic_energy", "soil=ccz_box_core", "landing.mass_kg=9000",
                                     "landing.velocity_m_s=2.5", "tracking=disabled"]))
    solver = AnalyticEnergySolver(scene)
    result = solver.solve()
    z = result.metrics["max_sinkage_m"]
    assert 0.114 < z  # through the table's steep first segment
    landing, strength = scene.landing, scene.soil.strength
    depths = np.unique(np.concatenate([[0.0, z], strength.depth[1:][strength.depth[1:] < z]]))
    absorbed = solver.resistance_area_m2 * np.trapezoid(strength.su(depths), depths)
    put_in = 0.5 * landing.inertia_per_track_kg * landing.velocity_m_s**2 + landing.weight_per_track_n * z
    assert absorbed == pytest.approx(put_in, rel=1e-12)
    history = result.history
    assert np.all(np.diff(history["sinkage_m"]) >= 0) and np.all(np.diff(history["time_s"]) > 0)
    assert history["sinkage_m"][-1] == z and history["velocity_m_s"][-1] == 0.0
    assert np.all(history["velocity_m_s"] >= -1e-12)


def test_a_table_scaled_carries_a_body_as_heavy_to_the_same_depth(compose_cfg):
    """soil.profile_scale multiplies the table's strengths: in the energy method a landing s times as
    heavy (weight and inertia) on strengths s times as high stops at the same depth (the energy balance
    is linear in both), and the segments the CEL kernels read (soil.strength) are scaled. At scale 1 the scene and
    its hash are the table's own; a scale on a straight line is refused in one line."""
    from dsmv.analytic.energy import AnalyticEnergySolver
    from dsmv.config.tree import compose_scene

    base = ["solver=analytic_energy", "soil=ccz_box_core", "landing.velocity_m_s=2.5", "tracking=disabled"]
    as_measured = AnalyticEnergySolver(build_scene(compose_cfg([*base, "landing.mass_kg=9000"]))).solve()
    scaled = AnalyticEnergySolver(build_scene(compose_cfg([*base, "landing.mass_kg=11700",
                                                           "soil.profile_scale=1.3"]))).solve()
    assert scaled.metrics["max_sinkage_m"] == pytest.approx(as_measured.metrics["max_sinkage_m"], rel=1e-12)
    one = compose_scene(["soil=ccz_box_core", "soil.profile_scale=1"])
    assert one.config_hash == compose_scene(["soil=ccz_box_core"]).config_hash
    strength = compose_scene(["soil=ccz_box_core", "soil.profile_scale=1.3"]).soil.strength
    np.testing.assert_allclose(strength.intercept, 1.3 * one.soil.strength.intercept, rtol=1e-15)
    np.testing.assert_allclose(strength.slope, 1.3 * one.soil.strength.slope, rtol=1e-15)
    with pytest.raises(ConfigError, match="soil.profile_scale = 1.3: scales a table"):
        compose_scene(["soil.profile_scale=1.3"])


#: Davis & Booker's push in an Einav–Randolph soil that softens and depends on rate
SOFTENING = [*DAVIS_BOOKER, "soil.law=einav_randolph", "soil.sensitivity=3", "soil.xi95=20", "soil.rate.eta=0.1",
             "soil.ks_pa_per_m=0"]


@pytest.mark.parametrize("solver", ["cel2d", "cel3d"])
def test_a_table_that_layers_the_law_alike_is_the_unlayered_soil_to_the_bit(compose_cfg, solver):
    """The table's law columns give two layers (a row's values hold from its depth down) with the soil's own
    values: the kernels look a layer up by the depth the soil started at, and read the same numbers."""
    plain = solve(compose_cfg, [*SOFTENING, f"solver={solver}", TABLE])
    layered = solve(compose_cfg, [*SOFTENING, f"solver={solver}", "soil.profile={depth_m:[0,100],"
                                  "su_pa:[10000,4010000],sensitivity:[3,3],xi95:[20,20],rate.eta:[0.1,0.1]}"])
    assert np.array_equal(layered.history["force_n"], plain.history["force_n"])


def test_a_layer_whose_rate_factor_is_constant_is_a_stronger_layer(compose_cfg):
    """An exact similarity of the power law: with n = 1e-300, (γ̇/γ̇ref)^n is 1 to the last bit at any
    γ̇ > 0, so R = 1 + η. A soil rate-free down to 0.1 m and rate-dependent below is then the rate-free soil
    whose table is 1 + η times stronger below 0.1 m: the push through both layers meets the same force
    to round-off (the strength's arithmetic differs in order only). Its capacity lies between the
    rate-free soil's and the soil rate-dependent throughout (measured: N 8.69 < 10.26 < 10.86)."""
    eta, line = 0.25, lambda z: 10000.0 + 40000.0 * z
    rate_free = [*SOFTENING, "soil.sensitivity=1", "soil.rate.eta=0", "soil.rate.n=1e-300"]
    points = f"depth_m:[0,0.1,0.1,100],su_pa:[{line(0)},{line(0.1)},{line(0.1)},{line(100)}]"
    layered = solve(compose_cfg, [*rate_free, f"soil.profile={{{points},rate.eta:[0,0,{eta},{eta}]}}"])
    stronger = solve(compose_cfg, [*rate_free, f"soil.profile=[[0,{line(0)}],[0.1,{line(0.1)}],"
                                   f"[0.1,{(1 + eta) * line(0.1)}],[100,{(1 + eta) * line(100)}]]"])
    force, expected = layered.history["force_n"], stronger.history["force_n"]
    np.testing.assert_allclose(force, expected, rtol=1e-12, atol=1e-12 * np.abs(expected).max())
    below = solve(compose_cfg, [*rate_free, f"soil.profile={{{points}}}"]).metrics["nc_at_0p02B"]
    above = solve(compose_cfg, [*rate_free, f"soil.profile={{{points},rate.eta:[{eta},{eta},{eta},{eta}]}}"])
    assert below < layered.metrics["nc_at_0p02B"] < above.metrics["nc_at_0p02B"]


def test_a_table_that_layers_the_law_badly_is_refused_in_one_line(compose_cfg):
    with pytest.raises(ConfigError, match="the layer from 0.5 m's sensitivity 0.5.*greater than or equal to 1"):
        build_scene(compose_cfg(["soil.profile={depth_m:[0,0.5,0.5],su_pa:[3000,5000,5000],sensitivity:[3,3,0.5]}"]))
    with pytest.raises(ConfigError, match="'column sensitivty': not a soil key"):
        build_scene(compose_cfg(["soil.profile={depth_m:[0,0.5],su_pa:[3000,5000],sensitivty:[3,3]}"]))
    with pytest.raises(ConfigError, match="the energy method takes one set of the soil law's values"):
        scene = build_scene(compose_cfg(["solver=analytic_energy", "soil.profile={depth_m:[0,0.5],su_pa:[3000,5000],"
                                         "sensitivity:[3,4]}"]))
        registry.load("solvers", scene.solver.name, "solver.name")(scene)


@pytest.mark.parametrize("solver", ["analytic_dynamic", "analytic_dynamic_3d"])
def test_the_fast_model_reads_the_law_s_layer_at_the_base(compose_cfg, solver):
    """The fast model takes the law's values of the layer at the base's depth. Two layers alike land as the
    unlayered soil, to the bit; the power law's similarity (n = 1e-300: R = 1 + η for γ̇ > 0) makes a
    rate layer from 0.03 m down the rate-free table 1 + η times stronger there, to round-off (its su and
    gradient both scale, so the gradient factor is the same)."""
    base = [f"solver={solver}", "tracking=disabled", "soil.law=einav_randolph", "soil.sensitivity=3", "soil.xi95=20"]
    line = lambda z: 3000.0 + 8000.0 * z
    points = f"depth_m:[0,0.03,0.03,10],su_pa:[{line(0)},{line(0.03)},{line(0.03)},{line(10)}]"
    plain = solve(compose_cfg, [*base, f"soil.profile={{{points}}}"]).metrics["max_sinkage_m"]
    alike = solve(compose_cfg, [*base, f"soil.profile={{{points},sensitivity:[3,3,3,3]}}"]).metrics["max_sinkage_m"]
    assert alike == plain
    eta, rate_free = 0.3, [*base, "soil.rate.eta=0", "soil.rate.n=1e-300"]
    layered = solve(compose_cfg, [*rate_free, f"soil.profile={{{points},rate.eta:[0,0,{eta},{eta}]}}"])
    stronger = solve(compose_cfg, [*rate_free, f"soil.profile=[[0,{line(0)}],[0.03,{line(0.03)}],"
                                   f"[0.03,{(1 + eta) * line(0.03)}],[10,{(1 + eta) * line(10)}]]"])
    assert layered.metrics["max_sinkage_m"] == pytest.approx(stronger.metrics["max_sinkage_m"], rel=1e-12)
    assert layered.metrics["max_sinkage_m"] < 0.99 * solve(compose_cfg, [*rate_free, f"soil.profile={{{points}}}"]
                                                          ).metrics["max_sinkage_m"]


def test_a_csv_layers_the_law_by_its_columns(tmp_path):
    """A layered CSV: units for depth and strength, soil keys for the law's columns; the row's values hold
    from its depth down, a depth given twice is the boundary."""
    from dsmv.config.profile import law_layers

    path = tmp_path / "site.csv"
    path.write_text("depth_m,su_kpa,sensitivity,rate.eta\n0,3.4,3,0.1\n0.5,6.9,3,0.1\n0.5,6.9,5,0.2\n2,12,5,0.2\n")
    layers = law_layers(str(path))
    assert layers.top.tolist() == [-math.inf, 0.5, 2.0]
    assert layers.values["sensitivity"].tolist() == [3.0, 5.0, 5.0]
    assert [layers.at(z) for z in (0.0, 0.4999, 0.5, 1.0, 3.0)] == [0, 0, 1, 1, 2]
    path.write_text("depth_m,su_kpa,note\n0,3.4,x\n")
    with pytest.raises(ConfigError, match="site.csv: column note': not a soil key"):
        read_points(str(path))


#: the default soil, su = 5 kPa + 1.5 kPa/m·z, as a table to 3 m: as it is, and with a density column,
#: 600 kg/m³ down to 0.05 m and ``below`` under it
PLAIN = "soil.profile={depth_m:[0,3],su_pa:[5000,9500]}"


def density_layers(below: float) -> str:
    return f"soil.profile={{depth_m:[0,0.05,0.05,3],su_pa:[5000,5075,5075,9500],density_kg_m3:[600,600,{below},{below}]}}"


def landing(compose_cfg, solver, *overrides):
    base = [f"solver={solver}", "tracking=disabled", "output.plots=false",
            *(["solver.progress=off"] if solver.startswith("cel") else [])]
    return solve(compose_cfg, [*base, *overrides])


@pytest.mark.parametrize("solver, cell, force_rtol", [("cel2d", 0.04, 1e-8), ("cel3d", 0.15, 5e-15)])
def test_a_table_that_layers_the_density_alike_lands_as_the_unlayered_soil(compose_cfg, solver, cell, force_rtol):
    """Two layers of the soil's own density: the cells carry a density row of ones, which the remap moves
    with the soil and by which it weighs the momentum's mass fluxes. The landing is the unlayered one to
    round-off: measured, its sinkage 1.0e-11 and its force history 3.0e-9 of the largest force apart in
    cel2d (the section bounces, and the row's ones differ from 1 by an ulp here and there), 1e-16 and 5e-16
    in cel3d."""
    mesh = f"mesh.cell_size_m={cell}"
    plain, alike = landing(compose_cfg, solver, mesh, PLAIN), landing(compose_cfg, solver, mesh, density_layers(600))
    assert alike.metrics["max_sinkage_m"] == pytest.approx(plain.metrics["max_sinkage_m"], rel=1e-10)
    force = plain.history["force_n"]
    np.testing.assert_allclose(alike.history["force_n"], force, rtol=0, atol=force_rtol * np.abs(force).max())


def test_a_landing_on_soil_heavier_below_sinks_between_the_uniform_soils(compose_cfg):
    """The section on soil twice as heavy below 0.05 m (its mass in the cells' density row, its geostatic
    stress the column's weight) sinks less than on the light soil and more than on the heavy one, in cel2d
    and in the fast model; cel2d keeps the soil's mass to round-off (measured 3e-16). Measured (cel2d on
    B/15, the fast model): light 0.0648, 0.0697; layered 0.0625, 0.0695; heavy 0.0613, 0.0675 m: cel2d
    feels the heavy layer under the base more than the fast model, which reads the column's weight at the
    base (+7.5, +11.2, +10.0 % over cel2d)."""
    for solver, mesh in (("cel2d", ["mesh.cell_size_m=0.04"]), ("analytic_dynamic", [])):
        light = landing(compose_cfg, solver, *mesh, PLAIN).metrics["max_sinkage_m"]
        heavy = landing(compose_cfg, solver, *mesh, PLAIN, "soil.density_kg_m3=1200").metrics["max_sinkage_m"]
        layered = landing(compose_cfg, solver, *mesh, density_layers(1200))
        assert heavy < layered.metrics["max_sinkage_m"] < light
        if solver == "cel2d":
            assert layered.metrics["mass_error"] < 1e-14


@pytest.mark.parametrize("solver, cell", [("cel2d", 0.04), ("cel3d", 0.15)])
def test_soil_of_a_layered_density_entering_the_grid_brings_its_mass(compose_cfg, solver, cell):
    """A landing drifting 0.5 m/s across the track: the grid follows the body as it slides, and the far
    field's soil enters through the sides in its layer's geostatic state and density (the ghost soil
    weighed as the cells weigh theirs). The soil's mass, counted by the density row and the inflow, is
    kept to round-off (measured 1.0e-15 in cel2d, 1.3e-16 in cel3d), while soil entered (and left)."""
    result = landing(compose_cfg, solver, f"mesh.cell_size_m={cell}", density_layers(1200),
                     "landing.horizontal_velocity_m_s=0.5", "landing.free=[z,x]")
    assert result.metrics["mass_error"] < 1e-14
    assert result.metrics["soil_entered_kg"] != 0.0


def test_a_table_that_layers_the_density_badly_is_refused_in_one_line(compose_cfg):
    with pytest.raises(ConfigError, match="the layer from 0.5 m's density_kg_m3 -600.0.*greater than 0"):
        build_scene(compose_cfg(["soil.profile={depth_m:[0,0.5,0.5],su_pa:[3000,5000,5000],"
                                 "density_kg_m3:[600,600,-600]}"]))


def test_the_3d_fast_model_reads_a_density_layered_alike_as_the_soil_to_the_bit(compose_cfg):
    plain = landing(compose_cfg, "analytic_dynamic_3d", PLAIN).metrics["max_sinkage_m"]
    assert landing(compose_cfg, "analytic_dynamic_3d", density_layers(600)).metrics["max_sinkage_m"] == plain


def test_the_soil_entering_the_grid_is_the_soil_its_cells_hold_at_that_depth():
    """The ghost state the side inflow brings at each layer of cells, weighed by the compiled rule, is the
    geostatic cells' own there: their vertical stress and density row, to round-off, boundary cells too."""
    from dsmv.cel.grid import build_grid_2d
    from dsmv.cel.layout import ROWS_2D
    from dsmv.cel.state import Elastic, density_ratios, geostatic_state, layers_below, step_parameters
    from dsmv.cel.stepper import geostatic_ghost
    from dsmv.config.tree import compose_scene

    soil = compose_scene([density_layers(1200).replace("0.05,0.05", "0.13,0.13")]).soil  # inside a cell
    layers, rho, h, g = soil.density_layers, soil.lightest_density_kg_m3, 0.04, 9.81
    grid = build_grid_2d(h, 0.4, 0.8, 0.4, 0.8, 3 * h, 1.1, 0.5)
    mudline = -0.01  # a layer of cells the mudline cuts
    elastic = Elastic.of(soil, rho)
    phi, q = geostatic_state(grid, rho, g, elastic.k0, mudline, layers=layers)
    q = np.concatenate([q, density_ratios(grid, mudline, layers, phi)[None]])
    par = step_parameters(dt=1e-4, density=rho, elastic=elastic, h=h, gravity=g, su0=5000.0, ks=0.0, hourglass=0.0,
                          bulk_linear=0.0, bulk_quadratic=0.0, stress_cutoff=0.01, axisymmetric=False,
                          advection_order=2, drop=False, inflow=True, remap=True, tresca=True, law_active=False,
                          density_layers=layers, density_row=q.shape[0] - 1)
    fill, depth = layers_below(grid.y, mudline)
    ghost = np.zeros((q.shape[0], len(fill)))
    for c in np.nonzero(fill > 0)[0]:
        geostatic_ghost(ghost, c, depth[c], 0.5 * fill[c] * (grid.y[c + 1] - grid.y[c]), par, ROWS_2D.inflow,
                        fill[c])
    below = fill > 0
    vertical = ROWS_2D.of(ROWS_2D.vertical)
    np.testing.assert_allclose(ghost[vertical, below] * fill[below], q[vertical, 0, below], rtol=1e-13)
    np.testing.assert_allclose(ghost[-1, below], q[-1, 0, below], rtol=1e-13)
    assert np.ptp(q[-1, 0, below]) > 0.9  # both layers, and the cell between them, are there


def test_the_commands_that_take_one_density_refuse_a_layered_one_in_one_line():
    from dsmv.calibration.run import check_config as check_calibration
    from dsmv.surrogate.predict import check_config as check_prediction
    from dsmv.testing import compose_config

    table = density_layers(1200)
    with pytest.raises(ConfigError, match="dsmv-predict takes one density"):
        check_prediction(compose_config("predict", table, "tracking=disabled"))
    with pytest.raises(ConfigError, match="dsmv-calibrate takes one density"):
        check_calibration(compose_config("calibrate", "site=synthetic_ccz", "tracking=disabled", table))


def test_a_layered_density_is_in_the_field_frames(compose_cfg, tmp_path):
    """The frames carry the cells' density where the table layers it: at the start, 600 kg/m³ in the cells
    above 0.05 m and 1200 below (a cell the boundary cuts, between)."""
    from dsmv.cel.fields import read_frame, series

    scene = build_scene(compose_cfg(["solver=cel2d", "mesh.cell_size_m=0.04", "solver.progress=off",
                                     "output.fields=true", "output.plots=false", density_layers(1200)]))
    result = registry.load("solvers", scene.solver.name, "solver.name")(scene).solve(tmp_path)
    assert result.status == "ok", result.message
    first = read_frame(series(tmp_path)[0][1])
    density, phi = first.cells["density_kg_m3"], first.cells["volume_fraction"]
    soil = density[phi > 0.999]
    assert soil.min() == pytest.approx(600.0, rel=1e-6) and soil.max() == pytest.approx(1200.0, rel=1e-6)
    assert (density[phi == 0.0] == 0.0).all()
