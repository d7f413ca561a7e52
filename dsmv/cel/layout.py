"""The typed containers the compiled loop works on: one NamedTuple per kind of state.

Numba compiles a NamedTuple of arrays and scalars into a struct and caches the machine code on
disk like any other argument type, so the loop takes a handful of these instead of loose arrays
and index constants. Containers hold arrays, never numerics; the kernels that change them live
in :mod:`dsmv.cel.kernels`.

Layout, in any number of axes d (2 today; the last axis is "up"):

- cells: arrays of the grid's cell shape, e.g. (nx, ny); the transported state ``q`` has the
  rows :class:`CellRows` names, then the soil law's state variables.
- nodes: flat arrays over the grid's structured nodes (node (i, j) is i·(ny+1) + j) followed by
  the **split nodes**, appended copies of a structured node (a body's corner, where the soil on
  either side must move apart). ``corner`` maps every cell corner to its node, so a split node
  is an ordinary node that some cells use in place of the structured one.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from dsmv.config.scene import FREEDOM_NAMES


@dataclass(frozen=True)
class CellRows:
    """Rows of the transported cell state q for a grid of ``dim`` axes: the stress components
    (the soil's own, tension positive, Pa; in plane strain and axisymmetry the out-of-plane or hoop
    stress is ``zz``), the accumulated plastic shear strain ξ, the initial depth z0 (m), then the
    soil law's state variables."""

    dim: int

    @property
    def stress(self) -> tuple[str, ...]:
        return ("xx", "yy", "xy", "zz") if self.dim == 2 else ("xx", "yy", "zz", "xy", "yz", "zx")

    def of(self, component: str) -> int:
        return self.stress.index(component)

    @property
    def xi(self) -> int:
        return len(self.stress)

    @property
    def z0(self) -> int:
        return len(self.stress) + 1

    @property
    def base(self) -> int:
        """Rows before the soil law's state variables."""
        return len(self.stress) + 2

    @property
    def vertical(self) -> str:
        """The normal stress along the up axis (the last one)."""
        return "yy" if self.dim == 2 else "zz"

    @property
    def horizontal(self) -> tuple[str, ...]:
        """The other normal stresses (in 2D the out-of-plane or hoop one is horizontal too)."""
        return ("xx", "zz") if self.dim == 2 else ("xx", "yy")

    @property
    def geostatic(self) -> tuple[int, int, int, int]:
        """The rows a geostatic state sets: the vertical stress, the two horizontal ones, z0."""
        return (self.of(self.vertical), *(self.of(c) for c in self.horizontal), self.z0)

    @property
    def slope_shear(self) -> tuple[int, int]:
        """The shear stresses on the planes along the seabed, along x and y (−1: plane strain has no y):
        those an infinite slope's weight sets (:func:`dsmv.cel.state.geostatic_state`)."""
        return (self.of("xy"), -1) if self.dim == 2 else (self.of("zx"), self.of("yz"))

    @property
    def inflow(self) -> tuple[int, ...]:
        """The rows a ghost state of the inflow sets: :attr:`geostatic`, then :attr:`slope_shear`."""
        return (*self.geostatic, *self.slope_shear)


ROWS_2D = CellRows(2)
ROWS_3D = CellRows(3)


class Mesh2D(NamedTuple):
    """The grid's geometry: node coordinates per axis (m), cell volumes (m³ per unit thickness, or
    per radian), the node of each cell corner ``corner`` (cells × 2^d, local corners in the order
    of :func:`corner_offsets`), how many nodes are structured (the rest are split nodes), and the
    cells whose corners differ from the structured numbering (``split``, from :func:`split_cells`:
    the per-cell kernels read the table there only, and compute the structured nodes elsewhere — a
    gather of four indices per cell cost a third of the force kernel)."""

    x: np.ndarray
    y: np.ndarray
    vol: np.ndarray
    corner: np.ndarray
    n_grid: int
    split: np.ndarray


class Mesh3D(NamedTuple):
    """A 3D grid's geometry, as :class:`Mesh2D` with the third axis: node coordinates x (across the
    body), y (along it) and z (up) in m, cell volumes (m³), the corner table (cells × 8), the
    structured node count, the cells that use a split node, and each cell's faces against the body
    (``closed``, uint8: bit 2a its lower face along axis a, bit 2a + 1 its upper one)."""

    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    vol: np.ndarray
    corner: np.ndarray
    n_grid: int
    split: np.ndarray
    closed: np.ndarray


