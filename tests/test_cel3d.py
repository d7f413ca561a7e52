"""The 3D CEL solver (``solver=cel3d``) against independent truths.

- Equilibrium: a column of geostatic soil on hexahedra stays at rest (the one-point forces of a
  linear stress balance the lumped weights exactly), to round-off.
- Plane strain: a strip modelled as a slab one cell thick between two roller planes is the 2D
  problem; the 3D element and remap must give the 2D solver's answer (smooth strip, B/10, in
  small strain and pushed with the remap).
- Tresca's return in principal axes: on the prism, corners included, and the trial's principal
  axes kept.
- Exact bearing capacities of surface plates in small strain (``-m slow``): Gourvenec (2007)'s
  square, Cox, Eason & Hopkins (1961)'s circle; pushed with the remap, the circle bears what
  ``cel2d``'s axisymmetric plate bears.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from dsmv import registry
from dsmv.config.scene import build_scene
from dsmv.errors import ConfigError

#: a push in small strain, weightless Tresca soil su 10 kPa, E = 500·su (the strip's verification soil)
SMALL_STRAIN_PUSH = ["landing=push", "soil.law=tresca", "soil.su0_pa=10000", "soil.ks_pa_per_m=0",
                     "soil.youngs_modulus_pa=5e6", "landing.gravity_m_s2=0", "landing.velocity_m_s=0.1",
                     "solver.remap=false", "solver.contact_separation=false", "solver.yield_surface=tresca",
                     "tracking=disabled", "output.plots=false", "solver.progress=off"]


def _solve(compose_cfg, overrides):
    scene = build_scene(compose_cfg(overrides))
    result = registry.load("solvers", scene.solver.name, "solver.name")(scene).solve()
    assert result.status == "ok", result.message
    return result


def test_a_geostatic_column_stays_at_rest():
    """Soil under its own weight on a 3 × 2 × 6 grid of boxes (graded in z), rollers on the sides and
    a fixed base: 200 steps leave every node at rest to 1e-12 m/s."""
    from dsmv.cel import ledger
    from dsmv.cel.contact import fixed_velocities
    from dsmv.cel.kernels.elements3d import ROWS_3D, cell_volumes
    from dsmv.cel.layout import N_BODY, Cells, Contact, Inflow, Nodes, Mesh3D, structured_corners
    from dsmv.cel.solver3d import faces_3d
    from dsmv.cel.state import Elastic, layers_below, step_parameters
    from dsmv.cel.kernels.nodes import nodal_mass
    from dsmv.cel.stepper3d import run_steps
    from types import SimpleNamespace

    x, y, z = np.array([0.0, 0.3, 0.5, 0.9]), np.array([0.0, 0.4, 0.6]), np.array([-2.0, -1.2, -0.7, -0.4, -0.2, 0.0, 0.2])
    shape = (3, 2, 6)
    rho, g = 600.0, 9.81
    elastic = Elastic.of(SimpleNamespace(youngs_modulus_pa=2.5e6, poisson_ratio=0.49, density_kg_m3=rho))
    fill, depth = layers_below(z, 0.0)
    phi = np.broadcast_to(fill, shape).copy()
    q = np.zeros((ROWS_3D.base, *shape))
    q[ROWS_3D.of("zz")] = -rho * g * depth * phi
    q[ROWS_3D.of("xx")] = q[ROWS_3D.of("yy")] = elastic.k0 * q[ROWS_3D.of("zz")]
    q[ROWS_3D.z0] = depth * phi
    vol = cell_volumes(x, y, z)
    n = 4 * 3 * 7
    mesh = Mesh3D(x, y, z, vol, structured_corners(shape), n, np.zeros(shape, dtype=bool),
                     np.zeros(shape, dtype=np.uint8))
    cells = Cells(phi, q, np.zeros(shape), np.ones(shape), np.zeros(shape, dtype=bool), np.ones(shape),
                  np.zeros(shape, dtype=bool), np.full(shape, np.nan), np.ones(shape))
    nodes = Nodes(np.zeros((3, n)), np.zeros((3, n)), np.zeros(n), np.zeros((3, n)))
    fixed_node, fixed_axis = fixed_velocities((4, 3, 7))
    none = np.zeros(0, dtype=np.int64)
    contact = Contact(none, none.astype(bool), np.zeros((0, 3)), np.zeros(0), np.zeros(1, dtype=np.int64),
                      np.zeros((0, 3), dtype=np.int64), np.zeros(0), none, none, fixed_node, fixed_axis,
                      np.zeros((0, 6), dtype=np.int64), np.zeros((0, 3)), np.zeros(0))
    par = step_parameters(dt=0.5 * 0.2 / elastic.wave_speed_m_s, density=rho, elastic=elastic, h=0.2, gravity=g,
                          su0=5000.0, ks=1500.0, hourglass=0.05, bulk_linear=0.06, bulk_quadratic=1.2,
                          stress_cutoff=0.01, push_velocity=0.0, axisymmetric=False, advection_order=2, drop=False,
                          inflow=False, remap=False, law_active=False, tresca=True)
    body = np.zeros(N_BODY)
    faces = faces_3d(np.zeros(shape, dtype=bool))
    inflow = Inflow(np.zeros((ROWS_3D.base, 3, 2)), np.zeros((3, 2)))
    nodal_mass(mesh, cells, rho, nodes.mass)
    steps, code = run_steps(200, mesh, cells, faces, nodes, contact, inflow, par, body, np.zeros(ledger.N_ENERGY), None)
    assert (steps, code) == (200, 0)
    assert np.abs(nodes.v).max() < 1e-12


def test_tresca_s_return_in_principal_axes_lands_on_the_prism():
    """A stress well outside the prism, in general axes: after the return s1 − s3 = 2·su, the
    intermediate principal stress where Tresca's corner rule puts it, and the principal axes kept."""
    from dsmv.cel.kernels.common import tresca_return
    from dsmv.cel.kernels.elements3d import tresca_3d

    rng = np.random.default_rng(7)
    su, shear = 10e3, 1.7e6
    for _ in range(50):
        rotation, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        principal = np.sort(rng.normal(scale=40e3, size=3))[::-1] - 20e3
        sigma = rotation @ np.diag(principal) @ rotation.T
        s = np.array([sigma[0, 0], sigma[1, 1], sigma[2, 2], sigma[0, 1], sigma[1, 2], sigma[0, 2]])
        dxi, dg = tresca_3d.py_func(s, su, shear, np.empty((3, 3)), np.empty((3, 3)))
        returned = np.array([[s[0], s[3], s[5]], [s[3], s[1], s[4]], [s[5], s[4], s[2]]])
        values, vectors = np.linalg.eigh(returned)
        expected = tresca_return.py_func(*principal, su, shear)
        if principal[0] - principal[2] > 2 * su:
            assert values[-1] - values[0] == pytest.approx(2 * su, rel=1e-9)
            assert dg == pytest.approx(expected[4], rel=1e-9)
        assert np.sort(values)[::-1] == pytest.approx(expected[:3], rel=1e-9, abs=1e-6)
        # the axes are the trial's: the returned stress commutes with the trial stress
        assert np.abs(returned @ sigma - sigma @ returned).max() < 1e-6 * np.abs(sigma).max() ** 2


