"""Scalar physics every dimension shares: the returns, the soil-law call, energies, limiters.

Small functions of scalars, inlined by Numba into the per-dimension element kernels
(:mod:`dsmv.cel.kernels.elements2d`), the remap sweeps and the contact stages. ``JIT`` holds the
one set of Numba flags every kernel compiles with.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

FAST = {"nsz", "arcp", "contract", "afn", "reassoc"}  # never 'nnan'/'ninf': the guards need NaN
JIT = dict(cache=True, error_model="numpy", fastmath=FAST)
#: small helpers called per tie or in a stage, inlined into their callers' IR: a call that passes a
#: container would otherwise count references on each of its arrays. Per-cell loops call scalar
#: helpers only, and read their arrays once, before the loop (a container passed per cell cost 5×).
INLINE = dict(JIT, inline="always")
#: a sliver of a cut cell is weighed as if this much of it were open: the open faces' stiffness
#: grows as aperture/open, unbounded for a sliver, and with it the explicit step's limit; a sliver
#: more closed than this merges with a neighbour (dsmv.cel.contact.sliver_pairs)
CUT_OPEN_FLOOR = 0.5
#: the 3D per-cell kernels' drivers: parallel over slabs of cells, in an order that does not depend on
#: the number of threads (:mod:`dsmv.cel.kernels.elements3d`)
PARALLEL = dict(JIT, parallel=True)
#: values per block of the parallel loops over flat arrays (node stages, reductions): a fixed size, so
#: that their partial results combine in the same order on any number of threads
BLOCK = 8192


@njit(**INLINE)
def layer_at(top, z0):
    """The index of the layer (a strength segment, a set of the law's values) holding soil that started at
    depth z0 (m), of layers whose top depths ``top`` rise from −∞: one layer searches nothing."""
    k = len(top) - 1
    while k > 0 and z0 < top[k]:
        k -= 1
    return k


@njit(**INLINE)
def intact_strength(par, z0):
    """su_intact(z0) (Pa), the strength of soil that started at depth z0 (m): the profile's segment there,
    intercept + slope·z0 (:class:`dsmv.config.profile.StrengthSegments`; su0 + ks·z0 is one segment)."""
    k = layer_at(par.strength_depth, z0)
    return par.strength_intercept[k] + par.strength_slope[k] * z0


@njit(**INLINE)
def weighing_depth(top, intercept, ratio, depth):
    """w(depth) (m) of the density layers (top, intercept, ratio) of :class:`dsmv.config.profile.DensityLayers`."""
    k = layer_at(top, depth)
    return intercept[k] + ratio[k] * depth


@njit(**INLINE)
def soil_column(top, intercept, ratio, upper, lower):
    """The soil a cell holds from depth ``upper`` down to ``lower`` (m), in density layers (top, intercept,
    ratio): the weighing depth of its centroid as the lumped nodal masses weigh it, the mean of the weighing
    depths at its top and bottom (m), and its mean density over the lightest layer's (its weight over its
    height). With these the geostatic stresses balance the nodes' weights exactly, a layer boundary inside
    a cell too (at its centroid's own weighing depth and layer, the soil by such a cell moved at 3–9 cm/s,
    level and on a 10° slope)."""
    w_upper = weighing_depth(top, intercept, ratio, upper)
    w_lower = weighing_depth(top, intercept, ratio, lower)
    height = lower - upper
    mean = (w_lower - w_upper) / height if height > 0.0 else ratio[layer_at(top, upper)]
    return 0.5 * (w_upper + w_lower), mean


@njit(**INLINE)
def law_rows(q, par, base):
    """The number of the soil law's state rows of q, which follow its ``base`` rows (the density row, when
    the soil's density is layered, comes last)."""
    return q.shape[0] - base - (1 if par.density_row >= 0 else 0)


