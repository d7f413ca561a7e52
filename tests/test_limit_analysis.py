"""Finite-element limit analysis: the bounds bracket Prandtl's exact 2 + π, and embedment raises
the strip's collapse load above it (dsmv.analytic.limit_analysis)."""

import numpy as np
import pytest

from dsmv.analytic import limit_analysis
from dsmv.analytic.bearing import (NOTCH_AT_0P05B, NOTCHED_STRIP_LOWER_BOUND_AT_0P05B,
                                   NOTCHED_STRIP_UPPER_BOUND_AT_0P05B, PRANDTL_NC, STRIP_LOWER_BOUND_AT_0P05B,
                                   embedded_strip_upper_bound)
from dsmv.analytic.limit_analysis import main, strip_lower_bound, strip_mesh, strip_upper_bound

# a coarse mesh: a few seconds per bound
COARSE = dict(corner_size=0.04, growth=1.4, zone_size=0.1)


@pytest.mark.parametrize("rough", [True, False], ids=["rough", "smooth"])
def test_bounds_bracket_prandtl_on_a_coarse_mesh(rough):
    """Rigorous bounds must bracket the exact factor on any mesh; on this one they lie within 2 % below
    and 3 % above it (measured 5.085/5.062 and 5.270/5.242, rough/smooth)."""
    lower = strip_lower_bound(0.0, rough, **COARSE)
    upper = strip_upper_bound(0.0, rough, **COARSE)
    assert lower.bearing_factor <= PRANDTL_NC <= upper.bearing_factor
    assert lower.bearing_factor > 0.98 * PRANDTL_NC
    assert upper.bearing_factor < 1.03 * PRANDTL_NC
    assert lower.max_violation < 1e-6 and upper.max_violation < 1e-6


def test_embedment_raises_the_rough_strips_lower_bound_above_prandtl():
    """0.05 B of embedment with rough walls: even a coarse mesh's lower bound exceeds 2 + π, and it
    stays below the closed-form upper bound of dsmv.analytic.bearing (5.404)."""
    lower = strip_lower_bound(0.05, True, **COARSE)
    assert PRANDTL_NC < lower.bearing_factor <= embedded_strip_upper_bound(0.05, rough_walls=True)


@pytest.mark.parametrize("gap", [0.0, 0.05])
def test_mesh_covers_the_domain_without_the_footing(gap):
    depth, extent = 0.05, 3.0
    mesh = strip_mesh(depth, extent, gap=gap, **COARSE)
    x, z = mesh.points[mesh.triangles][..., 0], mesh.points[mesh.triangles][..., 1]
    twice_area = (x[:, 1] - x[:, 0]) * (z[:, 2] - z[:, 0]) - (x[:, 2] - x[:, 0]) * (z[:, 1] - z[:, 0])
    assert (twice_area > 0).all()  # counter-clockwise, none degenerate
    assert 0.5 * twice_area.sum() == pytest.approx(extent * extent - (0.5 + gap) * depth, rel=1e-12)
    kinds = {mesh.boundary_kind(p, q) for (p, q), owners in mesh.edges().items() if len(owners) == 1}
    assert kinds == ({"axis", "far", "surface", "base"} | ({"wall"} if gap == 0.0 else set()))


