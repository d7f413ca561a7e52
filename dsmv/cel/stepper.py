"""The compiled time loop: N explicit CEL steps per call, Python steers between calls.

A step (Benson 1992 operator split) in the grid frame that moves with the body:
Lagrangian phase — nodal forces from the cell stresses, the rigid body's motion with the soil
nodes tied to it, explicit velocity update, boundary conditions, stress update — then the
Eulerian phase: the soil state and momentum are carried through the grid by the travel
relative to the grid, in two directional sweeps whose order alternates. The Eulerian phase
waits until some node has travelled ``par.remap_travel`` (a set fraction of a cell): the elastic
step moves the soil only about 1 % of a cell. It is the only place φ changes, so the nodal
masses are computed on entry and after each remap, not every step.

The stages are shared by every dimension (:mod:`dsmv.cel.kernels.nodes`); what is 2D here is the
element kernels (:mod:`dsmv.cel.kernels.plane`), the remap sweeps (:mod:`dsmv.cel.kernels.remap2d`)
and the ghost row of soil entering at the base.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from dsmv.cel.kernels.common import INLINE, JIT
from dsmv.cel.kernels.nodes import (
    adhesion, apply_fixed, apply_ties, gather_travel, hand_travel_to_parents, nodal_mass, rejoin_ties,
    split_mass_kinetic_change, split_masses, tie_reactions, ties_that_hold, update_velocities,
)
from dsmv.cel.kernels.plane import merged_divergence, nodal_forces, update_stress
from dsmv.cel.kernels.remap2d import remap_sweeps, share_merged_fill
from dsmv.cel.layout import (
    B_FCOUNT, B_FRICTION, B_FSUM, B_INFLOW, B_MAXDISP, B_OFFSET, B_REMAP_OFFSET, B_REMAPS, B_STEP, B_TIME, B_VEL,
    SXX, SYY, SZZ, Z0,
)
from dsmv.cel.ledger import (
    E_BODY_GRAV, E_BULK, E_FRICTION, E_GAP_RELEASE, E_HOURGLASS, E_PLASTIC, E_PUSH, E_REMAP_ELASTIC, E_REMAP_KINETIC,
    E_SOIL_GRAV,
)

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
def lagrange_step(mesh, cells, faces, nodes, contact, par, body, energy, law):
    """The Lagrangian phase of one step; returns the soil's force on the body (N) and its old velocity."""
    work = np.zeros(3)
    nodal_forces(mesh, cells, faces, nodes, par, body[B_VEL], work)
    energy[E_HOURGLASS] += work[0] * par.dt
    energy[E_BULK] += work[1] * par.dt
    if par.separation:  # which face ties hold this step: those the soil would otherwise cross
        v_body_next = body[B_VEL] if par.drop else -par.push_velocity
        ties_that_hold(contact, nodes, par.dt, par.gravity, par.mass_floor, v_body_next)
    # the adhesive pull of the last step, the cut cells' arcs
    resistance, v_old = move_body(nodes, contact, par, body, energy, body[B_FRICTION] + work[2])
    momentum_before, momentum_after = update_velocities(nodes, par.gravity, par.dt, par.mass_floor)
    hold_nodes(cells, nodes, contact, par, body, energy, momentum_before, momentum_after)
    merge = contact.merge
    for k in range(merge.shape[0]):  # a sliver and its neighbour change volume as one
        si, sj, ni, nj = merge[k, 0], merge[k, 1], merge[k, 2], merge[k, 3]
        d = merged_divergence(si, sj, ni, nj, mesh, nodes, body[B_VEL], faces, cells.open_frac)
        cells.shared_divergence[si, sj] = d
        cells.shared_divergence[ni, nj] = d
    stress_out = np.zeros(2)  # plastic work, elastic energy released by gap cells (J)
    update_stress(mesh, cells, faces, nodes, par, body[B_VEL], law, stress_out)
    energy[E_PLASTIC] += stress_out[0]
    energy[E_GAP_RELEASE] += stress_out[1]
    body[B_OFFSET] += body[B_VEL] * par.dt
    body[B_TIME] += par.dt
    body[B_STEP] += 1.0
    if -body[B_OFFSET] > body[B_MAXDISP]:
        body[B_MAXDISP] = -body[B_OFFSET]
    return resistance, v_old


