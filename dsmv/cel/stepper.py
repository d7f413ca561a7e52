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

from dsmv.cel.kernels.common import INLINE
from dsmv.cel.kernels.nodes import (
    adhesion, apply_fixed, apply_ties, hand_travel_to_parents, nodal_mass, rejoin_ties, split_mass_kinetic_change, split_masses, tie_reactions,
)
from dsmv.cel.layout import B_FCOUNT, B_FRICTION, B_FSUM, B_MAXDISP, B_OFFSET, B_REMAP_OFFSET, B_REMAPS, B_STEP, B_TIME, B_VEL
from dsmv.cel.ledger import E_BODY_GRAV, E_FRICTION, E_PUSH, E_REMAP_ELASTIC, E_REMAP_KINETIC, E_SOIL_GRAV

# exit codes
# (OUTRAN: some node went a whole core cell between remaps, which only an unstable step does:
# the remap's fluxes carry at most a cell, so it is not run on such a state)
RUNNING, AT_REST, NOT_FINITE, OUTRAN = 0, 1, 2, 3



@njit(**INLINE)
def move_body(nodes, contact, par, body, energy, soil_on_nodes):
    """The rigid body's step: free fall against the soil's force and the tied nodes' inertia, or the
    push's constant speed. Returns the soil's force on the body (N, up +) and its old velocity."""
    force, tied_mass = tie_reactions(contact, nodes, par.gravity)
    soil_on_nodes += force
    v_old = body[B_VEL]
    if par.drop:
        accel = (soil_on_nodes - par.body_weight) / (par.body_mass + tied_mass)
        body[B_VEL] = v_old + par.dt * accel
        energy[E_BODY_GRAV] += par.body_weight * (-0.5 * (v_old + body[B_VEL])) * par.dt
    else:
        accel = 0.0
        body[B_VEL] = -par.push_velocity
    resistance = soil_on_nodes - tied_mass * accel
    if not par.drop:
        energy[E_PUSH] += -resistance * body[B_VEL] * par.dt
    body[B_FSUM] += resistance
    body[B_FCOUNT] += 1.0
    return resistance, v_old


@njit(**INLINE)
def hold_nodes(cells, nodes, contact, par, body, energy, momentum_before, momentum_after):
    """After the explicit velocity update (which returned the soil's vertical momentum before and
    after it): the boundary conditions, the ties and the faces' adhesive pull; the work of gravity
    on the soil from its vertical momentum before and after all of them."""
    momentum_after += apply_fixed(nodes, contact)
    momentum_after += apply_ties(contact, nodes, body[B_VEL])
    slip = np.zeros(1)
    change, body[B_FRICTION] = adhesion(contact, cells, nodes, body[B_VEL], par.dt, par.mass_floor, slip)
    momentum_after += change
    energy[E_FRICTION] += slip[0]
    energy[E_SOIL_GRAV] += -par.gravity * par.dt * 0.5 * (momentum_before + momentum_after)


@njit(**INLINE)
def advance_clock(par, body):
    """The end of a step's Lagrangian phase: the grid moves on with the body, time and the step count
    advance, and the deepest sinkage is kept."""
    body[B_OFFSET] += body[B_VEL] * par.dt
    body[B_TIME] += par.dt
    body[B_STEP] += 1.0
    if -body[B_OFFSET] > body[B_MAXDISP]:
        body[B_MAXDISP] = -body[B_OFFSET]


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
    """A dropped body that was moving down and no longer does."""
    return par.drop and body[B_VEL] >= 0.0 and v_old < 0.0


@njit(**INLINE)
def prepare_remap(inflow, contact, nodes, par, body, rows):
    """Before the sweeps: the soil entering at the base, intact and geostatic at its depth halfway
    through the travel (``rows``: the ghost state's vertical stress, its two horizontal ones and z0),
    and the split nodes' travel handed to their parents."""
    if par.inflow:
        depth0 = inflow.depth0.ravel()
        ghost = inflow.ghost.reshape((inflow.ghost.shape[0], depth0.size))
        vertical, horizontal, other, z0 = rows
        for c in range(depth0.size):
            depth = depth0[c] - 0.5 * (body[B_REMAP_OFFSET] + body[B_OFFSET])
            ghost[vertical, c] = -par.density * par.gravity * depth
            ghost[horizontal, c] = par.k0 * ghost[vertical, c]
            ghost[other, c] = ghost[horizontal, c]
            ghost[z0, c] = depth
    hand_travel_to_parents(contact, nodes)


@njit(**INLINE)
def settle_nodes(mesh, cells, nodes, contact, par, body, energy, swept, audit):
    """After the sweeps (any dimension), which changed the elastic and kinetic energy by ``audit``
    (J): the nodal masses of the new fills, the split nodes' shares, and the tied nodes back with the
    body (:func:`dsmv.cel.kernels.nodes.rejoin_ties`)."""
    energy[E_REMAP_ELASTIC] += audit[0]
    energy[E_REMAP_KINETIC] += audit[1]
    nodes.travel[:] = 0.0
    split_masses(contact, nodes.mass, swept)
    nodal_mass(mesh, cells, par.density, nodes.mass)
    energy[E_REMAP_KINETIC] += split_mass_kinetic_change(contact, nodes, swept)
    rejoined = np.zeros(2)
    body[B_VEL] = rejoin_ties(contact, nodes, body[B_VEL], par.body_mass, par.drop, rejoined)
    energy[E_REMAP_KINETIC] += rejoined[0]
    energy[E_PUSH] += rejoined[1]
    body[B_REMAP_OFFSET] = body[B_OFFSET]
    body[B_REMAPS] += 1.0
