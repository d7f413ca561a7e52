"""Every registered soil law against its own NumPy twin, closed forms, limits and monotonicity."""

import json
import os
from pathlib import Path
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dsmv import registry
from dsmv.app.template import package_files
from dsmv.config.scene import build_scene

LAWS = list(registry.available("soil_laws"))


def make_law(compose_cfg, name, *overrides):
    scene = build_scene(compose_cfg([f"soil.law={name}", *overrides]))
    return registry.load("soil_laws", name, "soil.law")(scene.soil), scene


def test_builtin_laws_are_registered():
    assert {"tresca", "einav_randolph"} <= set(LAWS)


#: every installed law that runs with soil.params empty (each declared parameter has a default): a
#: third-party law installed beside dsmv is held to the same contract
LAWS_ON_DEFAULTS = [name for name in LAWS if registry.load("soil_laws", name, "soil.law").runs_on_defaults()]


@pytest.mark.parametrize("name", LAWS_ON_DEFAULTS)
@pytest.mark.parametrize("rate_law", ["power", "log"])
def test_every_installed_law_keeps_the_plugin_contract(name, rate_law):
    """dsmv.testing's checks, as a plugin's own tests call them: the compiled factor equals the NumPy
    twin (1e-12), intact strength at rest, no effect the law does not declare, softening in ξ and
    hardening in γ̇, and one cell in simple shear through the kernel on the twin's curve (1 %)."""
    from dsmv.testing import check_kernel_matches_twin, check_limits, check_monotone, check_simple_shear
    from dsmv.testing import make_law as make

    law = make(name, f"soil.rate.law={rate_law}", "soil.rate.eta=0.1", "soil.rate.mu=0.15", "soil.sensitivity=4",
               "soil.xi95=15")
    check_kernel_matches_twin(law)
    check_limits(law)
    check_monotone(law)
    if not law.state_variables():
        check_simple_shear(law)


def test_the_checks_catch_a_law_that_breaks_the_contract():
    """dsmv.testing names the point where a law breaks each part of the contract."""
    from dsmv.testing import check_kernel_matches_twin, check_limits, check_monotone

    law = _negative_law()(build_scene_default_soil())
    with pytest.raises(AssertionError, match="negative or not finite at ξ = "):
        check_kernel_matches_twin(law)
    rising = _negative_law()
    rising.strength_factor = lambda self, xi, g, *s: 1.0 + 0.01 * np.asarray(xi, dtype=float)
    with pytest.raises(AssertionError, match="rises with ξ"):
        check_monotone(rising(build_scene_default_soil()))
    unsheared = _negative_law()
    unsheared.strength_factor = lambda self, xi, g, *s: 0.9 + 0.0 * np.asarray(xi, dtype=float)
    with pytest.raises(AssertionError, match="not 1"):
        check_limits(unsheared(build_scene_default_soil()))


def build_scene_default_soil():
    from dsmv.testing import compose_scene

    return compose_scene("soil.law=tresca").soil


def test_einav_randolph_limits(compose_cfg):
    law, scene = make_law(compose_cfg, "einav_randolph", "soil.sensitivity=5", "soil.rate.eta=0.1")
    assert law.strength_factor(1e6, 0.0) == pytest.approx(1 / 5)  # fully remoulded: 1/St
    assert law.strength_factor(0.0, 0.0) == 1.0  # intact, γ̇ → 0: R = 1 (power)
    assert law.strength_factor(scene.soil.xi95, 0.0) == pytest.approx(1 / 5 + (4 / 5) * math.exp(-3))  # 95 % lost
    log_law, log_scene = make_law(compose_cfg, "einav_randolph", "soil.rate.law=log", "soil.rate.mu=0.2")
    ref = log_scene.soil.rate.gamma_dot_ref
    assert log_law.strength_factor(0.0, 0.5 * ref) == 1.0  # γ̇ ≤ γ̇ref: R = 1 (log)
    assert log_law.strength_factor(0.0, 1000 * ref) == pytest.approx(1 + 0.2 * 3)  # three decades


