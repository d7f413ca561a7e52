"""The compiled time loop: N explicit CEL steps per call, Python steers between calls.

A step (Benson 1992 operator split) in the grid frame that moves with the body:
Lagrangian phase — nodal forces from the cell stresses, the rigid body's motion with the soil
nodes tied to it, explicit velocity update, boundary conditions, stress update — then the
Eulerian phase: the soil state and momentum are carried through the grid by the travel
relative to the grid, in two directional sweeps whose order alternates. The Eulerian phase
waits until some node has travelled ``P_REMAP_DISP`` (a set fraction of a cell): the elastic
step moves the soil only about 1 % of a cell. It is the only place φ changes, so the nodal
masses are computed on entry and after each remap, not every step.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# Numba (0.68) keys a cached function on its own file's content only: run_steps keeps the
# kernels it inlined until this file changes. After changing a kernel, bump this revision
# (or clear the Numba cache). Kernel revision: 22 (one helper for a face's capped pull; no change of arithmetic).
from dsmv.cel.kernels import (
    JIT,
    advect_cells,
    advect_momentum,
    nodal_forces,
    nodal_mass,
    node_strength,
    twin_masses,
    TW_CAP, TW_FX, TW_FY, TW_M, TW_NX, TW_NY, TW_UX, TW_UY, TW_VX, TW_VY,
    update_stress,
    merged_divergence,
    update_velocities,
)

# float parameters
# P_REMAP_DISP: the remap runs once the soil has moved this far through the grid (m)
(P_DT, P_RHO, P_G, P_K, P_C, P_HG, P_BL, P_BQ, P_GRAV, P_SU0, P_KS, P_MFLOOR, P_PHIMIN, P_BODY_M, P_BODY_W,
 P_PUSH_V, P_K0, P_PHI_STRESS, P_REMAP_DISP) = range(19)
N_PAR = 19
# integer parameters
# I_SEPARATE: a face tie (one with a normal) lets go when the soil would pull away from the face (no tension)
I_AXISYM, I_ORDER, I_DROP, I_INFLOW, I_REMAP, I_TRESCA, I_LAW, I_SKIP_VOID, I_SEPARATE = range(9)
N_IPAR = 9
# body state (mutable floats)
# B_FRICTION: the adhesive ties' pull on the body in the last step (N, up +), applied in the next;
# B_REMAP_OFFSET: the body's offset at the last remap (m); B_REMAPS: remaps done
B_TIME, B_OFFSET, B_VEL, B_MAXDISP, B_FSUM, B_FCOUNT, B_INFLOW, B_STEP, B_FRICTION, B_REMAP_OFFSET, B_REMAPS = range(11)
N_BODY = 11
# energy accumulators of the model (J per unit thickness or per radian): plastic, hourglass and
# bulk-viscosity dissipation, work of the push, of gravity on the body and on the soil, and the
# changes of elastic and kinetic energy that the remap makes, the work lost to slip at a
# limited-adhesion contact, and the elastic energy gap cells let go (update_stress)
(E_PLASTIC, E_HOURGLASS, E_BULK, E_PUSH, E_BODY_GRAV, E_SOIL_GRAV, E_REMAP_ELASTIC, E_REMAP_KINETIC,
 E_FRICTION, E_GAP_RELEASE) = range(10)
N_ENERGY = 10
# exit codes
RUNNING, AT_REST, NOT_FINITE = 0, 1, 2
#: a cell the body cuts lends its nodes at least the mass of this fill of the whole cell: its open
#: faces are as stiff as a full cell's, and the explicit step stays stable (see nodal_mass)
CUT_MASS_FILL = 0.5


@njit(**JIT)
def tie_holds(vx, vy, fx, fy, m, nx, ny, dt, grav, v_body_next):
    """Whether a face tie (normal n into the soil) holds this step: the node's free velocity
    would carry it into the body, not away from the face (no tension)."""
    vn_free = (vx + dt * fx / m) * nx + (vy + dt * (fy / m - grav)) * ny
    return vn_free <= v_body_next * ny


@njit(**JIT)
def tie_reaction(fx, fy, m, grav, full, nx, ny):
    """What a tied node puts on the body: its force (N, up +) and the mass it adds (kg)."""
    if full:
        return fy - m * grav, m
    return (fx * nx + (fy - m * grav) * ny) * ny, m * ny * ny


@njit(**JIT)
def pull_along_face(vx, vy, tx, ty, v_body, dw_max, m, dt):
    """A face's capped pull on a tied node of mass m (kg) moving along the face (tx, ty): it takes
    the node's whole slip speed relative to the body when it can (the node sticks), else at most
    dw_max (m/s), against the slip. Returns the node's new velocity, its momentum change m·Δvy, the
    pull times the slip it leaves (J per s of step, times Δt: 0 when it sticks), and the pull's
    reaction on the body (N, up +)."""
    w = vx * tx + (vy - v_body) * ty  # slip speed relative to the body
    dw = -w if abs(w) <= dw_max else (-dw_max if w > 0.0 else dw_max)
    return vx + dw * tx, vy + dw * ty, m * dw * ty, -m * dw * (w + dw), -m * dw * ty / dt


@njit(**JIT)
def tied_velocity(vx, vy, full, nx, ny, v_body):
    """A tied node's velocity: the body's (full tie), or its own with the normal part the body's."""
    if full:
        return 0.0, v_body
    gap = v_body * ny - (vx * nx + vy * ny)
    return vx + gap * nx, vy + gap * ny


