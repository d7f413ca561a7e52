"""The CEL model's starting point: elastic constants, the geostatic soil state, packed parameters.

One home for what the solver and the verification cases (dsmv.cel.checks2d) both set up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dsmv.cel.kernels.common import soil_column
from dsmv.cel.layout import CellRows, Params, freedom_mask
from dsmv.config.profile import straight_line


@dataclass(frozen=True)
class Elastic:
    """Isotropic elasticity of the soil: shear and bulk moduli (Pa), P-wave speed (m/s), K0 (-)."""

    shear_pa: float
    bulk_pa: float
    wave_speed_m_s: float
    k0: float

    @classmethod
    def of(cls, soil, density_kg_m3: float | None = None) -> "Elastic":
        """The soil's, its waves through ``density_kg_m3`` (default the soil's density)."""
        E, nu = soil.youngs_modulus_pa, soil.poisson_ratio
        rho = soil.density_kg_m3 if density_kg_m3 is None else density_kg_m3
        shear, bulk = E / (2 * (1 + nu)), E / (3 * (1 - 2 * nu))
        # K0 = ν/(1 − ν): the at-rest ratio of an elastic soil loaded one-dimensionally by its weight
        return cls(shear, bulk, math.sqrt((bulk + 4 * shear / 3) / rho), nu / (1 - nu))


def layers_below(up: np.ndarray, mudline: float) -> tuple[np.ndarray, np.ndarray]:
    """Per layer of cells between the node coordinates ``up`` (m, upwards): the fraction below the
    mudline (one the mudline crosses is filled in part) and the depth of that soil's centroid (m)."""
    size = np.diff(up)
    fill = np.clip((mudline - up[:-1]) / size, 0.0, 1.0)
    depth = np.where(fill >= 1.0, mudline - 0.5 * (up[1:] + up[:-1]), 0.5 * fill * size)
    return fill, depth


def geostatic_state(grid, density: float, gravity: float, k0: float, mudline: float, open_frac=None,
                    sideways: tuple[float, float] = (0.0, 0.0), layers=None):
    """Soil below the mudline (``mudline`` m up the last axis) and outside the body, at rest under its
    weight, on a grid of any number of axes (the last one up).

    A cell the mudline cuts holds just the soil below it; a cell the body cuts, just the soil
    in its ``open_frac`` (the cells' shape; default all open).

    Returns φ and the transported state q (the :class:`~dsmv.cel.layout.CellRows` base rows, then the
    cells' shape): the vertical stress −ρ'·g·depth, the horizontal ones K0 times it, z0 = depth (m), ξ = 0.
    A soil whose density is layered (``layers``, :class:`~dsmv.config.profile.DensityLayers`; ``density`` its
    lightest) weighs its weighing depth, not its depth: −ρ'·g·w(depth).
    On a sloping seabed (``sideways``: gravity along x and y, m/s²; ``gravity`` its part down the normal)
    an infinite slope: the shear on the planes along the seabed ρ'·g_x·depth and ρ'·g_y·depth, which
    equilibrium ∂σ_xz/∂z + ρ'·g_x = 0 asks with no traction at the mudline.
    """
    axes = grid.axes
    shape = tuple(len(a) - 1 for a in axes)
    rows = CellRows(len(axes))
    fill, depth = layers_below(axes[-1], mudline)
    phi = np.broadcast_to(fill, shape).copy()
    if open_frac is not None:
        phi = phi * open_frac
    q = np.zeros((rows.base, *shape))
    vertical, horizontal, other, z0 = rows.geostatic
    weighed = depth if layers is None else layered_columns(axes[-1], mudline, layers)[0]
    q[vertical] = -density * gravity * weighed * phi
    q[horizontal] = k0 * q[vertical]
    q[other] = k0 * q[vertical]
    q[z0] = depth * phi
    # the shear of the layer the mudline cuts over the layer's fill squared (σ·φ over its fill): the one-point
    # forces carry φ·σ, and so its soil's weight along the slope rests on the node row below it (set as the
    # normal stresses are, σ·φ, a slope's soil at rest moved at 5e-4 m/s there; so, 8e-6 m/s, as level
    # soil's does); the cells the body cuts below it take σ·φ, as their normal stresses do
    layer_fill = np.broadcast_to(np.where(fill > 0.0, fill, 1.0), shape)
    for row, g in zip(rows.slope_shear, sideways):
        if g != 0.0:
            q[row] = density * g * weighed * phi / layer_fill**2
    return phi, q