def test_inactive_law_is_the_tresca_path(compose_cfg):
    law, _ = make_law(compose_cfg, "einav_randolph", "soil.sensitivity=1", "soil.rate.eta=0")
    assert not law.active
    assert make_law(compose_cfg, "einav_randolph")[0].active


@settings(max_examples=60, deadline=None)
@given(
    st_=st.floats(1.0, 10.0), xi95=st.floats(10.0, 50.0), eta=st.floats(0.0, 0.15), n=st.floats(0.05, 1.0),
    xi=st.floats(0.0, 200.0), dxi=st.floats(0.0, 50.0), g=st.floats(0.0, 1e3), dg_decades=st.floats(0.0, 6.0),
)
def test_einav_randolph_monotone_in_strain_and_rate(st_, xi95, eta, n, xi, dxi, g, dg_decades):
    from dsmv.config.scene import SoilConfig
    from dsmv_plugins.einav_randolph import EinavRandolphLaw

    soil = SoilConfig(name="h", law="einav_randolph", su0_pa=5e3, ks_pa_per_m=0, sensitivity=st_, xi95=xi95,
                      rate={"law": "power", "eta": eta, "n": n, "gamma_dot_ref": 3e-6}, density_kg_m3=600,
                      youngs_modulus_pa=2.5e6, poisson_ratio=0.49)
    law = EinavRandolphLaw(soil)
    assert law.strength_factor(xi + dxi, g) <= law.strength_factor(xi, g) * (1 + 1e-12)  # softens with ξ
    assert law.strength_factor(xi, g * 10**dg_decades) >= law.strength_factor(xi, g) * (1 - 1e-12)  # faster: stronger


@pytest.mark.parametrize("overrides", [["soil.sensitivity=4", "soil.xi95=2", "soil.rate.eta=0"],
                                       ["soil.sensitivity=3", "soil.xi95=3", "soil.rate.eta=0.1"],
                                       ["soil.sensitivity=2", "soil.xi95=2", "soil.rate.law=log", "soil.rate.mu=0.1"]])
def test_single_element_simple_shear_follows_the_closed_form(compose_cfg, overrides):
    """τ(γ) solves τ = su0·f(ξ = γ − τ/G, γ̇): the law's strength curve along the applied strain
    (dsmv.testing.check_simple_shear, 1 %), and the element softened."""
    from dsmv.testing import check_simple_shear, simple_shear

    law, _ = make_law(compose_cfg, "einav_randolph", "soil.youngs_modulus_pa=2.5e6", *overrides)
    check_simple_shear(law)
    _, taus, _ = simple_shear(law, 0.5, 6.0)
    assert taus[-1] < taus.max()


def test_einav_randolph_at_st1_eta0_lands_like_tresca(compose_cfg):
    from dsmv.cel.solver2d import Cel2DSolver

    common = ["solver=cel2d", "mesh=coarse", "solver.progress=off"]
    er = Cel2DSolver(build_scene(compose_cfg(common + ["soil.law=einav_randolph", "soil.sensitivity=1",
                                                      "soil.rate.eta=0"]))).solve()
    tresca = Cel2DSolver(build_scene(compose_cfg(common + ["soil.law=tresca"]))).solve()
    assert er.metrics["max_sinkage_m"] == pytest.approx(tresca.metrics["max_sinkage_m"], rel=1e-9)