@pytest.mark.parametrize("roughness, ks_pa_per_m, depth_m", [("smooth", 0, 0.0), ("smooth", 20000, 0.0),
                                                             ("rough", 20000, 0.0), ("rough", 0, 0.5)],
                         ids=["smooth", "smooth_kB_su0_2", "rough_kB_su0_2", "rough_wished_in_place_0p5B"])
def test_a_strip_slab_is_the_plane_strain_problem(compose_cfg, roughness, ks_pa_per_m, depth_m):
    """A strip pushed 0.03 B in small strain at B/10, in uniform soil, in soil whose strength grows
    with depth (k·B/su0 = 2), and wished in place below the mudline: the 3D slab's q/su at 0.02 B
    equals the 2D element's (measured relative differences 3.5e-5 smooth uniform, 4.681393 against
    4.681230; 5.6e-5 smooth k2, 7.003972 against 7.003581; 3.0e-5 rough k2, 7.485927 against
    7.485702; 8.1e-6 rough, wished in place 0.5 B deep, 6.006927 against 6.006878; the slab has no
    cut cells, so neither runs an hourglass force: what remains is the bulk viscosity's length in
    the graded cells, min(dx, dy, dz) with the slab's dy one core cell, against min(dx, dz)), and
    its energy audit closes as well as 2D's."""
    case = [*SMALL_STRAIN_PUSH, "geometry=strip", f"geometry.roughness={roughness}", "landing.displacement_m=0.03",
            "mesh.cell_size_m=0.1", f"soil.ks_pa_per_m={ks_pa_per_m}", f"landing.initial_depth_m={depth_m}"]
    plane = _solve(compose_cfg, [*case, "solver=cel2d"]).metrics
    slab = _solve(compose_cfg, [*case, "solver=cel3d"]).metrics
    assert slab["nc_at_0p02B"] == pytest.approx(plane["nc_at_0p02B"], rel=1e-4)
    assert slab["energy_error"] == pytest.approx(plane["energy_error"], abs=1e-5)


