"""Compiled kernels of the CEL step.

- :mod:`~dsmv.cel.kernels.common`: scalar physics every dimension shares (returns, soil-law call,
  elastic energy, donor–acceptor, van Leer) and the one set of Numba flags;
- :mod:`~dsmv.cel.kernels.nodes`: node and contact stages over the flat node arrays and the
  contact table, for any number of axes;
- per dimension, the element kernels (forces, strains, hourglass, stress update) and the remap
  sweeps: :mod:`~dsmv.cel.kernels.plane` and :mod:`~dsmv.cel.kernels.remap2d` for 2D.
"""
