"""``solver=cel3d``: the explicit CEL solver on hexahedra, on the layers 2D and 3D share.

What differs from :class:`~dsmv.cel.solver2d.Cel2DSolver` is the grid (three axes: x across the
body, y along it, z up), the bodies (a rectangular or circular plate, a strip as a slab one cell
thick between two plane-strain planes), their contact (:func:`~dsmv.cel.contact.build_plate_contact`)
and the element kernels (:mod:`dsmv.cel.kernels.elements3d`); sizing, the controller and its
guards, the energy ledger and the result are :class:`~dsmv.cel.solver.CelSolver`'s. A quarter of
a plate is modelled, with two vertical symmetry planes through its axes, unless
``solver.economies.symmetry`` asks for half of it or the whole.

With ``solver.remap=true`` (the default) the grid moves with the body and the soil is carried
through it in three directional sweeps; ``false`` is the small-strain analysis on the undeformed
grid, which is what the exact bearing capacities of surface plates refer to.
"""

from __future__ import annotations

import math

import numpy as np

from dsmv.cel.body import Box, Disc, Pose, TrackBody, TrackSideView, Turned3D, Vehicle
from dsmv.cel.config import Cel3DConfig
from dsmv.cel.contact import ContactRules, build_plate_contact, build_turned_contact
from dsmv.cel.grid import Grid3D, build_grid_3d
from dsmv.cel.layout import Faces3D, Mesh3D, split_cells
from dsmv.cel.solver import CelSolver, State, in_sweep
from dsmv.errors import ConfigError
from dsmv.config.scene import Scene

#: memory per cell of the 3D state (B): eight state rows, φ, strength, factor, openings and the shared
#: divergence, the cell volumes, three face apertures and fluxes, the corner table (8 × int32) and the
#: nodes' velocity, force, travel and mass (a tenth more nodes than cells on these grids); the state's
#: arrays measured 291 B per cell on the quarter square plate at B/10 (``dsmv-bench --3d``)
BYTES_PER_CELL_3D = 8 * (8 + 5 + 1 + 6) + 4 * 8 + 3 + int(1.1 * 8 * 10)
#: grids with fewer cells run the per-cell kernels on one thread. Two threads against one, the square
#: plate pushed with the remap (min of two runs each, dsmv-bench --3d for the larger grids): 1.13× at
#: 4,275 cells, 1.23× at 9,200, 1.25× at 17,500, 1.33× at 28,800, 1.62× at 81,356
PARALLEL_MIN_CELLS = 4_000


def faces_3d(solid: np.ndarray) -> Faces3D:
    """The faces of a 3D grid whose body is whole cells: closed beside a body cell, open elsewhere,
    each axis' faces indexed [face along it, the other two axes' cells]."""
    apertures = []
    for axis in range(3):
        padded = np.pad(solid, [(1, 1) if a == axis else (0, 0) for a in range(3)])
        n = solid.shape[axis] + 1
        closed = np.take(padded, range(n), axis=axis) | np.take(padded, range(1, n + 1), axis=axis)
        apertures.append(np.ascontiguousarray(np.moveaxis(1.0 - closed, axis, 0)))
    return Faces3D(*apertures, *(np.zeros_like(a) for a in apertures))


def closed_faces(faces: Faces3D, solid: np.ndarray) -> np.ndarray:
    """Each soil cell's faces against a body cell (:func:`faces_3d`' closed ones), as the bits of
    :attr:`~dsmv.cel.layout.Mesh3D.closed` (the grid's own edges are open: their boundary
    conditions hold the soil there)."""
    closed = np.zeros(solid.shape, dtype=np.uint8)
    for axis, aperture in enumerate(faces[:3]):
        shut = np.moveaxis(aperture == 0.0, 0, axis).astype(np.uint8)  # back to the cells' axes
        n = solid.shape[axis]
        below, above = np.take(shut, range(n), axis=axis), np.take(shut, range(1, n + 1), axis=axis)
        closed |= (below << 2 * axis) | (above << 2 * axis + 1)
    closed[solid] = 0
    return closed