def test_einav_randolph_landing_trends(compose_cfg):
    """The reference study's Figure 9 directions: sinkage grows with St, falls with ξ95 and with η."""
    from dsmv.cel.solver2d import Cel2DSolver

    def sinkage(*overrides):
        scene = build_scene(compose_cfg(["solver=cel2d", "mesh=coarse", "solver.progress=off",
                                         "soil.law=einav_randolph", *overrides]))
        result = Cel2DSolver(scene).solve()
        assert result.status == "ok", result.message
        return result.metrics["max_sinkage_m"]

    assert sinkage("soil.sensitivity=1.5") < sinkage("soil.sensitivity=6")
    assert sinkage("soil.xi95=50") < sinkage("soil.xi95=10")
    assert sinkage("soil.rate.eta=0.15") < sinkage("soil.rate.eta=0")


#: the template's law (dsmv-plugins new soil-law), as a one-module plugin: linear softening with its
#: declared parameter soil.params.slope
NEW_LAW = package_files("soil-law", "linear_softening")["linear_softening_law/law.py"]


def test_a_new_law_in_its_own_package_is_picked_up_by_name(run_cli, install_plugin):
    """One module, one entry-point line: no change to dsmv/. Its declared parameter takes its default,
    and a bad or misspelt value of it is one line and exit 2 naming soil.params.<key>."""
    install_plugin("my_soil_laws", NEW_LAW, "dsmv.soil_laws", "linear_softening", "LinearSofteningLaw")
    assert "linear_softening" in run_cli("dsmv-plugins").stdout
    common = ["soil.law=linear_softening", "solver=cel2d", "mesh=coarse", "tracking=disabled"]
    proc = run_cli("dsmv", *common)
    assert proc.returncode == 0, proc.stderr
    assert "dsmv: ok" in proc.stdout and "(linear_softening)" in proc.stdout
    for override, message in (("+soil.params.slope=1.5", "soil.params.slope = 1.5: must be less than or equal to 1"),
                              ("+soil.params.slop=0.1", "did you mean soil.params.slope?")):
        proc = run_cli("dsmv", *common, override)
        assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
        assert message in proc.stderr


def test_a_plugin_whose_target_does_not_load_is_named_by_the_check_and_refused_at_composition(run_cli,
                                                                                            install_plugin):
    install_plugin("my_soil_laws", NEW_LAW, "dsmv.soil_laws", "linear_softening", "LinearSofteningLaww")
    proc = run_cli("dsmv-plugins", "--check")
    assert proc.returncode == 1
    assert "dsmv.soil_laws:linear_softening = my_soil_laws:LinearSofteningLaww" in proc.stderr
    assert "AttributeError" in proc.stderr
    proc = run_cli("dsmv", "soil.law=linear_softening", "tracking=disabled")
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "soil.law = 'linear_softening': its entry point my_soil_laws:LinearSofteningLaww" in proc.stderr


def test_every_plugin_dsmv_ships_loads(run_cli):
    proc = run_cli("dsmv-plugins", "--check")
    assert proc.returncode == 0 and "plugins load" in proc.stdout, proc.stderr


def test_a_missing_declared_parameter_without_default_is_one_line_naming_it():
    from pydantic import Field

    from dsmv.errors import ConfigError
    from dsmv.config.scene import _law_parameters
    from dsmv.soil_law import LawParameters
    from dsmv.testing import compose_scene

    class Needed(LawParameters):
        r: float = Field(gt=0, le=1, description="the residual strength ratio (-)")

    law = type("NeedsR", (), {"parameters_model": Needed})
    soil = compose_scene("soil.law=tresca").soil
    with pytest.raises(ConfigError, match=r"^soil.params.r = None: missing: the residual strength ratio \(-\)$"):
        _law_parameters(law, soil)
    filled = _law_parameters(law, soil.model_copy(update={"params": {"r": 0.4}}))
    assert filled.params == {"r": 0.4}


