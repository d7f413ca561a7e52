"""Checks for plugins, shipped with dsmv: a plugin's own tests call them in one line each.

```python
from dsmv.testing import check_kernel_matches_twin, check_limits, check_monotone, make_law

def test_my_law():
    law = make_law("my_law", "soil.sensitivity=3", "soil.params.slope=0.1")
    check_kernel_matches_twin(law)   # the compiled factor() equals the NumPy twin on random states
    check_limits(law)                # the intact strength before any shearing; no rate effect if not declared
    check_monotone(law)              # strength never rises with ξ, never falls with γ̇
    check_simple_shear(law)          # one cell sheared through dsmv's stress kernel follows the twin
```

A surrogate's tests call ``check_surrogate("my_model", n_estimators=20)``: it fits on a known
function, predicts it back, exposes feature importances and repeats itself for a given seed.

Each check raises ``AssertionError`` naming the point where the plugin broke its contract. They need
no pytest fixture and no knowledge of the solver: :func:`make_law` composes the default scene with
the overrides given (exactly as the ``dsmv`` command does, so ``soil.params.<key>`` is validated
against the law's declared parameters) and returns the law as the solvers construct it.
"""

from __future__ import annotations

import numpy as np

from dsmv import registry
from dsmv.config import tree
from dsmv.soil_law import SoilLaw

#: the sampled states: ξ (-) uniform on [0, XI_MAX], γ̇ (1/s) log-uniform over RATE_DECADES
XI_MAX = 100.0
RATE_DECADES = (-9.0, 3.0)


def compose_scene(*overrides: str):
    """The validated scene of the default config with ``overrides`` (Hydra syntax, as on the command line)."""
    return tree.compose_scene([*overrides, "tracking=disabled"])


def compose_config(config_name: str, *overrides: str):
    """The composed (unvalidated) config ``config_name`` (``config``: a scene, ``train``: a surrogate's
    training) with ``overrides``, the plugin packages' config groups on the search path."""
    return tree.compose(config_name, list(overrides))


def make_law(name: str, *overrides: str) -> SoilLaw:
    """The installed law ``name`` (entry point in ``dsmv.soil_laws``) built on the default soil with
    ``overrides``, as the solvers build it."""
    scene = compose_scene(f"soil.law={name}", *overrides)
    return registry.load("soil_laws", name, "soil.law")(scene.soil)


def _states(law: SoilLaw, samples: int, seed: int):
    rng = np.random.default_rng(seed)
    xi = rng.uniform(0.0, XI_MAX, samples)
    gamma_dot = 10.0 ** rng.uniform(*RATE_DECADES, samples)
    state = [np.full(samples, value) for value in law.initial_state()]
    return xi, gamma_dot, state


def compiled_factor(law: SoilLaw, xi, gamma_dot, *state) -> np.ndarray:
    """The compiled ``factor`` (the machine code the CEL kernels call) at each point."""
    kernel, params = law.compiled(), law.packed()
    s = [np.broadcast_to(np.asarray(v, dtype=float), np.shape(xi)) for v in state] + [np.zeros(np.shape(xi))] * 2
    return np.array([kernel.ctypes(a, b, s0, s1, *params) for a, b, s0, s1 in zip(xi, gamma_dot, s[0], s[1])])


def check_kernel_matches_twin(law: SoilLaw, samples: int = 500, seed: int = 7, rtol: float = 1e-12) -> None:
    """The compiled ``factor`` equals the NumPy twin ``strength_factor`` (relative ``rtol``; the same
    arithmetic in both gives round-off) on random states, and both are finite and ≥ 0."""
    xi, gamma_dot, state = _states(law, samples, seed)
    compiled = compiled_factor(law, xi, gamma_dot, *state)
    twin = np.asarray(law.strength_factor(xi, gamma_dot, *state), dtype=float)
    for name, values in (("compiled factor()", compiled), ("strength_factor()", twin)):
        bad = ~(np.isfinite(values) & (values >= 0.0))
        assert not bad.any(), (f"{law.name}: {name} is negative or not finite at ξ = {xi[bad][0]:.6g}, "
                               f"γ̇ = {gamma_dot[bad][0]:.6g} 1/s: {values[bad][0]!r}")
    off = np.abs(compiled - twin) > rtol * np.maximum(np.abs(twin), 1e-300)
    assert not off.any(), (f"{law.name}: compiled factor() {compiled[off][0]!r} differs from the twin "
                           f"{twin[off][0]!r} at ξ = {xi[off][0]:.6g}, γ̇ = {gamma_dot[off][0]:.6g} 1/s")


