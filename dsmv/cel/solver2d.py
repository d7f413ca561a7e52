"""``solver=cel2d``: the explicit Coupled Eulerian–Lagrangian solver in two dimensions.

What is 2D: the grid (x across the section from the symmetry axis, y up), the bodies it draws
(strip, track cross-section or side view, T-bar, cone, circular plate), their contact
(:func:`~dsmv.cel.contact.build_contact`), the mesh and faces, and the element and remap kernels
(:mod:`dsmv.cel.kernels.elements2d`, :mod:`dsmv.cel.kernels.remap2d`). Modes: plane strain (a strip, or
a track's cross-section, per metre of contact length; the load per track is spread over L) and
axisymmetric (a circular plate of diameter B, a cone). A symmetry plane runs through the body's
axis. Everything else is :class:`~dsmv.cel.solver.CelSolver`'s.
"""

from __future__ import annotations

import math

import numpy as np

from dsmv.cel.config import Cel2DConfig
from dsmv.cel.contact import ContactRules, build_contact
from dsmv.cel.grid import Grid2D, build_grid_2d
from dsmv.cel.layout import Faces2D, Mesh2D, split_cells
from dsmv.cel.solver import CelSolver
from dsmv.errors import ConfigError
from dsmv.config.scene import RATE_KEYS, Scene


