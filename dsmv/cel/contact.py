"""Contact as data: one rule table decides how a scene's body holds the soil, built once.

:class:`ContactRules` reads the scene (body, roughness α, mode, separation) and decides which
contact the body gets; ``check_scene`` refuses what it cannot do and the set-up
(:func:`build_contact`) builds the tie table from the same rules:

- **flat faces** (a strip, a track's cross-section, a circular plate in axisymmetry): the base and walls tie their nodes along the
  face normal only; along the face the soil is held by adhesion α·su (rough is α = 1). The nodes
  at the body's corners are split: the soil cells beyond the base see their own copy of the
  corner node (:func:`split_corners`). Contact separation lets a face go of soil that pulls away.
- **staircase** bodies (a T-bar's cylinder, a cone, the side view of a track): a curved face is a
  staircase of cells, tied fully; a smooth face or limited adhesion lives in the *interface
  layer*, the soil cells touching the body, whose strength is α·su (the thin-layer interface of
  FE and CEL practice). Soil then slides round the body one layer out, through whole cells, which
  the remap carries. (Ties along the circle's normal let soil slide along the staircase instead,
  which the remap cannot carry past the steps: the soil piled up in front, a void opened behind,
  and a smooth T-bar read 6.6 for 9.20.)
- **cut cells** (a smooth cylinder in plane strain): the cells the circle cuts stay partly open,
  every node inside the circle moves with it, and the nodes of the cut cells slide along its
  normal; slivers merge with a neighbour (:func:`sliver_pairs`).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace

import numpy as np

from dsmv.cel.body import (
    Cone, Cylinder, FlatBody, TrackSideView, Turned, nodes_touching, soil_cells_touching, solid_cells,
)
from dsmv.cel.grid import Grid2D, Openings
from dsmv.cel.kernels.common import CUT_OPEN_FLOOR
from dsmv.cel.layout import Contact, corner_offsets, structured_corners
from dsmv.errors import ConfigError


@dataclass(frozen=True)
class ContactRules:
    """How a scene's body meets the soil: its shape family and the contact each part of it gets."""

    kind: str                # strip | track | tbar | cone
    longitudinal: bool       # a track seen from the side
    alpha: float             # adhesion factor α (rough 1, smooth 0)
    roughness: object        # geometry.roughness as given (rough, smooth or α)
    axisymmetric: bool
    separation: bool         # solver.contact_separation
    turning: bool = False    # a flat-faced body that turns in large deformation: redrawn as a staircase

    @classmethod
    def of(cls, scene, axisymmetric: bool, draws_turns: bool = False, held: tuple[str, ...] = ()) -> "ContactRules":
        """The rules of a scene. ``solver.contact_separation=auto`` lets the soil part from the body in a
        landing (real contact holds no tension) wherever the faces can let go;
        a push (the verification cases) keeps the soil tied unless asked. ``draws_turns``: the solver
        redraws a turning body into the grid, unless the model's symmetry planes hold the turn (``held``)."""
        body, asked = scene.geometry, scene.solver.contact_separation
        rules = cls(body.kind, getattr(body, "view", "cross_section") == "longitudinal", body.adhesion_factor,
                    body.roughness, axisymmetric, asked is True)
        if draws_turns and scene.solver.remap and not axisymmetric and turns_unheld(scene, held):
            rules = replace(rules, turning=True)
        if asked == "auto":
            landing = scene.landing.kind == "drop"
            rules = replace(rules, separation=rules.separable and landing)
        return rules

    @property
    def flat_faced(self) -> bool:
        """A flat base and vertical walls: normal ties with adhesion, split corners. A body that turns
        in large deformation is redrawn as it turns: a staircase (decision 0030)."""
        return self.kind in ("strip", "track", "circular_plate") and not self.longitudinal and not self.turning

    @property
    def circular(self) -> bool:
        return self.kind == "tbar"

    @property
    def cut_cells(self) -> bool:
        return self.circular and self.alpha == 0.0 and not self.axisymmetric

    @property
    def interface_layer(self) -> bool:
        return self.circular and self.alpha < 1.0 and not self.cut_cells

    @property
    def separable(self) -> bool:
        """Faces that may let the soil go: flat ones of any roughness, a smooth cylinder's cut cells, a
        turning flat body's staircase (each node by its nearest face)."""
        return self.flat_faced or self.cut_cells or self.turning

    def refusal(self) -> ConfigError | None:
        """What this contact cannot do, as the error to raise (None: it can)."""
        if self.turning and self.alpha != 1.0:
            return ConfigError("geometry.roughness", self.roughness,
                               "a body that turns with the remap is redrawn as a rough staircase: "
                               "'rough' only (or solver.remap=false: small strain, any roughness)")
        if self.longitudinal and self.alpha != 1.0:
            return ConfigError("geometry.roughness", self.roughness,
                               "the longitudinal view (plates and grousers) models a rough track only")
        if self.alpha not in (0.0, 1.0) and not (self.flat_faced or self.circular):
            return ConfigError("geometry.roughness", self.roughness,
                               "limited adhesion α in (0, 1) needs a flat-faced body (strip, or a track's "
                               "cross-section) or a T-bar (an interface layer of strength α·su); a cone takes "
                               "'rough' (1)")
        if self.kind == "cone" and self.alpha == 0.0:
            return ConfigError("geometry.roughness", self.roughness, "a cone is 'rough' in cel2d for now "
                                                                 "(a smooth staircase cone needs cut cells)")
        if self.separation and not self.separable:
            return ConfigError("solver.contact_separation", True,
                               "separation acts on a flat-faced body (strip, track cross-section) of any "
                               "roughness or a smooth T-bar in plane strain; this body's staircase faces stay "
                               "tied fully")
        return None

    def shape(self, geometry, h: float, angle: float = 0.0, pivot: tuple[float, float] = (0.0, 0.0)):
        """The body's shape (:mod:`dsmv.cel.body`); a turning one turned by ``angle`` (rad) about
        ``pivot`` (its centre of gravity in the grid frame, m)."""
        if self.turning:
            return Turned(FlatBody(0.5 * geometry.width_m, geometry.track_offset_m), angle, pivot)
        if self.kind == "cone":
            return Cone(geometry.apex_angle_deg, geometry.width_m)
        if self.circular:
            return Cylinder(0.5 * geometry.width_m)
        if self.longitudinal:
            return TrackSideView.of(geometry, h)
        return FlatBody(0.5 * geometry.width_m, geometry.track_offset_m)


