"""The CEL layers do not assume two dimensions: a one-cell-thick slab on a 3-axis grid.

The corner table, the boundary conditions, the rasteriser, the node and contact stages and the
controller are built and run on a grid of three axes (x, y across, z up) before any 3D element
kernel exists. Each check is exact: the mass a cell lends its eight corners, the velocity a step
of free fall gives (−g·Δt), a tie's velocity and the mass it adds, the body a box rasterises to.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from dsmv.cel import controller as C
from dsmv.cel.body import nodes_touching, solid_cells
from dsmv.cel.contact import fixed_velocities
from dsmv.cel.kernels.nodes import apply_fixed, apply_ties, gather_travel, nodal_mass, tie_reactions, update_velocities
from dsmv.cel.layout import (
    B_SINKAGE, B_TIME, B_VEL, B_VX, B_VY, B_WX, B_WY, B_WZ, N_BODY, Cells, Contact, Mesh2D, Nodes, corner_offsets, structured_corners,
)

NX, NY, NZ = 4, 1, 3  # a slab one cell thick across y
AXES = (np.linspace(0.0, 2.0, NX + 1), np.linspace(0.0, 0.5, NY + 1), np.linspace(-1.5, 0.0, NZ + 1))
NODE_SHAPE = (NX + 1, NY + 1, NZ + 1)
N_NODES = int(np.prod(NODE_SHAPE))


def node(i, j, k):
    return np.ravel_multi_index((i, j, k), NODE_SHAPE)


@pytest.fixture
def slab():
    cell_shape = (NX, NY, NZ)
    vol = np.full(cell_shape, 0.5 * 0.5 * 0.5)
    phi = np.ones(cell_shape)
    phi[:, :, -1] = 0.5  # the top layer half full
    cells = Cells(phi, np.zeros((8, *cell_shape)), np.zeros(cell_shape), np.ones(cell_shape),
                  np.zeros(cell_shape, dtype=bool), np.ones(cell_shape), np.zeros(cell_shape, dtype=bool),
                  np.full(cell_shape, np.nan), np.ones(cell_shape))
    mesh = Mesh2D(AXES[0], AXES[2], vol, structured_corners(cell_shape), N_NODES, np.zeros(cell_shape, dtype=bool))
    nodes = Nodes(np.zeros((3, N_NODES)), np.zeros((3, N_NODES)), np.zeros(N_NODES), np.zeros((3, N_NODES)))
    return mesh, cells, nodes


def test_the_corner_table_gives_each_cell_its_eight_nodes(slab):
    mesh, _, _ = slab
    assert mesh.corner.shape == (NX, NY, NZ, 8)
    for c, offset in enumerate(corner_offsets(3)):
        i, j, k = 2 + offset[0], 0 + offset[1], 1 + offset[2]
        assert mesh.corner[2, 0, 1, c] == node(i, j, k)


def test_lumped_masses_are_an_eighth_of_each_cell(slab):
    mesh, cells, nodes = slab
    rho = 1600.0
    nodal_mass(mesh, cells, rho, nodes.mass)
    assert nodes.mass.sum() == pytest.approx(rho * (cells.phi * mesh.vol).sum(), rel=1e-14)
    # an inner node of the bottom layer (x = 1, z = −1) touches four full cells across the slab's two y faces
    assert nodes.mass[node(2, 0, 1)] == pytest.approx(4 * rho * 0.125 / 8, rel=1e-14)


def test_a_step_of_free_fall_and_the_boundary_conditions(slab):
    mesh, cells, nodes = slab
    nodal_mass(mesh, cells, 1600.0, nodes.mass)
    g, dt = 9.81, 1e-4
    before, after = update_velocities(nodes, g, (0.0, 0.0), dt, 1e-12)
    assert nodes.v[2] == pytest.approx(np.full(N_NODES, -g * dt), rel=1e-14)
    assert (nodes.v[:2] == 0.0).all()
    assert after - before == pytest.approx(-g * dt * nodes.mass.sum(), rel=1e-12)
    nodes.v[:] = 1.0
    fixed_node, fixed_axis = fixed_velocities(NODE_SHAPE)
    contact = _contact(fixed_node, fixed_axis)
    change = apply_fixed(nodes, contact)
    v = nodes.v.reshape(3, *NODE_SHAPE)
    assert (v[0, [0, -1]] == 0.0).all() and (v[1, :, [0, -1]] == 0.0).all()  # rollers on the x and y planes
    assert (v[:, :, :, 0] == 0.0).all()  # the base is fixed
    assert (v[2, 1:-1, :, 1:] == 1.0).all()  # elsewhere the vertical velocity is free
    assert change == pytest.approx(-nodes.mass.reshape(NODE_SHAPE)[:, :, 0].sum(), rel=1e-12)


def test_the_node_stages_in_blocks_match_the_serial_ones_on_any_thread_count():
    """3D's parallel velocity update and travel (blocks of NODE_BLOCK nodes, more than one here)
    give the serial stages' velocities and travel bit for bit, and the same momentum sums, summed per
    block, to rounding; on one and two threads alike."""
    import numba

    from dsmv.cel.kernels.nodes import NODE_BLOCK, gather_travel_in_blocks, update_velocities_in_blocks

    n = 2 * NODE_BLOCK + 123
    rng = np.random.default_rng(3)
    start = Nodes(rng.normal(size=(3, n)), rng.normal(size=(3, n)), rng.random(n) * (rng.random(n) > 0.1),
                  rng.normal(size=(3, n)) * 1e-3)
    serial = Nodes(*(a.copy() for a in start))
    before, after = update_velocities(serial, 9.81, (0.0, 0.0), 1e-4, 1e-12)
    travel = gather_travel(serial, _body(vz=-0.3), 1e-4)
    previous = numba.get_num_threads()
    try:
        for threads in sorted({1, min(2, numba.config.NUMBA_NUM_THREADS)}):
            numba.set_num_threads(threads)
            blocks = Nodes(*(a.copy() for a in start))
            sums = update_velocities_in_blocks(blocks, 9.81, (0.0, 0.0), 1e-4, 1e-12)
            assert np.array_equal(blocks.v, serial.v)
            assert sums == pytest.approx((before, after), rel=1e-12)
            assert gather_travel_in_blocks(blocks, _body(vz=-0.3), 1e-4) == travel
            assert np.array_equal(blocks.travel, serial.travel)
    finally:
        numba.set_num_threads(previous)


def _contact(fixed_node, fixed_axis, tied=(), full=(), normal=np.zeros((0, 3)), arm=None):
    tied = np.asarray(tied, dtype=np.int64)
    none = np.zeros(0, dtype=np.int64)
    arm = np.zeros((len(tied), 3)) if arm is None else np.asarray(arm, dtype=float)
    return Contact(tied, np.asarray(full, dtype=bool), np.asarray(normal, dtype=float), np.zeros(len(tied)),
                   np.zeros(len(tied) + 1, dtype=np.int64), np.zeros((0, 2), dtype=np.int64),
                   np.ones(len(tied)), none, none, fixed_node, fixed_axis, np.zeros((0, 4), dtype=np.int64),
                   arm, np.zeros(len(tied)))


def _body(**velocities):
    """The body's state array with the velocities named (vz, vx, vy, wx, wy, wz)."""
    body = np.zeros(N_BODY)
    slots = {"vz": B_VEL, "vx": B_VX, "vy": B_VY, "wx": B_WX, "wy": B_WY, "wz": B_WZ}
    for name, value in velocities.items():
        body[slots[name]] = value
    return body


