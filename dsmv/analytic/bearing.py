"""Exact and bounding bearing factors of a rigid strip on weightless Tresca soil (q/su, -).

- Prandtl (1920): a strip on the surface carries q = (2 + π)·su, rough or smooth base.
- A strip wished in place with its (rough) base at depth d below a flat surface, the soil bonded
  to its walls (no gap opens), carries more: the mechanism must now also shear the layer beside
  it. Prandtl's surface stress field with that layer stress-free is still admissible, so 2 + π
  stays a lower bound. :func:`embedded_strip_upper_bound` is a kinematic (upper) bound derived
  here (no published closed form was at hand): Prandtl's mechanism under the base, and above
  each passive triangle the layer moves with it, at speed v/√2 along 45°, out to a 45° slip line
  from the triangle's far corner, which dissipates su·(v/√2)·(d·√2) = su·v·d per side.
  - Smooth walls: a triangle of soil against the wall stays at rest, cut off by a 45° line from
    the base corner: another su·v·d per side, so N ≤ 2 + π + 4·d/B.
  - Rough walls (shear up to su): that triangle moves down with the footing instead, so the
    wall does not slip; the line from the corner then rises at atan 3 and dissipates
    (5/3)·su·v·d per side, so N ≤ 2 + π + (16/3)·d/B.
  Optimising the wedge angles and the triangle's speed lowers these only at O(d²): 5.332 and
  5.404 against 5.342 and 5.408 at d/B = 0.05 (checked numerically in review).
"""

from __future__ import annotations

import math

import numpy as np

PRANDTL_NC = 2.0 + math.pi  # Prandtl (1920): rigid strip on the surface of weightless Tresca soil
#: a deeply embedded cylinder (T-bar) in weightless Tresca soil, full flow round it: Randolph &
#: Houlsby (1984) for the rough one, Martin & Randolph (2006) for the smooth one (exact)
TBAR_NC = {"rough": 11.94, "smooth": 9.20}


def green_vertical(h):
    """Green (1954): the exact vertical capacity V/(B·su) of a rough rigid strip on the surface of
    weightless Tresca soil carrying the horizontal load h = H/(B·su), 0 ≤ h ≤ 1:
    1 + π − arcsin h + √(1 − h²); 2 + π at h = 0 (Prandtl), 1 + π/2 at h = 1, where the strip slides
    along its base (any smaller V slides at H = B·su too). For an array, elementwise (NumPy's arcsin,
    whose last bit may differ from the math module's that a number gets, as the report's figures did)."""
    if np.ndim(h):
        h = np.asarray(h, dtype=float)
        if not ((h >= 0.0) & (h <= 1.0)).all():
            raise ValueError("h = H/(B·su) must lie in [0, 1]")
        return 1.0 + math.pi - np.arcsin(h) + np.sqrt(1.0 - h * h)
    if not 0.0 <= h <= 1.0:
        raise ValueError(f"h = H/(B·su) must lie in [0, 1], not {h}")
    return 1.0 + math.pi - math.asin(h) + math.sqrt(1.0 - h * h)


def green_horizontal(v):
    """The inverse of :func:`green_vertical`: the horizontal capacity h = H/(B·su) a rough surface strip
    carrying v = V/(B·su) has on Green's (1954) envelope, for arrays too: 1 for v ≤ 1 + π/2 (it slides
    along its base), 0 for v ≥ 2 + π; between, with h = sin t, the root of 1 + π − t + cos t = v, which
    falls in t, by bisection to round-off."""
    v = np.asarray(v, dtype=float)
    low, high = np.zeros_like(v), np.full_like(v, 0.5 * math.pi)
    for _ in range(60):
        mid = 0.5 * (low + high)
        beyond = 1.0 + math.pi - mid + np.cos(mid) > v  # the envelope's v at t = mid still above v: t is larger
        low, high = np.where(beyond, mid, low), np.where(beyond, high, mid)
    return np.sin(0.5 * (low + high))


