"""Surrogates: the Table 3 design, the dataset from MLflow, features, training, the train CLI.

Fast tests use a synthetic study written into a temporary MLflow store with the same tags,
params and metrics as real jobs; the full study (the Table 3 CEL dataset, both surrogates)
is behind ``-m slow``.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from dsmv import registry
from dsmv.surrogate import design
from dsmv.surrogate.dataset import PARAMETERS, TARGET_METRIC, Dataset, build_dataset, load_dataset, table_hash
from dsmv.surrogate.features import LeakFreeFeatures, StudyFeatures, energy_ratio, target

STUDY = "synthetic"
G = 9.81


def synthetic_sinkage(row: dict) -> float:
    """A learnable stand-in for CEL: the energy method's depth (Nc = 2 + π) scaled by softening
    (more remoulding, deeper) and rate (more viscosity, shallower)."""
    area = row["width_m"] * row["contact_length_m"]
    ra = (2 + math.pi) * area
    m, v, su0, ks = row["mass_kg"], row["velocity_m_s"], row["su0_pa"], row["ks_pa_per_m"]
    excess = ra * su0 - m * G
    kinetic = 0.5 * m * v * v
    if ks == 0:
        z = kinetic / excess
    else:
        z = (math.sqrt(excess**2 + 2 * ra * ks * kinetic) - excess) / (ra * ks)
    return z * (1 + 0.6 * (1 - 1 / row["sensitivity"])) * (1 - 2 * row["eta"])


def synthetic_rows(n: int, seed: int = 1) -> list[dict]:
    """Scenes over Table 3's levels, strong enough soil to stop the track (ks > 0 or capacity > weight)."""
    rng = np.random.default_rng(seed)
    rows = []
    while len(rows) < n:
        row = {key: float(rng.choice(levels)) for key, levels in design.TABLE3_LEVELS.items()}
        out = {"mass_kg": row["landing.mass_kg"], "inertial_mass_kg": math.nan, "velocity_m_s": row["landing.velocity_m_s"],
               "n_tracks": 1.0, "gravity_m_s2": G, "width_m": 0.6, "contact_length_m": row["contact_area_m2"] / 0.6,
               "su0_pa": row["soil.su0_pa"], "ks_pa_per_m": row["soil.ks_pa_per_m"],
               "sensitivity": row["soil.sensitivity"], "xi95": row["soil.xi95"], "eta": row["soil.rate.eta"]}
        if out["ks_pa_per_m"] == 0 and (2 + math.pi) * 0.6 * out["contact_length_m"] * out["su0_pa"] <= out["mass_kg"] * G:
            continue
        out[TARGET_METRIC] = synthetic_sinkage(out)
        if out[TARGET_METRIC] < 1.0:
            rows.append(out)
    return rows


def write_store(store: Path, rows: list[dict], extra_statuses=("bearing_failure", "unstable"), duplicate=True,
                ok=True) -> str:
    """Track ``rows`` as finished jobs of STUDY, like dsmv jobs do; plus non-ok runs and a duplicate
    (``ok=False``: the non-ok runs alone)."""
    from mlflow.entities import Metric, Param, RunTag
    from mlflow.tracking import MlflowClient

    uri = f"sqlite:///{store / 'mlflow.db'}"
    client = MlflowClient(uri)
    experiment = client.create_experiment(f"dsmv-{STUDY}", artifact_location=(store / "art").as_uri())
    jobs = [(row, "ok") for row in rows if ok] + [(rows[0], status) for status in extra_statuses]
    if duplicate and ok:
        jobs.append((rows[1], "ok"))
    for i, (row, status) in enumerate(jobs):
        params = {key: str(row[col]) if not math.isnan(row[col]) else "None" for col, key in PARAMETERS.items()}
        params["soil.law"] = "einav_randolph"
        tags = {"dsmv.study": STUDY, "dsmv.status": status, "dsmv.message": f"job {i}",
                "dsmv.config_hash": f"h{rows.index(row)}" if status == "ok" else f"x{i}"}
        run = client.create_run(experiment, tags=tags)
        metrics = [Metric(TARGET_METRIC, row[TARGET_METRIC], 0, 0)] if status == "ok" else []
        client.log_batch(run.info.run_id, metrics=metrics, params=[Param(k, v) for k, v in params.items()],
                         tags=[RunTag("mlflow.runName", f"job {i}")])
        client.set_terminated(run.info.run_id, "FINISHED")
    return uri


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    """A synthetic study of 24 ok runs, 2 non-ok runs and 1 duplicate in a temporary store.

    Small, because every run costs a few SQLite transactions; the learning tests use a larger
    table in memory."""
    folder = tmp_path_factory.mktemp("store")
    rows = synthetic_rows(24)
    return folder, write_store(folder, rows), rows