@pytest.mark.parametrize("roughness, cell_size_m, tolerance", [
    ("smooth", 0.1, 5e-4), ("rough", 0.1, 5e-4),
    pytest.param("smooth", 0.05, 2e-4, marks=pytest.mark.slow),
    pytest.param("rough", 0.05, 2e-4, marks=pytest.mark.slow)])
def test_a_strip_slab_pushed_with_the_remap_is_the_plane_strain_problem(compose_cfg, roughness, cell_size_m,
                                                                         tolerance):
    """The strip pushed 0.1 B with the remap (the grid moving with the strip, soil entering at the base,
    three sweeps of which the slab's y sweep moves nothing; rough: the capped adhesion α·su on the
    base, the walls and the split corners): the 3D slab's q/su at 0.02, 0.05 and 0.1 B equals the 2D
    solver's, with the mass exact and the audit as close as 2D's. Measured on B/10 at most 3.2e-4
    relative (smooth 4.691707, 5.295826, 5.504333 against 4.692329, 5.295460, 5.506075; rough 4.727487,
    5.382820, 5.659086 against 4.727975, 5.382420, 5.658772); on B/20 at most 7.7e-5 (smooth 4.719001,
    5.313413, 5.525072 against 4.719323, 5.313085, 5.524648; rough 5.376862 and 5.632763 against
    5.376599 and 5.632909 at 0.05 and 0.1 B)."""
    case = [*SMALL_STRAIN_PUSH, "solver.remap=true", "geometry=strip", f"geometry.roughness={roughness}",
            "landing.displacement_m=0.1", f"mesh.cell_size_m={cell_size_m}"]
    plane = _solve(compose_cfg, [*case, "solver=cel2d"]).metrics
    slab = _solve(compose_cfg, [*case, "solver=cel3d"]).metrics
    for name in ("nc_at_0p02B", "nc_at_0p05B", "nc_at_0p1B"):
        assert slab[name] == pytest.approx(plane[name], rel=tolerance), name
    assert slab["mass_error"] < 1e-12
    assert slab["energy_error"] == pytest.approx(plane["energy_error"], abs=1e-5)


def gourvenec(width_over_length: float) -> float:
    """A rough rectangular plate's exact factor: (2 + π)·sc, sc = 1 + 0.214·B/L − 0.067·(B/L)² (Gourvenec 2007)."""
    return (2 + math.pi) * (1 + 0.214 * width_over_length - 0.067 * width_over_length**2)


def test_a_quarter_a_half_and_the_whole_plate_agree(compose_cfg):
    """The square plate pushed 0.03 B in small strain at B/4 as a quarter (two symmetry planes), a half
    and the whole: the same bearing factor at 0.02 B to 1e-6, each model carrying its share of the
    load (with the remap, to 0.06 B, measured 1.4e-7 and 2.7e-7: the mirrored grids sum in other
    orders)."""
    case = [*SMALL_STRAIN_PUSH, "geometry=rectangular_plate", "landing.displacement_m=0.03", "mesh.cell_size_m=0.25"]
    runs = {sym: _solve(compose_cfg, [*case, f"solver.economies.symmetry={sym}"]).metrics
            for sym in ("quarter", "half", "full")}
    assert runs["half"]["cells"] == 2 * runs["quarter"]["cells"] == runs["full"]["cells"] / 2
    assert runs["quarter"]["cells_whole_body"] == runs["half"]["cells_whole_body"] == runs["full"]["cells"]
    for sym in ("half", "full"):
        assert runs[sym]["nc_at_0p02B"] == pytest.approx(runs["quarter"]["nc_at_0p02B"], rel=1e-6)


