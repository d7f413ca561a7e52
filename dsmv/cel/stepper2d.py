"""The compiled 2D time loop: N explicit CEL steps per call, Python steers between calls.

The step of :mod:`dsmv.cel.stepper` on Q4 cells: nodal forces and the stress update
(:mod:`dsmv.cel.kernels.elements2d`), the merged slivers of a cut body, the remap in two directional
sweeps whose order alternates (:mod:`dsmv.cel.kernels.remap2d`), and the ghost row of soil entering
at the base; the body's motion, the node stages and the exit checks are the shared ones.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from dsmv.cel.kernels.common import INLINE, JIT
from dsmv.cel.kernels.elements2d import merged_divergence, nodal_forces, update_stress
from dsmv.cel.kernels.nodes import gather_travel, ties_that_hold, update_velocities
from dsmv.cel.kernels.remap2d import remap_sweeps, share_merged_fill
from dsmv.cel.layout import B_INFLOW, B_REMAPS, B_VEL, ROWS_2D
from dsmv.cel.ledger import E_BULK, E_GAP_RELEASE, E_HOURGLASS, E_PLASTIC
from dsmv.cel.stepper import (
    AT_REST, RUNNING, advance_clock, came_to_rest, hold_nodes, momentum_along_the_slope, move_body, prepare_remap,
    remap_due, settle_nodes, step_failed,
)


@njit(**INLINE)
def lagrange_step(mesh, cells, faces, nodes, contact, par, body, energy, law):
    """The Lagrangian phase of one step; returns the soil's force on the body (N) and its old velocity."""
    work = np.zeros(3)
    nodal_forces(mesh, cells, faces, nodes, par, body[B_VEL], work)
    energy[E_HOURGLASS] += work[0] * par.dt
    energy[E_BULK] += work[1] * par.dt
    if par.separation:  # which face ties hold this step: those the soil would otherwise cross
        ties_that_hold(contact, nodes, par.dt, par.gravity, (par.gravity_x, par.gravity_y), par.mass_floor, body)
    # the cut cells' arcs (the adhesive pull of the last step is the body's)
    resistance, v_old = move_body(nodes, contact, par, body, energy, (0.0, 0.0, work[2], 0.0, 0.0, 0.0))
    sideways_before = momentum_along_the_slope(nodes, par)
    momentum_before, momentum_after = update_velocities(nodes, par.gravity, (par.gravity_x, par.gravity_y), par.dt,
                                                        par.mass_floor)
    hold_nodes(cells, nodes, contact, par, body, energy, momentum_before, momentum_after, sideways_before)
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
    advance_clock(par, body)
    return resistance, v_old


INFLOW_ROWS = ROWS_2D.inflow  # the ghost state's rows the inflow sets


@njit(**INLINE)
def remap(mesh, cells, faces, nodes, contact, inflow, par, body, energy, swept):
    """The Eulerian phase: carry soil and momentum through the grid by the gathered travel."""
    prepare_remap(inflow, contact, nodes, par, body, INFLOW_ROWS)
    audit = np.zeros(2)
    first = int(body[B_REMAPS]) % 2  # the sweeps alternate their order
    body[B_INFLOW] += remap_sweeps(mesh, cells, faces, nodes, par, inflow, first, audit)
    share_merged_fill(cells, contact.merge)
    settle_nodes(mesh, cells, nodes, contact, par, body, energy, swept, audit)


@njit(**JIT)
def run_steps(n_steps, mesh, cells, faces, nodes, contact, inflow, par, body, energy, law):
    """Advance up to ``n_steps`` steps; return (steps done, exit code).

    ``law`` is the soil law (:class:`~dsmv.cel.layout.SoilLawKernel`); its factor is called only
    when ``par.law_active``, its ``evolve`` updates the law's state variables, the rows of
    ``cells.q`` (and ``inflow.ghost``) beyond the base rows. None for a law that does neither (Tresca):
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
        travel = gather_travel(nodes, body, par.dt) if par.remap else 0.0
        code = step_failed(par, body, resistance, travel)
        if code != RUNNING:
            return step + 1, code
        if remap_due(par, travel):
            remap(mesh, cells, faces, nodes, contact, inflow, par, body, energy, swept)
        if came_to_rest(par, body, v_old):
            return step + 1, AT_REST
    return n_steps, RUNNING
