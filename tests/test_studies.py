"""The parametric studies: the case sweeper, the study summaries, and the study's trends.

The trend test runs the three parameter studies on the coarse mesh and asserts that max
sinkage moves strictly in the reference study's direction (Figures 7, 9, 11) for each of
the eight parameters: down with su0, ks, xi95, eta and L; up with St, mass and touchdown
velocity.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from dsmv.post import studies
from hydra_plugins.dsmv_sweeper.case_sweeper import one_at_a_time

STUDY_DIRECTIONS = {
    "study_strength": {"soil.su0_pa": "down", "soil.ks_pa_per_m": "down"},
    "study_softening": {"soil.sensitivity": "up", "soil.xi95": "down", "soil.rate.eta": "down"},
    "study_dynamics": {"landing.mass_kg": "up", "landing.velocity_m_s": "up", "geometry.contact_length_m": "down"},
}


def _sweep_dir(tmp_path: Path) -> Path:
    found = sorted((tmp_path / "runs" / "multirun").glob("*/*"))
    assert len(found) == 1, found
    return found[0]


def _read_csv(path: Path) -> list[dict]:
    with path.open() as fh:
        return list(csv.DictReader(fh))


def test_one_at_a_time_cases_vary_one_key_each():
    cases = one_at_a_time({"a.b": [1, 2], "c": [3]})
    assert cases == [["a.b=1"], ["a.b=2"], ["c=3"]]
    with pytest.raises(ValueError, match="hydra.sweeper.vary.c"):
        one_at_a_time({"c": []})


@pytest.mark.parametrize("values, sinkages, expected", [
    ([1, 2, 3], [0.3, 0.2, 0.1], "down"),
    ([3, 1, 2], [0.1, 0.3, 0.2], "down"),   # order of the jobs does not matter
    ([1, 2, 3], [0.1, 0.2, 0.3], "up"),
    ([1, 2, 3], [0.1, 0.1, 0.3], "mixed"),  # strictly: a tie is not a trend
    ([1, 2, 3], [0.1, 0.3, 0.2], "mixed"),
])
def test_trend_is_strict(values, sinkages, expected):
    assert studies.trend(values, sinkages) == expected


@pytest.mark.parametrize("solver", ["cel2d", pytest.param("cel3d", marks=pytest.mark.slow)])
@pytest.mark.parametrize("study", sorted(STUDY_DIRECTIONS))
def test_parameter_studies_move_in_the_reference_directions_on_the_coarse_mesh(run_cli, tmp_path, study, solver):
    """Each study on the coarse mesh, the track's cross-section (cel2d) or the track in 3D (cel3d, its
    grousers as trapped soil: 2–3 minutes a study on one core)."""
    done = run_cli("dsmv", f"experiment={study}", f"solver={solver}", "mesh=coarse", "tracking=disabled",
                   "output.plots=false", timeout=1800)
    assert done.returncode == 0, done.stderr[-2000:]
    sweep = _sweep_dir(tmp_path)
    rows = _read_csv(sweep / "one_at_a_time.csv")
    assert (sweep / "one_at_a_time.png").stat().st_size > 10_000
    jobs = [r for r in rows if r["status"] != "trend"]
    assert all(r["status"] == "ok" for r in jobs), [(r["parameter"], r["value"], r["status"]) for r in jobs]
    trends = {r["parameter"]: r["trend"] for r in rows if r["status"] == "trend"}
    assert trends == STUDY_DIRECTIONS[study]


def test_compare_analytic_pairs_cases_and_splits_the_gap(run_cli, tmp_path):
    """Two of the eight cases on the coarse mesh: the table pairs each case's runs (energy method, fast
    model and CEL, each with Tresca and Einav–Randolph)."""
    done = run_cli("dsmv", "experiment=compare_analytic", "mesh=coarse", "tracking=disabled", "output.plots=false",
                   'hydra.sweeper.cases=[["landing.mass_kg=3000","soil.su0_pa=10000"],["landing.mass_kg=6500","soil.su0_pa=3000"]]',
                   timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    sweep = _sweep_dir(tmp_path)
    rows = _read_csv(sweep / "compare_analytic.csv")
    assert len(rows) == 2
    for row in rows:
        z_a, z_t, z_er = (float(row[k]) for k in ("analytic_m", "cel_tresca_m", "cel_einav_randolph_m"))
        # the parts compose into the total: (1 + mechanics)(1 + law) = 1 + total
        total = (1 + float(row["mechanics_part"])) * (1 + float(row["soil_law_part"])) - 1
        assert total == pytest.approx(float(row["relative_difference"]), rel=1e-12)
        assert float(row["relative_difference"]) == pytest.approx(z_er / z_a - 1, rel=1e-12)
        assert z_t > 0 and z_er > 0
        assert float(row["dynamic_error"]) == pytest.approx(float(row["dynamic_m"]) / z_er - 1, rel=1e-12)
    # the lighter vehicle on the stronger soil sinks less, in every model
    light, heavy = rows
    for key in ("analytic_m", "cel_tresca_m", "cel_einav_randolph_m", "dynamic_m", "dynamic_tresca_m"):
        assert float(light[key]) < float(heavy[key])
    assert (sweep / "compare_analytic.png").exists()


def _section_sweep(tmp_path, scenes) -> Path:
    """A synthetic ``compare_2d_3d`` sweep: (overrides, metrics) per job."""
    sweep = tmp_path / "sweep"
    for job, (overrides, metrics) in enumerate(scenes):
        job_dir = sweep / str(job)
        (job_dir / ".hydra").mkdir(parents=True)
        (job_dir / ".hydra" / "overrides.yaml").write_text("".join(f"- {o}\n" for o in overrides))
        metrics = {"wall_s": 1.0, "cells": 10, "core_cell_size_m": 0.075, **metrics}
        (job_dir / "result.json").write_text(json.dumps({"status": "ok", "message": "", "metrics": metrics}))
    return sweep


#: compare_2d_3d's scenes, in another order than the factors'
SECTION_OVERRIDES = (["solver=cel3d"], ["solver=cel2d"], ["solver=cel3d", "geometry.grouser_height_m=0"],
                     ["solver=cel3d", "geometry=strip", "geometry.width_m=0.6"],
                     ["geometry=rectangular_plate", "geometry.width_m=0.6"])


def test_section_factors_multiply_from_the_cross_section_to_the_track(tmp_path):
    """Each scene's factor is its sinkage over the scene before it (jobs in any order), and their product
    is the track's over the cross-section."""
    sinkages = (0.13, 0.10, 0.08, 0.095, 0.09)
    sweep = _section_sweep(tmp_path, [(o, {"max_sinkage_m": z}) for o, z in zip(SECTION_OVERRIDES, sinkages)])
    assert studies.section_factors(sweep, sweep / "section_factors.png") is not None
    rows = _read_csv(sweep / "section_factors.csv")
    assert [r["scene"] for r in rows[:5]] == [name for name, _, _ in studies.SECTION_SCENES]
    factors = [float(r["factor"]) for r in rows[1:5]]
    assert factors == pytest.approx([0.95, 0.09 / 0.095, 0.08 / 0.09, 0.13 / 0.08], rel=1e-12)
    assert float(rows[5]["factor"]) == pytest.approx(np.prod(factors), rel=1e-12)
    assert float(rows[5]["factor"]) == pytest.approx(1.3, rel=1e-12)
    assert all(r["factor_error"] == "nan" for r in rows[1:6])  # one mesh each: no error known


