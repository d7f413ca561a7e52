"""The compiled time loop's stages that know no dimension, and its exit codes.

A step (Benson 1992 operator split) in the grid frame that moves with the body: Lagrangian phase —
nodal forces from the cell stresses, the rigid body's motion with the soil nodes tied to it
(:func:`move_body`), explicit velocity update, boundary conditions and ties (:func:`hold_nodes`),
stress update — then the Eulerian phase: the soil state and momentum are carried through the grid
by the travel relative to the grid, in directional sweeps whose order alternates, after which the
nodes take the new fills (:func:`settle_nodes`). The Eulerian phase waits until some node has
travelled ``par.remap_travel`` (a set fraction of a cell): the elastic step moves the soil only
about 1 % of a cell. It is the only place φ changes, so the nodal masses are computed on entry and
after each remap, not every step.

Each dimension's loop (:mod:`dsmv.cel.stepper2d`, :mod:`dsmv.cel.stepper3d`) calls these stages
around its element kernels and remap sweeps; the node and contact stages they call are
:mod:`dsmv.cel.kernels.nodes`'.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from dsmv.cel.kernels.common import INLINE, JIT, soil_column
from dsmv.cel.kernels.nodes import (
    adhesion, apply_fixed, apply_ties, catch_up_of_shared_ties, hand_travel_to_parents, held_kinetic_energy,
    model_freedoms, nodal_mass_of_soil, horizontal_momentum, split_mass_kinetic_change, split_masses, tie_reactions,
)
from dsmv.cel.layout import (
    B_FCOUNT, B_FELL, B_MAXDISP, B_MAXEDGE, B_MAXROT, B_MAXSLIDE, B_OFFSET, B_OFFSET_X, B_OFFSET_Y, B_REMAP_OFFSET,
    B_REMAPS, B_ROT_X, B_ROT_Y, B_ROT_Z, B_SINKAGE, B_STEP, B_TIME, B_VEL, FORCE_SLOTS, POSE_SLOTS, PULL_SLOTS,
    VELOCITY_SLOTS,
)
from dsmv.cel.ledger import E_BODY_GRAV, E_FRICTION, E_PUSH, E_REMAP_ELASTIC, E_REMAP_KINETIC, E_SOIL_GRAV

# exit codes
# (OUTRAN: some node went a whole core cell between remaps, which only an unstable step does:
# the remap's fluxes carry at most a cell, so it is not run on such a state)
RUNNING, AT_REST, NOT_FINITE, OUTRAN = 0, 1, 2, 3



@njit(**INLINE)
def is_free(par, q):
    """Whether the body's freedom q (:data:`~dsmv.cel.layout.FREEDOMS`) moves under the soil's reaction;
    a freedom that is not keeps the speed it was given (a push's, or 0: held)."""
    return (par.free >> q) & 1 == 1


@njit(**INLINE)
def body_inertia(par, q):
    """The body's own inertia along freedom q: its mass (kg) for a translation, its rotational inertia
    about the centre of gravity (kg·m²) for a rotation."""
    if q < 3:
        return par.body_mass
    return par.inertia_x if q == 3 else (par.inertia_y if q == 4 else par.inertia_z)


@njit(**INLINE)
def solve_free(matrix, rhs, free, n_free):
    """Solve the symmetric positive definite system over the ``n_free`` freedoms listed first in
    ``free`` in place (Gaussian elimination, no pivoting: the body's mass matrix dominates); the
    solution overwrites ``rhs`` at those indices."""
    for i in range(n_free):
        qi = free[i]
        for j in range(i + 1, n_free):
            qj = free[j]
            factor = matrix[qj, qi] / matrix[qi, qi]
            for l in range(i, n_free):
                matrix[qj, free[l]] -= factor * matrix[qi, free[l]]
            rhs[qj] -= factor * rhs[qi]
    for i in range(n_free - 1, -1, -1):
        qi = free[i]
        total = rhs[qi]
        for j in range(i + 1, n_free):
            total -= matrix[qi, free[j]] * rhs[free[j]]
        rhs[qi] = total / matrix[qi, qi]


@njit(**INLINE)
def body_weight(par, q):
    """The body's weight along freedom q (N, up +): down the up axis, and on a sloping seabed along it."""
    if q == 2:
        return -par.body_weight
    if q == 0:
        return par.weight_x
    return par.weight_y if q == 1 else 0.0


@njit(**INLINE)
def move_body(nodes, contact, par, body, energy, beside):
    """The rigid body's step. Its free freedoms (:func:`is_free`) move under its wet weight, the soil's
    force and moment on it and the inertia of the nodes tied to it (one linear system over them); the
    others keep their speed, the push supplying the work. ``beside``: the soil's force and moment on the
    body that no tie carries, per freedom (N along x, y and z, up +; N·m about the centre of gravity:
    the cut cells' arcs, the closed faces'). Adds the soil's
    reaction per freedom to the chunk's sums; returns the vertical one (N, up +) and the old vertical
    velocity."""
    force = np.zeros(6)
    inertia = np.zeros((6, 6))
    tie_reactions(contact, nodes, par.gravity, (par.gravity_x, par.gravity_y), force, inertia)
    catch_up_of_shared_ties(contact, nodes, body, par.dt, force)
    freedoms = model_freedoms(nodes.v.shape[0])
    free = np.empty(6, dtype=np.int64)
    n_free = 0
    for q in freedoms:
        force[q] = (body[PULL_SLOTS[q]] + beside[q]) + force[q]
        if is_free(par, q):
            free[n_free] = q
            n_free += 1
    v_old = body[B_VEL]
    accel = np.zeros(6)
    if n_free > 0:
        matrix = inertia.copy()
        for i in range(n_free):
            q = free[i]
            matrix[q, q] = body_inertia(par, q) + matrix[q, q]
            accel[q] = force[q] + body_weight(par, q)
        solve_free(matrix, accel, free, n_free)
    resistance = 0.0
    for q in freedoms:
        reaction = force[q]  # the soil's, less the tied nodes' share of the body's acceleration
        for p in freedoms:
            reaction -= inertia[q, p] * accel[p]
        slot = VELOCITY_SLOTS[q]
        if is_free(par, q):
            speed_old = body[slot]
            body[slot] = speed_old + par.dt * accel[q]
            if q < 3:
                energy[E_BODY_GRAV] += body_weight(par, q) * (0.5 * (speed_old + body[slot])) * par.dt
        else:
            energy[E_PUSH] += -reaction * body[slot] * par.dt
        body[FORCE_SLOTS[q]] += reaction
        if q == 2:
            resistance = reaction
    body[B_FCOUNT] += 1.0
    return resistance, v_old


@njit(**JIT)
def rejoin_ties(contact, nodes, par, body, energy_out):
    """The body and the soil nodes its holding ties hold become one rigid unit, and the body pays for it.

    After a remap: the remap carries momentum into and out of the tied nodes' dual cells, so it leaves
    them off the body's velocity. Set back to it for free, they would gain momentum from nothing: an
    energy source (5 % of the energy put in by a 10 m/s landing on a quarter plate four cells wide).
    At a drop's touchdown: the soil at rest meets the falling body. Either way an inelastic collision:
    the free freedoms take the velocities that keep the unit's momentum and moment of momentum,
    (M + A)·V = M·V₀ + Σ m·Jᵀv, A the tied nodes' inertia (a normal tie counts along its normal, as
    in :func:`tie_reactions`); the others keep their speed, and the push (or the hold) supplies the
    impulse. Adds the kinetic energy change less the push's work (−the collision's loss, J) to
    ``energy_out[0]`` and the push's work (J) to ``energy_out[1]``."""
    freedoms = model_freedoms(nodes.v.shape[0])
    before, after, inertia = np.zeros(6), np.zeros(6), np.zeros((6, 6))
    tie_reactions(contact, nodes, 0.0, (0.0, 0.0), before, inertia, True)
    speed_old = np.zeros(6)
    free = np.empty(6, dtype=np.int64)
    n_free = 0
    for q in freedoms:
        speed_old[q] = body[VELOCITY_SLOTS[q]]
        if is_free(par, q):
            free[n_free] = q
            n_free += 1
    kinetic = -held_kinetic_energy(contact, nodes)
    if n_free > 0:
        matrix = inertia.copy()
        shared = np.zeros(6)
        for i in range(n_free):
            q = free[i]
            own = body_inertia(par, q)
            matrix[q, q] = own + matrix[q, q]
            shared[q] = own * speed_old[q] + before[q]
            for p in freedoms:
                if not is_free(par, p):
                    shared[q] -= inertia[q, p] * speed_old[p]
        solve_free(matrix, shared, free, n_free)
        for i in range(n_free):
            q = free[i]
            body[VELOCITY_SLOTS[q]] = shared[q]
            kinetic += 0.5 * body_inertia(par, q) * (shared[q] ** 2 - speed_old[q] ** 2)
    apply_ties(contact, nodes, body)
    kinetic += held_kinetic_energy(contact, nodes)
    tie_reactions(contact, nodes, 0.0, (0.0, 0.0), after, np.zeros((6, 6)), True)
    push_work = 0.0
    for q in freedoms:
        if not is_free(par, q):
            push_work += (after[q] - before[q]) * speed_old[q]
    energy_out[0] += kinetic - push_work
    energy_out[1] += push_work


@njit(**INLINE)
def momentum_along_the_slope(nodes, par):
    """The soil's momentum along x and y on a sloping seabed (kg·m/s; zeros on a level one, unsummed):
    with the same after the step, the work of gravity along the slope (:func:`hold_nodes`)."""
    momentum = np.zeros(2)
    if par.sloped:
        horizontal_momentum(nodes, momentum)
    return momentum


@njit(**INLINE)
def hold_nodes(cells, nodes, contact, par, body, energy, momentum_before, momentum_after, sideways_before):
    """After the explicit velocity update (which returned the soil's vertical momentum before and
    after it): the boundary conditions, the ties and the faces' adhesive pull; the work of gravity
    on the soil from its vertical momentum before and after all of them, and on a sloping seabed from
    its momentum along x and y (``sideways_before``: before the update, :func:`horizontal_momentum`)."""
    momentum_after += apply_fixed(nodes, contact)
    momentum_after += apply_ties(contact, nodes, body)
    slip = np.zeros(1)
    pull = np.zeros(6)
    momentum_after += adhesion(contact, cells, nodes, body, par.dt, par.mass_floor, slip, pull)
    for q in model_freedoms(nodes.v.shape[0]):
        body[PULL_SLOTS[q]] = pull[q]
    energy[E_FRICTION] += slip[0]
    energy[E_SOIL_GRAV] += -par.gravity * par.dt * 0.5 * (momentum_before + momentum_after)
    if par.sloped:
        after = momentum_along_the_slope(nodes, par)
        energy[E_SOIL_GRAV] += par.dt * 0.5 * (par.gravity_x * (sideways_before[0] + after[0])
                                               + par.gravity_y * (sideways_before[1] + after[1]))


@njit(cache=True)
def turned_base(angle_x, angle_y, base_x, base_y, base_z, half_x, half_y):
    """How the base of a body turned by (``angle_x``, ``angle_y``) (rad; R = Rz·Ry·Rx, :meth:`Pose.turned`,
    whose last row, (−sin θy, cos θy·sin θx, cos θy·cos θx), a turn about z leaves alone) about its
    centre of gravity sits (m): the rise of the middle of its base (at ``base_*`` from the centre of
    gravity) and how far its lowest corner (``half_x``, ``half_y`` from the middle) lies below the middle."""
    sx, cx, sy, cy = math.sin(angle_x), math.cos(angle_x), math.sin(angle_y), math.cos(angle_y)
    rise = -sy * base_x + cy * sx * base_y + (cy * cx - 1.0) * base_z
    return rise, half_x * abs(sy) + half_y * abs(cy * sx)


@njit(**INLINE)
def advance_clock(par, body):
    """The end of a step's Lagrangian phase: the body's pose and the grid (which follows its vertical
    motion) move on, time and the step count advance, and the deepest sinkage (of the middle of the
    base, and of its lowest point), the largest rotation and the largest horizontal displacement are
    kept."""
    for q in range(6):
        body[POSE_SLOTS[q]] += body[VELOCITY_SLOTS[q]] * par.dt
    body[B_TIME] += par.dt
    body[B_STEP] += 1.0
    # the middle of the base moves with the centre of gravity and as it turns about it; its lowest corner
    # lies lower by the turn's lift across the base
    rise, lift = turned_base(body[B_ROT_X], body[B_ROT_Y], par.base_x, par.base_y, par.base_z, par.base_half_x,
                             par.base_half_y)
    sinkage = -(body[B_OFFSET] + rise)
    body[B_SINKAGE] = sinkage
    if sinkage > body[B_MAXDISP]:
        body[B_MAXDISP] = sinkage
    body[B_MAXEDGE] = max(body[B_MAXEDGE], sinkage + lift)
    rotation = math.sqrt(body[B_ROT_X] ** 2 + body[B_ROT_Y] ** 2 + body[B_ROT_Z] ** 2)
    body[B_MAXROT] = max(body[B_MAXROT], rotation)
    body[B_MAXSLIDE] = max(body[B_MAXSLIDE], math.sqrt(body[B_OFFSET_X] ** 2 + body[B_OFFSET_Y] ** 2))


@njit(**INLINE)
def step_failed(par, body, resistance, travel):
    """The exit code of a step that went wrong, else RUNNING: a body velocity or force that is not
    finite, or a node that travelled more than a core cell since the last remap (the remap's fluxes
    carry at most a cell, so it is not run on such a state)."""
    if not (math.isfinite(body[B_VEL]) and math.isfinite(resistance)):
        return NOT_FINITE
    if travel > par.cell_size:
        return OUTRAN
    return RUNNING


@njit(**INLINE)
def remap_due(par, travel):
    """Whether the Eulerian phase runs now: some node has gone ``par.remap_travel`` (0: every step).
    Checked before the rest check: the remap's tied nodes slow the body."""
    return par.remap and travel >= par.remap_travel


@njit(**INLINE)
def came_to_rest(par, body, v_old):
    """A dropped body that was moving down and no longer does. One that may slide or turn (a drift
    outlasts the fall) is at rest once, its fall stopped before, it also slides and turns no faster than
    ``par.rest_speed`` (its edge's speed for a turn) while its fall stops again or it moves up or down
    no faster either."""
    stopped_now = par.drop and body[B_VEL] >= 0.0 and v_old < 0.0
    if stopped_now:
        body[B_FELL] = 1.0
    if body[B_FELL] == 0.0 or not (stopped_now or abs(body[B_VEL]) <= par.rest_speed):
        return False
    for q in range(6):
        if q != 2 and is_free(par, q):
            speed = abs(body[VELOCITY_SLOTS[q]]) * (1.0 if q < 3 else par.base_half_x + par.base_half_y)
            if speed > par.rest_speed:
                return False
    return True


@njit(**INLINE)
def geostatic_ghost(ghost, c, depth, half, par, rows, fill=1.0):
    """Column c of a ghost state: intact soil at rest under its weight at ``depth`` (m; ``rows``: the
    vertical stress, its two horizontal ones, z0, and the shear stresses on the horizontal planes along
    x and y, −1 where the model has none), as an infinite slope on a sloping seabed, the shear of a layer
    ``fill`` full over its fill (:func:`dsmv.cel.state.geostatic_state`); a layered soil's, as the cells
    weigh soil ``depth`` ± ``half`` (m) (:func:`~dsmv.cel.kernels.common.soil_column`)."""
    vertical, horizontal, other, z0, shear_x, shear_y = rows
    weighed = depth
    if par.density_row >= 0:
        weighed, ghost[par.density_row, c] = soil_column(par.density_top, par.density_intercept, par.density_ratio,
                                                          max(depth - half, 0.0), depth + half)
    ghost[vertical, c] = -par.density * par.gravity * weighed
    ghost[horizontal, c] = par.k0 * ghost[vertical, c]
    ghost[other, c] = ghost[horizontal, c]
    ghost[z0, c] = depth
    if par.sloped:
        ghost[shear_x, c] = par.density * par.gravity_x * weighed / fill
        if shear_y >= 0:
            ghost[shear_y, c] = par.density * par.gravity_y * weighed / fill


@njit(**INLINE)
def prepare_remap(inflow, contact, nodes, par, body, rows):
    """Before the sweeps: the soil entering at the base and, while the body slides, at the sides,
    intact and geostatic at its depth halfway through the travel (``rows``: the ghost state's vertical
    stress, its two horizontal ones and z0), and the split nodes' travel handed to their parents."""
    if par.inflow:
        sunk = 0.5 * (body[B_REMAP_OFFSET] + body[B_OFFSET])  # the grid's vertical offset, halfway (m, up +)
        depth0 = inflow.depth0.ravel()
        ghost = inflow.ghost.reshape((inflow.ghost.shape[0], depth0.size))
        levels, fill = inflow.levels, inflow.side_fill
        for c in range(depth0.size):  # the cells below the grid's base, as tall as its lowest
            geostatic_ghost(ghost, c, depth0[c] - sunk, 0.5 * (levels[1] - levels[0]), par, rows)
        mudline = inflow.mudline - sunk  # in the grid, which went down with the body
        for layer in range(fill.size):  # as dsmv.cel.state.layers_below
            size = levels[layer + 1] - levels[layer]
            fill[layer] = min(max((mudline - levels[layer]) / size, 0.0), 1.0)
            centre = 0.5 * (levels[layer] + levels[layer + 1])
            geostatic_ghost(inflow.side, layer, mudline - centre if fill[layer] >= 1.0 else 0.5 * fill[layer] * size,
                            0.5 * fill[layer] * size, par, rows, max(fill[layer], 1e-12))
    hand_travel_to_parents(contact, nodes)


@njit(**INLINE)
def settle_nodes(mesh, cells, nodes, contact, par, body, energy, swept, audit):
    """After the sweeps (any dimension), which changed the elastic and kinetic energy by ``audit``
    (J): the nodal masses of the new fills, the split nodes' shares, and the tied nodes back with the
    body (:func:`rejoin_ties`)."""
    energy[E_REMAP_ELASTIC] += audit[0]
    energy[E_REMAP_KINETIC] += audit[1]
    nodes.travel[:] = 0.0
    split_masses(contact, nodes.mass, swept)
    nodal_mass_of_soil(mesh, cells, par, nodes.mass)
    energy[E_REMAP_KINETIC] += split_mass_kinetic_change(contact, nodes, swept)
    rejoined = np.zeros(2)
    rejoin_ties(contact, nodes, par, body, rejoined)
    energy[E_REMAP_KINETIC] += rejoined[0]
    energy[E_PUSH] += rejoined[1]
    body[B_REMAP_OFFSET] = body[B_OFFSET]
    body[B_REMAPS] += 1.0
