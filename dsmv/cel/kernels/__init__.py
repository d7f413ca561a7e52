"""Compiled kernels of the CEL step.

- :mod:`~dsmv.cel.kernels.common`: scalar physics every dimension shares (returns, soil-law call,
  elastic energy, bulk viscosity, donor–acceptor, van Leer) and the one set of Numba flags;
- :mod:`~dsmv.cel.kernels.nodes`: node and contact stages over the flat node arrays and the
  contact table, for any number of axes;
- per dimension, named by one rule: the element kernels (forces, strains, hourglass, stress update)
  :mod:`~dsmv.cel.kernels.elements2d` and :mod:`~dsmv.cel.kernels.elements3d`, the remap sweeps
  :mod:`~dsmv.cel.kernels.remap2d` and :mod:`~dsmv.cel.kernels.remap3d`, and the compiled loops that
  call them, :mod:`dsmv.cel.stepper2d` and :mod:`dsmv.cel.stepper3d`; :func:`for_dimension` picks them.
"""

from __future__ import annotations

from typing import NamedTuple


class DimensionKernels(NamedTuple):
    """What a solver of one dimension compiles and calls; everything else (node and contact stages,
    scalar physics) is shared. ``run_steps(n, mesh, cells, faces, nodes, contact, inflow, par, body,
    energy, law)`` is the compiled loop; the rest are the reductions its trackers and set-up use."""

    run_steps: object           # the compiled loop (dsmv.cel.stepper2d, dsmv.cel.stepper3d)
    cell_volumes: object        # (node coordinates per axis[, axisymmetric in 2D]) -> cell volumes (m³)
    elastic_energy: object      # (phi, q, vol, G, K) -> stored elastic energy (J)
    hourglass_modes: object     # (corner, phi, v, full) -> Σ|hourglass mode|², Σ|linear modes|²
    shear_strain_rates: object  # (mesh, cells, faces, nodes, par, v_body) -> γ̇ per cell (1/s)
    remap: object               # the Eulerian phase (mesh, cells, faces, nodes, contact, inflow, par, body, energy, swept)


def for_dimension(dim: int) -> DimensionKernels:
    """The kernels of a ``dim``-axis grid, looked up when a solver is set up (a test may replace the
    loop in its module first)."""
    if dim == 2:
        from dsmv.cel import stepper2d
        from dsmv.cel.kernels import elements2d

        return DimensionKernels(stepper2d.run_steps, elements2d.cell_volumes, elements2d.elastic_energy,
                                elements2d.hourglass_modes, elements2d.shear_strain_rates, stepper2d.remap)
    if dim == 3:
        from dsmv.cel import stepper3d
        from dsmv.cel.kernels import elements3d

        return DimensionKernels(stepper3d.run_steps, elements3d.cell_volumes, elements3d.elastic_energy,
                                elements3d.hourglass_modes, elements3d.shear_strain_rates, stepper3d.remap)
    raise ValueError(f"no CEL element kernels for {dim} axes (2 and 3 are available)")
