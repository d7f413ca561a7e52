"""Property-based tests (hypothesis) of config validation and of the solvers on random scenes.

Validation: any wrong value of any config field gives one line naming the field's path, the
value and what is allowed (a ConfigError in-process; ``dsmv: error: <path> = <value>: ...``
and exit code 2 from the CLI), never a traceback. The fields and their bounds are read from
the pydantic schemas themselves, so a field added later is covered without a test change.
Legal scenes: random legal soils, bodies and landings never crash either solver.
"""

from __future__ import annotations

import copy
import math
import typing

import annotated_types as at
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from dsmv import registry
from dsmv.cel.config import Cel2DConfig
from dsmv.config.scene import LandingConfig, MeshConfig, RateConfig, SoilConfig, TrackGeometry, build_scene
from dsmv.errors import ConfigError
from conftest import group_options

FAST = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
ALLOWED_STATUSES = {"ok", "bearing_failure", "out_of_domain", "unstable"}

# --------------------------------------------------------------------------- the schema's numeric fields

#: config group (dotted path) → its schema, for the default scene with solver=cel2d
GROUPS = {"soil": SoilConfig, "soil.rate": RateConfig, "geometry": TrackGeometry, "landing": LandingConfig,
          "mesh": MeshConfig, "solver": Cel2DConfig}


def _numeric_fields():
    """(path, is_integer, lower, lower_inclusive, upper, upper_inclusive) of every numeric field."""
    out = []
    for prefix, model in GROUPS.items():
        for name, info in model.model_fields.items():
            kinds = {a for a in (info.annotation, *typing.get_args(info.annotation)) if a in (int, float)}
            if not kinds:
                continue
            lo = hi = None
            lo_incl = hi_incl = True
            for c in info.metadata:
                if isinstance(c, at.Gt):
                    lo, lo_incl = c.gt, False
                elif isinstance(c, at.Ge):
                    lo, lo_incl = c.ge, True
                elif isinstance(c, at.Lt):
                    hi, hi_incl = c.lt, False
                elif isinstance(c, at.Le):
                    hi, hi_incl = c.le, True
            out.append((f"{prefix}.{name}", int in kinds, lo, lo_incl, hi, hi_incl))
    return out


NUMERIC = _numeric_fields()


def test_the_schemas_give_bounds_to_fuzz():
    """The introspection found the fields whose bounds the properties below rely on."""
    paths = {f[0]: f for f in NUMERIC}
    assert paths["soil.poisson_ratio"][2:] == (0, True, 0.5, False)
    assert paths["landing.mass_kg"][2:4] == (0, False)
    assert paths["landing.n_tracks"][1] is True
    assert paths["solver.cfl"][4:] == (1, True)
    assert len(NUMERIC) >= 35


@st.composite
def wrong_numeric(draw):
    """A numeric field and a value its schema must reject."""
    path, integer, lo, lo_incl, hi, hi_incl = draw(st.sampled_from(NUMERIC))
    options = [
        st.sampled_from([math.nan, math.inf, -math.inf]),
        st.booleans(),  # YAML `yes`/`true` must not pass as 1
        st.text(alphabet="abcdefghijklmnopqrstuvwxyz_", min_size=1, max_size=8),  # letters never parse as a number
        st.lists(st.integers(), max_size=2),
        st.dictionaries(st.sampled_from("abc"), st.integers(), max_size=1),
    ]
    finite = dict(allow_nan=False, allow_infinity=False)
    if lo is not None:
        options.append(st.floats(max_value=lo, exclude_max=lo_incl, **finite))
    if hi is not None:
        options.append(st.floats(min_value=hi, exclude_min=hi_incl, **finite))
    if integer:  # a count must be a whole number
        low = 0 if lo is None else lo
        options.append(st.floats(min_value=low + 0.01, max_value=low + 1e6, **finite).filter(lambda v: v % 1 != 0))
    return path, draw(st.one_of(options))


@pytest.fixture(scope="module")
def base_scene():
    """The default scene with the CEL solver, composed and resolved once (plain data)."""
    from hydra import compose, initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra
    from omegaconf import OmegaConf

    from dsmv.config.tree import CONFIG_DIR

    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=CONFIG_DIR, version_base="1.3"):
        cfg = compose("config", overrides=["solver=cel2d", "tracking=disabled", "output.plots=false"])
    GlobalHydra.instance().clear()
    data = OmegaConf.to_container(cfg, resolve=True)
    build_scene(data)  # the base itself is legal
    return data


def with_value(data: dict, path: str, value) -> dict:
    out = copy.deepcopy(data)
    node = out
    *parents, key = path.split(".")
    for part in parents:
        node = node[part]
    node[key] = value
    return out


def assert_one_line_error(error: ConfigError, path: str) -> None:
    text = str(error)
    assert error.path == path, text
    assert text.startswith(f"{path} = ") and "\n" not in text
    assert text.split(": ", 1)[1]  # says what is allowed


@FAST
@given(case=wrong_numeric())
def test_any_wrong_number_names_its_path(base_scene, case):
    path, value = case
    with pytest.raises(ConfigError) as info:
        build_scene(with_value(base_scene, path, value))
    assert_one_line_error(info.value, path)


