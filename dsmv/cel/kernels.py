"""Compiled kernels of the 2D CEL step: small, arrays and scalars only.

Layout: cell arrays have shape (nx, ny), node arrays (nx+1, ny+1); cell (i, j) has nodes
(i, j) bottom-left, (i+1, j) bottom-right, (i+1, j+1) top-right, (i, j+1) top-left. Stress
is the soil's own (tension positive, Pa); the cell carries φ·σ. The transported cell state
``q`` has shape (NQ, nx, ny): σxx, σyy, σxy, σzz (σθθ when axisymmetric), ξ, z0, then any
soil-law state.

Axisymmetric mode (x = r): volumes and face areas per radian are weighted by r, the hoop
strain rate is v_r/r and the hoop stress enters the radial nodal force (one-point rule).

References: Flanagan & Belytschko (1981) IJNME 17 (one-point quadrature, hourglass
control); Benson (1992) CMAME 99 (operator split, dual-mesh momentum remap); van Leer (1977)
(MUSCL); Hirt & Nichols (1981) (donor–acceptor volume fluxes).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

SXX, SYY, SXY, SZZ, XI, Z0 = 0, 1, 2, 3, 4, 5
NQ_BASE = 6

FAST = {"nsz", "arcp", "contract", "afn", "reassoc"}  # never 'nnan'/'ninf': the guards need NaN
JIT = dict(cache=True, error_model="numpy", fastmath=FAST)

# Corner twins. At a flat-faced body's corner (where the base meets the wall) Prandtl's fan is
# centred: the soil under the base moves with the body, the soil beside it rides the fan, and
# the velocity there has every direction of the fan between. One shared node forces a single
# velocity, so the cell beside the corner is dragged along with the base and smears the fan
# over itself: the strip then reads as if about a third of a cell wider (+3.6 % at B/20 in
# small strain). The soil cells beyond the base (beside the wall) therefore see their own copy
# of the corner node, the twin; the cells under the base keep the body's node. The twin is a
# node of the wall: tied along its normal, held along it by the wall's adhesion α·su over the
# lower half of the wall face above the corner (gripped by the soil that cell holds: none while
# the strip sits on the surface, where at the fan's centre the soil slips up past the corner,
# at 3V/2 relative to it in Prandtl's solution), and, with contact separation, free to leave
# the wall. A full tie, as the shared node was, grips with any shear. Rows of the float array
# ``twin`` (K, N_TWIN): velocity (m/s), force (N per unit thickness or per radian), lumped mass
# (kg per unit thickness or per radian), the wall's normal into the soil, and the travel through
# the grid since the last remap (m): it counts towards the remap's trigger, and its vertical part
# carries the soil through the face above the lower twin cell (the face below the corner, which
# the cell under the base shares, keeps the body's node's travel).
# ``TW_CAP`` is α × that half face (m, m²/rad axisymmetric), as a face tie's ``tie_cap``.
# ``twin_node`` (K, 4) holds the node it copies (i, j) and the cell above the corner beside the
# wall (i, j); ``cell_twin`` (nx, ny) is 4·k + the cell's local node (0..3) that twin k replaces,
# or -1.
TW_VX, TW_VY, TW_FX, TW_FY, TW_M, TW_NX, TW_NY, TW_UX, TW_UY, TW_CAP = range(10)
N_TWIN = 10


@njit(**JIT)
def local_node(i, j, local):
    """Node (i, j) of cell (i, j)'s local corner 0 (−,−), 1 (+,−), 2 (+,+) or 3 (−,+)."""
    if local == 0:
        return i, j
    if local == 1:
        return i + 1, j
    if local == 2:
        return i + 1, j + 1
    return i, j + 1


@njit(**JIT)
def with_twin(code, twin, vx0, vx1, vx2, vx3, vy0, vy1, vy2, vy3):
    """A cell's nodal velocities with its corner twin's in place of the node it copies."""
    k, local = code // 4, code % 4
    tvx, tvy = twin[k, TW_VX], twin[k, TW_VY]
    if local == 0:
        return tvx, vx1, vx2, vx3, tvy, vy1, vy2, vy3
    if local == 1:
        return vx0, tvx, vx2, vx3, vy0, tvy, vy2, vy3
    if local == 2:
        return vx0, vx1, tvx, vx3, vy0, vy1, tvy, vy3
    return vx0, vx1, vx2, tvx, vy0, vy1, vy2, tvy


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


@njit(**JIT)
def nodal_mass(phi, vol, rho, mass, open_frac, cut_mass_fill):
    """Lumped nodal mass: a quarter of each neighbouring cell's soil mass (kg).

    A cell the body cuts (``open_frac`` < 1) lends its nodes the mass of at least
    ``cut_mass_fill`` of its volume: its nodes may lie inside the body, where little soil is,
    yet carry the stiff open faces; the added inertia keeps the explicit step stable."""
    mass[:] = 0.0
    nx, ny = phi.shape
    for i in range(nx):
        for j in range(ny):
            fill = phi[i, j]
            if open_frac[i, j] < 1.0 and open_frac[i, j] > 0.0 and fill < cut_mass_fill:
                fill = cut_mass_fill
            m = 0.25 * rho * fill * vol[i, j]
            if m > 0.0:
                mass[i, j] += m
                mass[i + 1, j] += m
                mass[i + 1, j + 1] += m
                mass[i, j + 1] += m


