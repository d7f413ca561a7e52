"""``solver=cel2d``: the 2D explicit Coupled Eulerian–Lagrangian solver.

Soil lives on a rectilinear Eulerian grid with a volume fraction per cell; the body is rigid.
The grid translates with the body (what Abaqus/Explicit calls Eulerian mesh motion), so the
body's boundary always lies on the same grid lines. Contact is then a kinematic tie of a
fixed set of nodes (rough: both velocity components, smooth: the normal one), and the
cell-crossing noise and partly filled cells under the body, the largest errors of a
fixed-grid prototype (DESIGN.md §5), cannot arise. The price: in the grid frame the far
soil streams upwards, so soil enters through the base, intact and geostatic at the depth it
has there; the base stays at a fixed distance below the body (set by
``solver.domain_depth_widths``), and the mass audit counts what entered.

Modes: plane strain (a strip, or a track's cross-section, per metre of contact length; the
load per track is spread over L) and axisymmetric (a circular plate of diameter B). A
symmetry plane runs through the body's axis.
"""

from __future__ import annotations

import math
import sys
import time
from typing import Literal, Optional

import numpy as np
from pydantic import Field

from dsmv.analytic.energy import energy_estimate, sinkage_from_energy
from dsmv.cel.state import Elastic, geostatic_state, stepper_flags, stepper_parameters
from dsmv import registry
from dsmv.errors import ConfigError
from dsmv.results import SolveResult
from dsmv.scene import Count, Number, Scene, Schema

#: s/B at which push curves are sampled for the bearing factor q/su0 (averaged over ±0.005·B)
NC_SAMPLES = {"nc_at_0p02B": 0.02, "nc_at_0p05B": 0.05, "nc_at_0p1B": 0.1, "nc_at_1B": 1.0}
NC_WINDOW = 0.005
#: an 'ok' run's energy audit must close to this (relative); worse means the numerics failed
ENERGY_ERROR_LIMIT = 0.05
#: the zig-zag diagnostic counts cells at least this full: a partly filled cell at the soil's
#: surface has void nodes, which stand still, and would read as zig-zag
ZIGZAG_FULL_CELL = 0.99


class Economies(Schema):
    """Work the solver skips; each can be switched off only to measure what it saves (dsmv-bench)."""

    skip_inactive_law: bool = Field(True, description="a law without softening or rate skips that arithmetic")
    stop_at_rest: bool = Field(True, description="a landing ends when the body first comes to rest; "
                                                 "false: it runs on to twice that time")
    skip_void: bool = Field(True, description="cells without soil do no force arithmetic")
    symmetry: bool = Field(True, description="model half the section, with a symmetry plane on the body's axis; "
                                             "false: the whole section (plane strain, rough contact)")


class Cel2DConfig(Schema):
    """Config of ``solver=cel2d`` (numerical settings; the physics comes from the scene)."""

    name: Literal["cel2d"]
    mode: Literal["auto", "plane_strain", "axisymmetric"] = "auto"
    cfl: Number = Field(0.5, gt=0, le=1, description="time step as a fraction of the CFL limit (-)")
    hourglass: Number = Field(0.05, ge=0, le=1, description="viscous hourglass coefficient (-)")
    bulk_viscosity_linear: Number = Field(0.06, ge=0, description="linear bulk viscosity b1 (-)")
    bulk_viscosity_quadratic: Number = Field(1.2, ge=0, description="quadratic bulk viscosity b2 (-)")
    advection_order: Literal[1, 2] = 2
    yield_surface: Literal["auto", "tresca", "von_mises"] = Field(
        "auto", description="auto: von Mises (J2) in plane strain, where it equals Tresca; Tresca in axisymmetry"
    )
    stress_cutoff: Number = Field(0.01, ge=0, lt=1, description="cells with less soil carry no stress (-)")
    remap: bool = Field(True, description="false: small-strain analysis on the undeformed grid (verification)")
    contact_separation: bool = Field(False, description=(
        "true: a face lets go of the soil that would pull away from it (no tension); "
        "false: the soil stays tied to it"))
    # at most 0.25: next to the axis of an axisymmetric model a cell's volume Courant number is
    # about twice the travel over h
    remap_courant: Number = Field(0.05, ge=0, le=0.25, description=(
        "the remap runs once the soil has moved this fraction of a core cell through the grid; 0: every step (-)"))
    domain_depth_widths: Number = Field(5.0, ge=1, description="soil depth below the body, in body widths B")
    domain_half_width_widths: Number = Field(5.0, ge=1, description="half-width of the domain, in B")
    core_margin_widths: Number = Field(1.0, gt=0, description="uniform core beyond the body, in B")
    history_samples: Count = Field(400, ge=10, description="samples in the time history (-)")
    max_steps: Count = Field(20_000_000, ge=1)
    progress: Literal["auto", "on", "off"] = "auto"
    initial_travel_m: Optional[Number] = Field(None, gt=0, description="travel to size the domain for (m)")
    cone_cells_per_depth: Count = Field(16, ge=4, description="cone: core cells across the expected penetration")
    economies: "Economies" = Field(default_factory=lambda: Economies())


def in_sweep() -> bool:
    """True inside a Hydra multirun job: progress lines of many jobs would only interleave."""
    from hydra.core.hydra_config import HydraConfig
    from hydra.types import RunMode

    return HydraConfig.initialized() and HydraConfig.get().mode == RunMode.MULTIRUN


