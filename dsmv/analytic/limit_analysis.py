"""Rigorous bounds on the bearing factor q/su of a rigid strip on weightless Tresca soil, wished in
place with its base a depth d below a flat surface (d = 0: Prandtl's surface strip), by
finite-element limit analysis as second-order cone programmes (solved by Clarabel).

**Lower bound** (statically admissible stress; Sloan 1988, *Int. J. Numer. Anal. Meth. Geomech.*
12(1), in conic form): the stress varies linearly in each 3-node triangle and may jump across
every edge, so a fan of discontinuities can open at the footing's corner.
- equilibrium in each triangle (weightless soil: div σ = 0), the traction σ·n continuous across
  every interior edge at both its ends;
- Tresca at every corner as the exact cone √((σxx − σzz)² + (2·τxz)²) ≤ 2·su: a linear field
  that meets it at the corners meets it everywhere in the triangle (the set is convex);
- free surface: no traction; footing base and walls: no tension unless bonded, and no shear if
  smooth (a rough face carries any shear Tresca allows, and a wall's shear counts in the load);
  symmetry axis: no shear;
- beyond the mesh the field continues as constant states: (σxx, σzz, τxz) = (a, 0, 0) for every
  x > L at any depth, and (a, b, 0) below the mesh for 0 < x < L, with |a| ≤ 2·su and
  |a − b| ≤ 2·su. Every interface, the surface and the axis then check out, so the bound holds
  for the half-space, not only for the truncated mesh.

**Upper bound** (kinematically admissible velocity; Makrodimopoulos & Martin 2007, *Int. J.
Numer. Anal. Meth. Geomech.* 31(6)): the velocity is quadratic and continuous over 6-node
triangles, so the strain rate is linear in each.
- no volume change (ε̇xx + ε̇zz = 0) at the corners, hence everywhere;
- the dissipation su·√((ε̇xx − ε̇zz)² + γ̇xz²) is convex in a linear field, so its integral over a
  triangle is at most the area times its mean over the corners: charging that mean over-counts
  the dissipation, and the bound stays an upper one;
- the footing moves down at unit speed; the soil under a rough base sticks to it, under a smooth
  base it slides freely; a rough wall drags the soil with it, a smooth wall lets it slide and,
  unless bonded, part; symmetry axis: no horizontal velocity; far boundaries: at rest.

`bonded` ties the soil to the faces along their normal (no tension cut-off), as dsmv's CEL
contact does; without it the soil may part from them, as real contact allows.

Any admissible field bounds the collapse load, optimal or not: a bound is reported whenever the
solver's field meets its constraints to within FEASIBILITY_TOL, whatever its status. The bounds
are rigorous to that tolerance (a field off equilibrium or incompressibility by 1e-6 is not
strictly admissible), which moves q/su by far less than the digits reported.

The rough lower bound forbids tension on the faces, the rough upper bound bonds the soil to them:
the bracket holds for bonded rough faces (a no-tension stress field is admissible there too),
not for rough faces that can open a gap.

A pushed strip whose soil cannot pull on its walls leaves a wedge-shaped gap beside them (docs:
Verification > Strip footing, "The notch in the fields"): `notch` (see :func:`strip_mesh`) bounds that
geometry, its sloping face a free surface, σ·n = 0.

Units: lengths in B (the strip's width), stresses in su; the factor is independent of both.
``python -m dsmv.analytic.limit_analysis --help`` prints a bracket from the command line.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from dsmv.analytic.bearing import PRANDTL_NC

#: the largest constraint violation (absolute, in su or in the footing's speed, rows as built)
#: of a field still reported as a bound
FEASIBILITY_TOL = 1e-6
#: how far Prandtl's mechanism reaches from the footing's corner: its passive wedge spans B beside
#: the strip, its fan B/√2 below the base; the mesh keeps its zone cells out to here (B)
MECHANISM_REACH = 1.2
HALF_WIDTH = 0.5  # the strip's half-width (B): the mesh covers x ≥ 0, the symmetry axis at x = 0
#: how far from the wall a notch's shear of the grid fades out (B)
NOTCH_BLEND = 0.1


@dataclass(frozen=True)
class Bound:
    """A bound on q/su and what it cost."""

    kind: str  #: "lower" or "upper"
    bearing_factor: float  #: q/su (-)
    n_triangles: int
    n_variables: int
    solve_s: float  #: wall time of the cone programme (s)
    max_violation: float  #: largest constraint violation of the solver's field (FEASIBILITY_TOL's units)
    #: how the cone solver ended: "Solved" is optimal; otherwise the field still bounds, less tightly
    solver_status: str


@dataclass(frozen=True)
class Mesh:
    """Triangles of the half-domain x ∈ [0, L], z ∈ [-L, 0] without the footing (x < 1/2, z > -d)
    and the slot or the notch beside it, if any."""

    points: np.ndarray  #: (n, 2) x, z (B)
    triangles: np.ndarray  #: (m, 3) point indices, counter-clockwise
    n_grid_points: int  #: the grid's points come first, the cell centres after them
    extent: float  #: the domain's half-width and depth L (B)

    def gradients(self):
        """Twice the area (m,) and the linear shape functions' gradients ∂N/∂x, ∂N/∂z (m, 3)."""
        x, z = self.points[self.triangles][..., 0], self.points[self.triangles][..., 1]
        twice_area = (x[:, 1] - x[:, 0]) * (z[:, 2] - z[:, 0]) - (x[:, 2] - x[:, 0]) * (z[:, 1] - z[:, 0])
        dndx = np.stack([z[:, 1] - z[:, 2], z[:, 2] - z[:, 0], z[:, 0] - z[:, 1]], axis=1) / twice_area[:, None]
        dndz = np.stack([x[:, 2] - x[:, 1], x[:, 0] - x[:, 2], x[:, 1] - x[:, 0]], axis=1) / twice_area[:, None]
        return twice_area, dndx, dndz

    def edges(self) -> dict[tuple[int, int], list[tuple[int, int, int]]]:
        """(low point, high point) → the (triangle, corner at low, corner at high) that own it."""
        owners: dict[tuple[int, int], list[tuple[int, int, int]]] = {}
        for t, tri in enumerate(self.triangles):
            for k in range(3):
                p, q = int(tri[k]), int(tri[(k + 1) % 3])
                key, corners = ((p, q), (k, (k + 1) % 3)) if p < q else ((q, p), ((k + 1) % 3, k))
                owners.setdefault(key, []).append((t, *corners))
        return owners

    def boundary_kind(self, p: int, q: int) -> str:
        """Which boundary the edge p–q lies on: axis, far, surface (free, also a slot's), base or wall."""
        (xp, zp), (xq, zq) = self.points[p], self.points[q]
        x_mid, z_mid = 0.5 * (xp + xq), 0.5 * (zp + zq)
        tol = 1e-9
        if abs(xq - xp) < tol:  # vertical
            if x_mid < tol:
                return "axis"
            if x_mid > self.extent - tol:
                return "far"
            return "wall" if abs(x_mid - HALF_WIDTH) < tol else "surface"
        if z_mid < -self.extent + tol:
            return "far"
        return "surface" if x_mid > HALF_WIDTH else "base"