class Cells(NamedTuple):
    """Cell state: volume fraction φ, transported state q (:class:`CellRows`), current strength su
    (Pa, written by the stress update), the strength factor (α in a curved body's interface
    layer), the body's share (solid cells, open fraction), the gap cells of contact separation,
    the volumetric strain rate a merged sliver pair shares (NaN elsewhere), and the factor on the
    hourglass coefficient (1 where the hourglass force acts, 0 elsewhere)."""

    phi: np.ndarray
    q: np.ndarray
    su: np.ndarray
    strength_factor: np.ndarray
    solid: np.ndarray
    open_frac: np.ndarray
    gap: np.ndarray
    shared_divergence: np.ndarray
    hourglass_factor: np.ndarray


class Faces2D(NamedTuple):
    """Per face normal to each axis: its open fraction (the body closes faces) and the soil volume
    through it in the last remap sweep ([face, line], m³)."""

    aperture_x: np.ndarray
    aperture_y: np.ndarray
    flux_x: np.ndarray
    flux_y: np.ndarray


class Faces3D(NamedTuple):
    """A 3D grid's faces normal to each axis, indexed [face along the axis, the other two axes' cells
    in order]: their open fraction (the body closes faces) and the soil volume through them in the
    last remap sweep (m³)."""

    aperture_x: np.ndarray
    aperture_y: np.ndarray
    aperture_z: np.ndarray
    flux_x: np.ndarray
    flux_y: np.ndarray
    flux_z: np.ndarray


class Nodes(NamedTuple):
    """Node state, flat (:mod:`module docstring <dsmv.cel.layout>`): velocity (d, n) in m/s,
    force (d, n) in N per unit thickness or per radian, lumped mass (n,) in kg, and the travel
    through the grid since the last remap (d, n) in m."""

    v: np.ndarray
    f: np.ndarray
    mass: np.ndarray
    travel: np.ndarray


class Contact(NamedTuple):
    """The contact as data, built once (:mod:`dsmv.cel.contact`).

    Ties, one row each: the node, whether it is tied fully (moves with the body) or only along
    its face normal ``normal`` (d, pointing into the soil; zero at a corner or a staircase node),
    its adhesion capacity ``cap`` (α × its share of the face, m or m²/rad: the face pulls it along
    by at most cap·su), and the cells whose strength grips it (``grip_cell`` rows from
    ``grip_start[k]`` to ``grip_start[k + 1]``, cell indices per axis). ``holding`` is work space:
    how much of each tie holds this step (1 all of it, 0 none). Split nodes: each with the structured node it copies
    (``split_parent``). Boundary conditions: node and axis of every fixed velocity component.
    Merged slivers of a cut body: rows (i, j, i', j'). ``arm`` (ties, d): each tied node's position
    relative to the body's centre of gravity (m), the lever of its reaction. ``bond``: the share of
    each tie that holds whatever the soil does, soil against soil (the soil a track's grousers trap),
    which contact separation leaves holding."""

    node: np.ndarray
    full: np.ndarray
    normal: np.ndarray
    cap: np.ndarray
    grip_start: np.ndarray
    grip_cell: np.ndarray
    holding: np.ndarray
    split_node: np.ndarray
    split_parent: np.ndarray
    fixed_node: np.ndarray
    fixed_axis: np.ndarray
    merge: np.ndarray
    arm: np.ndarray
    bond: np.ndarray


class Inflow(NamedTuple):
    """Soil entering the grid, which follows the body's translation (the soil beyond is at rest and
    geostatic). Through the base: its state per base cell (rows of q) and the depth at t = 0 of the
    ghost cell below the base (m). Through the sides, while the body slides: its state per layer of
    cells (``side``: rows of q × layers) and the fill of each layer (``side_fill``: the mudline's layer
    is filled in part), set before each remap from the layers' node heights ``levels`` (m, up the grid)
    and the mudline's height at t = 0 (``mudline``, m). The defaults close the sides (a model whose
    inflow is off)."""

    ghost: np.ndarray
    depth0: np.ndarray
    side: np.ndarray = np.zeros((0, 0))
    side_fill: np.ndarray = np.zeros(0)
    levels: np.ndarray = np.zeros(1)
    mudline: float = 0.0


class SoilLawKernel(NamedTuple):
    """A soil law as the kernels call it (dsmv.soil_law): its compiled strength factor, its packed
    parameters per layer of the soil (one row per layer, ``soil.profile``'s law columns; one row
    unlayered), each layer's top depth (m; the first −∞) and its compiled state update. The kernels take
    None instead for a law that neither changes the strength nor carries state."""

    factor: object
    params: np.ndarray
    evolve: object
    top: np.ndarray

    @classmethod
    def of(cls, law) -> "SoilLawKernel":
        """The kernel of a :class:`dsmv.soil_law.SoilLaw` on its soil."""
        return cls(law.compiled(), np.array([layer.packed() for layer in law.layers()]), law.compiled_evolve(),
                   np.asarray(law.layer_tops, dtype=float))


