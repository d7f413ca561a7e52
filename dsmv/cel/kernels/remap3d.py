"""The 3D remap: directional sweeps of the cell state and of the nodal momentum on the dual mesh.

The 2D sweeps (:mod:`dsmv.cel.kernels.remap2d`) along three axes. A sweep along axis a moves soil
through the faces normal to a, line by line; the lines (the cells of one (j, k), (i, k) or (i, j))
are independent, so each sweep runs them in parallel and sums their audits in line order, the same
for any number of threads. Faces are indexed [face along a, first other axis, second other axis].
Soil enters through the base (axis 2, face 0) in the ghost state, and through the sides while the
grid follows a body that slides; the other edges are closed.

References: Benson (1992) CMAME 99 (operator split, dual-mesh momentum remap); van Leer (1977)
(MUSCL); Hirt & Nichols (1981) (donor–acceptor volume fluxes).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from dsmv.cel.kernels.common import (INLINE, JIT, PARALLEL, soil_through_face, upwind_value, van_leer,
                                     weigh_line_fluxes)
from dsmv.cel.kernels.elements3d import cell_elastic_energy_density


@njit(**INLINE)
def cell_of(axis, c, la, lb):
    """The cell at position c along ``axis`` on the line (la, lb) of the other two axes, in order."""
    if axis == 0:
        return c, la, lb
    if axis == 1:
        return la, c, lb
    return la, lb, c


@njit(**INLINE)
def face_travel(axis, u, f, la, lb):
    """The mean travel (m) of a face's four nodes along ``axis``: face f on the line (la, lb)."""
    i, j, k = cell_of(axis, f, la, lb)
    if axis == 0:
        return 0.25 * (u[i, j, k] + u[i, j + 1, k] + u[i, j, k + 1] + u[i, j + 1, k + 1])
    if axis == 1:
        return 0.25 * (u[i, j, k] + u[i + 1, j, k] + u[i, j, k + 1] + u[i + 1, j, k + 1])
    return 0.25 * (u[i, j, k] + u[i + 1, j, k] + u[i, j + 1, k] + u[i + 1, j + 1, k])


