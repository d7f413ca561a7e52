"""Compiled kernels of the CEL step.

- :mod:`~dsmv.cel.kernels.common`: scalar physics every dimension shares (returns, soil-law call,
  elastic energy, donor–acceptor, van Leer) and the one set of Numba flags;
- :mod:`~dsmv.cel.kernels.nodes`: node and contact stages over the flat node arrays and the
  contact table, for any number of axes;
- per dimension, the element kernels (forces, strains, hourglass, stress update) and the remap
  sweeps: :mod:`~dsmv.cel.kernels.plane` and :mod:`~dsmv.cel.kernels.remap2d` for 2D, with the
  compiled loop that calls them (:mod:`dsmv.cel.stepper`), :mod:`~dsmv.cel.kernels.hexahedra` for
  3D with its loop (:mod:`dsmv.cel.stepper3d`); :func:`for_dimension` picks them.
"""

from __future__ import annotations

from typing import NamedTuple


class DimensionKernels(NamedTuple):
    """What a solver of one dimension compiles and calls; everything else (node and contact stages,
    scalar physics) is shared. ``run_steps(n, mesh, cells, faces, nodes, contact, inflow, par, body,
    energy, law)`` is the compiled loop; the rest are the reductions its trackers and set-up use."""

    run_steps: object           # the compiled loop (dsmv.cel.stepper for 2D)
    cell_volumes: object        # (node coordinates per axis[, axisymmetric in 2D]) -> cell volumes (m³)
    elastic_energy: object      # (phi, q, vol, G, K) -> stored elastic energy (J)
    hourglass_modes: object     # (corner, phi, v, full) -> Σ|hourglass mode|², Σ|linear modes|²
    shear_strain_rates: object  # (mesh, cells, faces, nodes, par, v_body) -> γ̇ per cell (1/s)


def for_dimension(dim: int) -> DimensionKernels:
    """The kernels of a ``dim``-axis grid, looked up when a solver is set up (a test may replace the
    loop in its module first)."""
    if dim == 2:
        from dsmv.cel import stepper
        from dsmv.cel.kernels import plane

        return DimensionKernels(stepper.run_steps, plane.cell_volumes, plane.elastic_energy, plane.hourglass_modes,
                                plane.shear_strain_rates)
    if dim == 3:
        from dsmv.cel import stepper3d
        from dsmv.cel.kernels import hexahedra

        return DimensionKernels(stepper3d.run_steps, hexahedra.cell_volumes, hexahedra.elastic_energy,
                                hexahedra.hourglass_modes, hexahedra.shear_strain_rates)
    raise ValueError(f"no CEL element kernels for {dim} axes (2 and 3 are available)")