def check_limits(law: SoilLaw, rtol: float = 1e-12) -> None:
    """Soil not yet sheared, at rest, has its intact strength (factor 1 at ξ = 0, γ̇ = 0); a law that
    declares no rate dependence (``rate_dependent`` False) gives the same factor at every γ̇, and one
    that declares no softening (``softens`` False) the same at every ξ."""
    state = law.initial_state()
    at_rest = float(law.strength_factor(np.array([0.0]), np.array([0.0]), *([v] for v in state))[0])
    assert abs(at_rest - 1.0) <= rtol, f"{law.name}: factor at ξ = 0, γ̇ = 0 is {at_rest!r}, not 1 (intact)"
    xi, gamma_dot, state_arrays = _states(law, 200, 11)
    base = np.asarray(law.strength_factor(xi, gamma_dot, *state_arrays), dtype=float)
    if not law.rate_dependent:
        other = np.asarray(law.strength_factor(xi, gamma_dot[::-1], *state_arrays), dtype=float)
        assert np.allclose(base, other, rtol=rtol, atol=0.0), f"{law.name}: declares no rate effect, but γ̇ changes it"
    if not law.softens and not law.state_variables():
        other = np.asarray(law.strength_factor(xi[::-1], gamma_dot, *state_arrays), dtype=float)
        assert np.allclose(base, other, rtol=rtol, atol=0.0), f"{law.name}: declares no softening, but ξ changes it"


def check_monotone(law: SoilLaw, samples: int = 200) -> None:
    """Along ξ (at fixed γ̇) the factor never rises; along γ̇ (at fixed ξ) it never falls: a softening,
    rate-hardening law (the contract of :mod:`dsmv.soil_law`). State variables stay at their initial
    values."""
    state = law.initial_state()
    xi = np.linspace(0.0, XI_MAX, samples)
    for rate in (0.0, 1e-6, 1e-2, 1e2):
        f = np.asarray(law.strength_factor(xi, np.full(samples, rate), *(np.full(samples, v) for v in state)))
        rises = np.diff(f) > 1e-12 * np.abs(f[:-1])
        assert not rises.any(), f"{law.name}: the factor rises with ξ at ξ = {xi[1:][rises][0]:.4g}, γ̇ = {rate:g} 1/s"
    gamma_dot = 10.0 ** np.linspace(*RATE_DECADES, samples)
    for strain in (0.0, 1.0, 30.0):
        f = np.asarray(law.strength_factor(np.full(samples, strain), gamma_dot, *(np.full(samples, v) for v in state)))
        falls = np.diff(f) < -1e-12 * np.abs(f[:-1])
        assert not falls.any(), (f"{law.name}: the factor falls with γ̇ at γ̇ = {gamma_dot[1:][falls][0]:.4g} 1/s, "
                                 f"ξ = {strain:g}")


def check_surrogate(name: str, samples: int = 300, seed: int = 3, **params) -> None:
    """The installed surrogate ``name`` (entry point in ``dsmv.surrogates``) makes a regressor that
    fits a smooth function of six features (R² ≥ 0.8 on its own training set), predicts finite
    values of the right shape, exposes one importance per feature with the informative ones
    first, and gives the same predictions when refitted with the same seed."""
    cls = registry.load("surrogates", name, "surrogate.name")
    rng = np.random.default_rng(seed)
    x = rng.uniform(0.0, 1.0, (samples, 6))
    y = 0.3 + 0.2 * x[:, 0] + 0.1 * np.sin(3.0 * x[:, 1])  # features 2–5 carry nothing
    fitted = cls(seed=0).make(**params).fit(x, y)
    predicted = np.asarray(fitted.predict(x), dtype=float)
    assert predicted.shape == (samples,) and np.isfinite(predicted).all(), f"{name}: predict() gave {predicted!r}"
    r2 = 1.0 - ((predicted - y) ** 2).sum() / ((y - y.mean()) ** 2).sum()
    assert r2 >= 0.8, f"{name}: R² {r2:.3f} on its own training set"
    importances = np.asarray(fitted.feature_importances_, dtype=float)
    assert importances.shape == (6,), f"{name}: {importances.shape[0]} importances for 6 features"
    assert importances[:2].min() > importances[2:].max(), f"{name}: importances {importances} miss the signal"
    again = np.asarray(cls(seed=0).make(**params).fit(x, y).predict(x), dtype=float)
    assert np.array_equal(predicted, again), f"{name}: the same seed gives other predictions"