def undrained_wall_coefficient(adhesion_factor: float) -> float:
    """K such that a vertical wall pushed into (pulled from) weightless undrained soil meets σv ± K·su
    normal to it, the wall holding the soil by α·su along it: the slip-line field's fan turns the
    principal stresses from Rankine's state at the free surface by Δ = ½·arcsin α onto the wall, and
    Hencky's relation adds 2·su·Δ to the mean stress along the way, so K = 1 + arcsin α + √(1 − α²):
    Rankine's 2 on a smooth wall, 1 + π/2 = 2.571 on a rough one (Coulomb's planar wedge gives the
    larger 2·√(1 + α), an upper bound)."""
    return 1.0 + math.asin(adhesion_factor) + math.sqrt(1.0 - adhesion_factor**2)


def segment_distance_integral(half_angle: float, radius: float) -> float:
    """∫ r dA over a circular segment (m³): the chord subtending 2α at radius R, r the distance from
    the circle's centre. The sector's 2α·R³/3 less the triangle's d³·(sec α·tan α + ln(sec α + tan α))/3,
    d = R·cos α the chord's distance from the centre."""
    sec, tan = 1.0 / math.cos(half_angle), math.tan(half_angle)
    to_chord = radius * math.cos(half_angle)
    return (2.0 * half_angle * radius**3 - to_chord**3 * (sec * tan + math.log(sec + tan))) / 3.0


def scoop_moment_upper_bound(extent_over_chord: float = math.inf) -> float:
    """A kinematic (upper) bound on the pure moment M/(A·c·su) a rough body bonded to weightless Tresca
    soil carries (no vertical or horizontal load), turned about an axis along its extent e, across its
    chord c (A = c·e; a strip: e = ∞, M/(c²·su) per metre); derived here. The soil under it turns with it
    as a rigid segment of a circular cylinder through both edges (the "scoop"). A chord subtending 2α at
    radius R = c/(2 sin α) dissipates su·2α·R²·e per unit rotation on its arc and, where e is finite,
    su·∫ r dA on each plane end (:func:`segment_distance_integral`). The strip's bound, least at
    tan α = 2α: min α/(2 sin²α) = 0.690; a rectangle L/B = 2 turned across B, M/(A·B·su): 0.790; turned
    along L (e/c = 1/2), M/(A·L·su): 1.082."""
    from scipy.optimize import minimize_scalar

    def moment(alpha: float) -> float:
        arc = alpha / (2.0 * math.sin(alpha) ** 2)
        if math.isinf(extent_over_chord):
            return arc
        return arc + 2.0 * segment_distance_integral(alpha, 0.5 / math.sin(alpha)) / extent_over_chord  # chord 1

    if not extent_over_chord > 0.0:
        raise ValueError(f"the extent over the chord must be positive, not {extent_over_chord}")
    return minimize_scalar(moment, bounds=(0.05, 0.5 * math.pi - 1e-9), method="bounded",
                           options={"xatol": 1e-12}).fun


def spherical_scoop_moment_upper_bound() -> float:
    """The same bound for a rough circular plate of diameter D: the soil within a spherical cap through
    its rim turns with it about a horizontal axis through the sphere's centre, dissipating su·ω·ρ on
    the cap, ρ the distance from that axis (tangent to the sphere, so the cap slides on it):
    M/(A·D·su) ≤ min over the cap's half-angle α of R³·∫∫ ρ/R sin θ dθ dφ / (π D³/4), R = D/(2 sin α):
    0.670 at α = 66.7°; derived here. Vulpe, Gourvenec & Power (2014) tabulate 0.67 for a surface
    circular foundation under pure moment."""
    from scipy import integrate
    from scipy.optimize import minimize_scalar

    def moment(alpha: float) -> float:
        on_cap, _ = integrate.dblquad(lambda phi, theta: math.sqrt((math.sin(theta) * math.cos(phi)) ** 2
                                                                   + math.cos(theta) ** 2) * math.sin(theta),
                                      0.0, alpha, 0.0, 2.0 * math.pi, epsabs=1e-12, epsrel=1e-12)
        return (0.5 / math.sin(alpha)) ** 3 * on_cap / (0.25 * math.pi)

    return minimize_scalar(moment, bounds=(0.3, 1.5), method="bounded", options={"xatol": 1e-10}).fun