def turns_unheld(scene, held: tuple[str, ...]) -> bool:
    """Whether a scene's body may turn (free to, or given a rate) or touches down turned (its attitude)
    about an axis the model's symmetry planes (``held``) do not hold."""
    landing = scene.landing
    return any((n in landing.freedoms or landing.given_velocity(n) != 0.0 or tilt != 0.0) and n not in held
               for n, tilt in zip(("rx", "ry", "rz"), landing.attitude_rad))


@dataclass
class BodyContact:
    """What the set-up builds from the rules: the body's cells and openings, the contact table,
    the corner table with its split nodes, and the cell fields contact sets (strength factor, gap
    cells)."""

    solid: np.ndarray
    openings: Openings
    contact: Contact
    corner: np.ndarray
    n_nodes: int
    strength_factor: np.ndarray
    gap: np.ndarray


def _ties(rules: ContactRules, shape, grid: Grid2D, j_base: int, solid: np.ndarray):
    """The tied nodes (i, j) and, per tie: full or normal, the normal into the soil, the adhesion cap.

    A node of a body cell is tied fully (moves with the body) when it is a corner or inside the
    body, or when the body is a staircase. On a flat face (base or wall) only its normal velocity
    is tied, n pointing into the soil; along the face the soil is held by adhesion α·su: such a
    node carries ``cap`` = α × its share of the face (m per unit thickness, m²/rad axisymmetric).
    (A rough face that tied its nodes fully would hold them with any shear, more than su: at B/40
    that read the pushed strip's factor 1.3 % above the α → 1 limit, 5.321 against 5.255 at
    α = 0.999.)"""
    touching = nodes_touching(solid)
    if rules.cut_cells:  # every node inside the circle moves with it
        tie_i, tie_j = np.nonzero(shape.inside(grid.x[:, None], grid.y[None, :]))
    else:
        tie_i, tie_j = np.nonzero(touching)
    # a node is inside when all its cells are solid (on the domain's edges: all of its two)
    cells_around = np.full_like(touching, 4)
    cells_around[0, :] = cells_around[-1, :] = 2
    cells_around[:, 0] = cells_around[:, -1] = 2
    inside = touching[tie_i, tie_j] == cells_around[tie_i, tie_j]
    full = np.ones(len(tie_i), dtype=np.bool_)
    normal = np.zeros((len(tie_i), 2))
    cap = np.zeros(len(tie_i))
    if rules.cut_cells:  # the nodes in the cut cells slide along the circle (tied along its normal)
        xs, ys = grid.x[tie_i], grid.y[tie_j] - shape.radius
        r = np.maximum(np.hypot(xs, ys), 1e-300)
        normal[:, 0], normal[:, 1] = xs / r, ys / r
        full = inside.copy()
        normal[inside] = 0.0  # inside the body: no face, always tied
    elif rules.flat_faced:
        half = shape.half_width
        xs, ys = grid.x[tie_i], grid.y[tie_j]
        centre = np.sign(xs) * shape.centre  # the track each node belongs to (a vehicle's: ±centre)
        off = xs - centre
        on_base = (tie_j == j_base) & (np.abs(off) < half - 1e-12)
        on_side = (tie_j > j_base) & np.isclose(np.abs(off), half) & ~inside
        normal[on_base, 1] = -1.0
        normal[on_side, 0] = np.sign(off[on_side])  # the whole section has a wall on either side
        full = ~(on_base | on_side)
        if rules.alpha > 0.0:  # each node's share of the base (x) or of the wall (y)
            xg, yg = grid.x, grid.y
            left = np.where(tie_i > 0, xs - np.maximum(xg[np.maximum(tie_i - 1, 0)], centre - half), 0.0)
            right = np.minimum(xg[np.minimum(tie_i + 1, grid.nx)], centre + half) - xs
            below = ys - yg[np.maximum(tie_j - 1, 0)]
            above = np.where(tie_j < grid.ny, yg[np.minimum(tie_j + 1, grid.ny)] - ys, 0.0)
            radius = xs if rules.axisymmetric else 1.0
            cap[on_base] = (rules.alpha * 0.5 * (left + right) * radius)[on_base]
            radius = half if rules.axisymmetric else 1.0
            cap[on_side] = (rules.alpha * 0.5 * (below + above) * radius)[on_side]
    return tie_i, tie_j, full, normal, cap