@njit(**JIT)
def line_fluxes(axis, la, lb, mesh, cells, phi0, u, aperture, inflow, par, line_flux, qflux):
    """The face fluxes of line (la, lb) of a sweep along ``axis``: soil volume by donor–acceptor into
    ``line_flux``, the state at the donor's value plus a van Leer slope into ``qflux``. The interface's
    normal is read from ``phi0``, the fills before the sweep: a neighbouring line may be updating its
    own. Soil enters through the base in the ghost state (``inflow.ghost``) and, where the grid follows
    a body that slides, through the sides (axes 0 and 1) in the far field's state per layer
    (``inflow.side``, filled ``inflow.side_fill``), and leaves through them freely. Returns the net
    soil volume entered (m³)."""
    x, y, z, vol = mesh.x, mesh.y, mesh.z, mesh.vol
    phi, q, open_frac = cells.phi, cells.q, cells.open_frac
    nx, ny, nz = phi.shape
    n_cells = (nx, ny, nz)[axis]
    n_faces = n_cells + 1
    nq = q.shape[0]
    order, phi_min = par.advection_order, par.phi_min
    inflow_here = par.inflow and axis == 2  # soil enters through the base
    side_open = par.inflow and axis < 2  # and through the sides of a grid that follows a sliding body
    entered = 0.0
    for face in range(n_faces):
        un = face_travel(axis, u, face, la, lb)
        if axis == 0:
            area = (y[la + 1] - y[la]) * (z[lb + 1] - z[lb])
        elif axis == 1:
            area = (x[la + 1] - x[la]) * (z[lb + 1] - z[lb])
        else:
            area = (x[la + 1] - x[la]) * (y[lb + 1] - y[lb])
        dvol = un * area * aperture[face, la, lb]
        if dvol == 0.0:
            continue
        donor = face - 1 if un > 0.0 else face
        acceptor = face if un > 0.0 else face - 1
        if donor < 0 or donor >= n_cells:
            if face == 0 and inflow_here and un > 0.0:
                line_flux[face] = dvol
                for m in range(nq):
                    qflux[m, face] = dvol * inflow.ghost[m, la, lb]
                entered += dvol
            elif side_open:  # the far-field soil, at rest, enters the grid that slides under it (layer lb)
                signed = dvol * inflow.side_fill[lb]
                line_flux[face] = signed
                for m in range(nq):
                    qflux[m, face] = signed * inflow.side[m, lb]
                entered += abs(signed)
            continue
        leaving = acceptor < 0 or acceptor >= n_cells
        if leaving and not (side_open or (inflow_here and acceptor < 0)):
            continue  # closed edges: symmetry planes, rollers, top; the base lets soil out under a body going up
        di, dj, dk = cell_of(axis, donor, la, lb)
        phi_d = phi[di, dj, dk]
        if phi_d <= phi_min:
            continue
        # soil leaving through a side goes on into soil like the donor's
        ai, aj, ak = cell_of(axis, donor if leaving else acceptor, la, lb)
        open_d, open_a = open_frac[di, dj, dk], open_frac[ai, aj, ak]
        fill_d, fill_a = phi_d / open_d, phi[ai, aj, ak] / open_a
        along, across = 0.0, 0.0
        if fill_d < 1.0 or fill_a < 1.0:  # the interface's normal, from the fills around the donor
            gx = abs(phi0[min(di + 1, nx - 1), dj, dk] - phi0[max(di - 1, 0), dj, dk])
            gy = abs(phi0[di, min(dj + 1, ny - 1), dk] - phi0[di, max(dj - 1, 0), dk])
            gz = abs(phi0[di, dj, min(dk + 1, nz - 1)] - phi0[di, dj, max(dk - 1, 0)])
            along, across = (gx, max(gy, gz)) if axis == 0 else ((gy, max(gx, gz)) if axis == 1 else (gz, max(gx, gy)))
        moved = soil_through_face(fill_d, fill_a, dvol, open_d * vol[di, dj, dk], along, across)
        signed = moved if un > 0.0 else -moved
        line_flux[face] = signed
        if leaving:
            entered -= moved
        courant = moved / (phi_d * vol[di, dj, dk])
        lo_c, hi_c = max(donor - 1, 0), min(donor + 1, n_cells - 1)
        li, lj, lk = cell_of(axis, lo_c, la, lb)
        hi_, hj, hk = cell_of(axis, hi_c, la, lb)
        lo_full, hi_full = phi[li, lj, lk] > phi_min, phi[hi_, hj, hk] > phi_min
        for m in range(nq):
            value = q[m, di, dj, dk]
            lo = q[m, li, lj, lk] if lo_full else value
            hi = q[m, hi_, hj, hk] if hi_full else value
            qflux[m, face] = signed * upwind_value(value, lo, hi, order, un, courant)
    return entered


@njit(**JIT)
def limit_line_outflow(axis, la, lb, phi, vol, line_flux, qflux):
    """A cell that gives through both faces gives at most what it holds
    (:func:`dsmv.cel.kernels.remap2d.limit_diverging_outflow`)."""
    n_cells = len(line_flux) - 1
    for c in range(n_cells):
        if line_flux[c] < 0.0 and line_flux[c + 1] > 0.0:
            ci, cj, ck = cell_of(axis, c, la, lb)
            held = phi[ci, cj, ck] * vol[ci, cj, ck]
            given = line_flux[c + 1] - line_flux[c]
            if given > held:
                scale = held / given
                line_flux[c] *= scale
                line_flux[c + 1] *= scale
                for m in range(qflux.shape[0]):
                    qflux[m, c] *= scale
                    qflux[m, c + 1] *= scale


@njit(**JIT)
def apply_line(axis, la, lb, phi, q, vol, line_flux, qflux, flux, par):
    """The cells of line (la, lb) after the sweep (:func:`dsmv.cel.kernels.remap2d.apply_line_fluxes`);
    ``flux`` keeps the line's face fluxes for the momentum sweep. Returns the elastic energy change (J)."""
    n_cells = len(line_flux) - 1
    nq = q.shape[0]
    elastic_change = 0.0
    shear_mod, bulk_mod = par.shear, par.bulk
    for c in range(n_cells):
        flux[c, la, lb] = line_flux[c]
        if line_flux[c] == 0.0 and line_flux[c + 1] == 0.0:
            continue
        ci, cj, ck = cell_of(axis, c, la, lb)
        v = vol[ci, cj, ck]
        old_soil = phi[ci, cj, ck] * v
        new_soil = old_soil + line_flux[c] - line_flux[c + 1]
        if old_soil > 0.0:
            elastic_change -= old_soil * cell_elastic_energy_density(q, ci, cj, ck, shear_mod, bulk_mod)
        if new_soil <= 1e-14 * v:
            phi[ci, cj, ck] = 0.0
            for m in range(nq):
                q[m, ci, cj, ck] = 0.0
            continue
        for m in range(nq):
            q[m, ci, cj, ck] = (old_soil * q[m, ci, cj, ck] + qflux[m, c] - qflux[m, c + 1]) / new_soil
        phi[ci, cj, ck] = new_soil / v
        elastic_change += new_soil * cell_elastic_energy_density(q, ci, cj, ck, shear_mod, bulk_mod)
    flux[n_cells, la, lb] = line_flux[n_cells]
    return elastic_change




