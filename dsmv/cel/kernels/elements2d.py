"""Element kernels of the 2D CEL step (plane strain and axisymmetry): Q4 cells, one-point rule.

Cell arrays have shape (nx, ny); node arrays are flat (:mod:`dsmv.cel.layout`) and a cell finds
its four nodes in the corner table: local corner 0 (−,−), 1 (+,−), 2 (+,+), 3 (−,+). Stress is
the soil's own (tension positive, Pa); the cell carries φ·σ. The transported cell state ``q``
has the rows of :data:`dsmv.cel.layout.PLANE`: σxx, σyy, σxy, σzz (σθθ when axisymmetric), ξ, z0,
then any soil-law state.

Axisymmetric mode (x = r): volumes and face areas per radian are weighted by r, the hoop
strain rate is v_r/r and the hoop stress enters the radial nodal force (one-point rule).

References: Flanagan & Belytschko (1981) IJNME 17 (one-point quadrature, hourglass
control); de Souza Neto, Perić & Owen (2008) (the Tresca return).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from dsmv.cel.kernels.common import (CUT_OPEN_FLOOR, INLINE, JIT, bulk_viscosity, elastic_energy_density, intact_strength,
                                     law_factor, law_rows, law_state, radial_return, tresca_return)
from dsmv.cel.layout import ROWS_2D

SXX, SYY, SXY, SZZ = (ROWS_2D.of(c) for c in ("xx", "yy", "xy", "zz"))
XI, Z0, NQ_BASE = ROWS_2D.xi, ROWS_2D.z0, ROWS_2D.base

#: a cell beside a face the soil may leave is full, and carries stress, from this fill on (-): a
#: cell in contact reads 1 ± a few per mille (compression, remap round-off); at 0.999 the stress
#: flickered on and off (curve roughness 0.49 at B/20), 0.95 and 0.99 read the same factors
GAP_CELL_FULL = 0.95
#: an unsigned 1, for node index arithmetic (an int literal would turn a uint64 sum into a float)
ONE = np.uint64(1)


@njit(**JIT)
def cell_volumes(x, y, axisym):
    """Cell volume per unit thickness (plane strain) or per radian (axisymmetric), m³."""
    nx, ny = len(x) - 1, len(y) - 1
    vol = np.empty((nx, ny))
    for i in range(nx):
        r = 0.5 * (x[i] + x[i + 1]) if axisym else 1.0
        for j in range(ny):
            vol[i, j] = (x[i + 1] - x[i]) * (y[j + 1] - y[j]) * r
    return vol


@njit(**INLINE)
def cell_velocities(corner, v, i, j):
    """The four nodal velocities of cell (i, j), as one tuple vx0..vx3, vy0..vy3 (m/s)."""
    n0, n1, n2, n3 = corner[i, j, 0], corner[i, j, 1], corner[i, j, 2], corner[i, j, 3]
    return v[0, n0], v[0, n1], v[0, n2], v[0, n3], v[1, n0], v[1, n1], v[1, n2], v[1, n3]


@njit(**INLINE)
def cut_flux(i, j, dx, dy, vel, v_body, faces):
    """Net outflow of cell (i, j) through the open parts of its faces, relative to the body
    (m²/s per unit thickness, plane strain); ``vel`` the nodal velocities (:func:`cell_velocities`)."""
    vx0, vx1, vx2, vx3, vy0, vy1, vy2, vy3 = vel
    ax, ay = faces.aperture_x, faces.aperture_y
    flux = dy * (ax[i + 1, j] * 0.5 * (vx1 + vx2) - ax[i, j] * 0.5 * (vx0 + vx3))
    return flux + dx * (ay[j + 1, i] * (0.5 * (vy2 + vy3) - v_body) - ay[j, i] * (0.5 * (vy0 + vy1) - v_body))


@njit(**INLINE)
def cut_divergence(i, j, dx, dy, vel, v_body, faces, open_ij):
    """Volumetric strain rate (1/s) of the soil in a cell the body cuts: :func:`cut_flux` over the
    cell's open area (floored at ``CUT_OPEN_FLOOR``)."""
    return cut_flux(i, j, dx, dy, vel, v_body, faces) / (max(open_ij, CUT_OPEN_FLOOR) * dx * dy)


