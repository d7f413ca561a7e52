"""A body that turns in large deformation, redrawn into the grid as it turns (cel2d and cel3d;
docs/decisions/0030).

The grid follows the body's translation (the remap carries the soil by its travel relative to the
grid), so the centre of gravity stays put in the grid frame; the turn is not followed but drawn.
Between compiled chunks (:class:`Redraw`), once the body's farthest tied point has moved more than
``solver.redraw_fraction`` of a core cell past its drawing, the soil is remapped onto the grid and the
body is redrawn at its angle now:

1. the cells whose corners or centre lie in the turned shape (:class:`~dsmv.cel.body.Turned`) and
   their ties, every node that touches them tied fully while it holds; with contact separation a node
   lets go along the normal of the face nearest to it (:func:`~dsmv.cel.contact.build_contact`);
2. the soil fitted to the new drawing, volume for volume (:func:`conform`): each cell holds at most
   its part outside the turned shape (:func:`room_outside`); what the advancing side gives up feeds
   what the retreating side takes, and only the difference goes to or comes from the nearest free
   surface: the soil's mass is kept to round-off;
3. the nodal masses follow the fills, and the newly tied soil joins the body as one rigid unit
   (:func:`~dsmv.cel.stepper.rejoin_ties`).

What the redraw changes in the soil's energy (its elastic energy, its kinetic energy, and the work
against gravity of lifting the soil it moved) is the redraw's work, ``energy_in_redraw_j`` in the
audit: no force of the body does it.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Optional

import numpy as np

from dsmv.cel import controller as C
from dsmv.cel.body import cells_reached
from dsmv.cel.layout import B_ROT_X, B_ROT_Z
from dsmv.cel.state import weighed_soil
from dsmv.cel.ledger import E_PUSH, E_REDRAW, E_SOIL_GRAV


#: sub-cell points per axis that measure the part of a cell outside the turned shape
SAMPLES = 4


def room_outside(shape, grid, solid: np.ndarray) -> np.ndarray:
    """Per cell, the part of it outside ``shape`` (-), from SAMPLES points per axis; 0 in the body's
    cells (its inscribed staircase), 1 far from it. The soil may fill a cell up to this much. Only the
    cells within one cell of a node inside the shape are sampled (a flat-faced body wider than a cell
    reaches no other)."""
    offsets = (np.arange(SAMPLES) + 0.5) / SAMPLES - 0.5  # about the centre: mirrored cells sample mirrored points
    room = np.ones(solid.shape)
    near = np.nonzero(_grown(cells_reached(shape, grid)))
    if len(near[0]):
        box = tuple(slice(int(n.min()), int(n.max()) + 1) for n in near)
        points = [(0.5 * (a[b][:-1] + a[b][1:])[:, None] + np.diff(a[b])[:, None] * offsets[None, :]).ravel()
                  for a, b in zip(grid.axes, (slice(s.start, s.stop + 1) for s in box))]
        dim = len(points)
        inside = shape.inside(*(p.reshape([-1 if a == k else 1 for a in range(dim)]) for k, p in enumerate(points)))
        inside = np.broadcast_to(inside, tuple(len(p) for p in points))
        cells = tuple(s.stop - s.start for s in box)
        inside = inside.reshape([v for n in cells for v in (n, SAMPLES)])
        room[box] = 1.0 - inside.mean(axis=tuple(range(1, 2 * dim, 2)))
    room[solid] = 0.0
    return room


def _grown(mask: np.ndarray) -> np.ndarray:
    """``mask`` and the cells sharing a face with it (any number of axes)."""
    grown = mask.copy()
    for axis in range(mask.ndim):
        lower, upper = [slice(None)] * mask.ndim, [slice(None)] * mask.ndim
        lower[axis], upper[axis] = slice(1, None), slice(None, -1)
        grown[tuple(lower)] |= mask[tuple(upper)]
        grown[tuple(upper)] |= mask[tuple(lower)]
    return grown


def _face_neighbours(cell: tuple, shape: tuple):
    """The cells sharing a face with ``cell``, axis by axis, the lower first."""
    for axis in range(len(cell)):
        for step in (-1, 1):
            other = cell[axis] + step
            if 0 <= other < shape[axis]:
                yield cell[:axis] + (other,) + cell[axis + 1:]


def nearest_share(volume: float, sources: np.ndarray, through: np.ndarray, capacity: np.ndarray) -> np.ndarray:
    """``volume`` (m³) shared out over the cells nearest to ``sources`` that have ``capacity`` (m³ per
    cell): ring by ring of face neighbours outward through the cells ``through``, each ring's cells in
    proportion to their capacity until the volume is placed (mirror-symmetric, unlike a queue). Returns
    the volume per cell; what finds no capacity is left out of it."""
    placed = np.zeros(capacity.shape)
    reached = sources.copy()
    walk = sources.copy()
    left = volume
    while left > 0.0:
        ring = _grown(walk) & ~reached
        if not ring.any():
            break
        reached |= ring
        room = np.where(ring, capacity, 0.0)
        total = room.sum()
        if total > 0.0:
            part = min(left, total)
            placed += room * (part / total)
            left -= part
        walk = ring & through
    return placed


def conform(phi: np.ndarray, q: np.ndarray, vol: np.ndarray, room_was: np.ndarray, room: np.ndarray) -> None:
    """Fit the soil to the body's new drawing, in place, volume for volume.

    - Where the body left room (``room`` > ``room_was``), the soil that held to it follows: the cell
      fills by the room freed times how full it was of the room it had (a cell the body covered fills
      as full as its fullest neighbour), with the state of the soil beside it.
    - A cell holding more soil than its ``room`` gives up the rest.
    - What the body's advancing side gives up feeds what its retreating side takes (incompressible soil
      flows round under a turning body); only the difference goes to the nearest room at the free
      surface or in the cells the body cuts (more given), or comes from the nearest soil of the free
      surface (more taken), through the soil (:func:`nearest_share`), mixed in by volume as the remap
      mixes.

    The soil's volume is kept to round-off."""
    rows = q.shape[0]
    wanted, source = np.zeros(phi.shape), np.zeros(q.shape)
    freed = room > room_was + 1e-12
    for here in zip(*np.nonzero(freed)):
        if room_was[here] > 0.0:
            share, cell = min(phi[here] / room_was[here], 1.0), here
        else:  # the body's cell it left: as full as its fullest neighbour of soil
            share, cell = 0.0, None
            for other in _face_neighbours(here, phi.shape):
                if phi[other] > 0.0 and room_was[other] > 0.0 and phi[other] / room_was[other] > share:
                    share, cell = min(phi[other] / room_was[other], 1.0), other
        if cell is not None:  # a cell the remap filled beyond the room it had takes only what is left
            wanted[here] = min(share * (room[here] - room_was[here]), max(room[here] - phi[here], 0.0)) * vol[here]
            source[(slice(None), *here)] = q[(slice(None), *cell)]
    # what the body's cells and the cells it cuts hold beyond their room (the remap's own overshoot
    # elsewhere, a fraction of a percent, is the remap's business)
    excess = np.where(room < 1.0, np.maximum(phi - room, 0.0), 0.0) * vol
    excess[excess < 1e-12 * vol] = 0.0
    given = excess.sum()
    # and, for what the retreating side takes beyond that, what the cells beside the last drawing hold
    # beyond their room: between drawings the tied nodes turn with the body while its cells stay, so the
    # soil that follows a retreating face piles up through the remap in the cell beside it (the closed
    # face carries none: +0.02 a remap under a strip's rising corner), the room the face left being the
    # body's cell's until now; taken before the free surface, or the pile grows redraw after redraw
    spare = np.where((room >= 1.0) & _grown(room_was < 1.0), np.maximum(phi - room, 0.0), 0.0) * vol
    spare[spare < 1e-12 * vol] = 0.0
    short, spared = wanted.sum() - given, spare.sum()
    if short > 0.0 and spared > 0.0:
        excess += spare * (min(short, spared) / spared)
        given = excess.sum()
    gives = excess > 0.0
    mixed = (q * excess).reshape(rows, -1).sum(axis=1) / given if given > 0.0 else np.zeros(rows)
    phi[gives] -= excess[gives] / vol[gives]
    q[:, gives & (phi <= 0.0)] = 0.0
    total_wanted = wanted.sum()
    matched = min(total_wanted, given)
    arriving = wanted * (matched / total_wanted) if total_wanted > 0.0 else np.zeros(phi.shape)
    soil = phi > 0.0
    air = (phi <= 0.0) & (room >= 1.0)
    if total_wanted > matched:  # the rest from the free surface
        surface = soil & _grown(air) & ~freed
        taken = nearest_share(total_wanted - matched, freed & (wanted > 0.0), soil,
                              np.where(surface, phi * vol, 0.0))
        phi -= taken / vol
        arriving += wanted * (taken.sum() / total_wanted)
    if given > matched:  # the rest to the nearest room
        near = (_grown(soil) & _grown(air)) | ((room < 1.0) & soil)  # the free surface, the cut cells
        put = nearest_share(given - matched, gives, soil & (room > 0.0), np.where(near, np.maximum(room - phi, 0.0), 0.0) * vol)
        stays = given - matched - put.sum()
        put[gives] += excess[gives] * (stays / given)  # no room found (a grid full to its top): it stays
        _mix(phi, q, vol, put, mixed.reshape(-1, *(1,) * phi.ndim))
    _mix(phi, q, vol, arriving, source)