def test_cel2d_takes_half_and_full_for_its_symmetry(compose_cfg):
    """The 2D key takes the 3D solver's words: 'half' is the half model (true), 'full' the whole section."""
    for word, flag in (("half", True), ("full", False)):
        scene = build_scene(compose_cfg(["solver=cel2d", "geometry=strip", "landing=push", "solver.contact_separation=false",
                                         f"solver.economies.symmetry={word}"]))
        assert scene.solver.economies.symmetry is flag


def test_cel2d_runs_a_circular_plate_axisymmetric(compose_cfg):
    """``geometry=circular_plate`` with ``solver=cel2d`` is the axisymmetric flat plate: the same run, bit
    for bit, as the strip of the same width in ``solver.mode=axisymmetric``."""
    case = [*SMALL_STRAIN_PUSH, "solver=cel2d", "landing.displacement_m=0.02", "mesh.cell_size_m=0.1"]
    plate = _solve(compose_cfg, [*case, "geometry=circular_plate"]).metrics
    strip = _solve(compose_cfg, [*case, "geometry=strip", "solver.mode=axisymmetric"]).metrics
    assert plate["nc_at_0p02B"] == strip["nc_at_0p02B"]
    with pytest.raises(ConfigError, match="^solver.mode = 'plane_strain': a circular plate is axisymmetric"):
        build_scene(compose_cfg([*case, "geometry=circular_plate", "solver.mode=plane_strain"]))


@pytest.mark.slow
@pytest.mark.parametrize("geometry,length,roughness,truth,tolerance", [
    ("rectangular_plate", 1.0, "rough", gourvenec(1.0), 0.04),
    ("rectangular_plate", 2.0, "rough", gourvenec(0.5), 0.04),
    ("rectangular_plate", 4.0, "rough", gourvenec(0.25), 0.04),
    ("circular_plate", 1.0, "rough", 6.05, 0.03),  # Cox, Eason & Hopkins (1961)
])
def test_a_surface_plate_bears_its_exact_load(compose_cfg, geometry, length, roughness, truth, tolerance):
    """A quarter plate pushed 0.11 B in small strain at B/10: q/su at 0.1 B (the plateau) against the
    exact factor (measured: square 5.769, −2.2 %; L/B = 2 5.526, −1.5 %; L/B = 4 5.338, −1.1 %;
    circle 6.056, +0.1 %)."""
    length_key = [f"geometry.contact_length_m={length}"] if geometry == "rectangular_plate" else []
    metrics = _solve(compose_cfg, [*SMALL_STRAIN_PUSH, "solver=cel3d", f"geometry={geometry}", *length_key,
                                   f"geometry.roughness={roughness}", "landing.displacement_m=0.11",
                                   "mesh.cell_size_m=0.1"]).metrics
    assert metrics["nc_at_0p1B"] == pytest.approx(truth, rel=tolerance)
    assert metrics["energy_error"] < 1e-3 and metrics["mass_error"] < 1e-10


@pytest.mark.slow
@pytest.mark.parametrize("roughness", ["rough", "smooth"])
def test_the_pushed_circle_bears_what_the_axisymmetric_plate_bears(compose_cfg, roughness):
    """The circular plate pushed 0.11 B with the remap at B/10: the 3D staircase against ``cel2d``'s
    axisymmetric plate on the same cells, within 1 % at 0.1 B (measured: rough 7.394 against 7.396,
    −0.03 %; smooth 6.805 against 6.818, −0.2 %). Its staircase's vertical edges are tied along the
    bisector: tied fully, they held the heaving soil as rough corners (+1.5 % and +2.2 %, inscribed)."""
    case = [*SMALL_STRAIN_PUSH, "solver.remap=true", "geometry=circular_plate", f"geometry.roughness={roughness}",
            "landing.displacement_m=0.11", "mesh.cell_size_m=0.1"]
    solid = _solve(compose_cfg, [*case, "solver=cel3d"]).metrics
    axisymmetric = _solve(compose_cfg, [*case, "solver=cel2d"]).metrics
    assert solid["nc_at_0p1B"] == pytest.approx(axisymmetric["nc_at_0p1B"], rel=0.01)
    assert solid["mass_error"] < 1e-10 and solid["energy_error"] < 0.02