#: fields with a fixed set of choices, and the choices (the Literal's args, or the plugins installed)
CHOICES = {
    "soil.rate.law": typing.get_args(RateConfig.model_fields["law"].annotation),
    "landing.kind": typing.get_args(LandingConfig.model_fields["kind"].annotation),
    "geometry.view": typing.get_args(TrackGeometry.model_fields["view"].annotation),
    "solver.mode": typing.get_args(Cel2DConfig.model_fields["mode"].annotation),
    "solver.yield_surface": typing.get_args(Cel2DConfig.model_fields["yield_surface"].annotation),
    "solver.progress": typing.get_args(Cel2DConfig.model_fields["progress"].annotation),
    "solver.advection_order": typing.get_args(Cel2DConfig.model_fields["advection_order"].annotation),
    "soil.law": tuple(registry.available("soil_laws")),
    "solver.name": tuple(registry.available("solvers")),
    "geometry.kind": ("track", "strip", "tbar", "cone"),
    "geometry.roughness": ("rough", "smooth"),
}


@FAST
@given(path=st.sampled_from(sorted(CHOICES)),
       value=st.one_of(st.text(min_size=0, max_size=12), st.integers(-5, 5), st.floats(allow_nan=True), st.none()))
def test_any_unknown_choice_names_its_path_and_the_choices(base_scene, path, value):
    assume(value not in CHOICES[path] and str(value) not in map(str, CHOICES[path]))
    if path == "geometry.roughness":  # also takes an adhesion factor in [0, 1]
        assume(not (isinstance(value, (int, float)) and 0 <= value <= 1))
    with pytest.raises(ConfigError) as info:
        build_scene(with_value(base_scene, path, value))
    assert_one_line_error(info.value, path)
    if path in ("soil.law", "solver.name") and isinstance(value, str):  # an unknown plugin lists what is installed
        assert all(name in str(info.value) for name in CHOICES[path])


@FAST
@given(group=st.sampled_from(sorted(GROUPS)), key=st.from_regex(r"[a-z][a-z0-9_]{0,10}", fullmatch=True),
       value=st.one_of(st.integers(), st.text(max_size=5)))
def test_any_unknown_key_is_named(base_scene, group, key, value):
    assume(key not in GROUPS[group].model_fields)
    path = f"{group}.{key}"
    with pytest.raises(ConfigError) as info:
        build_scene(with_value(base_scene, path, value))
    assert_one_line_error(info.value, path)
    assert "Extra inputs" in str(info.value)