def _graded(start: float, stop: float, fine_size: float, growth: float, zone_size: float, zone_length: float,
            coarse_size: float) -> np.ndarray:
    """Points from start to stop (either order): fine_size at start, growing by `growth` per cell,
    at most zone_size within zone_length of start and coarse_size beyond; the last cell is
    stretched or shrunk to land on stop."""
    length = abs(stop - start)
    direction = 1.0 if stop > start else -1.0
    offsets = [0.0]
    size = fine_size
    while offsets[-1] + size < length - 0.5 * size:
        offsets.append(offsets[-1] + size)
        size = min(size * growth, zone_size if offsets[-1] < zone_length else coarse_size)
    offsets.append(length)
    return start + direction * np.asarray(offsets)


def notch_allowed(depth: float, gap: float, notch: float) -> bool:
    """Whether :func:`strip_mesh` can open a notch this wide (B): none, or one narrower than
    NOTCH_BLEND / 2 beside a wall that exists (depth > 0) and has no slot."""
    return notch == 0.0 or (0.0 < notch < 0.5 * NOTCH_BLEND and depth > 0.0 and gap == 0.0)


def _diagonal_crossings(quads: np.ndarray) -> np.ndarray:
    """Where the diagonals 0–2 and 1–3 of each quadrilateral (m, 4, 2) cross (m, 2)."""
    p0, p1, p2, p3 = (quads[:, k] for k in range(4))
    d02, d13, r = p2 - p0, p3 - p1, p1 - p0
    cross = d02[:, 0] * d13[:, 1] - d02[:, 1] * d13[:, 0]
    t = (r[:, 0] * d13[:, 1] - r[:, 1] * d13[:, 0]) / cross
    return p0 + t[:, None] * d02


