"""The energy method against hand calculation and against the equation of motion."""

import math

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp

from dsmv.analytic.energy import AnalyticEnergySolver, sinkage_from_energy
from dsmv.config.scene import build_scene

G = 9.81


@pytest.fixture
def compose_cfg(compose_cfg):
    """The scene as the energy method sees it (the default solver is cel2d)."""
    return lambda overrides=(): compose_cfg(["solver=analytic_energy", *overrides])


def hand_sinkage(m, v, n, B, L, su0, ks, nc=2 + math.pi):
    """Textbook quadratic formula for ½Mv² + Wz = Nc·sc·A·(su0·z + ½ks·z²), sc = 1 + 0.2B/L."""
    A, sc = B * L, 1 + 0.2 * B / L
    W, M = m * G / n, m / n
    a, b, c = 0.5 * nc * sc * A * ks, nc * sc * A * su0 - W, -0.5 * M * v**2
    return -c / b if a == 0 else (-b + math.sqrt(b * b - 4 * a * c)) / (2 * a)


def test_default_scene_by_hand(compose_cfg):
    # W = 44 145 N, A = 2.502 m², sc = 1.028777, Nc·sc·A = 13.23446 m², KE = 5062.5 J → z = 0.209963 m
    result = AnalyticEnergySolver(build_scene(compose_cfg())).solve()
    assert result.status == "ok"
    assert result.metrics["max_sinkage_m"] == pytest.approx(0.209963, rel=1e-5)
    assert result.metrics["max_sinkage_m"] == pytest.approx(hand_sinkage(4500, 1.5, 1, 0.6, 4.17, 5000, 1500), rel=1e-12)
    assert result.units["max_sinkage_m"] == "m"


@pytest.mark.parametrize(
    "m,v,n,su0,ks",
    [(2500, 1, 1, 2000, 0), (10500, 8, 2, 10000, 3000), (4500, 0, 1, 5000, 1500), (6500, 3, 1, 3000, 2500)],
)
def test_table3_corners_by_hand(compose_cfg, m, v, n, su0, ks):
    cfg = compose_cfg([f"landing.mass_kg={m}", f"landing.velocity_m_s={v}", f"landing.n_tracks={n}",
                       f"soil.su0_pa={su0}", f"soil.ks_pa_per_m={ks}"])
    result = AnalyticEnergySolver(build_scene(cfg)).solve()
    assert result.metrics["max_sinkage_m"] == pytest.approx(hand_sinkage(m, v, n, 0.6, 4.17, su0, ks), rel=1e-10)


def test_energy_balance_and_motion_agree(compose_cfg):
    """Work of R over the sinkage equals KE + W·z (quadrature), and M·z̈ = W − R(z) integrated
    numerically stops at the same depth and time as the closed form."""
    scene = build_scene(compose_cfg(["landing.velocity_m_s=2.5", "soil.ks_pa_per_m=800"]))
    solver = AnalyticEnergySolver(scene)
    result = solver.solve()
    z_max, t_rest = result.metrics["max_sinkage_m"], result.metrics["time_to_rest_s"]
    M, W, v0 = scene.landing.inertia_per_track_kg, scene.landing.weight_per_track_n, 2.5

    work, _ = quad(lambda z: float(solver.resistance_n(z)), 0.0, z_max)
    assert work == pytest.approx(0.5 * M * v0**2 + W * z_max, rel=1e-10)

    stop = lambda t, y: y[1]  # noqa: E731  (velocity reaches zero)
    stop.terminal, stop.direction = True, -1
    ode = solve_ivp(lambda t, y: [y[1], (W - float(solver.resistance_n(y[0]))) / M], (0, 10), [0.0, v0],
                    events=stop, rtol=1e-11, atol=1e-13)
    assert ode.t_events[0][0] == pytest.approx(t_rest, rel=1e-7)
    assert ode.y_events[0][0][0] == pytest.approx(z_max, rel=1e-7)
    # the history is the same motion, sample by sample
    h = result.history
    z_ode = np.interp(h["time_s"], ode.t, ode.y[0])
    assert np.max(np.abs(h["sinkage_m"] - z_ode)) < 1e-3 * z_max
    assert h["velocity_m_s"][0] == v0 and h["velocity_m_s"][-1] == 0.0


def test_uniform_soil_constant_deceleration(compose_cfg):
    scene = build_scene(compose_cfg(["soil.ks_pa_per_m=0"]))
    solver = AnalyticEnergySolver(scene)
    result = solver.solve()
    decel = (float(solver.resistance_n(0)) - scene.landing.weight_per_track_n) / scene.landing.inertia_per_track_kg
    assert result.metrics["max_sinkage_m"] == pytest.approx(1.5**2 / (2 * decel), rel=1e-12)
    assert result.metrics["time_to_rest_s"] == pytest.approx(1.5 / decel, rel=1e-12)


