"""The 2D remap: directional sweeps of the cell state and of the nodal momentum on the dual mesh.

References: Benson (1992) CMAME 99 (operator split, dual-mesh momentum remap); van Leer (1977)
(MUSCL); Hirt & Nichols (1981) (donor–acceptor volume fluxes).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from dsmv.cel.kernels.common import (JIT, elastic_energy_density, soil_through_face, upwind_value, van_leer,
                                     weigh_line_fluxes)
from dsmv.cel.kernels.elements2d import SXX, SXY, SYY, SZZ


@njit(**JIT)
def advect_cells(axis, mesh, cells, faces, ux, uy, dt, par, inflow, audit):
    """One directional sweep of the cell state: volume fraction and transported quantities.

    ``ux``, ``uy`` are nodal velocities relative to the grid (m/s), or, with ``dt`` = 1, the
    travel through the grid gathered since the last remap (m). A face's volume flux comes from
    the mean normal velocity of its two nodes. Soil volume moves by the
    donor–acceptor rule; each transported quantity moves with it at the donor's value plus
    a van Leer limited slope when ``order`` = 2. Domain edges are closed, except the base
    (axis 1, face 0) when ``par.inflow``: soil enters there in the state ``inflow.ghost[k, i]`` and leaves
    there, into soil like its own, while the grid follows a body going up (a cyclic push); and
    the sides (axis 0), where the grid follows a body that slides: the soil beyond enters in the state
    ``inflow.side[k, j]``, filled ``inflow.side_fill[j]``, and leaves freely.
    The faces' ``flux[face, line]`` receives the signed soil volume through each face (for the momentum
    sweep). The body takes part of the grid: the faces' aperture is the open fraction of each
    face (0 next to a cell inside the body), ``open_frac`` that of each cell (a cell the body's
    surface cuts holds at most that much soil); the Hirt–Nichols rule works on the fill of the
    open part, φ / open_frac. Returns the net soil volume
    that entered through the base and the sides (m³; in a layered soil, as soil of ``par.density``, and the
    faces' fluxes likewise, :func:`~dsmv.cel.kernels.common.weigh_line_fluxes`). ``audit[0]``
    accumulates the change of stored elastic energy the sweep makes (J), inflow included.
    """
    x, y, vol = mesh.x, mesh.y, mesh.vol
    phi, q, open_frac = cells.phi, cells.q, cells.open_frac
    flux = faces.flux_x if axis == 0 else faces.flux_y
    aperture = faces.aperture_x if axis == 0 else faces.aperture_y
    ghost, bottom_inflow = inflow.ghost, par.inflow and axis == 1
    side_open = par.inflow and axis == 0 and not par.axisymmetric  # the grid follows a body that slides
    order, axisym, phi_min, shear_mod, bulk_mod = par.advection_order, par.axisymmetric, par.phi_min, par.shear, par.bulk
    nx, ny = phi.shape
    nq = q.shape[0]
    boundary, weighed, density_row = 0.0, 0.0, par.density_row
    n_lines = ny if axis == 0 else nx
    n_faces = nx + 1 if axis == 0 else ny + 1
    n_cells = n_faces - 1
    qflux = np.zeros((nq, n_faces))
    phi0 = phi.copy()  # the interface's normal from the fills before the sweep, as in 3D (decision 0023)
    for line in range(n_lines):
        for face in range(n_faces):
            flux[face, line] = 0.0
            for k in range(nq):
                qflux[k, face] = 0.0
            if axis == 0:
                i, j = face, line
                un = 0.5 * (ux[i, j] + ux[i, j + 1])
                area = (y[j + 1] - y[j]) * (x[i] if axisym else 1.0)
            else:
                i, j = line, face
                un = 0.5 * (uy[i, j] + uy[i + 1, j])
                area = (x[i + 1] - x[i]) * (0.5 * (x[i] + x[i + 1]) if axisym else 1.0)
            dvol = un * area * dt * aperture[face, line]
            if dvol == 0.0:
                continue
            donor = face - 1 if un > 0.0 else face
            acceptor = face if un > 0.0 else face - 1
            if donor < 0 or donor >= n_cells:
                if face == 0 and bottom_inflow and un > 0.0:
                    flux[face, line] = dvol
                    for k in range(nq):
                        qflux[k, face] = dvol * ghost[k, i]
                    boundary += dvol
                elif side_open:  # the far-field soil, at rest, enters the grid that slides under it
                    signed = dvol * inflow.side_fill[j]
                    flux[face, line] = signed
                    for k in range(nq):
                        qflux[k, face] = signed * inflow.side[k, j]
                    boundary += abs(signed)
                continue
            leaving = acceptor < 0 or acceptor >= n_cells
            if leaving and not (side_open or (bottom_inflow and acceptor < 0)):
                continue  # closed edges: symmetry plane, rollers, top; soil near the top ends a run
            di = donor if axis == 0 else i
            dj = j if axis == 0 else donor
            phi_d = phi[di, dj]
            if phi_d <= phi_min:
                continue
            # soil leaving through a side goes on into soil like the donor's
            ai = di if leaving else (acceptor if axis == 0 else i)
            aj = dj if leaving else (j if axis == 0 else acceptor)
            open_d, open_a = open_frac[di, dj], open_frac[ai, aj]
            fill_d, fill_a = phi_d / open_d, phi[ai, aj] / open_a
            along, across = 0.0, 0.0
            if fill_d < 1.0 or fill_a < 1.0:  # the interface's normal, from the fills around the donor
                g_x = abs(phi0[min(di + 1, nx - 1), dj] - phi0[max(di - 1, 0), dj])
                g_y = abs(phi0[di, min(dj + 1, ny - 1)] - phi0[di, max(dj - 1, 0)])
                along, across = (g_x, g_y) if axis == 0 else (g_y, g_x)
            moved = soil_through_face(fill_d, fill_a, dvol, open_d * vol[di, dj], along, across)
            signed = moved if un > 0.0 else -moved
            flux[face, line] = signed
            if leaving:
                boundary -= moved
            courant = moved / (phi_d * vol[di, dj])
            if axis == 0:
                li, lj, hi_, hj = max(di - 1, 0), dj, min(di + 1, nx - 1), dj
            else:
                li, lj, hi_, hj = di, max(dj - 1, 0), di, min(dj + 1, ny - 1)
            lo_full, hi_full = phi[li, lj] > phi_min, phi[hi_, hj] > phi_min
            for k in range(nq):
                value = q[k, di, dj]
                lo = q[k, li, lj] if lo_full else value
                hi = q[k, hi_, hj] if hi_full else value
                qflux[k, face] = signed * upwind_value(value, lo, hi, order, un, courant)
        limit_diverging_outflow(axis, line, flux, qflux, phi, vol)
        apply_line_fluxes(axis, line, flux, qflux, phi, q, vol, shear_mod, bulk_mod, audit)
        if density_row >= 0:
            weighed += weigh_line_fluxes(qflux[density_row], flux[:, line])
    return weighed if density_row >= 0 else boundary


@njit(**JIT)
def limit_diverging_outflow(axis, line, flux, qflux, phi, vol):
    """Each face limits its donor's outflow on its own, so a cell that gives through both faces
    (diverging flow) could give up to twice what it holds; clipping the negative remainder to 0
    then creates soil (1e-10 of the mass in a 10 m/s landing). Scale such a cell's two outflows
    down to its content: both neighbours see the same fluxes."""
    n_cells = flux.shape[0] - 1
    for c in range(n_cells):
        if flux[c, line] < 0.0 and flux[c + 1, line] > 0.0:
            ci = c if axis == 0 else line
            cj = line if axis == 0 else c
            held = phi[ci, cj] * vol[ci, cj]
            given = flux[c + 1, line] - flux[c, line]
            if given > held:
                scale = held / given
                flux[c, line] *= scale
                flux[c + 1, line] *= scale
                for k in range(qflux.shape[0]):
                    qflux[k, c] *= scale
                    qflux[k, c + 1] *= scale


@njit(**JIT)
def apply_line_fluxes(axis, line, flux, qflux, phi, q, vol, shear_mod, bulk_mod, audit):
    """The cells of one line after the sweep: soil and its state in and out through both faces;
    ``audit[0]`` accumulates the change of stored elastic energy (J)."""
    n_cells = flux.shape[0] - 1
    nq = q.shape[0]
    for c in range(n_cells):
        ci = c if axis == 0 else line
        cj = line if axis == 0 else c
        v = vol[ci, cj]
        old_soil = phi[ci, cj] * v
        new_soil = old_soil + flux[c, line] - flux[c + 1, line]
        if flux[c, line] == 0.0 and flux[c + 1, line] == 0.0:
            continue
        if old_soil > 0.0:
            audit[0] -= old_soil * elastic_energy_density(
                q[SXX, ci, cj], q[SYY, ci, cj], q[SZZ, ci, cj], q[SXY, ci, cj], 0.0, 0.0, shear_mod, bulk_mod)
        if new_soil <= 1e-14 * v:
            phi[ci, cj] = 0.0
            for k in range(nq):
                q[k, ci, cj] = 0.0
            continue
        for k in range(nq):
            q[k, ci, cj] = (old_soil * q[k, ci, cj] + qflux[k, c] - qflux[k, c + 1]) / new_soil
        phi[ci, cj] = new_soil / v
        audit[0] += new_soil * elastic_energy_density(
            q[SXX, ci, cj], q[SYY, ci, cj], q[SZZ, ci, cj], q[SXY, ci, cj], 0.0, 0.0, shear_mod, bulk_mod)


@njit(**JIT)
def advect_momentum(axis, flux, rho, mass, vx, vy, order, mass_floor, audit):
    """The matching sweep of nodal momentum on the dual mesh (Benson 1992).

    The mass flux through a dual face is the mean of the four primal face fluxes around
    it, so the nodal masses stay a quarter of their cells' masses. Momentum moves at the
    upwind node's velocity (plus a van Leer slope when ``order`` = 2). ``mass`` (nodal,
    before the sweep) is updated in place; soil entering through the base brings no
    momentum (the base is at rest). ``audit[1]`` accumulates the kinetic energy change (J).
    """
    n0, n1 = vx.shape  # nodes (nx+1, ny+1)
    n_along = n0 if axis == 0 else n1
    n_across = n1 if axis == 0 else n0
    n_lines_primal = flux.shape[1]  # cell rows (axis 0) or columns (axis 1)
    gm = np.zeros(n_along + 1)
    gx = np.zeros(n_along + 1)
    gy = np.zeros(n_along + 1)
    for a in range(n_across):
        # dual faces: index d between node d−1 and node d along the sweep (d = 0..n_along)
        for d in range(n_along + 1):
            total = 0.0
            for line in (a - 1, a):
                if 0 <= line < n_lines_primal:
                    if d - 1 >= 0:
                        total += flux[d - 1, line] if d - 1 < flux.shape[0] else 0.0
                    if d < flux.shape[0]:
                        total += flux[d, line]
            # dual face d sits between primal faces d−1 and d: mean of up to four fluxes
            g = 0.25 * rho * total
            gm[d] = g
            gx[d] = 0.0
            gy[d] = 0.0
            if g == 0.0:
                continue
            up = d - 1 if g > 0.0 else d
            if up < 0 or up >= n_along:
                continue  # from outside: the base at rest brings mass, no momentum
            ui, uj = (up, a) if axis == 0 else (a, up)
            wx, wy = vx[ui, uj], vy[ui, uj]
            if order == 2:
                lo = max(up - 1, 0)
                hi = min(up + 1, n_along - 1)
                li, lj = (lo, a) if axis == 0 else (a, lo)
                hi_i, hi_j = (hi, a) if axis == 0 else (a, hi)
                courant = min(abs(g) / max(mass[ui, uj], mass_floor), 1.0)
                half = (0.5 if g > 0.0 else -0.5) * (1.0 - courant)
                wx += half * van_leer(wx - vx[li, lj], vx[hi_i, hi_j] - wx)
                wy += half * van_leer(wy - vy[li, lj], vy[hi_i, hi_j] - wy)
            gx[d] = g * wx
            gy[d] = g * wy
        for n in range(n_along):
            ni, nj = (n, a) if axis == 0 else (a, n)
            m_old = mass[ni, nj]
            m_new = m_old + gm[n] - gm[n + 1]
            px = m_old * vx[ni, nj] + gx[n] - gx[n + 1]
            py = m_old * vy[ni, nj] + gy[n] - gy[n + 1]
            audit[1] -= 0.5 * m_old * (vx[ni, nj] ** 2 + vy[ni, nj] ** 2)
            mass[ni, nj] = m_new
            if m_new > mass_floor:
                vx[ni, nj] = px / m_new
                vy[ni, nj] = py / m_new
            else:
                vx[ni, nj] = 0.0
                vy[ni, nj] = 0.0
            audit[1] += 0.5 * m_new * (vx[ni, nj] ** 2 + vy[ni, nj] ** 2)


@njit(**JIT)
def share_merged_fill(cells, merge):
    """A merged sliver pair (rows i, j, i', j') shares one fill and one mean stress after a remap."""
    phi, q, open_frac = cells.phi, cells.q, cells.open_frac
    for k in range(merge.shape[0]):
        si, sj, ni, nj = merge[k, 0], merge[k, 1], merge[k, 2], merge[k, 3]
        os_, on = open_frac[si, sj], open_frac[ni, nj]
        ps, pn = phi[si, sj], phi[ni, nj]
        tot = ps + pn
        if tot <= 0.0:
            continue
        fill = tot / (os_ + on)
        phi[si, sj] = fill * os_
        phi[ni, nj] = fill * on
        ms = (q[SXX, si, sj] + q[SYY, si, sj] + q[SZZ, si, sj]) / 3.0
        mn = (q[SXX, ni, nj] + q[SYY, ni, nj] + q[SZZ, ni, nj]) / 3.0
        mean = (ps * ms + pn * mn) / tot
        for r in (SXX, SYY, SZZ):
            q[r, si, sj] += mean - ms
            q[r, ni, nj] += mean - mn


@njit(**JIT)
def remap_sweeps(mesh, cells, faces, nodes, par, inflow, first, audit):
    """Both sweeps, the axis ``first`` first, with the gathered travel as velocity × time (Δt = 1):
    the cell state, then the momentum of the structured nodes (split nodes keep theirs). Returns
    the net soil volume that entered at the base and the sides (m³)."""
    nxn, nyn = len(mesh.x), len(mesh.y)
    n = mesh.n_grid
    ux = nodes.travel[0, :n].reshape((nxn, nyn))
    uy = nodes.travel[1, :n].reshape((nxn, nyn))
    mass = nodes.mass[:n].reshape((nxn, nyn))
    vx = nodes.v[0, :n].reshape((nxn, nyn))
    vy = nodes.v[1, :n].reshape((nxn, nyn))
    entered = 0.0
    for sweep in range(2):
        # each sweep is called with its axis as a constant: the compiler specialises the sweep's
        # branches on it (an axis passed in a variable cost a third of the remap)
        if (sweep == 0) == (first == 0):
            entered += advect_cells(0, mesh, cells, faces, ux, uy, 1.0, par, inflow, audit)
            advect_momentum(0, faces.flux_x, par.density, mass, vx, vy, par.advection_order, par.mass_floor, audit)
        else:
            entered += advect_cells(1, mesh, cells, faces, ux, uy, 1.0, par, inflow, audit)
            advect_momentum(1, faces.flux_y, par.density, mass, vx, vy, par.advection_order, par.mass_floor, audit)
    return entered