def test_section_factors_use_the_extrapolated_answers_and_their_errors(tmp_path):
    """With solver.error_estimate each factor is a ratio of extrapolated answers, its error the two
    relative errors added in quadrature; the product keeps only the two ends' errors."""
    answers = ((0.12, 0.001), (0.06, 0.0012), (0.058, 0.0005), (0.0645, 0.0011), (0.063, 0.002))
    sweep = _section_sweep(tmp_path, [(o, {"max_sinkage_m": z + 0.01, "max_sinkage_extrapolated_m": z,
                                           "max_sinkage_error_m": e})
                                      for o, (z, e) in zip(SECTION_OVERRIDES, answers)])
    studies.section_factors(sweep, sweep / "section_factors.png")
    rows = _read_csv(sweep / "section_factors.csv")
    section, bare, track = answers[1], answers[2], answers[0]
    assert float(rows[0]["max_sinkage_m"]) == section[0] and float(rows[0]["finest_mesh_sinkage_m"]) == 0.06 + 0.01
    grousers = track[0] / bare[0]
    assert float(rows[4]["factor"]) == pytest.approx(grousers, rel=1e-12)
    assert float(rows[4]["factor_error"]) == pytest.approx(grousers * np.hypot(0.001 / 0.12, 0.0005 / 0.058),
                                                           rel=1e-12)
    assert float(rows[5]["factor"]) == pytest.approx(2.0, rel=1e-12)
    assert float(rows[5]["factor_error"]) == pytest.approx(2.0 * np.hypot(0.001 / 0.12, 0.0012 / 0.06), rel=1e-12)