def split_corners(rules: ContactRules, shape, grid: Grid2D, j_base: int, solid: np.ndarray):
    """The split nodes of a flat-faced body's corners, where its base meets a wall.

    Prandtl's fan is centred there: the soil under the base moves with the body, the soil beside it
    rides the fan, and the velocity there has every direction of the fan between. One shared node
    forces a single velocity, so the cell beside the corner is dragged along with the base and
    smears the fan over itself: the strip then reads as if about a third of a cell wider (+3.6 % at
    B/20 in small strain). The soil cells beyond the base (beside the wall) therefore see their own
    copy of the corner node; the cells under the base keep the body's node. The copy is a node of
    the wall: tied along its normal, held along it by the wall's adhesion α·su over the lower half
    of the wall face above the corner (gripped by the soil that cell holds: none while the strip
    sits on the surface, where at the fan's centre the soil slips up past the corner, at 3V/2
    relative to it in Prandtl's solution), and, with contact separation, free to leave the wall.

    Returns rows (corner node i, j, local corner of each beyond-base cell that uses the copy as
    {cell: local}, the wall's normal x, the grip cell, the adhesion cap)."""
    splits = []
    if not rules.flat_faced:
        return splits
    half = shape.half_width
    wall_share = 0.5 * (grid.y[j_base + 1] - grid.y[j_base]) if j_base < grid.ny else 0.0
    radius = half if rules.axisymmetric else 1.0
    for edge, side in shape.edges():
        (i_corner,) = np.nonzero(np.isclose(grid.x, edge))
        if len(i_corner) == 0:
            continue
        i_corner = int(i_corner[0])
        # the cells beyond the base touch the corner with their left (right side) or right nodes
        i_cell, below, above = (i_corner, 3, 0) if side > 0 else (i_corner - 1, 2, 1)
        if not 0 <= i_cell < grid.nx:
            continue
        users = {(i_cell, j_cell): local for j_cell, local in ((j_base - 1, below), (j_base, above))
                 if 0 <= j_cell < grid.ny and not solid[i_cell, j_cell]}
        splits.append((i_corner, j_base, users, side, (i_cell, j_base), rules.alpha * wall_share * radius))
    return splits