@pytest.mark.parametrize("cells_per_radius", [5, 10])
def test_a_circle_s_staircase_keeps_its_area_and_a_perimeter_of_4_over_pi(cells_per_radius):
    """``geometry=circular_plate`` in 3D, a quarter on B/10 and B/20 cells: the staircase of the cells
    whose centre lies in the circle has the circle's area to 2 % (1.9 % and 0.6 % above; the inscribed
    staircase has 24 % and 12 % less), and its steps' faces add up to 2R per quarter, 4/π of the
    quarter circle's arc: the π/4 the walls' adhesion is scaled by (``build_plate_contact``)."""
    from dsmv.cel.body import Disc, solid_cells
    from dsmv.cel.grid import Grid3D

    R, h = 0.5, 0.5 / cells_per_radius
    plan = np.linspace(0.0, 2 * R, 2 * cells_per_radius + 1)
    grid = Grid3D(plan, plan, np.linspace(-R, R, 2 * cells_per_radius + 1), h)
    solid = solid_cells(Disc(R), grid)
    assert not solid[:, :, :cells_per_radius].any() and (solid[:, :, cells_per_radius:] == solid[:, :, -1:]).all()
    footprint = solid[:, :, -1]
    assert footprint.sum() * h * h == pytest.approx(math.pi * R * R / 4, rel=0.02)
    centres = plan[:-1] + h / 2
    assert np.array_equal(footprint, centres[:, None] ** 2 + centres[None, :] ** 2 <= R * R)
    steps = np.count_nonzero(np.diff(footprint, axis=0, append=False)) + np.count_nonzero(
        np.diff(footprint, axis=1, append=False))
    assert steps * h == pytest.approx(2 * R)


# --------------------------------------------------------------------------- the track in 3D

def test_the_track_s_cells_are_its_plates_grousers_and_sprocket_arcs():
    """``geometry=track_pioneer_i`` in 3D: across x its width B, along y the side view. Its cells are
    the plates' flat run |y| ≤ L/2 above the grouser height, a grouser row across B at every plate
    pitch from the axis, and the sprockets' arcs as the staircase inscribed in radius R (every corner
    of a body cell inside the arc; every cell with all its corners inside is the body's). A node on
    the plates' underside between two grousers is tied along −z, with the adhesion over its share of
    that face; one on the outer edge of an arc's step along the bisector of its two faces."""
    from dsmv.cel.body import TrackBody, TrackSideView, solid_cells
    from dsmv.cel.contact import build_plate_contact
    from dsmv.cel.grid import Grid3D
    from dsmv.cel.layout import corner_offsets

    h, B, L, R, pitch = 0.05, 0.6, 2.0, 0.5, 0.15
    side = TrackSideView(half_length=L / 2, sprocket_radius=R, grouser=h, plate_pitch=pitch)
    grid = Grid3D(np.arange(0.0, 0.5 + 1e-9, h), np.arange(0.0, 1.8 + 1e-9, h), np.arange(-0.3, 1.2 + 1e-9, h), h)
    track = TrackBody(B / 2, side)
    solid = solid_cells(track, grid)
    xc, yc, zc = (0.5 * (a[:-1] + a[1:]) for a in grid.axes)
    across = xc < B / 2
    assert not solid[~across].any()  # nothing beyond the width
    # the grousers: the rows between the base and the grouser height, at 0, 0.15, … 0.9 m along the run
    grouser_row = solid[:, :, np.argmin(abs(zc - 0.5 * h))]
    starts = np.round(grid.y[:-1][grouser_row[0]] / pitch, 9)
    assert np.array_equal(starts, np.arange(0, 7)) and (grouser_row[across] == grouser_row[0]).all()
    # the plates' flat run: everything above the grouser height over |y| ≤ L/2
    run = (yc < L / 2)[None, :, None] & (zc > h)[None, None, :] & across[:, None, None]
    assert solid[run].all()
    # the arcs: inscribed staircase of the circle of radius R about (L/2, h + R)
    corners_inside = np.ones(solid.shape, dtype=bool)
    for o in corner_offsets(3):
        y = grid.y[o[1]:o[1] + solid.shape[1]][None, :, None]
        z = grid.z[o[2]:o[2] + solid.shape[2]][None, None, :]
        corners_inside &= ((y - L / 2) ** 2 + (z - h - R) ** 2 <= R * R * (1 + 1e-12)) | (y <= L / 2) & (z >= h)
    beyond = (yc > L / 2)[None, :, None] & (zc < h + R)[None, None, :] & across[:, None, None]
    assert np.array_equal(solid[beyond], corners_inside[beyond])
    assert solid[beyond].sum() > 20  # the arc has steps on this grid

    k_base = grid.row_of(0.0)
    contact = build_plate_contact(track, grid, k_base, 1.0, staircase=True)
    node_shape = tuple(len(a) for a in grid.axes)
    ties = {int(n): t for t, n in enumerate(contact.contact.node)}
    under = ties[np.ravel_multi_index((2, 5, 1 + k_base), node_shape)]  # x = 0.1, y = 0.25, on the plates' underside
    assert not contact.contact.full[under]
    assert np.array_equal(contact.contact.normal[under], [0.0, 0.0, -1.0])
    assert contact.contact.cap[under] == pytest.approx(h * h)  # four quarters of h × h
    # a step of the arc: the outer lower corner of the last body cell of the layer z = 2h … 3h
    layer = int(np.argmin(abs(zc - 2.5 * h)))
    j_last = int(np.nonzero(solid[0, :, layer])[0].max())
    assert grid.y[j_last + 1] > L / 2 + h  # beyond the run, on the arc
    edge = ties[np.ravel_multi_index((2, j_last + 1, layer), node_shape)]
    normal = contact.contact.normal[edge]
    assert not contact.contact.full[edge] and normal[1] > 0 and normal[2] < 0
    assert np.linalg.norm(normal) == pytest.approx(1.0)


