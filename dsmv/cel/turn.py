"""A body that turns in large deformation, redrawn into the grid as it turns (plane strain;
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
from dsmv.cel.layout import B_ROT_Y
from dsmv.cel.ledger import E_PUSH, E_REDRAW, E_SOIL_GRAV


#: sub-cell points per axis that measure the part of a cell outside the turned shape
SAMPLES = 4


def room_outside(shape, grid, solid: np.ndarray) -> np.ndarray:
    """Per cell, the part of it outside ``shape`` (-), from SAMPLES² points; 0 in the body's cells (its
    inscribed staircase), 1 far from it. The soil may fill a cell up to this much."""
    offsets = (np.arange(SAMPLES) + 0.5) / SAMPLES - 0.5  # about the centre: mirrored cells sample mirrored points

    def points(axis):
        return (0.5 * (axis[:-1] + axis[1:])[:, None] + np.diff(axis)[:, None] * offsets[None, :]).ravel()

    x, y = points(grid.x), points(grid.y)
    inside = shape.inside(x[:, None], y[None, :]).reshape(grid.nx, SAMPLES, grid.ny, SAMPLES)
    room = 1.0 - inside.mean(axis=(1, 3))
    room[solid] = 0.0
    return room


def _grown(mask: np.ndarray) -> np.ndarray:
    """``mask`` and the cells sharing a face with it."""
    grown = mask.copy()
    grown[1:] |= mask[:-1]
    grown[:-1] |= mask[1:]
    grown[:, 1:] |= mask[:, :-1]
    grown[:, :-1] |= mask[:, 1:]
    return grown


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
    for i, j in zip(*np.nonzero(freed)):
        if room_was[i, j] > 0.0:
            share, cell = min(phi[i, j] / room_was[i, j], 1.0), (i, j)
        else:  # the body's cell it left: as full as its fullest neighbour of soil
            share, cell = 0.0, None
            for c, d in ((i - 1, j), (i + 1, j), (i, j - 1), (i, j + 1)):
                if 0 <= c < phi.shape[0] and 0 <= d < phi.shape[1] and phi[c, d] > 0.0 and room_was[c, d] > 0.0:
                    if phi[c, d] / room_was[c, d] > share:
                        share, cell = min(phi[c, d] / room_was[c, d], 1.0), (c, d)
        if cell is not None:
            wanted[i, j] = share * (room[i, j] - room_was[i, j]) * vol[i, j]
            source[:, i, j] = q[:, cell[0], cell[1]]
    # what the body's cells and the cells it cuts hold beyond their room (the remap's own overshoot
    # elsewhere, a fraction of a percent, is the remap's business)
    excess = np.where(room < 1.0, np.maximum(phi - room, 0.0), 0.0) * vol
    excess[excess < 1e-12 * vol] = 0.0
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
        _mix(phi, q, vol, put, mixed[:, None, None])
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
    """Redraws a turning body (module docstring) once its edge has moved ``fraction`` of a core cell
    past its drawing; a turn that takes its staircase out of the grid's uniform core ends the run
    ``out_of_domain``."""

    def __init__(self, solver, state, fraction: float):
        self.solver, self.state = solver, state
        self.step_rad = fraction * solver.h / solver.reach_m()
        self.drawn_rad = 0.0
        self.room = room_outside(solver.body_shape(state.grid, 0.0), state.grid, state.cells.solid)
        self.redraws = 0

    def after_chunk(self, run: C.Run) -> Optional[C.Ending]:
        angle = float(self.state.body[B_ROT_Y])
        if abs(angle - self.drawn_rad) < self.step_rad:
            return None
        self.solver.remap_now(self.state)
        room = redraw(self.solver, self.state, angle, self.room)
        if isinstance(room, str):
            return C.Ending("out_of_domain", room)
        self.drawn_rad, self.room = angle, room
        self.redraws += 1
        return None


def redraw(solver, state, angle: float, room_was: np.ndarray):
    """Draw the body of ``state`` at ``angle`` (rad, about y; module docstring), in place, the soil
    having filled ``room_was`` of each cell (:func:`room_outside`) at the last drawing; returns the room
    now, or why the body cannot be drawn (its staircase leaves the uniform core)."""
    from dsmv.cel.kernels.nodes import kinetic_energy, nodal_mass
    from dsmv.cel.state import hourglass_factor
    from dsmv.cel.stepper import rejoin_ties

    cells, nodes, par, mesh = state.cells, state.nodes, state.par, state.mesh
    grid = state.grid
    new = solver.body_contact(grid, angle)
    core = np.abs(np.diff(grid.x)) <= grid.h * (1 + 1e-9)
    soil_rows = np.nonzero((cells.phi > 0.0).any(axis=0))[0]
    top = soil_rows[-1] + 2 if len(soil_rows) else 0  # the walls above the soil meet none
    if new.solid[~core, :top].any():
        return (f"the body turned {math.degrees(angle):.3g}°: its drawing left the uniform core of cells; widen "
                f"solver.core_margin_widths")
    new = replace(new, contact=solver.about_centre_of_gravity(new.contact))
    room = room_outside(solver.body_shape(grid, angle), grid, new.solid)
    elastic = solver.kernels.elastic_energy
    before = (elastic(cells.phi, cells.q, mesh.vol, par.shear, par.bulk), kinetic_energy(nodes.mass, nodes.v))
    height = 0.5 * (grid.y[1:] + grid.y[:-1])
    lifted = -(cells.phi * mesh.vol * height[None, :]).sum()
    conform(cells.phi, cells.q, mesh.vol, room_was, room)
    lifted += (cells.phi * mesh.vol * height[None, :]).sum()
    cells.solid[:] = new.solid
    cells.open_frac[:] = new.openings.open_frac
    cells.strength_factor[:] = new.strength_factor
    cells.gap[:] = new.gap
    cells.hourglass_factor[:] = hourglass_factor(new.openings.open_frac, solver.scene.solver.hourglass_cells(
        solver.scene.geometry.kind))
    state.faces.aperture_x[:] = new.openings.aperture_x
    state.faces.aperture_y[:] = new.openings.aperture_y
    state.contact = new.contact
    nodal_mass(mesh, cells, par.density, nodes.mass)
    work_against_gravity = par.density * par.gravity * lifted
    changed = (elastic(cells.phi, cells.q, mesh.vol, par.shear, par.bulk) - before[0]
               + kinetic_energy(nodes.mass, nodes.v) - before[1] + work_against_gravity)
    rejoined = np.zeros(2)
    rejoin_ties(state.contact, nodes, par, state.body, rejoined)
    state.energy[E_REDRAW] += changed + rejoined[0]
    state.energy[E_PUSH] += rejoined[1]
    state.energy[E_SOIL_GRAV] -= work_against_gravity
    return room