def soil_cells_around(solid: np.ndarray, node: tuple) -> list[tuple]:
    """The cells outside the body (``solid`` False) that have ``node`` as a corner, any number of axes, in
    index order."""
    return [cell for cell in itertools.product(*((c - 1, c) for c in node))
            if all(0 <= c < n for c, n in zip(cell, solid.shape)) and not solid[cell]]


def grip_cells(solid, ties, splits=()):
    """The cells whose strength grips each tie (``ties``: their node indices per axis): a face node's
    soil cells; a split node's cell above the corner. CSR rows (start per tie, cells)."""
    grips = [soil_cells_around(solid, node) for node in zip(*ties)] + [[grip] for *_, grip, _cap in splits]
    return (np.concatenate([[0], np.cumsum([len(g) for g in grips])]).astype(np.int64),
            np.array([c for g in grips for c in g], dtype=np.int64).reshape(-1, solid.ndim))


def sliver_pairs(openings: Openings) -> np.ndarray:
    """Each sliver of a cut body (a cell open to less than ``CUT_OPEN_FLOOR``) paired with its most
    open neighbour across an open face: rows (i, j, i_neighbour, j_neighbour).

    A sliver alone cannot hold its soil: its pressure sees its volume change over the floored open
    fraction, 6 % of it for a cell open to 3 %, so the remap drained it and then its neighbours (a
    void behind a smooth T-bar). A pair changes volume as one, and shares one fill and one mean
    stress after each remap."""
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