def test_the_track_lands_in_3d_and_its_fields_open(compose_cfg, tmp_path):
    """The default scene (Einav–Randolph, 4.5 t at 1.5 m/s) with ``solver=cel3d`` on a coarse grid: it
    comes to rest ``ok`` with the soil's mass kept to 1e-10 and the energy audit closed within 2 %,
    no soil inside the track, and field files meshio reads as hexahedra with the named arrays."""
    import meshio

    from dsmv.cel import fields
    from dsmv.cel.solver3d import Cel3DSolver
    from tests.test_fields import CELL_FIELDS_3D

    scene = build_scene(compose_cfg(["solver=cel3d", "mesh.cell_size_m=0.15", "tracking=disabled",
                                     "output.plots=false", "solver.progress=off", "output.fields=true",
                                     "output.field_frames=2"]))
    result = Cel3DSolver(scene).solve(tmp_path)
    assert result.status == "ok", result.message
    m = result.metrics
    assert m["mass_error"] <= 1e-10 and m["energy_error"] <= 0.02
    assert m["phi_max"] < 1.01  # as 2D's landing: the remap packs no soil against the track (1.04 before)
    assert 0.0 < m["max_sinkage_m"] < scene.geometry.width_m
    # two sinkages: the grousers' tips (the body's base) and the plates, the grouser height above them
    assert m["plate_sinkage_m"] == m["max_sinkage_m"] - scene.geometry.grouser_height_m
    assert (result.history["plate_sinkage_m"] == result.history["sinkage_m"] - 0.05).all()
    frames = fields.series(tmp_path)
    last = meshio.read(frames[-1][1])
    (block,) = last.cells
    assert block.type == "hexahedron" and set(last.cell_data) == CELL_FIELDS_3D
    body = last.cell_data["body"][0] == 1.0
    assert body.any() and (last.cell_data["volume_fraction"][0][body] == 0.0).all()