@njit(**INLINE)
def merged_divergence(si, sj, ni, nj, mesh, nodes, v_body, faces, open_frac):
    """Volumetric strain rate (1/s) of a merged pair, a sliver (si, sj) and its neighbour (ni, nj):
    their joint net outflow (the shared face cancels) over their joint open area."""
    x, y = mesh.x, mesh.y
    flux = 0.0
    for i, j in ((si, sj), (ni, nj)):
        flux += cut_flux(i, j, x[i + 1] - x[i], y[j + 1] - y[j], cell_velocities(mesh.corner, nodes.v, i, j), v_body,
                         faces)
    return flux / ((open_frac[si, sj] + open_frac[ni, nj]) * (x[si + 1] - x[si]) * (y[sj + 1] - y[sj]))


@njit(**INLINE)
def add_cut_forces(f, corner, i, j, dx, dy, faces, open_eff, fill, sxx, syy):
    """In a cell the body cuts, the mean stress m on the open parts only: −(φ/2)·m·Σ (a_f/open − 1)·A_f·n_f
    per node. Returns the body's share, the mean stress on the arc, (φ/open)·m·Σ a_f·A_f·n_fy (N, up +)."""
    ax, ay = faces.aperture_x, faces.aperture_y
    n0, n1, n2, n3 = corner[i, j, 0], corner[i, j, 1], corner[i, j, 2], corner[i, j, 3]
    k = -0.25 * fill * (sxx + syy)
    c_left = (ax[i, j] / open_eff - 1.0) * dy
    c_right = (ax[i + 1, j] / open_eff - 1.0) * dy
    c_bottom = (ay[j, i] / open_eff - 1.0) * dx
    c_top = (ay[j + 1, i] / open_eff - 1.0) * dx
    f[0, n0] -= k * c_left
    f[1, n0] -= k * c_bottom
    f[0, n1] += k * c_right
    f[1, n1] -= k * c_bottom
    f[0, n2] += k * c_right
    f[1, n2] += k * c_top
    f[0, n3] -= k * c_left
    f[1, n3] += k * c_top
    return fill / open_eff * 0.5 * (sxx + syy) * dx * (ay[j + 1, i] - ay[j, i])


@njit(**INLINE)
def cell_nodes(corner, split, i, j, ny1):
    """Cell (i, j)'s four nodes as unsigned indices (Numba checks a signed index for wraparound at every
    access): from the corner table where the cell uses a split node, else the structured numbering
    (i·(ny+1) + j, the table's own for every other cell)."""
    if split[i, j]:
        return (np.uint64(corner[i, j, 0]), np.uint64(corner[i, j, 1]), np.uint64(corner[i, j, 2]),
                np.uint64(corner[i, j, 3]))
    n0 = np.uint64(i) * ny1 + np.uint64(j)
    return n0, n0 + ny1, n0 + ny1 + ONE, n0 + ONE


@njit(**INLINE)
def add_stress_forces(fn, n0, n1, n2, n3, ax, ay, sxx, syy, sxy):
    """A cell's stress into its nodes' forces by the one-point rule, −V·φ·σ·∇N_a, with
    ``ax`` = V·φ/(2·dx) and ``ay`` = V·φ/(2·dy)."""
    fn[0, n0] += ax * sxx + ay * sxy
    fn[1, n0] += ax * sxy + ay * syy
    fn[0, n1] += -ax * sxx + ay * sxy
    fn[1, n1] += -ax * sxy + ay * syy
    fn[0, n2] += -ax * sxx - ay * sxy
    fn[1, n2] += -ax * sxy - ay * syy
    fn[0, n3] += ax * sxx - ay * sxy
    fn[1, n3] += ax * sxy - ay * syy


@njit(**INLINE)
def add_hoop_forces(fn, n0, n1, n2, n3, hoop):
    """The hoop stress's share of an axisymmetric cell's radial forces, −A·φ·σθθ·N_a (``hoop``, N_a = 1/4)."""
    fn[0, n0] -= hoop
    fn[0, n1] -= hoop
    fn[0, n2] -= hoop
    fn[0, n3] -= hoop