def _mix(phi: np.ndarray, q: np.ndarray, vol: np.ndarray, volume: np.ndarray, state: np.ndarray) -> None:
    """Add ``volume`` (m³ per cell) of soil in ``state`` (rows of q, per cell or one for all) to the cells,
    mixed in by volume as the remap mixes."""
    cells = volume > 0.0
    held = phi * vol
    total = np.where(cells, held + volume, 1.0)
    q[:, cells] = ((held * q + volume * np.broadcast_to(state, q.shape)) / total)[:, cells]
    phi[cells] += volume[cells] / vol[cells]


class Redraw(C.Tracker):
    """Redraws a turning body (module docstring) once its farthest point has moved ``fraction`` of a core
    cell past its drawing; a turn that takes its staircase out of the grid's uniform core ends the run
    ``out_of_domain``."""

    def __init__(self, solver, state, fraction: float):
        self.solver, self.state = solver, state
        self.step_rad = fraction * solver.h / solver.reach_m()
        self.drawn = state.body[B_ROT_X:B_ROT_Z + 1].copy()  # upright, or its attitude at first contact
        self.room = room_outside(solver.body_shape(state.grid), state.grid, state.cells.solid)
        self.redraws = 0

    def after_chunk(self, run: C.Run) -> Optional[C.Ending]:
        angles = self.state.body[B_ROT_X:B_ROT_Z + 1].copy()
        if np.linalg.norm(angles - self.drawn) < self.step_rad:
            return None
        self.solver.remap_now(self.state)
        room = redraw(self.solver, self.state, angles, self.room)
        if isinstance(room, str):
            return C.Ending("out_of_domain", room)
        self.drawn, self.room = angles, room
        self.redraws += 1
        return None


