"""Node and contact stages of the CEL step, for any number of axes (the last one is up).

They work on the flat node arrays and the contact table of :mod:`dsmv.cel.layout`: every tie is
one row, a split node (a body's corner) is an ordinary node with a tie of its own, so each stage
is one loop over the table, whatever the body and the dimension.

Contact: a fully tied node moves with the body; a normally tied one only along its normal n
(into the soil). A normally tied node with ``cap`` > 0 (limited adhesion, α·su) also feels the
body's pull along the face, up to cap·su, su being the strength of the cells that grip it
(written by the stress update of the step before); the pull's reaction reaches the body in the
next step. The contact's dissipation is the pull times the slip it leaves, m·|Δw|·|w'| per step
(w' the slip speed after the pull): zero when the node sticks, as a full tie dissipates nothing
(the kinetic energy a tie removes is the internal forces' work, already counted). With contact
separation a tie on a face (one with a normal) lets go, for the step, of a node whose free
velocity would carry it away from the face (no tension): it then moves with the soil, and
pushes nothing onto the body. Corners and staircase nodes (no normal) hold, and so does a tie's
``bond``, the share of its face that is soil against soil (a track's trapped soil): a tie holding a
share s of its node moves it s of the way to the body and lends the body s of its mass and force.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from dsmv.cel.kernels.common import BLOCK, INLINE, JIT, PARALLEL, ordered_sums
from dsmv.cel.layout import MODEL_FREEDOMS, VELOCITY_SLOTS, Cells

#: a cell the body cuts lends its nodes at least the mass of this fill of the whole cell: its open
#: faces are as stiff as a full cell's, and the explicit step stays stable (see nodal_mass)
CUT_MASS_FILL = 0.5
#: nodes per block of the parallel node stages
NODE_BLOCK = BLOCK
#: the freedoms (indices into dsmv.cel.layout.FREEDOMS) a model of two or three axes has
FREEDOMS_2D, FREEDOMS_3D = MODEL_FREEDOMS[2], MODEL_FREEDOMS[3]


@njit(**INLINE)
def model_freedoms(dim):
    """The body's freedoms in a model of ``dim`` axes: x, z, ry in plane strain; all six in 3D."""
    return FREEDOMS_2D if dim == 2 else FREEDOMS_3D


@njit(**INLINE)
def lever(arm, k, a, q):
    """How fast tie k moves along the model's axis ``a`` per unit speed of the body's freedom ``q``
    (:data:`dsmv.cel.layout.FREEDOMS`): 1 along the freedom's own axis, the tie's lever for a rotation
    (ω × r, r = ``arm[k]`` from the centre of gravity), else 0. Plane strain's axes are x and up (z) and
    it turns about y, out of the plane: a positive ω_y moves the +x side down."""
    dim = arm.shape[1]
    if q < 3:
        axis = q if dim == 3 else (0 if q == 0 else (1 if q == 2 else -1))
        return 1.0 if axis == a else 0.0
    r = q - 3
    if dim == 2:
        if r != 1:
            return 0.0
        return arm[k, 1] if a == 0 else -arm[k, 0]
    if r == a:
        return 0.0
    c = 3 - a - r  # (ω × r)_a = ε_{a r c} ω_r r_c
    return arm[k, c] if r == (a + 1) % 3 else -arm[k, c]


@njit(**INLINE)
def rigid_velocity(body, arm, k, a):
    """The rigid body's velocity at tie k along axis ``a`` (m/s): v + ω × r."""
    u = 0.0
    for q in model_freedoms(arm.shape[1]):
        u += lever(arm, k, a, q) * body[VELOCITY_SLOTS[q]]
    return u


@njit(**INLINE)
def normal_speed(body, arm, normal, k):
    """The rigid body's velocity at tie k along the tie's normal (m/s)."""
    u = 0.0
    for a in range(arm.shape[1]):
        u += rigid_velocity(body, arm, k, a) * normal[k, a]
    return u


