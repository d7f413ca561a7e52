"""Element kernels of the 3D CEL step: eight-node hexahedra (boxes of the rectilinear grid), one-point rule.

Cell arrays have shape (nx, ny, nz); node arrays are flat (:mod:`dsmv.cel.layout`) and a cell finds
its eight nodes in the corner table, local corners in the order of
:func:`~dsmv.cel.layout.corner_offsets`: 0 (−,−,−), 1 (+,−,−), 2 (+,+,−), 3 (−,+,−), then 4–7 the
same one layer up. The transported cell state ``q`` has the rows of :data:`ROWS_3D`: σxx, σyy, σzz,
σxy, σyz, σzx (the soil's own, tension positive, Pa; the cell carries φ·σ), ξ, z0, then any soil-law
state. z is up.

On a box the one-point gradient of the trilinear shape functions is ∂N_a/∂x = s_a/(4·dx) with
s_a = ±1 the corner's side along x, and the four hourglass vectors (the products ηζ, ζξ, ξη and ξηζ
of the corners' signs) are orthogonal to every linear field: the viscous hourglass control of
Flanagan & Belytschko (1981) acts on them directly, scaled to match the 2D element (:data:`HOURGLASS_SCALE`).
The stress update rotates σ with the spin (Jaumann), adds the elastic trial increment and returns
to Tresca's hexagonal prism with its corners (de Souza Neto, Perić & Owen 2008, in principal
axes) or to the von Mises cylinder.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from dsmv.cel.kernels.common import (INLINE, JIT, PARALLEL, bulk_viscosity, elastic_energy_density, intact_strength,
                                     law_factor, law_rows, law_state, ordered_sums, radial_return,
                                     spread_order, tresca_return)
from dsmv.cel.kernels.nodes import zero_in_blocks
from dsmv.cel.layout import ROWS_3D, corner_sides, hourglass_vectors

SXX, SYY, SZZ, SXY, SYZ, SZX = (ROWS_3D.of(c) for c in ("xx", "yy", "zz", "xy", "yz", "zx"))
XI, Z0, NQ_BASE = ROWS_3D.xi, ROWS_3D.z0, ROWS_3D.base

#: each local corner's side (−1 or +1) along x, y and z (rows), in the corner table's order
SIDE = corner_sides(3)
#: the hourglass vectors ηζ, ζξ, ξη, ξηζ over the corners: the trilinear modes the one-point rule cannot see
HOURGLASS = hourglass_vectors(3)
#: the viscous hourglass force's scale, ρ·c·V^(2/3) times this: a slab one cell thick whose nodes
#: move alike on both faces then feels, per unit thickness, the 2D element's force (ρ·c·√A/4 on
#: the Q4 mode, which the slab sees as the ζξ vector over both faces, twice over eight nodes)
HOURGLASS_SCALE = 1.0 / 16.0
#: what a slab's cells sum: plastic work, hourglass and bulk-viscosity power, the force on the body (x, y,
#: z) and its moment about the grid's origin
N_SLAB_SUMS = 9
#: Jacobi sweeps at most, for a 3×3 symmetric matrix (it converges quadratically: 4–5 suffice)
JACOBI_SWEEPS = 12


@njit(**JIT)
def cell_volumes(x, y, z):
    """Cell volumes (m³)."""
    vol = np.empty((len(x) - 1, len(y) - 1, len(z) - 1))
    for i in range(len(x) - 1):
        for j in range(len(y) - 1):
            for k in range(len(z) - 1):
                vol[i, j, k] = (x[i + 1] - x[i]) * (y[j + 1] - y[j]) * (z[k + 1] - z[k])
    return vol


@njit(**INLINE)
def cell_nodes(corner, split, i, j, k, ny1, nz1, out):
    """Cell (i, j, k)'s eight nodes into ``out`` (uint64): from the corner table where a split node is
    used, else the structured numbering ((i·(ny+1) + j)·(nz+1) + k, the table's own)."""
    if split[i, j, k]:
        for c in range(8):
            out[c] = np.uint64(corner[i, j, k, c])
    else:
        n0 = (np.uint64(i) * ny1 + np.uint64(j)) * nz1 + np.uint64(k)
        out[0] = n0
        out[1] = n0 + ny1 * nz1
        out[2] = out[1] + nz1
        out[3] = n0 + nz1
        for c in range(4):
            out[c + 4] = out[c] + np.uint64(1)


@njit(**INLINE)
def walsh(u0, u1, u2, u3, u4, u5, u6, u7):
    """The eight corner values u_b (b = ox + 2·oy + 4·oz, the corner's offsets) in the basis of the
    corner sign products: coefficient M = Σ_b Π_{axes in M} s(b)·u_b, s = ±1 the side along that axis,
    so M = 1, 2, 4 are the x, y, z gradients' sums and M = 3, 5, 6, 7 the hourglass vectors ξη, ζξ, ηζ,
    ξηζ. Three butterflies (lo, hi) → (lo + hi, hi − lo): 24 additions instead of 64 products."""
    u0, u1, u2, u3, u4, u5, u6, u7 = u0 + u1, u1 - u0, u2 + u3, u3 - u2, u4 + u5, u5 - u4, u6 + u7, u7 - u6
    u0, u1, u2, u3, u4, u5, u6, u7 = u0 + u2, u1 + u3, u2 - u0, u3 - u1, u4 + u6, u5 + u7, u6 - u4, u7 - u5
    return u0 + u4, u1 + u5, u2 + u6, u3 + u7, u4 - u0, u5 - u1, u6 - u2, u7 - u3


@njit(**INLINE)
def walsh_transposed(c0, c1, c2, c3, c4, c5, c6, c7):
    """The transpose of :func:`walsh`: corner values u_b = Σ_M Π_{axes in M} s(b)·c_M, by the butterflies
    (lo, hi) → (lo − hi, lo + hi) in reverse order. Forces from their coefficients."""
    c0, c1, c2, c3, c4, c5, c6, c7 = c0 - c4, c1 - c5, c2 - c6, c3 - c7, c0 + c4, c1 + c5, c2 + c6, c3 + c7
    c0, c1, c2, c3, c4, c5, c6, c7 = c0 - c2, c1 - c3, c0 + c2, c1 + c3, c4 - c6, c5 - c7, c4 + c6, c5 + c7
    return c0 - c1, c0 + c1, c2 - c3, c2 + c3, c4 - c5, c4 + c5, c6 - c7, c6 + c7


@njit(**INLINE)
def corner_walsh(v, a, n0, n1, n2, n3, n4, n5, n6, n7):
    """:func:`walsh` of velocity component a over a cell's nodes n0 … n7, given in the corner table's
    order (round each face: 0, 1, 2, 3), which the transform takes in binary order (0, 1, 3, 2)."""
    return walsh(v[a, n0], v[a, n1], v[a, n3], v[a, n2], v[a, n4], v[a, n5], v[a, n7], v[a, n6])


@njit(**INLINE)
def corner_coefficients(v, nodes8, coeff):
    """The :func:`walsh` coefficients of each velocity component over a cell's nodes into ``coeff``
    (3, 8): coeff[a, 1 << b]·(1/(4·d_b)) is ∂v_a/∂x_b, coeff[a, 0] eight times the mean."""
    for a in range(3):
        c = corner_walsh(v, a, nodes8[0], nodes8[1], nodes8[2], nodes8[3], nodes8[4], nodes8[5], nodes8[6], nodes8[7])
        for m in range(8):
            coeff[a, m] = c[m]


@njit(**INLINE)
def remap_velocity(v, a, n, n_grid, parent):
    """Velocity component a of node n as the remap moves soil with it: a split node's copy (n ≥
    ``n_grid``) lends its parent its vertical travel and keeps none of its own
    (:func:`~dsmv.cel.kernels.nodes.hand_travel_to_parents`), so horizontally it is its parent."""
    if a < 2 and n >= n_grid:
        return v[a, parent[n - n_grid]]
    return v[a, n]


@njit(**INLINE)
def remap_divergence(v, nodes8, closed, n_grid, parent, dx, dy, dz, v_grid):
    """The volumetric strain rate (1/s) the remap makes of a cell: the net flux of its faces' mean
    velocities, the nodes' as the remap takes them (:func:`remap_velocity`), each closed face (bits of
    ``closed``, :attr:`~dsmv.cel.layout.Mesh3D.closed`) moving with the body (its translation ``v_grid``,
    the grid's velocity (m/s) along x, y and z) whatever its nodes do, for the remap lets no soil through it."""
    div = 0.0
    for a in range(3):
        c = walsh(remap_velocity(v, a, nodes8[0], n_grid, parent), remap_velocity(v, a, nodes8[1], n_grid, parent),
                  remap_velocity(v, a, nodes8[3], n_grid, parent), remap_velocity(v, a, nodes8[2], n_grid, parent),
                  remap_velocity(v, a, nodes8[4], n_grid, parent), remap_velocity(v, a, nodes8[5], n_grid, parent),
                  remap_velocity(v, a, nodes8[7], n_grid, parent), remap_velocity(v, a, nodes8[6], n_grid, parent))
        total, across = c[0], c[1 << a]  # Σ of all eight, Σ upper face − Σ lower face
        lower, upper = 0.125 * (total - across), 0.125 * (total + across)  # the faces' mean velocities
        on_body = v_grid[a]
        if closed & (1 << 2 * a):
            lower = on_body
        if closed & (1 << 2 * a + 1):
            upper = on_body
        div += (upper - lower) / (dx if a == 0 else (dy if a == 1 else dz))
    return div


@njit(**INLINE)
def strain_increment(v, nodes8, dx, dy, dz, dt, coeff, d):
    """A cell's strain increment over Δt into ``d`` (xx, yy, zz, then xy, yz, zx as tensor components)
    and its spin increments (wxy, wyz, wzx) returned, from its nodes' velocities by the one-point rule;
    ``coeff`` (3, 8) is work space (:func:`corner_coefficients`)."""
    corner_coefficients(v, nodes8, coeff)
    return strain_from_coefficients(coeff, dx, dy, dz, dt, d)


@njit(**INLINE)
def strain_from_coefficients(coeff, dx, dy, dz, dt, d):
    """:func:`strain_increment` from the cell's velocity coefficients (:func:`corner_coefficients`)."""
    ix, iy, iz = 0.25 / dx, 0.25 / dy, 0.25 / dz
    d[0], d[1], d[2] = dt * (coeff[0, 1] * ix), dt * (coeff[1, 2] * iy), dt * (coeff[2, 4] * iz)
    d[3] = 0.5 * dt * (coeff[0, 2] * iy + coeff[1, 1] * ix)
    d[4] = 0.5 * dt * (coeff[1, 4] * iz + coeff[2, 2] * iy)
    d[5] = 0.5 * dt * (coeff[0, 4] * iz + coeff[2, 1] * ix)
    # spin W_ab = ½(∂v_a/∂x_b − ∂v_b/∂x_a)Δt
    return (0.5 * dt * (coeff[0, 2] * iy - coeff[1, 1] * ix), 0.5 * dt * (coeff[1, 4] * iz - coeff[2, 2] * iy),
            0.5 * dt * (coeff[2, 1] * ix - coeff[0, 4] * iz))


@njit(**INLINE)
def mean_stress_as_remapped(fn, nodes8, closed, n_grid, parent, mean, wx, wy, wz, low, size):
    """Move a cell's mean stress m from its own nodes to where the remap sees the cell
    (:func:`remap_divergence`): each corner's share along axis a, −m·w_a·s (w_a = V·φ/(4·d_a), s its
    side), is taken back where the corner's face along a is closed, or moved to the parent where the
    corner is a split node's copy (horizontally). Returns the closed faces' share, which the body takes:
    its force along x, y and z (N) and its moment about the grid's origin (N·m; the cell's corners sit at
    ``low`` + the cell's ``size`` along each axis where the corner is on the upper side)."""
    fx, fy, fz, mx, my, mz = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    for b in range(8):
        n = nodes8[b]
        px = low[0] + (size[0] if SIDE[0, b] > 0.0 else 0.0)
        py = low[1] + (size[1] if SIDE[1, b] > 0.0 else 0.0)
        pz = low[2] + (size[2] if SIDE[2, b] > 0.0 else 0.0)
        for a in range(3):
            side = SIDE[a, b]
            share = -mean * (wx if a == 0 else (wy if a == 1 else wz)) * side
            if closed & (1 << 2 * a + (1 if side > 0.0 else 0)):
                fn[a, n] -= share
                if a == 0:  # r × (share along a)
                    fx += share
                    my += pz * share
                    mz -= py * share
                elif a == 1:
                    fy += share
                    mz += px * share
                    mx -= pz * share
                else:
                    fz += share
                    mx += py * share
                    my -= px * share
            elif a < 2 and n >= n_grid:
                fn[a, n] -= share
                fn[a, parent[n - n_grid]] += share
    return fx, fy, fz, mx, my, mz


@njit(**INLINE)
def cell_forces(fn, nodes8, coeff, stress, cell, low, div, beside, remapped, n_grid, parent, par):
    """One cell's nodal forces, added into ``fn``, from its stress (σxx, σyy, σzz, σxy, σyz, σzx, the
    soil's own, Pa), the cell's fill φ, hourglass factor and edges (``cell``: φ, factor, dx, dy, dz
    in m), its lowest corner (``low``, m), its velocity coefficients ``coeff`` (:func:`corner_coefficients`)
    and its volumetric strain rate ``div`` (1/s); returns its hourglass and bulk-viscosity power (W) and
    the force it puts on the body along x, y and z (N) and its moment about the grid's origin (N·m)
    where ``remapped`` (:func:`slab_update`)."""
    sxx, syy, szz, sxy, syz, szx = stress
    f, hourglass_factor, dx, dy, dz = cell
    rho, c_wave = par.density, par.wave_speed
    vol = dx * dy * dz
    ix, iy, iz = 0.25 / dx, 0.25 / dy, 0.25 / dz
    qb = 0.0
    bv_power = 0.0
    if div < 0.0:  # bulk viscosity, in compression only
        qb = bulk_viscosity(div, min(dx, dy, dz), rho, c_wave, par.bulk_linear, par.bulk_quadratic)
        bv_power = f * qb * (-div) * vol
    sxx -= qb
    syy -= qb
    szz -= qb
    wx, wy, wz = vol * f * ix, vol * f * iy, vol * f * iz
    coef = 0.0
    if par.hourglass > 0.0 and hourglass_factor > 0.0:
        coef = HOURGLASS_SCALE * par.hourglass * hourglass_factor * rho * f * c_wave * vol ** (2.0 / 3.0)
    hg_power = 0.0
    # the node numbers as scalars: the compiler cannot tell that writes to fn leave nodes8 unchanged
    n0, n1, n2, n3, n4, n5, n6, n7 = (nodes8[0], nodes8[1], nodes8[2], nodes8[3], nodes8[4], nodes8[5], nodes8[6],
                                      nodes8[7])
    for a in range(3):
        if a == 0:
            sx, sy, sz = sxx, sxy, szx
        elif a == 1:
            sx, sy, sz = sxy, syy, syz
        else:
            sx, sy, sz = szx, syz, szz
        g3, g5, g6, g7 = coeff[a, 3], coeff[a, 5], coeff[a, 6], coeff[a, 7]
        hg_power += coef * (g3 * g3 + g5 * g5 + g6 * g6 + g7 * g7)
        f0, f1, f3, f2, f4, f5, f7, f6 = walsh_transposed(
            0.0, -sx * wx, -sy * wy, -coef * g3, -sz * wz, -coef * g5, -coef * g6, -coef * g7)
        fn[a, n0] += f0
        fn[a, n1] += f1
        fn[a, n2] += f2
        fn[a, n3] += f3
        fn[a, n4] += f4
        fn[a, n5] += f5
        fn[a, n6] += f6
        fn[a, n7] += f7
    on_body = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    if remapped:
        on_body = mean_stress_as_remapped(fn, nodes8, beside, n_grid, parent, (sxx + syy + szz) / 3.0, wx, wy, wz,
                                          low, (dx, dy, dz))
    return hg_power, bv_power, on_body


@njit(**JIT)
def nodal_forces(mesh, cells, nodes, par, v_grid, parent, law, work):
    """Internal nodal forces (N) from the cell stresses: f_a = −V·φ·σ·∇N_a at the centre; viscous
    hourglass control on the four hourglass vectors (coefficient ``par.hourglass`` times the cell's
    ``hourglass_factor``); linear and quadratic bulk viscosity in compression; in the cells beside the
    body (moving with the grid's velocity ``v_grid``: x, y, z, m/s) or with a split node (``parent``: each
    copy's parent) the mean stress as the remap sees the cell (:func:`slab_update`). ``work``
    accumulates the power of hourglass [0] and bulk viscosity [1] (W), [2:5] the force those cells
    put on the body along x, y and z (N) and [5:8] its moment about the grid's origin (N·m). Cells
    without soil are skipped. Parallel over slabs
    (:func:`slabs_in_colours`). A step computes its forces here only where none are ahead of it:
    the stress update computes the next step's (:func:`update_stress_and_forces`). ``law`` is the stress
    update's, unused here: with it both run the same compiled code, so that the forces they give are bit
    for bit the same (compiled apart, fastmath may fuse their multiply-adds differently)."""
    all_work = np.zeros(N_SLAB_SUMS)
    slabs_in_colours(mesh, cells, nodes, par, v_grid, parent, law, False, all_work)
    for m in range(N_SLAB_SUMS - 1):
        work[m] += all_work[m + 1]


@njit(**INLINE)
def jacobi_eigen(a, vec):
    """Eigenvalues (on a's diagonal) and eigenvectors (vec's columns) of the symmetric 3×3 matrix a,
    in place, by cyclic Jacobi rotations (Golub & Van Loan 2013, §8.5)."""
    for r in range(3):
        for c in range(3):
            vec[r, c] = 1.0 if r == c else 0.0
    for _ in range(JACOBI_SWEEPS):
        off = a[0, 1] * a[0, 1] + a[1, 2] * a[1, 2] + a[0, 2] * a[0, 2]
        scale = a[0, 0] * a[0, 0] + a[1, 1] * a[1, 1] + a[2, 2] * a[2, 2]
        if off <= 1e-30 * scale or off == 0.0:
            return
        for p in range(2):
            for r in range(p + 1, 3):
                apr = a[p, r]
                if apr == 0.0:
                    continue
                theta = 0.5 * (a[r, r] - a[p, p]) / apr
                t = (1.0 if theta >= 0.0 else -1.0) / (abs(theta) + math.sqrt(theta * theta + 1.0))
                cos = 1.0 / math.sqrt(t * t + 1.0)
                sin = t * cos
                for m in range(3):  # a ← Jᵀ·a·J, columns then rows
                    amp, amr = a[m, p], a[m, r]
                    a[m, p] = cos * amp - sin * amr
                    a[m, r] = sin * amp + cos * amr
                for m in range(3):
                    apm, arm = a[p, m], a[r, m]
                    a[p, m] = cos * apm - sin * arm
                    a[r, m] = sin * apm + cos * arm
                for m in range(3):
                    vmp, vmr = vec[m, p], vec[m, r]
                    vec[m, p] = cos * vmp - sin * vmr
                    vec[m, r] = sin * vmp + cos * vmr


@njit(**INLINE)
def tresca_3d(s, su, shear_mod, a, vec):
    """Return of the stress s (six components, in place) to Tresca's prism s1 − s3 ≤ 2·su in its
    principal axes (:func:`~dsmv.cel.kernels.common.tresca_return`, corners included). Returns the
    plastic shear strain increment and the multiplier sum (0 when elastic)."""
    a[0, 0], a[1, 1], a[2, 2] = s[0], s[1], s[2]
    a[0, 1] = a[1, 0] = s[3]
    a[1, 2] = a[2, 1] = s[4]
    a[0, 2] = a[2, 0] = s[5]
    jacobi_eigen(a, vec)
    e0, e1, e2 = a[0, 0], a[1, 1], a[2, 2]
    # sort descending, remembering each principal value's axis
    i1, i2, i3 = 0, 1, 2
    if e0 < e1:
        e0, e1, i1, i2 = e1, e0, i2, i1
    if e1 < e2:
        e1, e2, i2, i3 = e2, e1, i3, i2
    if e0 < e1:
        e0, e1, i1, i2 = e1, e0, i2, i1
    n1, n2, n3, dxi, dg = tresca_return(e0, e1, e2, su, shear_mod)
    if dg <= 0.0:
        return 0.0, 0.0
    d1, d2, d3 = n1 - e0, n2 - e1, n3 - e2  # σ ← σ + Σ Δs_i·e_i⊗e_i
    rows = ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2))
    for m in range(6):
        r, c = rows[m]
        s[m] += d1 * vec[r, i1] * vec[c, i1] + d2 * vec[r, i2] * vec[c, i2] + d3 * vec[r, i3] * vec[c, i3]
    return dxi, dg


