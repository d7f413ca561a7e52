"""Every option of every config group composes and validates into a scene."""

import pytest

from dsmv.config.scene import Scene, build_scene, build_tracking
from dsmv.errors import ConfigError
from tests.conftest import group_options

SCENE_GROUPS = ["soil", "geometry", "landing", "mesh", "solver", "tracking"]


@pytest.mark.parametrize(
    "group,option", [(g, o) for g in SCENE_GROUPS for o in group_options(g)], ids=lambda v: str(v)
)
def test_every_group_option_builds_a_scene(compose_cfg, group, option):
    # a T-bar is not a track: the energy method refuses it, the CEL solver runs it; the 3D solver runs plates
    extra = {("geometry", "tbar"): ["solver=cel2d"], ("solver", "cel3d"): ["geometry=rectangular_plate"]}.get(
        (group, option), [])
    cfg = compose_cfg([f"{group}={option}", *extra])
    scene = build_scene(cfg)
    assert isinstance(scene, Scene)
    # mesh=auto settles to the solver's default mesh; a solver option may be another plugin's settings
    named = {("mesh", "auto"): "standard", ("solver", "analytic_dynamic_3d"): "analytic_dynamic"}
    if group not in ("landing", "tracking"):
        assert getattr(cfg, group).name == named.get((group, option), option)
    build_tracking(cfg)


@pytest.mark.parametrize("experiment", group_options("experiment"))
def test_every_experiment_composes(compose_cfg, experiment):
    cfg = compose_cfg([f"experiment={experiment}"], return_hydra_config=True)
    assert cfg.study == experiment
    assert build_scene(cfg).study == experiment
    # a sweep says so itself, so that it runs with or without -m
    assert str(cfg.hydra.mode) == "RunMode.MULTIRUN"
    sweeper = cfg.hydra.sweeper
    # what it sweeps: a product of params, or cases (hydra/sweeper=cases: vary, cases, cases_from)
    assert sweeper.params or sweeper.get("vary") or sweeper.get("cases") or sweeper.get("cases_from")


def test_the_default_scene_is_the_documented_one(compose_cfg):
    scene = build_scene(compose_cfg())
    soil, body, landing = scene.soil, scene.geometry, scene.landing
    assert (soil.name, soil.law, soil.su0_pa, soil.ks_pa_per_m) == ("nodule_field", "einav_randolph", 5000.0, 1500.0)
    assert (soil.sensitivity, soil.xi95, soil.rate.law, soil.rate.eta) == (3.0, 25.0, "power", 0.05)
    assert (soil.density_kg_m3, soil.youngs_modulus_pa, soil.poisson_ratio) == (600.0, 500 * 5000.0, 0.49)
    assert (body.name, body.width_m, body.contact_length_m, body.roughness) == ("track_pioneer_i", 0.6, 4.17, "rough")
    assert (landing.kind, landing.mass_kg, landing.velocity_m_s, landing.n_tracks) == ("drop", 4500.0, 1.5, 1)
    assert (scene.mesh.name, scene.mesh.cell_size_m) == ("standard", 0.02)


def test_each_solver_runs_its_own_default_mesh_and_an_explicit_mesh_wins(compose_cfg):
    """mesh=auto: cel2d the standard mesh, cel3d the coarse one (0.075 m on the track, within 1 % of the
    extrapolated 3D answer); mesh=<name> or a key the user sets is kept, and the composed config names
    the mesh that runs."""
    cfg = compose_cfg(["solver=cel3d"])
    assert (build_scene(cfg).mesh.name, build_scene(cfg).mesh.cell_size_m) == ("coarse", 0.08)
    assert (cfg.mesh.name, cfg.mesh.cell_size_m) == ("coarse", 0.08)
    assert build_scene(compose_cfg(["solver=cel3d", "mesh=medium"])).mesh.cell_size_m == 0.04
    custom = build_scene(compose_cfg(["solver=cel3d", "mesh.cell_size_m=0.05"])).mesh
    assert (custom.name, custom.cell_size_m, custom.growth_ratio) == ("custom", 0.05, 1.1)
    assert build_scene(compose_cfg(["experiment=dataset_table3", "solver=cel3d"])).mesh.name == "coarse"
    assert build_scene(compose_cfg(["experiment=dataset_table3"])).mesh.name == "standard"


def test_youngs_modulus_follows_su0_unless_given(compose_cfg):
    assert build_scene(compose_cfg(["soil.su0_pa=4000"])).soil.youngs_modulus_pa == 2.0e6
    assert build_scene(compose_cfg(["soil.youngs_modulus_pa=3e6"])).soil.youngs_modulus_pa == 3.0e6


def test_table1_samples_follow_the_stated_reading(compose_cfg):
    expected = {"sample_I": (590, 15e3, 7.5e6, 10), "sample_II": (520, 4.2e3, 2.1e6, 42),
                "sample_III": (660, 8.2e3, 4.1e6, 16.4), "sample_IV": (180, 11e3, 5.5e6, 8.5)}
    for name, (rho, su, e, st) in expected.items():
        soil = build_scene(compose_cfg([f"soil={name}"])).soil
        assert (soil.density_kg_m3, soil.su0_pa, soil.youngs_modulus_pa, soil.sensitivity) == (rho, su, e, st)
        assert soil.youngs_modulus_pa == pytest.approx(500 * soil.su0_pa)


def test_config_hash_tracks_physics_only(compose_cfg):
    base = build_scene(compose_cfg()).config_hash
    assert build_scene(compose_cfg(["study=other", "tracking=disabled"])).config_hash == base
    assert build_scene(compose_cfg(["landing.velocity_m_s=1.0"])).config_hash != base


@pytest.mark.parametrize("option", group_options("solver"))
def test_solver_yaml_documents_every_setting_of_its_schema(compose_cfg, option):
    """Each solver's YAML lists exactly its schema's fields, so every knob is visible and overridable."""
    from dsmv import registry

    cfg = compose_cfg([f"solver={option}"])
    schema = registry.load("solvers", cfg.solver.name, "solver.name").config_model
    assert set(cfg.solver.keys()) == set(schema.model_fields)


def test_the_cel_defaults_are_the_documented_numerics(compose_cfg):
    """The CEL solver's defaults have one home, its YAML (the schema requires every field): the
    values the verification and the benchmarks were measured with."""
    solver = build_scene(compose_cfg(["solver=cel2d"])).solver
    assert (solver.cfl, solver.hourglass, solver.bulk_viscosity_linear, solver.bulk_viscosity_quadratic) == (
        0.5, 0.05, 0.06, 1.2)
    assert (solver.advection_order, solver.remap_courant, solver.stress_cutoff, solver.remap) == (2, 0.05, 0.01, True)
    assert (solver.domain_depth_widths, solver.domain_half_width_widths, solver.core_margin_widths) == (5.0, 5.0, 1.0)
    assert solver.economies.skip_void and solver.economies.symmetry and solver.contact_separation == "auto"


def test_a_solver_yaml_missing_a_setting_fails_at_composition(compose_cfg):
    from omegaconf import OmegaConf, open_dict

    cfg = compose_cfg(["solver=cel2d"])
    with open_dict(cfg):
        del cfg.solver["hourglass"]
    assert "hourglass" not in OmegaConf.to_container(cfg.solver)
    with pytest.raises(ConfigError, match=r"solver\.hourglass"):
        build_scene(cfg)