def test_the_forces_beside_the_track_are_the_work_conjugate_of_the_strain(compose_cfg):
    """Virtual power, exactly: for any nodal velocities and cell stresses the internal forces' power
    plus the force they put on the body times its velocity (the grid's, which follows it sliding and
    sinking) is −Σ V·φ·σ:D, D the strain rate
    the stress update takes. On the track's coarse grid, with its closed faces and split nodes, D
    is the cell's own beside the body in its deviatoric part and the remap's in its volumetric part
    (the soil packed against a closed face is felt as pressure); without that pairing the energy
    audit of a landing is off by 5 %. Viscosities off, to 1e-12 of the power's scale."""
    from dsmv.cel.kernels.elements3d import (ROWS_3D, cell_nodes, nodal_forces, remap_divergence,
                                            strain_increment)
    from dsmv.cel.solver3d import Cel3DSolver

    scene = build_scene(compose_cfg(["solver=cel3d", "mesh.cell_size_m=0.15", "tracking=disabled",
                                     "solver.progress=off"]))
    state = Cel3DSolver(scene).initial_state()
    mesh, cells, nodes, contact = state.mesh, state.cells, state.nodes, state.contact
    assert mesh.closed.any() and mesh.split.any()
    par = state.par._replace(hourglass=0.0, bulk_linear=0.0, bulk_quadratic=0.0)
    rng = np.random.default_rng(5)
    nodes.v[:] = rng.normal(size=nodes.v.shape)
    cells.q[:6] = rng.normal(size=cells.q[:6].shape) * 1e3
    v_grid = (0.3, -0.2, -0.7)
    work = np.zeros(8)
    nodal_forces(mesh, cells, nodes, par, v_grid, contact.split_parent, None, work)
    assert np.abs(work[2:4]).max() > 0.0  # the closed walls take their share across as well
    power = float(np.sum(nodes.f * nodes.v)) + float(np.dot(work[2:5], v_grid))

    x, y, z = mesh.x, mesh.y, mesh.z
    ny1, nz1 = np.uint64(len(y)), np.uint64(len(z))
    nodes8, coeff, d = np.empty(8, dtype=np.uint64), np.empty((3, 8)), np.empty(6)
    q, expected, scale = cells.q, 0.0, 0.0
    for i, j, k in zip(*np.nonzero(cells.phi > 0.0)):
        dx, dy, dz = x[i + 1] - x[i], y[j + 1] - y[j], z[k + 1] - z[k]
        cell_nodes(mesh.corner, mesh.split, i, j, k, ny1, nz1, nodes8)
        strain_increment(nodes.v, nodes8, dx, dy, dz, 1.0, coeff, d)
        if mesh.closed[i, j, k] or mesh.split[i, j, k]:
            d[:3] += (remap_divergence(nodes.v, nodes8, mesh.closed[i, j, k], np.uint64(mesh.n_grid),
                                       contact.split_parent, dx, dy, dz, v_grid) - d[:3].sum()) / 3.0
        s = q[:6, i, j, k]
        density = s[:3] @ d[:3] + 2.0 * s[3:] @ d[3:]
        expected -= dx * dy * dz * cells.phi[i, j, k] * density
        scale += dx * dy * dz * cells.phi[i, j, k] * abs(density)
    assert ROWS_3D.of("xy") == 3 and ROWS_3D.of("zx") == 5
    assert power == pytest.approx(expected, abs=1e-12 * scale)


def test_the_forces_a_step_carries_ahead_are_the_forces_of_the_state_it_leaves(compose_cfg):
    """The stress update computes the next step's nodal forces with it (from the new stress and the
    velocities it used). On the track landing, through its remaps (the split nodes, closed faces and
    bulk viscosity all in play), they are bit for bit what the state gives afresh whenever a step
    ends without a remap, and a remap marks them stale."""
    from dsmv.cel.kernels.elements3d import nodal_forces
    from dsmv.cel.layout import (B_BESIDE_N, B_BESIDE_X, B_BESIDE_Y, B_BULK_W, B_FORCES_AHEAD, B_HOURGLASS_W,
                                 B_REMAPS, B_VEL, B_VX, B_VY)
    from dsmv.cel.solver3d import Cel3DSolver

    solver = Cel3DSolver(build_scene(compose_cfg(["solver=cel3d", "mesh.cell_size_m=0.15", "tracking=disabled",
                                                  "solver.progress=off"])))
    state = solver.initial_state()
    body, nodes = state.body, state.nodes
    assert body[B_FORCES_AHEAD] == 0.0
    checked = stale = 0
    for _ in range(60):
        remaps = body[B_REMAPS]
        solver.advance(state, 1)
        if body[B_REMAPS] > remaps:
            assert body[B_FORCES_AHEAD] == 0.0
            stale += 1
            continue
        assert body[B_FORCES_AHEAD] == 1.0
        ahead = nodes.f.copy()
        carried = body[[B_HOURGLASS_W, B_BULK_W, B_BESIDE_X, B_BESIDE_Y, B_BESIDE_N]].copy()
        work = np.zeros(8)
        nodal_forces(state.mesh, state.cells, nodes, state.par, (body[B_VX], body[B_VY], body[B_VEL]),
                     state.contact.split_parent, state.law, work)
        work = work[:5]  # the moment carried is about the centre of gravity, this one about the grid's origin
        assert np.array_equal(nodes.f, ahead) and np.array_equal(work, carried)
        assert np.abs(ahead).max() > 0.0 and carried[1] > 0.0
        checked += 1
    assert checked > 30 and stale > 0


