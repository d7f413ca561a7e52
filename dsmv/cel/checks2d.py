"""``solver=cel2d_check``: verification cases of the CEL core that need no body.

- ``advection``: a square of soil (and a smooth scalar riding in it) carried diagonally across
  a uniform grid by a uniform velocity, with no stress. Exact answer: the translate. Reports
  soil mass error, volume-fraction bounds, the L1 shape error of φ and of the smooth scalar,
  and their observed orders over three refinements (h, h/2, h/4).
- ``geostatic``: a soil block under gravity with its geostatic initial stress, no body, for
  ``duration_s``. Exact answer: it stays at rest. Reports the largest soil speed.

Both run the same kernels as ``cel2d``.
"""

from __future__ import annotations

import math
import time
from typing import Literal

import numpy as np
from pydantic import Field

from dsmv.cel.kernels.elements2d import NQ_BASE
from dsmv.cel.layout import B_TIME, N_BODY, SoilLawKernel
from dsmv.cel.state import Elastic, body_free_state, geostatic_state, step_parameters
from dsmv import registry
from dsmv.results import SolveResult
from dsmv.config.scene import Scene
from dsmv.config.schema import Number, Schema


class Cel2DCheckConfig(Schema):
    """Config of ``solver=cel2d_check``; the values live in ``conf/solver/cel2d_check.yaml``."""

    name: Literal["cel2d_check"]
    case: Literal["advection", "geostatic"]
    courant: Number = Field(gt=0, le=1, description="advection: |u|·Δt/h per axis (-)")
    advection_order: Literal[1, 2] = Field(description="advection: 1 donor cell, 2 van Leer")
    travel: Number = Field(gt=0, le=0.4, description="advection: distance moved per axis, in domain sizes (-)")
    duration_s: Number = Field(gt=0, description="geostatic: simulated time (s)")
    block_width_m: Number = Field(gt=0, description="geostatic: width of the soil block (m)")
    block_depth_m: Number = Field(gt=0, description="geostatic: depth of the soil block (m)")
    cfl: Number = Field(gt=0, le=1, description="geostatic: time step as a fraction of the CFL limit (-)")


def _exact_square_fraction(edges_x, edges_y, lo, hi):
    """Cell-averaged indicator of the square [lo, hi]² on a tensor grid."""
    fx = np.clip(np.minimum(edges_x[1:], hi) - np.maximum(edges_x[:-1], lo), 0, None) / np.diff(edges_x)
    fy = np.clip(np.minimum(edges_y[1:], hi) - np.maximum(edges_y[:-1], lo), 0, None) / np.diff(edges_y)
    return np.outer(fx, fy)


def _smooth(xc, yc, cx, cy, width):
    """A smooth bump (the transported scalar), evaluated at cell centres."""
    r2 = (xc[:, None] - cx) ** 2 + (yc[None, :] - cy) ** 2
    return np.exp(-r2 / width**2)


def advect_square(n_cells: int, courant: float, travel: float, order: int) -> dict:
    """Carry a square of soil across [0, 1]² diagonally; return errors against the translate."""
    from dsmv.cel.kernels.elements2d import cell_volumes
    from dsmv.cel.kernels.remap2d import advect_cells

    h = 1.0 / n_cells
    x = np.linspace(0.0, 1.0, n_cells + 1)
    y = x.copy()
    xc = 0.5 * (x[1:] + x[:-1])
    lo, hi = 0.15, 0.45
    phi = _exact_square_fraction(x, y, lo, hi)
    q = np.zeros((NQ_BASE, n_cells, n_cells))
    # the smooth scalar rides everywhere in a full-soil field: a second grid, φ = 1
    phi_full = np.ones_like(phi)
    q_full = np.zeros_like(q)
    q_full[0] = _smooth(xc, xc, 0.3, 0.3, 0.1)
    speed = 1.0
    dt = courant * h / speed
    n_steps = int(round(travel / (speed * dt)))
    dt = travel / (speed * n_steps)
    ux = np.full((n_cells + 1, n_cells + 1), speed)
    uy = ux.copy()
    # The walls hold the soil in, so the full field empties from the upwind walls and piles up
    # at the downwind ones; both fronts stay far from the bump, which is what is compared.
    vol = cell_volumes(x, y, False)
    mesh, square, faces, _, _, inflow = body_free_state(x, y, phi, q, vol)
    full = body_free_state(x, y, phi_full, q_full, vol)[1]
    # unit moduli, no inflow: the sweep only moves things
    par = step_parameters(dt=dt, density=1.0, elastic=Elastic(1.0, 1.0, 1.0, 0.0), h=h, gravity=0.0, su0=0.0, ks=0.0,
                          hourglass=0.0, bulk_linear=0.0, bulk_quadratic=0.0, stress_cutoff=0.0, axisymmetric=False,
                          advection_order=order, drop=False, inflow=False, remap=True, tresca=False,
                          law_active=False)._replace(phi_min=1e-12)
    mass0 = float((phi * vol).sum())
    audit = np.zeros(2)
    for step in range(n_steps):
        for sweep in range(2):
            axis = (step + sweep) % 2
            advect_cells(axis, mesh, square, faces, ux, uy, dt, par, inflow, audit)
            advect_cells(axis, mesh, full, faces, ux, uy, dt, par, inflow, audit)
    exact_phi = _exact_square_fraction(x, y, lo + travel, hi + travel)
    exact_bump = _smooth(xc, xc, 0.3 + travel, 0.3 + travel, 0.1)
    return {
        "h": h,
        "mass_error": abs(float((phi * vol).sum()) - mass0) / mass0,
        "phi_min": float(phi.min()),
        "phi_max": float(phi.max()),
        "shape_error": float(np.abs(phi - exact_phi).sum() / exact_phi.sum()),
        "smooth_error": float(np.abs(q_full[0] - exact_bump).sum() / exact_bump.sum()),
        "steps": n_steps,
    }


