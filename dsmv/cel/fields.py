"""Field output of the CEL solver: snapshots between compiled chunks, written for ParaView.

``output.fields=true`` makes a CEL run write, into its job directory,

- ``fields.pvd``: a ParaView collection that lists the frames with their simulated times;
- ``fields/frame_NNNN.vtu``: one unstructured-grid file per frame (quads in 2D, hexahedra in 3D,
  binary, zlib);
- ``fields/max_sinkage.vtu``: the frame at the deepest point of the run, listed in the
  collection at its time like the others.

Why VTU frames and a PVD rather than an XDMF time series: the grid moves with the body, so
every frame has its own node positions. meshio's XDMF ``TimeSeriesWriter`` stores one mesh
for all steps, which would leave the user to shift each step by the body's offset in
ParaView by hand; VTU frames carry their true positions, need no HDF5 (h5py), and each one
opens on its own with ``meshio.read``.

Coordinates are in the fixed (laboratory) frame, the last axis up with 0 at the body's base at
touchdown (the mudline when ``landing.initial_depth_m`` = 0). In 2D: x across the section from
the symmetry axis (the radius r in axisymmetry), y up. In 3D (``solver=cel3d``): x across the
body, y along it, z up; the modelled quarter (or half) lies on the positive side of its symmetry
planes x = 0 and y = 0 (ParaView's Reflect filter shows the rest). Each frame's nodes are the
grid's nodes shifted by the body's displacement at that instant. Units are SI.

Cell data (float32):

===================================  =====  ======================================================
``volume_fraction``                  -      soil volume per cell volume φ (compressed soil: > 1)
``stress_xx_pa`` … ``stress_zx_pa``  Pa     the soil's own stress, tension positive; in 2D xx, yy,
                                            xy and zz, the out-of-plane stress (the hoop stress in
                                            axisymmetry); in 3D xx, yy, zz, xy, yz, zx
``su_pa``                            Pa     current undrained strength, the stress update's own
                                            (su_intact(z0)·law factor·α in an interface layer)
``mobilised_strength``               -      √J2/su (Tresca: (σ1 − σ3)/(2·su)); 1 at yield
``plastic_shear_strain``             -      ξ, the accumulated plastic shear strain
``shear_strain_rate_per_s``          1/s    γ̇ = ε̇1 − ε̇3 by the stress update's own rule
``plastic_shear_strain_rate_per_s``  1/s    γ̇ where the soil is at yield (YIELD_RATIO), else 0
``initial_depth_m``                  m      z0, the depth where the cell's soil started
``hourglass_velocity_m_s``           m/s    amplitude of the hourglass (zig-zag) modes in the
                                            cell's nodal velocities (a checkerboard shows here):
                                            the Q4 mode in 2D, the four hexahedral vectors in 3D
``body``                             -      1 in cells inside the rigid body
``density_kg_m3``                    kg/m³  the soil's buoyant density, when the table layers it
                                            (0 in cells without soil)
===================================  =====  ======================================================

Point data: ``velocity_m_s`` (n, 3), the nodal material velocity in the laboratory frame
(the solver's own values at the grid's nodes, z component 0 in 2D; empty nodes carry 0; a body's split
corner nodes are not points of the frame, their cells' derived fields use them). Field data per frame:
``time_s``, ``sinkage_m`` (the body's downward displacement).

Snapshots cost nothing when output is off: the solver creates no recorder and its loop
only checks for ``None`` between chunks. When on, the solver calls :meth:`FieldRecorder.sample`
between compiled chunks (never inside a kernel): a frame is a copy of φ, the cell state, the
strength and strain rate the kernels computed, and the nodal velocities; the derived fields are
computed when the frames are written.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dsmv.cel import layout as K

FIELDS_FILE = "fields.pvd"
FIELDS_DIR = "fields"
MAX_SINKAGE_FRAME = f"{FIELDS_DIR}/max_sinkage.vtu"



def stress_names(dim: int) -> dict[int, str]:
    """The stress rows of a ``dim``-axis grid's cell state by output name's row."""
    rows = K.CellRows(dim)
    return {rows.of(c): f"stress_{c}_pa" for c in rows.stress}


#: a cell counts as yielding when its mobilised strength √J2/su is at least this. The return
#: puts a yielding cell on the surface exactly; the remap blends the cell with its neighbours.
#: Measured (with a remap after every step) over all frames of the default landing
#: (coarse and medium meshes): of
#: the soil cells above 0.9, 66–67 % lie within 0.1 % of 1, 5 % between 0.99 and 0.999 (those
#: blended) and 28 % between 0.9 and 0.99 (cells loading or unloading
#: elastically). The plastic rate is thus an indicator of the yielding zone, not a return's output.
YIELD_RATIO = 0.99


def hourglass_velocity(corner, v) -> np.ndarray:
    """Amplitude of the hourglass modes in each cell's nodal velocities (m/s), each mode's amplitude
    its projection on the corner vector over the vector's squared length, as in the kernels'
    ``hourglass_modes``: in 2D the Q4 mode Γ = (1, −1, 1, −1), a = (v0 − v1 + v2 − v3)/4; in 3D the
    root sum of squares over the four vectors ηζ, ζξ, ξη, ξηζ. The cells' nodes come from the corner
    table (a body's split corners included)."""
    w = v[:, corner]  # (d, cells..., 2^d)
    vectors = K.hourglass_vectors(corner.shape[-1].bit_length() - 1)
    a = w @ vectors.T / vectors.shape[1]  # (d, cells..., modes)
    return np.sqrt((a * a).sum(axis=(0, -1)))


def _stress_tensors(q: np.ndarray, dim: int) -> np.ndarray:
    """The cells' stress as 3×3 tensors (cells..., 3, 3), from the rows of a ``dim``-axis state."""
    rows = K.CellRows(dim)
    sigma = np.zeros((*q.shape[1:], 3, 3))
    if dim == 2:
        pairs = {"xx": (0, 0), "yy": (1, 1), "zz": (2, 2), "xy": (0, 1)}
    else:
        pairs = {"xx": (0, 0), "yy": (1, 1), "zz": (2, 2), "xy": (0, 1), "yz": (1, 2), "zx": (2, 0)}
    for name, (a, b) in pairs.items():
        sigma[..., a, b] = sigma[..., b, a] = q[rows.of(name)]
    return sigma


def mobilised_strength(q: np.ndarray, su: np.ndarray, tresca: bool) -> np.ndarray:
    """The stress over the strength (-): √J2/su, or (σ1 − σ3)/(2·su) on Tresca's surface; 0 where su = 0.
    ``q``: the cell state of a 2D (nx, ny) or 3D (nx, ny, nz) grid."""
    sigma = _stress_tensors(q, q.ndim - 1)
    if tresca:
        finite = np.isfinite(sigma).all(axis=(-2, -1))
        principal = np.linalg.eigvalsh(np.where(finite[..., None, None], sigma, 0.0))  # ascending
        shear = np.where(finite, 0.5 * (principal[..., -1] - principal[..., 0]), np.nan)
    else:
        p = np.trace(sigma, axis1=-2, axis2=-1) / 3.0
        dev = sigma - p[..., None, None] * np.eye(3)
        shear = np.sqrt(0.5 * (dev * dev).sum(axis=(-2, -1)))
    return np.divide(shear, su, out=np.zeros_like(shear), where=su > 0.0)


@dataclass
class _Snapshot:
    """The raw state at one instant: copies, so the solver can go on."""

    time_s: float
    sinkage_m: float
    phi: np.ndarray
    q: np.ndarray
    su: np.ndarray
    rate: np.ndarray
    v: np.ndarray


class FieldRecorder:
    """Frames of a CEL run at evenly spaced simulated times, plus the deepest instant.

    A frame is taken at the first chunk end past each multiple of the spacing, which starts
    at ``spacing_s`` (one chunk: a frame per chunk). Whenever more than ``2·frames`` frames
    after t = 0 pile up, every other one is dropped and the spacing doubled. So a run of any
    length, known beforehand or not, ends with ``frames`` to ``2·frames`` evenly spaced
    frames after the one at t = 0 (fewer only if it has fewer chunks), the last at its end;
    a frame's time is a chunk end, and every frame carries its true time. The deepest state
    met at a chunk end is kept as well (a drop's velocity turns within its last chunk, so
    that state can lie a chunk before the end).

    ``grid``: the solver's :class:`~dsmv.cel.grid.Grid`; ``solid``: cells inside the body;
    ``corner``: the corner table (cells' nodes, :mod:`dsmv.cel.layout`); ``tresca``: the
    solver's yield surface; ``stress_cutoff``: the volume fraction below which a cell carries
    no stress (derived fields are 0 there).
    """

    def __init__(self, grid, solid, corner, *, tresca: bool, stress_cutoff: float, frames: int, spacing_s: float,
                 density: tuple[float, int] = (0.0, -1)):
        self.grid, self.solid, self.corner = grid, solid, corner
        self.density = density  # a layered soil's lightest density (kg/m³) and its cells' density row of q
        self.tresca, self.stress_cutoff = tresca, stress_cutoff
        self.frames = frames
        self.spacing_s = spacing_s
        self.taken: list[tuple[int, _Snapshot]] = []  # (multiple of the spacing, snapshot)
        self.deepest: _Snapshot | None = None

    @staticmethod
    def _copy(time_s, sinkage_m, state, into: _Snapshot | None = None) -> _Snapshot:
        if into is None:
            return _Snapshot(time_s, sinkage_m, *(a.copy() for a in state))
        for target, source in zip((into.phi, into.q, into.su, into.rate, into.v), state):
            np.copyto(target, source)
        into.time_s, into.sinkage_m = time_s, sinkage_m
        return into

    def sample(self, time_s: float, sinkage_m: float, phi, q, su, rate, v, final: bool = False) -> None:
        """Look at the state between two chunks; copy it when a frame is due (``final``: the run's end).

        ``su`` and ``rate`` are the kernels' strength (Pa) and shear strain rate (1/s) per cell, ``v``
        the velocities of all nodes (d, n)."""
        state = (phi, q, su, rate, v)
        if self.deepest is None or sinkage_m >= self.deepest.sinkage_m:
            self.deepest = self._copy(time_s, sinkage_m, state, self.deepest)
        # which multiple of the spacing this is; the nudge keeps a time that sums up to a
        # multiple from landing a round-off below it
        k = int(math.floor(time_s / self.spacing_s + 1e-9))
        if self.taken and (self.taken[-1][1].time_s == time_s or (k <= self.taken[-1][0] and not final)):
            return
        self.taken.append((k, self._copy(time_s, sinkage_m, state)))
        if len(self.taken) > 2 * self.frames + 1 and not final:  # + 1: the frame at t = 0
            self.taken = [(j // 2, s) for j, s in self.taken if j % 2 == 0]
            self.spacing_s *= 2.0

    # ------------------------------------------------------------------ writing

    def cell_fields(self, snap: _Snapshot) -> dict[str, np.ndarray]:
        """The derived cell fields of one snapshot, (nx, ny) arrays by output name."""
        with np.errstate(invalid="ignore", over="ignore"):  # a run gone unstable is written as it is
            return self._cell_fields(snap)

    def _cell_fields(self, snap: _Snapshot) -> dict[str, np.ndarray]:
        phi, q, su, rate = snap.phi, snap.q, snap.su, snap.rate
        soil = phi > self.stress_cutoff
        ratio = mobilised_strength(q, su, self.tresca)
        rows = K.CellRows(phi.ndim)
        out = {"volume_fraction": phi}
        out |= {name: q[k] for k, name in stress_names(phi.ndim).items()}
        out |= {
            "su_pa": su,
            "mobilised_strength": ratio,
            "plastic_shear_strain": q[rows.xi],
            "shear_strain_rate_per_s": rate,
            "plastic_shear_strain_rate_per_s": np.where(ratio >= YIELD_RATIO, rate, 0.0),
            "initial_depth_m": q[rows.z0],
            "hourglass_velocity_m_s": np.where(soil, hourglass_velocity(self.corner, snap.v), 0.0),
            "body": self.solid.astype(float),
        }
        lightest, row = self.density
        if row >= 0:
            out["density_kg_m3"] = lightest * q[row]
        return out

    def _mesh(self, snap: _Snapshot):
        """The frame as a meshio mesh: the grid's nodes in row-major order (node (i, j[, k]) is point
        i·(ny+1) + j, or (i·(ny+1) + j)·(nz+1) + k, the solver's own numbering), the last axis shifted
        by the sinkage; cells as VTK quads or hexahedra, whose corner order is the corner table's."""
        import meshio

        axes = [np.asarray(a, dtype=float) for a in self.grid.axes]
        axes[-1] = axes[-1] - snap.sinkage_m
        dim = len(axes)
        coords = np.meshgrid(*axes, indexing="ij")
        points = np.column_stack([c.ravel() for c in coords] + [np.zeros(coords[0].size)] * (3 - dim))
        node = np.arange(points.shape[0]).reshape(coords[0].shape)
        corners = [node[tuple(slice(None, -1) if o == 0 else slice(1, None) for o in offset)]
                   for offset in K.corner_offsets(dim)]
        cells_of = np.stack(corners, axis=-1).reshape(-1, 2**dim)
        cells = {name: [np.ascontiguousarray(v, dtype=np.float32).ravel()]
                 for name, v in self.cell_fields(snap).items()}
        grid_v = snap.v[:, : points.shape[0]]  # the grid's nodes come first, split nodes after
        velocity = np.vstack([grid_v, np.zeros((3 - dim, grid_v.shape[1]))]).T.astype(np.float32)
        kind = "quad" if dim == 2 else "hexahedron"
        return meshio.Mesh(points, [(kind, cells_of)], cell_data=cells, point_data={"velocity_m_s": velocity})

    @staticmethod
    def _write_frame(mesh, path: Path, snap: _Snapshot) -> None:
        """Write a VTU frame with time and sinkage as VTK field data.

        meshio's VTU writer drops ``field_data`` (its reader keeps it), so the two values go
        in as an ASCII ``FieldData`` block of the grid, where VTK and ParaView look for them.
        """
        mesh.write(path, file_format="vtu")
        arrays = "".join(f'<DataArray type="Float64" Name="{name}" NumberOfTuples="1" format="ascii">{value!r}'
                         f"</DataArray>" for name, value in (("time_s", float(snap.time_s)),
                                                               ("sinkage_m", float(snap.sinkage_m))))
        text = path.read_text()
        path.write_text(text.replace("<UnstructuredGrid>", f"<UnstructuredGrid>\n<FieldData>{arrays}</FieldData>", 1))

    def write(self, run_dir: Path) -> list[Path]:
        """Write the frames and the collection into ``run_dir``; return [fields.pvd, fields/]."""
        run_dir = Path(run_dir)
        folder = run_dir / FIELDS_DIR
        folder.mkdir(parents=True, exist_ok=True)
        frames = [(f"{FIELDS_DIR}/frame_{n:04d}.vtu", s) for n, (_, s) in enumerate(self.taken)]
        deepest = self.deepest
        same = [n for n, (_, s) in enumerate(frames) if s.time_s == deepest.time_s]
        if same:  # the deepest instant is one of the frames: it takes the name
            frames[same[0]] = (MAX_SINKAGE_FRAME, frames[same[0]][1])
        else:
            frames.append((MAX_SINKAGE_FRAME, deepest))
            frames.sort(key=lambda item: item[1].time_s)
        collection = ET.Element("VTKFile", type="Collection", version="0.1")
        datasets = ET.SubElement(collection, "Collection")
        for name, snap in frames:
            self._write_frame(self._mesh(snap), run_dir / name, snap)
            ET.SubElement(datasets, "DataSet", timestep=repr(float(snap.time_s)), part="0", file=name)
        ET.indent(collection)
        (run_dir / FIELDS_FILE).write_text(ET.tostring(collection, encoding="unicode") + "\n")
        return [run_dir / FIELDS_FILE, folder]


def written_files(run_dir: Path) -> list[Path]:
    """The field output of a job, as files to log: [fields.pvd, fields/] (none when not written)."""
    run_dir = Path(run_dir)
    pvd = run_dir / FIELDS_FILE
    return [pvd, run_dir / FIELDS_DIR] if pvd.exists() else []


def series(run_dir: Path) -> list[tuple[float, Path]]:
    """The frames listed in a job's fields.pvd: (time in s, path), in time order."""
    root = ET.parse(Path(run_dir) / FIELDS_FILE).getroot()
    return [(float(d.get("timestep")), Path(run_dir) / d.get("file")) for d in root.iter("DataSet")]


#: the penetration frame: where the body first passed this fraction of its deepest sinkage
PENETRATION_FRACTION = 0.5


def penetration_frame(run_dir: Path, history: dict[str, np.ndarray]) -> Path | None:
    """The frame nearest the time the body first passed half its travel to its deepest sinkage (None
    before any travel).

    The soil's flow shows there; at the deepest point a landing body is at rest (the study's
    Figure 3 shows the "penetration process" between the initial and the final state). The travel
    starts where the body does (a trapped-soil track's grousers have cut in).
    """
    sinkage, time_s = np.asarray(history["sinkage_m"]), np.asarray(history["time_s"])
    finite = np.isfinite(sinkage)
    if not finite.any():
        return None
    start, deepest = sinkage[finite][0], np.nanmax(sinkage)
    if deepest <= start:
        return None
    t_mid = time_s[np.argmax(finite & (sinkage >= start + PENETRATION_FRACTION * (deepest - start)))]
    frames = series(run_dir)
    return min(frames, key=lambda item: abs(item[0] - t_mid))[1]


@dataclass
class Frame:
    """One frame read back on its rectilinear grid, in the laboratory frame (m): node coordinates x,
    y (and z in 3D), cell fields (nx, ny[, nz]), nodal velocity (nx+1, ny+1[, nz+1], d) in m/s.
    ``labels``: the axes' names (a section of a 3D frame is a 2D frame whose axes are two of x, y, z)."""

    x: np.ndarray
    y: np.ndarray
    cells: dict[str, np.ndarray]
    velocity: np.ndarray
    time_s: float
    sinkage_m: float
    z: np.ndarray | None = None
    labels: tuple[str, ...] = ("x", "y")

    def section(self, normal: str) -> Frame:
        """A 3D frame's 2D section on its symmetry plane ``normal`` = 0: ``"y"`` the cross-section
        (x, z), ``"x"`` the longitudinal section (y, z). Cells: the layer beside the plane on its
        positive side; velocity: the in-plane components, the mean of that layer's two node planes.
        The in-plane horizontal axis starts at the other symmetry plane (the half a full model
        mirrors), as a 2D frame starts at its axis."""
        cut = {"x": 0, "y": 1}[normal]
        keep = 1 - cut
        planes = (self.x, self.y)
        at = int(np.argmin(np.abs(planes[cut])))
        start = int(np.argmin(np.abs(planes[keep])))
        cells = {k: np.take(v, at, axis=cut)[start:] for k, v in self.cells.items()}
        nodes = 0.5 * (np.take(self.velocity, at, axis=cut) + np.take(self.velocity, at + 1, axis=cut))
        velocity = nodes[start:][..., [keep, 2]]
        return Frame(planes[keep][start:], self.z, cells, velocity, self.time_s, self.sinkage_m,
                     labels=(self.labels[keep], self.labels[2]))


def read_frame(path: Path) -> Frame:
    """Read a frame written by :class:`FieldRecorder` (points ordered node (i, j) → i·(ny+1) + j,
    in 3D (i, j, k) → (i·(ny+1) + j)·(nz+1) + k)."""
    import meshio

    mesh = meshio.read(path)
    time_s, sinkage_m = float(mesh.field_data["time_s"][0]), float(mesh.field_data["sinkage_m"][0])
    points = mesh.points
    if mesh.cells[0].type == "hexahedron":
        x, y = np.unique(points[:, 0]), np.unique(points[:, 1])
        nz1 = points.shape[0] // (len(x) * len(y))
        z = points[:nz1, 2]
        shape = (len(x) - 1, len(y) - 1, nz1 - 1)
        cells = {name: np.asarray(data[0], dtype=float).reshape(shape) for name, data in mesh.cell_data.items()}
        velocity = np.asarray(mesh.point_data["velocity_m_s"], dtype=float).reshape(len(x), len(y), nz1, 3)
        return Frame(x, y, cells, velocity, time_s, sinkage_m, z=z, labels=("x", "y", "z"))
    x = np.unique(points[:, 0])
    ny1 = points.shape[0] // len(x)
    y = points[:ny1, 1]
    nx, ny = len(x) - 1, ny1 - 1
    cells = {name: np.asarray(data[0], dtype=float).reshape(nx, ny) for name, data in mesh.cell_data.items()}
    velocity = np.asarray(mesh.point_data["velocity_m_s"], dtype=float)[:, :2].reshape(nx + 1, ny + 1, 2)
    return Frame(x, y, cells, velocity, time_s, sinkage_m)