@njit(**INLINE)
def add_hourglass_forces(fn, n0, n1, n2, n3, vel, c):
    """The viscous hourglass force c·Γ·(Γ·v) on the Q4 mode Γ = (1, −1, 1, −1) (Flanagan & Belytschko
    1981); returns its power (W)."""
    vx0, vx1, vx2, vx3, vy0, vy1, vy2, vy3 = vel
    gx = vx0 - vx1 + vx2 - vx3
    gy = vy0 - vy1 + vy2 - vy3
    hx = c * gx
    hy = c * gy
    fn[0, n0] -= hx
    fn[1, n0] -= hy
    fn[0, n1] += hx
    fn[1, n1] += hy
    fn[0, n2] -= hx
    fn[1, n2] -= hy
    fn[0, n3] += hx
    fn[1, n3] += hy
    return hx * gx + hy * gy


@njit(**INLINE)
def cell_divergence(dx, dy, r, axisym, vel):
    """A cell's volumetric strain rate (1/s) by the one-point rule, with the hoop rate in axisymmetry."""
    vx0, vx1, vx2, vx3, vy0, vy1, vy2, vy3 = vel
    div = (vx1 + vx2 - vx0 - vx3) / (2.0 * dx) + (vy2 + vy3 - vy0 - vy1) / (2.0 * dy)
    if axisym:
        div += 0.25 * (vx0 + vx1 + vx2 + vx3) / r
    return div


@njit(**JIT)
def nodal_forces(mesh, cells, faces, nodes, par, v_body, work):
    """Internal nodal forces (N per unit thickness or per radian) from the cell stresses.

    One-point quadrature at the cell centre, f_a = −V·φ·σ·∇N_a with ∇N_a = (±1/2dx, ±1/2dy);
    viscous hourglass control with coefficient ``par.hourglass`` times the cell's ``hourglass_factor``
    (Flanagan–Belytschko form, force ∝ ρ·c·√A·hourglass velocity, on the mode Γ = (1, −1, 1, −1));
    linear and quadratic bulk viscosity in compression. ``work`` accumulates the power dissipated by
    hourglass [0] and bulk viscosity [1] (W), to be multiplied by Δt by the caller, and [2] the vertical force the cut
    cells' mean stress puts on the body's arc (N, up +). Cells without soil give no force and are
    skipped; ``par.skip_void=False`` does their (null) arithmetic anyway, only to measure what
    skipping saves. In a cell the body cuts (``open_frac`` < 1) the in-plane mean stress acts
    through the open parts of the faces only (:func:`add_cut_forces`), the work-conjugate of
    :func:`cut_divergence`: the closed parts are the body's surface.
    """
    x, y, corner, split, v = mesh.x, mesh.y, mesh.corner, mesh.split, nodes.v
    phi, q, open_frac, shared = cells.phi, cells.q, cells.open_frac, cells.shared_divergence
    hourglass_factor = cells.hourglass_factor
    fn = nodes.f
    fn[:] = 0.0
    rho, axisym, c_wave = par.density, par.axisymmetric, par.wave_speed
    nx, ny = phi.shape
    ny1 = np.uint64(ny + 1)
    hg_power = 0.0
    bv_power = 0.0
    arc_fy = 0.0
    for i in range(nx):
        dx = x[i + 1] - x[i]
        r = 0.5 * (x[i] + x[i + 1]) if axisym else 1.0
        for j in range(ny):
            f = phi[i, j]
            if f <= 0.0 and par.skip_void:
                continue
            dy = y[j + 1] - y[j]
            area = dx * dy
            vol = area * r
            n0, n1, n2, n3 = cell_nodes(corner, split, i, j, ny1)
            vel = (v[0, n0], v[0, n1], v[0, n2], v[0, n3], v[1, n0], v[1, n1], v[1, n2], v[1, n3])
            open_ij = open_frac[i, j]
            div = cell_divergence(dx, dy, r, axisym, vel)
            if open_ij < 1.0:  # a cell the body cuts: the remap's
                div = cut_divergence(i, j, dx, dy, vel, v_body, faces, open_ij)
            # bulk viscosity: like σ it acts on the cell's soil fraction f
            qb = 0.0
            if div < 0.0:
                qb = bulk_viscosity(div, min(dx, dy), rho, c_wave, par.bulk_linear, par.bulk_quadratic)
                bv_power += f * qb * (-div) * vol
            sxx = q[SXX, i, j] - qb
            syy = q[SYY, i, j] - qb
            add_stress_forces(fn, n0, n1, n2, n3, 0.5 * vol * f / dx, 0.5 * vol * f / dy, sxx, syy, q[SXY, i, j])
            if open_ij < 1.0:
                open_eff = open_ij if not math.isnan(shared[i, j]) else max(open_ij, CUT_OPEN_FLOOR)
                arc_fy += add_cut_forces(fn, corner, i, j, dx, dy, faces, open_eff, f, sxx, syy)
            if axisym:
                add_hoop_forces(fn, n0, n1, n2, n3, 0.25 * area * f * (q[SZZ, i, j] - qb))
            if par.hourglass > 0.0 and hourglass_factor[i, j] > 0.0:
                c = 0.25 * par.hourglass * hourglass_factor[i, j] * rho * f * c_wave * math.sqrt(area) * (vol / area)
                hg_power += add_hourglass_forces(fn, n0, n1, n2, n3, vel, c)
    work[0] += hg_power
    work[1] += bv_power
    work[2] += arc_fy