def sliver_pairs(openings) -> np.ndarray:
    """Each sliver of a cut body (a cell open to less than ``CUT_OPEN_FLOOR``) paired with its most
    open neighbour across an open face: rows (i, j, i_neighbour, j_neighbour).

    A sliver alone cannot hold its soil: its pressure sees its volume change over the floored open
    fraction, 6 % of it for a cell open to 3 %, so the remap drained it and then its neighbours (a
    void behind a smooth T-bar). A pair changes volume as one, and shares one fill and one mean
    stress after each remap (:func:`dsmv.cel.stepper.run_steps`)."""
    from dsmv.cel.kernels import CUT_OPEN_FLOOR

    of, ax, ay = openings.open_frac, openings.aperture_x, openings.aperture_y
    pairs = []
    for i, j in zip(*np.nonzero((of > 0.0) & (of < CUT_OPEN_FLOOR))):
        best, neighbour = -1.0, None
        for di, dj, aperture in ((-1, 0, ax[i, j]), (1, 0, ax[i + 1, j]), (0, -1, ay[j, i]), (0, 1, ay[j + 1, i])):
            a, b = i + di, j + dj
            if 0 <= a < of.shape[0] and 0 <= b < of.shape[1] and aperture > 0.0 and of[a, b] >= CUT_OPEN_FLOOR:
                if of[a, b] * aperture > best:
                    best, neighbour = of[a, b] * aperture, (a, b)
        if neighbour is not None:
            pairs.append((i, j, *neighbour))
    return np.array(pairs, dtype=np.int64).reshape(-1, 4)


def soil_kinetic_energy(mass, vx, vy, twin) -> float:
    """The soil's kinetic energy on the nodes and the corner twins (J per unit thickness or per radian)."""
    from dsmv.cel import kernels as K

    nodes = 0.5 * (mass * (vx * vx + vy * vy)).sum()
    twins = 0.5 * (twin[:, K.TW_M] * (twin[:, K.TW_VX] ** 2 + twin[:, K.TW_VY] ** 2)).sum()
    return float(nodes + twins)


def soil_cells_touching(solid, node_i, node_j) -> np.ndarray:
    """The cells outside the body (``solid`` False) with a corner among the nodes (node_i, node_j)."""
    marked = np.zeros((solid.shape[0] + 1, solid.shape[1] + 1), dtype=bool)
    marked[node_i, node_j] = True
    return (marked[:-1, :-1] | marked[1:, :-1] | marked[1:, 1:] | marked[:-1, 1:]) & ~solid


def track_side_view_cells(grid, track) -> np.ndarray:
    """Cells of a track seen from the side (``geometry.view=longitudinal``), half model.

    The flat run of plates spans |x| ≤ L/2 with its underside at the grouser height gh
    (snapped to whole cell rows, at least one row when gh > 0); grousers hang below it to
    y = 0 (the base: sinkage is measured at the grouser tips), one cell column wide at every
    plate pitch from the axis; beyond L/2 the track wraps around a sprocket of radius R, the
    inscribed staircase of a circle centred at (L/2, gh + R). Everything above the plates is
    body (the vehicle). A 0.01 m plate or grouser is thinner than any practical cell: the
    staircase keeps their positions and heights, not their thickness.
    """
    h = grid.x[1] - grid.x[0]
    half, radius = 0.5 * track.contact_length_m, track.sprocket_radius_m
    grouser = 0.0 if track.grouser_height_m == 0 else h * max(1, round(track.grouser_height_m / h))
    x, y = grid.x[:, None], grid.y[None, :]
    inside_node = ((x <= half * (1 + 1e-12)) & (y >= grouser - 1e-12)) | (
        (x - half) ** 2 + (y - grouser - radius) ** 2 <= radius**2 * (1 + 1e-12)) | (
        (x <= half + radius) & (y >= grouser + radius))
    solid = inside_node[:-1, :-1] & inside_node[1:, :-1] & inside_node[1:, 1:] & inside_node[:-1, 1:]
    if grouser > 0:
        positions = np.arange(0.0, half + 1e-12, track.plate_pitch_m)
        columns = np.unique(np.clip(np.searchsorted(grid.x, positions, side="right") - 1, 0, grid.nx - 1))
        rows = (grid.yc > 0.0) & (grid.yc < grouser)
        solid[np.ix_(columns, np.nonzero(rows)[0])] = True
    return solid