def strip_mesh(depth: float, extent: float = 3.0, corner_size: float = 0.01, growth: float = 1.2,
               zone_size: float = 0.05, coarse_size: float = 0.5, gap: float = 0.0, notch: float = 0.0) -> Mesh:
    """A rectilinear grid graded towards the base corner (1/2, -d), its cells no larger than
    zone_size over Prandtl's mechanism (out to MECHANISM_REACH from the corner), each cell split
    into four triangles at its centre; `gap` leaves a soil-free slot of that width beside the
    wall, down to the base. `notch` opens a wedge-shaped gap instead, from nothing at the base
    corner to that width at the surface: the grid beside the wall is sheared away from it, the
    shift fading out over NOTCH_BLEND. Sizes in B."""
    if not notch_allowed(depth, gap, notch):
        raise ValueError(f"a notch (here {notch}) needs a depth > 0, no slot, and a width below {0.5 * NOTCH_BLEND} B")
    xs = np.unique(np.concatenate([[HALF_WIDTH + gap],
        _graded(HALF_WIDTH, 0.0, corner_size, growth, zone_size, HALF_WIDTH, coarse_size),
        _graded(HALF_WIDTH, extent, corner_size, growth, zone_size, MECHANISM_REACH, coarse_size),
    ]))
    z_parts = [_graded(-depth, -extent, corner_size, growth, zone_size, MECHANISM_REACH, coarse_size)]
    if depth > 0.0:
        z_parts.append(_graded(-depth, 0.0, corner_size, growth, zone_size, depth, coarse_size))
    zs = np.unique(np.concatenate(z_parts))
    nx, nz = len(xs), len(zs)
    grid_index = np.arange(nx * nz).reshape(nz, nx)
    x_mid, z_mid = np.meshgrid(0.5 * (xs[:-1] + xs[1:]), 0.5 * (zs[:-1] + zs[1:]))
    keep = ~((x_mid < HALF_WIDTH + gap) & (z_mid > -depth))  # not inside the footing or its slot
    j, i = np.nonzero(keep)
    centres = nx * nz + np.arange(len(i))
    corners = np.stack([grid_index[j, i], grid_index[j, i + 1], grid_index[j + 1, i + 1], grid_index[j + 1, i]], axis=1)
    triangles = np.concatenate([np.stack([corners[:, k], corners[:, (k + 1) % 4], centres], axis=1) for k in range(4)])
    points = np.vstack([np.column_stack([np.tile(xs, nz), np.repeat(zs, nx)]),
                        np.column_stack([x_mid[keep], z_mid[keep]])])
    if notch > 0.0:  # shear the soil beside the wall away from it: x += w(z)·fade(x)
        x, z = points[:, 0], points[:, 1]
        beside = (x >= HALF_WIDTH - 1e-12) & (z > -depth)
        fade = np.clip(1.0 - (x - HALF_WIDTH) / NOTCH_BLEND, 0.0, 1.0)
        points[beside, 0] += (notch * (z + depth) / depth * fade)[beside]
        # each centre back onto its sheared cell's diagonals: the lower bound drops one traction
        # condition per centre, implied by the others only where the four triangles meet along
        # two straight lines
        points[nx * nz:] = _diagonal_crossings(points[corners])
    return Mesh(points, triangles.astype(np.int64), nx * nz, float(extent))


