"""The compiled 3D time loop: N explicit CEL steps per call, Python steers between calls.

The step of :mod:`dsmv.cel.stepper` on hexahedra: nodal forces (:mod:`dsmv.cel.kernels.hexahedra`),
the body's motion and the tied nodes (the shared stages of :mod:`dsmv.cel.kernels.nodes`), the
explicit velocity update, the boundary conditions, the stress update. The grid stays where it is
relative to the body's start: this loop is the small-strain analysis (``solver.remap=false``);
the faces hold the soil along their normal or wholly, without a capped adhesive pull.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from dsmv.cel.kernels.common import INLINE, JIT
from dsmv.cel.kernels.hexahedra import nodal_forces, update_stress
from dsmv.cel.kernels.nodes import apply_fixed, apply_ties, nodal_mass, ties_that_hold, update_velocities
from dsmv.cel.layout import B_MAXDISP, B_OFFSET, B_STEP, B_TIME, B_VEL
from dsmv.cel.ledger import E_BULK, E_HOURGLASS, E_PLASTIC, E_SOIL_GRAV
from dsmv.cel.stepper import AT_REST, NOT_FINITE, RUNNING, move_body


@njit(**INLINE)
def lagrange_step(mesh, cells, nodes, contact, par, body, energy, law):
    """One step; returns the soil's force on the body (N) and the body's old velocity."""
    work = np.zeros(2)
    nodal_forces(mesh, cells, nodes, par, work)
    energy[E_HOURGLASS] += work[0] * par.dt
    energy[E_BULK] += work[1] * par.dt
    if par.separation:  # which face ties hold this step: those the soil would otherwise cross
        ties_that_hold(contact, nodes, par.dt, par.gravity, par.mass_floor,
                       body[B_VEL] if par.drop else -par.push_velocity)
    resistance, v_old = move_body(nodes, contact, par, body, energy, 0.0)
    momentum_before, momentum_after = update_velocities(nodes, par.gravity, par.dt, par.mass_floor)
    momentum_after += apply_fixed(nodes, contact)
    momentum_after += apply_ties(contact, nodes, body[B_VEL])
    energy[E_SOIL_GRAV] += -par.gravity * par.dt * 0.5 * (momentum_before + momentum_after)
    plastic = np.zeros(1)
    update_stress(mesh, cells, nodes, par, law, plastic)
    energy[E_PLASTIC] += plastic[0]
    body[B_OFFSET] += body[B_VEL] * par.dt
    body[B_TIME] += par.dt
    body[B_STEP] += 1.0
    if -body[B_OFFSET] > body[B_MAXDISP]:
        body[B_MAXDISP] = -body[B_OFFSET]
    return resistance, v_old


@njit(**JIT)
def run_steps(n_steps, mesh, cells, nodes, contact, par, body, energy, law):
    """Advance up to ``n_steps`` steps; return (steps done, exit code) as :func:`dsmv.cel.stepper.run_steps`."""
    nodal_mass(mesh, cells, par.density, nodes.mass)
    for step in range(n_steps):
        resistance, v_old = lagrange_step(mesh, cells, nodes, contact, par, body, energy, law)
        if not (math.isfinite(body[B_VEL]) and math.isfinite(resistance)):
            return step + 1, NOT_FINITE
        if par.drop and body[B_VEL] >= 0.0 and v_old < 0.0:
            return step + 1, AT_REST
    return n_steps, RUNNING