class Cel2DSolver(CelSolver):
    """Solver plugin ``cel2d``."""

    name = "cel2d"
    dim = 2
    config_model = Cel2DConfig
    bodies = ("strip", "track", "tbar", "cone", "circular_plate")

    @staticmethod
    def is_axisymmetric(scene: Scene) -> bool:
        mode = scene.solver.mode
        return mode == "axisymmetric" or (mode == "auto" and scene.geometry.kind in ("cone", "circular_plate"))

    #: plane strain moves across (x) and up (z) and turns about the axis out of the plane (y)
    model_freedoms = ("x", "z", "ry")

    @staticmethod
    def half_model(scene: Scene) -> bool:
        """Whether the model is half the section, a symmetry plane on the body's axis: asked
        (``solver.economies.symmetry``) and valid (the landing is symmetric about that plane)."""
        return scene.solver.economies.symmetry and scene.landing.symmetric_about("x") and scene.soil.level_across("x")

    @classmethod
    def held_in(cls, scene: Scene) -> tuple[str, ...]:
        """On the half model the symmetry plane holds the slide and the turn: a symmetric body stays upright."""
        return ("x", "ry") if cls.half_model(scene) else ()

    @classmethod
    def check_capabilities(cls, scene: Scene) -> ContactRules:
        rules = super().check_capabilities(scene)
        cfg, body = scene.solver, scene.geometry
        landing = scene.landing
        if landing.moves_beyond_vertical and (cls.is_axisymmetric(scene) or body.kind not in ("strip", "track")
                                              or getattr(body, "view", "") == "longitudinal"):
            key = landing.beyond_vertical_key
            raise ConfigError(key, landing.model_dump()[key.split(".")[1]], "a body slides and turns in plane "
                              "strain on a strip or a track's cross-section")
        if landing.pitch_deg:
            raise ConfigError("landing.pitch_deg", landing.pitch_deg, "plane strain turns about y (landing.roll_deg): "
                              "a pitched touchdown runs in cel3d")
        beyond_plane = [n for n in ("y", "rx", "rz") if n in landing.freedoms or landing.given_velocity(n)]
        if beyond_plane:
            raise ConfigError("landing.free" if beyond_plane[0] in landing.freedoms else f"landing.{RATE_KEYS[beyond_plane[0]]}",
                              beyond_plane[0], "plane strain moves in x and z and turns about y (ry): cel3d has the rest")
        if not cls.half_model(scene) and (body.kind in ("cone", "circular_plate") or cfg.mode == "axisymmetric"):
            raise ConfigError("solver.economies.symmetry", False, "the whole section is a plane-strain model: an "
                              "axisymmetric body is its own whole")
        if not scene.soil.level_across("y"):
            raise ConfigError("soil.downslope_direction_deg", scene.soil.downslope_direction_deg,
                              "plane strain takes a slope across its section: 0 or 180 (cel3d takes any)")
        if body.vehicle and getattr(body, "view", "") == "longitudinal":
            raise ConfigError("geometry.view", body.view, "a vehicle's section is its cross-section, both tracks "
                              "side by side: the longitudinal view shows one track")
        if body.kind in ("cone", "circular_plate") and cfg.mode == "plane_strain":
            raise ConfigError("solver.mode", cfg.mode, f"a {body.kind.replace('_', ' ')} is axisymmetric: 'auto' or "
                                                       "'axisymmetric'")
        return rules

    def __init__(self, scene: Scene, checked: bool = False):
        super().__init__(scene, checked)
        self.mode = "axisymmetric" if self.axisym else "plane_strain"

    def build(self):
        """The grid: uniform core around the body, graded outwards (:func:`dsmv.cel.grid.build_grid_2d`)."""
        scene, cfg = self.scene, self.scene.solver
        travel = self.expected_travel_m()
        B = self.characteristic_width_m(travel)
        half = 0.5 * B
        h, n_half = self.core_cell_size(half)
        beside = scene.geometry.track_offset_m  # a vehicle's tracks stand off its middle
        core_half_width = h * math.ceil((beside + half + cfg.core_margin_widths * B) / h)
        far_half_width = max(beside + cfg.domain_half_width_widths * B, core_half_width + h)
        self.mudline = self.mudline_m(h)
        grid = build_grid_2d(
            h=h,
            core_half_width=core_half_width,
            half_width=far_half_width,
            core_depth=cfg.core_margin_widths * B,
            depth=max(cfg.domain_depth_widths * B, cfg.core_margin_widths * B + h),
            void_height=self.mudline + 1.3 * travel + 0.25 * B + 3 * h,
            ratio=scene.mesh.growth_ratio,
            h_max=scene.mesh.max_cell_size_m,
            # a deep body (a T-bar) needs the uniform core only around itself
            core_height=B + cfg.core_margin_widths * B if self.circular else None,
        )
        if scene.geometry.vehicle:
            grid = Grid2D(self.tracks_axis(h, half + cfg.core_margin_widths * B, far_half_width), grid.y, h)
        if not self.half_model(scene):  # the whole section: the half grid and its mirror image
            grid = Grid2D(np.concatenate([-grid.x[:0:-1], grid.x]), grid.y, grid.h)
        self.grid, self.h, self.n_half, self.travel = grid, h, n_half, travel
        return grid

    def body_shape(self, grid, angles=(0.0, 0.0, 0.0)):
        """The body's shape (:mod:`dsmv.cel.body`); a turning body's turned by ``angles[1]`` (rad, about y:
        the plane's only turn) about its centre of gravity."""
        cg = self.scene.landing.cg_offset_m
        return self.rules.shape(self.scene.geometry, grid.h, float(angles[1]), (cg[0], cg[2]))

    def body_contact(self, grid, angles=(0.0, 0.0, 0.0)):
        """The body's cells, openings and contact table on ``grid`` (:func:`dsmv.cel.contact.build_contact`)
        turned by ``angles``."""
        return build_contact(self.rules, self.body_shape(grid, angles), grid, grid.row_of(0.0), self.trapped_soil_m())

    def far_sides(self, axis: int) -> tuple[int, ...]:
        """The half model's axis (x = 0) is its symmetry plane."""
        return (-1,) if self.half_model(self.scene) else (0, -1)

    def whole_body_cells(self, cells: float) -> float:
        """The cells the whole section would take on this grid (the half model mirrored; an
        axisymmetric model is its own whole)."""
        return 2 * cells if self.half_model(self.scene) and not self.axisym else cells

    def model_scale(self) -> float:
        """The model carries a share of the body: the half-section per metre of the out-of-plane length
        (L for the cross-section, B for the longitudinal view); axisymmetric per radian."""
        if self.axisym:
            return 2.0 * math.pi
        body = self.scene.geometry
        tracks = 2.0 if body.vehicle else 1.0  # a vehicle's section holds both
        return (2.0 if self.half_model(self.scene) else 1.0) / tracks * (
            body.width_m if self.longitudinal else body.contact_length_m)

    def mesh_and_faces(self, grid, body_contact):
        """The 2D mesh (cell volumes per unit thickness or per radian) and faces of ``grid``."""
        nx, ny = grid.nx, grid.ny
        openings = body_contact.openings
        mesh = Mesh2D(grid.x, grid.y, self.kernels.cell_volumes(grid.x, grid.y, self.axisym), body_contact.corner,
                      (nx + 1) * (ny + 1), split_cells(body_contact.corner))
        return mesh, Faces2D(openings.aperture_x, openings.aperture_y, np.zeros((nx + 1, ny)), np.zeros((ny + 1, nx)))