def test_fall_cone_implied_hansbo_factor(compose_cfg):
    """GEONOR 30° cone, 0.1 kg, sample I, coarse cells. Einav–Randolph with the default rate
    parameters lands inside the 0.5–1.33 range published for 30° cones; Tresca, with no rate
    effect, penetrates deeper (K = su·d²/(m·g) is larger)."""
    from dsmv.cel.solver2d import Cel2DSolver

    def hansbo_k(law):
        scene = build_scene(compose_cfg(["geometry=fall_cone_30deg", "soil=sample_I", f"soil.law={law}",
                                         "solver.cone_cells_per_depth=6", "solver.progress=off"]))
        result = Cel2DSolver(scene).solve()
        assert result.status == "ok", result.message
        assert result.metrics["mass_error"] < 1e-10 and result.metrics["energy_error"] < 0.02
        return result.metrics["hansbo_k"]

    k_er, k_tresca = hansbo_k("einav_randolph"), hansbo_k("tresca")
    assert 0.5 <= k_er <= 1.33
    assert k_tresca > k_er


def test_a_softening_cone_is_given_the_room_to_stop(compose_cfg):
    """A cone in a sensitive soil without rate effect sinks past 1.5 × Hansbo's K = 0.8 depth, which once
    sized its domain and ended such a drop as a bearing failure; sized by the soil's measured softening
    it comes to rest, deeper than that."""
    from dsmv.cel.solver2d import Cel2DSolver

    scene = build_scene(compose_cfg(["geometry=fall_cone_30deg", "soil.su0_pa=5000", "soil.ks_pa_per_m=0",
                                     "soil.youngs_modulus_pa=2.5e6", "soil.sensitivity=10", "soil.xi95=5",
                                     "soil.rate.eta=0", "solver.cone_cells_per_depth=8", "solver.progress=off"]))
    result = Cel2DSolver(scene).solve()
    assert result.status == "ok", result.message
    old_room = 1.5 * (0.8 * scene.landing.mass_kg * 9.81 / 5000.0) ** 0.5
    assert result.metrics["max_sinkage_m"] > old_room


STATEFUL_LAW = '''
import math
import numpy as np
from dsmv.soil_law import SoilLaw


class XiMemoryLaw(SoilLaw):
    """Einav-Randolph softening (no rate) read from a state variable that accumulates ξ itself."""
    name = "xi_memory"

    def state_variables(self):
        return {"xi_copy": 0.0}

    def parameters(self):
        return np.array([1.0 / self.soil.sensitivity, self.soil.xi95])

    @staticmethod
    def factor(xi, gamma_dot, s0, s1, d_rem, xi95, p2, p3, p4, p5, p6, p7):
        return d_rem + (1.0 - d_rem) * math.exp(-3.0 * s0 / xi95)

    @staticmethod
    def evolve(k, s0, s1, xi, dxi, gamma_dot, dt, d_rem, xi95, p2, p3, p4, p5, p6, p7):
        return s0 + dxi

    def strength_factor(self, xi, gamma_dot_per_s, *state):
        d_rem = 1.0 / self.soil.sensitivity
        return d_rem + (1.0 - d_rem) * np.exp(-3.0 * np.asarray(state[0]) / self.soil.xi95)
'''


def test_a_law_state_variable_is_carried_with_the_material(run_cli, install_plugin, tmp_path):
    """A state variable that sums the plastic strain increments, advected with the soil, is ξ
    itself: the landing matches Einav–Randolph without rate effect to round-off. It also shows
    that soil entering at the base brings the initial state and that the remap moves it."""
    install_plugin("xi_memory_law", STATEFUL_LAW, "dsmv.soil_laws", "xi_memory", "XiMemoryLaw")
    common = ["solver=cel2d", "mesh=coarse", "tracking=disabled", "output.plots=false", "soil.sensitivity=5",
              "soil.xi95=2", "landing.velocity_m_s=3"]
    sinkages = []
    for law in (["soil.law=xi_memory"], ["soil.law=einav_randolph", "soil.rate.eta=0"]):
        proc = run_cli("dsmv", *common, *law, "hydra.run.dir=run_" + law[0].split("=")[1])
        assert proc.returncode == 0, proc.stderr[-2000:]
        result = json.loads((tmp_path / ("run_" + law[0].split("=")[1]) / "result.json").read_text())
        assert result["status"] == "ok", result["message"]
        sinkages.append(result["metrics"]["max_sinkage_m"])
    tresca = run_cli("dsmv", *common, "soil.law=tresca", "hydra.run.dir=run_tresca")
    assert tresca.returncode == 0, tresca.stderr[-2000:]
    tresca_sinkage = json.loads((tmp_path / "run_tresca" / "result.json").read_text())["metrics"]["max_sinkage_m"]
    assert sinkages[0] == pytest.approx(sinkages[1], rel=1e-9)
    assert sinkages[0] > tresca_sinkage * 1.01  # the state did soften the soil