@njit(**JIT)
def nodal_mass(mesh, cells, density, mass):
    """Lumped nodal mass: a quarter (2D; an eighth in 3D) of each neighbouring cell's soil mass (kg),
    to the nodes of the corner table (a split node takes its own cells' shares).

    A cell the body cuts (``open_frac`` < 1) lends its nodes the mass of at least
    ``CUT_MASS_FILL`` of its volume: its nodes may lie inside the body, where little soil is,
    yet carry the stiff open faces; the added inertia keeps the explicit step stable."""
    mass[:] = 0.0
    n_cells = cells.phi.size
    n_corners = mesh.corner.shape[-1]
    corner = mesh.corner.reshape((n_cells, n_corners))
    phi = cells.phi.reshape(n_cells)
    open_frac = cells.open_frac.reshape(n_cells)
    vol = mesh.vol.reshape(n_cells)
    share = 1.0 / n_corners
    for c in range(n_cells):
        fill = phi[c]
        if open_frac[c] < 1.0 and open_frac[c] > 0.0 and fill < CUT_MASS_FILL:
            fill = CUT_MASS_FILL
        m = share * density * fill * vol[c]
        if m > 0.0:
            for k in range(n_corners):
                mass[np.uint64(corner[c, k])] += m


@njit(**INLINE)
def nodal_mass_of_soil(mesh, cells, par, mass):
    """:func:`nodal_mass` of the cells' soil: in a layered soil (``par.density_row``), each cell's fill as the
    lightest soil as heavy (its fill times its density row; an empty cut cell lends the lightest's)."""
    if par.density_row < 0:
        nodal_mass(mesh, cells, par.density, mass)
    else:
        weighed = Cells(cells.phi * cells.q[par.density_row], cells.q, cells.su, cells.strength_factor, cells.solid,
                        cells.open_frac, cells.gap, cells.shared_divergence, cells.hourglass_factor)
        nodal_mass(mesh, weighed, par.density, mass)


@njit(**INLINE)
def squared_speed(v, n):
    """|v|² of node n."""
    speed_sq = 0.0
    for a in range(v.shape[0]):
        speed_sq += v[a, n] * v[a, n]
    return speed_sq


@njit(**PARALLEL)
def kinetic_energy(mass, v):
    """½·Σ m·|v|² over the nodes (J per unit thickness or per radian in 2D), without temporaries; in
    parallel over blocks of :data:`NODE_BLOCK` nodes, the blocks' sums added in block order."""
    n = v.shape[1]
    n_blocks = (n + NODE_BLOCK - 1) // NODE_BLOCK
    parts = np.zeros(n_blocks)
    for b in prange(n_blocks):
        total = 0.0
        for k in range(b * NODE_BLOCK, min(n, (b + 1) * NODE_BLOCK)):
            total += mass[k] * squared_speed(v, k)
        parts[b] = total
    total = 0.0
    for b in range(n_blocks):
        total += parts[b]
    return 0.5 * total


@njit(**PARALLEL)
def largest_speed(v):
    """The largest node speed |v| (m/s), NaN if any is (as NumPy's max: the guards that read it then
    see it); in parallel over blocks of :data:`NODE_BLOCK` nodes."""
    n = v.shape[1]
    n_blocks = (n + NODE_BLOCK - 1) // NODE_BLOCK
    largest = np.zeros(n_blocks)
    for b in prange(n_blocks):
        block_largest = 0.0
        for k in range(b * NODE_BLOCK, min(n, (b + 1) * NODE_BLOCK)):
            speed_sq = squared_speed(v, k)
            if math.isnan(speed_sq):
                block_largest = math.nan
                break
            block_largest = max(block_largest, speed_sq)
        largest[b] = block_largest
    for b in range(n_blocks):
        if math.isnan(largest[b]):
            return math.nan
    return math.sqrt(largest.max()) if n_blocks > 0 else 0.0


@njit(**INLINE)
def update_velocity_range(v, f, mass, gravity, sideways, dt, mass_floor, start, stop):
    """:func:`update_velocities` for the nodes start … stop − 1. One pass per axis: each is a stride-1
    loop the compiler vectorises."""
    dim = v.shape[0]
    up = dim - 1
    for a in range(up):
        va, fa, pull = v[a], f[a], dt * sideways[a]  # gravity along a sloping seabed, once per axis
        for k in range(start, stop):
            m = mass[k]
            va[k] = va[k] + dt * fa[k] / m + pull if m > mass_floor else 0.0
    vu, fu = v[up], f[up]
    momentum_before = 0.0
    momentum_after = 0.0
    for k in range(start, stop):
        m = mass[k]
        momentum_before += m * vu[k]
        vu[k] = vu[k] + dt * (fu[k] / m - gravity) if m > mass_floor else 0.0
        momentum_after += m * vu[k]
    return momentum_before, momentum_after


