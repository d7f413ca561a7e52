"""The 2D explicit Coupled Eulerian–Lagrangian solver: grid, kernels, stepper, solver plugin."""
