"""The fast landing model against closed forms it must reduce to, and its table path against the solver."""

import math

import numpy as np
import pandas as pd
import pytest
from scipy.optimize import brentq

from dsmv.analytic.bearing import PRANDTL_NC
from dsmv.analytic.dynamic import AnalyticDynamicSolver
from dsmv.analytic.landing_model import gradient_factor
from dsmv.analytic.energy import sinkage_from_energy
from dsmv.config.scene import build_scene

#: every refinement off: the energy method with sc = 1 (plane strain) and Tresca soil
BARE = ["solver=analytic_dynamic", "soil.law=tresca", "solver.depth_coefficient=0", "solver.strain_coefficient=0",
        "solver.rate_coefficient=0", "solver.elastic_coefficient=0", "solver.drag_coefficient=0",
        "solver.buoyancy=false"]
#: the rest threshold (speed 1e-3 of touchdown) and the depth steps leave the sinkage within this of a
#: closed form (measured: at most 3e-7)
REL = 2e-6


@pytest.fixture
def solve(compose_cfg):
    def _solve(*overrides):
        scene = build_scene(compose_cfg([*BARE, *overrides]))
        return scene, AnalyticDynamicSolver(scene).solve()
    return _solve


def test_bare_model_is_the_energy_method(solve):
    """A resistance Nc·A·(su0 + ks·z): the quadratic of the reference study's Eq. (3), sc = 1."""
    scene, result = solve("soil.ks_pa_per_m=0")  # G(κ) = 1 only without a gradient
    landing, soil = scene.landing, scene.soil
    exact = sinkage_from_energy(landing.weight_per_track_n, landing.inertia_per_track_kg, landing.velocity_m_s,
                                PRANDTL_NC * scene.geometry.contact_area_m2, soil.su0_pa, 0.0)
    assert result.status == "ok"
    assert result.metrics["max_sinkage_m"] == pytest.approx(exact, rel=REL)


def test_grousers_cut_in_first_then_the_base_bears(solve):
    """The 3D track's landing (``solver.grousers=true``): the tips start gh deep at the speed gained falling
    gh, carrying the soil they trap; on a constant strength the base then goes p further, where
    ½·M'·v'² + W'·p = Nc·A·su0·p (exact), and the plates end gh above the tips."""
    scene, result = solve("soil.ks_pa_per_m=0", "solver.grousers=true")
    landing, soil, body = scene.landing, scene.soil, scene.geometry
    gh, area = body.grouser_height_m, body.contact_area_m2
    trapped = soil.density_kg_m3 * area * gh
    weight, inertia = landing.weight_per_track_n, landing.inertia_per_track_kg
    speed2 = landing.velocity_m_s**2 + 2.0 * weight / inertia * gh
    p = 0.5 * (inertia + trapped) * speed2 / (PRANDTL_NC * area * soil.su0_pa - weight - trapped * landing.gravity_m_s2)
    assert result.metrics["max_sinkage_m"] == pytest.approx(gh + p, rel=REL)
    assert result.metrics["plate_sinkage_m"] == pytest.approx(p, rel=REL)
    assert result.history["sinkage_m"][0] == gh and result.history["velocity_m_s"][0] == pytest.approx(speed2**0.5)


def test_strength_gradient_and_buoyancy(solve):
    """su = su0 + ks·z under the bearing factor Nc·G(ks·B/su(z)) plus ρ'·g·z: integrated by quadrature."""
    scene, result = solve("solver.buoyancy=true")
    landing, soil, body = scene.landing, scene.soil, scene.geometry
    from scipy.integrate import quad

    def pressure(z):
        su = soil.su0_pa + soil.ks_pa_per_m * z
        return PRANDTL_NC * gradient_factor(soil.ks_pa_per_m * body.width_m / su) * su + soil.density_kg_m3 * 9.81 * z

    def energy_left(z):
        return (0.5 * landing.inertia_per_track_kg * landing.velocity_m_s**2 + landing.weight_per_track_n * z
                - body.contact_area_m2 * quad(pressure, 0.0, z, epsabs=0, epsrel=1e-12)[0])

    assert result.metrics["max_sinkage_m"] == pytest.approx(brentq(energy_left, 1e-6, 1.0, xtol=1e-12), rel=REL)


def test_inertial_drag_of_a_weightless_body(solve):
    """W = 0, ks = 0: M·v·dv/dz = −A·(Nc·su0 + ½·Cd·ρ'·v²), so z = M/(Cd·ρ'·A)·ln(1 + Cd·ρ'·v0²/(2·Nc·su0))."""
    scene, result = solve("landing.gravity_m_s2=0", "soil.ks_pa_per_m=0", "solver.drag_coefficient=2.5",
                          "landing.velocity_m_s=6")
    rho, su0, area = scene.soil.density_kg_m3, scene.soil.su0_pa, scene.geometry.contact_area_m2
    mass, v0 = scene.landing.inertia_per_track_kg, 6.0
    exact = mass / (2.5 * rho * area) * math.log1p(2.5 * rho * v0**2 / (2 * PRANDTL_NC * su0))
    assert result.metrics["max_sinkage_m"] == pytest.approx(exact, rel=REL)