def test_ties_move_nodes_with_the_body_in_three_axes(slab):
    mesh, cells, nodes = slab
    nodal_mass(mesh, cells, 1600.0, nodes.mass)
    a, b = node(2, 0, 3), node(4, 1, 3)  # one tied fully, one along a wall normal (x)
    contact = _contact(np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), [a, b], [True, False],
                       [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    nodes.v[:, a] = (0.3, -0.2, 0.1)
    nodes.v[:, b] = (0.3, -0.2, 0.1)
    apply_ties(contact, nodes, _body(vz=-1.5))
    assert tuple(nodes.v[:, a]) == (0.0, 0.0, -1.5)
    assert tuple(nodes.v[:, b]) == (0.0, -0.2, 0.1)  # only the normal part is the body's (0 along x)
    nodes.f[2, a], nodes.f[0, b] = 5.0, 7.0
    force, inertia = np.zeros(6), np.zeros((6, 6))
    tie_reactions(contact, nodes, 9.81, (0.0, 0.0), force, inertia)
    assert force[2] == pytest.approx(5.0 - nodes.mass[a] * 9.81)  # a wall takes no weight
    assert force[0] == 7.0  # but pushes the body sideways
    assert inertia[2, 2] == nodes.mass[a] and inertia[0, 0] == nodes.mass[a] + nodes.mass[b]
    assert gather_travel(nodes, _body(vz=-1.5), 0.01) == pytest.approx((0.1 + 1.5) * 0.01)  # b rises through the grid
    assert tuple(nodes.travel[:, a]) == (0.0, 0.0, 0.0)  # the fully tied node keeps pace with the grid


def test_a_turning_body_moves_its_ties_with_v_plus_omega_cross_r(slab):
    """A rigid body's velocity at a tie is v + ω × r, and the reaction it gets is the force and its moment
    r × f about the centre of gravity: the exact kinematics, checked on three arms."""
    mesh, cells, nodes = slab
    nodal_mass(mesh, cells, 1600.0, nodes.mass)
    tied = [node(1, 0, 3), node(2, 1, 3), node(3, 1, 2)]
    arm = np.array([[0.4, -0.2, 0.1], [-0.3, 0.5, -0.25], [0.2, 0.1, 0.6]])
    contact = _contact(np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), tied, [True] * 3,
                       np.zeros((3, 3)), arm)
    v, w = np.array([0.3, -0.1, -1.2]), np.array([0.5, -0.7, 0.2])
    apply_ties(contact, nodes, _body(vx=v[0], vy=v[1], vz=v[2], wx=w[0], wy=w[1], wz=w[2]))
    for k, n in enumerate(tied):
        assert nodes.v[:, n] == pytest.approx(v + np.cross(w, arm[k]), rel=1e-14)
    f = np.array([[1.0, 2.0, 3.0], [-4.0, 0.5, 2.0], [0.25, -1.0, 7.0]])
    for k, n in enumerate(tied):
        nodes.f[:, n] = f[k]
    force, inertia = np.zeros(6), np.zeros((6, 6))
    tie_reactions(contact, nodes, 0.0, (0.0, 0.0), force, inertia)
    assert force[:3] == pytest.approx(f.sum(axis=0), rel=1e-14)
    assert force[3:] == pytest.approx(np.cross(arm, f).sum(axis=0), rel=1e-14)
    # the tied nodes' inertia: Σ m·JᵀJ, J = [I, −[r]×], whose rotational block is the inertia tensor Σ m(r²I − rrᵀ)
    m = nodes.mass[tied]
    tensor = sum(mk * (rk @ rk * np.eye(3) - np.outer(rk, rk)) for mk, rk in zip(m, arm))
    assert inertia[3:, 3:] == pytest.approx(tensor, rel=1e-13)
    assert inertia[:3, :3] == pytest.approx(m.sum() * np.eye(3), rel=1e-14)