def fixed_velocities(node_shape: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    """The boundary conditions as data: the symmetry axis and the far sides are rollers (no normal
    velocity), the base is fixed. Rows (flat node, axis), in the order they are applied."""
    index = np.arange(int(np.prod(node_shape))).reshape(node_shape)
    dim = len(node_shape)
    nodes, axes = [], []
    for a in range(dim - 1):  # rollers: the two planes normal to each horizontal axis
        for end in (0, -1):
            side = np.take(index, [end], axis=a).ravel()
            nodes.append(side), axes.append(np.full(side.size, a))
    base = np.take(index, [0], axis=dim - 1).ravel()
    for n in base:  # the base: every component, node by node
        nodes.append(np.full(dim, n)), axes.append(np.arange(dim))
    order = np.concatenate(axes)
    return np.concatenate(nodes).astype(np.int64), order.astype(np.int64)


def tie_arms(axes, node: np.ndarray, split_node: np.ndarray, split_parent: np.ndarray, base_m: float) -> np.ndarray:
    """Each tied node's position (ties, d) relative to the body's reference point: the middle of its
    base, on the model's axis (x = 0, and y = 0 in 3D) at height ``base_m`` (m). A split node sits
    where the node it copies does."""
    shape = tuple(len(a) for a in axes)
    parent = np.arange(int(np.prod(shape)) + len(split_node))
    parent[split_node] = split_parent
    index = np.unravel_index(parent[node], shape)
    arm = np.stack([a[i] for a, i in zip(axes, index)], axis=1)
    arm[:, -1] -= base_m
    return np.ascontiguousarray(arm)


def build_contact(rules: ContactRules, shape, grid: Grid2D, j_base: int, trapped_m: float = 0.0) -> BodyContact:
    """The body's cells, openings and contact table on a grid, from the rules; the ties' share of the face
    within ``trapped_m`` of the base holds (:func:`trapped_shares`)."""
    if rules.turning:
        return build_turned_contact(shape, grid, grid.y[j_base], trapped_m)
    solid = solid_cells(shape, grid)
    openings = Openings.of_circle(grid, shape.radius, shape.radius) if rules.cut_cells else Openings.of_cells(solid)
    tie_i, tie_j, full, normal, cap = _ties(rules, shape, grid, j_base, solid)
    splits = split_corners(rules, shape, grid, j_base, solid)
    n_grid = (grid.nx + 1) * (grid.ny + 1)
    corner = structured_corners((grid.nx, grid.ny))
    for k, (_, _, users, *_rest) in enumerate(splits):
        for (ci, cj), local in users.items():
            corner[ci, cj, local] = n_grid + k
    ny1 = grid.ny + 1
    split_node = n_grid + np.arange(len(splits), dtype=np.int64)
    split_parent = np.array([i * ny1 + j for i, j, *_ in splits], dtype=np.int64)
    grip_start, grip_cell = grip_cells(solid, (tie_i, tie_j), splits)
    split_normal = np.zeros((len(splits), 2))
    split_normal[:, 0] = [side for *_, side, _grip, _cap in splits]
    # the ties: the grid's, then the split nodes' (tied along the wall's normal, with its adhesion)
    fixed_node, fixed_axis = fixed_velocities((grid.nx + 1, grid.ny + 1))
    node = np.concatenate([tie_i * ny1 + tie_j, split_node]).astype(np.int64)
    contact = Contact(
        node=node,
        full=np.concatenate([full, np.zeros(len(splits), dtype=np.bool_)]),
        normal=np.ascontiguousarray(np.concatenate([normal, split_normal])),
        cap=np.concatenate([cap, [c for *_, c in splits]]).astype(float),
        grip_start=grip_start, grip_cell=grip_cell,
        holding=np.ones(len(tie_i) + len(splits)),
        split_node=split_node, split_parent=split_parent,
        fixed_node=fixed_node, fixed_axis=fixed_axis,
        merge=sliver_pairs(openings),
        arm=tie_arms((grid.x, grid.y), node, split_node, split_parent, grid.y[j_base]),
        bond=trapped_shares(np.concatenate([grid.y[tie_j] - grid.y[j_base], np.zeros(len(splits))]), trapped_m, grid.h),
    )
    factor = np.ones(solid.shape)
    if rules.cut_cells:
        factor[(openings.open_frac < 1.0) & (openings.open_frac > 0.0)] = 0.0
    elif rules.interface_layer:
        factor[soil_cells_touching(solid, tie_i, tie_j)] = rules.alpha
    return BodyContact(solid, openings, contact, corner, n_grid + len(splits), factor,
                       gap_cells(rules, solid, tie_i, tie_j, normal))


def build_turned_contact(shape, grid, base_m: float, trapped_m: float = 0.0) -> BodyContact:
    """A body that turns in large deformation, drawn at its pose now as a rough staircase (decision
    0030), on a grid of any number of axes: the cells ``shape`` holds (its turned shape's), every node
    touching them tied fully while it holds, and with contact separation let go along the normal of
    its nearest face (``shape.face_normals``; none at a corner or deep inside), but for the share of
    its face within ``trapped_m`` of its base in its own axes (:func:`trapped_shares`); no split nodes, no
    adhesion caps. ``base_m``: the height of the body's reference point (the middle of its base)."""
    solid = solid_cells(shape, grid)
    dim = solid.ndim
    node_shape = tuple(n + 1 for n in solid.shape)
    ties = np.nonzero(nodes_touching(solid))
    node = np.ravel_multi_index(ties, node_shape).astype(np.int64)
    grip_start, grip_cell = grip_cells(solid, ties)
    fixed_node, fixed_axis = fixed_velocities(node_shape)
    none = np.zeros(0, dtype=np.int64)
    contact = Contact(
        node=node,
        full=np.ones(len(node), dtype=np.bool_),
        normal=np.ascontiguousarray(shape.face_normals(*(a[i] for a, i in zip(grid.axes, ties)), grid.h)),
        cap=np.zeros(len(node)),
        grip_start=grip_start, grip_cell=grip_cell,
        holding=np.ones(len(node)),
        split_node=none, split_parent=none, fixed_node=fixed_node, fixed_axis=fixed_axis,
        merge=np.zeros((0, 2 * dim), dtype=np.int64),
        arm=tie_arms(grid.axes, node, none, none, base_m),
        bond=trapped_shares(shape.heights(*(a[i] for a, i in zip(grid.axes, ties))), trapped_m, grid.h),
    )
    openings = Openings.of_cells(solid) if dim == 2 else Openings(1.0 - solid, np.zeros(0), np.zeros(0))
    return BodyContact(solid, openings, contact, structured_corners(solid.shape), int(np.prod(node_shape)),
                       np.ones(solid.shape), np.zeros(solid.shape, dtype=bool))


def trapped_shares(heights: np.ndarray, trapped_m: float, h: float) -> np.ndarray:
    """How much of each tie's share of the body's face the soil a track's grousers trap covers
    (``trapped_m``, their height, m; 0: none), from its node's height up the body's own axis
    (``heights``, m): a node on the wall at height z stands for the face from z − h/2 to z + h/2, so its
    share is (trapped_m − z)/h + ½ clipped to [0, 1]; a node on the base's level or below, 1. That soil
    meets the soil beside and below it as soil, which does not part in undrained clay (suction holds
    it): contact separation leaves this share of a tie holding, as it lets go of the steel above
    (decision 0042). The held wall then measures ``trapped_m`` on any cells up to twice it (coarser, the base's
    half cell holds whole), where whole nodes held a wall that stepped with the cell."""
    heights = np.asarray(heights, dtype=float)
    if trapped_m <= 0.0:
        return np.zeros(len(heights))
    share = np.clip((trapped_m - heights) / h + 0.5, 0.0, 1.0)
    return np.where(heights <= 1e-9 * h, 1.0, share)


def gap_cells(rules: ContactRules, solid, tie_i, tie_j, normal) -> np.ndarray:
    """The soil cells beside a face the soil may leave (nx, ny), with contact separation: they carry
    stress only while full (:func:`dsmv.cel.kernels.elements2d.update_stress`). A pushed strip leaves a
    wedge-shaped gap beside its wall, a third of a cell wide at 0.05 B and B/20; spread across a
    partly full cell, the sliver of soil beside it would bridge it. The rule cannot tell a gap
    from a free surface or a smeared fill: a wall cell under 95 % full, at the corner early in a
    push too, carries nothing (an O(h) effect), and its node's adhesive grip (α > 0) goes with its
    strength. Flat faces only: a T-bar's cut cells keep their stress."""
    if not (rules.separation and rules.flat_faced):
        return np.zeros(solid.shape, dtype=bool)
    on_face = (normal != 0.0).any(axis=1)
    return soil_cells_touching(solid, tie_i[on_face], tie_j[on_face])


def wall_share(solid, i, j, k, dx, dy, dz) -> float:
    """Node (i, j, k)'s share of a body's vertical walls (m²): a quarter of each wall face (between a
    body cell and a soil cell, in plan) that it is a corner of."""
    nx, ny, nz = solid.shape
    share = 0.0
    for ck in (k - 1, k):
        if not 0 <= ck < nz:
            continue
        for cj in (j - 1, j):  # faces normal to x, between columns i - 1 and i
            if 0 <= cj < ny and 0 < i < nx and solid[i - 1, cj, ck] != solid[i, cj, ck]:
                share += dy[cj] * dz[ck] / 4
        for ci in (i - 1, i):  # faces normal to y
            if 0 <= ci < nx and 0 < j < ny and solid[ci, j - 1, ck] != solid[ci, j, ck]:
                share += dx[ci] * dz[ck] / 4
    return share


def flat_share(solid, i, j, k, dx, dy) -> float:
    """Node (i, j, k)'s share of a body's horizontal faces (m²): a quarter of each face between a
    body cell and a soil cell, one above the other, that it is a corner of."""
    nx, ny, nz = solid.shape
    share = 0.0
    if 0 < k < nz:
        for ci in (i - 1, i):
            for cj in (j - 1, j):
                if 0 <= ci < nx and 0 <= cj < ny and solid[ci, cj, k - 1] != solid[ci, cj, k]:
                    share += dx[ci] * dy[cj] / 4
    return share


def build_plate_contact(shape, grid, k_base: int, alpha: float, wall_area: float = 1.0,
                        staircase: bool = False, trapped_m: float = 0.0) -> BodyContact:
    """The contact of a flat-based body on a 3D grid (a plate, a strip slab), from the same ideas as
    the flat faces of 2D (:func:`build_contact`):

    - the base's nodes inside its footprint are tied along the base's normal and held along it by
      the capped adhesion α·su over their share of the base (rough is α = 1, as in 2D);
    - the nodes on the footprint's edge are tied wholly for the cells under the base, and split:
      the soil cells beyond the edge (below the base and beside the wall's first layer) see their
      own copy (:func:`split_corners`' idea, along a line of nodes), tied along the wall's normal
      in plan and held along it by the wall's adhesion over the lower half of the wall faces beside
      it, which with contact separation lets go of soil that pulls away. At a corner of the
      footprint the copy's normal is the bisector; on a symmetry plane it lies in that plane, and
      the copy keeps its parent's rollers;
    - the wall nodes on one flat face (a plate's side, a step of a circle's staircase) are tied
      along the face's normal with the adhesion α·su over their share of the wall, as 2D's walls;
      with ``staircase`` (a curved wall drawn in cells) so are the nodes on the steps' vertical
      edges, along the bisector of the two faces: the staircase stands for a smooth wall, and a
      full tie there held the soil as a rough corner, whatever α (the pushed circle read 1.4 %
      above the axisymmetric plate at 0.1 B, 0.9 % with the edges tied along the bisector);
      a face that looks down above the base (a track's plates between its grousers) holds its
      nodes along its normal as the base does, and a curved body's steps seen from below (a
      sprocket's arc) hold theirs along the bisector of their faces;
      the body's other nodes move with it.

    The share of the ties' face within ``trapped_m`` of the base (a track's grousers' envelope: the soil
    they trap) holds whatever the soil does (:func:`trapped_shares`).

    ``shape`` is in the grid frame (x = y = 0 on the symmetry planes, z = 0 at the base);
    ``wall_area`` scales the walls' adhesion to the body's true wall: the faces of a circle's
    staircase add up to 4/π of the circle's perimeter, so a circle passes π/4."""
    solid = solid_cells(shape, grid)
    nx, ny, nz = solid.shape
    node_shape = (nx + 1, ny + 1, nz + 1)
    n_grid = int(np.prod(node_shape))
    footprint = solid[:, :, k_base] if k_base < nz else np.zeros((nx, ny), dtype=bool)
    touching = nodes_touching(solid)
    tie_i, tie_j, tie_k = np.nonzero(touching)
    full = np.ones(len(tie_i), dtype=np.bool_)
    normal = np.zeros((len(tie_i), 3))
    corner = structured_corners(solid.shape)
    offsets = [tuple(o) for o in corner_offsets(3)]
    cap = np.zeros(len(tie_i))
    dx, dy, dz = (np.diff(a) for a in grid.axes)
    grips = [[] for _ in tie_i]

    for t in np.nonzero(tie_k > k_base)[0]:  # a wall holds its nodes along its normal, where it has one
        i, j, k = tie_i[t], tie_j[t], tie_k[t]
        soil = soil_cells_around(solid, (i, j, k))
        n_wall = np.array([sum(ci + 0.5 - i for ci, _, _ in soil) * (0 < i < nx),
                           sum(cj + 0.5 - j for _, cj, _ in soil) * (0 < j < ny)])
        n_up = sum(ck + 0.5 - k for _, _, ck in soil)  # soil below (< 0) or above (> 0) the node
        faces = np.count_nonzero(n_wall)
        if n_up == 0.0 and (faces == 1 or (faces == 2 and staircase)):  # on a flat face, or on a step of a curved one
            full[t], normal[t, :2] = False, n_wall / np.linalg.norm(n_wall)
            cap[t] = alpha * wall_area * wall_share(solid, i, j, k, dx, dy, dz)
            grips[t] = soil
        elif n_up != 0.0 and (faces == 0 or (staircase and len(soil) > touching[i, j, k])):
            # a face that looks down above the base (a track's plates between its grousers) as the base;
            # the outer edge of a step of a curved one (a sprocket's arc) along the bisector of its faces
            # (an inner edge, where a grouser meets its plate, holds its node wholly)
            n_face = np.array([*n_wall, n_up])
            full[t], normal[t] = False, n_face / np.linalg.norm(n_face)
            cap[t] = alpha * (wall_area * wall_share(solid, i, j, k, dx, dy, dz) + flat_share(solid, i, j, k, dx, dy))
            grips[t] = soil
    split_node, split_parent, split_normal, split_fixed, split_cap, split_grips = [], [], [], [], [], []
    for t in np.nonzero(tie_k == k_base)[0]:
        i, j = tie_i[t], tie_j[t]
        columns = [(ci, cj) for ci in (i - 1, i) for cj in (j - 1, j) if 0 <= ci < nx and 0 <= cj < ny]
        outside = [(ci, cj) for ci, cj in columns if not footprint[ci, cj]]
        if not outside:  # inside the footprint (or on a symmetry plane through it): its share of the base
            full[t], normal[t, 2] = False, -1.0
            cap[t] = alpha * sum(dx[ci] * dy[cj] / 4 for ci, cj in columns)
            grips[t] = soil_cells_around(solid, (i, j, k_base))
            continue
        # on the footprint's edge: the copy's normal points out of the footprint, in plan
        n_out = np.array([sum(ci + 0.5 - i for ci, _ in outside), sum(cj + 0.5 - j for _, cj in outside), 0.0])
        n_out[0] *= 0 < i < nx  # on a roller plane (symmetry, plane strain) the normal lies in it
        n_out[1] *= 0 < j < ny
        n_out /= max(np.linalg.norm(n_out), 1e-300)
        copy = n_grid + len(split_node)
        for ci, cj in outside:
            for ck in (k_base - 1, k_base):
                if 0 <= ck < nz and not solid[ci, cj, ck]:
                    corner[ci, cj, ck, offsets.index((i - ci, j - cj, k_base - ck))] = copy
        parent = np.ravel_multi_index((i, j, k_base), node_shape)
        split_node.append(copy), split_parent.append(parent), split_normal.append(n_out)
        # the copy is a node of the wall: held along it by the adhesion over the lower half of the wall
        # faces beside it (2D's split corner), gripped by the soil that the cells beside them hold
        beside = []
        if k_base < nz:
            for ci, cj in outside:
                mirror_x = 0 <= 2 * i - 1 - ci < nx and footprint[2 * i - 1 - ci, cj]  # beyond the x wall
                mirror_y = 0 <= 2 * j - 1 - cj < ny and footprint[ci, 2 * j - 1 - cj]  # beyond the y wall
                if (mirror_x or mirror_y) and not solid[ci, cj, k_base]:
                    beside.append((ci, cj, k_base, dy[cj] if mirror_x else dx[ci]))
        split_cap.append(alpha * wall_area * sum(width * dz[k_base] / 4 for *_, width in beside))
        split_grips.append([cell for *cell, _ in beside])
        split_fixed += [(copy, a) for a, index in ((0, i), (1, j)) if index in (0, node_shape[a] - 1)]
    fixed_node, fixed_axis = fixed_velocities(node_shape)
    n_split = len(split_node)
    extra = np.array(split_fixed, dtype=np.int64).reshape(-1, 2)
    node = np.concatenate([np.ravel_multi_index((tie_i, tie_j, tie_k), node_shape), split_node]).astype(np.int64)
    split_node, split_parent = np.array(split_node, dtype=np.int64), np.array(split_parent, dtype=np.int64)
    contact = Contact(
        node=node,
        full=np.concatenate([full, np.zeros(n_split, dtype=np.bool_)]),
        normal=np.ascontiguousarray(np.concatenate([normal, np.array(split_normal).reshape(-1, 3)])),
        cap=np.concatenate([cap, split_cap]),
        grip_start=np.concatenate([[0], np.cumsum([len(g) for g in grips + split_grips])]).astype(np.int64),
        grip_cell=np.array([c for g in grips + split_grips for c in g], dtype=np.int64).reshape(-1, 3),
        holding=np.ones(len(tie_i) + n_split),
        split_node=split_node, split_parent=split_parent,
        fixed_node=np.concatenate([fixed_node, extra[:, 0]]), fixed_axis=np.concatenate([fixed_axis, extra[:, 1]]),
        merge=np.zeros((0, 6), dtype=np.int64),
        arm=tie_arms((grid.x, grid.y, grid.z), node, split_node, split_parent, grid.z[k_base]),
        bond=trapped_shares(np.concatenate([grid.z[tie_k] - grid.z[k_base], np.zeros(n_split)]), trapped_m, grid.h),
    )
    return BodyContact(solid, Openings(1.0 - solid, np.zeros(0), np.zeros(0)), contact, corner, n_grid + n_split,
                       np.ones(solid.shape), np.zeros(solid.shape, dtype=bool))