def effective_width_moment(v: float) -> float:
    """The moment M/(B²·su) a rough strip whose contact holds no tension carries with the vertical load
    v = V/(B·su), by Meyerhof's (1953) effective width: the load sits at eccentricity e over the width
    B − 2e that bears it at (2 + π)·su, so v = (2 + π)(1 − 2e/B) and M = V·e. The stress field (Prandtl's
    under the effective width, none beside it) is statically admissible: a lower bound."""
    if not 0.0 <= v <= PRANDTL_NC:
        raise ValueError(f"v = V/(B·su) must lie in [0, 2 + π], not {v}")
    return 0.5 * v * (1.0 - v / PRANDTL_NC)


def bonded_moment_upper_bound(v: float, h_toward_dip: float = 0.0) -> float:
    """A kinematic (upper) bound on the moment M/(B²·su) a rough strip bonded to weightless Tresca soil
    carries with the vertical load v = V/(B·su) and the horizontal load h = H/(B·su) (positive towards
    the edge the turn presses down); derived here. The soil within a circle turns with the strip as a
    rigid segment, the arc meeting the surface at a ≤ −B/2 and b ≥ B/2 (beyond an edge the free surface
    turns with it) about its centre, height d above the surface (below it where d < 0), over the middle
    of the chord, xc = (a + b)/2 towards the edge that rises. Per unit turn the arc dissipates
    su·2α·R² (2α the arc's angle, R its radius), V works through the middle's descent xc and H through
    the base's slide d towards the rising edge: M ≤ min 2α·R² − v·xc + h·d. With xc = 0 it is the
    pure-moment scoop, 0.690 (:func:`scoop_moment_upper_bound`), which V does not move: the bound is
    flat at 0.690 up to v ≈ 2.8, then falls, to 0 at v = 5.52 (Fellenius' circle, 7 % over Prandtl)."""
    from scipy.optimize import minimize

    def moment(p) -> float:  # p: how far each end lies beyond its edge (squared: ≥ 0) and the height d
        a, b, d = -0.5 - p[0] ** 2, 0.5 + p[1] ** 2, p[2]
        half_chord = 0.5 * (b - a)
        return 2.0 * math.atan2(half_chord, d) * (half_chord**2 + d * d) - v * 0.5 * (a + b) + h_toward_dip * d

    starts = ((0.0, 0.0, 0.2), (0.0, 0.3, 0.2), (0.0, 0.8, 0.4), (0.3, 0.0, 0.2), (0.0, 0.3, -0.2))
    return min(minimize(moment, start, method="Nelder-Mead",
                        options={"xatol": 1e-10, "fatol": 1e-13, "maxiter": 20000}).fun for start in starts)


def effective_width_inclined_moment(v: float, h: float = 0.0) -> float:
    """The lower bound of :func:`effective_width_moment` with a horizontal load h = H/(B·su) too: Green's
    (1954) field under the narrowest width B' = b·B whose envelope holds (v, h) (h ≤ b and
    v ≤ b·(1 + π − arcsin(h/b) + √(1 − (h/b)²))), none beside it: M = V·(B − B')/2. A bonded strip
    may carry it as well as one that holds no tension (its base need not pull). Its rigour rests on the
    field's extension into the rigid soil, shown for Prandtl's (h = 0; Bishop 1953), taken as for it with h."""
    h = abs(h)
    if not (0.0 <= v and h <= 1.0 and v <= green_vertical(h)):
        raise ValueError(f"(v, h) = ({v}, {h}) lies beyond Green's envelope of the whole width")

    def holds(b: float) -> bool:
        return h <= b and v <= b * green_vertical(h / b)

    low, high = 0.0, 1.0  # holds(high) always; the envelope grows with b
    for _ in range(80):
        mid = 0.5 * (low + high)
        low, high = (low, mid) if holds(mid) else (mid, high)
    return 0.5 * v * (1.0 - high)