@njit(**JIT)
def advect_line(axis, la, lb, mesh, cells, phi0, u, aperture, flux, inflow, par):
    """One line of a sweep of the cell state along ``axis`` (:func:`dsmv.cel.kernels.remap2d.advect_cells`,
    in 3D): its face fluxes, the limit on diverging outflow, its cells updated. Returns (net soil volume
    entered, elastic energy change), in a layered soil weighed
    (:func:`~dsmv.cel.kernels.common.weigh_line_fluxes`)."""
    la, lb = np.int64(la), np.int64(lb)  # a parallel loop's index is unsigned: mixed with int64 it would unify to float
    n_faces = (cells.phi.shape[0], cells.phi.shape[1], cells.phi.shape[2])[axis] + 1
    qflux = np.zeros((cells.q.shape[0], n_faces))
    line_flux = np.zeros(n_faces)
    entered = line_fluxes(axis, la, lb, mesh, cells, phi0, u, aperture, inflow, par, line_flux, qflux)
    limit_line_outflow(axis, la, lb, cells.phi, mesh.vol, line_flux, qflux)
    elastic = apply_line(axis, la, lb, cells.phi, cells.q, mesh.vol, line_flux, qflux, flux, par)
    if par.density_row >= 0:
        entered = weigh_line_fluxes(qflux[par.density_row], flux[:, la, lb])
    return entered, elastic


@njit(**PARALLEL)
def advect_cells(axis, mesh, cells, aperture, flux, u, par, inflow, audit):
    """One sweep of the cell state along ``axis`` with the gathered travel ``u`` (node array of that
    axis' component, m); ``flux`` receives the signed soil volume through each face (m³). Returns the
    net soil volume that entered (m³); ``audit[0]`` accumulates the elastic energy change (J)."""
    n_a, n_b = flux.shape[1], flux.shape[2]
    entered = np.zeros((n_a, n_b))
    elastic = np.zeros((n_a, n_b))
    phi0 = cells.phi.copy()
    for la in prange(n_a):
        for lb in range(n_b):
            entered[la, lb], elastic[la, lb] = advect_line(axis, la, lb, mesh, cells, phi0, u, aperture, flux,
                                                           inflow, par)
    total = 0.0
    for la in range(n_a):
        for lb in range(n_b):
            total += entered[la, lb]
            audit[0] += elastic[la, lb]
    return total