@njit(**JIT)
def hourglass_modes(corner, phi, v, full):
    """How much of the nodal velocity field is the Q4 hourglass mode (a zig-zag diagnostic).

    Each cell's four nodal velocities split into v̄ + b_ξ·ξ + b_η·η + a·Γ with ξ = (−1, 1, 1, −1),
    η = (−1, −1, 1, 1) and Γ = (1, −1, 1, −1). Sums over cells with φ ≥ ``full`` of |a|² and of
    |b_ξ|² + |b_η|² (m²/s²) are returned. A smooth field has |a|/|b| = O(h) and a rigid motion has
    a = 0, so the square root of the ratio measures the zig-zag, independent of the frame.
    """
    nx, ny = phi.shape
    hourglass_sq = 0.0
    linear_sq = 0.0
    for i in range(nx):
        for j in range(ny):
            if phi[i, j] < full:
                continue
            vx0, vx1, vx2, vx3, vy0, vy1, vy2, vy3 = cell_velocities(corner, v, i, j)
            ax, ay = vx0 - vx1 + vx2 - vx3, vy0 - vy1 + vy2 - vy3
            bxx, bxy = -vx0 + vx1 + vx2 - vx3, -vy0 + vy1 + vy2 - vy3
            byx, byy = -vx0 - vx1 + vx2 + vx3, -vy0 - vy1 + vy2 + vy3
            hourglass_sq += 0.0625 * (ax * ax + ay * ay)
            linear_sq += 0.0625 * (bxx * bxx + bxy * bxy + byx * byx + byy * byy)
    return hourglass_sq, linear_sq


@njit(**JIT)
def strain_increment(dt, dx, dy, r, axisym, vel):
    """A Q4 cell's strain increments Δεxx, Δεyy, Δεxy, Δεzz and spin increment (-) over Δt from its
    four nodal velocities ``vel`` (one-point rule; r the centre's radius in axisymmetry)."""
    vx0, vx1, vx2, vx3, vy0, vy1, vy2, vy3 = vel
    dxx = dt * (vx1 + vx2 - vx0 - vx3) / (2.0 * dx)
    dyy = dt * (vy2 + vy3 - vy0 - vy1) / (2.0 * dy)
    dvx_dy = (vx2 + vx3 - vx0 - vx1) / (2.0 * dy)
    dvy_dx = (vy1 + vy2 - vy0 - vy3) / (2.0 * dx)
    dxy = 0.5 * dt * (dvx_dy + dvy_dx)
    dzz = dt * 0.25 * (vx0 + vx1 + vx2 + vx3) / r if axisym else 0.0
    return dxx, dyy, dxy, dzz, 0.5 * dt * (dvx_dy - dvy_dx)


@njit(**JIT)
def volumetric_override(i, j, dt, dx, dy, dxx, dyy, vel, v_body, faces, shared, open_ij):
    """In a cell the body cuts (``open_frac`` < 1, plane strain) the volumetric strain is the one
    the remap makes: the net flux through the open parts of its faces relative to the body
    (vertical velocity ``v_body``, m/s), over its open volume (or a merged pair's common one,
    ``shared``); the deviatoric strain is the cell's own. The pressure then sees what the remap
    does to the soil, and :func:`nodal_forces` applies it through the same open faces."""
    if math.isnan(shared):
        shared = cut_divergence(i, j, dx, dy, vel, v_body, faces, open_ij)
    half = 0.5 * (dt * shared - dxx - dyy)
    return dxx + half, dyy + half