def test_mobilisation_over_the_elastic_settlement(solve):
    """R = Nc·su0·A·(1 − exp(−z/z_e)), z_e = Nc·B·su0/E: K(z) = K0 + W·z − Nc·su0·A·(z − z_e·(1 − e^(−z/z_e)))."""
    scene, result = solve("soil.ks_pa_per_m=0", "solver.elastic_coefficient=1")
    landing, soil, body = scene.landing, scene.soil, scene.geometry
    z_e = PRANDTL_NC * body.width_m * soil.su0_pa / soil.youngs_modulus_pa
    capacity = PRANDTL_NC * soil.su0_pa * body.contact_area_m2

    def energy_left(z):
        return (0.5 * landing.inertia_per_track_kg * landing.velocity_m_s**2 + landing.weight_per_track_n * z
                - capacity * (z + z_e * math.expm1(-z / z_e)))

    # z_e is about ten depth steps: the midpoint rule on the exponential leaves 3.0e-5 (measured)
    assert result.metrics["max_sinkage_m"] == pytest.approx(brentq(energy_left, 1e-6, 1.0, xtol=1e-12), rel=1e-4)


def test_a_law_that_neither_softens_nor_hardens_is_tresca(compose_cfg):
    """Einav–Randolph with St = 1 and η = 0 is Tresca, through the law's own twin."""
    def sinkage(*overrides):
        scene = build_scene(compose_cfg(["solver=analytic_dynamic", *overrides]))
        return AnalyticDynamicSolver(scene).solve().metrics["max_sinkage_m"]

    assert sinkage("soil.sensitivity=1", "soil.rate.eta=0") == sinkage("soil.law=tresca")


def test_history_ends_at_rest(solve):
    scene, result = solve()
    history = result.history
    assert history["sinkage_m"][-1] == pytest.approx(result.metrics["max_sinkage_m"], rel=1e-12)
    assert history["velocity_m_s"][0] == scene.landing.velocity_m_s
    assert np.all(np.diff(history["time_s"]) > 0) and np.all(np.diff(history["sinkage_m"]) >= 0)


@pytest.mark.parametrize("law", ["einav_randolph", "tresca"])
def test_a_table_of_landings_equals_the_solver_scene_by_scene(compose_cfg, law):
    """dsmv.surrogate.fast_model runs the rows of a dataset table at once: each row equals the solver
    on that scene (the same law's twin, the default soil's other values)."""
    from dsmv.surrogate.dataset import PARAMETERS
    from dsmv.surrogate.fast_model import default_settings, fast_sinkage

    rows = [{"landing.mass_kg": 2500, "landing.velocity_m_s": 6, "soil.su0_pa": 3000, "soil.ks_pa_per_m": 3000,
             "soil.sensitivity": 8, "soil.xi95": 10, "soil.rate.eta": 0.15, "geometry.contact_length_m": 3.12},
            {"landing.mass_kg": 9000, "landing.velocity_m_s": 1, "soil.su0_pa": 6000, "soil.ks_pa_per_m": 0,
             "soil.sensitivity": 5, "soil.xi95": 20, "soil.rate.eta": 0.15, "geometry.contact_length_m": 5.2}]
    expected, table = [], []
    for row in rows:
        scene = build_scene(compose_cfg(["solver=analytic_dynamic", f"soil.law={law}",
                                         *(f"{k}={v}" for k, v in row.items())]))
        expected.append(AnalyticDynamicSolver(scene).solve().metrics["max_sinkage_m"])
        flat = {"landing": scene.landing, "geometry": scene.geometry, "soil": scene.soil}
        record = {}
        for column, key in PARAMETERS.items():
            value = flat[key.split(".")[0]]
            for part in key.split(".")[1:]:
                value = getattr(value, part)
            record[column] = math.nan if value is None else value
        table.append(record)
    settings = default_settings() | {"law": law}
    assert fast_sinkage(pd.DataFrame(table), settings=settings) == pytest.approx(expected, rel=1e-12)


def test_refuses_a_push_and_a_tbar(compose_cfg):
    from dsmv.errors import ConfigError

    for overrides, key in ((["landing=push"], "landing.kind"), (["geometry=tbar"], "geometry.kind")):
        with pytest.raises(ConfigError, match=key):
            AnalyticDynamicSolver(build_scene(compose_cfg(["solver=analytic_dynamic", *overrides])))