@njit(**INLINE)
def shear_rate_3d(d, a, vec):
    """(Δε1 − Δε3) of the strain increment d (six components, shear as tensor components)."""
    a[0, 0], a[1, 1], a[2, 2] = d[0], d[1], d[2]
    a[0, 1] = a[1, 0] = d[3]
    a[1, 2] = a[2, 1] = d[4]
    a[0, 2] = a[2, 0] = d[5]
    jacobi_eigen(a, vec)
    return max(a[0, 0], a[1, 1], a[2, 2]) - min(a[0, 0], a[1, 1], a[2, 2])


@njit(**INLINE)
def cell_stress(q, su_cell, cell, d, spin, strength, volume, par, law, s, a, vec):
    """The stress update of cell (i, j, k) = ``cell`` (:func:`update_stress_and_forces`) from its strain
    increment ``d`` and spin increments (wxy, wyz, wzx), its strength before the soil law (Pa) and its soil volume (m³): the new
    stress into ``q`` and ``s``, ξ and the law's state into ``q``, the strength into ``su_cell``;
    returns the plastic work (J)."""
    i, j, k = cell
    wxy, wyz, wzx = spin
    shear_mod, dt = par.shear, par.dt
    lam = par.bulk - 2.0 * shear_mod / 3.0
    n_state = law_rows(q, par, NQ_BASE)
    sxx, syy, szz = q[SXX, i, j, k], q[SYY, i, j, k], q[SZZ, i, j, k]
    sxy, syz, szx = q[SXY, i, j, k], q[SYZ, i, j, k], q[SZX, i, j, k]
    # Jaumann: σ + W·σ − σ·W (W = [[0, wxy, −wzx], [−wxy, 0, wyz], [wzx, −wyz, 0]])
    s[0] = sxx + 2.0 * (wxy * sxy - wzx * szx)
    s[1] = syy + 2.0 * (wyz * syz - wxy * sxy)
    s[2] = szz + 2.0 * (wzx * szx - wyz * syz)
    s[3] = sxy + wxy * (syy - sxx) + wyz * szx - wzx * syz
    s[4] = syz + wyz * (szz - syy) + wzx * sxy - wxy * szx
    s[5] = szx + wzx * (sxx - szz) + wxy * syz - wyz * sxy
    tr = d[0] + d[1] + d[2]
    for m in range(3):
        s[m] += lam * tr + 2.0 * shear_mod * d[m]
    for m in range(3, 6):
        s[m] += 2.0 * shear_mod * d[m]
    su = strength
    if su < 0.0:
        su = 0.0
    xi_before = q[XI, i, j, k]
    gamma_dot = 0.0
    if law is not None and par.law_active:
        gamma_dot = shear_rate_3d(d, a, vec) / dt
        s0 = q[NQ_BASE, i, j, k] if n_state > 0 else 0.0
        s1 = q[NQ_BASE + 1, i, j, k] if n_state > 1 else 0.0
        su *= law_factor(law, xi_before, gamma_dot, s0, s1, q[Z0, i, j, k])
    su_cell[i, j, k] = su
    p = (s[0] + s[1] + s[2]) / 3.0
    dev_sq = ((s[0] - p) ** 2 + (s[1] - p) ** 2 + (s[2] - p) ** 2
              + 2.0 * (s[3] * s[3] + s[4] * s[4] + s[5] * s[5]))
    plastic = 0.0
    if 0.5 * dev_sq > su * su:  # J2 > su²: outside the von Mises cylinder, which contains Tresca's prism
        if par.tresca:
            dxi, dg = tresca_3d(s, su, shear_mod, a, vec)
            if dg > 0.0:
                q[XI, i, j, k] += dxi
                plastic = 2.0 * su * dg * volume
        else:
            scale, dlam = radial_return(math.sqrt(dev_sq), su, shear_mod)
            for m in range(3):
                s[m] = p + (s[m] - p) * scale
            for m in range(3, 6):
                s[m] *= scale
            q[XI, i, j, k] += math.sqrt(2.0) * dlam
            plastic = math.sqrt(2.0) * su * dlam * volume
    for m in range(6):
        q[m, i, j, k] = s[m]
    if law is not None and n_state > 0:
        s0 = q[NQ_BASE, i, j, k]
        s1 = q[NQ_BASE + 1, i, j, k] if n_state > 1 else 0.0
        xi = q[XI, i, j, k]
        for m in range(n_state):
            q[NQ_BASE + m, i, j, k] = law_state(law, m, s0, s1, xi, xi - xi_before, gamma_dot, dt, q[Z0, i, j, k])
    return plastic


