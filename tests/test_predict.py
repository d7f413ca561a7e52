"""dsmv-predict: a tiny random forest registered as dsmv-sinkage-rf in a temporary MLflow store
(through the rf plugin's own log_model, as dsmv-train does), with a conformal.json whose
residuals are known, so the interval's half-width is exactly B·q."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra
from omegaconf import OmegaConf

from dsmv.config.tree import CONFIG_DIR
from dsmv.errors import ConfigError
from dsmv.surrogate.dataset import PARAMETERS, TARGET_METRIC
from dsmv.surrogate.features import LeakFreeFeatures, target
from dsmv.surrogate.intervals import residual_quantile

NAME = "dsmv-sinkage-rf"
RESIDUALS = np.linspace(0.0, 0.2, 101)  # z/B; q(0.9) = the ⌈0.9·102⌉ = 92nd smallest = 0.182
Q90 = float(RESIDUALS[91])
B = 0.6  # m, the default track's width


def dataset(n: int = 300, seed: int = 0) -> pd.DataFrame:
    """Default-scene rows with v, su0 and L varied; z = 0.05 + 0.06·v²·(5000/su0)·(4.17/L) (m)."""
    rng = np.random.default_rng(seed)
    rows = pd.DataFrame({"mass_kg": 4500.0, "inertial_mass_kg": np.nan, "velocity_m_s": rng.uniform(0.5, 2.5, n),
                         "n_tracks": 1.0, "gravity_m_s2": 9.81, "width_m": B,
                         "contact_length_m": rng.uniform(3.1, 5.2, n), "su0_pa": rng.uniform(2000.0, 8000.0, n),
                         "ks_pa_per_m": 1500.0, "sensitivity": 3.0, "xi95": 25.0, "eta": 0.05}, index=range(n))
    rows[TARGET_METRIC] = (0.05 + 0.06 * rows.velocity_m_s**2 * 5000.0 / rows.su0_pa * 4.17 / rows.contact_length_m)
    return rows


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    """(uri, runs_dir) of a store holding one registered rf model with its conformal.json."""
    import mlflow

    from plugins.rf import RandomForestSurrogate

    folder = tmp_path_factory.mktemp("predict_store")
    uri = f"sqlite:///{folder / 'mlflow.db'}"
    mlflow.set_tracking_uri(uri)
    experiment = mlflow.create_experiment("dsmv-surrogates", artifact_location=str(folder / "mlartifacts"))
    table = dataset()
    features = LeakFreeFeatures()
    X, y = features.transform(table), target(table)
    plugin = RandomForestSurrogate(seed=0)
    estimator = plugin.make(n_estimators=30, min_samples_leaf=3).fit(X, y)
    metadata = {"surrogate": "rf", "feature_set": "leak_free", "features": list(features.columns),
                "target": "z_over_b", "study": "synthetic", "dataset_hash": "test", "implicit_z_max_m": 2.0,
                "ranges": {c: [float(table[c].min()), float(table[c].max())] for c in PARAMETERS
                           if table[c].notna().any()}}
    record = {"method": "cross_conformal_pooled", "target": "z_over_b", "folds": 10, "seed": 0,
              "n": len(RESIDUALS), "residuals": RESIDUALS.tolist()}
    (folder / "conformal.json").write_text(json.dumps(record))
    with mlflow.start_run(experiment_id=experiment):
        mlflow.log_artifact(str(folder / "conformal.json"))
        plugin.log_model(estimator, "model", NAME, None, metadata)  # an input example costs 8 s
    mlflow.set_tracking_uri(None)
    return uri, folder


def config(store, *overrides):
    uri, folder = store
    GlobalHydra.instance().clear()
    try:
        with initialize_config_dir(config_dir=CONFIG_DIR, version_base="1.3"):
            return compose("predict", overrides=[f"paths.runs_dir={folder}", f"tracking.uri={uri}", *overrides])
    finally:
        GlobalHydra.instance().clear()


def test_quantile_of_the_test_residuals():
    assert residual_quantile(RESIDUALS, 0.9) == pytest.approx(Q90) == pytest.approx(0.182)


def test_scaled_calibration_widens_the_interval_with_the_prediction():
    """A scaled record (dsmv-train's default): half-width = B·q·(a + b·z/B), in metres."""
    from dsmv.surrogate.predictor import Calibration, PredictError

    record = {"target": "z_over_b", "residuals": RESIDUALS.tolist(), "score": "scaled",
              "scale_intercept": 0.01, "scale_slope": 0.1}
    calibration = Calibration.from_record(record, "test")
    table = pd.DataFrame({"width_m": [1.0, 2.0]})
    sinkage_m = np.array([0.3, 0.3])  # z/B = 0.3, 0.15
    half = calibration.half_width_m(table, sinkage_m, 0.9)
    assert half == pytest.approx(Q90 * np.array([1.0 * (0.01 + 0.03), 2.0 * (0.01 + 0.015)]), rel=1e-12)
    old_record = {"target": "z_over_b", "residuals": RESIDUALS.tolist()}  # before scores existed: absolute
    assert Calibration.from_record(old_record, "test").half_width_m(table, sinkage_m, 0.9) == \
        pytest.approx(Q90 * table["width_m"].to_numpy(), rel=1e-12)
    with pytest.raises(PredictError, match="score 'log' is not one of absolute, scaled"):
        Calibration.from_record(record | {"score": "log"}, "test")
    with pytest.raises(PredictError, match="scale_intercept and scale_slope"):
        Calibration.from_record(record | {"scale_slope": -1}, "test")


def test_check_command_reproduces_the_training_runs_kind_and_the_scene():
    from dsmv.surrogate.model import TrainedSurrogate
    from dsmv.surrogate.predict import check_command
    from dsmv.surrogate.predictor import Predictor

    metadata = {"run_settings": {"solver": "cel2d", "soil.law": "einav_randolph", "mesh": "medium"},
                "ranges": {"velocity_m_s": [1.0, 8.0], "su0_pa": [2000.0, 10000.0], "gravity_m_s2": [9.81, 9.81]}}
    predictor = Predictor("m", "1", "-", TrainedSurrogate(None, LeakFreeFeatures(), metadata), None)
    base = pd.DataFrame([{c: 1.0 for c in PARAMETERS} | {"su0_pa": 3000.0, "velocity_m_s": 2.0}])
    command = check_command(predictor, base, "landing.velocity_m_s", 3.25)
    # the varied parameters written out (gravity is constant in the data: left to the config)
    assert command == ("dsmv solver=cel2d soil.law=einav_randolph mesh=medium soil.su0_pa=3000 "
                       "landing.velocity_m_s=3.25")


def test_default_scene_prediction_and_interval(store, tmp_path, capsys):
    from dsmv.surrogate.predict import run_predict

    out = run_predict(config(store), tmp_path)
    assert out["version"] == "1" and out["task"] == "predict"
    z_true = 0.05 + 0.06 * 1.5**2  # the default scene (su0 = 5000 Pa, L = 4.17 m): 0.185 m
    assert out["sinkage_m"] == pytest.approx(z_true, abs=0.02)
    assert out["upper_m"] - out["sinkage_m"] == pytest.approx(B * Q90, rel=1e-12)
    assert out["lower_m"] == pytest.approx(max(out["sinkage_m"] - B * Q90, 0.0), rel=1e-12)
    printed = capsys.readouterr().out
    assert "90% interval" in printed and "warning" not in printed
    assert json.loads((tmp_path / "prediction.json").read_text())["sinkage_m"] == out["sinkage_m"]


def test_scene_outside_the_training_range_warns(store, capsys):
    from dsmv.surrogate.predict import run_predict

    out = run_predict(config(store, "soil.su0_pa=9000", "confidence=0.8"))
    assert out["outside_training_range"] == ["soil.su0_pa"]
    assert out["upper_m"] - out["sinkage_m"] == pytest.approx(B * residual_quantile(RESIDUALS, 0.8))
    printed = capsys.readouterr().out
    assert "warning: the scene lies outside the training data: soil.su0_pa = 9000 not in" in printed
    # beside it, what the physics says and the CEL run that answers it
    assert f"The fast landing model says {out['fast_model_sinkage_m']:.4f} m" in printed
    assert "the CEL: dsmv solver=cel2d" in printed and "soil.su0_pa=9000" in printed


@pytest.mark.parametrize("task, parameter, column", [("max_velocity", "landing.velocity_m_s", "velocity_m_s"),
                                                     ("min_contact_length", "geometry.contact_length_m",
                                                      "contact_length_m")])
def test_inverse_tasks_agree_with_a_brute_force_scan_of_the_model(store, tmp_path, task, parameter, column):
    from dsmv.surrogate.model import scene_table
    from dsmv.surrogate.predict import run_predict
    from dsmv.surrogate.predictor import load_predictor
    from dsmv.config.scene import build_scene

    cfg = config(store, f"task={task}", "sinkage_limit_m=0.3", "verify=false")
    out = run_predict(cfg, tmp_path)
    assert out["status"] == "ok" and (tmp_path / "inverse.png").stat().st_size > 10_000
    # the exact answer of this model: the first crossing of the limit on a fine scan from the safe end
    predictor = load_predictor(NAME, store[0])
    base = scene_table([build_scene(cfg)])
    lo, hi = predictor.model.metadata["ranges"][column]
    scan = np.linspace(lo, hi, 20_001)
    table = base.loc[base.index.repeat(len(scan))].reset_index(drop=True)
    table[column] = scan
    passes = predictor.upper(0.9)(table) <= 0.3
    if task == "min_contact_length":
        scan, passes = scan[::-1], passes[::-1]
    exact = scan[np.argmin(passes) - 1]
    assert out["value"] == pytest.approx(exact, abs=(hi - lo) / 20_000)
    assert out["upper_at_value_m"] <= 0.3


def test_verify_runs_cel_at_the_answer_and_beyond(store, tmp_path, monkeypatch, capsys):
    """verify (the default): real CEL landings (medium mesh) at the answer, then 20 % faster than the
    CEL's own answer; when the CEL at the surrogate's answer is over the limit, a CEL bisection from
    the searched range's safe end finds the largest velocity it keeps under it."""
    from dsmv.surrogate.predict import run_predict

    monkeypatch.chdir(tmp_path)  # the check runs track into ./runs
    out = run_predict(config(store, "task=max_velocity", "sinkage_limit_m=0.3", "plot=false"), tmp_path / "predict")
    checks = out["verify"]
    assert out["cel_runs"] == len(checks) and all(c["status"] == "ok" for c in checks)
    first, beyond = checks[0], checks[-1]
    assert first["role"] == "answer" and first["value"] == pytest.approx(out["value"], rel=1e-3)
    assert beyond["role"] == "20 % beyond" and beyond["value"] == pytest.approx(1.2 * out["cel_value"])
    # the CEL's answer: a CEL run there is under the limit, and any run over it was at a larger velocity
    at = next(c for c in checks[:-1] if c["value"] == out["cel_value"])
    assert at["under_limit"] and at["max_sinkage_m"] <= 0.3
    assert all(c["value"] > out["cel_value"] for c in checks[:-1] if not c["under_limit"])
    if first["under_limit"]:
        assert out["cel_value"] == first["value"] and len(checks) == 2
    else:
        failing = min(c["value"] for c in checks if not c["under_limit"] and c["role"] != "20 % beyond")
        assert failing - out["cel_value"] <= 0.02 * first["value"]  # the bisection's bracket
    assert beyond["max_sinkage_m"] > at["max_sinkage_m"] > 0.0
    assert (tmp_path / "predict" / "check_0" / "result.json").is_file()
    assert "verify   : CEL answer" in capsys.readouterr().out


@pytest.mark.parametrize("surrogate_answer, runs", [(2.5, 2), (3.6, 9)])
def test_a_cel_check_that_fails_is_refined_by_cel_bisection(monkeypatch, tmp_path, surrogate_answer, runs):
    """A CEL whose sinkage is 0.1 s·v (m) against a 0.3 m limit: its answer is 3 m/s. A surrogate answer
    of 2.5 m/s holds (two runs: at it and 20 % beyond); one of 3.6 m/s is over the limit, and the
    bisection from the safe end 0.5 m/s brackets 3 m/s to 2 % of 3.6 m/s: the answer, the safe end,
    ⌈log2(3.1/0.072)⌉ = 6 halvings and the run 20 % beyond, 9 runs."""
    from dsmv.surrogate import predict as P
    from dsmv.surrogate.inverse import InverseResult

    def cel(predictor, base, parameter, value, limit, folder):
        return {"value": value, "status": "ok", "max_sinkage_m": 0.1 * value, "under_limit": 0.1 * value <= limit,
                "run_dir": str(folder)}

    monkeypatch.setattr(P, "cel_check", cel)
    result = InverseResult("landing.velocity_m_s", surrogate_answer, "ok", 0.29, 0.3, True, np.zeros(0), np.zeros(0))
    verified = P.verify_answer(None, None, result, tmp_path, safe_end=0.5, tolerance=0.02)
    assert verified["cel_runs"] == len(verified["checks"]) == runs
    if surrogate_answer < 3.0:
        assert verified["value"] == surrogate_answer
    else:
        assert 3.0 - 0.02 * 3.6 <= verified["value"] <= 3.0 and "bisection" in verified["how"]
    assert verified["checks"][-1]["value"] == pytest.approx(1.2 * verified["value"])


def test_csv_in_bulk(store, tmp_path, capsys):
    from dsmv.surrogate.predict import run_predict

    n = 10_000
    rng = np.random.default_rng(3)
    pd.DataFrame({"id": range(n), "landing.velocity_m_s": rng.uniform(0.5, 3.0, n),
                  "su0_pa": rng.uniform(2000, 8000, n)}).to_csv(tmp_path / "scenes.csv", index=False)
    out = run_predict(config(store, f"csv={tmp_path / 'scenes.csv'}"))
    assert out["n"] == n and out["predict_s"] < 1.0
    written = pd.read_csv(tmp_path / "scenes_predictions.csv")
    assert list(written.columns[:3]) == ["id", "landing.velocity_m_s", "su0_pa"] and len(written) == n
    assert np.allclose(written.upper_m - written.sinkage_m, B * Q90, atol=1e-5)
    train = dataset()
    v = written["landing.velocity_m_s"]
    outside = ((v < train.velocity_m_s.min()) | (v > train.velocity_m_s.max()) | (written.su0_pa < train.su0_pa.min())
               | (written.su0_pa > train.su0_pa.max()))
    assert (written.outside_training_range == outside).all()
    assert "scenes outside the training data" in capsys.readouterr().out


def test_plot_band_writes_a_png(tmp_path):
    from dsmv.surrogate.predict import plot_band

    v = np.linspace(0.5, 3.0, 50)
    path = plot_band(v, 0.05 * v**2, 0.05 * v**2 - 0.03, 0.05 * v**2 + 0.03, "landing.velocity_m_s", 0.9,
                     tmp_path / "band.png", 0.3, 2.3, (0.5, 2.5), "test")
    assert path.stat().st_size > 10_000


def cli(cwd, *args):
    env = dict(os.environ, NUMBA_NUM_THREADS="1", HYDRA_FULL_ERROR="0")
    return subprocess.run([str(Path(sys.executable).parent / "dsmv-predict"), *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("overrides, message", [
    (["task=bogus"], "task = 'bogus': must be 'predict', 'max_velocity', 'min_contact_length' or 'exceedance'"),
    (["task=max_velocity", "sinkage_limit_m=-0.1"], "sinkage_limit_m = -0.1: must be greater than 0"),
    (["task=max_velocity"], "sinkage_limit_m = None: task=max_velocity needs a limit"),
    (["confidence=1.0"], "confidence = 1.0: must be less than 1"),
    (["tracking.uri=sqlite:///nowhere/mlflow.db"], "no MLflow store at sqlite:///nowhere/mlflow.db"),
    (["csv=/nowhere/scenes.csv"], "csv = '/nowhere/scenes.csv': no such file"),
])
def test_user_mistakes_are_one_line_with_exit_2(store, overrides, message, capsys):
    from dsmv.surrogate.predict import predict

    with pytest.raises(SystemExit) as exit_:
        predict(config(store, *overrides))
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith(f"dsmv-predict: error: {message}") and len(err.strip().splitlines()) == 1, err


@pytest.mark.parametrize("args, message", [
    (["task=bogus"], "dsmv-predict: error: task = 'bogus': must be"),
    (["surrogate=svm"], "dsmv-predict: error: surrogate = 'svm': not a surrogate option; available: rf, xgboost"),
    (["landing.mas_kg=5000"], "dsmv-predict: error: landing.mas_kg = 5000: no such config key; did you mean "
                              "landing.mass_kg?"),
    (["landing.mass_kg=-5"], "dsmv-predict: error: landing.mass_kg = -5: must be greater than 0"),
    (["task=exceedance", "sinkage_limit_m=0.1", "uncertainty.soil.su0_pa.dist=beta"],
     "dsmv-predict: error: uncertainty.soil.su0_pa.dist = 'beta': must be"),
    (["tracking.uri=sqlite:///nowhere/mlflow.db"], "dsmv-predict: error: no MLflow store at sqlite:///nowhere/mlflow.db"),
])
def test_cli_mistakes_are_one_line_with_exit_2(tmp_path, args, message):
    done = cli(tmp_path, *args)
    assert done.returncode == 2, done.stderr
    assert done.stderr.strip().startswith(message), done.stderr
    assert len(done.stderr.strip().splitlines()) == 1 and "Traceback" not in done.stderr
    assert not (tmp_path / "runs" / "predict").exists()  # refused before it ran or when it started: no run dir left


@pytest.mark.parametrize("override, message", [
    ("solver=cel3d", "solver = 'cel3d': the model predicts 2D cross-section, cel2d, soil law not recorded runs"),
    ("soil.law=tresca", "soil.law = 'tresca': the model predicts"),
    ("mesh=fine", "mesh = 'fine': the model predicts"),
    ("landing.mass_kg=5000", "landing.mass_kg = '5000': the model was trained on landing.mass_kg = 4500 only"),
    ("geometry.grouser_height_m=0.03", "geometry.grouser_height_m = '0.03': not an input of the model, which "
                                       "varies landing.velocity_m_s, geometry.contact_length_m, soil.su0_pa"),
])
def test_an_override_the_model_cannot_honour_is_refused(store, override, message):
    """The model answers for the runs it learnt: another solver, law or mesh, a key it never saw, or a
    value of an input it was trained on one value of, is one line, not an answer of another kind."""
    from dsmv.surrogate.predict import run_predict

    with pytest.raises(ConfigError) as error:
        run_predict(config(store, override), None, [override])
    assert str(error.value).startswith(message), str(error.value)


def test_the_overrides_a_model_honours_pass(store, capsys):
    from dsmv.surrogate.predict import describe_runs, run_predict

    kept = ["landing.velocity_m_s=1.2", "landing.mass_kg=4500", "solver=cel2d", "soil=nodule_field", "confidence=0.8"]
    assert "sinkage_m" in run_predict(config(store, *kept), None, kept)
    assert "  predicts : 2D cross-section, cel2d, soil law not recorded" in capsys.readouterr().out
    assert describe_runs({"solver": "cel3d", "mesh": "coarse", "soil.law": "einav_randolph"}) == \
        "3D track, grouser tips, cel3d coarse, einav_randolph"


def test_a_scene_the_soil_cannot_stop_is_a_bearing_failure_answer(store, tmp_path, capsys):
    """50 t on one track: the fast landing model (solver=analytic_dynamic, which answers the same scene
    bearing_failure) finds no depth where the soil stops it; dsmv-predict says so instead of predicting."""
    from dsmv.analytic.dynamic import AnalyticDynamicSolver
    from dsmv.config.scene import build_scene
    from dsmv.surrogate.predict import run_predict

    heavy = config(store, "landing.mass_kg=50000")
    assert AnalyticDynamicSolver(build_scene(config(store, "landing.mass_kg=50000", "solver=analytic_dynamic"))
                                 ).solve().status == "bearing_failure"
    out = run_predict(heavy, tmp_path)
    assert out["status"] == "bearing_failure" and "sinkage_m" not in out
    assert "answer   : bearing_failure" in capsys.readouterr().out
    assert json.loads((tmp_path / "prediction.json").read_text())["status"] == "bearing_failure"
    assert "sinkage_m" in run_predict(config(store, "landing.mass_kg=6500"))  # a landing the soil stops: predicted


@pytest.mark.slow  # three processes that each import MLflow and open a store: about 35 s
def test_cli_with_a_store_but_no_registered_model_and_then_with_one(store, tmp_path):
    import mlflow

    empty = f"sqlite:///{tmp_path / 'empty.db'}"
    mlflow.MlflowClient(tracking_uri=empty).search_experiments()  # creates the empty store
    done = cli(tmp_path, f"tracking.uri={empty}")
    assert done.returncode == 2 and "no registered model 'dsmv-sinkage-rf'" in done.stderr
    done = cli(tmp_path, f"tracking.uri={store[0]}", "landing.velocity_m_s=2")
    assert done.returncode == 0, done.stderr
    assert "sinkage  :" in done.stdout and "90% interval" in done.stdout


# ----------------------------------------------------------------------------- reliability (task=exceedance)


def test_distributions_have_the_moments_they_are_given():
    from dsmv.surrogate.reliability import Distribution

    rng = np.random.default_rng(1)
    n = 400_000
    z = Distribution(dist="lognormal", median=5000.0, cov=0.2).sample(rng, n)
    assert np.median(z) == pytest.approx(5000.0, rel=0.005) and z.std() / z.mean() == pytest.approx(0.2, rel=0.01)
    x = Distribution(dist="normal", mean=1500.0, cov=0.1).sample(rng, n)
    assert x.mean() == pytest.approx(1500.0, rel=0.002) and x.std() / x.mean() == pytest.approx(0.1, rel=0.01)
    u = Distribution(dist="uniform", low=1.0, high=2.0).sample(rng, n)
    assert u.min() >= 1.0 and u.max() <= 2.0 and u.mean() == pytest.approx(1.5, rel=0.002)


def test_exceedance_is_the_share_of_sampled_scenes_over_the_limit(store, tmp_path):
    """P(z > limit) is the fraction of the seeded samples whose prediction exceeds the limit, with the
    binomial standard error; the interval's bounds bracket it; a limit above every sample gives 0,
    one below every sample 1."""
    from dsmv.config.scene import build_scene
    from dsmv.surrogate.model import scene_table
    from dsmv.surrogate.predict import run_predict
    from dsmv.surrogate.predictor import load_predictor
    from dsmv.surrogate.reliability import sample_scenes, uncertainty_from

    args = ["task=exceedance", "verify=false", "uncertainty.samples=2000", "uncertainty.soil.su0_pa.cov=0.3"]
    cfg = config(store, *args, "sinkage_limit_m=0.3")
    out = run_predict(cfg, tmp_path)
    table = sample_scenes(scene_table([build_scene(cfg)]), uncertainty_from(OmegaConf.to_container(cfg, resolve=True)))
    mid, lower, upper = load_predictor(NAME, store[0]).interval(table, 0.9)
    p = np.mean(mid > 0.3)
    assert out["exceedance_probability"] == p and out["samples"] == 2000
    assert out["monte_carlo_error"] == pytest.approx(np.sqrt(p * (1 - p) / 2000))
    assert out["model_low"] <= p <= out["model_high"]
    assert (tmp_path / "exceedance.png").stat().st_size > 10_000
    assert run_predict(config(store, *args, "sinkage_limit_m=100"))["exceedance_probability"] == 0.0
    assert run_predict(config(store, *args, "sinkage_limit_m=1e-9"))["exceedance_probability"] == 1.0


def test_calibrated_soil_uncertainty_flows_into_the_exceedance(store, capsys):
    """dsmv-calibrate's joint draws, read by the exceedance as dsmv-predict reads them: P(z > limit) of the
    default scene with the calibrated uncertainty beside the default file's, both printed; the default's
    is dsmv-predict's own answer, the calibrated one that of the written uncertainty= file."""
    from dsmv.calibration.run import run_calibration
    from dsmv.config.tree import compose_scene
    from dsmv.surrogate.model import scene_table
    from dsmv.surrogate.predict import run_predict
    from dsmv.surrogate.predictor import load_predictor
    from dsmv.surrogate.reliability import exceedance, sample_scenes, uncertainty_from
    from dsmv.testing import compose_config

    uri, folder = store
    cfg = compose_config("calibrate", "site=synthetic_ccz", f"tracking.uri={uri}", f"paths.runs_dir={folder}",
                         "calibrate.tests=[{kind: tbar, path: conf/site/tbar_20mm_s.csv}, "
                         "{kind: tbar, path: conf/site/tbar_0p2mm_s.csv}, {kind: fall_cone, path: conf/site/fall_cones.csv}]",
                         "calibrate.parameters=[soil.su0_pa,soil.ks_pa_per_m,soil.rate.eta]",
                         "~calibrate.synthetic.truth.soil.sensitivity", "~calibrate.synthetic.truth.soil.xi95",
                         "calibrate.bootstrap=30", "calibrate.cel_check=false",
                         "calibrate.exceedance.sinkage_limit_m=0.1", f"calibrate.exceedance.registered_model={NAME}")
    out = run_calibration(cfg, folder / "calibration_run")
    printed = capsys.readouterr().out
    answers = out["exceedance"]
    assert "default scene, calibrated uncertainty" in printed and "default scene, default uncertainty" in printed
    default = run_predict(config(store, "task=exceedance", "verify=false", "plot=false", "sinkage_limit_m=0.1"))
    assert answers["default"]["probability"] == default["exceedance_probability"]
    written = OmegaConf.to_container(OmegaConf.load(folder / "calibration_run" / "conf" / "uncertainty" / "synthetic_ccz.yaml"))
    uncertainty = uncertainty_from({"uncertainty": written})
    assert sorted(uncertainty.joint.columns) == ["soil.ks_pa_per_m", "soil.rate.eta", "soil.su0_pa"]
    mid, lower, upper = load_predictor(NAME, uri).interval(sample_scenes(scene_table([compose_scene([])]), uncertainty), 0.9)
    assert answers["calibrated"]["probability"] == exceedance(mid, lower, upper, 0.1).probability
    assert answers["calibrated"]["probability"] != answers["default"]["probability"]


def test_the_exceedance_histogram_names_the_model_that_drew_it(store, tmp_path, monkeypatch):
    """The title of exceedance.png, read back from the drawn figure: the surrogate in words and by name,
    the registered model and version, and what it was trained on (the metadata dsmv-train records)."""
    from dsmv.surrogate.evaluate import pyplot
    from dsmv.surrogate.predict import run_predict

    plt = pyplot()
    close = plt.close
    monkeypatch.setattr(plt, "close", lambda *args, **kwargs: None)  # keep the figure to read it back
    try:
        run_predict(config(store, "task=exceedance", "verify=false", "uncertainty.samples=500",
                           "sinkage_limit_m=0.3"), tmp_path)
        title = plt.figure(plt.get_fignums()[-1]).axes[0].get_title()
    finally:
        close("all")
    model, trained, answer = title.splitlines()
    assert model == "random forest (rf), dsmv-sinkage-rf v1"
    assert trained == "leak_free features, trained on study synthetic (dataset test)"
    assert answer.startswith("P(z > 0.3 m) = ")


def test_a_model_whose_plugin_is_not_installed_is_named_by_its_name():
    from dsmv.surrogate.model import TrainedSurrogate
    from dsmv.surrogate.predictor import Predictor

    metadata = {"surrogate": "svm", "run_settings": {"solver": "cel2d", "soil.law": "tresca"}, "study": "s"}
    predictor = Predictor("dsmv-sinkage-svm", "2", "-", TrainedSurrogate(None, LeakFreeFeatures(), metadata), None)
    assert predictor.describe() == ("svm, dsmv-sinkage-svm v2", "trained on study s (cel2d, tresca)")


@pytest.mark.parametrize("override, message", [
    ("uncertainty.soil.su0_pa.dist=beta", "uncertainty.soil.su0_pa.dist = 'beta': must be 'normal', 'lognormal' or 'uniform'"),
    ("uncertainty.landing.velocity_m_s.low=3", "uncertainty.landing.velocity_m_s = [3.0, 2.0]: a uniform distribution needs low < high"),
    ("+uncertainty.soil.density_kg_m3={dist:normal,mean:600,cov:0.1}", "uncertainty.soil.density_kg_m3"),
])
def test_a_wrong_uncertainty_is_one_line(store, override, message):
    from dsmv.surrogate.predict import run_predict

    with pytest.raises(ConfigError) as caught:
        run_predict(config(store, "task=exceedance", "verify=false", "sinkage_limit_m=0.3", override))
    assert str(caught.value).startswith(message) and "\n" not in str(caught.value)


def test_exceedance_spot_checks_run_the_cel_at_a_quantile(store, tmp_path, monkeypatch):
    from dsmv.surrogate.predict import run_predict

    monkeypatch.chdir(tmp_path)
    out = run_predict(config(store, "task=exceedance", "sinkage_limit_m=0.3", "spot_checks=[0.5]", "plot=false",
                             "uncertainty.samples=500"), tmp_path / "predict")
    (check,) = out["verify"]
    assert check["status"] == "ok" and check["quantile"] == 0.5 and check["max_sinkage_m"] > 0.0
    assert (tmp_path / "predict" / "check_0" / "result.json").is_file()