def test_mesh_study_reports_errors_against_the_finest_mesh(tmp_path):
    """Synthetic histories: the error is measured against the finest mesh, zero for itself."""
    sweep = tmp_path / "sweep"
    depth = np.linspace(0, 0.1, 200)
    for job, (size, scale) in enumerate([(0.02, 1.0), (0.04, 1.05), (0.08, 1.2)]):
        job_dir = sweep / str(job)
        (job_dir / ".hydra").mkdir(parents=True)
        (job_dir / ".hydra" / "overrides.yaml").write_text(f"- mesh.cell_size_m={size}\n")
        (job_dir / "result.json").write_text(
            '{"status": "ok", "message": "", "metrics": {"max_sinkage_m": 0.1, "wall_s": %g, "cells": 100}}' % (1 / size))
        force = scale * 1e4 * (1 + 5 * depth)
        np.savetxt(job_dir / "history.csv", np.column_stack([depth, depth, -np.ones_like(depth), force]),
                   delimiter=",", header="time_s,sinkage_m,velocity_m_s,force_n", comments="")
    assert studies.mesh_study(sweep, sweep / "mesh_study.png") is not None
    rows = _read_csv(sweep / "mesh_study.csv")
    errors = {float(r["cell_size_m"]): float(r["mean_relative_error"]) for r in rows}
    assert errors == pytest.approx({0.02: 0.0, 0.04: 0.05, 0.08: 0.2}, abs=1e-9)


def test_bearing_curves_normalise_each_push_by_its_own_body(tmp_path):
    """Synthetic pushes: q/su = F/(su0·B·L) with each job's own body (a T-bar's B is its
    diameter); a landing in the same sweep is left out of the table."""
    sweep = tmp_path / "sweep"
    travel = np.linspace(0.0, 0.1, 50)
    jobs = [  # (geometry, landing, width B or D (m), force (N), separation): q/su = 5.5, 5.3 and 9.2 by hand
        ("strip", "push", 1.0, 5.5 * 1e4 * 1.0 * 2.0, "false"),
        ("strip", "push", 1.0, 5.3 * 1e4 * 1.0 * 2.0, "true"),
        ("tbar", "push", 0.5, 9.2 * 1e4 * 0.5 * 2.0, "false"),
        ("strip", "drop", 1.0, 1.0, "false"),
    ]
    for job, (kind, landing, width, force, separation) in enumerate(jobs):
        job_dir = sweep / str(job)
        (job_dir / ".hydra").mkdir(parents=True)
        (job_dir / ".hydra" / "overrides.yaml").write_text("[]\n")
        (job_dir / "result.json").write_text('{"status": "ok", "message": "", "metrics": {"wall_s": 1.0}}')
        (job_dir / "config_resolved.yaml").write_text(
            f"geometry: {{kind: {kind}, width_m: {width}, contact_length_m: 2.0, roughness: rough}}\n"
            f"soil: {{su0_pa: 10000.0}}\nlanding: {{kind: {landing}, velocity_m_s: 0.1}}\nmesh: {{cell_size_m: 0.05}}\n"
            + (f"solver: {{contact_separation: {separation}}}\n" if job else ""))  # the first job predates the key
        np.savetxt(job_dir / "history.csv", np.column_stack([travel, travel, np.ones_like(travel), force + 0 * travel]),
                   delimiter=",", header="time_s,sinkage_m,velocity_m_s,force_n", comments="")
    assert studies.bearing_curves(sweep, sweep / "bearing_curves.png") == sweep / "bearing_curves.png"
    assert (sweep / "bearing_curves.png").stat().st_size > 0
    rows = _read_csv(sweep / "bearing_curves.csv")
    assert [(r["body"], float(r["nc_end"])) for r in rows] == [
        ("strip", pytest.approx(5.5)), ("strip", pytest.approx(5.3)), ("tbar", pytest.approx(9.2))]
    assert [r["contact_separation"] for r in rows] == ["False", "True", "False"]


