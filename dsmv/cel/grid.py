"""Rectilinear graded grids for the 2D CEL solver.

The grid frame moves with the rigid body (see :mod:`dsmv.cel.solver`): x ≥ 0 runs across the
section from the symmetry axis, y upwards with y = 0 at the body's base (the mudline at t = 0).
A uniform core of cells of size h surrounds the body; beyond it cells grow geometrically by
``growth_ratio`` up to ``max_cell_size_m`` towards the far side and the base. The void above
the mudline keeps the core size, since that is where soil heaves.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def graded_coordinates(start: float, core_end: float, far_end: float, h: float, ratio: float, h_max: float):
    """Node coordinates from ``start`` (uniform h up to ``core_end``) grading to ``far_end``.

    Works in either direction (far_end < start for a downward axis). The last graded cell is
    stretched or merged so that the axis ends exactly at ``far_end``.
    """
    sign = 1.0 if far_end >= start else -1.0
    n_core = max(1, int(round(abs(core_end - start) / h)))
    coords = [start + sign * h * k for k in range(n_core + 1)]
    size = h
    while sign * (far_end - coords[-1]) > 1e-12:
        size = min(size * ratio, h_max)
        remaining = sign * (far_end - coords[-1])
        if remaining < 1.5 * size:  # close the axis with one last cell
            coords.append(far_end)
            break
        coords.append(coords[-1] + sign * size)
    return np.asarray(coords)


@dataclass(frozen=True)
class Grid:
    """Node coordinates ``x`` (nx+1) and ``y`` (ny+1) in m; cell (i, j) spans x[i]..x[i+1], y[j]..y[j+1]."""

    x: np.ndarray
    y: np.ndarray
    h: float  # core cell size (m)

    @property
    def nx(self) -> int:
        return len(self.x) - 1

    @property
    def ny(self) -> int:
        return len(self.y) - 1

    @property
    def dx(self) -> np.ndarray:
        return np.diff(self.x)

    @property
    def dy(self) -> np.ndarray:
        return np.diff(self.y)

    @property
    def xc(self) -> np.ndarray:
        return 0.5 * (self.x[1:] + self.x[:-1])

    @property
    def yc(self) -> np.ndarray:
        return 0.5 * (self.y[1:] + self.y[:-1])

    def row_of(self, y_value: float) -> int:
        """Index of the node row at ``y_value`` (which must lie on a node row)."""
        j = int(np.argmin(np.abs(self.y - y_value)))
        if abs(self.y[j] - y_value) > 1e-9 * max(1.0, abs(y_value)):
            raise ValueError(f"y = {y_value} is not a node row")
        return j


def build_grid(
    h: float,
    core_half_width: float,
    half_width: float,
    core_depth: float,
    depth: float,
    void_height: float,
    ratio: float,
    h_max: float,
    core_height: float | None = None,
) -> Grid:
    """A grid with uniform h on [0, core_half_width] × [−core_depth, core_height], graded outwards.

    Above y = 0 the cells stay uniform up to ``core_height`` (default: all the way to
    ``void_height``, where a surface body heaves soil) and grade beyond it. ``core_half_width``
    should be a multiple of h so the body's edge falls on a node line.
    """
    x = graded_coordinates(0.0, core_half_width, half_width, h, ratio, h_max)
    below = graded_coordinates(0.0, -core_depth, -depth, h, ratio, h_max)[::-1]
    top_of_core = void_height if core_height is None else min(core_height, void_height)
    above = graded_coordinates(0.0, h * np.ceil(top_of_core / h - 1e-9), void_height, h, ratio, h_max)[1:]
    return Grid(x=x, y=np.concatenate([below, above]), h=h)
