"""The compiled 3D time loop: N explicit CEL steps per call, Python steers between calls.

The step of :mod:`dsmv.cel.stepper` on hexahedra: nodal forces (:mod:`dsmv.cel.kernels.elements3d`),
the body's motion and the tied nodes (the shared stages), the explicit velocity update (in parallel
over blocks of nodes), the boundary conditions, the stress update, which computes the next step's
nodal forces in the same pass over the cells (they need the new stress and the velocities it used;
reading each cell once instead of twice); then, once some node has travelled ``par.remap_travel``,
the Eulerian phase in three directional sweeps whose order alternates (x, y, z, then z, y, x)
(:mod:`dsmv.cel.kernels.remap3d`), with soil entering at the base as the grid moves down with the body,
and at the sides while it slides.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from dsmv.cel.kernels.common import INLINE, JIT
from dsmv.cel.kernels.elements3d import N_SLAB_SUMS, nodal_forces, update_stress_and_forces
from dsmv.cel.kernels.nodes import gather_travel_in_blocks, ties_that_hold, update_velocities_in_blocks
from dsmv.cel.kernels.remap3d import remap_sweeps
from dsmv.cel.layout import (B_BESIDE_MX, B_BESIDE_MY, B_BESIDE_MZ, B_BESIDE_N, B_BESIDE_X, B_BESIDE_Y, B_BULK_W,
                              B_FORCES_AHEAD, B_HOURGLASS_W, B_INFLOW, B_REMAPS, B_VEL, B_VX, B_VY, ROWS_3D)
from dsmv.cel.ledger import E_BULK, E_HOURGLASS, E_PLASTIC
from dsmv.cel.stepper import (
    AT_REST, RUNNING, advance_clock, came_to_rest, hold_nodes, momentum_along_the_slope, move_body, prepare_remap,
    remap_due, settle_nodes, step_failed,
)


@njit(**INLINE)
def grid_velocity(body):
    """The grid's velocity along x, y and z (m/s): it follows the body's translation."""
    return body[B_VX], body[B_VY], body[B_VEL]


@njit(**INLINE)
def keep_ahead(par, body, work, start):
    """The node forces' companions, kept for the step that uses the forces: the hourglass and
    bulk-viscosity power (W), and the force of the cells beside the body on it (N; x, y, z) and its
    moment about the centre of gravity (N·m), from ``work[start:]`` (the moment there about the grid's
    origin, the middle of the base, which the grid keeps as it follows the body: the centre of gravity
    sits at −``par.base_*`` from it)."""
    body[B_HOURGLASS_W], body[B_BULK_W] = work[start], work[start + 1]
    fx, fy, fz = work[start + 2], work[start + 3], work[start + 4]
    cx, cy, cz = -par.base_x, -par.base_y, -par.base_z
    body[B_BESIDE_X], body[B_BESIDE_Y], body[B_BESIDE_N] = fx, fy, fz
    body[B_BESIDE_MX] = work[start + 5] - (cy * fz - cz * fy)
    body[B_BESIDE_MY] = work[start + 6] - (cz * fx - cx * fz)
    body[B_BESIDE_MZ] = work[start + 7] - (cx * fy - cy * fx)


@njit(**INLINE)
def lagrange_step(mesh, cells, nodes, contact, par, body, energy, law):
    """One step; returns the soil's force on the body (N) and the body's old velocity. The node forces
    come from the last step's stress update (:func:`~dsmv.cel.kernels.elements3d.update_stress_and_forces`),
    or are computed here when there are none ahead (the first step of a run, after a remap)."""
    if body[B_FORCES_AHEAD] == 0.0:
        work = np.zeros(N_SLAB_SUMS - 1)
        nodal_forces(mesh, cells, nodes, par, grid_velocity(body), contact.split_parent, law, work)
        keep_ahead(par, body, work, 0)
    energy[E_HOURGLASS] += body[B_HOURGLASS_W] * par.dt
    energy[E_BULK] += body[B_BULK_W] * par.dt
    if par.separation:  # which face ties hold this step: those the soil would otherwise cross
        ties_that_hold(contact, nodes, par.dt, par.gravity, (par.gravity_x, par.gravity_y), par.mass_floor, body)
    # the mean stress on the closed faces (the adhesive pull of the last step is the body's)
    beside = (body[B_BESIDE_X], body[B_BESIDE_Y], body[B_BESIDE_N], body[B_BESIDE_MX], body[B_BESIDE_MY],
              body[B_BESIDE_MZ])
    resistance, v_old = move_body(nodes, contact, par, body, energy, beside)
    sideways_before = momentum_along_the_slope(nodes, par)
    momentum_before, momentum_after = update_velocities_in_blocks(nodes, par.gravity, (par.gravity_x, par.gravity_y),
                                                                  par.dt, par.mass_floor)
    hold_nodes(cells, nodes, contact, par, body, energy, momentum_before, momentum_after, sideways_before)
    work = np.zeros(N_SLAB_SUMS)
    update_stress_and_forces(mesh, cells, nodes, par, grid_velocity(body), contact.split_parent, law, work)
    energy[E_PLASTIC] += work[0]
    keep_ahead(par, body, work, 1)
    body[B_FORCES_AHEAD] = 1.0
    advance_clock(par, body)
    return resistance, v_old


INFLOW_ROWS = ROWS_3D.inflow  # the ghost state's rows the inflow sets


@njit(**INLINE)
def remap(mesh, cells, faces, nodes, contact, inflow, par, body, energy, swept):
    """The Eulerian phase: carry soil and momentum through the grid by the gathered travel."""
    prepare_remap(inflow, contact, nodes, par, body, INFLOW_ROWS)
    audit = np.zeros(2)
    reverse = int(body[B_REMAPS]) % 2 == 1  # the sweeps alternate their order: x, y, z then z, y, x
    body[B_INFLOW] += remap_sweeps(mesh, cells, faces, nodes, par, inflow, reverse, audit)
    settle_nodes(mesh, cells, nodes, contact, par, body, energy, swept, audit)
    body[B_FORCES_AHEAD] = 0.0  # the soil and its momentum have moved: the forces ahead no longer hold


@njit(**JIT)
def run_steps(n_steps, mesh, cells, faces, nodes, contact, inflow, par, body, energy, law):
    """Advance up to ``n_steps`` steps; return (steps done, exit code) as :func:`dsmv.cel.stepper2d.run_steps`
    (the nodal masses come with the state)."""
    swept = np.zeros((len(contact.split_node), 2))
    for step in range(n_steps):
        resistance, v_old = lagrange_step(mesh, cells, nodes, contact, par, body, energy, law)
        travel = gather_travel_in_blocks(nodes, body, par.dt) if par.remap else 0.0
        code = step_failed(par, body, resistance, travel)
        if code != RUNNING:
            return step + 1, code
        if remap_due(par, travel):
            remap(mesh, cells, faces, nodes, contact, inflow, par, body, energy, swept)
        if came_to_rest(par, body, v_old):
            return step + 1, AT_REST
    return n_steps, RUNNING