@njit(**JIT)
def cell_strain(mesh, cells, faces, nodes, i, j, dt, v_body, axisym):
    """Cell (i, j)'s strain and spin increments (:func:`strain_increment`, :func:`volumetric_override`):
    for the field output; the stress update computes the same inline."""
    x, y = mesh.x, mesh.y
    dx, dy = x[i + 1] - x[i], y[j + 1] - y[j]
    r = 0.5 * (x[i] + x[i + 1]) if axisym else 1.0
    vel = cell_velocities(mesh.corner, nodes.v, i, j)
    dxx, dyy, dxy, dzz, w = strain_increment(dt, dx, dy, r, axisym, vel)
    shared, open_ij = cells.shared_divergence[i, j], cells.open_frac[i, j]
    if not math.isnan(shared) or open_ij < 1.0:
        dxx, dyy = volumetric_override(i, j, dt, dx, dy, dxx, dyy, vel, v_body, faces, shared, open_ij)
    return dxx, dyy, dxy, dzz, w


@njit(**INLINE)
def tresca_2d(sxx, syy, sxy, szz, su, shear_mod):
    """Return of a plane stress state (in-plane σ and the out-of-plane σzz) to Tresca's hexagon.
    Returns the new σxx, σyy, σxy, σzz, the plastic shear strain increment and the multiplier sum."""
    centre = 0.5 * (sxx + syy)
    radius = math.sqrt(0.25 * (sxx - syy) ** 2 + sxy * sxy)
    a, b = centre + radius, centre - radius
    # sort (a, b, szz) descending, remembering where the in-plane ones went
    if szz >= a:
        s1, s2, s3 = szz, a, b
    elif szz >= b:
        s1, s2, s3 = a, szz, b
    else:
        s1, s2, s3 = a, b, szz
    n1, n2, n3, dxi, dg = tresca_return(s1, s2, s3, su, shear_mod)
    if dg <= 0.0:
        return sxx, syy, sxy, szz, 0.0, 0.0
    if szz >= a:
        szz, a2, b2 = n1, n2, n3
    elif szz >= b:
        a2, szz, b2 = n1, n2, n3
    else:
        a2, b2, szz = n1, n2, n3
    if radius > 0.0:
        c2 = 0.5 * (sxx - syy) / radius  # cos 2θ
        s2t = sxy / radius  # sin 2θ
    else:
        c2, s2t = 1.0, 0.0
    half = 0.5 * (a2 - b2)
    mid = 0.5 * (a2 + b2)
    return mid + half * c2, mid - half * c2, half * s2t, szz, dxi, dg


@njit(**INLINE)
def evolve_law_state(q, i, j, law, xi_before, gamma_dot, dt, n_state):
    """A soil law's ``n_state`` state variables (rows NQ_BASE… of q) after the step of cell (i, j)."""
    s0 = q[NQ_BASE, i, j]
    s1 = q[NQ_BASE + 1, i, j] if n_state > 1 else 0.0
    xi = q[XI, i, j]
    for k in range(n_state):
        q[NQ_BASE + k, i, j] = law_state(law, k, s0, s1, xi, xi - xi_before, gamma_dot, dt, q[Z0, i, j])


@njit(**JIT)
def shear_rate(dxx, dyy, dxy, dzz, dt):
    """Shear strain rate (Δε1 − Δε3)/Δt (1/s) from the principal total strain increments."""
    ring = math.sqrt(0.25 * (dxx - dyy) ** 2 + dxy * dxy)
    e_hi = max(0.5 * (dxx + dyy) + ring, dzz)
    e_lo = min(0.5 * (dxx + dyy) - ring, dzz)
    return (e_hi - e_lo) / dt if dt > 0.0 else 0.0


@njit(**JIT)
def jaumann_trial(sxx, syy, sxy, szz, dxx, dyy, dxy, dzz, w, lam, shear_mod):
    """The stress rotated by the spin increment w (Jaumann) plus the elastic trial increment."""
    rxx = 2.0 * w * sxy
    rxy = w * (syy - sxx)
    sxx += rxx
    syy -= rxx
    sxy += rxy
    tr = dxx + dyy + dzz
    return (sxx + lam * tr + 2.0 * shear_mod * dxx, syy + lam * tr + 2.0 * shear_mod * dyy,
            sxy + 2.0 * shear_mod * dxy, szz + lam * tr + 2.0 * shear_mod * dzz)


