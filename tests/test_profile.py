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
    slope is exactly ks, so each segment's intercept + slope·z0 is su0 + ks·z0)."""
    line = solve(compose_cfg, [*DAVIS_BOOKER, f"solver={solver}", LINE])
    table = solve(compose_cfg, [*DAVIS_BOOKER, f"solver={solver}", "soil.ks_pa_per_m=0", TABLE])
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