@njit(**JIT)
def run_steps(
    n_steps, x, y, vol, phi, q, vx, vy, mass, fx, fy, ux, uy, flux_x, flux_y,
    tie_i, tie_j, tie_full, tie_nx, tie_ny, tie_cap, strength_factor, su_cell, solid, aperture_x, aperture_y, open_frac,
    merge, gap_cells, cell_twin, twin_node, twin, ghost, ghost_depth0, par, ipar, body, energy,
    law, law_params, evolve,
):
    """Advance up to ``n_steps`` steps; return (steps done, exit code).

    The body's share of the grid: ``solid`` cells lie inside it; ``aperture_x``, ``aperture_y`` and
    ``open_frac`` are the open fractions of faces and cells (:class:`dsmv.cel.grid.Openings`);
    ``merge`` rows (i, j, i', j') pair a sliver of a cut cell with its neighbour
    (:func:`dsmv.cel.solver.sliver_pairs`): one volumetric strain, one fill, one mean stress.
    ``gap_cells`` (nx, ny) marks the cells beside a face the soil may leave, which carry stress
    only while full (:func:`dsmv.cel.kernels.update_stress`). ``cell_twin``, ``twin_node`` and
    ``twin`` are the corners' twins (:data:`dsmv.cel.kernels.N_TWIN`): moved by their cells, tied
    and pulled by the wall like its face ties; a remap carries the soil through the face between
    the twin's cells with the twin's vertical travel, and keeps the twin's velocity (a corner stays
    put in the grid).

    ``law`` is the soil law's compiled strength factor (dsmv.soil_law), ``law_params`` its
    packed parameters; it is called only when ``ipar[I_LAW]`` is set. ``evolve`` updates the
    law's state variables, the rows of ``q`` (and ``ghost``) beyond NQ_BASE.

    Contact: a fully tied node moves with the body; a normally tied one only along its normal n.
    A normally tied node with ``tie_cap`` > 0 (limited adhesion, α·su) also feels the body's
    pull along the face, up to ``tie_cap·su`` (N per unit thickness or per radian; tie_cap = α ×
    the node's share of the face, m or m²/rad), su being the node's soil strength (``su_cell``,
    written by the stress update of the step before). The pull's reaction reaches the body in
    the next step. The contact's dissipation ``energy[E_FRICTION]`` is the pull times the slip it
    leaves, m·|Δw|·|w'| per step (w' the slip speed after the pull): zero when the node sticks,
    as a full tie dissipates nothing (the kinetic energy a tie removes is the internal forces'
    work, already counted). With ``ipar[I_SEPARATE]`` a tie on a face (one with a normal; rough
    or smooth) lets go, for the step, of a node whose free velocity would carry it away from the
    face (no tension): it then moves with the soil, and pushes nothing onto the body. Corners
    and staircase nodes (no normal) hold.
    """
    dt = par[P_DT]
    rho = par[P_RHO]
    grav = par[P_GRAV]
    axisym = ipar[I_AXISYM] == 1
    order = ipar[I_ORDER]
    drop = ipar[I_DROP] == 1
    inflow = ipar[I_INFLOW] == 1
    remap = ipar[I_REMAP] != 0
    nxn, nyn = vx.shape
    work = np.zeros(3)
    stress_out = np.zeros(2)  # plastic work, elastic energy released by gap cells (J)
    audit = np.zeros(2)
    n_tied = len(tie_i)
    separate = ipar[I_SEPARATE] == 1
    holding = np.ones(n_tied, dtype=np.bool_)  # every tie holds unless the soil may part from the faces
    n_twins = twin.shape[0]
    twin_holding = np.ones(n_twins, dtype=np.bool_)
    swept = np.zeros((n_twins, 2))  # corner node and twin masses (kg) as the remap's sweeps leave them
    # a merged sliver and its neighbour are marked here (their common strain rate is set before each stress update)
    div_override = np.full(phi.shape, np.nan)
    for k in range(merge.shape[0]):
        div_override[merge[k, 0], merge[k, 1]] = 0.0
        div_override[merge[k, 2], merge[k, 3]] = 0.0
    # nodal masses change only where soil moves through the grid: here and after each remap
    nodal_mass(phi, vol, rho, mass, open_frac, CUT_MASS_FILL)
    twin_masses(phi, vol, rho, mass, cell_twin, twin)
    for step in range(n_steps):
        # ---- Lagrangian phase
        work[:] = 0.0
        nodal_forces(x, y, phi, q, vx, vy, rho, par[P_C], par[P_HG], par[P_BL], par[P_BQ], axisym, fx, fy, work,
                     ipar[I_SKIP_VOID] == 1, aperture_x, aperture_y, open_frac, body[B_VEL], div_override,
                     cell_twin, twin)
        energy[E_HOURGLASS] += work[0] * dt
        energy[E_BULK] += work[1] * dt
        # rigid body with the soil nodes tied to it (vertical motion): a fully tied node moves
        # with the body, a normally tied one (smooth contact) only along its normal n
        soil_on_nodes = body[B_FRICTION] + work[2]  # the adhesive pull of the last step, the cut cells' arcs
        tied_mass = 0.0
        if separate:  # which face ties hold this step: those the soil would otherwise cross
            v_body_next = body[B_VEL] if drop else -par[P_PUSH_V]
            for k in range(n_tied):
                i, j = tie_i[k], tie_j[k]
                m = mass[i, j]
                if (tie_nx[k] == 0.0 and tie_ny[k] == 0.0) or m <= par[P_MFLOOR]:  # no face: a corner, a staircase
                    holding[k] = True
                    continue
                holding[k] = tie_holds(vx[i, j], vy[i, j], fx[i, j], fy[i, j], m, tie_nx[k], tie_ny[k], dt, grav,
                                       v_body_next)
            for k in range(n_twins):
                m = twin[k, TW_M]
                twin_holding[k] = m <= par[P_MFLOOR] or tie_holds(
                    twin[k, TW_VX], twin[k, TW_VY], twin[k, TW_FX], twin[k, TW_FY], m, twin[k, TW_NX], twin[k, TW_NY],
                    dt, grav, v_body_next)
        for k in range(n_tied):
            i, j = tie_i[k], tie_j[k]
            if holding[k]:
                force, m = tie_reaction(fx[i, j], fy[i, j], mass[i, j], grav, tie_full[k], tie_nx[k], tie_ny[k])
                soil_on_nodes += force
                tied_mass += m
        for k in range(n_twins):
            if twin_holding[k]:
                force, m = tie_reaction(twin[k, TW_FX], twin[k, TW_FY], twin[k, TW_M], grav, False, twin[k, TW_NX],
                                        twin[k, TW_NY])
                soil_on_nodes += force
                tied_mass += m
        v_old = body[B_VEL]
        if drop:
            accel = (soil_on_nodes - par[P_BODY_W]) / (par[P_BODY_M] + tied_mass)
            body[B_VEL] = v_old + dt * accel
            energy[E_BODY_GRAV] += par[P_BODY_W] * (-0.5 * (v_old + body[B_VEL])) * dt
        else:
            accel = 0.0
            body[B_VEL] = -par[P_PUSH_V]
        resistance = soil_on_nodes - tied_mass * accel  # soil force on the body (N, up +)
        if not drop:
            energy[E_PUSH] += -resistance * body[B_VEL] * dt
        body[B_FSUM] += resistance
        body[B_FCOUNT] += 1.0
        # Σ m·vy before the update and after it, kept current through every later change of vy
        # in this step (the audit of gravity's work on the soil needs both)
        momentum_before, momentum_after = update_velocities(vx, vy, fx, fy, mass, grav, dt, par[P_MFLOOR])
        for k in range(n_twins):
            m = twin[k, TW_M]
            momentum_before += m * twin[k, TW_VY]
            if m > par[P_MFLOOR]:
                twin[k, TW_VX] += dt * twin[k, TW_FX] / m
                twin[k, TW_VY] += dt * (twin[k, TW_FY] / m - grav)
            else:
                twin[k, TW_VX] = 0.0
                twin[k, TW_VY] = 0.0
            if twin_holding[k]:
                twin[k, TW_VX], twin[k, TW_VY] = tied_velocity(twin[k, TW_VX], twin[k, TW_VY], False, twin[k, TW_NX],
                                                               twin[k, TW_NY], body[B_VEL])
            momentum_after += m * twin[k, TW_VY]
        # boundary conditions: symmetry axis and far side are rollers, the base is fixed
        for j in range(nyn):
            vx[0, j] = 0.0
            vx[nxn - 1, j] = 0.0
        for i in range(nxn):
            vx[i, 0] = 0.0
            momentum_after -= mass[i, 0] * vy[i, 0]
            vy[i, 0] = 0.0
        for k in range(n_tied):
            i, j = tie_i[k], tie_j[k]
            if not holding[k]:
                continue
            vy_free = vy[i, j]
            vx[i, j], vy[i, j] = tied_velocity(vx[i, j], vy[i, j], tie_full[k], tie_nx[k], tie_ny[k], body[B_VEL])
            momentum_after += mass[i, j] * (vy[i, j] - vy_free)
        friction = 0.0
        for k in range(n_tied):
            if tie_full[k] or tie_cap[k] <= 0.0 or not holding[k]:
                continue
            i, j = tie_i[k], tie_j[k]
            m = mass[i, j]
            if m <= par[P_MFLOOR]:
                continue
            dw_max = tie_cap[k] * node_strength(su_cell, phi, solid, i, j) * dt / m
            vx[i, j], vy[i, j], dp, slip, reaction = pull_along_face(vx[i, j], vy[i, j], -tie_ny[k], tie_nx[k],
                                                                     body[B_VEL], dw_max, m, dt)
            momentum_after += dp
            energy[E_FRICTION] += slip
            friction += reaction
        for k in range(n_twins):  # the twins by the same rule: their share of wall is the lower half of
            m = twin[k, TW_M]      # the wall face of the cell above the corner, gripped by what that holds
            if twin[k, TW_CAP] <= 0.0 or not twin_holding[k] or m <= par[P_MFLOOR]:
                continue
            ci, cj = twin_node[k, 2], twin_node[k, 3]
            dw_max = twin[k, TW_CAP] * su_cell[ci, cj] * min(phi[ci, cj], 1.0) * dt / m
            twin[k, TW_VX], twin[k, TW_VY], dp, slip, reaction = pull_along_face(
                twin[k, TW_VX], twin[k, TW_VY], -twin[k, TW_NY], twin[k, TW_NX], body[B_VEL], dw_max, m, dt)
            momentum_after += dp
            energy[E_FRICTION] += slip
            friction += reaction
        body[B_FRICTION] = friction
        energy[E_SOIL_GRAV] += -grav * dt * 0.5 * (momentum_before + momentum_after)
        stress_out[:] = 0.0
        for k in range(merge.shape[0]):  # a sliver and its neighbour change volume as one
            si, sj, ni, nj = merge[k, 0], merge[k, 1], merge[k, 2], merge[k, 3]
            d = merged_divergence(si, sj, ni, nj, x, y, vx, vy, body[B_VEL], aperture_x, aperture_y, open_frac)
            div_override[si, sj] = d
            div_override[ni, nj] = d
        update_stress(x, y, phi, q, vx, vy, dt, par[P_G], par[P_K], par[P_SU0], par[P_KS], axisym,
                      par[P_PHI_STRESS], ipar[I_TRESCA] == 1, law, law_params, ipar[I_LAW] == 1, evolve,
                      strength_factor, su_cell, stress_out, aperture_x, aperture_y, open_frac, body[B_VEL], div_override,
                      gap_cells, cell_twin, twin)
        energy[E_PLASTIC] += stress_out[0]
        energy[E_GAP_RELEASE] += stress_out[1]
        body[B_OFFSET] += body[B_VEL] * dt
        body[B_TIME] += dt
        body[B_STEP] += 1.0
        if -body[B_OFFSET] > body[B_MAXDISP]:
            body[B_MAXDISP] = -body[B_OFFSET]
        # The soil moves a small fraction of a cell per step (the step is set by the elastic wave
        # speed, not by the flow): ux, uy gather each node's travel through the grid, which moves
        # with the body (m), and the remap runs once some node has gone par[P_REMAP_DISP]
        # (0: every step). Gathered before the exits, so a run that goes on keeps this step's.
        travel = 0.0
        if remap:
            v_grid = body[B_VEL]
            for i in range(nxn):
                for j in range(nyn):
                    ux[i, j] += vx[i, j] * dt
                    uy[i, j] += (vy[i, j] - v_grid) * dt
                    travel = max(travel, abs(ux[i, j]), abs(uy[i, j]))
            for k in range(n_twins):
                twin[k, TW_UX] += twin[k, TW_VX] * dt
                twin[k, TW_UY] += (twin[k, TW_VY] - v_grid) * dt
                travel = max(travel, abs(twin[k, TW_UX]), abs(twin[k, TW_UY]))
        if not (math.isfinite(body[B_VEL]) and math.isfinite(resistance)):
            return step + 1, NOT_FINITE
        if drop and body[B_VEL] >= 0.0 and v_old < 0.0:
            return step + 1, AT_REST
        if not remap or travel < par[P_REMAP_DISP]:
            continue
        # ---- Eulerian phase: carry soil and momentum through the grid by the gathered travel
        # soil entering at the base: intact and geostatic at its depth halfway through the travel
        if inflow:
            for i in range(ghost.shape[1]):
                depth = ghost_depth0[i] - 0.5 * (body[B_REMAP_OFFSET] + body[B_OFFSET])
                ghost[1, i] = -rho * grav * depth
                ghost[0, i] = par[P_K0] * ghost[1, i]
                ghost[3, i] = ghost[0, i]
                ghost[5, i] = depth
        # of a corner node's four faces two are the body's, one (below the corner) is shared with
        # the cell under the base, and one lies between the twin's cells: that one moves soil with
        # the twin's vertical travel
        for k in range(n_twins):
            uy[twin_node[k, 0], twin_node[k, 1]] = twin[k, TW_UY]
            twin[k, TW_UX] = 0.0
            twin[k, TW_UY] = 0.0
        audit[:] = 0.0
        first = int(body[B_REMAPS]) % 2  # the sweeps alternate their order
        for sweep in range(2):  # with the gathered travel as velocity × time: Δt = 1
            axis = first if sweep == 0 else 1 - first
            if axis == 0:
                body[B_INFLOW] += advect_cells(0, x, y, vol, phi, q, ux, uy, 1.0, order, axisym, ghost, False,
                                               flux_x, par[P_PHIMIN], par[P_G], par[P_K], audit, aperture_x, open_frac)
                advect_momentum(0, flux_x, rho, mass, vx, vy, order, par[P_MFLOOR], audit)
            else:
                body[B_INFLOW] += advect_cells(1, x, y, vol, phi, q, ux, uy, 1.0, order, axisym, ghost, inflow,
                                               flux_y, par[P_PHIMIN], par[P_G], par[P_K], audit, aperture_y, open_frac)
                advect_momentum(1, flux_y, rho, mass, vx, vy, order, par[P_MFLOOR], audit)
        energy[E_REMAP_ELASTIC] += audit[0]
        energy[E_REMAP_KINETIC] += audit[1]
        for k in range(merge.shape[0]):  # a merged pair shares one fill and one mean stress
            si, sj, ni, nj = merge[k, 0], merge[k, 1], merge[k, 2], merge[k, 3]
            os_, on = open_frac[si, sj], open_frac[ni, nj]
            ps, pn = phi[si, sj], phi[ni, nj]
            tot = ps + pn
            if tot <= 0.0:
                continue
            fill = tot / (os_ + on)
            phi[si, sj] = fill * os_
            phi[ni, nj] = fill * on
            ms = (q[0, si, sj] + q[1, si, sj] + q[3, si, sj]) / 3.0
            mn = (q[0, ni, nj] + q[1, ni, nj] + q[3, ni, nj]) / 3.0
            mean = (ps * ms + pn * mn) / tot
            for r in (0, 1, 3):
                q[r, si, sj] += mean - ms
                q[r, ni, nj] += mean - mn
        ux[:, :] = 0.0
        uy[:, :] = 0.0
        for k in range(n_twins):  # the masses the sweeps left at the corners, and the twins' own
            swept[k, 0] = mass[twin_node[k, 0], twin_node[k, 1]]
            swept[k, 1] = twin[k, TW_M]
        nodal_mass(phi, vol, rho, mass, open_frac, CUT_MASS_FILL)
        twin_masses(phi, vol, rho, mass, cell_twin, twin)
        # the sweeps move the corner node's whole quarter shares; the twin takes its part back at
        # the velocity it keeps: the kinetic energy that changes hands is the remap's too
        for k in range(n_twins):
            i, j = twin_node[k, 0], twin_node[k, 1]
            energy[E_REMAP_KINETIC] += 0.5 * ((mass[i, j] - swept[k, 0]) * (vx[i, j] ** 2 + vy[i, j] ** 2)
                                              + (twin[k, TW_M] - swept[k, 1]) * (twin[k, TW_VX] ** 2 + twin[k, TW_VY] ** 2))
        body[B_REMAP_OFFSET] = body[B_OFFSET]
        body[B_REMAPS] += 1.0
    return n_steps, RUNNING
