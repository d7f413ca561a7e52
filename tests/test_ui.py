"""What the runs list shows: run names that say what a run computes."""

from __future__ import annotations

from pathlib import Path

from dsmv.config.tree import compose_scene
from dsmv.tracking.runs import run_name, short_overrides, sweep_name


def test_a_3d_and_a_2d_run_are_named_by_solver_soil_law_and_overrides():
    plate = ["solver=cel3d", "geometry=rectangular_plate", "landing.mass_kg=5000", "landing.velocity_m_s=1.0"]
    # where and how a run is kept, settings that change no result and the study name nothing
    kept = ["paths.runs_dir=/tmp/r", "hydra/launcher=joblib", "tracking=disabled", "solver.max_wall_s=7200",
            "experiment=study_mesh_3d", "output.plots=false"]
    assert run_name(compose_scene(plate), plate + kept) == \
        "cel3d einav_randolph geometry=rectangular_plate mass_kg=5000 velocity_m_s=1.0"
    track = ["soil=sample_II", "soil.law=tresca", "landing.mass_kg=6500", "geometry.contact_length_m=5.2"]
    assert run_name(compose_scene(track), track) == "cel2d tresca soil=sample_II mass_kg=6500 contact_length_m=5.2"
    assert run_name(compose_scene([]), []) == "cel2d einav_randolph"


def test_a_shortened_key_stays_whole_where_two_would_read_alike():
    assert short_overrides(["soil.params.x=1", "landing.x=2", "++soil.params.slope=0.05", "~mesh.y"]) == \
        ["soil.params.x=1", "landing.x=2", "slope=0.05", "~y"]


def test_a_sweep_is_named_by_what_it_varies():
    assert sweep_name("default_scene", ["landing.velocity_m_s=0.5,1.0", "soil.su0_pa=4000,6000",
                                        "hydra/launcher=joblib"], Path("/r/12-00-00")) == \
        "sweep velocity_m_s=0.5,1.0 su0_pa=4000,6000"
    assert sweep_name("study_strength", ["experiment=study_strength"], Path("/r/12-00-00")) == \
        "sweep study_strength 12-00-00"