@njit(**JIT)
def j2_2d(sxx, syy, sxy, szz, su, shear_mod):
    """J2's radial return of a plane state; returns the new σxx, σyy, σxy, σzz and |Δe^p|."""
    p = (sxx + syy + szz) / 3.0
    ex, ey, ez = sxx - p, syy - p, szz - p
    scale, dlam = radial_return(math.sqrt(ex * ex + ey * ey + ez * ez + 2.0 * sxy * sxy), su, shear_mod)
    return p + ex * scale, p + ey * scale, sxy * scale, p + ez * scale, dlam


@njit(**INLINE)
def plastic_return(q, i, j, sxx, syy, sxy, szz, su, shear_mod, volume, tresca, plastic):
    """Cell (i, j)'s trial stress returned to the yield surface (Tresca's hexagon with ``tresca``, else
    J2's cylinder) and stored in ``q`` with its plastic shear strain ξ; returns ``plastic`` plus the
    step's plastic work in the cell's soil ``volume`` (J)."""
    if tresca:
        sxx, syy, sxy, szz, dxi, dg = tresca_2d(sxx, syy, sxy, szz, su, shear_mod)
        if dg > 0.0:
            q[XI, i, j] += dxi
            plastic += 2.0 * su * dg * volume
    else:
        sxx, syy, sxy, szz, dlam = j2_2d(sxx, syy, sxy, szz, su, shear_mod)
        if dlam > 0.0:
            q[XI, i, j] += math.sqrt(2.0) * dlam
            plastic += math.sqrt(2.0) * su * dlam * volume
    q[SXX, i, j] = sxx
    q[SYY, i, j] = syy
    q[SZZ, i, j] = szz
    q[SXY, i, j] = sxy
    return plastic