def test_notched_mesh_covers_the_domain_without_the_footing_and_the_wedge():
    """A wedge-shaped gap beside the wall, closed at the base corner and `notch` wide at the surface:
    the soil's area loses the wedge's notch·depth/2, no triangle folds, and no face is a wall."""
    depth, extent, notch = 0.05, 3.0, 0.02
    mesh = strip_mesh(depth, extent, notch=notch, **COARSE)
    x, z = mesh.points[mesh.triangles][..., 0], mesh.points[mesh.triangles][..., 1]
    twice_area = (x[:, 1] - x[:, 0]) * (z[:, 2] - z[:, 0]) - (x[:, 2] - x[:, 0]) * (z[:, 1] - z[:, 0])
    assert (twice_area > 0).all()
    assert 0.5 * twice_area.sum() == pytest.approx(extent * extent - 0.5 * depth - 0.5 * notch * depth, rel=1e-12)
    kinds = {mesh.boundary_kind(p, q) for (p, q), owners in mesh.edges().items() if len(owners) == 1}
    assert kinds == {"axis", "far", "surface", "base"}
    # each cell centre on both diagonals of its sheared cell: the lower bound drops one traction
    # condition per centre, which the others imply only when its triangles meet along two lines
    first = mesh.triangles[: len(mesh.triangles) // 4]  # (corner k, corner k+1, centre) for k = 0
    second = mesh.triangles[len(mesh.triangles) // 2: 3 * len(mesh.triangles) // 4]  # k = 2
    bl, br, centre = (mesh.points[first[:, k]] for k in range(3))
    tr, tl = mesh.points[second[:, 0]], mesh.points[second[:, 1]]
    for a, b in ((bl, tr), (br, tl)):
        along = (b - a)[:, 0] * (centre - a)[:, 1] - (b - a)[:, 1] * (centre - a)[:, 0]
        assert np.abs(along).max() < 1e-14
    with pytest.raises(ValueError, match="needs a depth > 0"):
        strip_mesh(0.0, extent, notch=notch)


@pytest.mark.slow  # cone programmes on fine meshes: 31 s and 19 s
def test_a_wedge_gap_beside_the_wall_brings_the_bounds_down_towards_the_surface_strips():
    """A rough strip 0.05 B deep with a wedge-shaped gap (0.02 B wide at the surface) beside the
    wall, as a pushed strip's corner leaves behind: its bounds bracket a factor below the strip
    with soil against the wall and above the strip on the surface (the slope's free-surface
    condition σ·n = 0 at work). Coarse mesh, rigorous bounds of each geometry."""
    notched = [bound(0.05, True, notch=0.02, **COARSE) for bound in (strip_lower_bound, strip_upper_bound)]
    against_wall = strip_lower_bound(0.05, True, **COARSE)
    assert notched[0].bearing_factor <= notched[1].bearing_factor
    assert notched[0].bearing_factor < against_wall.bearing_factor
    assert notched[1].bearing_factor > strip_lower_bound(0.0, True, **COARSE).bearing_factor
    assert max(b.max_violation for b in notched) < 1e-6


@pytest.mark.parametrize("depth", [0.0, 0.2])
def test_lower_bound_equalities_are_independent(depth):
    """An interior solver needs independent equalities: one traction condition per cell centre is
    implied by the other seven and must be dropped (limit_analysis._lower_bound_program); the rest,
    with the boundary and far-field rows, keep full row rank."""
    mesh = strip_mesh(depth, 2.0, corner_size=0.25, growth=1.6, zone_size=0.5, coarse_size=1.0)
    equalities, _ = limit_analysis._lower_bound_program(mesh, rough=True, bonded=False).matrix("eq")
    assert np.linalg.matrix_rank(equalities.toarray()) == equalities.shape[0]


def test_negative_depth_is_refused_with_what_is_allowed(capsys):
    with pytest.raises(ValueError, match="must be ≥ 0"):
        strip_lower_bound(-0.1)
    with pytest.raises(SystemExit) as exit_info:  # the command line: a usage error, not a traceback
        main(["--depth", "-1"])
    assert exit_info.value.code == 2
    assert "--depth -1.0: allowed are a depth ≥ 0" in capsys.readouterr().err


def test_command_line_prints_a_bracket(capsys):
    main(["--depth", "0", "--roughness", "smooth", "--corner-size", "0.1", "--growth", "1.6", "--zone-size", "0.2"])
    header, *lines = capsys.readouterr().out.splitlines()
    assert header.startswith("q/su0 of a strip whose base lies 0 B deep, smooth")
    assert lines[0].startswith("lower bound  q/su0 = ") and lines[1].startswith("upper bound  q/su0 = ")
    lower, upper = (float(line.split("= ")[1].split()[0]) for line in lines)
    assert lower <= PRANDTL_NC <= upper


def test_a_bonded_wall_costs_the_mechanism_more_than_one_the_soil_may_leave():
    """Tying the soil to a smooth wall along its normal removes mechanisms, so the upper bound can
    only rise (the same mesh, 0.2 B deep)."""
    free = strip_upper_bound(0.2, rough=False, bonded=False, **COARSE)
    bonded = strip_upper_bound(0.2, rough=False, bonded=True, **COARSE)
    assert bonded.bearing_factor >= free.bearing_factor - 1e-6


@pytest.mark.slow
@pytest.mark.parametrize("roughness,bonded", [("rough", False), ("smooth", True)])
def test_strip_wished_in_place_0p05B_deep_carries_more_than_the_acceptance_lines(roughness, bonded):
    """The README's headline (2–3 min each): the strip wished in place 0.05 B deep, its soil tied to
    the walls as in the CEL (the rough bound forbids tension, so it covers the tied wall too), has
    rigorous lower bounds of 5.357 (rough) and 5.296 (smooth): above #3's 2.5 % line (5.271), and
    the rough one above its 4 % line (5.348) too. dsmv.analytic.bearing quotes them."""
    lower = strip_lower_bound(0.05, roughness == "rough", bonded, corner_size=0.005, growth=1.15, zone_size=0.025)
    assert lower.bearing_factor > 1.025 * PRANDTL_NC
    assert lower.bearing_factor == pytest.approx(STRIP_LOWER_BOUND_AT_0P05B[roughness], abs=0.001)
    if roughness == "rough":
        assert lower.bearing_factor > 1.04 * PRANDTL_NC


@pytest.mark.slow
@pytest.mark.parametrize("roughness", ["rough", "smooth"])
def test_pushed_strip_with_its_notch_is_bracketed_below_the_tied_one(roughness):
    """The quoted bounds for the strip pushed 0.05 B whose soil may part from its walls (about 5 min
    each roughness): the notch beside the wall brings the lower bounds to 5.207 (rough) and 5.206
    (smooth), +1.3 % above 2 + π, below the strip with soil against its walls; the upper bounds of
    the notched strip with a flat surface beyond are 5.270 and 5.264."""
    mesh = dict(notch=NOTCH_AT_0P05B, corner_size=0.005, growth=1.15, zone_size=0.025)
    lower = strip_lower_bound(0.05, roughness == "rough", False, **mesh)
    upper = strip_upper_bound(0.05, roughness == "rough", False, **mesh)
    # the lower bound's solver stalls (NumericalError, gap about 0.5 %): where it stops may move
    # with the platform, so the quoted value is met to 0.01 (any feasible field is a bound)
    assert lower.bearing_factor == pytest.approx(NOTCHED_STRIP_LOWER_BOUND_AT_0P05B[roughness], abs=0.01)
    assert upper.bearing_factor == pytest.approx(NOTCHED_STRIP_UPPER_BOUND_AT_0P05B[roughness], abs=0.001)
    assert PRANDTL_NC < lower.bearing_factor < upper.bearing_factor < STRIP_LOWER_BOUND_AT_0P05B["rough"]


@pytest.mark.parametrize("notch", [0.0, 0.02])
def test_lower_bound_field_keeps_every_traction_continuous_even_the_dropped_ones(notch):
    """The programme drops one traction condition per cell centre as implied by the others; the
    solved field must then meet all of them, dropped ones included, or the bound is not rigorous
    (a notched mesh whose centres left their cells' diagonals broke exactly this)."""
    mesh = strip_mesh(0.05, 3.0, notch=notch, **COARSE)
    program = limit_analysis._lower_bound_program(mesh, rough=True, bonded=False)
    stress, violation, _, _ = program.solve()
    field = stress.reshape(len(mesh.triangles), 3, 3)  # triangle, corner, (σxx, σzz, τxz)
    worst = 0.0
    for (p, q), owners in mesh.edges().items():
        if len(owners) != 2:
            continue
        (xp, zp), (xq, zq) = mesh.points[p], mesh.points[q]
        nx, nz = zq - zp, -(xq - xp)
        (t1, a1, b1), (t2, a2, b2) = owners
        for c1, c2 in ((a1, a2), (b1, b2)):
            (sxx1, szz1, txz1), (sxx2, szz2, txz2) = field[t1, c1], field[t2, c2]
            jump = np.hypot((sxx1 - sxx2) * nx + (txz1 - txz2) * nz, (txz1 - txz2) * nx + (szz1 - szz2) * nz)
            worst = max(worst, jump / np.hypot(nx, nz))
    assert violation < 1e-6 and worst < 1e-6


#: Davis & Booker (1973), strength growing with depth: q/su0 = F·[(2 + π) + k·B/(4·su0)]. The smooth
#: k·B/su0 = 4 case is the PLAXIS 2D validation manual's (3.2): 7.80
DAVIS_BOOKER_SMOOTH_4 = 7.80


@pytest.mark.slow  # cone programmes on fine meshes: 31 s and 19 s
def test_strength_gradient_zero_is_the_uniform_soil():
    """k = 0 must give the uniform soil's bounds to the last digit (the same programme)."""
    for bound in (strip_lower_bound, strip_upper_bound):
        assert bound(0.0, False, strength_gradient=0.0, **COARSE).bearing_factor == \
            bound(0.0, False, **COARSE).bearing_factor


def test_bounds_bracket_davis_and_booker_for_strength_growing_with_depth():
    """Smooth strip, k·B/su0 = 4: the bounds bracket Davis & Booker's 7.80 on a coarse mesh
    (measured 7.620 and 8.076), and both rise above the uniform soil's, which the gradient only
    strengthens."""
    lower = strip_lower_bound(0.0, False, strength_gradient=4.0, **COARSE)
    upper = strip_upper_bound(0.0, False, strength_gradient=4.0, **COARSE)
    assert lower.bearing_factor <= DAVIS_BOOKER_SMOOTH_4 <= upper.bearing_factor
    assert lower.bearing_factor > 0.97 * DAVIS_BOOKER_SMOOTH_4 and upper.bearing_factor < 1.04 * DAVIS_BOOKER_SMOOTH_4
    assert lower.bearing_factor > strip_upper_bound(0.0, False, **COARSE).bearing_factor
    assert lower.max_violation < 1e-6 and upper.max_violation < 1e-6


def test_a_negative_strength_gradient_is_refused():
    with pytest.raises(ValueError, match="k·B/su0"):
        strip_lower_bound(0.0, True, strength_gradient=-1.0, **COARSE)