def observed_order(errors: list[float], hs: list[float]) -> float:
    """Least-squares slope of log(error) against log(h)."""
    return float(np.polyfit(np.log(hs), np.log(errors), 1)[0])


class Cel2DCheckSolver:
    """Solver plugin ``cel2d_check``: verification cases of the CEL core."""

    name = "cel2d_check"
    config_model = Cel2DCheckConfig

    def __init__(self, scene: Scene):
        self.scene = scene

    def solve(self, run_dir=None) -> SolveResult:
        return self._advection() if self.scene.solver.case == "advection" else self._geostatic()

    def _advection(self) -> SolveResult:
        cfg = self.scene.solver
        n0 = max(10, int(round(1.0 / self.scene.mesh.cell_size_m / 10.0)) * 10)  # coarse cells per unit side
        runs = [advect_square(n0 * k, cfg.courant, cfg.travel, cfg.advection_order) for k in (1, 2, 4)]
        hs = [r["h"] for r in runs]
        finest = runs[-1]
        metrics = {
            "mass_error": max(r["mass_error"] for r in runs),
            "phi_min": min(r["phi_min"] for r in runs),
            "phi_max": max(r["phi_max"] for r in runs),
            "shape_error": runs[0]["shape_error"],
            "shape_error_fine": finest["shape_error"],
            "shape_order": observed_order([r["shape_error"] for r in runs], hs),
            "smooth_error": runs[0]["smooth_error"],
            "smooth_error_fine": finest["smooth_error"],
            "smooth_order": observed_order([r["smooth_error"] for r in runs], hs),
        }
        units = {k: "-" for k in metrics}
        message = (f"shape error {runs[0]['shape_error']:.3g} → {finest['shape_error']:.3g} "
                   f"(order {metrics['shape_order']:.2f}); smooth scalar order {metrics['smooth_order']:.2f}")
        return SolveResult("ok", message, metrics, units, None)  # a convergence study has no time history

    def _geostatic(self) -> SolveResult:
        from dsmv.cel.grid import build_grid_2d
        from dsmv.cel.kernels import for_dimension
        from dsmv.cel.ledger import N_ENERGY

        scene, cfg = self.scene, self.scene.solver
        soil, mesh_cfg = scene.soil, scene.mesh
        h = mesh_cfg.cell_size_m
        grid = build_grid_2d(h, 0.5 * cfg.block_width_m, cfg.block_width_m, 0.5 * cfg.block_depth_m,
                             cfg.block_depth_m, 3 * h, mesh_cfg.growth_ratio, mesh_cfg.max_cell_size_m)
        x, y = grid.x, grid.y
        rho, grav = soil.density_kg_m3, scene.landing.gravity_m_s2
        elastic = Elastic.of(soil)
        dt = cfg.cfl * h / elastic.wave_speed_m_s
        phi, q = geostatic_state(grid, rho, grav, elastic.k0, mudline=0.0)
        kernels = for_dimension(2)
        vol = kernels.cell_volumes(x, y, False)
        # the CEL solver's default numerics (its YAML), no body, closed base
        from dsmv.cel.config import solver_defaults

        cel = solver_defaults("cel2d")
        par = step_parameters(dt=dt, density=rho, elastic=elastic, h=h, gravity=grav, su0=soil.su0_pa,
                              ks=soil.ks_pa_per_m, hourglass=cel["hourglass"], bulk_linear=cel["bulk_viscosity_linear"],
                              bulk_quadratic=cel["bulk_viscosity_quadratic"], stress_cutoff=cel["stress_cutoff"],
                              axisymmetric=False, advection_order=cel["advection_order"], drop=False, inflow=False,
                              remap=True, tresca=False, law_active=False)
        state = (*body_free_state(x, y, phi, q, vol), par)
        v = state[3].v
        body = np.zeros(N_BODY)
        energy = np.zeros(N_ENERGY)
        law = SoilLawKernel.of(registry.load("soil_laws", "tresca", "soil.law")(soil))
        n_steps = int(math.ceil(cfg.duration_s / dt))
        samples = 100
        times, speeds = [0.0], [0.0]
        t0 = time.perf_counter()
        done = 0
        while done < n_steps:
            chunk = min(max(1, n_steps // samples), n_steps - done)
            kernels.run_steps(chunk, *state, body, energy, law)
            done += chunk
            times.append(body[B_TIME])
            speeds.append(float(np.sqrt((v * v).sum(axis=0)).max()))
        wall = time.perf_counter() - t0
        soil_volume0 = float((geostatic_state(grid, rho, grav, elastic.k0, mudline=0.0)[0] * vol).sum())
        metrics = {
            "max_speed_m_s": float(max(speeds)),
            "mass_error": abs(float((phi * vol).sum()) - soil_volume0) / soil_volume0,
            "wall_s": wall,
            "steps": float(n_steps),
        }
        units = {"max_speed_m_s": "m/s", "mass_error": "-", "wall_s": "s", "steps": "-"}
        n = len(times)
        history = {"time_s": np.array(times), "sinkage_m": np.zeros(n), "velocity_m_s": np.array(speeds),
                   "force_n": np.zeros(n)}
        return SolveResult("ok", f"largest soil speed {max(speeds):.3g} m/s over {cfg.duration_s:g} s",
                           metrics, units, history)
