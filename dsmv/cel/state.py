"""The CEL model's starting point: elastic constants, the geostatic soil state, packed parameters.

One home for what the solver and the verification cases (dsmv.cel.checks) both set up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dsmv.cel import kernels as K
from dsmv.cel import stepper as S
from dsmv.cel.grid import Grid


@dataclass(frozen=True)
class Elastic:
    """Isotropic elasticity of the soil: shear and bulk moduli (Pa), P-wave speed (m/s), K0 (-)."""

    shear_pa: float
    bulk_pa: float
    wave_speed_m_s: float
    k0: float

    @classmethod
    def of(cls, soil) -> "Elastic":
        E, nu, rho = soil.youngs_modulus_pa, soil.poisson_ratio, soil.density_kg_m3
        shear, bulk = E / (2 * (1 + nu)), E / (3 * (1 - 2 * nu))
        # K0 = ν/(1 − ν): the at-rest ratio of an elastic soil loaded one-dimensionally by its weight
        return cls(shear, bulk, math.sqrt((bulk + 4 * shear / 3) / rho), nu / (1 - nu))


def geostatic_state(grid: Grid, density: float, gravity: float, k0: float, mudline: float, open_frac=None):
    """Soil below the mudline (y = ``mudline``) and outside the body, at rest under its weight.

    A cell the mudline cuts holds just the soil below it; a cell the body cuts, just the soil
    in its ``open_frac`` (nx, ny; default all open).

    Returns φ (nx, ny) and the transported state q (NQ_BASE, nx, ny): σyy = −ρ'·g·depth,
    σxx = σzz = K0·σyy, z0 = depth (m), ξ = 0.
    """
    # the fraction of each row below the mudline (a mudline inside a graded cell fills it in part)
    fill = np.clip((mudline - grid.y[:-1]) / grid.dy, 0.0, 1.0)
    # the depth of the soil's own centroid in each row
    depth = np.where(fill >= 1.0, mudline - grid.yc, 0.5 * fill * grid.dy)
    phi = np.tile(fill, (grid.nx, 1))
    if open_frac is not None:
        phi = phi * open_frac
    q = np.zeros((K.NQ_BASE, grid.nx, grid.ny))
    q[K.SYY] = -density * gravity * depth[None, :] * phi
    q[K.SXX] = k0 * q[K.SYY]
    q[K.SZZ] = k0 * q[K.SYY]
    q[K.Z0] = depth[None, :] * phi
    return phi, q


def stepper_parameters(*, dt, density, elastic: Elastic, h, gravity, su0, ks, hourglass, bulk_linear,
                       bulk_quadratic, stress_cutoff, body_mass=1.0, body_weight=0.0, push_velocity=0.0,
                       remap_courant=0.0):
    """The float parameters of :func:`dsmv.cel.stepper.run_steps`, packed in its order.

    ``remap_courant``: the remap runs once the soil has moved this fraction of a core cell h
    through the grid (0: every step)."""
    par = np.zeros(S.N_PAR)
    par[S.P_DT], par[S.P_RHO] = dt, density
    par[S.P_G], par[S.P_K], par[S.P_C], par[S.P_K0] = elastic.shear_pa, elastic.bulk_pa, elastic.wave_speed_m_s, elastic.k0
    par[S.P_HG], par[S.P_BL], par[S.P_BQ] = hourglass, bulk_linear, bulk_quadratic
    par[S.P_GRAV], par[S.P_SU0], par[S.P_KS] = gravity, su0, ks
    par[S.P_MFLOOR] = 1e-9 * density * h * h  # nodes lighter than this are empty
    par[S.P_PHIMIN] = 1e-9  # cells with less soil give none
    par[S.P_PHI_STRESS] = stress_cutoff
    par[S.P_BODY_M], par[S.P_BODY_W], par[S.P_PUSH_V] = body_mass, body_weight, push_velocity
    par[S.P_REMAP_DISP] = remap_courant * h
    return par


def stepper_flags(*, axisym, advection_order, drop, bottom_inflow, remap, exact_tresca, law_active, skip_void=True,
                  separate=False):
    """The integer switches of :func:`dsmv.cel.stepper.run_steps`, packed in its order."""
    flags = np.zeros(S.N_IPAR, dtype=np.int64)
    flags[S.I_AXISYM], flags[S.I_ORDER], flags[S.I_DROP] = int(axisym), advection_order, int(drop)
    flags[S.I_INFLOW], flags[S.I_REMAP] = int(bottom_inflow), int(remap)
    flags[S.I_TRESCA], flags[S.I_LAW], flags[S.I_SKIP_VOID] = int(exact_tresca), int(law_active), int(skip_void)
    flags[S.I_SEPARATE] = int(separate)
    return flags