def test_the_longitudinal_view_is_refused_in_3d(compose_cfg):
    """geometry.view names the plane a 2D model cuts: in 3D it would size the domain on the track's length
    (about 36 times the track's cells on the coarse mesh); one line naming the key instead."""
    with pytest.raises(ConfigError, match="geometry.view = 'longitudinal': cel3d models the whole track"):
        build_scene(compose_cfg(["solver=cel3d", "geometry.view=longitudinal", "mesh=coarse", "tracking=disabled"]))


def test_a_track_s_shape_carries_a_pose():
    """The body's description is not vertical-only: a track pitched nose down by 5° about its x axis
    reaches below its upright base ahead (y > 0) by L/2·sin 5° at the end of its run, and not behind;
    upright, the pose changes nothing."""
    from dsmv.cel.body import Pose, TrackBody, TrackSideView, inside_nodes
    from dsmv.cel.grid import Grid3D

    h, L = 0.05, 2.0
    side = TrackSideView(half_length=L / 2, sprocket_radius=0.3, grouser=0.0, plate_pitch=0.15)
    grid = Grid3D(np.arange(-0.5, 0.5 + 1e-9, h), np.arange(-1.6, 1.6 + 1e-9, h), np.arange(-0.3, 0.8 + 1e-9, h), h)
    upright = inside_nodes(TrackBody(0.3, side), grid)
    assert np.array_equal(upright, inside_nodes(TrackBody(0.3, side, Pose()), grid))
    pitched = inside_nodes(TrackBody(0.3, side, Pose.pitched(5.0)), grid)
    z = grid.z[None, None, :]
    below = pitched & (z < -1e-9)
    assert not (upright & (z < -1e-9)).any() and below.any()
    y_below = grid.y[np.nonzero(below.any(axis=(0, 2)))[0]]
    assert y_below.min() > 0  # only the nose, ahead, goes below the upright base
    deepest = -grid.z[np.nonzero(below.any(axis=(0, 1)))[0]].min()
    assert deepest == pytest.approx(L / 2 * math.sin(math.radians(5.0)), abs=h)


def test_nodal_masses_stay_those_of_the_cells_through_the_remaps(compose_cfg):
    """The loop computes no nodal masses: the set-up does, and each remap, the one place φ changes.
    On the track landing (split nodes at its edges and corners), after every step, remaps included,
    they equal a fresh computation from the cells."""
    from dsmv.cel.kernels.nodes import nodal_mass
    from dsmv.cel.layout import B_REMAPS
    from dsmv.cel.solver3d import Cel3DSolver

    solver = Cel3DSolver(build_scene(compose_cfg(["solver=cel3d", "mesh.cell_size_m=0.15", "tracking=disabled",
                                                  "solver.progress=off"])))
    state = solver.initial_state()
    assert len(state.nodes.mass) > state.mesh.n_grid  # the track's edges and corners are split
    fresh = np.empty_like(state.nodes.mass)
    for _ in range(40):
        solver.advance(state, 1)
        nodal_mass(state.mesh, state.cells, state.par.density, fresh)
        assert np.array_equal(state.nodes.mass, fresh)
    assert state.body[B_REMAPS] > 0