class Cel2DSolver:
    """Solver plugin ``cel2d``."""

    name = "cel2d"
    config_model = Cel2DConfig

    @staticmethod
    def check_scene(scene: Scene) -> None:
        """What cel2d cannot run, as a ConfigError at composition time."""
        cfg, body = scene.solver, scene.geometry
        if body.kind not in ("strip", "track", "tbar", "cone"):
            raise ConfigError("geometry.kind", body.kind, "cel2d runs strip, track, tbar and cone bodies")
        if not cfg.economies.symmetry and (body.kind == "cone" or cfg.mode == "axisymmetric"
                                           or body.roughness != "rough" or scene.output.fields
                                           or cfg.contact_separation):
            raise ConfigError("solver.economies.symmetry", False, "the whole section runs plane strain bodies with "
                              "rough contact, no contact separation and no field output; it exists to measure what "
                              "the half model saves")
        if getattr(body, "view", "cross_section") == "longitudinal" and body.roughness != "rough":
            raise ConfigError("geometry.roughness", body.roughness,
                              "the longitudinal view (plates and grousers) models a rough track only")
        flat = body.kind in ("strip", "track") and getattr(body, "view", "cross_section") == "cross_section"
        if body.adhesion_factor not in (0.0, 1.0) and not (flat or body.kind == "tbar"):
            raise ConfigError("geometry.roughness", body.roughness,
                              "limited adhesion α in (0, 1) needs a flat-faced body (strip, or a track's cross-section) "
                              "or a T-bar (an interface layer of strength α·su); a cone takes 'rough' (1)")
        if body.kind == "cone" and body.adhesion_factor == 0.0:
            raise ConfigError("geometry.roughness", body.roughness, "a cone is 'rough' in cel2d for now "
                                                                   "(a smooth staircase cone needs cut cells)")
        if body.kind == "cone" and cfg.mode == "plane_strain":
            raise ConfigError("solver.mode", cfg.mode, "a cone is axisymmetric: 'auto' or 'axisymmetric'")
        separable = flat or (body.kind == "tbar" and body.adhesion_factor == 0.0 and cfg.mode != "axisymmetric")
        if cfg.contact_separation and not separable:
            raise ConfigError("solver.contact_separation", True,
                              "separation acts on a flat-faced body (strip, track cross-section) of any roughness "
                              "or a smooth T-bar in plane strain; this body's staircase faces stay tied fully")

    def __init__(self, scene: Scene):
        self.check_scene(scene)
        self.scene = scene
        cfg, body, soil = scene.solver, scene.geometry, scene.soil
        self.law = registry.load("soil_laws", soil.law, "soil.law")(soil)
        self.cone = body.kind == "cone"
        self.mode = cfg.mode if cfg.mode != "auto" else ("axisymmetric" if self.cone else "plane_strain")
        self.axisym = self.mode == "axisymmetric"
        self.circular = body.kind == "tbar"  # a cylinder (plane strain) or a ball (axisymmetric)
        # A curved body is a staircase of cells. Its contact is tied fully, and a smooth face or
        # limited adhesion α lives in the interface layer, the soil cells that touch it, whose
        # strength is α·su (the thin-layer interface of FE and CEL practice). Soil then slides
        # round the body one layer out, through whole cells, which the remap carries. (Ties
        # along the circle's normal let soil slide along the staircase instead, which the remap
        # cannot carry past the steps: the soil piled up in front, a void opened behind, and a
        # smooth T-bar read 6.6 for 9.20.)
        self.cut_cells = self.circular and body.adhesion_factor == 0.0 and not self.axisym
        self.interface_layer = self.circular and body.adhesion_factor < 1.0 and not self.cut_cells
        #: a track seen from the side: plates, grousers and sprockets in the plane, per metre of B
        self.longitudinal = getattr(body, "view", "cross_section") == "longitudinal"
        # a strip or a track's cross-section: a flat base and vertical walls
        self.flat_faced = body.kind in ("strip", "track") and not self.longitudinal

    def hansbo_depth_m(self) -> float:
        """The cone's scale (m): Hansbo's penetration d = √(K·m·g/su) with K = 0.8 (30° cone), or,
        when deeper, the depth whose work ∫ su·z²/K dz = su·d³/(3K) takes up the touchdown energy
        ½·m·v² (without gravity Hansbo's depth is nil: the cells were nanometres, the run endless)."""
        landing, su = self.scene.landing, self.scene.soil.su0_pa
        static = math.sqrt(0.8 * landing.mass_kg * max(landing.gravity_m_s2, 1e-9) / su)
        return max(static, (1.5 * 0.8 * landing.mass_kg * landing.velocity_m_s**2 / su) ** (1 / 3))

    def characteristic_width_m(self, travel: float) -> float:
        """The body's width for sizing the domain (m): B, or a cone's diameter at the expected depth."""
        body = self.scene.geometry
        if self.cone:
            return 2.0 * travel * math.tan(math.radians(0.5 * body.apex_angle_deg))
        return body.contact_length_m if self.longitudinal else body.width_m

    def contact_area_m2(self) -> float:
        """The area a bearing factor refers to: B·L in plane strain, π·B²/4 in axisymmetry (m²)."""
        B = self.scene.geometry.width_m
        return math.pi * B * B / 4 if self.axisym else B * self.scene.geometry.contact_length_m

    def body_cells_and_ties(self, grid, j_base):
        """Cells inside the body, and the nodes tied to it.

        A node of a body cell is tied fully (moves with the body) when it is a corner or inside
        the body, or when the body is curved (its contact law lives in the interface layer, see
        :meth:`strength_factors`). On a flat face (base or wall) only its normal velocity is
        tied, n being the face normal, pointing into the soil: with solver.contact_separation
        the tie lets go where the soil pulls away. Along the face the soil is held by adhesion
        α·su (roughness α in [0, 1]; rough is α = 1): such a node carries ``tie_cap`` = α × its
        share of the face (m per unit thickness, m²/rad axisymmetric), and the stepper lets the
        face pull it along by up to tie_cap·su. (A rough face that tied its nodes fully would
        hold them with any shear, more than su: at B/40 that read the pushed strip's factor 1.3 %
        above the α → 1 limit, 5.321 against 5.255 at α = 0.999.)
        Returns (solid, tie_i, tie_j, tie_full, tie_nx, tie_ny, tie_cap).
        """
        from dsmv.cel.grid import Grid

        B = self.scene.geometry.width_m
        mirrored = grid.x[0] < 0.0  # the whole section (solver.economies.symmetry=false)
        if mirrored:  # the body's cells on the half grid, then their mirror image
            grid = Grid(grid.x[grid.nx // 2 :], grid.y, grid.h)
        if self.cone:  # the inscribed staircase of the cone (tip at the origin) and its shaft
            body = self.scene.geometry
            radius = np.minimum(grid.y * math.tan(math.radians(0.5 * body.apex_angle_deg)), 0.5 * body.width_m)
            inside_node = (grid.y[None, :] >= 0.0) & (grid.x[:, None] <= radius[None, :] * (1 + 1e-12))
            solid = inside_node[:-1, :-1] & inside_node[1:, :-1] & inside_node[1:, 1:] & inside_node[:-1, 1:]
        elif self.circular:
            # the staircase inscribed in the circle: a cell is solid when its four nodes are
            # inside. (Cells chosen by their centre stick out by up to 0.7·h and read a rough
            # T-bar 15 % high at D/10; inscribed, +1 %.)
            R = 0.5 * B
            inside_node = grid.x[:, None] ** 2 + (grid.y[None, :] - R) ** 2 <= R * R * (1 + 1e-12)
            solid = inside_node[:-1, :-1] & inside_node[1:, :-1] & inside_node[1:, 1:] & inside_node[:-1, 1:]
        elif self.longitudinal:
            solid = track_side_view_cells(grid, self.scene.geometry)
        else:
            solid = (grid.xc[:, None] < 0.5 * B) & (grid.yc[None, :] > 0.0)
        if mirrored:
            solid = np.concatenate([solid[::-1], solid])
            grid = Grid(np.concatenate([-grid.x[:0:-1], grid.x]), grid.y, grid.h)
        touching = np.zeros((grid.nx + 1, grid.ny + 1), dtype=int)
        for di in (0, 1):
            for dj in (0, 1):
                touching[di : di + grid.nx, dj : dj + grid.ny] += solid
        if self.cut_cells:  # every node inside the circle moves with it
            R = 0.5 * B
            tie_i, tie_j = np.nonzero(grid.x[:, None] ** 2 + (grid.y[None, :] - R) ** 2 <= R * R * (1 + 1e-12))
        else:
            tie_i, tie_j = np.nonzero(touching)
        # a node is inside when all its cells are solid (on the axis: both of its two cells)
        cells_around = np.full_like(touching, 4)
        cells_around[0, :] = cells_around[-1, :] = 2
        cells_around[:, 0] = cells_around[:, -1] = 2
        inside = touching[tie_i, tie_j] == cells_around[tie_i, tie_j]
        tie_full = np.ones(len(tie_i), dtype=np.bool_)
        nx_, ny_ = np.zeros(len(tie_i)), np.zeros(len(tie_i))
        cap = np.zeros(len(tie_i))
        alpha = self.scene.geometry.adhesion_factor
        if self.cut_cells:  # the nodes in the cut cells slide along the circle (tied along its normal)
            xs, ys = grid.x[tie_i], grid.y[tie_j] - 0.5 * B
            r = np.maximum(np.hypot(xs, ys), 1e-300)
            nx_, ny_ = xs / r, ys / r
            tie_full = inside.copy()
            nx_[inside], ny_[inside] = 0.0, 0.0  # inside the body: no face, always tied
        elif self.flat_faced:
            xs, ys = grid.x[tie_i], grid.y[tie_j]
            on_base = (tie_j == j_base) & (np.abs(xs) < 0.5 * B - 1e-12)
            on_side = (tie_j > j_base) & np.isclose(np.abs(xs), 0.5 * B) & ~inside
            # normals point into the soil: a tie that may let go (contact_separation) needs the side
            ny_[on_base] = -1.0
            nx_[on_side] = np.sign(xs[on_side])  # the whole section has a wall on either side
            tie_full = ~(on_base | on_side)  # normal ties, and α·su along the face
            if alpha > 0.0:  # each node's share of the base (x) or of the wall (y)
                xg, yg = grid.x, grid.y
                left = np.where(tie_i > 0, xs - xg[np.maximum(tie_i - 1, 0)], 0.0)
                right = np.minimum(xg[np.minimum(tie_i + 1, grid.nx)], 0.5 * B) - xs
                below = ys - yg[np.maximum(tie_j - 1, 0)]
                above = np.where(tie_j < grid.ny, yg[np.minimum(tie_j + 1, grid.ny)] - ys, 0.0)
                radius = xs if self.axisym else 1.0
                cap[on_base] = (alpha * 0.5 * (left + right) * radius)[on_base]
                radius = 0.5 * B if self.axisym else 1.0
                cap[on_side] = (alpha * 0.5 * (below + above) * radius)[on_side]
        return solid, tie_i.astype(np.int64), tie_j.astype(np.int64), tie_full, nx_, ny_, cap

    def corner_twins(self, grid, j_base, solid):
        """The corner twins of a flat-faced body (:data:`dsmv.cel.kernels.N_TWIN`): at each end of
        its base, the soil cells beyond the base, beside the wall, get their own copy of the
        corner node, tied along the wall's normal and held along it by adhesion α·su over the lower
        half of the wall face above the corner. Returns (cell_twin, twin_node, twin); none for
        other bodies."""
        from dsmv.cel import kernels as K

        cell_twin = np.full(solid.shape, -1, dtype=np.int64)
        normals, nodes = [], []
        if self.flat_faced:
            half = 0.5 * self.scene.geometry.width_m
            for side in (1.0, -1.0):
                (i_corner,) = np.nonzero(np.isclose(grid.x, side * half))
                if len(i_corner) == 0:
                    continue
                i_corner = int(i_corner[0])
                # the cells beyond the base touch the corner with their left (right side) or right nodes
                i_cell, below, above = (i_corner, 3, 0) if side > 0 else (i_corner - 1, 2, 1)
                if not 0 <= i_cell < grid.nx:
                    continue
                k = len(normals)
                for j_cell, local in ((j_base - 1, below), (j_base, above)):
                    if 0 <= j_cell < grid.ny and not solid[i_cell, j_cell]:
                        cell_twin[i_cell, j_cell] = 4 * k + local
                normals.append(side)
                nodes.append((i_corner, j_base, i_cell, j_base))
        twin = np.zeros((len(normals), K.N_TWIN))
        twin[:, K.TW_NX] = normals
        if self.flat_faced and len(normals):  # α × the half cell of wall above the corner
            wall_share = 0.5 * (grid.y[j_base + 1] - grid.y[j_base]) if j_base < grid.ny else 0.0
            radius = 0.5 * self.scene.geometry.width_m if self.axisym else 1.0
            twin[:, K.TW_CAP] = self.scene.geometry.adhesion_factor * wall_share * radius
        return cell_twin, np.array(nodes, dtype=np.int64).reshape(-1, 4), twin

    def body_openings(self, grid, solid):
        """What the body leaves open to the soil (:class:`~dsmv.cel.grid.Openings`): whole cells,
        or for a smooth cylinder the cells its circle cuts, partly."""
        from dsmv.cel.grid import Openings

        if self.cut_cells:
            R = 0.5 * self.scene.geometry.width_m
            return Openings.of_circle(grid, R, R)
        return Openings.of_cells(solid)

    def strength_factors(self, solid, tie_i, tie_j, open_frac) -> np.ndarray:
        """Each cell's share of the soil's strength (nx, ny): α in a curved body's interface layer
        (the soil cells with a node tied to the body), 1 elsewhere."""
        factor = np.ones(solid.shape)
        if self.cut_cells:
            factor[(open_frac < 1.0) & (open_frac > 0.0)] = 0.0
        elif self.interface_layer:
            factor[soil_cells_touching(solid, tie_i, tie_j)] = self.scene.geometry.adhesion_factor
        return factor

    def gap_cells(self, solid, tie_i, tie_j, tie_nx, tie_ny) -> np.ndarray:
        """The soil cells beside a face the soil may leave (nx, ny), with solver.contact_separation:
        they carry stress only while full (:func:`dsmv.cel.kernels.update_stress`). A pushed strip
        leaves a wedge-shaped gap beside its wall, a third of a cell wide at 0.05 B and B/20 (README);
        spread across a partly full cell, the sliver of soil beside it would bridge it. The rule
        cannot tell a gap from a free surface or a smeared fill: a wall cell under 95 % full, at
        the corner early in a push too, carries nothing (an O(h) effect), and its node's
        adhesive grip (α > 0) goes with its strength. Flat faces only: a T-bar's cut
        cells keep their stress."""
        if not (self.scene.solver.contact_separation and self.flat_faced):
            return np.zeros(solid.shape, dtype=bool)
        on_face = (tie_nx != 0.0) | (tie_ny != 0.0)
        return soil_cells_touching(solid, tie_i[on_face], tie_j[on_face])

    # ------------------------------------------------------------------ setup

    def expected_travel_m(self) -> float:
        """How far the body is expected to go (m): the push displacement, or the energy method's sinkage."""
        scene = self.scene
        if scene.solver.initial_travel_m:
            return scene.solver.initial_travel_m
        if scene.landing.kind == "push":
            return scene.landing.displacement_m
        if self.cone:
            return 1.5 * self.hansbo_depth_m()
        estimate = energy_estimate(scene)
        z = sinkage_from_energy(
            scene.landing.weight_per_track_n, scene.landing.inertia_per_track_kg, scene.landing.velocity_m_s,
            estimate.resistance_area_m2, scene.soil.su0_pa, scene.soil.ks_pa_per_m,
        )
        return 1.5 * scene.geometry.width_m if math.isinf(z) else 1.5 * z + 0.05 * scene.geometry.width_m

    def build(self):
        """Grid, initial state and tied nodes."""
        from dsmv.cel.grid import build_grid

        scene, cfg = self.scene, self.scene.solver
        travel = self.expected_travel_m()
        B = self.characteristic_width_m(travel)
        half = 0.5 * B
        if self.cone:  # cells sized to the cone: a fixed number across its expected penetration
            h = min(scene.mesh.cell_size_m, self.hansbo_depth_m() / cfg.cone_cells_per_depth)
            n_half = max(1, int(math.ceil(half / h)))
        else:
            n_half = max(1, int(round(half / scene.mesh.cell_size_m)))
            h = half / n_half  # the body's edge falls on a node line
        core_half_width = h * math.ceil((half + cfg.core_margin_widths * B) / h)
        # a body wished in place at depth d0: the mudline lies d0 above the base (rounded to a
        # node row of the uniform core; beyond it a cell the mudline cuts is partly filled)
        self.mudline = h * round(scene.landing.initial_depth_m / h)
        grid = build_grid(
            h=h,
            core_half_width=core_half_width,
            half_width=max(cfg.domain_half_width_widths * B, core_half_width + h),
            core_depth=cfg.core_margin_widths * B,
            depth=max(cfg.domain_depth_widths * B, cfg.core_margin_widths * B + h),
            void_height=self.mudline + 1.3 * travel + 0.25 * B + 3 * h,
            ratio=scene.mesh.growth_ratio,
            h_max=scene.mesh.max_cell_size_m,
            # a deep body (a T-bar) needs the uniform core only around itself
            core_height=B + cfg.core_margin_widths * B if self.circular else None,
        )
        if not cfg.economies.symmetry:  # the whole section: the half grid and its mirror image
            from dsmv.cel.grid import Grid

            grid = Grid(np.concatenate([-grid.x[:0:-1], grid.x]), grid.y, grid.h)
        self.grid, self.h, self.n_half, self.travel = grid, h, n_half, travel
        return grid

    # ------------------------------------------------------------------ run

    def solve(self, run_dir=None) -> SolveResult:
        from dsmv.cel import kernels as K
        from dsmv.cel import stepper as S

        scene, cfg = self.scene, self.scene.solver
        soil, body_cfg, landing = scene.soil, scene.geometry, scene.landing
        grid = self.build()
        x, y = grid.x, grid.y
        nx, ny = grid.nx, grid.ny
        j_base = grid.row_of(0.0)

        rho, grav = soil.density_kg_m3, landing.gravity_m_s2
        elastic = Elastic.of(soil)
        G, Kb = elastic.shear_pa, elastic.bulk_pa
        dt = cfg.cfl * self.h / elastic.wave_speed_m_s
        B = self.characteristic_width_m(self.travel)  # the width that scales guards and ratios (m)

        d0 = self.mudline
        solid, tie_i, tie_j, tie_full, tie_nx, tie_ny, tie_cap = self.body_cells_and_ties(grid, j_base)
        openings = self.body_openings(grid, solid)
        phi, q = geostatic_state(grid, rho, grav, elastic.k0, d0, openings.open_frac)
        strength_factor = self.strength_factors(solid, tie_i, tie_j, openings.open_frac)
        gap_cells = self.gap_cells(solid, tie_i, tie_j, tie_nx, tie_ny)
        cell_twin, twin_node, twin = self.corner_twins(grid, j_base, solid)
        # the soil law's state variables ride with the material, as ξ and z0 do
        initial_state = self.law.initial_state()
        q = np.concatenate([q, np.broadcast_to(initial_state[:, None, None], (len(initial_state), nx, ny))])
        vol = K.cell_volumes(x, y, self.axisym)

        # the model carries a share of the body: the half-section per metre of the out-of-plane
        # length (L for the cross-section, B for the longitudinal view); axisymmetric per radian
        if self.axisym:
            scale = 2.0 * math.pi
        else:
            scale = (2.0 if cfg.economies.symmetry else 1.0) * (
                body_cfg.width_m if self.longitudinal else body_cfg.contact_length_m)
        drop = landing.kind == "drop"
        par = stepper_parameters(
            dt=dt, density=rho, elastic=elastic, h=self.h, gravity=grav, su0=soil.su0_pa, ks=soil.ks_pa_per_m,
            hourglass=cfg.hourglass, bulk_linear=cfg.bulk_viscosity_linear,
            bulk_quadratic=cfg.bulk_viscosity_quadratic, stress_cutoff=cfg.stress_cutoff,
            body_mass=landing.inertia_per_track_kg / scale, body_weight=landing.weight_per_track_n / scale,
            push_velocity=landing.velocity_m_s, remap_courant=cfg.remap_courant,
        )
        ipar = stepper_flags(
            axisym=self.axisym, advection_order=cfg.advection_order, drop=drop, bottom_inflow=True,
            remap=cfg.remap, law_active=self.law.active or not cfg.economies.skip_inactive_law,
            skip_void=cfg.economies.skip_void, separate=cfg.contact_separation,
            exact_tresca=cfg.yield_surface == "tresca" or (cfg.yield_surface == "auto" and self.axisym),
        )
        law_fn, law_params, law_evolve = self.law.compiled(), self.law.packed(), self.law.compiled_evolve()

        vx = np.zeros((nx + 1, ny + 1))
        vy = np.zeros((nx + 1, ny + 1))
        mass = np.zeros_like(vx)
        K.nodal_mass(phi, vol, rho, mass, openings.open_frac, S.CUT_MASS_FILL)
        K.twin_masses(phi, vol, rho, mass, cell_twin, twin)
        body = np.zeros(S.N_BODY)
        v0 = -landing.velocity_m_s
        if drop:  # touchdown: the body and the soil nodes it meets share momentum
            tied_mass = float((mass[tie_i, tie_j] * np.where(tie_full, 1.0, tie_ny**2)).sum()
                              + (twin[:, K.TW_M] * twin[:, K.TW_NY] ** 2).sum())
            v0 = par[S.P_BODY_M] * v0 / (par[S.P_BODY_M] + tied_mass)
        touchdown_loss = 0.0
        if drop:
            body_m = par[S.P_BODY_M]
            touchdown_loss = 0.5 * body_m * landing.velocity_m_s**2 - 0.5 * (body_m + tied_mass) * v0**2
        body[S.B_VEL] = v0
        vy[tie_i[tie_full], tie_j[tie_full]] = v0
        vx[tie_i[~tie_full], tie_j[~tie_full]] = v0 * tie_ny[~tie_full] * tie_nx[~tie_full]
        vy[tie_i[~tie_full], tie_j[~tie_full]] = v0 * tie_ny[~tie_full] ** 2
        energy = np.zeros(S.N_ENERGY)
        elastic0 = K.elastic_energy(phi, q, vol, G, Kb)
        ghost = np.zeros((q.shape[0], nx))
        ghost[K.NQ_BASE :] = initial_state[:, None]  # soil entering at the base brings the initial state
        ghost_depth0 = np.full(nx, d0 - (y[0] - 0.5 * (y[1] - y[0])))
        work = dict(
            fx=np.zeros_like(vx), fy=np.zeros_like(vx), ux=np.zeros_like(vx), uy=np.zeros_like(vx),
            flux_x=np.zeros((nx + 1, ny)), flux_y=np.zeros((ny + 1, nx)), su_cell=np.zeros((nx, ny)),
        )
        mass0 = float(rho * (phi * vol).sum())

        merge = sliver_pairs(openings)

        def advance(n):
            return S.run_steps(
                n, x, y, vol, phi, q, vx, vy, mass, work["fx"], work["fy"], work["ux"], work["uy"],
                work["flux_x"], work["flux_y"], tie_i, tie_j, tie_full, tie_nx, tie_ny, tie_cap, strength_factor,
                work["su_cell"], solid, openings.aperture_x, openings.aperture_y, openings.open_frac, merge, gap_cells,
                cell_twin, twin_node, twin, ghost, ghost_depth0,
                par, ipar, body, energy, law_fn, law_params, law_evolve,
            )

        # expected duration → steps per history sample
        if drop and self.cone:  # from rest under gravity; without it, at its touchdown speed
            duration = (4.0 * math.sqrt(2.0 * self.travel / grav) if grav > 0
                        else self.travel / max(landing.velocity_m_s, 0.1))
        elif drop:
            duration = energy_estimate(scene).solve().metrics.get("time_to_rest_s", 0.0) or 0.0
            duration = max(duration, self.travel / max(landing.velocity_m_s, 0.1))
        else:
            duration = landing.displacement_m / landing.velocity_m_s
        chunk = max(1, int(duration / dt / cfg.history_samples))
        recorder = None  # field output: snapshots between chunks, only when asked for
        if scene.output.fields and run_dir is not None:
            from dsmv.fields import FieldRecorder

            recorder = FieldRecorder(grid, solid, self.law, soil, axisym=self.axisym, tresca=ipar[S.I_TRESCA] == 1,
                                     stress_cutoff=cfg.stress_cutoff, frames=scene.output.field_frames,
                                     spacing_s=chunk * dt)
            recorder.sample(0.0, 0.0, phi, q, vx, vy)

        t_start = time.perf_counter()
        done, code = advance(1)  # first call compiles (or loads the cache)
        compile_s = time.perf_counter() - t_start
        steps = done
        history = {"time_s": [0.0], "sinkage_m": [0.0], "velocity_m_s": [-v0], "force_n": [0.0]}
        show = cfg.progress == "on" or (cfg.progress == "auto" and sys.stderr.isatty() and not in_sweep())
        status, message = "ok", ""
        rest_time_s = None
        modes_sq = np.zeros(2)  # Σ over samples of the hourglass and linear velocity modes (m²/s²)
        t_run = time.perf_counter()
        last_print = t_run
        speed_limit = 50.0 * (abs(v0) + landing.velocity_m_s + math.sqrt(max(grav, 0.0) * B) + 1.0)
        while True:
            body[S.B_FSUM] = 0.0
            body[S.B_FCOUNT] = 0.0
            if code == S.RUNNING:
                done, code = advance(min(chunk, cfg.max_steps - steps))
                steps += done
            sinkage = -body[S.B_OFFSET]
            force = scale * body[S.B_FSUM] / max(body[S.B_FCOUNT], 1.0)
            history["time_s"].append(body[S.B_TIME])
            history["sinkage_m"].append(sinkage)
            history["velocity_m_s"].append(-body[S.B_VEL])
            history["force_n"].append(force)
            hourglass_sq, linear_sq = K.hourglass_modes(phi, vx, vy, ZIGZAG_FULL_CELL, cell_twin, twin)
            modes_sq += np.array([hourglass_sq, linear_sq])
            if recorder is not None:
                recorder.sample(body[S.B_TIME], sinkage, phi, q, vx, vy)
            if code == S.NOT_FINITE or not (np.isfinite(vy).all() and np.isfinite(q).all() and np.isfinite(twin).all()):
                status, message = "unstable", (
                    f"a non-finite value appeared at t = {body[S.B_TIME]:.4g} s; lower solver.cfl "
                    f"(now {cfg.cfl}) or raise solver.bulk_viscosity_linear")
                break
            kinetic = soil_kinetic_energy(mass, vx, vy, twin)
            delivered = (0.5 * par[S.P_BODY_M] * landing.velocity_m_s**2 if drop else 0.0) + abs(
                energy[S.E_BODY_GRAV]) + abs(energy[S.E_SOIL_GRAV]) + abs(energy[S.E_PUSH])
            if kinetic > 10.0 * delivered + 1e-9:
                status, message = "unstable", (
                    f"the soil's kinetic energy ({kinetic * scale:.3g} J) ran away past ten times the energy "
                    f"put in at t = {body[S.B_TIME]:.4g} s; lower solver.cfl (now {cfg.cfl})")
                break
            vmax = float(max(np.sqrt(vx * vx + vy * vy).max(),
                             np.hypot(twin[:, K.TW_VX], twin[:, K.TW_VY]).max(initial=0.0)))
            if vmax > speed_limit:
                status, message = "unstable", (
                    f"soil speed {vmax:.3g} m/s exceeds the guard {speed_limit:.3g} m/s at t = {body[S.B_TIME]:.4g} s; "
                    f"lower solver.cfl (now {cfg.cfl}) or raise solver.hourglass (now {cfg.hourglass})")
                break
            if phi[:, -1].max() > 1e-6:  # soil in the top row of cells
                status, message = "out_of_domain", (
                    f"soil reached the top of the domain at sinkage {sinkage:.4g} m; "
                    f"raise solver.initial_travel_m (sized for {self.travel:.3g} m)")
                break
            if drop and code == S.RUNNING and abs(body[S.B_VEL]) < 1e-12 and par[S.P_BODY_W] == 0.0:
                message = "the body neither moves nor weighs anything: it stays at rest"
                break
            if drop and code == S.AT_REST and rest_time_s is None:
                rest_time_s = body[S.B_TIME]
                message = f"came to rest at {body[S.B_MAXDISP]:.4g} m after {rest_time_s:.4g} s"
            if rest_time_s is not None:
                if cfg.economies.stop_at_rest or body[S.B_TIME] >= 2.0 * rest_time_s:
                    break
                code = S.RUNNING  # economy off: run on past rest (the max sinkage is already known)
            # a body must slow down within one width of its own. A cone dropped from rest
            # accelerates for a while, and so does a body on a weak mudline over soil that
            # strengthens with depth (ks > 0: su0 = 500 Pa under the default track speeds up
            # over its first 0.6 m, then rests at 1.2 m); the soil can still stop them, so
            # they get the travel the domain was sized for
            width = max(body_cfg.width_m, self.travel) if self.cone or soil.ks_pa_per_m > 0 else body_cfg.width_m
            if drop and sinkage > width and self._not_decelerating(history, width):
                status, message = "bearing_failure", (
                    f"the body kept sinking without slowing down over {width:g} m "
                    f"({'one width B' if width == body_cfg.width_m else 'the travel the domain was sized for'})")
                break
            if not drop and sinkage >= landing.displacement_m - 1e-12:
                message = f"pushed to {sinkage:.4g} m"
                break
            if drop and sinkage > self.travel:
                status, message = "out_of_domain", (
                    f"the body passed the travel the domain was sized for ({self.travel:.3g} m)")
                break
            if steps >= cfg.max_steps:
                status, message = "unstable", f"no result after solver.max_steps = {cfg.max_steps} steps"
                break
            if show and time.perf_counter() - last_print > 1.0:
                last_print = time.perf_counter()
                rate = (steps - 1) / (last_print - t_run)
                print(f"\r  t = {body[S.B_TIME]:.4f} s  sinkage {sinkage:.4f} m  "
                      f"velocity {-body[S.B_VEL]:.3f} m/s  {rate:,.0f} steps/s", end="", file=sys.stderr)
        wall_s = time.perf_counter() - t_run
        if recorder is not None:
            recorder.sample(body[S.B_TIME], -body[S.B_OFFSET], phi, q, vx, vy, final=True)
            recorder.write(run_dir)
        if show:
            print(file=sys.stderr)

        audit = self._energy_audit(energy, elastic0, touchdown_loss, phi, q, vol, G, Kb, mass, vx, vy, twin, body,
                                   par, drop, scale)
        mass_now = float(rho * (phi * vol).sum())
        mass_expected = mass0 + rho * body[S.B_INFLOW]
        history_arrays = {k: np.asarray(v) for k, v in history.items()}
        metrics = {
            "mass_error": abs(mass_now - mass_expected) / mass0,
            "phi_max": float(phi.max()),
            "phi_min": float(phi.min()),
            "compile_s": compile_s,
            "wall_s": wall_s,
            "steps": float(steps),
            "time_step_s": dt,
            "cells": float(nx * ny),
            "cell_updates_per_s": nx * ny * max(steps - 1, 1) / max(wall_s, 1e-9),
            "core_cell_size_m": self.h,
            # the zig-zag in the velocity field: hourglass against linear modes, over the run
            # (a run gone unstable may have summed infinities: NaN, which its report leaves out)
            "hourglass_mode_ratio": (math.sqrt(modes_sq[0] / modes_sq[1]) if modes_sq[1] > 0 else 0.0)
            if np.isfinite(modes_sq).all() else math.nan,
        }
        units = {"mass_error": "-", "phi_max": "-", "phi_min": "-", "compile_s": "s", "wall_s": "s", "steps": "-",
                 "time_step_s": "s", "cells": "-", "cell_updates_per_s": "1/s", "core_cell_size_m": "m",
                 "hourglass_mode_ratio": "-"}
        metrics |= audit
        units |= {k: ("-" if k == "energy_error" else "J") for k in audit}
        if status in ("ok", "out_of_domain", "bearing_failure"):
            metrics["max_sinkage_m"] = float(body[S.B_MAXDISP])
            units["max_sinkage_m"] = "m"
        if drop and status == "ok" and self.cone and grav > 0:  # Hansbo's factor implied by the penetration
            metrics["hansbo_k"] = soil.su0_pa * metrics["max_sinkage_m"] ** 2 / (landing.mass_kg * grav)
            units["hansbo_k"] = "-"
        if drop and status == "ok":
            metrics["sinkage_over_width"] = metrics["max_sinkage_m"] / B
            metrics["time_to_rest_s"] = float(body[S.B_TIME] if rest_time_s is None else rest_time_s)
            units |= {"sinkage_over_width": "-", "time_to_rest_s": "s"}
        if not drop:
            self._push_metrics(history_arrays, metrics, units)
        if status == "ok" and metrics["mass_error"] > 1e-6:
            status, message = "unstable", f"soil mass drifted by {metrics['mass_error']:.2e} (relative)"
        if status == "ok" and metrics["energy_error"] > ENERGY_ERROR_LIMIT:
            status, message = "unstable", (
                f"the energy audit is off by {metrics['energy_error']:.1%} (limit {ENERGY_ERROR_LIMIT:.0%}): "
                f"lower solver.cfl (now {cfg.cfl}) or raise solver.hourglass / solver.bulk_viscosity_linear")
        if status != "ok":  # a run that went wrong reports what stayed finite, never a NaN
            metrics = {k: v for k, v in metrics.items() if math.isfinite(v)}
            finite = np.all([np.isfinite(v) for v in history_arrays.values()], axis=0)
            history_arrays = {k: v[finite] for k, v in history_arrays.items()}
        return SolveResult(status, message, metrics, units, history_arrays)

    @staticmethod
    def _energy_audit(energy, elastic0, touchdown_loss, phi, q, vol, G, Kb, mass, vx, vy, twin, body, par, drop,
                      scale):
        """Every energy term on its own (J per track), and the relative mismatch of the balance.

        In: the body's kinetic energy at touchdown, the work of gravity on body and soil, the work
        of the push. Out: kinetic (soil, body) and elastic energy now, plastic, hourglass and
        bulk-viscosity dissipation, slip at a limited-adhesion contact, the elastic energy a gap cell
        lets go (:meth:`gap_cells`), the touchdown impact, and
        what the remap changed (a remap that smooths stress or velocity loses energy; soil
        entering at the base brings its elastic energy). ``energy_error`` = |in − out| /
        (energy delivered to the soil).
        """
        from dsmv.cel import kernels as K
        from dsmv.cel import stepper as S

        body_m = par[S.P_BODY_M]
        touchdown_speed = par[S.P_PUSH_V]  # the landing velocity, in both modes
        kinetic_in = 0.5 * body_m * touchdown_speed**2 if drop else 0.0
        terms = {
            "energy_in_kinetic_j": kinetic_in,
            "energy_in_gravity_body_j": energy[S.E_BODY_GRAV],
            "energy_in_gravity_soil_j": energy[S.E_SOIL_GRAV],
            "energy_in_push_j": energy[S.E_PUSH],
            "energy_kinetic_soil_j": soil_kinetic_energy(mass, vx, vy, twin),
            "energy_kinetic_body_j": 0.5 * body_m * body[S.B_VEL] ** 2 if drop else 0.0,
            "energy_elastic_change_j": K.elastic_energy(phi, q, vol, G, Kb) - elastic0,
            "energy_plastic_j": energy[S.E_PLASTIC],
            "energy_hourglass_j": energy[S.E_HOURGLASS],
            "energy_bulk_viscosity_j": energy[S.E_BULK],
            "energy_touchdown_loss_j": touchdown_loss,
            "energy_remap_loss_j": -(energy[S.E_REMAP_ELASTIC] + energy[S.E_REMAP_KINETIC]),
            "energy_contact_slip_j": energy[S.E_FRICTION],
            "energy_gap_release_j": energy[S.E_GAP_RELEASE],
        }
        inputs = sum(v for k, v in terms.items() if k.startswith("energy_in_"))
        outputs = sum(v for k, v in terms.items() if not k.startswith("energy_in_"))
        delivered = sum(abs(v) for k, v in terms.items() if k.startswith("energy_in_"))
        audit = {k: v * scale for k, v in terms.items()}
        audit["energy_error"] = abs(inputs - outputs) / max(delivered, 1e-300)
        return audit

    def _not_decelerating(self, history, width) -> bool:
        """True when the downward speed now is at least what it was one body width ago."""
        s = np.asarray(history["sinkage_m"])
        v = np.asarray(history["velocity_m_s"])
        earlier = np.interp(s[-1] - width, s, v)
        return v[-1] >= earlier

    def _push_metrics(self, history, metrics, units) -> None:
        """Bearing factor q/su0 along a push: samples at fixed s/B and the curve's roughness."""
        scene = self.scene
        B = scene.geometry.width_m
        nc = history["force_n"] / (self.contact_area_m2() * scene.soil.su0_pa)
        s_over_b = history["sinkage_m"] / B
        for name, at in NC_SAMPLES.items():
            window = np.abs(s_over_b - at) <= NC_WINDOW
            if window.any():
                metrics[name] = float(nc[window].mean())
                units[name] = "-"
        beyond = s_over_b >= NC_SAMPLES["nc_at_0p02B"]
        if beyond.sum() > 2:
            metrics["nc_roughness"] = float(np.abs(np.diff(nc[beyond])).max())
            units["nc_roughness"] = "-"
        if self.circular:  # a T-bar (or ball): the deep factor is the mean over the last diameter pushed
            last = history["sinkage_m"] >= history["sinkage_m"][-1] - B
            metrics["nc_deep"] = float(nc[last & (history["sinkage_m"] > 0)].mean())
            units["nc_deep"] = "-"
        metrics["max_force_n"] = float(history["force_n"].max())
        units["max_force_n"] = "N"