@njit(**JIT)
def slab_update(i, mesh, cells, v, v_grid, parent, fn, par, law, stress):
    """The cells of slab i (all j, k): with ``stress``, their stress update (:func:`update_stress_and_forces`);
    then their nodal forces, added into ``fn``. Returns the slab's plastic work (J), hourglass and
    bulk-viscosity power (W), and the force its cells beside the body put on the body along x, y and z
    (N) and its moment about the grid's origin (N·m). A slab's cells touch the nodes of planes i and
    i + 1 only (split nodes included: a copy sits on
    its parent's plane). Containers are read once per slab (a container passed per cell costs a
    reference count per array).

    Per axis a, the corner velocities go to their sign-product coefficients (:func:`walsh`): three
    are the velocity gradient's, four the hourglass amplitudes g. The forces' coefficients are
    −V·φ·σ_ab/(4·d_b) on the gradient's and −coef·g on the hourglass vectors, and go back to the
    corners by the transposed transform.

    With the remap on (``par.remap``), in a cell beside the body or with a split node the mean stress
    acts as the work-conjugate of :func:`remap_divergence` (:func:`mean_stress_as_remapped`): through
    the open faces only, the body taking the closed faces' share, and a split node's horizontal share
    at its parent; the stress update takes its volumetric strain from the same divergence."""
    x, y, z, corner, split, closed = mesh.x, mesh.y, mesh.z, mesh.corner, mesh.split, mesh.closed
    n_grid = np.uint64(mesh.n_grid)
    phi, q, su_cell, factor, open_frac = cells.phi, cells.q, cells.su, cells.strength_factor, cells.open_frac
    hourglass_factor = cells.hourglass_factor
    _, ny, nz = phi.shape
    ny1, nz1 = np.uint64(ny + 1), np.uint64(nz + 1)
    nodes8 = np.empty(8, dtype=np.uint64)
    coeff = np.empty((3, 8))
    s = np.empty(6)
    d = np.empty(6)
    a = np.empty((3, 3))
    vec = np.empty((3, 3))
    plastic = 0.0
    hg_power = 0.0
    bv_power = 0.0
    fx, fy, fz, mx, my, mz = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0  # the force and moment on the body
    dx = x[i + 1] - x[i]
    for j in range(ny):
        dy = y[j + 1] - y[j]
        for k in range(nz):
            f = phi[i, j, k]
            stressed = stress and f > par.stress_cutoff * open_frac[i, j, k]
            if stress and not stressed:
                for m in range(6):
                    q[m, i, j, k] = 0.0
                su_cell[i, j, k] = 0.0
            if f <= 0.0 and par.skip_void:
                continue
            dz = z[k + 1] - z[k]
            cell_nodes(corner, split, i, j, k, ny1, nz1, nodes8)
            corner_coefficients(v, nodes8, coeff)
            beside = closed[i, j, k]
            remapped = par.remap and (beside != 0 or split[i, j, k])
            if remapped:
                div = remap_divergence(v, nodes8, beside, n_grid, parent, dx, dy, dz, v_grid)
            else:
                div = coeff[0, 1] * (0.25 / dx) + coeff[1, 2] * (0.25 / dy) + coeff[2, 4] * (0.25 / dz)
            if stressed:
                spin = strain_from_coefficients(coeff, dx, dy, dz, par.dt, d)
                if remapped:
                    # the volumetric part the remap makes, the deviatoric the cell's own: the pressure then
                    # feels the soil the remap packs against the body (2D's cut cells do the same,
                    # :func:`dsmv.cel.kernels.elements2d.volumetric_override`); without a remap nothing packs
                    shift = (par.dt * div - d[0] - d[1] - d[2]) / 3.0
                    for m in range(3):
                        d[m] += shift
                strength = intact_strength(par, q[Z0, i, j, k]) * factor[i, j, k]
                plastic += cell_stress(q, su_cell, (i, j, k), d, spin, strength, dx * dy * dz * f, par, law, s, a, vec)
            stress_now = (q[SXX, i, j, k], q[SYY, i, j, k], q[SZZ, i, j, k], q[SXY, i, j, k], q[SYZ, i, j, k],
                          q[SZX, i, j, k])
            hg, bv, f6 = cell_forces(fn, nodes8, coeff, stress_now, (f, hourglass_factor[i, j, k], dx, dy, dz),
                                     (x[i], y[j], z[k]), div, beside, remapped, n_grid, parent, par)
            hg_power += hg
            bv_power += bv
            if remapped:  # only the cells beside the body pass it anything
                fx, fy, fz = fx + f6[0], fy + f6[1], fz + f6[2]
                mx, my, mz = mx + f6[3], my + f6[4], mz + f6[5]
    return plastic, hg_power, bv_power, fx, fy, fz, mx, my, mz