# ----------------------------------------------------------------------------- design


def test_design_is_seeded_on_table3_levels_and_reports_what_it_dropped(compose_cfg, capsys):
    cfg = compose_cfg(["experiment=dataset_table3", "dataset.n_samples=12"])
    cases = design.table3_cases(cfg)
    report = capsys.readouterr().out
    assert len(cases) == 12
    assert cases == design.table3_cases(cfg)  # seeded: the same design every time
    other = design.table3_cases(compose_cfg(["experiment=dataset_table3", "dataset.n_samples=12", "dataset.seed=7"]))
    assert other != cases
    # a sweep can run part of the design (to resume failed jobs): the same scenes, no others
    part = design.table3_cases(compose_cfg(["experiment=dataset_table3", "dataset.n_samples=12", "dataset.jobs=8:"]))
    assert part == cases[8:]
    lengths = {round(a / 0.6, 9) for a in design.TABLE3_LEVELS["contact_area_m2"]}
    for case in cases:
        values = dict(item.split("=") for item in case)
        assert float(values.pop(design.CONTACT_LENGTH_KEY)) in lengths
        for key, value in values.items():
            assert float(value) in design.TABLE3_LEVELS[key], key
    # the report counts drops; drawn = dropped + kept-or-spare, and every kept scene is below the limit
    drawn, dropped = (int(x) for x in re.search(r"drew (\d+) .* dropped (\d+)", report).groups())
    assert dropped > 0 and drawn - dropped >= 12


def test_design_filter_keeps_only_scenes_below_the_analytic_limit(compose_cfg):
    from dsmv.analytic.energy import energy_estimate
    from dsmv.config.scene import build_scene

    scene = build_scene(compose_cfg(["experiment=dataset_table3"]))
    limit = 0.3
    result = design.table3_design(scene, design.DatasetConfig(n_samples=30, seed=3, max_analytic_sinkage_m=limit))
    assert len(result.scenes) == 30 and max(result.analytic_sinkage_m) <= limit
    # the drawn hypercube, recomputed: the dropped ones are exactly those above the limit
    drawn = design._scene_values(design.latin_hypercube_levels(result.n_drawn, 3), scene.geometry.width_m)
    z = design.analytic_sinkage(scene, drawn)
    assert sum(zi > limit for zi in z) == sum(result.dropped.values()) > 0
    assert result.scenes == [s for s, zi in zip(drawn, z) if zi <= limit][:30]
    # the design's shortcut (Ra once per contact length) agrees with the energy solver on a full scene
    overrides = [f"{k}={v}" for k, v in result.scenes[0].items()]
    full = build_scene(compose_cfg(["experiment=dataset_table3", *overrides]))
    assert energy_estimate(full).solve().metrics["max_sinkage_m"] == pytest.approx(result.analytic_sinkage_m[0])


def test_design_levels_are_stratified():
    indices = design.latin_hypercube_levels(70, seed=0)
    # 70 points over 7 mass levels: each level exactly 10 times (Latin hypercube)
    assert np.bincount(indices[:, 0]).tolist() == [10] * 7
    assert (design.latin_hypercube_levels(70, seed=0) == indices).all()


def test_design_needs_a_dataset_block(compose_cfg):
    from dsmv.errors import ConfigError

    with pytest.raises(ConfigError, match="dataset"):
        design.table3_cases(compose_cfg([]))
    with pytest.raises(ConfigError, match="dataset.n_samples"):
        design.table3_cases(compose_cfg(["experiment=dataset_table3", "dataset.n_samples=0"]))
    with pytest.raises(ConfigError, match="dataset.jobs"):
        design.table3_cases(compose_cfg(["experiment=dataset_table3", "dataset.jobs=first"]))


# ----------------------------------------------------------------------------- dataset


def test_dataset_reads_ok_runs_typed_and_counts_the_rest(store):
    _, uri, rows = store
    data = load_dataset(uri, STUDY)
    assert len(data.table) == len(rows)
    assert data.excluded_counts == {"bearing_failure": 1, "duplicate": 1, "unstable": 1}
    assert all(data.table[c].dtype == np.float64 for c in [*PARAMETERS, TARGET_METRIC])
    assert sorted(data.table[TARGET_METRIC]) == pytest.approx(sorted(r[TARGET_METRIC] for r in rows))
    assert data.settings == {"soil.law": "einav_randolph"}  # shared by every run; solver/mesh not logged here