class Params(NamedTuple):
    """The step's parameters: SI floats and switches, fixed for a run."""

    dt: float               # time step (s)
    density: float          # soil's buoyant density (kg/m³; a layered soil's lightest, see density_row)
    shear: float            # shear modulus G (Pa)
    bulk: float             # bulk modulus K (Pa)
    wave_speed: float       # P-wave speed (m/s)
    k0: float               # at-rest earth pressure ratio (-)
    hourglass: float        # viscous hourglass coefficient (-)
    bulk_linear: float      # bulk viscosity b1 (-)
    bulk_quadratic: float   # bulk viscosity b2 (-)
    gravity: float          # m/s², down the up axis (on a sloping seabed, its part normal to it: g·cos β)
    su0: float              # strength at the mudline (Pa)
    ks: float               # strength gradient (Pa/m)
    mass_floor: float       # nodes lighter than this are empty (kg)
    phi_min: float          # cells with less soil give none in the remap (-)
    stress_cutoff: float    # cells with less soil carry no stress (-)
    body_mass: float        # the body's inertia in the model (kg per unit thickness or per radian)
    body_weight: float      # its wet weight (N per unit thickness or per radian)
    push_velocity: float    # a push's speed, and a drop's touchdown speed (m/s, down +)
    remap_travel: float     # the remap runs once some node has travelled this far (m; 0: every step)
    cell_size: float        # the core cell h (m)
    axisymmetric: bool
    advection_order: int    # 1 donor cell, 2 van Leer
    drop: bool              # free fall (true) or push at constant speed
    inflow: bool            # soil enters through the base
    remap: bool             # false: small strain on the undeformed grid
    tresca: bool            # Tresca's hexagon, else J2
    law_active: bool        # evaluate the soil law (softening or rate)
    skip_void: bool         # cells without soil do no force arithmetic
    separation: bool        # face ties let go of soil that pulls away
    strength_depth: np.ndarray = np.array([-np.inf])  # the intact strength's segments: top depth (m),
    strength_intercept: np.ndarray = np.zeros(1)       # intercept (Pa) and slope (Pa/m), su = intercept + slope·z0
    strength_slope: np.ndarray = np.zeros(1)           # (dsmv.config.profile.StrengthSegments)
    free: int = 0           # the body's freedoms integrated under the soil's reaction (bits over FREEDOMS)
    inertia_x: float = 0.0  # the body's rotational inertia about axes through its centre of gravity
    inertia_y: float = 0.0  # (kg·m² per unit thickness in plane strain, where only y turns)
    inertia_z: float = 0.0
    base_x: float = 0.0     # the middle of the body's base from its centre of gravity, across and along (m)
    base_y: float = 0.0
    base_z: float = 0.0     # and up (m): minus the centre of gravity's height above the base
    base_half_x: float = 0.0  # the base's half width and half length (m): its lowest point as it turns
    base_half_y: float = 0.0
    rest_speed: float = 0.0  # a drop whose fall has stopped is at rest once it slides and turns (its edge) slower (m/s)
    sloped: bool = False    # the seabed slopes: gravity has a part along the grid's x and y (the level grid turned)
    gravity_x: float = 0.0  # gravity along +x and +y (m/s², downslope positive): g·sin β·cos α, g·sin β·sin α
    gravity_y: float = 0.0
    weight_x: float = 0.0   # the body's weight along +x and +y (N per unit thickness or per radian)
    weight_y: float = 0.0
    density_row: int = -1   # a layered soil: the last row of q, each cell's density over ``density`` (-1: one density)
    density_top: np.ndarray = np.array([-np.inf])  # its layers (dsmv.config.profile.DensityLayers): top depth (m),
    density_ratio: np.ndarray = np.ones(1)          # density over ``density``, the lightest layer's (-), and the
    density_intercept: np.ndarray = np.zeros(1)     # weighing depth's intercept (m)


# the body's mutable state, a float array: time (s), offset of the grid (m, up +), velocity (m/s,
# up +), deepest sinkage (m), the sum and count of the soil's force on the body over the chunk
# (N, up +), soil volume entered at the base (m³), steps, the adhesive pull of the last step (N,
# applied in the next), the offset at the last remap (m), remaps done; then whether the node forces
# already hold the next step's (1.0; 3D computes them with the stress update, and a remap makes
# them stale), and with them their hourglass and bulk-viscosity power (W) and force on the body (N)
(B_TIME, B_OFFSET, B_VEL, B_MAXDISP, B_FSUM, B_FCOUNT, B_INFLOW, B_STEP, B_FRICTION, B_REMAP_OFFSET, B_REMAPS,
 B_FORCES_AHEAD, B_HOURGLASS_W, B_BULK_W, B_BESIDE_N) = range(15)