@njit(**INLINE)
def refresh_inflow(inflow, par, body):
    """Soil entering at the base: intact and geostatic at its depth halfway through the travel."""
    ghost = inflow.ghost
    for i in range(ghost.shape[1]):
        depth = inflow.depth0[i] - 0.5 * (body[B_REMAP_OFFSET] + body[B_OFFSET])
        ghost[SYY, i] = -par.density * par.gravity * depth
        ghost[SXX, i] = par.k0 * ghost[SYY, i]
        ghost[SZZ, i] = ghost[SXX, i]
        ghost[Z0, i] = depth


@njit(**INLINE)
def remap(mesh, cells, faces, nodes, contact, inflow, par, body, energy, swept):
    """The Eulerian phase: carry soil and momentum through the grid by the gathered travel."""
    if par.inflow:
        refresh_inflow(inflow, par, body)
    hand_travel_to_parents(contact, nodes)
    audit = np.zeros(2)
    first = int(body[B_REMAPS]) % 2  # the sweeps alternate their order
    body[B_INFLOW] += remap_sweeps(mesh, cells, faces, nodes, par, inflow, first, audit)
    energy[E_REMAP_ELASTIC] += audit[0]
    energy[E_REMAP_KINETIC] += audit[1]
    share_merged_fill(cells, contact.merge)
    settle_nodes(mesh, cells, nodes, contact, par, body, energy, swept)


@njit(**INLINE)
def settle_nodes(mesh, cells, nodes, contact, par, body, energy, swept):
    """After the sweeps (any dimension): the nodal masses of the new fills, the split nodes' shares,
    and the tied nodes back with the body (:func:`dsmv.cel.kernels.nodes.rejoin_ties`)."""
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


@njit(**JIT)
def run_steps(n_steps, mesh, cells, faces, nodes, contact, inflow, par, body, energy, law):
    """Advance up to ``n_steps`` steps; return (steps done, exit code).

    ``law`` is the soil law (:class:`~dsmv.cel.layout.SoilLawKernel`); its factor is called only
    when ``par.law_active``, its ``evolve`` updates the law's state variables, the rows of
    ``cells.q`` (and ``inflow.ghost``) beyond NQ_BASE. None for a law that does neither (Tresca):
    the loop is then compiled without the calls. The nodal masses come with the state: they change only
    where soil moves through the grid, so the set-up computes them and each remap renews them
    (:func:`settle_nodes`).
    """
    swept = np.zeros((len(contact.split_node), 2))
    for step in range(n_steps):
        resistance, v_old = lagrange_step(mesh, cells, faces, nodes, contact, par, body, energy, law)
        # The soil moves a small fraction of a cell per step (the step is set by the elastic wave
        # speed, not by the flow): each node's travel through the grid is gathered, and the remap
        # runs once some node has gone par.remap_travel (0: every step). Gathered before the
        # exits, so a run that goes on keeps this step's.
        travel = gather_travel(nodes, body[B_VEL], par.dt) if par.remap else 0.0
        if not (math.isfinite(body[B_VEL]) and math.isfinite(resistance)):
            return step + 1, NOT_FINITE
        if travel > par.cell_size:
            return step + 1, OUTRAN
        if par.remap and travel >= par.remap_travel:  # before the rest check: the remap's tied nodes slow the body
            remap(mesh, cells, faces, nodes, contact, inflow, par, body, energy, swept)
        if par.drop and body[B_VEL] >= 0.0 and v_old < 0.0:
            return step + 1, AT_REST
    return n_steps, RUNNING