@njit(**INLINE)
def weigh_line_fluxes(density_flux, flux):
    """In a layered soil, a line's face fluxes after the cells took them: the volume of soil of
    ``par.density`` as heavy as what crossed each face (``density_flux``, the density row's fluxes, m³), for
    the momentum sweep's masses. Returns that of the soil that entered through the line's ends (m³)."""
    for face in range(flux.shape[0]):
        flux[face] = density_flux[face]
    return density_flux[0] - density_flux[-1]


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
def elastic_energy_density(sxx, syy, szz, sxy, syz, szx, shear_mod, bulk_mod):
    """Linear elastic energy per unit volume, s:s/(4G) + p²/(2K) (J/m³), of a stress given by its six
    components (Pa; 2D passes syz = szx = 0: its out-of-plane or hoop stress is szz)."""
    p = (sxx + syy + szz) / 3.0
    ex, ey, ez = sxx - p, syy - p, szz - p
    shear = sxy * sxy + syz * syz + szx * szx
    return (ex * ex + ey * ey + ez * ez + 2.0 * shear) / (4.0 * shear_mod) + p * p / (2.0 * bulk_mod)


@njit(**INLINE)
def bulk_viscosity(div, h, rho, c_wave, linear, quadratic):
    """The bulk viscosity's pressure (Pa), a pressure of the soil itself, which acts in compression
    only (the callers ask for it where the volumetric strain rate ``div`` < 0, 1/s):
    ρ·(b2²·h²·div² − b1·c·h·div) over the cell's smallest edge h (m), with the soil's density ρ,
    its P-wave speed c and the coefficients b1 (``linear``) and b2 (``quadratic``)."""
    return rho * (quadratic * quadratic * h * h * div * div - linear * c_wave * h * div)


@njit(**JIT)
def van_leer(d_minus, d_plus):
    """van Leer's limited slope from the two one-sided differences (0 at extrema)."""
    prod = d_minus * d_plus
    if prod <= 0.0:
        return 0.0
    return 2.0 * prod / (d_minus + d_plus)


@njit(**JIT)
def donor_acceptor(phi_d, phi_a, volume_flux, donor_volume, acceptor_first):
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


@njit(**INLINE)
def soil_through_face(fill_d, fill_a, dvol, donor_open_volume, normal_along, normal_across):
    """The soil volume (m³) a face volume flux ``dvol`` carries from donor to acceptor, from the fills of
    their open parts. Full to full there is no interface: the flux times the donor's fill. Else the
    Hirt–Nichols rule (:func:`donor_acceptor`), taking the acceptor's fill first, which keeps the
    interface sharp, where the interface's normal lies along the flow: the fill's difference across
    the donor along the flow, ``normal_along``, at least the largest across it, ``normal_across``
    (both magnitudes, 0 where both cells are full), which both dimensions' sweeps read from the fills
    before the sweep, so that no line sees another's update (decision 0023)."""
    if fill_d >= 1.0 and fill_a >= 1.0:
        return abs(dvol) * fill_d
    acceptor_first = normal_along >= normal_across and fill_d < 1.0
    return donor_acceptor(fill_d, fill_a, dvol, donor_open_volume, acceptor_first)


@njit(**INLINE)
def upwind_value(value, lo, hi, order, un, courant):
    """A transported quantity's value at a face: the donor's ``value``, plus with ``order`` 2 van Leer's
    limited slope from its neighbours upstream and downstream (``lo``, ``hi``) times what the flux
    leaves of the donor (1 − its Courant number), towards the face the flow ``un`` crosses."""
    if order == 2:
        value += (0.5 if un > 0.0 else -0.5) * van_leer(value - lo, hi - value) * (1.0 - courant)
    return value