@njit(**JIT)
def update_stress_and_forces(mesh, cells, nodes, par, v_grid, parent, law, work):
    """Stress update for undrained soil of strength su = (su0 + ks·z0)·f·law(ξ, γ̇, state): Jaumann
    rotation by the spin, elastic trial, return (Tresca with ``par.tresca``, else von Mises √J2 ≤ su).
    ξ accumulates Δε1^p − Δε3^p; ``cells.su`` receives each cell's strength (Pa). Beside the body
    (moving with the grid's velocity ``v_grid``: x, y, z, m/s) and in cells with a split node (``parent``: each copy's
    parent) the volumetric strain is the remap's (:func:`remap_divergence`). As
    :func:`dsmv.cel.kernels.elements2d.update_stress`, in three dimensions. Tresca's return needs the
    principal axes only where √J2 > su (s1 − s3 ≤ 2·√J2 always).

    Then, cell by cell while its nodes' velocities are at hand, the nodal forces of the next step
    (:func:`nodal_forces`): they depend on the new stress and on these same velocities, which nothing
    changes before the next step but a remap. ``work`` receives the plastic work [0] (J), and the
    next step's hourglass [1] and bulk-viscosity power [2] (W) and force on the body [3:6] (N, along x,
    y and z) and its moment about the grid's origin [6:9] (N·m).
    Parallel over slabs in two colours as :func:`nodal_forces` (a cell writes only its own state);
    the slabs' sums are added in slab order, so the result does not depend on the number of threads."""
    slabs_in_colours(mesh, cells, nodes, par, v_grid, parent, law, True, work)