@njit(**JIT)
def twin_masses(phi, vol, rho, mass, cell_twin, twin):
    """Move each twin's share of the lumped mass, a quarter of its cells' soil (kg), from the
    node it copies to the twin (after :func:`nodal_mass`; bodies with corners have no cut cells)."""
    twin[:, TW_M] = 0.0
    nx, ny = phi.shape
    for i in range(nx):
        for j in range(ny):
            code = cell_twin[i, j]
            if code < 0:
                continue
            m = 0.25 * rho * phi[i, j] * vol[i, j]
            ni, nj = local_node(i, j, code % 4)
            mass[ni, nj] = max(mass[ni, nj] - m, 0.0)  # no round-off residue below zero
            twin[code // 4, TW_M] += m


@njit(**JIT)
def nodal_forces(x, y, phi, q, vx, vy, rho, wave_speed, hourglass, bulk_lin, bulk_quad, axisym, fx, fy, work,
                 skip_void, aperture_x, aperture_y, open_frac, v_body, div_override, cell_twin, twin):
    """Internal nodal forces (N per unit thickness or per radian) from the cell stresses.

    One-point quadrature at the cell centre; viscous hourglass control with coefficient
    ``hourglass`` (Flanagan–Belytschko form, force ∝ ρ·c·√A·hourglass velocity); linear and
    quadratic bulk viscosity in compression. ``work`` accumulates the power dissipated by
    hourglass [0] and bulk viscosity [1] (W), to be multiplied by Δt by the caller, and [2] the
    vertical force the cut cells' mean stress puts on the body's arc (N, up +).
    Cells without soil give no force and are skipped; ``skip_void=False`` does their (null)
    arithmetic anyway, only to measure what skipping saves. In a cell the body cuts
    (``open_frac`` < 1) the in-plane mean stress acts through the open parts of the faces only,
    the work-conjugate of :func:`cut_divergence`: the closed parts are the body's surface. A cell
    beside a body's corner (``cell_twin``) moves with, and pushes on, the corner's twin.
    """
    fx[:] = 0.0
    fy[:] = 0.0
    twin[:, TW_FX] = 0.0
    twin[:, TW_FY] = 0.0
    nx, ny = phi.shape
    hg_power = 0.0
    bv_power = 0.0
    arc_fy = 0.0
    for i in range(nx):
        dx = x[i + 1] - x[i]
        r = 0.5 * (x[i] + x[i + 1]) if axisym else 1.0
        for j in range(ny):
            f = phi[i, j]
            if f <= 0.0 and skip_void:
                continue
            dy = y[j + 1] - y[j]
            area = dx * dy
            vol = area * r
            # velocity gradient at the centre
            vx0, vx1, vx2, vx3 = vx[i, j], vx[i + 1, j], vx[i + 1, j + 1], vx[i, j + 1]
            vy0, vy1, vy2, vy3 = vy[i, j], vy[i + 1, j], vy[i + 1, j + 1], vy[i, j + 1]
            code = cell_twin[i, j]
            ti, tj, kept_x, kept_y = 0, 0, 0.0, 0.0
            if code >= 0:  # the twin's velocity in, its force out: the node's force is kept aside
                vx0, vx1, vx2, vx3, vy0, vy1, vy2, vy3 = with_twin(code, twin, vx0, vx1, vx2, vx3, vy0, vy1, vy2, vy3)
                ti, tj = local_node(i, j, code % 4)
                kept_x, kept_y = fx[ti, tj], fy[ti, tj]
            dvx_dx = (vx1 + vx2 - vx0 - vx3) / (2.0 * dx)
            dvy_dy = (vy2 + vy3 - vy0 - vy1) / (2.0 * dy)
            div = dvx_dx + dvy_dy
            if axisym:
                div += 0.25 * (vx0 + vx1 + vx2 + vx3) / r
            open_ij = open_frac[i, j]
            if open_ij < 1.0:
                div = cut_divergence(i, j, dx, dy, vx0, vx1, vx2, vx3, vy0, vy1, vy2, vy3, v_body, aperture_x,
                                     aperture_y, open_ij)
            # bulk viscosity: a pressure of the soil itself (Pa), in compression only; like σ it
            # acts on the cell's soil fraction f
            qb = 0.0
            if div < 0.0:
                h = min(dx, dy)
                qb = rho * (bulk_quad * bulk_quad * h * h * div * div - bulk_lin * wave_speed * h * div)
                bv_power += f * qb * (-div) * vol
            sxx = q[SXX, i, j] - qb
            syy = q[SYY, i, j] - qb
            sxy = q[SXY, i, j]
            # f_a = −V·φ·σ·∇N_a with ∇N_a = (±1/2dx, ±1/2dy)
            ax = 0.5 * vol * f / dx
            ay = 0.5 * vol * f / dy
            # node 0 (−,−), 1 (+,−), 2 (+,+), 3 (−,+)
            fx[i, j] += ax * sxx + ay * sxy
            fy[i, j] += ax * sxy + ay * syy
            fx[i + 1, j] += -ax * sxx + ay * sxy
            fy[i + 1, j] += -ax * sxy + ay * syy
            fx[i + 1, j + 1] += -ax * sxx - ay * sxy
            fy[i + 1, j + 1] += -ax * sxy - ay * syy
            fx[i, j + 1] += ax * sxx - ay * sxy
            fy[i, j + 1] += ax * sxy - ay * syy
            if open_ij < 1.0:
                # the mean stress m on the open parts only: −(φ/2)·m·Σ (a_f/open − 1)·A_f·n_f per node
                open_eff = open_ij if not math.isnan(div_override[i, j]) else max(open_ij, CUT_OPEN_FLOOR)
                k = -0.25 * f * (sxx + syy)
                c_left = (aperture_x[i, j] / open_eff - 1.0) * dy
                c_right = (aperture_x[i + 1, j] / open_eff - 1.0) * dy
                c_bottom = (aperture_y[j, i] / open_eff - 1.0) * dx
                c_top = (aperture_y[j + 1, i] / open_eff - 1.0) * dx
                fx[i, j] -= k * c_left
                fy[i, j] -= k * c_bottom
                fx[i + 1, j] += k * c_right
                fy[i + 1, j] -= k * c_bottom
                fx[i + 1, j + 1] += k * c_right
                fy[i + 1, j + 1] += k * c_top
                fx[i, j + 1] -= k * c_left
                fy[i, j + 1] += k * c_top
                # the body's share: the mean stress on the arc, (φ/open)·m·Σ a_f·A_f·n_fy (N, up +)
                arc_fy += f / open_eff * 0.5 * (sxx + syy) * dx * (aperture_y[j + 1, i] - aperture_y[j, i])
            if axisym:  # hoop stress: −A·φ·σθθ·N_a, N_a = 1/4 at the centre
                hoop = 0.25 * area * f * (q[SZZ, i, j] - qb)
                fx[i, j] -= hoop
                fx[i + 1, j] -= hoop
                fx[i + 1, j + 1] -= hoop
                fx[i, j + 1] -= hoop
            # viscous hourglass control on the mode Γ = (1, −1, 1, −1)
            if hourglass > 0.0:
                gx = vx0 - vx1 + vx2 - vx3
                gy = vy0 - vy1 + vy2 - vy3
                c = 0.25 * hourglass * rho * f * wave_speed * math.sqrt(area) * (vol / area)
                hx = c * gx
                hy = c * gy
                fx[i, j] -= hx
                fy[i, j] -= hy
                fx[i + 1, j] += hx
                fy[i + 1, j] += hy
                fx[i + 1, j + 1] -= hx
                fy[i + 1, j + 1] -= hy
                fx[i, j + 1] += hx
                fy[i, j + 1] += hy
                hg_power += hx * gx + hy * gy
            if code >= 0:
                twin[code // 4, TW_FX] += fx[ti, tj] - kept_x
                twin[code // 4, TW_FY] += fy[ti, tj] - kept_y
                fx[ti, tj] = kept_x
                fy[ti, tj] = kept_y
    work[0] += hg_power
    work[1] += bv_power
    work[2] += arc_fy


@njit(**JIT)
def hourglass_modes(phi, vx, vy, full, cell_twin, twin):
    """How much of the nodal velocity field is the Q4 hourglass mode (a zig-zag diagnostic).

    Each cell's four nodal velocities split into v̄ + b_ξ·ξ + b_η·η + a·Γ with ξ = (−1, 1, 1, −1),
    η = (−1, −1, 1, 1) and Γ = (1, −1, 1, −1). Sums over cells with φ ≥ ``full`` of |a|² and of
    |b_ξ|² + |b_η|² (m²/s²) are returned. A smooth field has |a|/|b| = O(h) and a rigid motion has
    a = 0, so the square root of the ratio measures the zig-zag, independent of the frame. A cell
    beside a body's corner moves with the corner's twin (``cell_twin``).
    """
    nx, ny = phi.shape
    hourglass_sq = 0.0
    linear_sq = 0.0
    for i in range(nx):
        for j in range(ny):
            if phi[i, j] < full:
                continue
            vx0, vx1, vx2, vx3 = vx[i, j], vx[i + 1, j], vx[i + 1, j + 1], vx[i, j + 1]
            vy0, vy1, vy2, vy3 = vy[i, j], vy[i + 1, j], vy[i + 1, j + 1], vy[i, j + 1]
            if cell_twin[i, j] >= 0:
                vx0, vx1, vx2, vx3, vy0, vy1, vy2, vy3 = with_twin(cell_twin[i, j], twin, vx0, vx1, vx2, vx3, vy0, vy1,
                                                                   vy2, vy3)
            ax, ay = vx0 - vx1 + vx2 - vx3, vy0 - vy1 + vy2 - vy3
            bxx, bxy = -vx0 + vx1 + vx2 - vx3, -vy0 + vy1 + vy2 - vy3
            byx, byy = -vx0 - vx1 + vx2 + vx3, -vy0 - vy1 + vy2 + vy3
            hourglass_sq += 0.0625 * (ax * ax + ay * ay)
            linear_sq += 0.0625 * (bxx * bxx + bxy * bxy + byx * byx + byy * byy)
    return hourglass_sq, linear_sq


@njit(**JIT)
def update_velocities(vx, vy, fx, fy, mass, gravity, dt, mass_floor):
    """Explicit velocity update v += Δt·(f/m − g·ŷ) at nodes holding soil; empty nodes stop.

    Returns the soil's vertical momentum Σ m·vy before and after (kg·m/s per unit thickness or
    per radian), which the audit of gravity's work needs, gathered in the same pass."""
    n0, n1 = vx.shape
    momentum_before = 0.0
    momentum_after = 0.0
    for i in range(n0):
        for j in range(n1):
            m = mass[i, j]
            momentum_before += m * vy[i, j]
            if m > mass_floor:
                vx[i, j] += dt * fx[i, j] / m
                vy[i, j] += dt * (fy[i, j] / m - gravity)
            else:
                vx[i, j] = 0.0
                vy[i, j] = 0.0
            momentum_after += m * vy[i, j]
    return momentum_before, momentum_after


@njit(**JIT)
def tresca_return(s1, s2, s3, su, shear_mod):
    """Return of sorted principal stresses s1 ≥ s2 ≥ s3 to Tresca's hexagon, s1 − s3 ≤ 2·su.

    Perfect plasticity, closed form (de Souza Neto, Perić & Owen 2008, Computational Methods
    for Plasticity, Boxes 8.1–8.3): the one-vector return to the main plane, or the two-vector
    return to the right (s1 = s2) or left (s2 = s3) corner. Returns the new principal stresses,
    the plastic shear strain increment Δε1^p − Δε3^p, and the multiplier sum (work = 2su·that).
    """
    yield_stress = 2.0 * su
    phi = s1 - s3 - yield_stress
    if phi <= 0.0:
        return s1, s2, s3, 0.0, 0.0
    two_g = 2.0 * shear_mod
    dg = phi / (2.0 * two_g)
    n1, n2, n3 = s1 - two_g * dg, s2, s3 + two_g * dg
    if n1 >= n2 >= n3:
        return n1, n2, n3, 2.0 * dg, dg
    ra = s1 - s3 - yield_stress
    if n2 > n1:  # right corner: s1 = s2
        rb = s2 - s3 - yield_stress
        dga = (2.0 * ra - rb) / (3.0 * two_g)
        dgb = (2.0 * rb - ra) / (3.0 * two_g)
        e1, e2, e3 = dga, dgb, -(dga + dgb)
        n1, n2, n3 = s1 - two_g * dga, s2 - two_g * dgb, s3 + two_g * (dga + dgb)
    else:  # left corner: s2 = s3
        rb = s1 - s2 - yield_stress
        dga = (2.0 * ra - rb) / (3.0 * two_g)
        dgb = (2.0 * rb - ra) / (3.0 * two_g)
        e1, e2, e3 = dga + dgb, -dgb, -dga
        n1, n2, n3 = s1 - two_g * (dga + dgb), s2 + two_g * dgb, s3 + two_g * dga
    return n1, n2, n3, max(e1, e2, e3) - min(e1, e2, e3), dga + dgb


@njit(**JIT)
def _evolve_state(q, i, j, evolve, xi_before, gamma_dot, dt, p):
    """A soil law's state variables (rows NQ_BASE… of q) after the step of cell (i, j)."""
    n_state = q.shape[0] - NQ_BASE
    s0 = q[NQ_BASE, i, j]
    s1 = q[NQ_BASE + 1, i, j] if n_state > 1 else 0.0
    xi = q[XI, i, j]
    for k in range(n_state):
        q[NQ_BASE + k, i, j] = evolve(float(k), s0, s1, xi, xi - xi_before, gamma_dot, dt,
                                      p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7])


# A sliver of a cut cell is weighed as if this much of it were open: the open faces' stiffness
# grows as aperture/open, unbounded for a sliver, and with it the explicit step's limit.
CUT_OPEN_FLOOR = 0.5


@njit(**JIT)
def cut_flux(i, j, dx, dy, vx0, vx1, vx2, vx3, vy0, vy1, vy2, vy3, v_body, aperture_x, aperture_y):
    """Net outflow of cell (i, j) through the open parts of its faces, relative to the body
    (m²/s per unit thickness, plane strain); nodal velocities in the kernels' node order."""
    flux = dy * (aperture_x[i + 1, j] * 0.5 * (vx1 + vx2) - aperture_x[i, j] * 0.5 * (vx0 + vx3))
    return flux + dx * (aperture_y[j + 1, i] * (0.5 * (vy2 + vy3) - v_body)
                        - aperture_y[j, i] * (0.5 * (vy0 + vy1) - v_body))


@njit(**JIT)
def cut_divergence(i, j, dx, dy, vx0, vx1, vx2, vx3, vy0, vy1, vy2, vy3, v_body, aperture_x, aperture_y, open_ij):
    """Volumetric strain rate (1/s) of the soil in a cell the body cuts: :func:`cut_flux` over the
    cell's open area (floored at ``CUT_OPEN_FLOOR``)."""
    return (cut_flux(i, j, dx, dy, vx0, vx1, vx2, vx3, vy0, vy1, vy2, vy3, v_body, aperture_x, aperture_y)
            / (max(open_ij, CUT_OPEN_FLOOR) * dx * dy))


@njit(**JIT)
def merged_divergence(si, sj, ni, nj, x, y, vx, vy, v_body, aperture_x, aperture_y, open_frac):
    """Volumetric strain rate (1/s) of a merged pair, a sliver (si, sj) and its neighbour (ni, nj):
    their joint net outflow (the shared face cancels) over their joint open area."""
    flux = 0.0
    for i, j in ((si, sj), (ni, nj)):
        flux += cut_flux(i, j, x[i + 1] - x[i], y[j + 1] - y[j], vx[i, j], vx[i + 1, j], vx[i + 1, j + 1],
                         vx[i, j + 1], vy[i, j], vy[i + 1, j], vy[i + 1, j + 1], vy[i, j + 1], v_body,
                         aperture_x, aperture_y)
    return flux / ((open_frac[si, sj] + open_frac[ni, nj]) * (x[si + 1] - x[si]) * (y[sj + 1] - y[sj]))


#: a cell beside a face the soil may leave is full, and carries stress, from this fill on (-): a
#: cell in contact reads 1 ± a few per mille (compression, remap round-off); at 0.999 the stress
#: flickered on and off (curve roughness 0.49 at B/20), 0.95 and 0.99 read the same factors
GAP_CELL_FULL = 0.95


@njit(**JIT)
def update_stress(x, y, phi, q, vx, vy, dt, shear_mod, bulk_mod, su0, ks, axisym, phi_min, exact_tresca,
                  law, law_params, law_active, evolve, strength_factor, su_cell, out, aperture_x, aperture_y,
                  open_frac, v_body, div_override, gap_cells, cell_twin, twin):
    """Stress update for undrained soil of strength su: Jaumann rotation, elastic trial, return.

    su = (su0 + ks·z0)·f·law(ξ, γ̇, params) with z0 the depth where the soil started, f the
    cell's ``strength_factor`` (α in the interface layer round a curved body, 1 elsewhere) and
    γ̇ = (Δε1 − Δε3)/Δt; the soil law ``law`` (a compiled callback, see dsmv.soil_law) is
    called only when ``law_active``, so laws without softening or rate cost nothing. The
    return is J2's radial return
    to √J2 ≤ su, or with ``exact_tresca`` the return to Tresca's hexagon s1 − s3 ≤ 2·su. Both
    are the same in plane strain; in axisymmetry only Tresca matches Tresca's exact solutions
    (J2 matched in shear is weaker in triaxial states by √3/2). Accumulates the plastic shear
    strain ξ += Δε1^p − Δε3^p (Δγ in simple shear); ``out[0]`` accumulates plastic work (J).
    A law's state variables, the rows of ``q`` beyond NQ_BASE, reach ``law`` as s0, s1 and
    are updated by its compiled ``evolve`` after the return. ``su_cell`` receives each cell's
    current strength su (Pa; 0 without soil), which limited-adhesion contact reads.

    In a cell the body cuts (``open_frac`` < 1, plane strain) the volumetric strain is the one
    the remap makes: the net flux through the open parts of its faces (``aperture_x`` [face,
    row], ``aperture_y`` [face, column]) relative to the body (vertical velocity ``v_body``,
    m/s), over its open volume; the deviatoric strain is the cell's own. The pressure then
    sees what the remap does to the soil, and :func:`nodal_forces` applies it through the same
    open faces.

    A ``gap_cells`` cell (beside a face the soil may leave) carries stress only while full: partly
    full, it holds the sliver of soil beside the gap the soil has opened at the face, which spread
    across the cell would bridge the gap. ``out[1]`` accumulates the elastic energy so released (J).
    A cell beside a body's corner strains with the corner's twin (``cell_twin``, see N_TWIN).
    """
    nx, ny = phi.shape
    has_state = q.shape[0] > NQ_BASE
    s0 = 0.0
    s1 = 0.0
    lam = bulk_mod - 2.0 * shear_mod / 3.0
    plastic = 0.0
    for i in range(nx):
        dx = x[i + 1] - x[i]
        r = 0.5 * (x[i] + x[i + 1]) if axisym else 1.0
        for j in range(ny):
            f = phi[i, j]
            open_ij = open_frac[i, j]
            sliver = gap_cells[i, j] and f < GAP_CELL_FULL * open_ij
            if f <= phi_min * open_ij or sliver:
                # a wisp of soil in a nearly empty cell carries no stress: its strain rate,
                # taken from void nodes, means nothing; nor does the sliver beside a gap
                if sliver:
                    out[1] += f * dx * (y[j + 1] - y[j]) * r * elastic_energy_density(
                        q[SXX, i, j], q[SYY, i, j], q[SXY, i, j], q[SZZ, i, j], shear_mod, bulk_mod)
                q[SXX, i, j] = 0.0
                q[SYY, i, j] = 0.0
                q[SXY, i, j] = 0.0
                q[SZZ, i, j] = 0.0
                su_cell[i, j] = 0.0
                continue
            dy = y[j + 1] - y[j]
            vx0, vx1, vx2, vx3 = vx[i, j], vx[i + 1, j], vx[i + 1, j + 1], vx[i, j + 1]
            vy0, vy1, vy2, vy3 = vy[i, j], vy[i + 1, j], vy[i + 1, j + 1], vy[i, j + 1]
            if cell_twin[i, j] >= 0:
                vx0, vx1, vx2, vx3, vy0, vy1, vy2, vy3 = with_twin(cell_twin[i, j], twin, vx0, vx1, vx2, vx3, vy0, vy1,
                                                                   vy2, vy3)
            dxx = dt * (vx1 + vx2 - vx0 - vx3) / (2.0 * dx)
            dyy = dt * (vy2 + vy3 - vy0 - vy1) / (2.0 * dy)
            dvx_dy = (vx2 + vx3 - vx0 - vx1) / (2.0 * dy)
            dvy_dx = (vy1 + vy2 - vy0 - vy3) / (2.0 * dx)
            dxy = 0.5 * dt * (dvx_dy + dvy_dx)
            dzz = dt * 0.25 * (vx0 + vx1 + vx2 + vx3) / r if axisym else 0.0
            if not math.isnan(div_override[i, j]):
                half = 0.5 * (dt * div_override[i, j] - dxx - dyy)
                dxx += half
                dyy += half
            elif open_ij < 1.0:
                half = 0.5 * (dt * cut_divergence(i, j, dx, dy, vx0, vx1, vx2, vx3, vy0, vy1, vy2, vy3, v_body,
                                                  aperture_x, aperture_y, open_ij) - dxx - dyy)
                dxx += half
                dyy += half
            w = 0.5 * dt * (dvx_dy - dvy_dx)  # spin increment
            sxx, syy, sxy, szz = q[SXX, i, j], q[SYY, i, j], q[SXY, i, j], q[SZZ, i, j]
            # Jaumann rotation
            rxx = 2.0 * w * sxy
            rxy = w * (syy - sxx)
            sxx += rxx
            syy -= rxx
            sxy += rxy
            # elastic trial
            tr = dxx + dyy + dzz
            sxx += lam * tr + 2.0 * shear_mod * dxx
            syy += lam * tr + 2.0 * shear_mod * dyy
            szz += lam * tr + 2.0 * shear_mod * dzz
            sxy += 2.0 * shear_mod * dxy
            su = (su0 + ks * q[Z0, i, j]) * strength_factor[i, j]
            if su < 0.0:
                su = 0.0
            xi_before = q[XI, i, j]
            gamma_dot = 0.0
            if law_active:
                # shear strain rate (Δε1 − Δε3)/Δt from the principal total strain increments
                ring = math.sqrt(0.25 * (dxx - dyy) ** 2 + dxy * dxy)
                e_hi = max(0.5 * (dxx + dyy) + ring, dzz)
                e_lo = min(0.5 * (dxx + dyy) - ring, dzz)
                gamma_dot = (e_hi - e_lo) / dt if dt > 0.0 else 0.0
                if has_state:
                    s0 = q[NQ_BASE, i, j]
                    s1 = q[NQ_BASE + 1, i, j] if q.shape[0] > NQ_BASE + 1 else 0.0
                su *= law(q[XI, i, j], gamma_dot, s0, s1, law_params[0], law_params[1], law_params[2], law_params[3],
                          law_params[4], law_params[5], law_params[6], law_params[7])
            su_cell[i, j] = su
            if exact_tresca:
                # principal stresses: the in-plane pair and the out-of-plane one
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
                if dg > 0.0:
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
                    sxx = mid + half * c2
                    syy = mid - half * c2
                    sxy = half * s2t
                    q[XI, i, j] += dxi
                    plastic += 2.0 * su * dg * dx * dy * r * f
                q[SXX, i, j] = sxx
                q[SYY, i, j] = syy
                q[SZZ, i, j] = szz
                q[SXY, i, j] = sxy
                if has_state:
                    _evolve_state(q, i, j, evolve, xi_before, gamma_dot, dt, law_params)
                continue
            # radial return
            p = (sxx + syy + szz) / 3.0
            ex, ey, ez = sxx - p, syy - p, szz - p
            norm = math.sqrt(ex * ex + ey * ey + ez * ez + 2.0 * sxy * sxy)  # |s| = √(2 J2)
            limit = math.sqrt(2.0) * su
            if norm > limit:
                scale = limit / norm
                dlam = (norm - limit) / (2.0 * shear_mod)  # |Δe^p|
                ex *= scale
                ey *= scale
                ez *= scale
                sxy *= scale
                q[XI, i, j] += math.sqrt(2.0) * dlam
                vol = dx * dy * r * f
                plastic += limit * dlam * vol
            q[SXX, i, j] = p + ex
            q[SYY, i, j] = p + ey
            q[SZZ, i, j] = p + ez
            q[SXY, i, j] = sxy
            if has_state:
                _evolve_state(q, i, j, evolve, xi_before, gamma_dot, dt, law_params)
    out[0] += plastic


@njit(**JIT)
def node_strength(su_cell, phi, solid, i, j):
    """The strength of the soil touching a body's face at node (i, j) (Pa): φ·su averaged over
    the node's cells outside the body. A cell the soil only partly fills (at the mudline)
    grips the face in proportion: counted at full su, the face dragged the last wisps of soil
    down with it and dug a slot along the wall."""
    nx, ny = phi.shape
    total = 0.0
    count = 0
    for ci in (i - 1, i):
        for cj in (j - 1, j):
            if 0 <= ci < nx and 0 <= cj < ny and not solid[ci, cj]:
                total += su_cell[ci, cj] * min(phi[ci, cj], 1.0)
                count += 1
    return total / count if count > 0 else 0.0


@njit(**JIT)
def elastic_energy_density(sxx, syy, sxy, szz, shear_mod, bulk_mod):
    """Linear elastic energy per unit volume, s:s/(4G) + p²/(2K) (J/m³)."""
    p = (sxx + syy + szz) / 3.0
    ex, ey, ez = sxx - p, syy - p, szz - p
    return (ex * ex + ey * ey + ez * ez + 2.0 * sxy * sxy) / (4.0 * shear_mod) + p * p / (2.0 * bulk_mod)


@njit(**JIT)
def elastic_energy(phi, q, vol, shear_mod, bulk_mod):
    """Elastic energy stored in the soil (J per unit thickness or per radian)."""
    total = 0.0
    nx, ny = phi.shape
    for i in range(nx):
        for j in range(ny):
            if phi[i, j] > 0.0:
                total += vol[i, j] * phi[i, j] * elastic_energy_density(
                    q[SXX, i, j], q[SYY, i, j], q[SXY, i, j], q[SZZ, i, j], shear_mod, bulk_mod)
    return total


@njit(**JIT)
def _van_leer(d_minus, d_plus):
    """van Leer's limited slope from the two one-sided differences (0 at extrema)."""
    prod = d_minus * d_plus
    if prod <= 0.0:
        return 0.0
    return 2.0 * prod / (d_minus + d_plus)


@njit(**JIT)
def _donor_acceptor(phi_d, phi_a, volume_flux, donor_volume, acceptor_first):
    """Hirt–Nichols soil volume carried by a face volume flux |δV| from donor to acceptor.

    ``phi_d``, ``phi_a``: the fills of the two cells' open parts; ``donor_volume``: the donor's
    open volume (m³ per unit thickness or per radian)."""
    pd = min(phi_d, 1.0)
    pad = min(phi_a, 1.0) if acceptor_first else pd
    dv = abs(volume_flux)
    cf = max((1.0 - pad) * dv - (1.0 - pd) * donor_volume, 0.0)
    moved = min(pad * dv + cf, pd * donor_volume)
    # soil compressed beyond φ = 1 carries its density along
    return moved * phi_d / pd if phi_d > 1.0 else moved


@njit(**JIT)
def advect_cells(axis, x, y, vol, phi, q, ux, uy, dt, order, axisym, ghost, bottom_inflow, flux, phi_min,
                 shear_mod, bulk_mod, audit, aperture, open_frac):
    """One directional sweep of the cell state: volume fraction and transported quantities.

    ``ux``, ``uy`` are nodal velocities relative to the grid (m/s), or, with ``dt`` = 1, the
    travel through the grid gathered since the last remap (m). A face's volume flux comes from
    the mean normal velocity of its two nodes. Soil volume moves by the
    donor–acceptor rule; each transported quantity moves with it at the donor's value plus
    a van Leer limited slope when ``order`` = 2. Domain edges are closed, except the base
    (axis 1, face 0) when ``bottom_inflow``: soil enters there in the state ``ghost[k, i]``.
    ``flux[face, line]`` receives the signed soil volume through each face (for the momentum
    sweep). The body takes part of the grid: ``aperture[face, line]`` is the open fraction of each
    face (0 next to a cell inside the body), ``open_frac`` that of each cell (a cell the body's
    surface cuts holds at most that much soil); the Hirt–Nichols rule works on the fill of the
    open part, φ / open_frac. Returns the soil volume
    that entered through the base (m³). ``audit[0]``
    accumulates the change of stored elastic energy the sweep makes (J), inflow included.
    """
    nx, ny = phi.shape
    nq = q.shape[0]
    boundary = 0.0
    n_lines = ny if axis == 0 else nx
    n_faces = nx + 1 if axis == 0 else ny + 1
    n_cells = n_faces - 1
    qflux = np.zeros((nq, n_faces))
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
                if axis == 1 and face == 0 and bottom_inflow and un > 0.0:
                    flux[face, line] = dvol
                    for k in range(nq):
                        qflux[k, face] = dvol * ghost[k, i]
                    boundary += dvol
                continue
            if acceptor < 0 or acceptor >= n_cells:
                continue  # closed edges: symmetry plane, rollers, base; soil near the top ends a run
            di = donor if axis == 0 else i
            dj = j if axis == 0 else donor
            phi_d = phi[di, dj]
            if phi_d <= phi_min:
                continue
            ai = acceptor if axis == 0 else i
            aj = j if axis == 0 else acceptor
            open_d, open_a = open_frac[di, dj], open_frac[ai, aj]
            fill_d, fill_a = phi_d / open_d, phi[ai, aj] / open_a
            if fill_d >= 1.0 and fill_a >= 1.0:
                moved = abs(dvol) * fill_d  # full to full: no interface here
            else:
                # interface normal along the flow: the downwind value keeps the interface sharp
                g_along_x = phi[min(di + 1, nx - 1), dj] - phi[max(di - 1, 0), dj]
                g_along_y = phi[di, min(dj + 1, ny - 1)] - phi[di, max(dj - 1, 0)]
                g_n = g_along_x if axis == 0 else g_along_y
                g_t = g_along_y if axis == 0 else g_along_x
                acceptor_first = abs(g_n) >= abs(g_t) and fill_d < 1.0
                moved = _donor_acceptor(fill_d, fill_a, dvol, open_d * vol[di, dj], acceptor_first)
            signed = moved if un > 0.0 else -moved
            flux[face, line] = signed
            courant = moved / (phi_d * vol[di, dj])
            for k in range(nq):
                value = q[k, di, dj]
                if order == 2:
                    if axis == 0:
                        il, ih = max(di - 1, 0), min(di + 1, nx - 1)
                        lo = q[k, il, dj] if phi[il, dj] > phi_min else value
                        hi = q[k, ih, dj] if phi[ih, dj] > phi_min else value
                    else:
                        jl, jh = max(dj - 1, 0), min(dj + 1, ny - 1)
                        lo = q[k, di, jl] if phi[di, jl] > phi_min else value
                        hi = q[k, di, jh] if phi[di, jh] > phi_min else value
                    slope = _van_leer(value - lo, hi - value)
                    value += (0.5 if un > 0.0 else -0.5) * slope * (1.0 - courant)
                qflux[k, face] = signed * value
        # Each face limits its donor's outflow on its own, so a cell that gives through both
        # faces (diverging flow) could give up to twice what it holds; clipping the negative
        # remainder to 0 then creates soil (1e-10 of the mass in a 10 m/s landing). Scale such a
        # cell's two outflows down to its content: both neighbours see the same fluxes.
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
                    for k in range(nq):
                        qflux[k, c] *= scale
                        qflux[k, c + 1] *= scale
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
                    q[SXX, ci, cj], q[SYY, ci, cj], q[SXY, ci, cj], q[SZZ, ci, cj], shear_mod, bulk_mod)
            if new_soil <= 1e-14 * v:
                phi[ci, cj] = 0.0
                for k in range(nq):
                    q[k, ci, cj] = 0.0
                continue
            for k in range(nq):
                q[k, ci, cj] = (old_soil * q[k, ci, cj] + qflux[k, c] - qflux[k, c + 1]) / new_soil
            phi[ci, cj] = new_soil / v
            audit[0] += new_soil * elastic_energy_density(
                q[SXX, ci, cj], q[SYY, ci, cj], q[SXY, ci, cj], q[SZZ, ci, cj], shear_mod, bulk_mod)
    return boundary


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
                wx += half * _van_leer(wx - vx[li, lj], vx[hi_i, hi_j] - wx)
                wy += half * _van_leer(wy - vy[li, lj], vy[hi_i, hi_j] - wy)
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