@njit(**JIT)
def update_velocities(nodes, gravity, sideways, dt, mass_floor):
    """Explicit velocity update v += Δt·(f/m − g·up + ``sideways``) at nodes holding soil (``sideways``:
    gravity along x and y on a sloping seabed, m/s²); empty nodes stop.

    Returns the soil's vertical momentum Σ m·v_up before and after (kg·m/s per unit thickness or
    per radian), which the audit of gravity's work needs."""
    return update_velocity_range(nodes.v, nodes.f, nodes.mass, gravity, sideways, dt, mass_floor, 0, nodes.v.shape[1])


@njit(**JIT)
def horizontal_momentum(nodes, out):
    """The soil's momentum Σ m·v along x and (3D) y into ``out`` (kg·m/s): the audit of the work of
    gravity along a sloping seabed."""
    v, mass = nodes.v, nodes.mass
    for a in range(v.shape[0] - 1):
        total = 0.0
        for k in range(v.shape[1]):
            total += mass[k] * v[a, k]
        out[a] = total


@njit(**PARALLEL)
def zero_in_blocks(values):
    """values[:] = 0 for a node array (axis, node), in parallel over blocks of :data:`NODE_BLOCK` nodes."""
    n = values.shape[1]
    for b in prange((n + NODE_BLOCK - 1) // NODE_BLOCK):
        values[:, b * NODE_BLOCK:min(n, (b + 1) * NODE_BLOCK)] = 0.0


@njit(**PARALLEL)
def update_velocities_in_blocks(nodes, gravity, sideways, dt, mass_floor):
    """:func:`update_velocities` in parallel over blocks of :data:`NODE_BLOCK` nodes, the blocks'
    momenta summed in block order (3D)."""
    n = nodes.v.shape[1]
    n_blocks = (n + NODE_BLOCK - 1) // NODE_BLOCK
    parts = np.zeros((2, n_blocks))
    for b in prange(n_blocks):
        parts[0, b], parts[1, b] = update_velocity_range(nodes.v, nodes.f, nodes.mass, gravity, sideways, dt, mass_floor,
                                                         b * NODE_BLOCK, min(n, (b + 1) * NODE_BLOCK))
    return ordered_sums(parts)


@njit(**JIT)
def apply_fixed(nodes, contact):
    """The boundary conditions: each listed velocity component is held at 0. Returns the change of
    the vertical momentum (kg·m/s)."""
    v, mass = nodes.v, nodes.mass
    up = v.shape[0] - 1
    change = 0.0
    for k in range(len(contact.fixed_node)):
        n, a = contact.fixed_node[k], contact.fixed_axis[k]
        if a == up:
            change -= mass[n] * v[a, n]
        v[a, n] = 0.0
    return change


@njit(**JIT)
def ties_that_hold(contact, nodes, dt, gravity, sideways, mass_floor, body):
    """With contact separation: how much of each tie holds this step (``contact.holding``). All of it
    when the node's free velocity would carry it into the body, not away from the face (no tension),
    and for a tie with no normal (a corner, a staircase) or an empty node; else its ``bond``, the
    share soil against soil (the soil a track's grousers trap), which does not part."""
    v, f, mass, normal, holding = nodes.v, nodes.f, nodes.mass, contact.normal, contact.holding
    dim = v.shape[0]
    up = dim - 1
    for k in range(len(contact.node)):
        n = np.uint64(contact.node[k])  # unsigned: no wraparound check at each access
        m = mass[n]
        held = 1.0
        if m > mass_floor and contact.bond[k] < 1.0:
            vn_free = 0.0  # the free velocity along the normal, from its nonzero components only
            on_face = False
            for a in range(dim):
                nk = normal[k, a]
                if nk != 0.0:
                    on_face = True
                    g = -gravity if a == up else sideways[a]
                    vn_free += (v[a, n] + dt * (f[a, n] / m + g)) * nk
            if on_face and vn_free > normal_speed(body, contact.arm, normal, k):
                held = contact.bond[k]
        holding[k] = held


@njit(**INLINE)
def translation_of(dim, a):
    """The freedom (:data:`dsmv.cel.layout.FREEDOMS`) that translates along the model's axis ``a``."""
    return a if dim == 3 else 2 * a


@njit(**JIT)
def tie_reactions(contact, nodes, gravity, sideways, force, inertia, momentum=False):
    """What the holding tied nodes put on the body, per freedom (:data:`dsmv.cel.layout.FREEDOMS`): their
    force and moment about the centre of gravity (N, N·m; the nodes' forces with their weight, down the
    up axis ``gravity`` and along x and y ``sideways``, m/s²) added
    to ``force``, and the inertia they add to the body's motion (kg, kg·m, kg·m²) added to ``inertia``
    (6 × 6: a node held along its normal n counts m·(nᵀJ)ᵀ(nᵀJ), a fully tied one m·JᵀJ, J its levers).
    With ``momentum`` their momentum and moment of momentum m·v instead of their force (kg·m/s,
    kg·m²/s; ``gravity`` then 0)."""
    f, mass, normal, arm = (nodes.v if momentum else nodes.f), nodes.mass, contact.normal, contact.arm
    dim = f.shape[0]
    up = dim - 1
    freedoms = model_freedoms(dim)
    levers = np.zeros(6)
    for k in range(len(contact.node)):
        share = contact.holding[k]
        if share == 0.0:
            continue
        n = np.uint64(contact.node[k])  # unsigned: no wraparound check at each access
        m = share * mass[n]  # the part of the node the tie holds
        scale = m if momentum else share
        if contact.full[k]:
            for a in range(dim):
                fa = scale * f[a, n] - m * gravity if a == up else scale * f[a, n] + m * sideways[a]
                along = translation_of(dim, a)
                force[along] += fa
                inertia[along, along] += m
                for q in freedoms:
                    if q >= 3:  # a rotation: the force's moment, the node's coupling and its m·r²
                        lq = lever(arm, k, a, q)
                        force[q] += lq * fa
                        inertia[along, q] += m * lq
                        inertia[q, along] += m * lq
                        for p in freedoms:
                            if p >= 3:
                                inertia[q, p] += m * lq * lever(arm, k, a, p)
        else:
            fn = 0.0
            for a in range(up):
                fn += (scale * f[a, n] + m * sideways[a]) * normal[k, a]
            fn += (scale * f[up, n] - m * gravity) * normal[k, up]
            for q in freedoms:
                levers[q] = 0.0
                for a in range(dim):
                    levers[q] += normal[k, a] * lever(arm, k, a, q)
                force[q] += fn * levers[q]
            for q in freedoms:
                for p in freedoms:
                    inertia[q, p] += m * levers[q] * levers[p]


@njit(**JIT)
def catch_up_of_shared_ties(contact, nodes, body, dt, force):
    """What a tie holding a share s of its node (0 < s < 1, :func:`ties_that_hold`) puts on the body by
    closing s of the node's lag behind it this step (:func:`apply_ties`): s·m·(v − V)/dt along the tie
    (N; its moment about the centre of gravity, N·m), added to ``force`` per freedom. With it the body
    meets the whole impulse its tie gives the node, and the two keep their momentum; a whole tie closes
    the lag every step and has none to meet."""
    v, mass, normal, arm = nodes.v, nodes.mass, contact.normal, contact.arm
    dim = v.shape[0]
    freedoms = model_freedoms(dim)
    for k in range(len(contact.node)):
        share = contact.holding[k]
        if share == 0.0 or share == 1.0:
            continue
        n = np.uint64(contact.node[k])  # unsigned: no wraparound check at each access
        rate = share * mass[n] / dt
        if contact.full[k]:
            for a in range(dim):
                fa = rate * (v[a, n] - rigid_velocity(body, arm, k, a))
                for q in freedoms:
                    force[q] += lever(arm, k, a, q) * fa
        else:
            fn = 0.0
            for a in range(dim):
                fn += rate * (v[a, n] - rigid_velocity(body, arm, k, a)) * normal[k, a]
            for q in freedoms:
                for a in range(dim):
                    force[q] += fn * normal[k, a] * lever(arm, k, a, q)


@njit(**JIT)
def apply_ties(contact, nodes, body):
    """A holding tied node's velocity: the body's at its place (full tie), or its own with the normal
    part the body's; a tie that holds a share of its node (:func:`ties_that_hold`) moves it that share
    of the way. Returns the change of the vertical momentum (kg·m/s)."""
    v, mass, normal, arm = nodes.v, nodes.mass, contact.normal, contact.arm
    dim = v.shape[0]
    up = dim - 1
    change = 0.0
    for k in range(len(contact.node)):
        share = contact.holding[k]
        if share == 0.0:
            continue
        n = np.uint64(contact.node[k])  # unsigned: no wraparound check at each access
        v_free = v[up, n]
        if contact.full[k]:
            for a in range(dim):
                target = rigid_velocity(body, arm, k, a)
                v[a, n] = target if share == 1.0 else v[a, n] + share * (target - v[a, n])
        else:
            vn = 0.0
            for a in range(dim):
                vn += v[a, n] * normal[k, a]
            gap = -vn  # the body's normal speed there less the node's
            for a in range(dim):
                gap += rigid_velocity(body, arm, k, a) * normal[k, a]
            gap *= share
            for a in range(dim):
                v[a, n] += gap * normal[k, a]
        change += mass[n] * (v[up, n] - v_free)
    return change


@njit(**INLINE)
def held_kinetic_energy(contact, nodes):
    """The kinetic energy of the nodes the holding ties hold, wholly or in part (J)."""
    v, mass = nodes.v, nodes.mass
    total = 0.0
    for k in range(len(contact.node)):
        if contact.holding[k] > 0.0:
            n = np.uint64(contact.node[k])  # unsigned: no wraparound check at each access
            for a in range(v.shape[0]):
                total += 0.5 * mass[n] * v[a, n] ** 2
    return total


@njit(**INLINE)
def grip_strength(contact, cells, k):
    """The strength gripping tie k (Pa): φ·su averaged over its grip cells. A cell the soil only
    partly fills (at the mudline) grips the face in proportion: counted at full su, the face
    dragged the last wisps of soil down with it and dug a slot along the wall."""
    start, end = contact.grip_start[k], contact.grip_start[k + 1]
    if end == start:
        return 0.0
    su, phi, grip = cells.su.reshape(-1), cells.phi.reshape(-1), contact.grip_cell
    shape = cells.su.shape
    total = 0.0
    for c in range(start, end):
        flat = 0  # the grip cell's index in the flat cell arrays, from its index per axis
        for a in range(grip.shape[1]):
            flat = flat * shape[a] + grip[c, a]
        total += su[flat] * min(phi[flat], 1.0)
    return total / (end - start)


@njit(**INLINE)
def pull_along_face(vx, vy, tx, ty, ux, uy, dw_max, m, dt):
    """A face's capped pull on a tied node of mass m (kg) moving along the face (tx, ty), the body
    moving there at (ux, uy): it takes the node's whole slip speed relative to the body when it can
    (the node sticks), else at most dw_max (m/s), against the slip. Returns the node's new velocity,
    its momentum change m·Δvy, the pull times the slip it leaves (J per s of step, times Δt: 0 when it
    sticks), and the pull's reaction on the body along x and up (N)."""
    w = (vx - ux) * tx + (vy - uy) * ty  # slip speed relative to the body
    dw = -w if abs(w) <= dw_max else (-dw_max if w > 0.0 else dw_max)
    return vx + dw * tx, vy + dw * ty, m * dw * ty, -m * dw * (w + dw), -m * dw * tx / dt, -m * dw * ty / dt


@njit(**INLINE)
def pull_in_face(v, n, normal, k, ux, uy, uz, dw_max, m, dt, reaction):
    """In 3D, the face's capped pull on tied node n: as :func:`pull_along_face`, against the slip's own
    direction in the face (the node's velocity relative to the body's (ux, uy, uz) there, less its
    normal part). Updates ``v``, puts the pull's reaction on the body along each axis (N) in
    ``reaction`` and returns the momentum change m·Δv_up and the pull times the slip it leaves."""
    wx, wy, wz = v[0, n] - ux, v[1, n] - uy, v[2, n] - uz
    un = wx * normal[k, 0] + wy * normal[k, 1] + wz * normal[k, 2]
    wx, wy, wz = wx - un * normal[k, 0], wy - un * normal[k, 1], wz - un * normal[k, 2]
    w = math.sqrt(wx * wx + wy * wy + wz * wz)
    reaction[:] = 0.0
    if w == 0.0:
        return 0.0, 0.0
    scale = -1.0 if w <= dw_max else -dw_max / w  # stick, or the capped change against the slip
    v[0, n] += scale * wx
    v[1, n] += scale * wy
    v[2, n] += scale * wz
    dw = -scale * w  # the change's size
    reaction[0], reaction[1], reaction[2] = -m * scale * wx / dt, -m * scale * wy / dt, -m * scale * wz / dt
    return m * scale * wz, m * dw * (w - dw)


@njit(**JIT)
def adhesion(contact, cells, nodes, body, dt, mass_floor, energy_slip, pull):
    """The faces' capped pull (α·su) on their holding, normally tied nodes: in 2D along the face's
    in-plane tangent, in 3D against the slip's direction in the face. Adds the slip's dissipation to
    ``energy_slip[0]`` (J) and the pull's reaction on the body per freedom (N, N·m) to ``pull``;
    returns the change of the vertical momentum (kg·m/s)."""
    v, mass, normal, arm = nodes.v, nodes.mass, contact.normal, contact.arm
    dim = v.shape[0]
    freedoms = model_freedoms(dim)
    change = 0.0
    reaction = np.zeros(3)
    for k in range(len(contact.node)):
        if contact.full[k] or contact.cap[k] <= 0.0 or contact.holding[k] == 0.0:
            continue
        n = np.uint64(contact.node[k])  # unsigned: no wraparound check at each access
        m = mass[n]
        if m <= mass_floor:
            continue
        dw_max = contact.cap[k] * grip_strength(contact, cells, k) * dt / m
        if dim == 2:
            v[0, n], v[1, n], dp, slip, reaction[0], reaction[1] = pull_along_face(
                v[0, n], v[1, n], -normal[k, 1], normal[k, 0], rigid_velocity(body, arm, k, 0),
                rigid_velocity(body, arm, k, 1), dw_max, m, dt)
        else:
            dp, slip = pull_in_face(v, n, normal, k, rigid_velocity(body, arm, k, 0), rigid_velocity(body, arm, k, 1),
                                    rigid_velocity(body, arm, k, 2), dw_max, m, dt, reaction)
        change += dp
        energy_slip[0] += slip
        for q in freedoms:
            for a in range(dim):
                pull[q] += lever(arm, k, a, q) * reaction[a]
    return change


@njit(**INLINE)
def gather_travel_range(v, u, body, dt, start, stop):
    """:func:`gather_travel` for the nodes start … stop − 1."""
    dim = v.shape[0]
    travel = 0.0
    for a in range(dim):
        va, ua = v[a], u[a]
        shift = body[VELOCITY_SLOTS[translation_of(dim, a)]]
        for k in range(start, stop):
            ua[k] += (va[k] - shift) * dt
            travel = max(travel, abs(ua[k]))
    return travel


@njit(**JIT)
def gather_travel(nodes, body, dt):
    """Each node's travel through the grid, which follows the body's translation (its velocity in
    ``body``; a turn is drawn, not followed), gathered since the last remap; returns the largest
    component (m)."""
    return gather_travel_range(nodes.v, nodes.travel, body, dt, 0, nodes.v.shape[1])


@njit(**PARALLEL)
def gather_travel_in_blocks(nodes, body, dt):
    """:func:`gather_travel` in parallel over blocks of :data:`NODE_BLOCK` nodes (3D); the largest is
    the same in any order."""
    n = nodes.v.shape[1]
    n_blocks = (n + NODE_BLOCK - 1) // NODE_BLOCK
    largest = np.zeros(n_blocks)
    for b in prange(n_blocks):
        largest[b] = gather_travel_range(nodes.v, nodes.travel, body, dt, b * NODE_BLOCK,
                                         min(n, (b + 1) * NODE_BLOCK))
    return largest.max() if n_blocks > 0 else 0.0


@njit(**JIT)
def hand_travel_to_parents(contact, nodes):
    """Before a remap: the face between a split node's cells moves soil with the split node's
    vertical travel, so it takes its parent's place there (the remap sweeps the structured nodes)."""
    u = nodes.travel
    up = u.shape[0] - 1
    for k in range(len(contact.split_node)):
        s = contact.split_node[k]
        u[up, contact.split_parent[k]] = u[up, s]
        for a in range(u.shape[0]):
            u[a, s] = 0.0


@njit(**JIT)
def split_masses(contact, mass, out):
    """The masses (kg) of each split node's parent [k, 0] and of the split node [k, 1]."""
    for k in range(len(contact.split_node)):
        out[k, 0] = mass[contact.split_parent[k]]
        out[k, 1] = mass[contact.split_node[k]]


@njit(**JIT)
def split_mass_kinetic_change(contact, nodes, swept):
    """The sweeps move a parent node's whole shares; the split node takes its part back at the
    velocity it keeps: the kinetic energy that changes hands (J), the remap's too."""
    v, mass = nodes.v, nodes.mass
    total = 0.0
    for k in range(len(contact.split_node)):
        p, s = contact.split_parent[k], contact.split_node[k]
        vp, vs = 0.0, 0.0
        for a in range(v.shape[0]):
            vp += v[a, p] ** 2
            vs += v[a, s] ** 2
        total += 0.5 * ((mass[p] - swept[k, 0]) * vp + (mass[s] - swept[k, 1]) * vs)
    return total
