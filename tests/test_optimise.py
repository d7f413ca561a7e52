"""Design search with the CEL in the loop: each job returns its objective (:mod:`dsmv.config.objective`),
and Hydra's Optuna sweeper minimises it (``experiment=optimise_track``)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from dsmv.config.objective import ObjectiveConfig, objective_config, objective_value
from dsmv.errors import ConfigError

from tests.conftest import mlflow_runs

TRACK = {"width_m": 0.5, "contact_length_m": 4.0}


def test_the_contact_area_pays_for_sinkage_beyond_the_limit_and_a_run_not_ok_pays_most():
    area = ObjectiveConfig(name="contact_area_m2", sinkage_limit_m=0.08)
    ok = {"status": "ok", "metrics": {"max_sinkage_m": 0.05}}
    assert objective_value(area, ok, TRACK) == pytest.approx(2.0)
    deep = {"status": "ok", "metrics": {"max_sinkage_m": 0.09}}
    assert objective_value(area, deep, TRACK) == pytest.approx(2.0 + 100.0 * 0.01)
    assert objective_value(area, {"status": "bearing_failure", "metrics": {}}, TRACK) == 1000.0
    assert objective_value(ObjectiveConfig(), ok, TRACK) == 0.05  # the default: the max sinkage (m)
    assert objective_value(ObjectiveConfig(name="nope"), ok, TRACK) == 1000.0
    with pytest.raises(ConfigError, match="^objective.sinkage_limit_m"):
        objective_config({"objective": {"name": "contact_area_m2"}})


def test_optimise_track_returns_its_best_trial_and_tracks_every_one(run_cli, tmp_path):
    proc = run_cli("dsmv", "experiment=optimise_track", "mesh=coarse", "hydra.sweeper.n_trials=4", "output.plots=false")
    assert proc.returncode == 0, proc.stderr
    assert "(4 of 4 jobs done)" in proc.stdout
    (found,) = tmp_path.glob("runs/multirun/*/*/optimization_results.yaml")
    best = yaml.safe_load(found.read_text())
    values = {}
    for result_file in found.parent.glob("*/result.json"):  # each trial's objective, from its own files
        result = json.loads(result_file.read_text())
        geometry = yaml.safe_load((result_file.parent / "config_resolved.yaml").read_text())["geometry"]
        area = geometry["width_m"] * geometry["contact_length_m"]
        sinkage = result["metrics"]["max_sinkage_m"]
        values[result_file.parent.name] = area + 100.0 * max(0.0, sinkage - 0.08) if result["status"] == "ok" else 1e3
        assert 0.4 <= geometry["width_m"] <= 0.8 and 2.5 <= geometry["contact_length_m"] <= 5.5
    assert len(values) == 4
    assert best["best_value"] == pytest.approx(min(values.values()), rel=1e-12)
    runs = mlflow_runs(tmp_path)
    children = [r for r in runs if "mlflow.parentRunId" in r.data.tags]
    assert len(children) == 4 and all(c.info.status == "FINISHED" for c in children)


def fake_trial(sweep_dir, name, width, length, status="ok", sinkage=0.05, message="came to rest"):
    """A finished trial as a job leaves it: result.json, the overrides and the config Hydra saved."""
    job = sweep_dir / name
    (job / ".hydra").mkdir(parents=True)
    metrics = {"max_sinkage_m": sinkage} if status == "ok" else {}
    (job / "result.json").write_text(json.dumps({"status": status, "message": message, "metrics": metrics,
                                                 "units": {"max_sinkage_m": "m"}}))
    (job / ".hydra" / "overrides.yaml").write_text(
        yaml.safe_dump([f"geometry.width_m={width!r}", f"geometry.contact_length_m={length!r}"]))
    (job / ".hydra" / "config.yaml").write_text(
        yaml.safe_dump({"geometry": {"width_m": width, "contact_length_m": length}}))


def fake_results(sweep_dir, width, length, value):
    (sweep_dir / "optimization_results.yaml").write_text(yaml.safe_dump(
        {"name": "optuna", "best_params": {"geometry.width_m": width, "geometry.contact_length_m": length},
         "best_value": value}, sort_keys=False))


AREA = ObjectiveConfig(name="contact_area_m2", sinkage_limit_m=0.08)


def test_the_optimum_is_told_in_b_l_area_and_sinkage_against_the_limit(tmp_path):
    from dsmv.post.optimum import optimum_summary

    fake_trial(tmp_path, "0", 0.6, 4.0, sinkage=0.07)
    fake_trial(tmp_path, "1", 0.4, 3.0, status="bearing_failure", message="kept sinking")
    fake_trial(tmp_path, "2", 0.5, 4.2, sinkage=0.075)
    fake_results(tmp_path, 0.5, 4.2, 2.1)
    assert optimum_summary(tmp_path, AREA, trials=4, study="optimise_track") == [
        "dsmv: optimise_track: the smallest track found under the sinkage limit (job 2)",
        "  best     : B = 0.5000 m, L = 4.2000 m, contact area B·L = 2.100 m²",
        "  sinkage  : max 0.0750 m against the limit 0.08 m: margin 0.0050 m",
        "  trials   : 3 of 4 run (2 ok, 1 bearing_failure)",
        f"  results  : {(tmp_path / 'optimization_results.yaml').resolve()}"]


def test_a_best_trial_past_the_limit_is_said_so_with_the_smallest_area_under_it(tmp_path):
    from dsmv.post.optimum import optimum_summary

    fake_trial(tmp_path, "0", 0.6, 4.0, sinkage=0.07)
    fake_trial(tmp_path, "1", 0.5, 3.0, sinkage=0.085)  # 1.5 m² + 100 × 0.005 = 2.0 beats 2.4
    fake_results(tmp_path, 0.5, 3.0, 2.0)
    lines = optimum_summary(tmp_path, AREA, trials=2, study="s")
    assert lines[0] == "dsmv: s: the best trial (job 1) sinks past the limit"
    assert lines[2] == "  sinkage  : max 0.0850 m against the limit 0.08 m: over it by 0.0050 m"
    assert lines[3] == ("  under it : the smallest area that stayed under the limit: B = 0.6000 m, L = 4.0000 m, "
                        "2.400 m², max sinkage 0.0700 m (job 0)")


def test_no_trial_ok_and_no_results_file(tmp_path):
    from dsmv.post.optimum import optimum_summary

    assert optimum_summary(tmp_path, AREA) is None  # not an Optuna sweep, or it stopped before its end
    fake_trial(tmp_path, "0", 0.4, 2.5, status="bearing_failure", message="kept sinking")
    fake_results(tmp_path, 0.4, 2.5, 1000.0)
    assert optimum_summary(tmp_path, AREA, trials=1, study="s")[0] == (
        "dsmv: s: no trial ended ok; the best proposed (geometry.width_m = 0.4, geometry.contact_length_m = 2.5) "
        "job 0 ended bearing_failure: kept sinking")
    (tmp_path / "0" / "result.json").write_text(json.dumps({"status": "ok", "message": "", "units": {"max_sinkage_m": "m"},
                                                            "metrics": {"max_sinkage_m": 0.0712}}))
    assert optimum_summary(tmp_path, ObjectiveConfig(), study="s")[:2] == [  # the default objective: a metric
        "dsmv: s: best max_sinkage_m = 0.0712 m (job 0)",
        "  best     : geometry.width_m = 0.4, geometry.contact_length_m = 2.5"]


def test_optimise_track_ends_with_its_answer_in_units_and_where_the_results_are(run_cli, tmp_path):
    """Two trials of the fast landing model: the last lines name B, L, the area, the sinkage against the
    limit with the margin, the trials, and the results file, each figure as the trial's own files hold it."""
    proc = run_cli("dsmv", "experiment=optimise_track", "solver=analytic_dynamic", "hydra.sweeper.n_trials=2",
                   "output.plots=false", "tracking=disabled")
    assert proc.returncode == 0, proc.stderr
    (found,) = tmp_path.glob("runs/multirun/*/*/optimization_results.yaml")
    best = yaml.safe_load(found.read_text())["best_params"]
    width, length = best["geometry.width_m"], best["geometry.contact_length_m"]
    (job,) = [j for j in found.parent.glob("*/.hydra/..")
              if f"geometry.width_m={width!r}" in (j / ".hydra" / "overrides.yaml").read_text()]
    sinkage = json.loads((job / "result.json").read_text())["metrics"]["max_sinkage_m"]
    tail = proc.stdout.strip().splitlines()[-5:]
    assert tail[0].startswith("dsmv: optimise_track: the smallest track found under the sinkage limit"), proc.stdout
    assert tail[1] == f"  best     : B = {width:.4f} m, L = {length:.4f} m, contact area B·L = {width * length:.3f} m²"
    assert tail[2] == f"  sinkage  : max {sinkage:.4f} m against the limit 0.08 m: margin {0.08 - sinkage:.4f} m"
    assert tail[3] == "  trials   : 2 (2 ok)"
    assert tail[4] == f"  results  : {found.resolve()}" and Path(tail[4].split(": ", 1)[1]).is_absolute()
