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

from dsmv.cel.grid import Openings
from dsmv.cel.state import Elastic, geostatic_state, stepper_flags, stepper_parameters
from dsmv import registry
from dsmv.results import SolveResult
from dsmv.scene import Number, Scene, Schema


class Cel2DCheckConfig(Schema):
    """Config of ``solver=cel2d_check``."""

    name: Literal["cel2d_check"]
    case: Literal["advection", "geostatic"]
    courant: Number = Field(0.4, gt=0, le=1, description="advection: |u|·Δt/h per axis (-)")
    advection_order: Literal[1, 2] = 2
    travel: Number = Field(0.3, gt=0, le=0.4, description="advection: distance moved per axis, in domain sizes (-)")
    duration_s: Number = Field(1.0, gt=0, description="geostatic: simulated time (s)")
    block_width_m: Number = Field(4.0, gt=0, description="geostatic: width of the soil block (m)")
    block_depth_m: Number = Field(4.0, gt=0, description="geostatic: depth of the soil block (m)")
    cfl: Number = Field(0.5, gt=0, le=1)


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
    from dsmv.cel import kernels as K

    h = 1.0 / n_cells
    x = np.linspace(0.0, 1.0, n_cells + 1)
    y = x.copy()
    xc = 0.5 * (x[1:] + x[:-1])
    lo, hi = 0.15, 0.45
    phi = _exact_square_fraction(x, y, lo, hi)
    q = np.zeros((K.NQ_BASE, n_cells, n_cells))
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
    vol = K.cell_volumes(x, y, False)
    ghost = np.zeros((K.NQ_BASE, n_cells))
    flux_x = np.zeros((n_cells + 1, n_cells))
    flux_y = np.zeros((n_cells + 1, n_cells))
    mass0 = float((phi * vol).sum())
    audit = np.zeros(2)
    no_body = Openings.of_cells(np.zeros((n_cells, n_cells), dtype=bool))
    for step in range(n_steps):
        for sweep in range(2):
            axis = (step + sweep) % 2
            flux = flux_x if axis == 0 else flux_y
            aperture = no_body.aperture_x if axis == 0 else no_body.aperture_y
            K.advect_cells(axis, x, y, vol, phi, q, ux, uy, dt, order, False, ghost, False, flux, 1e-12, 1.0, 1.0, audit,
                           aperture, no_body.open_frac)
            K.advect_cells(axis, x, y, vol, phi_full, q_full, ux, uy, dt, order, False, ghost, False, flux, 1e-12,
                           1.0, 1.0, audit, aperture, no_body.open_frac)
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
        from dsmv.cel import kernels as K
        from dsmv.cel import stepper as S
        from dsmv.cel.grid import build_grid

        scene, cfg = self.scene, self.scene.solver
        soil, mesh = scene.soil, scene.mesh
        h = mesh.cell_size_m
        grid = build_grid(h, 0.5 * cfg.block_width_m, cfg.block_width_m, 0.5 * cfg.block_depth_m,
                          cfg.block_depth_m, 3 * h, mesh.growth_ratio, mesh.max_cell_size_m)
        x, y, nx, ny = grid.x, grid.y, grid.nx, grid.ny
        rho, grav = soil.density_kg_m3, scene.landing.gravity_m_s2
        elastic = Elastic.of(soil)
        dt = cfg.cfl * h / elastic.wave_speed_m_s
        phi, q = geostatic_state(grid, rho, grav, elastic.k0, mudline=0.0)
        vol = K.cell_volumes(x, y, False)
        par = stepper_parameters(dt=dt, density=rho, elastic=elastic, h=h, gravity=grav, su0=soil.su0_pa,
                                 ks=soil.ks_pa_per_m, hourglass=0.05, bulk_linear=0.06, bulk_quadratic=1.2,
                                 stress_cutoff=0.01)
        ipar = stepper_flags(axisym=False, advection_order=2, drop=False, bottom_inflow=False, remap=True,
                             exact_tresca=False, law_active=False)
        vx = np.zeros((nx + 1, ny + 1))
        vy = np.zeros_like(vx)
        tresca = registry.load("soil_laws", "tresca", "soil.law")
        none = np.zeros(0, dtype=np.int64)
        no_body = Openings.of_cells(np.zeros((nx, ny), dtype=bool))
        openings = (no_body.aperture_x, no_body.aperture_y, no_body.open_frac)
        body = np.zeros(S.N_BODY)
        energy = np.zeros(S.N_ENERGY)
        args = (x, y, vol, phi, q, vx, vy, np.zeros_like(vx), np.zeros_like(vx), np.zeros_like(vx),
                np.zeros_like(vx), np.zeros_like(vx), np.zeros((nx + 1, ny)), np.zeros((ny + 1, nx)),
                none, none, none.astype(np.bool_), np.zeros(0), np.zeros(0), np.zeros(0),
                np.ones((nx, ny)), np.zeros((nx, ny)),
                np.zeros((nx, ny), dtype=np.bool_), *openings, np.zeros((0, 4), dtype=np.int64),
                np.zeros((nx, ny), dtype=np.bool_), np.full((nx, ny), -1, dtype=np.int64),
                np.zeros((0, 4), dtype=np.int64), np.zeros((0, K.N_TWIN)), np.zeros((K.NQ_BASE, nx)), np.zeros(nx),
                par, ipar, body, energy, tresca.compiled(), np.zeros(8), tresca.compiled_evolve())
        n_steps = int(math.ceil(cfg.duration_s / dt))
        samples = 100
        times, speeds = [0.0], [0.0]
        t0 = time.perf_counter()
        done = 0
        while done < n_steps:
            chunk = min(max(1, n_steps // samples), n_steps - done)
            S.run_steps(chunk, *args)
            done += chunk
            times.append(body[S.B_TIME])
            speeds.append(float(np.sqrt(vx * vx + vy * vy).max()))
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