def _override(value) -> str:
    """A Hydra command-line spelling of a value that Hydra parses back to the same value."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float) and math.isnan(value):
        return "nan"
    if isinstance(value, float) and math.isinf(value):
        return "inf" if value > 0 else "-inf"
    return repr(value) if isinstance(value, float) else str(value)


@settings(max_examples=3, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(case=wrong_numeric().filter(lambda c: isinstance(c[1], (bool, float, str)) and c[0] != "soil.su0_pa"
                                   and c[1] != "null"))  # Hydra reads `null` as None, legal where optional
def test_cli_any_wrong_number_one_line_exit_2(run_cli, case):
    """Through Hydra and the CLI: exit code 2 and ``dsmv: error: <path> = <value>: ...``, one line.
    (soil.su0_pa is left out: a wrong su0 is first reported where E = 500·su0 reads it.)"""
    path, value = case
    proc = run_cli("dsmv", "solver=cel2d", "tracking=disabled", f"{path}={_override(value)}", timeout=120)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2, proc.stderr
    assert len(lines) == 1 and lines[0].startswith(f"dsmv: error: {path} = "), proc.stderr
    assert "Traceback" not in proc.stdout + proc.stderr


@pytest.mark.parametrize("group", ["soil", "geometry", "solver"])
def test_cli_unknown_group_choice_lists_the_options(run_cli, group):
    """An unknown option of a config group is caught before Hydra composes: one line, exit
    code 2, naming the group, the value and every option."""
    proc = run_cli("dsmv", f"{group}=no_such_option", "tracking=disabled", timeout=120)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stdout + proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"dsmv: error: {group} = 'no_such_option'")
    assert all(option in lines[0] for option in group_options(group))


# --------------------------------------------------------------------------- random legal scenes


@st.composite
def legal_scene(draw):
    """A random legal scene within (and a little beyond) the study's Table 3 ranges:
    (geometry option, {config path: value})."""
    su0 = draw(st.floats(500, 20000))
    density, poisson = draw(st.floats(300, 1000)), draw(st.floats(0, 0.49))
    # legal touchdowns stay below a tenth of the soil's elastic wave speed (dsmv.config.scene.check_touchdown_speed)
    bulk, shear = 500 * su0 / (3 * (1 - 2 * poisson)), 500 * su0 / (2 * (1 + poisson))
    fastest = min(5.0, 0.1 * ((bulk + 4 * shear / 3) / density) ** 0.5)
    values = {
        "soil.law": draw(st.sampled_from(["tresca", "einav_randolph"])),
        "soil.su0_pa": su0,
        "soil.youngs_modulus_pa": 500 * su0,  # E = 500·su0, as every Table 1 sample
        "soil.ks_pa_per_m": draw(st.floats(0, 3000)),
        "soil.sensitivity": draw(st.floats(1, 50)),
        "soil.xi95": draw(st.floats(1, 50)),
        "soil.rate.eta": draw(st.floats(0, 0.15)),
        "soil.rate.law": draw(st.sampled_from(["power", "log"])),
        "soil.density_kg_m3": density,
        "soil.poisson_ratio": poisson,
        "geometry.roughness": draw(st.sampled_from(["rough", "smooth"])),
        "landing.mass_kg": draw(st.floats(500, 12000)),
        "landing.velocity_m_s": draw(st.floats(0, fastest)),
        "landing.gravity_m_s2": draw(st.sampled_from([0.0, 9.81])),
    }
    return draw(st.sampled_from(["track_pioneer_i", "strip"])), values


#: a tiny CEL model: 0.15 m cells, the domain 2 B deep and wide and sized for 2 m of travel, a
#: step budget as a time limit. (Sized from the energy method, a heavy body on weak soil with a
#: small ks gets a domain for hundreds of metres of travel: 10⁴–10⁵ cells, minutes per example.)
TINY_CEL = ["solver=cel2d", "mesh=coarse", "mesh.cell_size_m=0.15", "solver.domain_depth_widths=2",
            "solver.domain_half_width_widths=2", "solver.initial_travel_m=2", "solver.progress=off",
            "solver.max_steps=20000"]


@pytest.fixture(scope="module")
def legal_bases():
    """(solver, geometry) → the composed, resolved base scene that random values go into."""
    from hydra import compose, initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra
    from omegaconf import OmegaConf

    from dsmv.config.tree import CONFIG_DIR

    bases = {}
    for solver, extra in (("analytic_energy", []), ("cel2d", TINY_CEL)):
        for geometry in ("track_pioneer_i", "strip"):
            GlobalHydra.instance().clear()
            with initialize_config_dir(config_dir=CONFIG_DIR, version_base="1.3"):
                cfg = compose("config", overrides=["tracking=disabled", f"geometry={geometry}", f"solver={solver}",
                                                   *extra])
            bases[solver, geometry] = OmegaConf.to_container(cfg, resolve=True)
    GlobalHydra.instance().clear()
    return bases


def legal(bases, solver, scene):
    geometry, values = scene
    data = bases[solver, geometry]
    for path, value in values.items():
        data = with_value(data, path, value)
    return build_scene(data)


def check_result(result) -> None:
    assert result.status in ALLOWED_STATUSES, result.message
    assert result.message or result.status == "ok"
    assert all(math.isfinite(v) for v in result.metrics.values())
    if result.history is not None:
        assert all(np.isfinite(col).all() for col in result.history.values())


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(scene=legal_scene())
def test_random_legal_scene_never_crashes_the_energy_method(legal_bases, scene):
    from dsmv.analytic.energy import AnalyticEnergySolver

    result = AnalyticEnergySolver(legal(legal_bases, "analytic_energy", scene)).solve()
    check_result(result)
    if result.status == "ok":
        assert result.metrics["max_sinkage_m"] >= 0.0


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(scene=legal_scene())
def test_random_legal_scene_never_crashes_the_cel_solver(legal_bases, scene):
    from dsmv.cel.solver2d import Cel2DSolver

    result = Cel2DSolver(legal(legal_bases, "cel2d", scene)).solve()
    check_result(result)
    assert result.metrics["mass_error"] <= 1e-10


@pytest.mark.parametrize("ks", [5e-324, 2.2250738585072014e-308, 1e-300, 1e-12])
def test_energy_method_with_a_vanishing_ks_is_the_constant_deceleration(legal_bases, ks):
    """Found by the property above: a tiny ks divided by zero (5e-324), gave a NaN history
    (2e-308) or stopped the clock (t_rest = 0 at 1e-300). As ks → 0 the motion is the ks = 0
    one: constant deceleration a = (R0 − W)/M, at rest after v0/a at v0²/(2a)."""
    from dsmv.analytic.energy import AnalyticEnergySolver

    values = {"soil.ks_pa_per_m": ks, "soil.su0_pa": 500.0, "landing.gravity_m_s2": 0.0,
              "landing.velocity_m_s": 1.0, "landing.mass_kg": 500.0}
    vanishing = AnalyticEnergySolver(legal(legal_bases, "analytic_energy", ("track_pioneer_i", values))).solve()
    zero = AnalyticEnergySolver(legal(legal_bases, "analytic_energy", ("track_pioneer_i", values | {
        "soil.ks_pa_per_m": 0.0}))).solve()
    check_result(vanishing)
    assert zero.metrics["time_to_rest_s"] > 0
    assert vanishing.metrics["time_to_rest_s"] == pytest.approx(zero.metrics["time_to_rest_s"], rel=1e-9)
    for name in ("sinkage_m", "velocity_m_s"):
        assert vanishing.history[name] == pytest.approx(zero.history[name], rel=1e-9, abs=1e-12)
