"""Rigid bodies as shapes, and the one rasteriser that turns a shape into solid cells.

A shape says which points lie inside it (``inside``, on node coordinates: one array per axis,
broadcast); the body's cells are those whose every corner is inside — the staircase inscribed in
the shape. A flat face on a node line is then exact; a curved one is a staircase that never
sticks out (cells chosen by their centre stick out by up to 0.7·h and read a rough T-bar 15 %
high at D/10; inscribed, +1 %). A shape may add cells (``extra_solid``): a track its grousers,
a circular plate the cells whose centre lies in the circle (its curve is in plan, across the push,
where the area pressed is what counts). Shapes are symmetric about x = 0 (but a turned one,
:class:`Turned`) and given in the grid frame, which moves with the body: y = 0 at the body's lowest
point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dsmv.cel.grid import Grid2D
from dsmv.cel.layout import corner_offsets

#: a point within this relative distance of a shape's boundary counts as inside (node lines on it)
ON_BOUNDARY = 1e-12


@dataclass(frozen=True)
class FlatBody:
    """A strip or a track's cross-section: a flat base at y = 0 and vertical walls at |x| = B/2; a
    vehicle's section (``centre`` > 0): two of them, centred at x = ±centre."""

    half_width: float
    centre: float = 0.0

    def inside(self, x, y):
        return (np.abs(np.abs(x) - self.centre) <= self.half_width * (1 + ON_BOUNDARY)) & (y >= -ON_BOUNDARY)

    def edges(self) -> list[tuple[float, float]]:
        """Each wall: (its x, the side its soil is on: +1 beyond a right wall, −1 beyond a left one)."""
        centres = (self.centre, -self.centre) if self.centre > 0 else (0.0,)
        return [(c + side * self.half_width, side) for c in centres for side in (1.0, -1.0)]


@dataclass(frozen=True)
class Turned:
    """A plane-strain shape turned by ``angle`` (rad) about ``pivot`` (x, y in the grid frame, m): the
    body as it turns about its centre of gravity, which the grid follows. The sign is the model's:
    a positive turn about y lowers the +x side (x' = x cos θ + y sin θ, y' = −x sin θ + y cos θ about
    the pivot)."""

    shape: object
    angle: float
    pivot: tuple[float, float]

    @property
    def symmetric(self) -> bool:
        """Whether the turned shape is still its own mirror image about x = 0."""
        return self.angle == 0.0 and self.pivot[0] == 0.0

    def upright(self, x, y):
        """Points (x, y) of the grid frame where the upright body has them: turned back by −θ."""
        c, s = math.cos(self.angle), math.sin(self.angle)
        dx, dy = x - self.pivot[0], y - self.pivot[1]
        return self.pivot[0] + c * dx - s * dy, self.pivot[1] + s * dx + c * dy

    def inside(self, x, y):
        return self.shape.inside(*((x, y) if self.angle == 0.0 else self.upright(x, y)))

    def heights(self, x, y):
        """How high points (x, y) of the grid frame lie above the body's base, up its own axis (m)."""
        return self.upright(x, y)[1]

    def face_normals(self, x, y, h: float) -> np.ndarray:
        """Per point (x, y) beside the turned body (a flat body's base and walls), the normal into the soil of
        the face nearest to it, (points, 2); zero at a corner (within h/2 of both faces, as a flat
        body's corner node holds) and deep inside (over 1.5 h from every face)."""
        xb, yb = self.upright(np.asarray(x, float), np.asarray(y, float))
        body = self.shape
        track = np.sign(xb) * body.centre  # the track each point belongs to (a vehicle's: ±centre)
        side = np.where(xb >= track, 1.0, -1.0)
        to_base, to_wall = np.abs(yb), np.abs(body.half_width - np.abs(xb - track))
        upright = np.zeros((len(xb), 2))
        base = to_base < to_wall
        upright[base, 1] = -1.0
        upright[~base, 0] = side[~base]
        upright[(np.abs(to_base - to_wall) < 0.5 * h) & (np.maximum(to_base, to_wall) < h)] = 0.0
        upright[np.minimum(to_base, to_wall) > 1.5 * h] = 0.0
        # turned with the body: x' = x cos θ + y sin θ, y' = −x sin θ + y cos θ
        c, s = math.cos(self.angle), math.sin(self.angle)
        return np.stack([c * upright[:, 0] + s * upright[:, 1], -s * upright[:, 0] + c * upright[:, 1]], axis=1)

    def extra_solid(self, grid: Grid2D, solid: np.ndarray) -> None:
        """Turned, the body also takes the cells whose centre it holds: a staircase inscribed in a tilted
        base would leave its rising side a cell's row of nearly empty cells from the soil it holds,
        its ties gone; by centres the staircase lies as much outside the face as inside."""
        if self.angle != 0.0:
            solid |= self.inside(0.5 * (grid.x[:-1, None] + grid.x[1:, None]), 0.5 * (grid.y[None, :-1] + grid.y[None, 1:]))