def test_one_rasteriser_for_three_axes():
    box = SimpleNamespace(inside=lambda x, y, z: (np.abs(x) <= 1.0) & (z >= -0.5 - 1e-12))
    grid = SimpleNamespace(axes=AXES, x=AXES[0])
    solid = solid_cells(box, grid)
    assert solid.shape == (NX, NY, NZ)
    assert solid[:2, :, -1].all() and not solid[2:].any() and not solid[:, :, :-1].any()
    assert nodes_touching(solid).sum() == 8 * solid.sum()


def test_the_controller_steers_chunks_for_any_state():
    """The controller knows nothing of the dimension: a fake compiled loop that moves a body at
    a constant speed, stopped by the push's end, the history sampled per chunk."""
    body = np.zeros(N_BODY)
    body[B_VEL] = -0.5

    def advance(n):
        body[B_TIME] += n * 0.01
        body[1] += n * 0.01 * body[B_VEL]  # the grid's offset (m)
        body[B_SINKAGE] = -body[1]  # the middle of the base, upright
        return n, 0

    run = C.Run(state=None, body=body, energy=np.zeros(10))
    ending, _, _ = C.Controller(advance, [C.History(body.copy()), C.PushEnd(0.2), C.StepBudget(10_000)], 5, 10_000).run(run)
    assert ending.status == "ok" and ending.message.startswith("pushed to")
    assert run.history["sinkage_m"][0] == 0.0 and run.history["velocity_m_s"][0] == 0.5
    assert 0.2 <= run.sinkage_m < 0.2 + 0.025  # within a chunk of the target
    assert np.all(np.diff(run.history["time_s"]) > 0)