def redraw(solver, state, angles: np.ndarray, room_was: np.ndarray):
    """Draw the body of ``state`` turned by ``angles`` (rad, about x, y, z; module docstring), in place,
    the soil having filled ``room_was`` of each cell (:func:`room_outside`) at the last drawing; returns
    the room now, or why the body cannot be drawn (its staircase leaves the uniform core)."""
    from dsmv.cel.kernels.nodes import kinetic_energy, nodal_mass_of_soil
    from dsmv.cel.state import hourglass_factor
    from dsmv.cel.stepper import rejoin_ties

    cells, nodes, par, mesh = state.cells, state.nodes, state.par, state.mesh
    grid = state.grid
    new = solver.body_contact(grid, angles)
    soil_rows = np.nonzero((cells.phi > 0.0).reshape(-1, cells.phi.shape[-1]).any(axis=0))[0]
    top = soil_rows[-1] + 2 if len(soil_rows) else 0  # the walls above the soil meet none
    for axis, nodes_along in enumerate(grid.axes[:-1]):
        outside = np.abs(np.diff(nodes_along)) > grid.h * (1 + 1e-9)
        if np.moveaxis(new.solid, axis, 0)[outside, ..., :top].any():
            turned = max(abs(a) for a in angles)
            return (f"the body turned {math.degrees(turned):.3g}°: its drawing left the uniform core of cells; widen "
                    f"solver.core_margin_widths")
    new = replace(new, contact=solver.seated(new.contact))
    room = room_outside(solver.body_shape(grid, angles), grid, new.solid)
    elastic = solver.kernels.elastic_energy
    before = (elastic(cells.phi, cells.q, mesh.vol, par.shear, par.bulk), kinetic_energy(nodes.mass, nodes.v))
    dim = cells.phi.ndim
    centres = [(0.5 * (a[1:] + a[:-1])).reshape([-1 if k == axis else 1 for k in range(dim)])
               for axis, a in enumerate(grid.axes)]
    moved = [-(weighed_soil(cells, mesh, par) * c).sum() for c in centres]  # the soil's first moments (m⁴) …
    conform(cells.phi, cells.q, mesh.vol, room_was, room)
    moved = [m + (weighed_soil(cells, mesh, par) * c).sum() for m, c in zip(moved, centres)]  # … how they changed
    cells.solid[:] = new.solid
    cells.open_frac[:] = new.openings.open_frac
    cells.strength_factor[:] = new.strength_factor
    cells.gap[:] = new.gap
    cells.hourglass_factor[:] = hourglass_factor(new.openings.open_frac, solver.scene.solver.hourglass_cells(
        solver.scene.geometry.kind))
    _, drawn_faces = solver.mesh_and_faces(grid, new)  # a turning body closes no faces for the 3D remap
    for name in drawn_faces._fields:
        if name.startswith("aperture"):
            getattr(state.faces, name)[:] = getattr(drawn_faces, name)
    state.contact = new.contact
    nodal_mass_of_soil(mesh, cells, par, nodes.mass)
    work_against_gravity = par.density * par.gravity * moved[-1]
    if par.sloped:  # and along a sloping seabed
        work_against_gravity -= par.density * (par.gravity_x * moved[0] + (par.gravity_y * moved[1] if dim == 3 else 0.0))
    changed = (elastic(cells.phi, cells.q, mesh.vol, par.shear, par.bulk) - before[0]
               + kinetic_energy(nodes.mass, nodes.v) - before[1] + work_against_gravity)
    rejoined = np.zeros(2)
    rejoin_ties(state.contact, nodes, par, state.body, rejoined)
    state.energy[E_REDRAW] += changed + rejoined[0]
    state.energy[E_PUSH] += rejoined[1]
    state.energy[E_SOIL_GRAV] -= work_against_gravity
    return room