def layered_columns(up: np.ndarray, mudline: float, layers) -> tuple[np.ndarray, np.ndarray]:
    """Per layer of cells between the node coordinates ``up`` (:func:`layers_below`), in a soil whose density is
    layered (:class:`~dsmv.config.profile.DensityLayers`): its soil's weighing depth and mean density over the
    lightest layer's (:func:`~dsmv.cel.kernels.common.soil_column`)."""
    top = np.clip(mudline - up[1:], 0.0, None)     # depth of the soil's top and bottom in each layer of cells
    bottom = np.maximum(mudline - up[:-1], top)
    columns = [soil_column(layers.top, layers.intercept, layers.ratio, t, b) for t, b in zip(top, bottom)]
    return np.array([c[0] for c in columns]), np.array([c[1] for c in columns])


def density_ratios(grid, mudline: float, layers, phi) -> np.ndarray:
    """A layered soil's density row of q (:attr:`~dsmv.cel.layout.Params.density_row`): in each cell with soil,
    its soil's mean density over the lightest layer's (:func:`layered_columns`)."""
    ratio = layered_columns(grid.axes[-1], mudline, layers)[1]
    return np.where(phi > 0.0, np.broadcast_to(ratio, phi.shape), 0.0)


#: Params fields a caller may leave out, and their values
PARAM_DEFAULTS = {"body_mass": 1.0, "body_weight": 0.0, "push_velocity": 0.0, "skip_void": True, "separation": False}


def step_parameters(*, elastic: Elastic, h: float, remap_courant: float = 0.0, **fields) -> Params:
    """The step's :class:`~dsmv.cel.layout.Params` from the soil's elasticity, the core cell size h
    (m) and the other fields by name (:data:`PARAM_DEFAULTS` for those left out). Derived here: the
    elastic constants, the empty-node mass floor, and the remap's trigger (``remap_courant``: the
    remap runs once the soil has moved this fraction of h through the grid; 0: every step)."""
    fields = PARAM_DEFAULTS | fields
    switches = ("axisymmetric", "drop", "inflow", "remap", "tresca", "law_active", "skip_void", "separation")
    fields |= {k: bool(fields[k]) for k in switches} | {"advection_order": int(fields["advection_order"])}
    # a landing's body falls free: the vertical is one of its integrated freedoms
    fields["free"] = int(fields.get("free", 0)) | (freedom_mask("z") if fields["drop"] else 0)
    # the intact strength: a table's segments, else the straight line su0 + ks·z0 as one
    strength = fields.pop("strength", None) or straight_line(fields["su0"], fields["ks"])
    if (density := fields.pop("density_layers", None)) is not None:  # a layered soil's, beside its density row
        fields |= {"density_top": np.ascontiguousarray(density.top, dtype=float),
                   "density_ratio": np.ascontiguousarray(density.ratio, dtype=float),
                   "density_intercept": np.ascontiguousarray(density.intercept, dtype=float)}
    fields |= {"strength_depth": np.ascontiguousarray(strength.depth, dtype=float),
               "strength_intercept": np.ascontiguousarray(strength.intercept, dtype=float),
               "strength_slope": np.ascontiguousarray(strength.slope, dtype=float)}
    return Params(
        shear=elastic.shear_pa, bulk=elastic.bulk_pa, wave_speed=elastic.wave_speed_m_s, k0=elastic.k0,
        mass_floor=1e-9 * fields["density"] * h * h,  # nodes lighter than this are empty
        phi_min=1e-9,  # cells with less soil give none
        remap_travel=remap_courant * h, cell_size=h, **fields,
    )