def test_a_body_still_turning_is_not_at_rest_at_an_instant_s_stop():
    """A body free to turn that stops for an instant while the soil's moment on it about its centre of
    gravity exceeds the limit runs on (a vehicle rocked onto one track); under the limit it rests."""
    from dsmv.cel.layout import B_FCOUNT, FORCE_SLOTS
    from dsmv.cel.stepper import AT_REST, RUNNING

    slot = int(FORCE_SLOTS[4])
    rest = C.Rest(weightless=False, stop_at_rest=True, turns=(slot,), moment_limit_n_m=10.0)
    body = np.zeros(N_BODY)
    body[B_FCOUNT], body[slot] = 2.0, 2 * 25.0  # a mean moment of 25 N·m over the chunk
    run = C.Run(state=None, body=body, energy=np.zeros(10), code=AT_REST)
    assert rest.after_chunk(run) is None and run.code == RUNNING and rest.rest_time_s is None
    body[slot], run.code = 2 * -9.0, AT_REST
    ending = rest.after_chunk(run)
    assert ending is not None and ending.status == "ok" and rest.rest_time_s is not None


def test_a_body_at_the_top_of_a_bounce_is_not_at_rest():
    """A body that stops for an instant while the soil bears less than its weight (less the rest's
    out-of-balance share) is at the top of a bounce and falls again: it runs on. Borne, it rests."""
    from dsmv.analytic.landing_model import REST_OUT_OF_BALANCE
    from dsmv.cel.layout import B_FCOUNT, FORCE_SLOTS
    from dsmv.cel.stepper import AT_REST, RUNNING

    weight = 1000.0
    rest = C.Rest(weightless=False, stop_at_rest=True, borne_n=(1.0 - REST_OUT_OF_BALANCE) * weight)
    body = np.zeros(N_BODY)
    up = int(FORCE_SLOTS[2])
    body[B_FCOUNT], body[up] = 4.0, 4 * 0.9 * weight  # the soil bore 90 % of the weight over the chunk
    run = C.Run(state=None, body=body, energy=np.zeros(10), code=AT_REST)
    assert rest.after_chunk(run) is None and run.code == RUNNING and rest.rest_time_s is None
    body[up], run.code = 4 * 0.96 * weight, AT_REST
    ending = rest.after_chunk(run)
    assert ending is not None and ending.status == "ok" and rest.rest_time_s is not None


class Counting(C.Tracker):
    """A scan that records the steps it looked at, and may end the run from a given step on."""

    cadence = C.SCAN

    def __init__(self, ends_at=None):
        self.seen, self.ends_at = [], ends_at

    def after_chunk(self, run):
        self.seen.append(run.steps)
        if self.ends_at is not None and run.steps >= self.ends_at:
            return C.Ending("unstable", "seen")
        return None


def test_scans_look_every_scan_steps_when_the_loop_stops_early_and_before_a_run_ends():
    """Chunks of 3 steps: the scans look once SCAN_STEPS steps have passed since their last look,
    at once when the compiled loop stops early, and before another tracker's ending, which theirs
    overrides."""
    body = np.zeros(N_BODY)

    def advance(n):
        body[B_TIME] += n
        return n, 0

    scan = Counting()
    run = C.Run(state=None, body=body, energy=np.zeros(10))
    ending, _, _ = C.Controller(advance, [scan, C.StepBudget(100)], 3, 100).run(run)
    gaps = np.diff([0, *scan.seen])
    assert ending.status == "unstable" and "max_steps" in ending.message
    assert scan.seen[-1] == 100  # the budget's end was shown to the scan first
    assert (gaps[:-1] >= C.SCAN_STEPS).all() and (gaps[:-1] < C.SCAN_STEPS + 3).all()

    # a scan's ending found between looks wins over the ending that made it look
    ending, _, _ = C.Controller(advance, [Counting(ends_at=50), C.StepBudget(60)], 3, 100).run(
        C.Run(state=None, body=np.zeros(N_BODY), energy=np.zeros(10)))
    assert (ending.status, ending.message) == ("unstable", "seen")

    # the compiled loop stopping early (here on its 4th call) makes the scans look at once
    calls = {"n": 0, "steps": 0}

    def stops(n):
        calls["n"] += 1
        calls["steps"] += n
        return n, C.OUTRAN if calls["n"] == 4 else 0

    scan = Counting()
    run = C.Run(state=None, body=np.zeros(N_BODY), energy=np.zeros(10))
    ending, _, _ = C.Controller(stops, [scan, C.NonFinite(lambda: [], 0.5)], 3, 100).run(run)
    assert ending.status == "unstable" and "crossed a whole cell" in ending.message
    assert scan.seen == [calls["steps"]] and calls["steps"] < C.SCAN_STEPS