def green_radial_factor(h: float, v: float) -> float:
    """How far the load point (h, v) = (H, V)/(B·su) lies from Green's envelope along its ray from the
    origin: λ with (h, v)/λ on the envelope (1: on it, > 1: beyond it). Bisection on λ, the envelope
    being convex (the flat sliding part H = B·su below V = (1 + π/2)·B·su included)."""
    def outside(lam: float) -> bool:
        hh, vv = abs(h) / lam, v / lam
        return hh > 1.0 or vv > green_vertical(hh)

    low, high = 1e-6, 1e6
    for _ in range(200):
        mid = math.sqrt(low * high)
        low, high = (mid, high) if outside(mid) else (low, mid)
    return math.sqrt(low * high)
#: rigorous lower bounds on q/su of a strip wished in place 0.05 B deep, its soil tied to the walls
#: along their normal as dsmv's CEL contact ties it: dsmv.analytic.limit_analysis on its finest
#: mesh, ``python -m dsmv.analytic.limit_analysis --depth 0.05 --roughness rough`` (the rough bound
#: forbids tension, so it holds for the tied wall too) and ``--roughness smooth --bonded``, each
#: with ``--corner-size 0.005 --growth 1.15 --zone-size 0.025`` (2–3 min; `pytest -m slow
#: tests/test_limit_analysis.py` recomputes them)
STRIP_LOWER_BOUND_AT_0P05B = {"rough": 5.357, "smooth": 5.296}
#: rigorous lower bounds on q/su of the strip pushed to 0.05 B whose soil may part from its walls:
#: the notch Prandtl's kinematics leave beside the wall (slope 3, s/3 = 0.0167 B wide at the old
#: mudline) and a flat surface beyond it; the heave only adds soil and cannot lower them.
#: ``python -m dsmv.analytic.limit_analysis --depth 0.05 --roughness R --notch 0.016667`` on the
#: finest mesh above (about 2 min; `pytest -m slow tests/test_limit_analysis.py` recomputes them).
#: Clarabel stalls on these programmes (status NumericalError, duality gap about 0.5 %): the field
#: it returns is checked feasible, so each value is a rigorous bound, if looser than the optimum
NOTCHED_STRIP_LOWER_BOUND_AT_0P05B = {"rough": 5.207, "smooth": 5.206}
#: and upper bounds of the same notched strips, flat surface beyond the notch (the heave may raise
#: the pushed strip's factor above them), the same mesh and command
NOTCHED_STRIP_UPPER_BOUND_AT_0P05B = {"rough": 5.270, "smooth": 5.264}
#: a surface strip on weightless Tresca soil whose strength grows with depth, su = su0 + k·z:
#: Davis & Booker (1973), q/su0 = F·[(2 + π) + k·B/(4·su0)], read as q/su0 for (roughness, k·B/su0);
#: the smooth k·B/su0 = 4 case is the PLAXIS 2D validation manual's (3.2), the rough ones are read
#: off Davis & Booker's chart (about)
DAVIS_BOOKER_NC = {("smooth", 4): 7.80, ("rough", 2): 7.57, ("rough", 4): 9.0, ("rough", 6): 10.5}
#: rigorous brackets on the same (lower, upper): ``python -m dsmv.analytic.limit_analysis --roughness R
#: --gradient G`` on its default mesh (8480 triangles, about 30 s each)
GRADIENT_STRIP_BRACKET = {("smooth", 4): (7.7254, 7.8915), ("rough", 2): (7.5404, 7.6898),
                          ("rough", 4): (8.9974, 9.2833), ("rough", 6): (10.2969, 10.6371)}
#: the notch's width at the old mudline for a strip pushed 0.05 B (B): s/3
NOTCH_AT_0P05B = 0.05 / 3.0


def embedded_strip_upper_bound(depth_over_width: float, rough_walls: bool) -> float:
    """Upper bound on q/su of a strip (width B) whose base lies d below a flat surface, d/B ≥ 0."""
    if depth_over_width < 0.0:
        raise ValueError(f"depth_over_width must be ≥ 0, got {depth_over_width}")
    corner_line = 5.0 / 3.0 if rough_walls else 1.0  # the slip line from the base corner, in su·v·d
    dissipation_per_side = 1.0 + corner_line  # plus the outer line
    return PRANDTL_NC + 2.0 * dissipation_per_side * depth_over_width