def test_the_green_envelope_extrapolates_each_direction_from_its_two_finest_cells(tmp_path):
    """Synthetic probes whose load exceeds a point on Green's envelope by 2·h/B in H (the corner's wedge)
    on cells 0.1 and 0.05 m: the plot's table extrapolates them back onto the envelope (λ = 1)."""
    from dsmv.analytic.bearing import green_vertical

    sweep = tmp_path / "sweep"
    cases = [(0.1, 0.5), (0.05, 0.5), (0.1, 1.0), (0.05, 1.0)]  # (cell, true h)
    for job, (cell, h) in enumerate(cases):
        job_dir = sweep / str(job)
        (job_dir / ".hydra").mkdir(parents=True)
        (job_dir / ".hydra" / "overrides.yaml").write_text("[]\n")
        v = green_vertical(h) if h < 1.0 else 0.0
        metrics = {"end_horizontal_factor": h + 2 * cell, "end_vertical_factor": v, "wall_s": 1.0}
        (job_dir / "result.json").write_text(json.dumps({"status": "ok", "message": "", "metrics": metrics}))
        down = 0.05 if h < 1.0 else 0.0
        (job_dir / "config_resolved.yaml").write_text(
            f"geometry: {{kind: strip, width_m: 1.0, contact_length_m: 1.0}}\nsoil: {{su0_pa: 10000.0}}\n"
            f"landing: {{kind: push, velocity_m_s: {down}, horizontal_velocity_m_s: 0.0866}}\n"
            f"mesh: {{cell_size_m: {cell}}}\n")
    assert studies.green_envelope(sweep, sweep / "green_envelope.png") == sweep / "green_envelope.png"
    rows = _read_csv(sweep / "green_envelope.csv")
    extrapolated = [r for r in rows if float(r["cell_size_m"]) == 0.0]
    assert len(extrapolated) == 2
    for row in extrapolated:
        assert float(row["lambda"]) == pytest.approx(1.0, abs=1e-9)


def test_the_vehicle_s_safe_region_is_mapped_with_the_limits_each_landing_broke(run_cli, tmp_path):
    """``study_vehicle_safety`` on three speeds × two masses (the fast vehicle model): the map and its
    table, each landing judged as its own verdict says, the count of jobs right (the experiment's own
    sweep counted), and the region safe below and unsafe above: a landing faster or heavier than an
    unsafe one is unsafe (sinkage and tilt grow with both)."""
    done = run_cli("dsmv", "experiment=study_vehicle_safety", "tracking=disabled",
                   "landing.velocity_m_s=0.5,1.5,3", "landing.mass_kg=3000,9000")
    assert done.returncode == 0, done.stderr[-2000:]
    assert "(6 of 6 jobs done)" in done.stdout + done.stderr
    sweep = _sweep_dir(tmp_path)
    assert (sweep / "safe_region.png").stat().st_size > 10_000
    rows = _read_csv(sweep / "safe_region.csv")
    verdicts = {(float(r["landing.velocity_m_s"]), float(r["landing.mass_kg"])): r for r in rows}
    assert len(verdicts) == 6
    for (speed, mass), row in verdicts.items():
        job = next(p for p in sweep.glob("*/result.json")
                   if f"landing.velocity_m_s={speed:g}" in (p.parent / ".hydra" / "overrides.yaml").read_text()
                   and f"landing.mass_kg={mass:g}" in (p.parent / ".hydra" / "overrides.yaml").read_text())
        assert int(row["safe"]) == int(json.loads(job.read_text())["metrics"]["safe"])
        if not int(row["safe"]):
            assert row["broken"] and all(float(row[f"margin_{what}"]) < 0 for what in row["broken"].split(" & "))
    assert int(verdicts[0.5, 3000.0]["safe"]) == 1 and int(verdicts[3.0, 9000.0]["safe"]) == 0
    for (speed, mass), row in verdicts.items():
        if not int(row["safe"]):
            assert all(not int(other["safe"]) for (s, m), other in verdicts.items() if s >= speed and m >= mass)