def test_dataset_hash_depends_on_content_only(store):
    _, uri, _ = store
    data = load_dataset(uri, STUDY)
    shuffled = data.table.sample(frac=1.0, random_state=0).assign(run_id="other")
    assert table_hash(shuffled) == data.content_hash == load_dataset(uri, STUDY).content_hash
    changed = data.table.copy()
    changed.loc[0, TARGET_METRIC] += 1e-9
    assert table_hash(changed) != data.content_hash


def test_dataset_errors_are_user_errors(store, tmp_path):
    from dsmv.surrogate.dataset import DatasetError

    _, uri, _ = store
    with pytest.raises(DatasetError, match="no tracked runs of study 'nope'"):
        load_dataset(uri, "nope")
    with pytest.raises(DatasetError, match="no ok run"):
        build_dataset(STUDY, [])  # nothing to train on


def test_a_study_of_two_solvers_trains_on_the_one_named(store):
    """The same scenes run in 2D and 3D answer different questions: the named solver's runs train, and
    a study that holds both refuses to guess."""
    from types import SimpleNamespace

    from dsmv.surrogate.dataset import DatasetError

    def run(k, solver, sinkage):
        params = {key: "1.0" for key in PARAMETERS.values()} | {"solver.name": solver, "soil.su0_pa": str(4000 + k)}
        return SimpleNamespace(info=SimpleNamespace(run_id=f"{solver}-{k}", status="FINISHED", start_time=k),
                               data=SimpleNamespace(params=params, tags={"dsmv.status": "ok"},
                                                    metrics={TARGET_METRIC: sinkage}))

    runs = [run(k, "cel2d", 0.06) for k in range(3)] + [run(k, "cel3d", 0.12) for k in range(2)]
    three = build_dataset(STUDY, runs, "cel3d")
    assert len(three.table) == 2 and (three.table[TARGET_METRIC] == 0.12).all()
    assert three.settings["solver"] == "cel3d"
    assert len(build_dataset(STUDY, runs, "cel2d").table) == 3
    with pytest.raises(DatasetError, match="3 ok of cel2d, 2 ok of cel3d.*train.solver"):
        build_dataset(STUDY, runs)
    with pytest.raises(DatasetError, match="no run of solver analytic_dynamic"):
        build_dataset(STUDY, runs, "analytic_dynamic")


# ----------------------------------------------------------------------------- features


def one_row(**changes) -> pd.DataFrame:
    row = {"mass_kg": 4500.0, "inertial_mass_kg": math.nan, "velocity_m_s": 2.0, "n_tracks": 1.0, "gravity_m_s2": 9.81,
           "width_m": 0.6, "contact_length_m": 4.0, "su0_pa": 5000.0, "ks_pa_per_m": 1000.0, "sensitivity": 4.0,
           "xi95": 20.0, "eta": 0.05, TARGET_METRIC: 0.3}
    return pd.DataFrame([row | changes])


def test_features_match_hand_values():
    table = one_row()
    # A = 2.4 m²; ½·m·v² = 9000 J; W = 44 145 N; su at z = 0.3 m: 5300 Pa
    leak = LeakFreeFeatures().transform(table).iloc[0]
    assert leak["contact_area_m2"] == pytest.approx(2.4)
    assert leak["kinetic_number"] == pytest.approx(9000 / (2.4 * 0.6 * 5000))
    assert leak["weight_number"] == pytest.approx(44145 / (2.4 * 5000))
    assert leak["gradient_number"] == pytest.approx(1000 * 0.6 / 5000)
    assert leak["delta_rem"] == pytest.approx(0.25)
    study = StudyFeatures().transform(table).iloc[0]
    assert study["energy_ratio"] == pytest.approx((9000 + 44145 * 0.3) / (2.4 * 0.6 * 5300))
    assert list(study.index) == ["delta_rem", "xi95", "eta", "energy_ratio"]
    assert target(table)[0] == pytest.approx(0.5)  # z/B
    # two tracks share the weight and the inertia
    assert energy_ratio(one_row(n_tracks=2.0), 0.3)[0] == pytest.approx((4500 + 22072.5 * 0.3) / (2.4 * 0.6 * 5300))


class Proportional:
    """An 'estimator' z/B = c·Π_E: the implicit equation then has a closed-form root."""

    def __init__(self, c):
        self.c = c

    def predict(self, X):
        return self.c * X["energy_ratio"].to_numpy()


