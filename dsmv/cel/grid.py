"""Rectilinear graded grids for the 2D CEL solver.

The grid frame moves with the rigid body (see :mod:`dsmv.cel.solver`): x ≥ 0 runs across the
section from the symmetry axis, y upwards with y = 0 at the body's base (the mudline at t = 0).
A uniform core of cells of size h surrounds the body; beyond it cells grow geometrically by
``growth_ratio`` up to ``max_cell_size_m`` towards the far side and the base. The void above
the mudline keeps the core size, since that is where soil heaves.
"""

from __future__ import annotations

import math
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


def axis_through(centre: float, core_end: float, far_end: float, h: float, ratio: float, h_max: float):
    """Node coordinates from 0 with a node line at ``centre``, uniform h from there on to ``core_end``
    and graded to ``far_end`` (:func:`graded_coordinates`); uniform h between 0 and the centre too, but
    for the cell at 0, which takes what is left (more than h/2, at most 3h/2): a body centred off the
    symmetry plane (a vehicle's track) keeps its edges on node lines."""
    inward = max(0, int(math.floor((centre - 0.5 * h) / h)))
    between = centre - h * np.arange(inward, -1, -1)
    beyond = graded_coordinates(centre, core_end, far_end, h, ratio, h_max)[1:]
    return np.concatenate([[0.0], between, beyond])


@dataclass(frozen=True)
class Grid2D:
    """Node coordinates ``x`` (nx+1) and ``y`` (ny+1) in m; cell (i, j) spans x[i]..x[i+1], y[j]..y[j+1]."""

    x: np.ndarray
    y: np.ndarray
    h: float  # core cell size (m)

    @property
    def axes(self) -> tuple[np.ndarray, ...]:
        """Node coordinates per axis, the last one up."""
        return (self.x, self.y)

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


def build_grid_2d(
    h: float,
    core_half_width: float,
    half_width: float,
    core_depth: float,
    depth: float,
    void_height: float,
    ratio: float,
    h_max: float,
    core_height: float | None = None,
) -> Grid2D:
    """A grid with uniform h on [0, core_half_width] × [−core_depth, core_height], graded outwards.

    Above y = 0 the cells stay uniform up to ``core_height`` (default: all the way to
    ``void_height``, where a surface body heaves soil) and grade beyond it. ``core_half_width``
    should be a multiple of h so the body's edge falls on a node line.
    """
    x = graded_coordinates(0.0, core_half_width, half_width, h, ratio, h_max)
    below = graded_coordinates(0.0, -core_depth, -depth, h, ratio, h_max)[::-1]
    top_of_core = void_height if core_height is None else min(core_height, void_height)
    above = graded_coordinates(0.0, h * np.ceil(top_of_core / h - 1e-9), void_height, h, ratio, h_max)[1:]
    return Grid2D(x=x, y=np.concatenate([below, above]), h=h)


@dataclass(frozen=True)
class Grid3D:
    """A 3D rectilinear grid: node coordinates ``x`` across the body, ``y`` along it and ``z`` up (m),
    x = y = 0 on the body's two symmetry planes, z = 0 at its base; core cell size h (m)."""

    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    h: float

    @property
    def axes(self) -> tuple[np.ndarray, ...]:
        return (self.x, self.y, self.z)

    @property
    def shape(self) -> tuple[int, int, int]:
        """Cells along x, y and z."""
        return len(self.x) - 1, len(self.y) - 1, len(self.z) - 1

    def row_of(self, z_value: float) -> int:
        """Index of the node layer at ``z_value`` (which must lie on one)."""
        return Grid2D(self.x, self.z, self.h).row_of(z_value)


def build_grid_3d(h: float, core: tuple[float, float], far: tuple[float, float], core_depth: float, depth: float,
                  void_height: float, ratio: float, h_max: float, slab: bool = False) -> Grid3D:
    """A 3D grid, uniform h over [0, core[0]] × [0, core[1]] × [−core_depth, void_height], graded
    outwards to ``far`` across and along and to ``depth`` below, as :func:`build_grid_2d` in each
    direction. ``slab``: one cell of h along y (a plane-strain slice between two roller planes)."""
    section = build_grid_2d(h=h, core_half_width=core[0], half_width=far[0], core_depth=core_depth, depth=depth,
                         void_height=void_height, ratio=ratio, h_max=h_max)
    y = np.array([0.0, h]) if slab else graded_coordinates(0.0, core[1], far[1], h, ratio, h_max)
    return Grid3D(section.x, y, section.y, h)


