"""Exact and bounding bearing factors of a rigid strip on weightless Tresca soil (q/su, -).

- Prandtl (1920): a strip on the surface carries q = (2 + π)·su, rough or smooth base.
- A strip wished in place with its base at depth d below a flat surface carries more: the soil
  beside it must be lifted too. :func:`embedded_strip_upper_bound` is a kinematic (upper)
  bound for that case, derived here (no published closed form was at hand): Prandtl's
  mechanism under the base, and above each passive triangle the layer of height d moves with
  it, at speed v/√2 along 45°, between two 45° slip lines: one from the base corner (beside it a
  triangle of soil against the wall stays at rest) and one from the triangle's far corner.
  Each line dissipates su·(v/√2)·(d·√2) = su·v·d; a bonded (rough) wall slipping past the
  resting triangle adds su·v·d. Against the work q·B·v:
  N ≤ 2 + π + 4·d/B (smooth walls), N ≤ 2 + π + 6·d/B (rough walls).
"""

from __future__ import annotations

import math

PRANDTL_NC = 2.0 + math.pi  # Prandtl (1920): rigid strip on the surface of weightless Tresca soil


def embedded_strip_upper_bound(depth_over_width: float, rough_walls: bool) -> float:
    """Upper bound on q/su of a strip (width B) whose base lies d below a flat surface, d/B ≥ 0."""
    if depth_over_width < 0.0:
        raise ValueError(f"depth_over_width must be ≥ 0, got {depth_over_width}")
    lines_per_side = 3.0 if rough_walls else 2.0  # slip lines (and the bonded wall) per side
    return PRANDTL_NC + 2.0 * lines_per_side * depth_over_width