def test_implicit_solve_finds_the_closed_form_root():
    table = one_row(ks_pa_per_m=0.0)
    c = 0.2
    # z = B·c·(K + W·z)/(A·B·su0)  =>  z = c·K / (A·su0 − c·W) = 0.568 m
    exact = c * 9000 / (2.4 * 5000 - c * 44145)
    solved = StudyFeatures().solve(Proportional(c), table, z_max_m=2.0, points=400)
    assert solved.solved.all() and solved.n_roots[0] == 1
    assert solved.sinkage_m[0] == pytest.approx(exact, rel=1e-6)
    # a model that always predicts deeper than z can go: no root, reported as unsolved
    unsolved = StudyFeatures().solve(Proportional(100.0), table, z_max_m=0.5, points=50)
    assert not unsolved.solved.any()


# ----------------------------------------------------------------------------- training


def quick_settings(**changes):
    from dsmv.surrogate.train import TrainSettings

    values = dict(study=STUDY, features="leak_free", seed=0, test_fraction=0.1, cv_folds=5, mc_splits=10, n_jobs=1,
                  experiment="surrogates", register_model=False, implicit_points=60,
                  learning_curve_fractions=[0.5, 1.0])
    return TrainSettings(**(values | changes))


def quick_rf():
    from dsmv.surrogate.base import SurrogateConfig
    from dsmv_plugins.rf import RandomForestSurrogate

    config = SurrogateConfig(name="rf", registered_model="dsmv-sinkage-rf", params={"n_estimators": 30},
                             grid={"max_depth": [4, None]}, grid_cv_folds=3)
    return RandomForestSurrogate(seed=0), config


def in_memory(n: int, seed: int = 2) -> Dataset:
    """A dataset of ``n`` synthetic ok runs without MLflow."""
    table = pd.DataFrame(synthetic_rows(n, seed)).assign(run_id=[f"r{i}" for i in range(n)])
    return Dataset(STUDY, table, pd.DataFrame(columns=["run_id", "status", "message"]))


def test_rf_learns_a_learnable_function_and_not_a_shuffled_one():
    from dsmv.surrogate.train import fit_and_evaluate

    data = in_memory(150)
    surrogate, config = quick_rf()
    learned = fit_and_evaluate(surrogate, config, quick_settings(), data)
    assert learned.metrics["cv_r2_mean"] > 0.7 and learned.metrics["mc_r2_mean"] > 0.7
    assert learned.metrics["train_r2"] > 0.9
    rng = np.random.default_rng(0)
    shuffled = Dataset(STUDY, data.table.assign(**{TARGET_METRIC: rng.permutation(data.table[TARGET_METRIC])}),
                       data.excluded)
    noise = fit_and_evaluate(surrogate, config, quick_settings(), shuffled)
    assert noise.metrics["cv_r2_mean"] < 0.2 and noise.metrics["mc_r2_mean"] < 0.2


def test_xgboost_learns_the_same_function():
    from dsmv.surrogate.base import SurrogateConfig
    from dsmv.surrogate.train import fit_and_evaluate
    from dsmv_plugins.xgb import XGBoostSurrogate

    config = SurrogateConfig(name="xgboost", registered_model="dsmv-sinkage-xgboost",
                             params={"n_estimators": 200, "learning_rate": 0.1}, grid={"max_depth": [2, 4]},
                             grid_cv_folds=3)
    result = fit_and_evaluate(XGBoostSurrogate(seed=0), config, quick_settings(), in_memory(150))
    assert result.metrics["cv_r2_mean"] > 0.7 and result.metrics["train_r2"] > 0.9


def test_learning_curve_fits_nested_subsets_and_scores_whole_folds():
    """An exact linear law is learnt exactly from any subset (R² = 1, RMSE 0 at every size); with
    noise, the full folds score better on average than a tenth of them. Sizes are the rounded
    fractions of each fold's training rows."""
    from sklearn.linear_model import LinearRegression

    from dsmv.surrogate.evaluate import learning_curve

    rng = np.random.default_rng(3)
    X = pd.DataFrame({"a": rng.uniform(size=100), "b": rng.uniform(size=100)})
    exact = 2.0 * X["a"].to_numpy() - X["b"].to_numpy()
    curve = learning_curve(LinearRegression, X, exact, [0.1, 0.5, 1.0], folds=5, seed=0)
    assert sorted(curve["n_runs"].unique()) == [8, 40, 80] and len(curve) == 15
    assert np.allclose(curve["test_r2"], 1.0, atol=1e-12) and np.allclose(curve["test_rmse"], 0.0, atol=1e-12)
    noisy = exact + rng.normal(0.0, 0.3, size=100)
    means = learning_curve(LinearRegression, X, noisy, [0.05, 1.0], folds=5, seed=0).groupby("fraction")["test_r2"].mean()
    assert means.iloc[-1] > means.iloc[0]