@njit(**JIT)
def momentum_line(axis, a, b, flux, rho, mass, v, order, mass_floor, gm, gv):
    """The momentum sweep of one node line (a, b) along ``axis`` on the dual mesh; returns its change
    of kinetic energy (J). ``gm``, ``gv`` are work space (n_along + 1, and 3 × that)."""
    a, b = np.int64(a), np.int64(b)  # a parallel loop's index is unsigned
    n_along = mass.shape[axis]
    n_faces, n_a, n_b = flux.shape
    kinetic = 0.0
    for d in range(n_along + 1):
        total = 0.0
        for la in (a - 1, a):  # the primal faces d − 1 and d of the four cell lines around the node line
            if 0 <= la < n_a:
                for lb in (b - 1, b):
                    if 0 <= lb < n_b:
                        if 0 <= d - 1 < n_faces:
                            total += flux[d - 1, la, lb]
                        if d < n_faces:
                            total += flux[d, la, lb]
        g = 0.125 * rho * total
        gm[d] = g
        gv[0, d] = gv[1, d] = gv[2, d] = 0.0
        if g == 0.0:
            continue
        up = d - 1 if g > 0.0 else d
        if up < 0 or up >= n_along:
            continue  # from outside: the base at rest brings mass, no momentum
        ui, uj, uk = cell_of(axis, up, a, b)
        lo_i, lo_j, lo_k = cell_of(axis, max(up - 1, 0), a, b)
        hi_i, hi_j, hi_k = cell_of(axis, min(up + 1, n_along - 1), a, b)
        courant = min(abs(g) / max(mass[ui, uj, uk], mass_floor), 1.0)
        half = (0.5 if g > 0.0 else -0.5) * (1.0 - courant)
        for c in range(3):
            vc = v[c]
            w = vc[ui, uj, uk]
            if order == 2:
                w += half * van_leer(w - vc[lo_i, lo_j, lo_k], vc[hi_i, hi_j, hi_k] - w)
            gv[c, d] = g * w
    for n in range(n_along):
        ni, nj, nk = cell_of(axis, n, a, b)
        m_old = mass[ni, nj, nk]
        m_new = m_old + gm[n] - gm[n + 1]
        speed_sq = 0.0
        for c in range(3):
            speed_sq += v[c][ni, nj, nk] ** 2
        kinetic -= 0.5 * m_old * speed_sq
        mass[ni, nj, nk] = m_new
        speed_sq = 0.0
        for c in range(3):
            vc = v[c]
            p = m_old * vc[ni, nj, nk] + gv[c, n] - gv[c, n + 1]
            vc[ni, nj, nk] = p / m_new if m_new > mass_floor else 0.0
            speed_sq += vc[ni, nj, nk] ** 2
        kinetic += 0.5 * m_new * speed_sq
    return kinetic


@njit(**PARALLEL)
def advect_momentum(axis, flux, rho, mass, v, order, mass_floor, audit):
    """The matching sweep of nodal momentum on the dual mesh (Benson 1992), ``v`` the three velocity
    components as node arrays: a dual face's mass flux is
    an eighth of the eight primal fluxes around it (two faces along, four cell lines across), so
    the nodal masses stay an eighth of their cells'; momentum moves at the upwind node's velocity
    (plus a van Leer slope). ``audit[1]`` accumulates the kinetic energy change (J)."""
    shape = mass.shape
    n_a = shape[1] if axis == 0 else shape[0]
    n_b = shape[1] if axis == 2 else shape[2]
    n_along = shape[axis]
    kinetic = np.zeros((n_a, n_b))
    for a in prange(n_a):
        gm = np.empty(n_along + 1)
        gv = np.empty((3, n_along + 1))
        for b in range(n_b):
            kinetic[a, b] = momentum_line(axis, a, b, flux, rho, mass, v, order, mass_floor, gm, gv)
    for a in range(n_a):
        for b in range(n_b):
            audit[1] += kinetic[a, b]


@njit(**JIT)
def remap_sweeps(mesh, cells, faces, nodes, par, inflow, reverse, audit):
    """The three sweeps, x, y, z or (``reverse``) z, y, x, with the gathered travel: the cell state, then the momentum of the structured nodes (split nodes keep
    theirs). Returns the net soil volume that entered (m³). Each sweep is called with its
    axis as a constant, so the compiler specialises its branches."""
    shape = (len(mesh.x), len(mesh.y), len(mesh.z))
    n = mesh.n_grid
    ux, uy, uz = (nodes.travel[0, :n].reshape(shape), nodes.travel[1, :n].reshape(shape),
                  nodes.travel[2, :n].reshape(shape))
    mass = nodes.mass[:n].reshape(shape)
    v = (nodes.v[0, :n].reshape(shape), nodes.v[1, :n].reshape(shape), nodes.v[2, :n].reshape(shape))
    entered = 0.0
    for sweep in range(3):
        axis = 2 - sweep if reverse else sweep
        if axis == 0:
            entered += advect_cells(0, mesh, cells, faces.aperture_x, faces.flux_x, ux, par, inflow, audit)
            advect_momentum(0, faces.flux_x, par.density, mass, v, par.advection_order, par.mass_floor, audit)
        elif axis == 1:
            entered += advect_cells(1, mesh, cells, faces.aperture_y, faces.flux_y, uy, par, inflow, audit)
            advect_momentum(1, faces.flux_y, par.density, mass, v, par.advection_order, par.mass_floor, audit)
        else:
            entered += advect_cells(2, mesh, cells, faces.aperture_z, faces.flux_z, uz, par, inflow, audit)
            advect_momentum(2, faces.flux_z, par.density, mass, v, par.advection_order, par.mass_floor, audit)
    return entered