def _negative_law():
    """A broken law for the guard: its factor 1 − 40·ξ turns negative once ξ passes 0.025."""
    from dsmv.soil_law import SoilLaw

    class NegativeLaw(SoilLaw):
        name = "negative_past_0p025"

        @property
        def softens(self):
            return True

        @staticmethod
        def factor(xi, gamma_dot, s0, s1, p0, p1, p2, p3, p4, p5, p6, p7):
            return 1.0 - 40.0 * xi

        def strength_factor(self, xi, gamma_dot_per_s, *state):
            return 1.0 - 40.0 * np.asarray(xi, dtype=float)

    return NegativeLaw


def test_a_law_whose_factor_turns_negative_fails_the_run_naming_it(compose_cfg, monkeypatch):
    """A negative (or non-finite) factor is the plugin's fault: the run raises a one-line PluginError
    naming soil.law and the cell's ξ and γ̇ (the runner records it as failed, exit code of failed),
    never an ok run with a wrong answer."""
    from dsmv.errors import PluginError

    law = _negative_law()
    real_load, real_check = registry.load, registry.check_name
    monkeypatch.setattr(registry, "check_name", lambda kind, name, path: None if name == law.name
                        else real_check(kind, name, path))
    monkeypatch.setattr(registry, "load", lambda kind, name, path: law if name == law.name
                        else real_load(kind, name, path))
    scene = build_scene(compose_cfg([f"soil.law={law.name}", "mesh=coarse", "tracking=disabled",
                                     "solver.progress=off"]))
    solver = registry.load("solvers", "cel2d", "solver.name")(scene)
    with pytest.raises(PluginError, match=rf"^soil.law = '{law.name}' returned a strength factor that is negative "
                                          r"or not finite at cell \(\d+, \d+\) \(ξ = [0-9.e+-]+, γ̇ = "):
        solver.solve()