def test_study_features_report_the_implicit_solve():
    from dsmv.surrogate.train import fit_and_evaluate

    surrogate, config = quick_rf()
    result = fit_and_evaluate(surrogate, config, quick_settings(features="study"), in_memory(60))
    m = result.metrics
    for key in ("implicit_r2", "implicit_solved_fraction", "implicit_multiple_roots_fraction", "cv_implicit_r2_mean"):
        assert key in m and np.isfinite(m[key])
    assert 0.0 <= m["implicit_solved_fraction"] <= 1.0


# ----------------------------------------------------------------------------- CLI

METRIC_KEYS = {"test_r2", "train_r2", "cv_r2_mean", "cv_r2_std", "mc_r2_mean", "mc_r2_std", "test_mse", "test_mae",
               "test_rmse", "train_mse", "train_mae", "train_rmse", "cv_train_r2_mean", "mc_train_r2_mean",
               "interval_coverage_mean", "interval_coverage_band_low", "interval_coverage_band_high"}


@pytest.mark.parametrize("surrogate", ["rf", pytest.param("xgboost", marks=pytest.mark.slow)])
def test_train_cli_writes_metrics_and_registers_the_model(run_cli, tmp_path, store, surrogate):
    from mlflow.tracking import MlflowClient

    folder, uri, _ = store
    small = {"rf": ["surrogate.grid.n_estimators=[30]", "surrogate.grid.max_depth=[4,null]",
                    "surrogate.grid.min_samples_split=[2]", "surrogate.grid.min_samples_leaf=[1]",
                    "surrogate.grid.max_features=[1.0]"],
             "xgboost": ["surrogate.grid.n_estimators=[50]", "surrogate.grid.max_depth=[3]",
                         "surrogate.grid.learning_rate=[0.1]", "surrogate.grid.subsample=[1.0]",
                         "surrogate.grid.min_child_weight=[1]"]}[surrogate]
    proc = run_cli("dsmv-train", f"surrogate={surrogate}", f"train.study={STUDY}", f"tracking.uri={uri}",
                   f"tracking.artifact_location={folder / 'art'}", "train.mc_splits=10", "train.cv_folds=5", "train.n_jobs=1",
                   "surrogate.grid_cv_folds=3", *small)
    assert proc.returncode == 0, proc.stderr
    assert "dsmv-train:" in proc.stdout and "test" in proc.stdout
    (metrics_file,) = tmp_path.glob("runs/train/*/*/metrics.json")
    metrics = json.loads(metrics_file.read_text())
    assert METRIC_KEYS <= set(metrics)
    assert metrics["n_samples"] == 24 and metrics["n_excluded"] == 3
    for name in ("dataset.csv", "kendall_tau.png", "learning_curve.csv", "learning_curve.png"):
        assert (metrics_file.parent / name).exists(), name
    # the registered model carries its interval calibration, for dsmv-predict
    calibration = json.loads((metrics_file.parent / "conformal.json").read_text())
    assert calibration["target"] == "z_over_b" and len(calibration["residuals"]) == metrics["n_train"]
    assert 0.0 < metrics["interval_coverage_mean"] <= 1.0

    client = MlflowClient(uri)
    (run,) = client.search_runs([client.get_experiment_by_name("dsmv-surrogates").experiment_id],
                                filter_string=f"tags.`dsmv.surrogate` = '{surrogate}'")
    assert run.data.metrics["test_r2"] == pytest.approx(metrics["test_r2"])
    assert run.data.tags["dsmv.dataset_hash"] == load_dataset(uri, STUDY).content_hash
    name = f"dsmv-sinkage-{surrogate}"
    versions = client.search_model_versions(f"name = '{name}'")
    assert versions and versions[0].tags["feature_set"] == "physics"

    # the registered model reads back as a predictor with its training ranges
    from dsmv.surrogate.model import load_registered

    model = load_registered(name, uri)
    table = load_dataset(uri, STUDY).table
    z = model.predict_sinkage(table)
    assert z.shape == (len(table),) and np.all(np.isfinite(z)) and np.all(z > 0)
    assert model.out_of_range(table) == {}
    assert model.out_of_range(table.assign(mass_kg=1e5)) == {"mass_kg": list(range(len(table)))}

    # a plain MLflow client calls it with scene config keys; the keys the data never varied may be left out
    import mlflow

    from dsmv.surrogate.serving import OUTPUT_COLUMNS, scene_frame

    served = mlflow.pyfunc.load_model(f"models:/{name}/latest")
    scenes = scene_frame(table).drop(columns=["landing.n_tracks", "landing.gravity_m_s2", "landing.inertial_mass_kg"])
    answer = served.predict(scenes)
    assert tuple(answer.columns) == OUTPUT_COLUMNS
    np.testing.assert_allclose(answer["sinkage_m"], z, rtol=1e-12)
    assert (answer["sinkage_lower_m"] < answer["sinkage_m"]).all() and (answer["sinkage_m"] < answer["sinkage_upper_m"]).all()
    with pytest.raises(Exception, match="soil.su0_pa"):  # a key the data varied is required
        served.predict(scenes.drop(columns=["soil.su0_pa"]))