@dataclass(frozen=True)
class Cylinder:
    """A T-bar's cylinder (a ball in axisymmetry): radius R, lowest point at the origin."""

    radius: float

    def inside(self, x, y):
        return x**2 + (y - self.radius) ** 2 <= self.radius**2 * (1 + ON_BOUNDARY)


@dataclass(frozen=True)
class Cone:
    """A fall cone, tip at the origin, with its shaft of diameter ``width`` above."""

    apex_angle_deg: float
    width: float

    def inside(self, x, y):
        radius = np.minimum(y * math.tan(math.radians(0.5 * self.apex_angle_deg)), 0.5 * self.width)
        return (y >= 0.0) & (np.abs(x) <= radius * (1 + ON_BOUNDARY))


@dataclass(frozen=True)
class TrackSideView:
    """A track seen from the side (``geometry.view=longitudinal``): the flat run of plates over
    |x| ≤ L/2 with its underside at the grouser height gh, then a sprocket of radius R, the vehicle
    above; grousers hang below the plates to y = 0 (the base: sinkage is measured at the grouser
    tips), one cell column wide at every plate pitch from the axis (:meth:`extra_solid`). A 0.01 m
    plate or grouser is thinner than any practical cell: the staircase keeps their positions and
    heights, not their thickness. ``grouser`` is snapped to whole core cells (at least one row
    when the track has grousers)."""

    half_length: float
    sprocket_radius: float
    grouser: float
    plate_pitch: float

    @classmethod
    def of(cls, track, h: float) -> "TrackSideView":
        """The track on cells h: with ``grousers=cells`` as above; with ``trapped_soil`` the grousers'
        envelope, whose soil between the grousers moves with the track: a flat base at their tips and
        sprocket arcs of radius R + gh, the same shape on every mesh."""
        half, gh = 0.5 * track.contact_length_m, track.grouser_height_m
        if track.grousers == "trapped_soil":
            return cls(half, track.sprocket_radius_m + gh, 0.0, track.plate_pitch_m)
        grouser = 0.0 if gh == 0 else h * max(1, round(gh / h))
        return cls(half, track.sprocket_radius_m, grouser, track.plate_pitch_m)

    def inside(self, x, y):
        half, radius, gh = self.half_length, self.sprocket_radius, self.grouser
        x = np.abs(x)
        return ((x <= half * (1 + ON_BOUNDARY)) & (y >= gh - ON_BOUNDARY)) | (
            (x - half) ** 2 + (y - gh - radius) ** 2 <= radius**2 * (1 + ON_BOUNDARY)) | (
            (x <= half + radius) & (y >= gh + radius))

    def grouser_cells(self, along: np.ndarray, up: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Which cells, along the track and up, the grousers fill: along, the cell that starts at each
        plate pitch from the axis (the same distance on either side of it); up, the cells whose
        centres lie between the base and the grouser height. ``along`` and ``up`` are node coordinates."""
        positions = np.arange(0.0, self.half_length + 1e-12, self.plate_pitch)[None, :]
        near, far = np.minimum(np.abs(along[:-1]), np.abs(along[1:])), np.maximum(np.abs(along[:-1]), np.abs(along[1:]))
        slack = (ON_BOUNDARY * (far - near))[:, None]  # a position on a node line starts the cell beyond it
        columns = ((positions >= near[:, None] - slack) & (positions < far[:, None] - slack)).any(axis=1)
        centres = 0.5 * (up[:-1] + up[1:])
        return columns, (centres > 0.0) & (centres < self.grouser)

    def extra_solid(self, grid: Grid2D, solid: np.ndarray) -> None:
        """The grousers: a column of cells below the plates at every plate pitch."""
        if self.grouser <= 0:
            return
        columns, rows = self.grouser_cells(grid.x, grid.y)
        solid[np.ix_(np.nonzero(columns)[0], np.nonzero(rows)[0])] = True


@dataclass(frozen=True)
class Box:
    """A rectangular plate in 3D (a strip slab when ``half_length`` is infinite): base at z = 0,
    |x| ≤ B/2 across, |y| ≤ L/2 along."""

    half_width: float
    half_length: float

    def inside(self, x, y, z):
        return ((np.abs(x) <= self.half_width * (1 + ON_BOUNDARY)) & (np.abs(y) <= self.half_length * (1 + ON_BOUNDARY))
                & (z >= -ON_BOUNDARY))

    def faces(self, x, y, z):
        """Per point (body axes), each face's distance and its normal into the soil: the base, the walls
        across x, the ends along y (:meth:`Turned3D.face_normals`)."""
        return _box_faces(x, y, z, self.half_width, self.half_length)


@dataclass(frozen=True)
class Disc:
    """A circular plate in 3D: base at z = 0, radius R in plan; the staircase of the cells whose centre
    lies in the circle. It keeps the circle's area to a fraction of a cell per row of cells, and its
    steps' faces add up to 4/π of the circle's perimeter (the inscribed staircase has 12 % less area
    on B/20 cells, and pushed to 0.1 B it went relatively deeper: decision 0014)."""

    radius: float

    def inside(self, x, y, z):
        return (x * x + y * y <= self.radius**2 * (1 + ON_BOUNDARY)) & (z >= -ON_BOUNDARY)

    def faces(self, x, y, z):
        """The base's and the round wall's distance and normal into the soil, per point (body axes)."""
        r = np.maximum(np.hypot(x, y), 1e-300)
        zero = np.zeros_like(x)
        return (np.stack([np.abs(z), np.abs(self.radius - r)], axis=1),
                np.stack([np.stack([zero, zero, zero - 1.0], axis=1), np.stack([x / r, y / r, zero], axis=1)], axis=1))

    def extra_solid(self, grid, solid: np.ndarray) -> None:
        """The cells whose centre lies in the circle (beyond the inscribed ones, which ``inside`` gives)."""
        x, y, z = (0.5 * (a[:-1] + a[1:]) for a in grid.axes)
        solid |= self.inside(x[:, None, None], y[None, :, None], z[None, None, :])


@dataclass(frozen=True)
class Pose:
    """Where a 3D body stands in the grid: the grid point its own origin (the middle of its base) sits
    on (m), and the rotation from its axes (x across, y along, z up) to the grid's. Upright
    (:data:`UPRIGHT`) is no rotation; :meth:`pitched` tips the body about its x axis (nose down for a
    positive pitch) and then rolls it about its y axis. A landing moves the body vertically; the
    pose is how its shape is drawn."""

    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rotation: tuple[tuple[float, float, float], ...] = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))

    @classmethod
    def pitched(cls, pitch_deg: float, roll_deg: float = 0.0, origin=(0.0, 0.0, 0.0)) -> "Pose":
        p, r = math.radians(pitch_deg), math.radians(roll_deg)
        pitch = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(p), math.sin(p)], [0.0, -math.sin(p), math.cos(p)]])
        roll = np.array([[math.cos(r), 0.0, math.sin(r)], [0.0, 1.0, 0.0], [-math.sin(r), 0.0, math.cos(r)]])
        return cls(tuple(origin), tuple(map(tuple, roll @ pitch)))

    @classmethod
    def turned(cls, angles, pivot=(0.0, 0.0, 0.0)) -> "Pose":
        """The body turned by ``angles`` (rad; about x, y, z, right-handed: the model's sign, +y lowers
        the +x side) about ``pivot`` (its centre of gravity in the grid frame, m): R = Rz·Ry·Rx. The
        body integrates each rate about the grid's axes, so two turns at once compose to second order
        in the angles (exact for a turn about one axis)."""
        (cx, sx), (cy, sy), (cz, sz) = ((math.cos(a), math.sin(a)) for a in angles)
        rx = np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
        ry = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
        rz = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]])
        rotation = rz @ ry @ rx
        pivot = np.asarray(pivot, dtype=float)
        return cls(tuple(pivot - rotation @ pivot), tuple(map(tuple, rotation)))

    @property
    def upright(self) -> bool:
        return self == UPRIGHT

    def to_grid(self, vectors: np.ndarray) -> np.ndarray:
        """Vectors in the body's axes, (n, 3), turned into the grid's: R·v."""
        return vectors @ np.asarray(self.rotation).T

    def to_body(self, x, y, z):
        """Grid coordinates (arrays that broadcast) in the body's axes: Rᵀ·(p − origin)."""
        if self.upright:
            return x, y, z
        d = (x - self.origin[0], y - self.origin[1], z - self.origin[2])
        R = self.rotation
        return tuple(R[0][a] * d[0] + R[1][a] * d[1] + R[2][a] * d[2] for a in range(3))


UPRIGHT = Pose()


@dataclass(frozen=True)
class TrackBody:
    """The track in 3D: its width B across x (|x| ≤ B/2); along y and up, the side view
    (:class:`TrackSideView`): the flat run of plates with a grouser at every pitch, the sprocket
    arcs at its ends, the vehicle above. The arcs are a staircase of cells, as a circle's. Its
    ``pose`` places it in the grid (upright: its base on z = 0, as the quarter model needs)."""

    half_width: float
    side: TrackSideView
    pose: Pose = UPRIGHT

    def inside(self, x, y, z):
        x, y, z = self.pose.to_body(x, y, z)
        return (np.abs(x) <= self.half_width * (1 + ON_BOUNDARY)) & self.side.inside(y, z)

    def faces(self, x, y, z):
        """The base, the walls across x and the sprocket arcs at the ends (upright track, body axes): each
        one's distance and normal into the soil, per point."""
        side = self.side
        distances, normals = _box_faces(x, y, z, self.half_width, math.inf)
        beyond = np.abs(y) - side.half_length
        up = z - side.grouser - side.sprocket_radius
        r = np.maximum(np.hypot(beyond, up), 1e-300)
        arc = np.where(beyond > 0.0, np.abs(r - side.sprocket_radius), math.inf)
        distances[:, 2] = arc
        normals[:, 2] = np.stack([np.zeros_like(x), np.sign(y) * beyond / r, up / r], axis=1)
        return distances, normals

    def extra_solid(self, grid, solid: np.ndarray, centre_x: float = 0.0) -> None:
        """The grousers, across the whole width (drawn as cells on an upright track only); with
        ``centre_x``, those of the two tracks centred at ±centre_x (a vehicle's)."""
        if self.side.grouser <= 0:
            return
        if not self.pose.upright:
            raise NotImplementedError("grousers as cells on a pitched or rolled track: use geometry.grousers=trapped_soil")
        columns, rows = self.side.grouser_cells(grid.y, grid.z)
        across = np.abs(np.abs(0.5 * (grid.x[:-1] + grid.x[1:])) - centre_x) <= self.half_width
        solid[np.ix_(np.nonzero(across)[0], np.nonzero(columns)[0], np.nonzero(rows)[0])] = True


@dataclass(frozen=True)
class Vehicle:
    """Two tracks side by side, their centres ``gauge`` apart across x (±gauge/2), joined rigidly: the
    frame above them stays clear of the soil and is not drawn."""

    track: TrackBody
    gauge: float

    def inside(self, x, y, z):
        return self.track.inside(np.abs(x) - 0.5 * self.gauge, y, z)

    def faces(self, x, y, z):
        """Each point's track's faces (:meth:`TrackBody.faces`), the walls across x mirrored on the −x track."""
        distances, normals = self.track.faces(np.abs(x) - 0.5 * self.gauge, y, z)
        normals[:, :, 0] *= np.where(x < 0.0, -1.0, 1.0)[:, None]
        return distances, normals

    def extra_solid(self, grid, solid: np.ndarray) -> None:
        """Each track's grousers, across its own width."""
        self.track.extra_solid(grid, solid, 0.5 * self.gauge)


def _box_faces(x, y, z, half_width: float, half_length: float):
    """A box's base (z = 0), walls (|x| = half_width) and ends (|y| = half_length): per point, each face's
    distance (points, 3) and its normal into the soil (points, 3, 3)."""
    zero = np.zeros_like(x)
    distances = np.stack([np.abs(z), np.abs(half_width - np.abs(x)), np.abs(half_length - np.abs(y))], axis=1)
    normals = np.stack([np.stack([zero, zero, zero - 1.0], axis=1), np.stack([np.sign(x), zero, zero], axis=1),
                        np.stack([zero, np.sign(y), zero], axis=1)], axis=1)
    return distances, normals


@dataclass(frozen=True)
class Turned3D:
    """A 3D shape (upright, given in its own axes) placed in the grid by a turned ``pose``
    (:meth:`Pose.turned`): the body as it turns about its centre of gravity, which the grid follows."""

    shape: object
    pose: Pose

    def inside(self, x, y, z):
        return self.shape.inside(*self.pose.to_body(x, y, z))

    def heights(self, x, y, z):
        """How high points of the grid frame lie above the body's base, up its own axis (m)."""
        return self.pose.to_body(x, y, z)[2]

    def face_normals(self, x, y, z, h: float) -> np.ndarray:
        """Per point (grid frame) beside the turned body, the normal into the soil of its face nearest to
        it, turned with the body, (points, 3); zero at an edge or a corner (its two nearest faces within
        h/2 of each other, both within h) and deep inside (over 1.5 h from every face): 2D's rule
        (:meth:`Turned.face_normals`)."""
        distances, normals = self.shape.faces(*self.pose.to_body(*(np.asarray(a, float) for a in (x, y, z))))
        order = np.argsort(distances, axis=1, kind="stable")
        nearest, second = (np.take_along_axis(distances, order[:, k:k + 1], axis=1)[:, 0] for k in (0, 1))
        upright = np.take_along_axis(normals, order[:, :1, None], axis=1)[:, 0].copy()
        upright[(second - nearest < 0.5 * h) & (second < h)] = 0.0
        upright[nearest > 1.5 * h] = 0.0
        return self.pose.to_grid(upright)

    def extra_solid(self, grid, solid: np.ndarray) -> None:
        """Turned, the body also takes the cells whose centre it holds (2D's :meth:`Turned.extra_solid`);
        upright, what the shape adds."""
        if self.pose.upright:
            if hasattr(self.shape, "extra_solid"):
                self.shape.extra_solid(grid, solid)
            return
        x, y, z = (0.5 * (a[:-1] + a[1:]) for a in grid.axes)
        solid |= self.inside(x[:, None, None], y[None, :, None], z[None, None, :])


def inside_nodes(shape, grid) -> np.ndarray:
    """Which grid nodes lie inside the shape: an array of the node shape, any number of axes."""
    inside = shape.inside(*np.meshgrid(*grid.axes, indexing="ij", sparse=True))
    return np.broadcast_to(inside, tuple(len(a) for a in grid.axes))  # a shape may not vary along every axis


def _corner_views(node_array: np.ndarray, cell_shape) -> list:
    """The node array seen from each local corner of every cell (one view per corner)."""
    return [node_array[tuple(slice(o, o + n) for o, n in zip(off, cell_shape))]
            for off in corner_offsets(len(cell_shape))]


def solid_cells(shape, grid) -> np.ndarray:
    """The body's cells (the grid's cell shape): every corner inside the shape, plus what the shape adds.

    On a 2D grid that spans both sides of the axis (the whole section), the half grid x ≥ 0 is
    rasterised and mirrored, so the two halves are exact mirror images (a 3D grid's mirrored axes
    have exactly negated coordinates, and its shapes depend on |x| and |y|)."""
    if grid.x[0] < 0.0 and len(grid.axes) == 2 and getattr(shape, "symmetric", True):
        half = Grid2D(grid.x[grid.nx // 2:], grid.y, grid.h)
        solid = solid_cells(shape, half)
        return np.concatenate([solid[::-1], solid])
    cell_shape = tuple(len(a) - 1 for a in grid.axes)
    solid = np.logical_and.reduce(_corner_views(inside_nodes(shape, grid), cell_shape))
    if hasattr(shape, "extra_solid"):
        shape.extra_solid(grid, solid)
    return solid


def cells_reached(shape, grid) -> np.ndarray:
    """The cells (the grid's cell shape) with a corner inside the shape: those the body's boundary may
    cross, beside the ones it holds whole (:func:`solid_cells`)."""
    cell_shape = tuple(len(a) - 1 for a in grid.axes)
    return np.logical_or.reduce(_corner_views(inside_nodes(shape, grid), cell_shape))


def nodes_touching(solid: np.ndarray) -> np.ndarray:
    """How many body cells each node touches (the node shape, any number of axes)."""
    touching = np.zeros(tuple(n + 1 for n in solid.shape), dtype=int)
    for view in _corner_views(touching, solid.shape):
        view += solid
    return touching


def soil_cells_touching(solid, node_i, node_j) -> np.ndarray:
    """The cells outside the body (``solid`` False) with a corner among the nodes (node_i, node_j)."""
    marked = np.zeros((solid.shape[0] + 1, solid.shape[1] + 1), dtype=bool)
    marked[node_i, node_j] = True
    return (marked[:-1, :-1] | marked[1:, :-1] | marked[1:, 1:] | marked[:-1, 1:]) & ~solid