def test_the_vehicle_attitude_study_draws_each_parameter_alone(run_cli, tmp_path):
    """``study_vehicle_attitude`` with the fast vehicle model: 16 landings, the figure and its table; the
    vehicle's deepest point grows with each offset and attitude (a heavier end or side sinks deeper), and
    a centre of gravity off the middle tilts it the more the farther it is off."""
    done = run_cli("dsmv", "experiment=study_vehicle_attitude", "tracking=disabled")
    assert done.returncode == 0, done.stderr[-2000:]
    sweep = _sweep_dir(tmp_path)
    assert (sweep / "vehicle_response.png").stat().st_size > 10_000
    rows = _read_csv(sweep / "vehicle_response.csv")
    assert len(rows) == 16 and {r["status"] for r in rows} == {"ok"}
    for key in ("landing.cg_offset_m.0", "landing.cg_offset_m.1", "landing.roll_deg", "landing.pitch_deg"):
        points = sorted((float(r["value"]), r) for r in rows if r["parameter"] == key)
        assert trend_of(points, "max_edge_sinkage_m") == "up", key
        if key.startswith("landing.cg_offset_m"):
            assert trend_of(points, "max_rotation_deg") == "up", key


def trend_of(points, name: str) -> str:
    return studies.trend([value for value, _ in points], [float(row[name]) for _, row in points])


def test_a_vehicle_study_counts_the_scenes_where_the_fast_model_agrees_with_the_cel(tmp_path):
    """A sweep of two parameters landed by the fast model and cel3d (results written by hand): the base
    scene, which both parameters' lists hold, is compared once; an offset's largest tilt and a tilted
    touchdown's tilt at the end are what is compared; 15 % on sinkage and 1° (or 15 %) on tilt decide."""
    sweep = tmp_path / "sweep"
    sweep.mkdir()
    (sweep / "multirun.yaml").write_text(
        "study: s\nlanding: {cg_offset_m: [0.0, 0.0, 0.0], roll_deg: 0.0}\n"
        "hydra: {sweeper: {vary: {landing.cg_offset_m.0: [0, 0.3], landing.roll_deg: [0, 2]}}}\n")
    # (override, solver, deepest point, largest tilt, tilt at the end)
    landings = [("landing.cg_offset_m.0=0", "cel3d", 0.080, 0.0, 0.0),
                ("landing.cg_offset_m.0=0", "analytic_dynamic", 0.084, 0.0, 0.0),
                ("landing.cg_offset_m.0=0.3", "cel3d", 0.088, 0.51, 0.30),
                ("landing.cg_offset_m.0=0.3", "analytic_dynamic", 0.095, 1.60, 0.40),  # tilt 1.09° off
                ("landing.roll_deg=0", "cel3d", 0.080, 0.0, 0.0),
                ("landing.roll_deg=0", "analytic_dynamic", 0.084, 0.0, 0.0),
                ("landing.roll_deg=2", "cel3d", 0.063, 2.0, 1.4),
                ("landing.roll_deg=2", "analytic_dynamic", 0.0720, 2.0, 0.5)]  # +14.3 %, 0.9° off at the end
    for job, (override, solver, deepest, largest, end) in enumerate(landings):
        job_dir = sweep / str(job)
        (job_dir / ".hydra").mkdir(parents=True)
        (job_dir / ".hydra" / "overrides.yaml").write_text(f"- {override}\n- solver={solver}\n")
        metrics = {"max_edge_sinkage_m": deepest, "max_rotation_deg": largest, "final_tilt_deg": end}
        (job_dir / "result.json").write_text(json.dumps({"status": "ok", "solver": solver, "metrics": metrics}))
    assert studies.vehicle_response(sweep, sweep / "vehicle_response.png") == sweep / "vehicle_response.png"
    compared = {r["value"]: r for r in _read_csv(sweep / "vehicle_response.csv") if r["parameter"] == "scene"}
    assert set(compared) == {"base", "landing.cg_offset_m.0=0.3", "landing.roll_deg=2"}
    assert compared["base"]["status"] == "within"
    assert compared["landing.cg_offset_m.0=0.3"]["status"] == "outside"
    assert float(compared["landing.cg_offset_m.0=0.3"]["tilt_gap_deg"]) == pytest.approx(1.09)
    assert compared["landing.roll_deg=2"]["status"] == "within"
    assert compared["landing.roll_deg=2"]["tilt_compared"] == "final_tilt_deg"
    assert float(compared["landing.roll_deg=2"]["sinkage_gap"]) == pytest.approx(0.072 / 0.063 - 1)