def hourglass_factor(open_frac: np.ndarray, region: str) -> np.ndarray:
    """Per cell, the factor on the hourglass coefficient: 1 where the viscous hourglass force acts, 0
    where it does not (``solver.hourglass_region``; any number of axes).

    The force damps the zig-zag the one-point rule cannot see, but it also resists the soil's real
    flow. Flat and staircase faces need none: without it the smooth strip on soil whose strength
    grows with depth reads +2.5 % instead of +5.9 % at B/40, the smooth circular plate +0.9 % instead
    of +2.8 %. A curved body's cut cells do (the smooth T-bar reads 8.60 without any, 8.74 with it in
    the cells it cuts and their neighbours). ``cut_cells`` keeps it there (docs/decisions/0016).
    Fixed in index space: the grid moves with the body, and so do its cut cells.
    """
    if region == "everywhere":
        return np.ones(open_frac.shape)
    cut = (open_frac > 0.0) & (open_frac < 1.0)
    return dilated(cut).astype(float)


def dilated(mask: np.ndarray) -> np.ndarray:
    """A boolean mask grown by one cell in every direction, diagonals included (the 3×3… cube),
    nothing beyond the edges: one pass along each axis, since the cube is their product."""
    grown = mask.copy()
    for axis in range(mask.ndim):
        ahead = [slice(None)] * mask.ndim
        behind = [slice(None)] * mask.ndim
        ahead[axis], behind[axis] = slice(1, None), slice(None, -1)
        step = grown.copy()
        step[tuple(ahead)] |= grown[tuple(behind)]
        step[tuple(behind)] |= grown[tuple(ahead)]
        grown = step
    return grown


def body_free_state(x, y, phi, q, vol):
    """The containers of soil on a 2D grid with no body (verification cases, kernel tests): mesh,
    cells, faces, nodes (at rest), a contact with no ties and the grid's boundary conditions, and a
    closed base (no inflow)."""
    from dsmv.cel.contact import fixed_velocities
    from dsmv.cel.grid import Openings
    from dsmv.cel.layout import Cells, Contact, Faces2D, Inflow, Mesh2D, Nodes, structured_corners

    nx, ny = phi.shape
    n_nodes = (nx + 1) * (ny + 1)
    none = np.zeros(0, dtype=np.int64)
    fixed_node, fixed_axis = fixed_velocities((nx + 1, ny + 1))
    open_cells = Openings.of_cells(np.zeros((nx, ny), dtype=bool))
    return (
        Mesh2D(np.asarray(x, float), np.asarray(y, float), vol, structured_corners((nx, ny)), n_nodes,
             np.zeros((nx, ny), dtype=np.bool_)),
        Cells(phi, q, np.zeros((nx, ny)), np.ones((nx, ny)), np.zeros((nx, ny), dtype=np.bool_), np.ones((nx, ny)),
              np.zeros((nx, ny), dtype=np.bool_), np.full((nx, ny), np.nan), np.ones((nx, ny))),
        Faces2D(open_cells.aperture_x, open_cells.aperture_y, np.zeros((nx + 1, ny)), np.zeros((ny + 1, nx))),
        Nodes(np.zeros((2, n_nodes)), np.zeros((2, n_nodes)), np.zeros(n_nodes), np.zeros((2, n_nodes))),
        Contact(none, none.astype(np.bool_), np.zeros((0, 2)), np.zeros(0), np.zeros(1, dtype=np.int64),
                np.zeros((0, 2), dtype=np.int64), np.zeros(0), none, none, fixed_node, fixed_axis,
                np.zeros((0, 4), dtype=np.int64), np.zeros((0, 2)), np.zeros(0)),
        Inflow(np.zeros((q.shape[0], nx)), np.zeros(nx)),
    )


def weighed_soil(cells, mesh, par) -> np.ndarray:
    """Each cell's soil as the volume of soil of ``par.density`` as heavy (m³): φ·V, times the cell's density
    row in a layered soil; ``par.density`` times it is the cell's soil mass (kg)."""
    soil = cells.phi * mesh.vol
    return soil if par.density_row < 0 else soil * cells.q[par.density_row]