@dataclass(frozen=True)
class Openings:
    """How much of the grid the body leaves to the soil, for the remap.

    ``open_frac`` (nx, ny): the fraction of each cell outside the body; ``aperture_x``
    (nx+1, ny) and ``aperture_y`` (ny+1, nx): the open fraction of each face normal to x
    (indexed [face, row]) and to y ([face, column]), the layout of the remap's face fluxes.
    """

    open_frac: np.ndarray
    aperture_x: np.ndarray
    aperture_y: np.ndarray

    @classmethod
    def of_cells(cls, solid: np.ndarray) -> "Openings":
        """A body made of whole cells: closed faces around each ``solid`` cell, the rest open."""
        nx, ny = solid.shape
        padded = np.zeros((nx + 2, ny + 2), dtype=bool)
        padded[1:-1, 1:-1] = solid
        aperture_x = 1.0 - (padded[:-1, 1:-1] | padded[1:, 1:-1])  # the cells left and right of each face
        aperture_y = 1.0 - (padded[1:-1, :-1] | padded[1:-1, 1:]).T  # below and above
        return cls(1.0 - solid, aperture_x, aperture_y)

    @classmethod
    def of_circle(cls, grid: Grid2D, radius: float, centre_y: float, samples: int = 24) -> "Openings":
        """A circle (centre (0, ``centre_y``), m) cutting the cells: its cut cells stay partly open.

        Face apertures are exact (the chord each face line has inside the circle); cell
        fractions come from ``samples``² sub-cell points, exact to about 1/samples² of a cut cell.
        """

        def outside_length(fixed, lo, hi, centre_other, centre_fixed):
            # length of [lo, hi] on the line (coordinate ``fixed``) outside the circle
            half_chord = np.sqrt(np.maximum(radius**2 - (fixed - centre_fixed) ** 2, 0.0))
            inside = np.clip(np.minimum(hi, centre_other + half_chord) - np.maximum(lo, centre_other - half_chord), 0.0, None)
            return 1.0 - inside / (hi - lo)

        x, y = grid.x, grid.y
        aperture_x = outside_length(x[:, None], y[None, :-1], y[None, 1:], centre_y, 0.0)
        aperture_y = outside_length(y[:, None], x[None, :-1], x[None, 1:], 0.0, centre_y)
        offsets = (np.arange(samples) + 0.5) / samples
        px = x[:-1, None] + np.diff(x)[:, None] * offsets[None, :]  # (nx, samples)
        py = y[:-1, None] + np.diff(y)[:, None] * offsets[None, :]  # (ny, samples)
        # only cells near the circle need sampling
        open_frac = np.ones((grid.nx, grid.ny))
        near_i = np.nonzero(x[:-1] < radius)[0]
        near_j = np.nonzero((y[1:] > centre_y - radius) & (y[:-1] < centre_y + radius))[0]
        for i in near_i:
            inside = (px[i][:, None, None] ** 2 + (py[near_j][None, :, :] - centre_y) ** 2) <= radius**2
            open_frac[i, near_j] = 1.0 - inside.mean(axis=(0, 2))
        # a cell whose four corners are inside lies inside (the circle is convex): closed exactly
        corner_inside = x[:, None] ** 2 + (y[None, :] - centre_y) ** 2 <= radius**2 * (1 + 1e-12)
        solid = corner_inside[:-1, :-1] & corner_inside[1:, :-1] & corner_inside[1:, 1:] & corner_inside[:-1, 1:]
        # a cut cell keeps some room however thin its sliver, so its fill φ/open_frac is defined
        open_frac = np.where(solid, 0.0, np.maximum(open_frac, 0.5 / samples**2))
        aperture_x = np.where(np.abs(aperture_x) < 1e-12, 0.0, aperture_x)
        aperture_y = np.where(np.abs(aperture_y) < 1e-12, 0.0, aperture_y)
        return cls(open_frac, aperture_x, aperture_y.copy())