class Cel3DSolver(CelSolver):
    """Solver plugin ``cel3d``."""

    name = "cel3d"
    dim = 3
    config_model = Cel3DConfig
    bodies = ("strip", "rectangular_plate", "circular_plate", "track")
    bytes_per_cell = BYTES_PER_CELL_3D
    #: mesh=auto: 0.075 m core cells, 0.8 % above B/30 and 1.3 % above the answer extrapolated from B/30, B/16
    #: and B/8 (± 1.1 %; docs/verification/track-3d.md)
    default_mesh = "coarse"

    @classmethod
    def check_capabilities(cls, scene: Scene) -> ContactRules:
        body = scene.geometry
        if body.kind not in cls.bodies:
            raise ConfigError("geometry.kind", body.kind, f"{cls.name} runs {', '.join(cls.bodies)} bodies")
        if getattr(body, "view", "cross_section") == "longitudinal":
            # the view names the plane a 2D model cuts; a 3D domain sized on the view's width (L) holds
            # about 36 times the track's cells
            raise ConfigError("geometry.view", body.view, "cel3d models the whole track, its side view included: "
                                                          "leave geometry.view to cel2d")
        landing = scene.landing
        rules = ContactRules.of(scene, False, True, cls.held_in(scene))
        if rules.turning:  # redrawn as it turns (dsmv.cel.turn): a rough staircase of whole cells
            refusal = rules.refusal()
            if refusal is not None:
                raise refusal
            if getattr(body, "grousers", "trapped_soil") == "cells":
                raise ConfigError("geometry.grousers", body.grousers, "a track that turns with the remap is redrawn "
                                  "as its grousers' envelope: trapped_soil")
        if body.kind == "strip":
            beyond_slab = [n for n in ("y", "rx", "rz") if n in landing.freedoms or landing.given_velocity(n)]
            if beyond_slab:
                raise ConfigError("landing.free", beyond_slab[0], "a strip (a slab between plane-strain planes) moves "
                                  "in x and z and turns about y")
        return rules

    @staticmethod
    def planes_of(scene: Scene) -> tuple[bool, bool]:
        """Which vertical mid-planes a scene's model cuts the body on (normal to x, normal to y): those
        ``solver.economies.symmetry`` asks for (quarter: both; half: the one normal to x; full: none) about
        which the landing is symmetric. A strip's slab always has its plane-strain planes."""
        asked, landing = scene.solver.economies.symmetry, scene.landing
        soil = scene.soil  # a seabed that falls along an axis has no mirror across it
        return (asked != "full" and landing.symmetric_about("x") and soil.level_across("x"),
                scene.geometry.kind == "strip" or (asked == "quarter" and landing.symmetric_about("y")
                                                   and soil.level_across("y")))

    @classmethod
    def held_in(cls, scene: Scene) -> tuple[str, ...]:
        """A symmetry plane holds the slide across it and the turns that would tilt or twist it."""
        normal_x, normal_y = cls.planes_of(scene)
        held = (("x", "ry", "rz") if normal_x else ()) + (("y", "rx", "rz") if normal_y else ())
        return tuple(dict.fromkeys(held))

    def symmetry_planes(self) -> tuple[bool, bool]:
        """:meth:`planes_of` this solver's scene."""
        return self.planes_of(self.scene)

    # ------------------------------------------------------------------ geometry

    @property
    def slab(self) -> bool:
        """A strip: a slab one cell thick between two plane-strain planes."""
        return self.scene.geometry.kind == "strip"

    @property
    def models_track_side(self) -> bool:
        return True

    def half_length_m(self) -> float:
        """Half the body's length along y (m): L/2, B/2 for a circle, unbounded for a strip; a track's
        flat run L/2 and a sprocket's radius beyond it."""
        body = self.scene.geometry
        if body.kind == "strip":
            return math.inf
        if body.kind == "track":
            return 0.5 * body.contact_length_m + body.sprocket_radius_m
        return 0.5 * (body.width_m if body.kind == "circular_plate" else body.contact_length_m)

    def shape(self):
        body = self.scene.geometry
        if body.kind == "circular_plate":
            return Disc(0.5 * body.width_m)
        if body.kind == "track":
            track = TrackBody(0.5 * body.width_m, TrackSideView.of(body, self.h))
            return Vehicle(track, body.gauge_m) if body.vehicle else track
        return Box(0.5 * body.width_m, self.half_length_m())

    def build(self):
        """The grid: a uniform core around the body, graded outwards in all three directions."""
        scene, cfg = self.scene, self.scene.solver
        travel = self.expected_travel_m()
        B = self.characteristic_width_m(travel)
        h, n_half = self.core_cell_size(0.5 * B)
        margin = cfg.core_margin_widths * B
        self.mudline = self.mudline_m(h)
        half_length = self.half_length_m() if not self.slab else 0.5 * B
        beside = scene.geometry.track_offset_m  # a vehicle's track centres stand off its middle
        core = (h * math.ceil((beside + 0.5 * B + margin) / h), h * math.ceil((half_length + margin) / h))
        far = (max(beside + cfg.domain_half_width_widths * B, core[0] + h),
               max(half_length + (cfg.domain_half_width_widths - 0.5) * B, core[1] + h))
        grid = build_grid_3d(h=h, core=core, far=far, core_depth=margin,
                             depth=max(cfg.domain_depth_widths * B, margin + h),
                             void_height=self.mudline + 1.3 * travel + 0.25 * B + 3 * h,
                             ratio=scene.mesh.growth_ratio,
                             h_max=scene.mesh.max_cell_size_m, slab=self.slab)
        if scene.geometry.vehicle:
            grid = Grid3D(self.tracks_axis(h, 0.5 * B + margin, far[0]), grid.y, grid.z, h)
        mirrored = tuple(not plane for plane in self.symmetry_planes())  # the axes modelled on both sides
        grid = Grid3D(*(np.concatenate([-a[:0:-1], a]) if both else a for a, both in zip((grid.x, grid.y), mirrored)),
                         grid.z, grid.h)
        self.grid, self.h, self.n_half, self.travel = grid, h, n_half, travel
        return grid

    def far_sides(self, axis: int) -> tuple[int, ...]:
        """A symmetry plane at the start of an axis is no far side; a strip slab's planes along y are its
        plane-strain planes."""
        if axis == 1 and self.slab:
            return ()
        return (-1,) if self.symmetry_planes()[axis] else (0, -1)

    def mirrors(self) -> float:
        """The model's copies in the whole body: four quarters, two halves, one whole."""
        normal_x, normal_y = self.symmetry_planes()
        return (2.0 if normal_x else 1.0) * (2.0 if normal_y else 1.0)

    def model_scale(self) -> float:
        """Model quantities → per track: four quarters of a plate (two halves, one whole), a vehicle's
        share of them per each of its two tracks; a strip slab is half the section (or the whole) over
        one cell of thickness, per contact length L."""
        normal_x, _ = self.symmetry_planes()
        if self.slab:
            return (2.0 if normal_x else 1.0) * self.scene.geometry.contact_length_m / self.h
        return self.mirrors() / (2.0 if self.scene.geometry.vehicle else 1.0)

    def whole_body_cells(self, cells: float) -> float:
        """The cells the whole body would take on this grid: the quarter model mirrored twice, the half
        once (a strip slab is its own whole)."""
        if self.slab:
            return cells
        return cells * self.mirrors()

    def contact_area_m2(self) -> float:
        """The area the bearing factor refers to (m²): the footprint the body's cells press, per track
        (B·L for a rectangle on node lines; a circle's staircase, within a fraction of a cell per row of π·B²/4);
        a track's B·L, its plates' flat run, as in 2D (its grousers' tips press far less)."""
        if self.scene.geometry.kind == "track":
            return super().contact_area_m2()
        return self.footprint_m2 * self.model_scale()

    # ------------------------------------------------------------------ state

    def body_shape(self, grid, angles=(0.0, 0.0, 0.0)):
        """A turning body's shape turned by ``angles`` (rad, about x, y, z) about its centre of gravity
        (:class:`~dsmv.cel.body.Turned3D`)."""
        return Turned3D(self.shape(), Pose.turned(angles, self.scene.landing.cg_offset_m))

    def body_contact(self, grid, angles=None):
        """The body's cells, openings and contact table on ``grid`` (:func:`dsmv.cel.contact.build_plate_contact`;
        a turning body's turned by ``angles``, :func:`~dsmv.cel.contact.build_turned_contact`), and, drawn
        upright, the footprint its base presses (m², model)."""
        k_base = grid.row_of(0.0)
        if self.rules.turning:
            body_contact = build_turned_contact(self.body_shape(grid, (0.0, 0.0, 0.0) if angles is None else angles),
                                                grid, grid.z[k_base], self.trapped_soil_m())
        else:
            shape = self.shape()
            body_contact = build_plate_contact(shape, grid, k_base, self.scene.geometry.adhesion_factor,
                                               wall_area=math.pi / 4 if isinstance(shape, Disc) else 1.0,
                                               staircase=isinstance(shape, (Disc, TrackBody)),
                                               trapped_m=self.trapped_soil_m())
        if angles is None:
            footprint = body_contact.solid[:, :, k_base]
            self.footprint_m2 = float((np.diff(grid.x)[:, None] * np.diff(grid.y)[None, :])[footprint].sum())
        return body_contact

    def reach_m(self) -> float:
        """How far the body's farthest point lies from its centre of gravity (m): the lever that turns an
        angle into a displacement (its walls counted up to one width; a strip slab's length not at all)."""
        cg = self.scene.landing.cg_offset_m
        along = 0.0 if self.slab else self.half_length_m() + abs(cg[1])
        return math.hypot(self.half_span_m() + abs(cg[0]), along, max(abs(cg[2]), self.scene.geometry.width_m))

    def mesh_and_faces(self, grid, body_contact):
        """The 3D mesh (cell volumes, the faces each cell has against the body) and faces of ``grid``."""
        faces = faces_3d(body_contact.solid)
        # the remap takes a closed face as moving with the grid (the body's translation), which a turning
        # body's faces do not: its cells beside it see their nodes' velocities, as 2D's staircase does
        closed = (np.zeros(body_contact.solid.shape, dtype=np.uint8) if self.rules.turning
                  else closed_faces(faces, body_contact.solid))
        mesh = Mesh3D(grid.x, grid.y, grid.z, self.kernels.cell_volumes(grid.x, grid.y, grid.z), body_contact.corner,
                      int(np.prod([len(a) for a in grid.axes])), split_cells(body_contact.corner), closed)
        return mesh, faces

    def contact_separation(self) -> bool:
        """The faces let go of soil that pulls away when asked, or in a landing (``auto``)."""
        asked = self.scene.solver.contact_separation
        return asked is True or (asked == "auto" and self.scene.landing.kind == "drop")

    def thread_count(self, cells: int) -> int:
        """Threads for the per-cell kernels: ``solver.threads``, else all Numba's outside a sweep and one
        in a sweep's job; one below :data:`PARALLEL_MIN_CELLS`, where threads cost more than they save."""
        import numba

        available = numba.config.NUMBA_NUM_THREADS
        asked = self.scene.solver.threads or (1 if in_sweep() else available)
        return 1 if cells < PARALLEL_MIN_CELLS else max(1, min(asked, available))

    def advance(self, state: State, n: int) -> tuple[int, int]:
        import numba

        numba.set_num_threads(self.thread_count(state.cells.phi.size))
        return super().advance(state, n)