def test_the_kinetic_energy_guard_ends_a_run_past_ten_times_the_energy_put_in():
    from dsmv.cel import ledger

    energy = np.zeros(ledger.N_ENERGY)
    run = C.Run(state=None, body=np.zeros(N_BODY), energy=energy)
    delivered = ledger.delivered(energy, 2.0)
    assert C.EnergyRunaway(lambda: 10.0 * delivered, 2.0, 1.0, 0.5).after_chunk(run) is None
    ending = C.EnergyRunaway(lambda: 10.0 * delivered + 1e-6, 2.0, 1.0, 0.5).after_chunk(run)
    assert ending.status == "unstable" and "kinetic energy" in ending.message and "solver.cfl (now 0.5)" in ending.message


def test_the_top_of_the_domain_ends_a_run_on_soil_that_bears_not_on_a_trace():
    """The closed top holds a trace that carries no stress (under ``solver.stress_cutoff``); soil that
    bears there ends the run out of the domain, with the advice."""
    run = C.Run(state=None, body=np.zeros(N_BODY), energy=np.zeros(1))
    cutoff = 0.01
    assert C.TopOfDomain(lambda: 3e-6, 0.1, cutoff).after_chunk(run) is None
    assert C.TopOfDomain(lambda: cutoff, 0.1, cutoff).after_chunk(run) is None
    ending = C.TopOfDomain(lambda: 2 * cutoff, 0.1, cutoff).after_chunk(run)
    assert ending.status == "out_of_domain" and "solver.initial_travel_m" in ending.message


@pytest.mark.parametrize("ndim", [2, 3])
def test_the_hourglass_force_acts_around_cut_cells_only(ndim):
    """solver.hourglass_region: cut_cells keeps the force in the cells a curved body cuts (0 < open
    fraction < 1) and their neighbours, in any number of axes; solid and open cells elsewhere get none."""
    from dsmv.cel.state import hourglass_factor

    open_frac = np.ones((7,) * ndim)
    open_frac[(slice(0, 2),) * ndim] = 0.0   # a solid corner block: no cut cell
    centre = (3,) * ndim
    open_frac[centre] = 0.4                  # one cut cell
    factor = hourglass_factor(open_frac, "cut_cells")
    expected = np.zeros_like(open_frac)
    expected[(slice(2, 5),) * ndim] = 1.0
    assert np.array_equal(factor, expected)
    assert np.array_equal(hourglass_factor(open_frac, "everywhere"), np.ones_like(open_frac))


@pytest.mark.parametrize("shape", [(9, 6), (5, 6, 4), (1, 8)])
def test_the_mask_grows_as_scipys_dilation_by_the_full_cube(shape):
    """dsmv.cel.state.dilated (cut cells and their neighbours) against scipy.ndimage's binary
    dilation with the 3×3… structure, edges included; scipy.ndimage costs 0.3 s to import, so the
    solver does not use it."""
    from scipy.ndimage import binary_dilation

    from dsmv.cel.state import dilated

    mask = np.random.default_rng(7).random(shape) < 0.15
    mask.flat[0] = mask.flat[-1] = True   # the edges
    assert np.array_equal(dilated(mask), binary_dilation(mask, structure=np.ones((3,) * len(shape), dtype=bool)))


def test_auto_keeps_the_hourglass_force_everywhere_only_for_the_fall_cone(compose_cfg):
    """solver.hourglass_region: auto (cel2d's default) is cut_cells for every body but the cone, whose
    staircase gathers the zig-zag (decision 0016); an explicit value is taken as given."""
    from dsmv.config.scene import build_scene

    def cells(*overrides):
        scene = build_scene(compose_cfg(["solver=cel2d", *overrides]))
        return scene.solver.hourglass_cells(scene.geometry.kind)

    assert cells() == "cut_cells"
    assert cells("geometry=tbar") == "cut_cells"
    assert cells("geometry=fall_cone_30deg") == "everywhere"
    assert cells("geometry=fall_cone_30deg", "solver.hourglass_region=cut_cells") == "cut_cells"
