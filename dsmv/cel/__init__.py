"""The explicit Coupled Eulerian–Lagrangian solvers, as layers 2D and 3D share: typed state
(layout), grids and body shapes, contact as data, compiled kernels (shared scalar physics, node and
contact stages, per-dimension element and remap kernels), the compiled loop (stepper), the
controller with its trackers, the energy ledger, and the solver plugins (solver, checks).
docs/decisions/0001-cel-core-as-layers.md has the cut and why."""