class _ConeProgram:
    """min c·x subject to sparse rows: equalities (= 0 or = rhs), inequalities (≤ rhs) and 3-cones
    (t, u, w) with t ≥ √(u² + w²), each cone entry an affine function of x."""

    def __init__(self, n_var: int):
        self.n_var = n_var
        self.objective = np.zeros(n_var)
        self._blocks = {"eq": ([], [], [], []), "le": ([], [], [], [])}
        self._rows = {"eq": 0, "le": 0}
        self._cones: list[tuple[list, list, list, float]] = []  # (t, u, w terms, t's constant)

    def add(self, kind: str, terms, rhs=0.0):
        """Rows Σ value·x[col] (= or ≤) rhs, vectorised: each term is (cols, values) with one entry per row."""
        n_rows = len(np.atleast_1d(terms[0][0]))
        rows, cols, vals, rhss = self._blocks[kind]
        for col, val in terms:
            rows.append(self._rows[kind] + np.arange(n_rows))
            cols.append(np.atleast_1d(col))
            vals.append(np.broadcast_to(val, (n_rows,)).astype(float))
        rhss.append(np.broadcast_to(rhs, (n_rows,)).astype(float))
        self._rows[kind] += n_rows

    def add_cones(self, t_terms, u_terms, w_terms, t_constant=0.0):
        """n cones (t, u, w): each argument a list of (cols (n,), values (n,)); t adds t_constant."""
        self._cones.append((t_terms, u_terms, w_terms, t_constant))

    def matrix(self, kind: str):
        """The rows of one kind ("eq" or "le") as a sparse matrix, and their right-hand sides."""
        rows, cols, vals, rhss = self._blocks[kind]
        if not rows:
            return sp.csr_matrix((0, self.n_var)), np.zeros(0)
        matrix = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                               shape=(self._rows[kind], self.n_var))
        return matrix, np.concatenate(rhss)

    def solve(self):
        """Returns (x, its largest constraint violation, solve time s, the solver's status)."""
        import clarabel  # the cone solver is needed only here

        a_eq, b_eq = self.matrix("eq")
        a_le, b_le = self.matrix("le")
        cone_rows, cone_cols, cone_vals, cone_rhs = [], [], [], []
        n_cone_rows = 0
        for t_terms, u_terms, w_terms, t_constant in self._cones:
            n = len(np.atleast_1d(t_terms[0][0]))
            base = n_cone_rows + 3 * np.arange(n)
            for offset, terms in enumerate((t_terms, u_terms, w_terms)):
                for col, val in terms:  # Clarabel's s = b - A·x lies in the cone: A = -(affine part)
                    cone_rows.append(base + offset)
                    cone_cols.append(np.atleast_1d(col))
                    cone_vals.append(-np.broadcast_to(val, (n,)).astype(float))
            rhs = np.zeros(3 * n)
            rhs[0::3] = t_constant
            cone_rhs.append(rhs)
            n_cone_rows += 3 * n
        a_cone = sp.csr_matrix((np.concatenate(cone_vals), (np.concatenate(cone_rows), np.concatenate(cone_cols))),
                               shape=(n_cone_rows, self.n_var))
        b_cone = np.concatenate(cone_rhs)
        settings = clarabel.DefaultSettings()
        settings.verbose = False
        start = time.perf_counter()
        solver = clarabel.DefaultSolver(
            sp.csc_matrix((self.n_var, self.n_var)), self.objective,
            sp.vstack([a_eq, a_le, a_cone], format="csc"), np.concatenate([b_eq, b_le, b_cone]),
            [clarabel.ZeroConeT(len(b_eq)), clarabel.NonnegativeConeT(len(b_le))]
            + [clarabel.SecondOrderConeT(3)] * (n_cone_rows // 3), settings)
        solution = solver.solve()
        solve_s = time.perf_counter() - start
        x = np.asarray(solution.x)
        cone = (b_cone - a_cone @ x).reshape(-1, 3)
        violation = max(
            float(np.abs(a_eq @ x - b_eq).max(initial=0.0)),
            float((a_le @ x - b_le).max(initial=0.0)),
            float((np.hypot(cone[:, 1], cone[:, 2]) - cone[:, 0]).max(initial=0.0)),
        )
        if not violation <= FEASIBILITY_TOL:
            raise RuntimeError(f"the cone programme ended {solution.status} with a field that breaks its constraints "
                               f"by {violation:.2e} (allowed {FEASIBILITY_TOL:.0e}); try another mesh "
                               "(corner_size, growth)")
        return x, violation, solve_s, str(solution.status)


def corner_strength(mesh: Mesh, gradient: float) -> np.ndarray:
    """su/su0 at every triangle corner, (n_tri, 3): su = su0 + k·z below the surface z = 0, with
    ``gradient`` = k·B/su0 (lengths in B)."""
    depth = np.maximum(-mesh.points[mesh.triangles][..., 1], 0.0)
    return 1.0 + gradient * depth


def strip_lower_bound(depth_over_width: float = 0.0, rough: bool = True, bonded: bool = False,
                      strength_gradient: float = 0.0, **mesh_options) -> Bound:
    """Lower bound on q/su0 of a strip, base at depth_over_width·B below the surface; `rough`: base
    and walls take shear (up to su), else neither does; `bonded`: they take tension too;
    `strength_gradient`: k·B/su0 of su = su0 + k·z. mesh_options go to :func:`strip_mesh`."""
    mesh = strip_mesh(_checked_depth(depth_over_width), **mesh_options)
    program = _lower_bound_program(mesh, rough, bonded, _checked_gradient(strength_gradient))
    # base: minimise Σ σzz (compression is negative); wall: maximise the soil's upward shear τ
    stress, violation, solve_s, status = program.solve()
    return Bound("lower", float(-program.objective @ stress), len(mesh.triangles), program.n_var, solve_s, violation,
                 status)


def _lower_bound_program(mesh: Mesh, rough: bool, bonded: bool, gradient: float = 0.0) -> _ConeProgram:
    """The lower bound's cone programme on `mesh` (see the module's docstring); stresses in su0.
    With su growing linearly with depth, Tresca holds at each corner with that corner's su: a linear
    stress field under a convex yield function meets the linear su(z) everywhere in the triangle."""
    n_tri = len(mesh.triangles)
    sxx, szz, txz = 0, 1, 2

    def var(tri, corner, comp):
        return (tri * 3 + corner) * 3 + comp

    program = _ConeProgram(n_tri * 9)
    tri = np.arange(n_tri)
    _, dndx, dndz = mesh.gradients()
    # equilibrium: ∂σxx/∂x + ∂τ/∂z = 0 and ∂τ/∂x + ∂σzz/∂z = 0
    program.add("eq", [(var(tri, i, sxx), dndx[:, i]) for i in range(3)] + [(var(tri, i, txz), dndz[:, i]) for i in range(3)])
    program.add("eq", [(var(tri, i, txz), dndx[:, i]) for i in range(3)] + [(var(tri, i, szz), dndz[:, i]) for i in range(3)])
    corner = np.arange(n_tri * 3)
    program.add_cones([(corner * 3 + sxx, 0.0)], [(corner * 3 + sxx, 1.0), (corner * 3 + szz, -1.0)],
                      [(corner * 3 + txz, 2.0)], t_constant=2.0 * corner_strength(mesh, gradient).ravel())

    relieved: set[int] = set()
    far_right: list[tuple[float, int]] = []  # (z, σxx variable) of the corners on x = L
    far_bottom: list[tuple[float, int]] = []  # (x, σzz variable) of the corners on z = -L
    for (p, q), owners in mesh.edges().items():
        (xp, zp), (xq, zq) = mesh.points[p], mesh.points[q]
        length = float(np.hypot(xq - xp, zq - zp))
        nx, nz = (zq - zp) / length, -(xq - xp) / length  # a unit normal (its sign is irrelevant)
        if len(owners) == 2:  # interior: the traction σ·n is continuous at both ends
            (t1, a1, b1), (t2, a2, b2) = owners
            for point, c1, c2 in ((p, a1, a2), (q, b1, b2)):
                program.add("eq", [(var(t1, c1, sxx), nx), (var(t1, c1, txz), nz), (var(t2, c2, sxx), -nx), (var(t2, c2, txz), -nz)])
                # A cell centre joins four triangles across two straight lines; there the jumps
                # round the node leave one of the eight conditions implied by the other seven.
                # Dropping it keeps the equalities independent (the solver needs full rank).
                if point >= mesh.n_grid_points and point not in relieved:
                    relieved.add(point)
                    continue
                program.add("eq", [(var(t1, c1, txz), nx), (var(t1, c1, szz), nz), (var(t2, c2, txz), -nx), (var(t2, c2, szz), -nz)])
            continue
        (t, cp, cq), = owners
        kind = mesh.boundary_kind(p, q)
        vertical = abs(xq - xp) < 1e-9
        normal_stress, shear = (sxx, txz) if vertical else (szz, txz)
        for c, (x_end, z_end) in ((cp, (xp, zp)), (cq, (xq, zq))):
            if kind == "surface":  # no traction, σ·n = 0, on any slope (a notch's face)
                program.add("eq", [(var(t, c, sxx), nx), (var(t, c, txz), nz)])
                program.add("eq", [(var(t, c, txz), nx), (var(t, c, szz), nz)])
                continue
            if kind in ("axis", "far") or (kind in ("base", "wall") and not rough):
                program.add("eq", [(var(t, c, shear), 1.0)])
            if kind in ("base", "wall"):  # the soil holds the footing up
                if not bonded:  # no tension
                    program.add("le", [(var(t, c, normal_stress), 1.0)])
                program.objective[var(t, c, normal_stress if kind == "base" else txz)] += \
                    0.5 * length / HALF_WIDTH * (1.0 if kind == "base" else -1.0)
            if kind == "far":
                (far_right if vertical else far_bottom).append(
                    (z_end, var(t, c, sxx)) if vertical else (x_end, var(t, c, szz)))
    # The far field's two constant states: one σxx = a along the right edge, one σzz = b along the
    # bottom, chained neighbour to neighbour (a shared variable would tie every boundary node
    # together and fill the solver's factor); then Tresca for them, |a| ≤ 2 and |a - b| ≤ 2,
    # with a and b read at the bottom right corner (su ≥ su0 everywhere: with strength growing
    # with depth these are conservative).
    for chain in (sorted(far_right), sorted(far_bottom)):
        for (_, first), (_, second) in zip(chain[:-1], chain[1:]):
            program.add("eq", [(first, 1.0), (second, -1.0)])
    var_a, var_b = sorted(far_right)[0][1], sorted(far_bottom)[-1][1]
    for terms in ([(var_a, 1.0)], [(var_a, -1.0)], [(var_a, 1.0), (var_b, -1.0)], [(var_a, -1.0), (var_b, 1.0)]):
        program.add("le", terms, rhs=2.0)

    return program


def strip_upper_bound(depth_over_width: float = 0.0, rough: bool = True, bonded: bool = False,
                      strength_gradient: float = 0.0, **mesh_options) -> Bound:
    """Upper bound on q/su0 of a strip, base at depth_over_width·B below the surface; `rough`: the
    soil sticks to base and walls, else it slides along them; `bonded`: it cannot part from a wall;
    `strength_gradient`: k·B/su0 of su = su0 + k·z. mesh_options go to :func:`strip_mesh`."""
    mesh = strip_mesh(_checked_depth(depth_over_width), **mesh_options)
    gradient = _checked_gradient(strength_gradient)
    n_tri = len(mesh.triangles)
    edges = mesh.edges()
    midside = {key: len(mesh.points) + n for n, key in enumerate(edges)}  # the 6-node triangles' midside nodes
    n_nodes = len(mesh.points) + len(midside)
    # each triangle's six nodes: corners 0, 1, 2, then midsides 01, 12, 20
    nodes = np.empty((n_tri, 6), dtype=np.int64)
    nodes[:, :3] = mesh.triangles
    for k in range(3):
        a, b = mesh.triangles[:, k], mesh.triangles[:, (k + 1) % 3]
        nodes[:, 3 + k] = [midside[(min(p, q), max(p, q))] for p, q in zip(a, b)]

    def ux(node):
        return 2 * node

    def uz(node):
        return 2 * node + 1

    n_velocity = 2 * n_nodes
    dissipation = n_velocity + np.arange(n_tri * 3)  # one variable per triangle corner: √(..)
    program = _ConeProgram(n_velocity + n_tri * 3)
    twice_area, dndx, dndz = mesh.gradients()
    # ∫ su·D over a triangle, D the dissipation rate per unit su (convex in a linear strain rate, so
    # D ≤ Σ Lk·Dk) and su = Σ Lk·suk linear: ≤ Σ Dk·∫ su·Lk = Σ Dk·A·(Σ su + suk)/12 (su0 = 1,
    # speed 1); for uniform su each corner weighs A/3
    su = corner_strength(mesh, gradient)
    weight = 0.5 * twice_area[:, None] * (su.sum(axis=1, keepdims=True) + su) / 12.0
    program.objective[dissipation] = weight.ravel() / HALF_WIDTH
    for k in range(3):  # the strain rate at corner k: ∂N/∂x of the quadratic shape functions there
        grad_x, grad_z = np.zeros((n_tri, 6)), np.zeros((n_tri, 6))
        for i in range(3):  # corner i: N = L(2L - 1), ∂N/∂L = 4L - 1
            grad_x[:, i] = (4.0 * (i == k) - 1.0) * dndx[:, i]
            grad_z[:, i] = (4.0 * (i == k) - 1.0) * dndz[:, i]
        for m in range(3):  # midside (i, j): N = 4·Li·Lj
            i, j = m, (m + 1) % 3
            grad_x[:, 3 + m] = 4.0 * ((j == k) * dndx[:, i] + (i == k) * dndx[:, j])
            grad_z[:, 3 + m] = 4.0 * ((j == k) * dndz[:, i] + (i == k) * dndz[:, j])
        exx = [(ux(nodes[:, n]), grad_x[:, n]) for n in range(6)]
        ezz = [(uz(nodes[:, n]), grad_z[:, n]) for n in range(6)]
        program.add("eq", exx + ezz)  # no volume change
        program.add_cones([(dissipation[k::3], 1.0)], exx + [(col, -val) for col, val in ezz],
                          [(ux(nodes[:, n]), grad_z[:, n]) for n in range(6)] + [(uz(nodes[:, n]), grad_x[:, n]) for n in range(6)])

    for (p, q), owners in edges.items():
        if len(owners) == 2:
            continue
        kind = mesh.boundary_kind(p, q)
        for node in (p, q, midside[(p, q)]):
            if kind == "far":
                program.add("eq", [(ux(node), 1.0)])
                program.add("eq", [(uz(node), 1.0)])
            elif kind == "axis":
                program.add("eq", [(ux(node), 1.0)])
            elif kind == "base":
                program.add("eq", [(uz(node), 1.0)], rhs=-1.0)
                if rough:
                    program.add("eq", [(ux(node), 1.0)])
            elif kind == "wall":
                if rough:
                    program.add("eq", [(ux(node), 1.0)])
                    program.add("eq", [(uz(node), 1.0)], rhs=-1.0)
                elif bonded:  # the soil slides along it
                    program.add("eq", [(ux(node), 1.0)])
                elif node != midside[(p, q)]:  # the soil may slide along it, or part, but not enter
                    program.add("le", [(ux(node), -1.0)])
        if kind == "wall" and not rough and not bonded:
            # ux ≥ 0 at the nodes would let the quadratic dip between them; ux ≥ 0 at the ends and
            # its Bernstein control value 2·u_mid − (u_p + u_q)/2 ≥ 0 keep it ≥ 0 all along
            program.add("le", [(ux(midside[(p, q)]), -2.0), (ux(p), 0.5), (ux(q), 0.5)])
    x, violation, solve_s, status = program.solve()
    return Bound("upper", float(program.objective @ x), n_tri, program.n_var, solve_s, violation, status)


def _checked_gradient(gradient: float) -> float:
    if not gradient >= 0.0:
        raise ValueError(f"strength gradient k·B/su0 = {gradient}: must be ≥ 0 (strength that grows with depth)")
    return float(gradient)


def _checked_depth(depth_over_width: float) -> float:
    if not depth_over_width >= 0.0:
        raise ValueError(f"depth_over_width must be ≥ 0 (the base's depth over the strip's width), got {depth_over_width}")
    return float(depth_over_width)


def main(argv=None) -> None:
    """Print the bracket on q/su for one strip."""
    parser = argparse.ArgumentParser(prog="python -m dsmv.analytic.limit_analysis", description=main.__doc__,
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--depth", type=float, default=0.0, help="the base's depth below the surface, in B")
    parser.add_argument("--roughness", choices=("rough", "smooth"), default="rough",
                        help="rough: base and walls take shear up to su; smooth: none")
    parser.add_argument("--bonded", action="store_true", help="the soil cannot part from base and walls (as in dsmv's CEL)")
    parser.add_argument("--gradient", type=float, default=0.0,
                        help="k·B/su0: strength growing with depth, su = su0 + k·z (Davis & Booker 1973)")
    parser.add_argument("--corner-size", type=float, default=0.01, help="cells at the base corner, in B")
    parser.add_argument("--growth", type=float, default=1.2, help="size ratio of neighbouring cells")
    parser.add_argument("--zone-size", type=float, default=0.05, help="largest cells over the mechanism, in B")
    parser.add_argument("--gap", type=float, default=0.0,
                        help="width of a soil-free slot beside the wall, down to the base, in B")
    parser.add_argument("--notch", type=float, default=0.0,
                        help="width at the surface of a wedge-shaped gap beside the wall, closed at the base corner, in B")
    args = parser.parse_args(argv)
    for name, value, allowed in (("--depth", args.depth, args.depth >= 0.0),
                                 ("--gradient", args.gradient, args.gradient >= 0.0),
                                 ("--corner-size", args.corner_size, args.corner_size > 0.0),
                                 ("--growth", args.growth, args.growth >= 1.0),
                                 ("--zone-size", args.zone_size, args.zone_size >= args.corner_size),
                                 ("--gap", args.gap, args.gap >= 0.0),
                                 ("--notch", args.notch, notch_allowed(args.depth, args.gap, args.notch))):
        if not allowed:
            parser.error(f"{name} {value}: allowed are a depth ≥ 0, a gradient ≥ 0, a corner size > 0, a growth ≥ 1, "
                         f"a zone size ≥ the corner size, a gap ≥ 0, and a notch in [0, {0.5 * NOTCH_BLEND:g}) "
                         "that needs a depth > 0 and no gap (lengths in B)")
    mesh_options = dict(corner_size=args.corner_size, growth=args.growth, zone_size=args.zone_size, gap=args.gap,
                        notch=args.notch)
    print(f"q/su0 of a strip whose base lies {args.depth:g} B deep, {args.roughness}"
          + (f", su = su0 + k·z with k·B/su0 = {args.gradient:g}" if args.gradient > 0 else "")
          + (", soil bonded to base and walls" if args.bonded else "")
          + (f", a soil-free slot {args.gap:g} B wide beside the wall" if args.gap > 0 else "")
          + (f", a wedge-shaped gap {args.notch:g} B wide at the surface beside the wall" if args.notch > 0 else "")
          + f"; Prandtl's 2 + π = {PRANDTL_NC:.4f}", flush=True)
    for bound in (strip_lower_bound, strip_upper_bound):
        result = bound(args.depth, args.roughness == "rough", args.bonded, args.gradient, **mesh_options)
        print(f"{result.kind:5s} bound  q/su0 = {result.bearing_factor:.4f}   ({result.n_triangles} triangles, "
              f"{result.solve_s:.1f} s, constraints met to {result.max_violation:.1e}, solver {result.solver_status})",
              flush=True)


if __name__ == "__main__":
    main()
