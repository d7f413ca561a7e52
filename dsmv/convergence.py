"""Discretisation error from three meshes: Richardson extrapolation with the observed order.

A result z(h) on core cells h1 < h2 < h3 (each about twice the last) is taken to behave as
z(h) = z* + C·h^p. The three runs fix z*, C and p; the error of the fine answer is |z* − z1|. When
the sequence is not in that regime — the differences change sign, or the observed order falls
outside [``ORDER_MIN``, ``ORDER_MAX``] — the estimate assumes first order and a safety factor:
error = ``FALLBACK_FACTOR``·|z1 − z2|, extrapolated with p = 1 (:func:`first_order`, also the estimate
from two meshes). The interval reported is extrapolated ± error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

ORDER_MIN, ORDER_MAX = 0.5, 3.0
#: the error assumed outside the asymptotic regime, in units of the last change |z1 − z2|
FALLBACK_FACTOR = 3.0


@dataclass(frozen=True)
class Estimate:
    """The fine answer's extrapolated value, its error (same unit), the order used and whether the
    observed order was in range (False: first order and the fallback error were assumed)."""

    extrapolated: float
    error: float
    order: float
    asymptotic: bool


def _ratio_at(p: float, h1: float, h2: float, h3: float) -> float:
    return (h3**p - h2**p) / (h2**p - h1**p)


def observed_order(h: tuple[float, float, float], z: tuple[float, float, float]) -> float:
    """The order p with (z3 − z2)/(z2 − z1) = (h3^p − h2^p)/(h2^p − h1^p), any three cell sizes
    h1 < h2 < h3 (bisection: the right side grows with p). NaN when the differences change sign,
    one vanishes, or no p in [0.01, 20] matches."""
    (h1, h2, h3), (z1, z2, z3) = h, z
    d12, d23 = z2 - z1, z3 - z2
    if d12 == 0.0 or d23 == 0.0 or (d12 > 0) != (d23 > 0):
        return math.nan
    target = d23 / d12
    lo, hi = 0.01, 20.0
    if not _ratio_at(lo, h1, h2, h3) <= target <= _ratio_at(hi, h1, h2, h3):
        return math.nan
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if _ratio_at(mid, h1, h2, h3) < target:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def richardson(h: tuple[float, float, float], z: tuple[float, float, float]) -> Estimate:
    """The estimate of the fine answer z[0] on cells h[0] < h[1] < h[2]."""
    (h1, h2, _), (z1, z2, _) = h, z
    p = observed_order(h, z)
    if ORDER_MIN <= p <= ORDER_MAX:
        c = (z2 - z1) / (h2**p - h1**p)
        extrapolated = z1 - c * h1**p
        return Estimate(extrapolated, abs(extrapolated - z1), p, True)
    return first_order((h1, h2), (z1, z2))


def first_order(h: tuple[float, float], z: tuple[float, float]) -> Estimate:
    """The estimate of the fine answer z[0] from two meshes h[0] < h[1], no order observed: first order
    extrapolated, error ``FALLBACK_FACTOR``·|z1 − z2|."""
    (h1, h2), (z1, z2) = h, z
    extrapolated = z1 - (z2 - z1) * h1 / (h2 - h1)
    return Estimate(extrapolated, FALLBACK_FACTOR * abs(z1 - z2), 1.0, False)
