"""Wrong values fail at composition with one line: config path, value, what is allowed."""

import pytest

from dsmv.config.scene import build_scene
from dsmv.errors import ConfigError

BAD_VALUES = [
    ("landing.mass_kg=-1", "landing.mass_kg", "greater than 0"),
    ("landing.velocity_m_s=-0.5", "landing.velocity_m_s", "greater than or equal to 0"),
    ("landing.n_tracks=0", "landing.n_tracks", "greater than or equal to 1"),
    ("landing.n_tracks=1.5", "landing.n_tracks", "integer"),
    ("soil.sensitivity=0.9", "soil.sensitivity", "greater than or equal to 1"),
    ("soil.poisson_ratio=0.5", "soil.poisson_ratio", "less than 0.5"),
    ("soil.su0_pa=0", "soil.su0_pa", "greater than 0"),
    ("soil.ks_pa_per_m=-1", "soil.ks_pa_per_m", "greater than or equal to 0"),
    ("soil.xi95=0", "soil.xi95", "greater than 0"),
    ("soil.rate.law=linear", "soil.rate.law", "'power' or 'log'"),
    ("soil.rate.eta=-0.1", "soil.rate.eta", "greater than or equal to 0"),
    ("soil.density_kg_m3=true", "soil.density_kg_m3", "not a boolean"),
    ("soil.su0_pa=nan", "soil.su0_pa", "finite"),
    ("geometry.contact_length_m=0", "geometry.contact_length_m", "greater than 0"),
    ("geometry.width_m=-1", "geometry.width_m", "greater than 0"),
    ("geometry.roughness=sticky", "geometry.roughness", "'rough', 'smooth'"),
    ("geometry.roughness=1.5", "geometry.roughness", "adhesion factor"),
    ("geometry.view=top", "geometry.view", "cross_section"),
    ("mesh.cell_size_m=0", "mesh.cell_size_m", "greater than 0"),
    ("mesh.max_cell_size_m=0.01", "mesh.max_cell_size_m", "mesh.cell_size_m"),
    ("mesh.growth_ratio=2", "mesh.growth_ratio", "less than or equal to 1.5"),
    ("soil.law=nope", "soil.law", "tresca"),
    ("solver.name=nope", "solver.name", "available: analytic_dynamic, analytic_energy"),
    ("solver=analytic_energy solver.shape_factor=-1", "solver.shape_factor", "skempton"),
    ("+soil.su0=5", "soil.su0", "Extra inputs"),
    ("soil.su0_pa=abc", "soil.youngs_modulus_pa", "'abc' is not a number"),
    ("tracking.uri=null", "tracking.uri", "tracking=disabled"),
    ("sweep_plot=nope", "sweep_plot", "fall_cone"),
    ("solver=analytic_energy geometry=tbar", "geometry.kind", "solver=cel2d"),
    ("solver=cel2d geometry=fall_cone_30deg geometry.roughness=0.5", "geometry.roughness", "limited adhesion"),
    ("solver=cel2d geometry.view=longitudinal geometry.roughness=smooth", "geometry.roughness", "rough track only"),
    ("solver=cel2d geometry.view=sideways", "geometry.view", "longitudinal"),
    ("geometry=fall_cone_30deg geometry.roughness=smooth", "geometry.roughness", "cut cells"),
    ("geometry=fall_cone_30deg solver.mode=plane_strain", "solver.mode", "axisymmetric"),
    ("geometry=fall_cone_30deg solver.contact_separation=true", "solver.contact_separation", "tied fully"),
    ("geometry=fall_cone_30deg solver.economies.symmetry=false", "solver.economies.symmetry", "its own whole"),
]


@pytest.mark.parametrize("override,path,allowed", BAD_VALUES, ids=[b[0] for b in BAD_VALUES])
def test_bad_value_names_path_value_and_allowed(compose_cfg, override, path, allowed):
    with pytest.raises(ConfigError) as info:
        build_scene(compose_cfg(override.split()))
    assert info.value.path == path
    assert allowed in str(info.value)
    if path == "soil.law":  # an unknown plugin lists what is installed
        assert "available: " in str(info.value) and "einav_randolph" in str(info.value)
    assert "\n" not in str(info.value)


def test_push_needs_a_velocity(compose_cfg):
    with pytest.raises(ConfigError, match="landing.velocity_m_s"):
        build_scene(compose_cfg(["landing=push", "landing.velocity_m_s=0"]))


@pytest.mark.parametrize(
    "override,expected",
    [("landing.mass_kg=-1", "landing.mass_kg = -1"), ("soil.law=nope", "tresca"),
     ("soil=nope", "available: ccz_box_core, nodule_field, sample_I"), ("mesh=coarse,tiny", "mesh = 'tiny'")],
)
def test_cli_reports_one_line_without_traceback(run_cli, override, expected):
    proc = run_cli("dsmv", override, "tracking=disabled")
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and expected in lines[0]
    assert "Traceback" not in proc.stderr + proc.stdout