# then the body's other freedoms (:data:`FREEDOMS`), each with the slots of the vertical one above: its
# velocity (m/s, rad/s: v_x, v_y, ω_x, ω_y, ω_z), its displacement (m, rad), the sum of the soil's
# force or moment on the body over the chunk (N, N·m about the centre of gravity) and the adhesive
# pull of the last step; and the largest rotation (rad) and horizontal displacement (m) so far, the
# sinkage of the middle of the base now (m; B_OFFSET is the centre of gravity's travel, B_MAXDISP the
# base's deepest sinkage) and the deepest sinkage of the base's lowest point (m); and the horizontal
# force (x, y) the cells beside the body put on it, as B_BESIDE_N the vertical (N), and its moment
# about the centre of gravity (N·m); 1.0 once a drop's fall has stopped
(B_VX, B_VY, B_WX, B_WY, B_WZ, B_OFFSET_X, B_OFFSET_Y, B_ROT_X, B_ROT_Y, B_ROT_Z,
 B_HSUM_X, B_HSUM_Y, B_MSUM_X, B_MSUM_Y, B_MSUM_Z, B_PULL_X, B_PULL_Y, B_PULL_RX, B_PULL_RY, B_PULL_RZ,
 B_MAXROT, B_MAXSLIDE, B_SINKAGE, B_MAXEDGE, B_BESIDE_X, B_BESIDE_Y, B_BESIDE_MX, B_BESIDE_MY,
 B_BESIDE_MZ, B_FELL) = range(15, 45)
N_BODY = 45

#: the rigid body's six freedoms, in the config's order everywhere (bitmask ``Params.free``, slots)
FREEDOMS = FREEDOM_NAMES
#: per freedom, the body's slot for its velocity, its displacement, its force sum and its adhesive pull
VELOCITY_SLOTS = np.array([B_VX, B_VY, B_VEL, B_WX, B_WY, B_WZ])
POSE_SLOTS = np.array([B_OFFSET_X, B_OFFSET_Y, B_OFFSET, B_ROT_X, B_ROT_Y, B_ROT_Z])
FORCE_SLOTS = np.array([B_HSUM_X, B_HSUM_Y, B_FSUM, B_MSUM_X, B_MSUM_Y, B_MSUM_Z])
PULL_SLOTS = np.array([B_PULL_X, B_PULL_Y, B_FRICTION, B_PULL_RX, B_PULL_RY, B_PULL_RZ])
#: the freedoms a model of d axes has: plane strain moves in x, z and turns about y (out of the plane)
MODEL_FREEDOMS = {2: np.array([0, 2, 4]), 3: np.arange(6)}


def freedom_mask(names) -> int:
    """The bitmask over :data:`FREEDOMS` of the freedoms named."""
    return sum(1 << FREEDOMS.index(n) for n in names)


def corner_offsets(dim: int) -> np.ndarray:
    """The local corners of a cell, (2^d, d) offsets: in 2D (0,0), (1,0), (1,1), (0,1), counter-clockwise."""
    if dim == 2:
        return np.array([(0, 0), (1, 0), (1, 1), (0, 1)])
    return np.array([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)])


def corner_sides(dim: int) -> np.ndarray:
    """Each local corner's side (−1 or +1) along each axis, (d, 2^d), in the corner table's order."""
    return np.ascontiguousarray(2.0 * corner_offsets(dim).T - 1.0)


def hourglass_vectors(dim: int) -> np.ndarray:
    """The hourglass vectors over a cell's corners, (modes, 2^d): the products of the corners' sides
    that the one-point rule cannot see, Γ = ξη = (1, −1, 1, −1) in 2D, ηζ, ζξ, ξη and ξηζ in 3D."""
    s = corner_sides(dim)
    if dim == 2:
        return (s[0] * s[1])[None, :]
    return np.stack([s[1] * s[2], s[2] * s[0], s[0] * s[1], s[0] * s[1] * s[2]])


def structured_corners(cell_shape: tuple[int, ...]) -> np.ndarray:
    """The corner table of a grid without split nodes: (*cell_shape, 2^d) flat node indices (int32:
    the per-cell gather reads half the bytes)."""
    dim = len(cell_shape)
    node_shape = tuple(n + 1 for n in cell_shape)
    index = np.arange(int(np.prod(node_shape)), dtype=np.int32).reshape(node_shape)
    cells = tuple(slice(0, n) for n in cell_shape)
    return np.stack([index[tuple(slice(o, o + n) for o, n in zip(off, cell_shape))] for off in corner_offsets(dim)],
                    axis=-1)[cells]


def split_cells(corner: np.ndarray) -> np.ndarray:
    """The cells that use a split node somewhere: where the corner table differs from the structured one."""
    return (corner != structured_corners(corner.shape[:-1])).any(axis=-1)