RF_SMALL = ["surrogate.grid.n_estimators=[30]", "surrogate.grid.max_depth=[4,null]", "surrogate.grid.min_samples_split=[2]",
            "surrogate.grid.min_samples_leaf=[1]", "surrogate.grid.max_features=[1.0]"]


@pytest.mark.server
def test_mlflow_models_serve_answers_a_scene_over_rest(run_cli, tmp_path_factory):
    """``mlflow models serve --env-manager local`` on the registered model, on loopback: a JSON
    request of scene config keys returns the sinkage and its interval, as the model does in-process."""
    import os
    import socket
    import subprocess
    import sys
    import time
    import urllib.request

    import mlflow

    from dsmv.surrogate.serving import OUTPUT_COLUMNS, scene_frame

    folder = tmp_path_factory.mktemp("serve")
    uri = write_store(folder, synthetic_rows(24))
    proc = run_cli("dsmv-train", "surrogate=rf", f"train.study={STUDY}", f"tracking.uri={uri}",
                   f"tracking.artifact_location={folder / 'art'}", "train.mc_splits=5", "train.cv_folds=5",
                   "train.n_jobs=1", "surrogate.grid_cv_folds=3", *RF_SMALL)
    assert proc.returncode == 0, proc.stderr
    scenes = scene_frame(load_dataset(uri, STUDY).table.head(3))
    mlflow.set_tracking_uri(uri)
    expected = mlflow.pyfunc.load_model("models:/dsmv-sinkage-rf/latest").predict(scenes)

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    bin_dir = Path(sys.executable).parent  # the server runs uvicorn from the PATH
    env = dict(os.environ, MLFLOW_TRACKING_URI=uri, PATH=f"{bin_dir}{os.pathsep}{os.environ['PATH']}")
    server = subprocess.Popen([str(bin_dir / "mlflow"), "models", "serve", "-m", "models:/dsmv-sinkage-rf/latest",
                               "--env-manager", "local", "-h", "127.0.0.1", "-p", str(port)], env=env, cwd=folder,
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while True:
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/ping", timeout=2) as answer:
                    if answer.status == 200:
                        break
            except OSError:
                assert server.poll() is None, server.stderr.read()
                assert time.monotonic() < deadline, "the model server did not come up in 120 s"
                time.sleep(0.5)
        body = json.dumps({"dataframe_split": json.loads(scenes.to_json(orient="split", index=False))})
        request = urllib.request.Request(f"http://127.0.0.1:{port}/invocations", data=body.encode(),
                                         headers={"Content-Type": "application/json"})
        with urllib.request.urlopen(request, timeout=60) as answer:
            predictions = pd.DataFrame(json.loads(answer.read())["predictions"])
    finally:
        server.terminate()
        server.wait(timeout=30)
    assert tuple(predictions.columns) == OUTPUT_COLUMNS
    np.testing.assert_allclose(predictions.to_numpy(), expected.to_numpy(), rtol=1e-12)


def test_train_cli_user_mistakes_are_one_line(run_cli, store, tmp_path):
    _, uri, _ = store
    proc = run_cli("dsmv-train", "surrogate=nope")
    assert proc.returncode == 2 and proc.stderr.strip().count("\n") == 0
    assert "surrogate = 'nope'" in proc.stderr and "rf, xgboost" in proc.stderr
    proc = run_cli("dsmv-train", "train.study=nothing_here", f"tracking.uri={uri}")
    assert proc.returncode == 2 and proc.stderr.strip().count("\n") == 0, proc.stderr
    assert "no tracked runs of study 'nothing_here'" in proc.stderr
    assert not (tmp_path / "runs" / "train").exists()  # a refused training leaves no run dir behind


@pytest.mark.parametrize("args, message", [
    (["surrogate.n_estimator=5"], "surrogate.n_estimator = 5: no such config key; did you mean surrogate.grid.n_estimators?"),
    (["train.cv_fold=5"], "train.cv_fold = 5: no such config key; did you mean train.cv_folds?"),
    (["surrogate.name=svm"], "surrogate.name = 'svm': not an installed surrogate; available: rf, xgboost"),
    (["surrogate=svm"], "surrogate = 'svm': not a surrogate option; available: rf, xgboost"),
    (["train.mc_splits=-1"], "train.mc_splits = -1: must be greater than or equal to 1"),
    (["surrogate.grid_cv_folds=1"], "surrogate.grid_cv_folds = 1: must be greater than or equal to 2"),
    (["surrogate.grid.n_estimators=[50,-5]"], "surrogate.grid.n_estimators = [50, -5]: The 'n_estimators' parameter of "
                                              "RandomForestRegressor must be an int in the range [1, inf). Got -5"),
    (["+surrogate.params.min_samples_leaf=0"], "surrogate.params.min_samples_leaf = 0: The 'min_samples_leaf' "
                                               "parameter of RandomForestRegressor must be"),
    (["+surrogate.params.n_trees=100"], "surrogate.params.n_trees = 100: RandomForestRegressor.__init__() got an "
                                        "unexpected keyword argument 'n_trees'"),
    (["tracking=disabled"], "tracking.enabled = False: dsmv-train reads tracked runs"),
])
def test_train_command_line_mistakes_are_one_line_before_any_run_dir(args, message, tmp_path, monkeypatch, capsys):
    """dsmv-train's command line is checked as dsmv's is, its settings and hyper-parameters as the training
    checks them (dsmv.surrogate.train.check_config), before Hydra creates anything."""
    from dsmv.app.command_line import check_app_command_line

    monkeypatch.chdir(tmp_path)
    registry.register_plugin_configs()
    with pytest.raises(SystemExit) as stop:
        check_app_command_line("dsmv-train", args)
    err = capsys.readouterr().err
    assert stop.value.code == 2 and err.startswith(f"dsmv-train: error: {message}"), err
    assert len(err.strip().splitlines()) == 1 and not (tmp_path / "runs").exists()


def test_train_on_a_study_without_an_ok_run_says_what_to_run_first(run_cli, tmp_path):
    folder = tmp_path / "failed_store"
    folder.mkdir()
    uri = write_store(folder, synthetic_rows(1), extra_statuses=("bearing_failure", "unstable", "failed"), ok=False)
    proc = run_cli("dsmv-train", f"train.study={STUDY}", f"tracking.uri={uri}")
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip() == (f"dsmv-train: error: study '{STUDY}' has no ok run to train on (3 runs: 1 "
                                   "bearing_failure, 1 failed, 1 unstable): a surrogate learns from ok runs only; run "
                                   f"`dsmv -m study={STUDY} …` first (each run's dsmv.message in MLflow says why it "
                                   "did not end ok)")
    assert not (tmp_path / "runs" / "train").exists()


def test_a_missing_store_is_not_created_and_its_message_names_the_study_s_experiment(tmp_path):
    from dsmv.surrogate.dataset import DatasetError

    uri = f"sqlite:///{tmp_path / 'mlflow.db'}"
    with pytest.raises(DatasetError, match=r"^no MLflow store at .*: run `dsmv experiment=dataset_table3` first"):
        load_dataset(uri, "dataset_table3")
    assert not (tmp_path / "mlflow.db").exists()


@pytest.mark.slow
def test_dataset_table3_runs_as_a_multirun_with_joblib(run_cli, tmp_path):
    """The design through the cases sweeper and joblib, with the energy method for speed
    (about 25 s on an idle 2-core machine: joblib's workers and a new MLflow store)."""
    from conftest import mlflow_runs

    proc = run_cli("dsmv", "experiment=dataset_table3", "dataset.n_samples=2", "solver=analytic_energy",
                   "hydra/launcher=joblib", "hydra.launcher.n_jobs=2")
    assert proc.returncode == 0, proc.stderr
    assert "dropped" in proc.stdout
    (design_file,) = tmp_path.glob("runs/multirun/*/*/dataset_design.csv")
    assert len(design_file.read_text().splitlines()) == 3
    runs = mlflow_runs(tmp_path)
    jobs = [r for r in runs if r.data.tags.get("dsmv.role") != "sweep"]
    (parent,) = [r for r in runs if r.data.tags.get("dsmv.role") == "sweep"]
    assert len(jobs) == 2 and all(r.data.tags["dsmv.study"] == "dataset_table3" for r in jobs)
    assert all(r.data.params["soil.law"] == "einav_randolph" for r in jobs)
    assert parent.data.metrics["dataset_n_kept"] == 2 and parent.data.metrics["dataset_n_dropped"] > 0


# ----------------------------------------------------------------------------- the full study


@pytest.mark.slow
@pytest.mark.parametrize("surrogate", ["rf", "xgboost"])
@pytest.mark.parametrize("features", ["physics", "leak_free", "study"])
def test_full_study_trains_on_the_table3_dataset(surrogate, features):
    """On the tracked CEL dataset in runs/ (``dsmv experiment=dataset_table3`` first): the full
    grid, 10 folds and 200 re-splits within 5 minutes, and a useful model; with the fast model's
    z/B among the features, 10-fold R² of at least 0.98 (measured: rf 0.991, xgboost 0.995)."""
    import time

    from omegaconf import OmegaConf

    from dsmv.surrogate.train import fit_and_evaluate, settings_from
    from dsmv import registry
    from dsmv.config.tree import CONFIG_DIR

    store = Path(__file__).resolve().parent.parent / "runs" / "mlflow.db"  # the checkout's local store
    if not store.exists():
        pytest.skip("no local store: run `dsmv experiment=dataset_table3` first")
    cfg = OmegaConf.merge(OmegaConf.load(Path(CONFIG_DIR) / "train.yaml"),
                          {"surrogate": OmegaConf.load(Path(CONFIG_DIR) / "surrogate" / f"{surrogate}.yaml")})
    cfg.train.features = features
    settings, config = settings_from(cfg)
    data = load_dataset(f"sqlite:///{store}", settings.study)
    if len(data.table) < 200:
        pytest.skip(f"the Table 3 dataset is incomplete ({len(data.table)} ok runs)")
    plugin = registry.load("surrogates", config.name, "surrogate.name")(seed=settings.seed)
    started = time.perf_counter()
    result = fit_and_evaluate(plugin, config, settings, data)
    assert time.perf_counter() - started < 300
    assert result.metrics["cv_r2_mean"] > (0.98 if features == "physics" else 0.8)


@pytest.mark.parametrize("name", sorted(registry.available("surrogates")))
def test_every_installed_surrogate_keeps_the_plugin_contract(name):
    """dsmv.testing's check, as a plugin's own tests call it: fits a known function, one importance per
    feature with the informative ones first, the same predictions for the same seed."""
    from dsmv.testing import check_surrogate

    check_surrogate(name, n_estimators=20)


# ----------------------------------------------------------------------------- multi-fidelity


def test_a_low_fidelity_that_is_exact_makes_a_few_3d_runs_enough():
    """3D 'runs' that are the 3D fast model itself: the forest with the fast model's z/B (its
    coefficients refitted on the draw) predicts held-out runs almost exactly from 16 runs, while the
    forest on the inputs alone does not."""
    from dsmv.surrogate.fast_model import default_settings, fast_sinkage
    from dsmv.surrogate.multifidelity import learning_curve

    rng = np.random.default_rng(1)
    n = 80
    table = pd.DataFrame({"mass_kg": rng.uniform(3000, 6500, n), "inertial_mass_kg": np.nan,
                          "velocity_m_s": rng.uniform(0.5, 3.0, n), "n_tracks": 1.0, "gravity_m_s2": 9.81,
                          "width_m": 0.6, "contact_length_m": rng.uniform(3.1, 5.2, n),
                          "su0_pa": rng.uniform(3000, 10000, n), "ks_pa_per_m": rng.uniform(500, 3000, n),
                          "sensitivity": rng.uniform(2, 5, n), "xi95": rng.uniform(10, 40, n),
                          "eta": rng.uniform(0.02, 0.15, n)})
    table[TARGET_METRIC] = fast_sinkage(table, settings=default_settings("cel3d"))
    table = table[np.isfinite(table[TARGET_METRIC])].reset_index(drop=True)  # the landings the soil stops
    curve = learning_curve(table, repeats=1)
    at16 = curve[curve.n_3d_runs == 16].set_index("model")["r2"]
    assert at16["+ fast model"] > 0.999 and at16["3D only"] < 0.99
    assert set(curve.n_3d_runs) == {16, 32, round(0.75 * len(table))}  # the sizes below the pool, then it all