def test_too_heavy_on_uniform_soil_is_bearing_failure(compose_cfg):
    # capacity 13.23 m² × 2 kPa = 26.5 kN < 44.1 kN wet weight, no strength gain with depth
    result = AnalyticEnergySolver(build_scene(compose_cfg(["soil.su0_pa=2000", "soil.ks_pa_per_m=0"]))).solve()
    assert result.status == "bearing_failure"
    assert "max_sinkage_m" not in result.metrics
    assert "cannot carry" in result.message


def test_at_rest_on_strong_soil_does_not_sink():
    assert sinkage_from_energy(1000.0, 100.0, 0.0, 1.0, 5000.0, 100.0) == 0.0
    assert math.isinf(sinkage_from_energy(6000.0, 100.0, 0.0, 1.0, 5000.0, 0.0))


def test_no_cancellation_for_strong_soil_and_slow_touchdown():
    # excess ≫ kinetic: z ≈ KE/excess; the naive formula loses all digits here
    z = sinkage_from_energy(1.0, 1.0, 1e-6, 1.0, 1e9, 1e3)
    assert z == pytest.approx(0.5e-12 / (1e9 - 1.0), rel=1e-9)


def test_sinkage_trends_follow_the_physics(compose_cfg):
    def z(*overrides):
        return AnalyticEnergySolver(build_scene(compose_cfg(list(overrides)))).solve().metrics["max_sinkage_m"]

    base = z()
    assert z("soil.su0_pa=7000") < base < z("soil.su0_pa=4000")
    assert z("soil.ks_pa_per_m=3000") < base < z("soil.ks_pa_per_m=500")
    assert z("landing.mass_kg=3000") < base < z("landing.mass_kg=6000")
    assert z("landing.velocity_m_s=0.5") < base < z("landing.velocity_m_s=3")
    assert z("geometry.contact_length_m=5.2") < base < z("geometry.contact_length_m=3.12")
    assert z("landing.n_tracks=2") < base


def test_push_gives_the_resistance_curve(compose_cfg):
    scene = build_scene(compose_cfg(["landing=push", "geometry=strip", "soil.ks_pa_per_m=0"]))
    result = AnalyticEnergySolver(scene).solve()
    # a strip on uniform soil: q/su = 2 + π at every depth
    assert result.metrics["bearing_factor_at_end"] == pytest.approx(2 + math.pi, rel=1e-12)
    assert np.allclose(result.history["force_n"], (2 + math.pi) * 5000.0)


def test_a_non_finite_history_never_leaves_silently():
    """A solver bug that writes NaN into the history fails loudly instead of an 'ok' with NaNs."""
    import numpy as np
    import pytest

    from dsmv.results import SolveResult

    history = {"time_s": np.array([0.0, 1.0]), "sinkage_m": np.array([0.0, np.nan]),
               "velocity_m_s": np.zeros(2), "force_n": np.zeros(2)}
    with pytest.raises(ValueError, match="sinkage_m"):
        SolveResult("ok", "", {"max_sinkage_m": 0.1}, history=history)


def test_the_estimate_takes_a_t_bar_the_solver_refuses(compose_cfg):
    """The CEL solver sizes a T-bar's landing with the energy estimate: a strip of width D per metre
    of bar (sc = 1). solver=analytic_energy itself still refuses a T-bar when the scene is composed."""
    from dsmv.analytic.energy import energy_estimate
    from dsmv.errors import ConfigError

    with pytest.raises(ConfigError, match=r"^geometry.kind = 'tbar': "):
        build_scene(compose_cfg(["geometry=tbar"]))
    scene = build_scene(compose_cfg(["geometry=tbar", "solver=cel2d"]))
    estimate = energy_estimate(scene)
    assert estimate.shape_factor == 1.0
    assert estimate.resistance_area_m2 == pytest.approx((2 + math.pi) * 0.5 * 1.0)
    # ½·Nc·A·ks·z² + (Nc·A·su0 − W)·z − ½·M·v² = 0 with A = D·1 m, W = m·g, M = m
    a, b, c = 0.5 * (2 + math.pi) * 0.5 * 1500, (2 + math.pi) * 0.5 * 5000 - 4500 * G, -0.5 * 4500 * 1.5**2
    assert estimate.solve().metrics["max_sinkage_m"] == pytest.approx((-b + math.sqrt(b * b - 4 * a * c)) / (2 * a))
    with pytest.raises(ConfigError, match=r"^geometry.kind = 'cone': "):
        energy_estimate(build_scene(compose_cfg(["geometry=fall_cone_30deg", "solver=cel2d"])))