def test_the_table3_scenes_per_vehicle_sink_as_one_track_with_half_the_mass(run_cli, tmp_path, compose_cfg):
    """``study_vehicle_table3`` on three scenes of the Table 3 design (the fast model of the 3D track):
    each scene on one track carrying m and on the vehicle's two; the vehicle, its centre of gravity over
    its middle, sinks as one track carrying m/2 (to 1 %: the rigid-body step's error, first order, 0.17 %,
    0.34 % and 0.61 % on these scenes, 0.08 %, 0.15 % and 0.25 % with half the step) and less than the
    track carrying all of m."""
    from dsmv import registry
    from dsmv.config.scene import build_scene

    done = run_cli("dsmv", "experiment=study_vehicle_table3", "tracking=disabled", "dataset.n_samples=3")
    assert done.returncode == 0, done.stderr[-2000:]
    sweep = _sweep_dir(tmp_path)
    assert (sweep / "per_vehicle.png").stat().st_size > 10_000
    rows = _read_csv(sweep / "per_vehicle.csv")
    assert len(rows) == 3
    for row in rows:
        overrides = row["scene"].split()
        mass = float(next(o for o in overrides if o.startswith("landing.mass_kg=")).split("=")[1])
        half = build_scene(compose_cfg(["experiment=study_vehicle_table3", "tracking=disabled", *overrides,
                                        f"landing.mass_kg={mass / 2}"]))
        alone = registry.load("solvers", half.solver.name, "solver.name")(half).solve().metrics["max_sinkage_m"]
        assert float(row["vehicle_m"]) == pytest.approx(alone, rel=1e-2)
        assert float(row["vehicle_m"]) < float(row["one_track_m"])


def test_the_vehicle_slope_study_slides_it_the_farther_the_steeper_and_the_faster(run_cli, tmp_path):
    """``study_vehicle_slope`` with the fast vehicle model: on steeper slopes and drifting faster the vehicle
    slides farther; level and upright without drift it does not slide; it rests on every slope the
    nodule-field seabed stands."""
    done = run_cli("dsmv", "experiment=study_vehicle_slope", "tracking=disabled")
    assert done.returncode == 0, done.stderr[-2000:]
    rows = _read_csv(_sweep_dir(tmp_path) / "vehicle_response.csv")
    assert len(rows) == 15 and {r["status"] for r in rows} == {"ok"}
    for key in ("soil.slope_deg", "landing.horizontal_velocity_m_s", "landing.lateral_velocity_m_s"):
        points = sorted((float(r["value"]), r) for r in rows if r["parameter"] == key)
        assert float(points[0][1]["max_horizontal_displacement_m"]) == 0.0
        assert trend_of(points[1:], "max_horizontal_displacement_m") == "up", key
