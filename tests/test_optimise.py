"""Design search with the CEL in the loop: each job returns its objective (:mod:`dsmv.config.objective`),
and Hydra's Optuna sweeper minimises it (``experiment=optimise_track``)."""

from __future__ import annotations

import json

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