@njit(**PARALLEL)
def slabs_in_colours(mesh, cells, nodes, par, v_grid, parent, law, stress, work):
    """:func:`slab_update` over all slabs, into zeroed node forces: in two colours, the even slabs then the
    odd ones, each colour's in :func:`~dsmv.cel.kernels.common.spread_order`. Slabs of one colour share
    no node, so each node sums its cells' forces in the same order whatever the number of threads; the
    slabs' sums (``work``: plastic work, hourglass and bulk-viscosity power, force on the body) are
    added in slab order, so the results are bit for bit the same on any number of threads."""
    nx = cells.phi.shape[0]
    fn = nodes.f
    zero_in_blocks(fn)
    sums = np.zeros((N_SLAB_SUMS, nx))
    for colour in range(2):
        order = spread_order((nx - colour + 1) // 2)
        for s in prange(len(order)):
            i = 2 * order[s] + colour
            slab = slab_update(i, mesh, cells, nodes.v, v_grid, parent, fn, par, law, stress)
            for m in range(N_SLAB_SUMS):
                sums[m, i] = slab[m]
    for m in range(N_SLAB_SUMS):
        work[m] = 0.0
    for i in range(nx):
        for m in range(N_SLAB_SUMS):
            work[m] += sums[m, i]


@njit(**JIT)
def shear_strain_rates(mesh, cells, faces, nodes, par, v_body):
    """Each cell's shear strain rate γ̇ = ε̇1 − ε̇3 (1/s) by the stress update's own rule, 0 in cells that
    carry no stress: what the field output shows (the remap's volumetric part, which the update takes
    beside the body, does not change it). (``faces`` and ``v_body``: the 2D kernel's signature.)"""
    x, y, z, corner, split = mesh.x, mesh.y, mesh.z, mesh.corner, mesh.split
    nx, ny, nz = cells.phi.shape
    ny1, nz1 = np.uint64(ny + 1), np.uint64(nz + 1)
    rate = np.zeros((nx, ny, nz))
    nodes8 = np.empty(8, dtype=np.uint64)
    coeff = np.empty((3, 8))
    d = np.empty(6)
    a = np.empty((3, 3))
    vec = np.empty((3, 3))
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                if cells.phi[i, j, k] <= par.stress_cutoff * cells.open_frac[i, j, k]:
                    continue
                cell_nodes(corner, split, i, j, k, ny1, nz1, nodes8)
                strain_increment(nodes.v, nodes8, x[i + 1] - x[i], y[j + 1] - y[j], z[k + 1] - z[k], 1.0, coeff, d)
                rate[i, j, k] = shear_rate_3d(d, a, vec)
    return rate


@njit(**INLINE)
def cell_elastic_energy_density(q, i, j, k, shear_mod, bulk_mod):
    """Linear elastic energy per unit volume of cell (i, j, k)'s stress (J/m³)."""
    return elastic_energy_density(q[SXX, i, j, k], q[SYY, i, j, k], q[SZZ, i, j, k], q[SXY, i, j, k], q[SYZ, i, j, k],
                                  q[SZX, i, j, k], shear_mod, bulk_mod)


@njit(**JIT)
def elastic_energy(phi, q, vol, shear_mod, bulk_mod):
    """Elastic energy stored in the soil (J)."""
    total = 0.0
    nx, ny, nz = phi.shape
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                f = phi[i, j, k]
                if f > 0.0:
                    total += vol[i, j, k] * f * cell_elastic_energy_density(q, i, j, k, shear_mod, bulk_mod)
    return total


@njit(**JIT)
def slab_modes(i, corner, phi, v, full):
    """:func:`hourglass_modes` over the cells of slab i."""
    _, ny, nz = phi.shape
    hourglass_sq = 0.0
    linear_sq = 0.0
    for j in range(ny):
        for k in range(nz):
            if phi[i, j, k] < full:
                continue
            n0, n1, n2, n3 = corner[i, j, k, 0], corner[i, j, k, 1], corner[i, j, k, 2], corner[i, j, k, 3]
            n4, n5, n6, n7 = corner[i, j, k, 4], corner[i, j, k, 5], corner[i, j, k, 6], corner[i, j, k, 7]
            for a in range(3):
                c = corner_walsh(v, a, n0, n1, n2, n3, n4, n5, n6, n7)
                hourglass_sq += c[3] * c[3] + c[5] * c[5] + c[6] * c[6] + c[7] * c[7]
                linear_sq += c[1] * c[1] + c[2] * c[2] + c[4] * c[4]
    return hourglass_sq / 64.0, linear_sq / 64.0


@njit(**PARALLEL)
def hourglass_modes(corner, phi, v, full):
    """How much of the nodal velocity field is hourglass (the zig-zag diagnostic, as in 2D): over
    cells with φ ≥ ``full``, Σ|hourglass amplitudes|² and Σ|linear amplitudes|² (m²/s²), each
    amplitude the projection on its corner vector over the vector's squared length (8): the
    :func:`walsh` coefficients over 8. Parallel over slabs, summed in slab order."""
    nx = phi.shape[0]
    sums = np.zeros((2, nx))
    for i in prange(nx):
        sums[0, i], sums[1, i] = slab_modes(i, corner, phi, v, full)
    return ordered_sums(sums)