def simple_shear(law: SoilLaw, gamma_dot: float, gamma_total: float, n_steps: int = 4000):
    """Drive one cell of the law's soil in simple shear at constant rate ``gamma_dot`` (1/s) to
    ``gamma_total`` through the 2D CEL stress kernel (Tresca's return, the law's compiled factor):
    the applied shear strains γ, the shear stresses τ (Pa) and the shear modulus G (Pa)."""
    from dsmv.cel.kernels.elements2d import update_stress
    from dsmv.cel.kernels.elements2d import NQ_BASE, SXY
    from dsmv.cel.layout import SoilLawKernel
    from dsmv.cel.state import Elastic, body_free_state, step_parameters

    soil, h = law.soil, 1.0
    x = y = np.array([0.0, h])
    initial = law.initial_state()
    q = np.zeros((NQ_BASE + len(initial), 1, 1))
    q[NQ_BASE:, 0, 0] = initial
    elastic = Elastic.of(soil)
    dt = gamma_total / gamma_dot / n_steps
    mesh, cells, faces, nodes, *_ = body_free_state(x, y, np.ones((1, 1)), q, np.ones((1, 1)))
    nodes.v[0] = [0.0, gamma_dot * h, 0.0, gamma_dot * h]  # nodes (i, j) at i·2 + j: the top row moves
    par = step_parameters(dt=dt, density=soil.density_kg_m3, elastic=elastic, h=h, gravity=0.0, su0=soil.su0_pa,
                          ks=0.0, hourglass=0.0, bulk_linear=0.0, bulk_quadratic=0.0, stress_cutoff=0.01,
                          axisymmetric=False, advection_order=2, drop=False, inflow=False, remap=True, tresca=True,
                          law_active=law.active)
    kernel = SoilLawKernel.of(law)
    out = np.zeros(2)
    gammas, taus = np.empty(n_steps), np.empty(n_steps)
    for step in range(n_steps):
        update_stress(mesh, cells, faces, nodes, par, 0.0, kernel, out)
        gammas[step], taus[step] = (step + 1) * gamma_dot * dt, q[SXY, 0, 0]
    return gammas, taus, elastic.shear_pa


def check_simple_shear(law: SoilLaw, gamma_dot: float = 0.5, gamma_total: float = 6.0, rtol: float = 0.01) -> None:
    """One cell sheared at ``gamma_dot`` through dsmv's stress kernel follows the twin's closed form
    τ = min(G·γ, su0·f(ξ = γ − τ/G, γ̇)) to ``rtol`` (the explicit steps' error: 4000 steps to
    γ = 6 stay within 1 % for Einav–Randolph). For laws without state variables."""
    from scipy.optimize import brentq

    assert not law.state_variables(), f"{law.name}: check_simple_shear reads the twin without state variables"
    su0 = law.soil.su0_pa
    gammas, taus, shear = simple_shear(law, gamma_dot, gamma_total)
    for gamma, tau in zip(gammas[::200], taus[::200]):
        def residual(t):
            return t - min(shear * gamma, su0 * float(law.strength_factor(max(gamma - t / shear, 0.0), gamma_dot)))

        exact = brentq(residual, -1.0, 10 * su0)
        assert abs(tau - exact) <= rtol * abs(exact) + 1e-3 * su0, (
            f"{law.name}: simple shear at γ = {gamma:.4g}: τ = {tau:.6g} Pa through the kernel, {exact:.6g} Pa "
            f"from the twin")