@njit(**INLINE)
def law_factor(law, xi, gamma_dot, s0, s1, z0):
    """The soil law's strength factor su/su_intact (-) at ξ, γ̇ (1/s) and state s0, s1, with the values of
    the layer soil from depth z0 (m) carries (``law``: a :class:`~dsmv.cel.layout.SoilLawKernel`). A factor
    that is negative or not finite comes back as NaN: the cell's strength (``cells.su``) then shows it, its
    stress takes no plastic return, and the controller's law guard ends the run naming the law and the
    cell's state."""
    k = layer_at(law.top, z0)
    p = law.params
    f = law.factor(xi, gamma_dot, s0, s1, p[k, 0], p[k, 1], p[k, 2], p[k, 3], p[k, 4], p[k, 5], p[k, 6], p[k, 7])
    return f if 0.0 <= f < math.inf else math.nan


@njit(**INLINE)
def law_state(law, k, s0, s1, xi, dxi, gamma_dot, dt, z0):
    """State variable k of a soil law after a step with plastic strain increment dxi (dsmv.soil_law), with
    the values of the layer soil from depth z0 (m) carries."""
    m = layer_at(law.top, z0)
    p = law.params
    return law.evolve(float(k), s0, s1, xi, dxi, gamma_dot, dt, p[m, 0], p[m, 1], p[m, 2], p[m, 3], p[m, 4], p[m, 5],
                      p[m, 6], p[m, 7])


@njit(**INLINE)
def radial_return(dev_norm, su, shear_mod):
    """J2's radial return: the deviator's scale factor to √J2 ≤ su and the plastic strain |Δe^p|
    (0 when elastic), from the deviator's norm |s| = √(2 J2) (Pa)."""
    limit = math.sqrt(2.0) * su
    if dev_norm > limit:
        return limit / dev_norm, (dev_norm - limit) / (2.0 * shear_mod)
    return 1.0, 0.0


def compiled_entry(dispatcher, args: tuple):
    """The machine code a dispatcher compiled (or loaded) for these arguments, to call without
    dispatching again: typing a NamedTuple of arrays at every call cost about 70 µs, more than a
    chunk of a small landing's steps."""
    from numba import typeof

    if not hasattr(dispatcher, "overloads"):  # not a compiled function (a test's stand-in): called as it is
        return dispatcher
    signature = tuple(typeof(a) for a in args)
    if signature not in dispatcher.overloads:
        dispatcher.compile(signature)  # compiles it, or loads it from the cache (without running it)
    return dispatcher.overloads[signature].entry_point


@njit(**INLINE)
def ordered_sums(parts):
    """The sums of the two rows of ``parts`` (2, n), each in index order: the per-slab or per-block
    partial sums of a parallel loop, added up the same way on any number of threads."""
    first = 0.0
    second = 0.0
    for i in range(parts.shape[1]):
        first += parts[0, i]
        second += parts[1, i]
    return first, second


@njit(**JIT)
def spread_order(n):
    """The indices 0 … n−1 in van der Corput order (sorted by their bits reversed): 0, 4, 2, 6, 1, 5,
    3, 7 for n = 8. Any contiguous run of it samples the whole range evenly, so a parallel loop over
    it, which hands each thread one contiguous block, gives every thread near and far slabs alike.
    In slab order the slabs beside the body, where the returns are plastic, fell to one thread."""
    bits = 0
    while (1 << bits) < n:
        bits += 1
    key = np.empty(n, dtype=np.int64)
    for i in range(n):
        reversed_bits, rest = 0, i
        for _ in range(bits):
            reversed_bits = (reversed_bits << 1) | (rest & 1)
            rest >>= 1
        key[i] = reversed_bits
    return np.argsort(key)


@njit(**PARALLEL)
def all_finite(values):
    """Whether every value of a contiguous array is finite (read flat in blocks, without a temporary)."""
    flat = values.ravel()
    n = flat.size
    n_blocks = (n + BLOCK - 1) // BLOCK
    finite = np.ones(n_blocks, dtype=np.bool_)
    for b in prange(n_blocks):
        for k in range(b * BLOCK, min(n, (b + 1) * BLOCK)):
            if not math.isfinite(flat[k]):
                finite[b] = False
                break
    return finite.all()