@njit(**JIT)
def update_stress(mesh, cells, faces, nodes, par, v_body, law, out):
    """Stress update for undrained soil of strength su: Jaumann rotation, elastic trial, return.

    su = (su0 + ks·z0)·f·law(ξ, γ̇, state) with z0 the depth where the soil started, f the cell's
    strength factor (α in a curved body's interface layer) and γ̇ = (Δε1 − Δε3)/Δt; the soil law
    ``law`` (a compiled callback, see dsmv.soil_law) is called only when ``par.law_active``; a law that
    neither changes the strength nor carries state (Tresca) comes as ``law=None``, and the kernel
    compiles without the calls (the untaken call alone cost 8–16 % of the update). The return is
    J2's radial return to √J2 ≤ su, or with ``par.tresca`` the return to Tresca's hexagon s1 − s3 ≤ 2·su. Both are the same in plane strain;
    in axisymmetry only Tresca matches Tresca's exact solutions (J2 matched in shear is weaker in
    triaxial states by √3/2). Accumulates the plastic shear strain ξ += Δε1^p − Δε3^p (Δγ in simple
    shear); ``out[0]`` accumulates plastic work (J). A law's state variables, the rows of ``q``
    beyond NQ_BASE, are updated by its compiled ``evolve`` after the return. ``cells.su`` receives
    each cell's current strength (Pa; 0 without soil), which limited-adhesion contact reads.

    A gap cell (beside a face the soil may leave) carries stress only while full: partly full, it
    holds the sliver of soil beside the gap the soil has opened at the face, which spread across
    the cell would bridge the gap. ``out[1]`` accumulates the elastic energy so released (J).
    """
    x, y, corner, split, v = mesh.x, mesh.y, mesh.corner, mesh.split, nodes.v
    phi, q, su_cell, factor = cells.phi, cells.q, cells.su, cells.strength_factor
    open_frac, gap, shared = cells.open_frac, cells.gap, cells.shared_divergence
    nx, ny = phi.shape
    ny1 = np.uint64(ny + 1)
    n_state = law_rows(q, par, NQ_BASE)
    shear_mod, dt, axisym = par.shear, par.dt, par.axisymmetric
    lam = par.bulk - 2.0 * shear_mod / 3.0
    plastic = 0.0
    for i in range(nx):
        dx = x[i + 1] - x[i]
        r = 0.5 * (x[i] + x[i + 1]) if axisym else 1.0
        for j in range(ny):
            f = phi[i, j]
            dy = y[j + 1] - y[j]
            open_ij = open_frac[i, j]
            sliver = gap[i, j] and f < GAP_CELL_FULL * open_ij
            if f <= par.stress_cutoff * open_ij or sliver:
                # a wisp of soil in a nearly empty cell carries no stress: its strain rate,
                # taken from void nodes, means nothing; nor does the sliver beside a gap
                if sliver:  # the elastic energy it held (J)
                    out[1] += f * dx * dy * r * elastic_energy_density(q[SXX, i, j], q[SYY, i, j], q[SZZ, i, j],
                                                                       q[SXY, i, j], 0.0, 0.0, shear_mod, par.bulk)
                q[SXX, i, j] = 0.0
                q[SYY, i, j] = 0.0
                q[SXY, i, j] = 0.0
                q[SZZ, i, j] = 0.0
                su_cell[i, j] = 0.0
                continue
            # unsigned node indices: Numba checks a signed index for wraparound at every access
            n0, n1, n2, n3 = cell_nodes(corner, split, i, j, ny1)
            vel = (v[0, n0], v[0, n1], v[0, n2], v[0, n3], v[1, n0], v[1, n1], v[1, n2], v[1, n3])
            dxx, dyy, dxy, dzz, w = strain_increment(dt, dx, dy, r, axisym, vel)
            if not math.isnan(shared[i, j]) or open_ij < 1.0:
                dxx, dyy = volumetric_override(i, j, dt, dx, dy, dxx, dyy, vel, v_body, faces, shared[i, j], open_ij)
            sxx, syy, sxy, szz = jaumann_trial(q[SXX, i, j], q[SYY, i, j], q[SXY, i, j], q[SZZ, i, j], dxx, dyy, dxy,
                                               dzz, w, lam, shear_mod)
            su = intact_strength(par, q[Z0, i, j]) * factor[i, j]
            if su < 0.0:
                su = 0.0
            xi_before = q[XI, i, j]
            gamma_dot = 0.0
            if law is not None and par.law_active:
                gamma_dot = shear_rate(dxx, dyy, dxy, dzz, dt)
                s0 = q[NQ_BASE, i, j] if n_state > 0 else 0.0
                s1 = q[NQ_BASE + 1, i, j] if n_state > 1 else 0.0
                su *= law_factor(law, xi_before, gamma_dot, s0, s1, q[Z0, i, j])
            su_cell[i, j] = su
            plastic = plastic_return(q, i, j, sxx, syy, sxy, szz, su, shear_mod, dx * dy * r * f, par.tresca, plastic)
            if law is not None and n_state > 0:
                evolve_law_state(q, i, j, law, xi_before, gamma_dot, dt, n_state)
    out[0] += plastic


@njit(**JIT)
def elastic_energy(phi, q, vol, shear_mod, bulk_mod):
    """Elastic energy stored in the soil (J per unit thickness or per radian)."""
    total = 0.0
    nx, ny = phi.shape
    for i in range(nx):
        for j in range(ny):
            if phi[i, j] > 0.0:
                total += vol[i, j] * phi[i, j] * elastic_energy_density(
                    q[SXX, i, j], q[SYY, i, j], q[SZZ, i, j], q[SXY, i, j], 0.0, 0.0, shear_mod, bulk_mod)
    return total


@njit(**JIT)
def shear_strain_rates(mesh, cells, faces, nodes, par, v_body):
    """Each cell's shear strain rate γ̇ = ε̇1 − ε̇3 (1/s) by the stress update's own rule
    (:func:`strain_increment`), 0 in cells that carry no stress: what the field output shows."""
    nx, ny = cells.phi.shape
    rate = np.zeros((nx, ny))
    dt = 1.0  # rates: the increments over a unit time
    for i in range(nx):
        for j in range(ny):
            if cells.phi[i, j] <= par.stress_cutoff * cells.open_frac[i, j]:
                continue
            dxx, dyy, dxy, dzz, _ = cell_strain(mesh, cells, faces, nodes, i, j, dt, v_body, par.axisymmetric)
            ring = math.sqrt(0.25 * (dxx - dyy) ** 2 + dxy * dxy)
            rate[i, j] = max(0.5 * (dxx + dyy) + ring, dzz) - min(0.5 * (dxx + dyy) - ring, dzz)
    return rate