def _install_generated(root, site):
    """Install a generated package as pip would for the CLI subprocesses: its folder on PYTHONPATH and
    a dist-info whose entry points are those of its pyproject.toml."""
    import os
    import tomllib

    project = tomllib.loads((root / "pyproject.toml").read_text())["project"]
    dist = site / f"{project['name'].replace('-', '_')}-{project['version']}.dist-info"
    dist.mkdir(parents=True)
    (dist / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {project['name']}\nVersion: {project['version']}\n")
    (dist / "entry_points.txt").write_text("".join(
        f"[{group}]\n" + "".join(f"{k} = {v}\n" for k, v in points.items()) + "\n"
        for group, points in project["entry-points"].items()))
    return os.pathsep.join([str(site), str(root), os.environ.get("PYTHONPATH", "")])


def test_the_template_writes_a_law_package_that_installs_runs_and_passes_its_tests(run_cli, tmp_path, monkeypatch):
    """dsmv-plugins new soil-law: the law with a declared parameter, a soil profile of its own (found
    through the dsmv.configs entry point) and tests on dsmv.testing. Installed, it is listed and
    loads, lands ok selected by its profile and by soil.law, its generated tests pass, and so do
    dsmv's own contract checks, which now include it."""
    import subprocess
    import sys

    proc = run_cli("dsmv-plugins", "new", "soil-law", "my_clay", "--dir", str(tmp_path / "pkgs"))
    assert proc.returncode == 0, proc.stderr
    root = tmp_path / "pkgs" / "my-clay-law"
    monkeypatch.setenv("PYTHONPATH", _install_generated(root, tmp_path / "site"))
    assert run_cli("dsmv-plugins", "--check").returncode == 0
    listed = run_cli("dsmv-plugins").stdout
    assert "my_clay_law.law:MyClayLaw" in listed and "dsmv.configs:\n  my_clay" in listed, listed
    assert "soil: ccz_box_core, my_clay_clay, nodule_field" in run_cli("dsmv", "--help").stdout  # Hydra lists it too
    proc = run_cli("dsmv", "-m", "soil=my_clay_clay,nodule_field", "soil.law=my_clay", "mesh=coarse",
                   "tracking=disabled", "output.plots=false")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.count("ok: max sinkage") == 2 and "sweep done: 2 ok" in proc.stdout, proc.stdout
    env = dict(os.environ, NUMBA_NUM_THREADS="1")
    generated = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(root / "tests")],
                               cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert generated.returncode == 0 and "5 passed" in generated.stdout, generated.stdout + generated.stderr
    ours = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", f"{__file__}::"
                           "test_every_installed_law_keeps_the_plugin_contract"], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=300)
    assert ours.returncode == 0 and "6 passed" in ours.stdout, ours.stdout + ours.stderr  # 3 laws × 2 rate forms


def test_the_template_refuses_a_name_that_is_not_an_identifier(run_cli, tmp_path):
    proc = run_cli("dsmv-plugins", "new", "soil-law", "My-Law", "--dir", str(tmp_path))
    assert proc.returncode == 2 and "NAME = 'My-Law': must be a lower-case Python identifier" in proc.stderr


@pytest.mark.parametrize("how", ["--config-dir", "hydra.searchpath"])
def test_a_profile_in_a_config_dir_of_ones_own_is_a_soil_option(run_cli, tmp_path, how):
    """Hydra's own ways to add configs: the option is found, not refused as 'not a soil option'."""
    from dsmv.config.tree import CONFIG_DIR

    folder = tmp_path / "my_conf" / "soil"
    folder.mkdir(parents=True)
    text = (Path(CONFIG_DIR) / "soil" / "nodule_field.yaml").read_text().replace("name: nodule_field", "name: my_site")
    (folder / "my_site.yaml").write_text(text)
    where = (["--config-dir", str(tmp_path / "my_conf")] if how == "--config-dir"
             else [f"hydra.searchpath=[file://{tmp_path / 'my_conf'}]"])
    proc = run_cli("dsmv", *where, "soil=my_site", "--cfg", "job")
    assert proc.returncode == 0, proc.stderr
    assert "name: my_site" in proc.stdout


def test_the_template_writes_a_surrogate_package_that_installs_and_passes_its_tests(run_cli, tmp_path, monkeypatch):
    """dsmv-plugins new surrogate: the plugin, its surrogate option (found through dsmv.configs) and
    tests on dsmv.testing; installed, it loads and its generated tests pass."""
    import subprocess
    import sys

    proc = run_cli("dsmv-plugins", "new", "surrogate", "my_trees", "--dir", str(tmp_path / "pkgs"))
    assert proc.returncode == 0, proc.stderr
    root = tmp_path / "pkgs" / "my-trees-surrogate"
    monkeypatch.setenv("PYTHONPATH", _install_generated(root, tmp_path / "site"))
    assert run_cli("dsmv-plugins", "--check").returncode == 0
    generated = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(root / "tests")],
                               cwd=tmp_path, env=dict(os.environ), capture_output=True, text=True, timeout=300)
    assert generated.returncode == 0 and "2 passed" in generated.stdout, generated.stdout + generated.stderr
