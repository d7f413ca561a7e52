"""The CLI end to end: result.json per job, MLflow runs, parents for sweeps, failures kept."""

import json
import os
import shlex
import subprocess
from pathlib import Path

import pytest

from dsmv.results import HISTORY_COLUMNS
from tests.conftest import BIN, mlflow_runs, mlflow_server

RESULT_KEYS = {"status", "message", "solver", "soil_law", "metrics", "units", "dsmv_version", "config_hash"}


def job_dirs(root: Path) -> list[Path]:
    """Hydra job dirs (runs/outputs/<day>/<time>, runs/multirun/<day>/<time>/<n>), not artifact copies."""
    found = [*root.glob("runs/outputs/*/*/result.json"), *root.glob("runs/multirun/*/*/*/result.json")]
    return sorted(p.parent for p in found)


def test_single_run_writes_the_contract_and_one_finished_mlflow_run(run_cli, tmp_path):
    proc = run_cli("dsmv")
    assert proc.returncode == 0, proc.stderr
    assert "dsmv: ok — max sinkage 0.0654 m" in proc.stdout  # the default solver, cel2d (README)
    (job,) = job_dirs(tmp_path)
    result = json.loads((job / "result.json").read_text())
    assert set(result) == RESULT_KEYS
    assert result["status"] == "ok" and result["soil_law"] == "einav_randolph" and result["solver"] == "cel2d"
    assert result["units"]["max_sinkage_m"] == "m"
    header = (job / "history.csv").read_text().splitlines()[0]
    assert header == ",".join((*HISTORY_COLUMNS, "plate_sinkage_m"))  # a track's plates: its section's base
    assert result["metrics"]["plate_sinkage_m"] == result["metrics"]["max_sinkage_m"]
    assert (job / "config_resolved.yaml").exists()

    (run,) = mlflow_runs(tmp_path)
    assert run.info.status == "FINISHED"
    assert run.data.tags["dsmv.status"] == "ok" and run.data.params["status"] == "ok"
    # named by its solver and soil law (and overrides, none here), the scene in words a tag, described by the answer
    assert run.data.tags["mlflow.runName"] == "cel2d einav_randolph"
    assert run.data.tags["dsmv.scene"] == "nodule_field soil (einav_randolph), track_pioneer_i, drop 4500 kg at 1.5 m/s"
    assert run.data.tags["mlflow.note.content"] == "ok: max sinkage 0.0654 m of the 2D cross-section"
    assert run.data.metrics["plate_sinkage_m"] == result["metrics"]["plate_sinkage_m"]
    # MLflow 3 opens the experiment on its runs (a classic experiment), under a description
    from mlflow.tracking import MlflowClient

    experiment = MlflowClient(f"sqlite:///{(tmp_path / 'runs' / 'mlflow.db').resolve()}").get_experiment(
        run.info.experiment_id)
    assert experiment.tags["mlflow.experimentKind"] == "custom_model_development"
    assert "one run per dsmv job" in experiment.tags["mlflow.note.content"]
    assert run.data.params["soil.su0_pa"] == "5000.0"
    assert run.data.metrics["max_sinkage_m"] == pytest.approx(result["metrics"]["max_sinkage_m"])
    assert "history.sinkage_m" in run.data.metrics


def test_python_dash_m_is_the_same_app(run_cli, tmp_path):
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-m", "dsmv", "tracking=disabled", "landing.velocity_m_s=0"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "dsmv: ok" in proc.stdout


@pytest.mark.parametrize("launcher", ["basic", "joblib",
                                      pytest.param("dsmv_local", marks=pytest.mark.server)])  # with the scale-out tests
def test_2x2_multirun_leaves_one_parent_and_four_finished_children(run_cli, tmp_path, launcher):
    """Hydra's basic launcher (one process), joblib's (a pool) and submitit's through dsmv_local (a
    worker process per job): the same parent run, four FINISHED children, every metric arrived."""
    args = ["-m", "landing.velocity_m_s=0.5,1.0", "soil.su0_pa=4000,6000", "output.plots=false"]
    if launcher == "joblib":
        args += ["hydra/launcher=joblib", "hydra.launcher.n_jobs=2"]
    elif launcher == "dsmv_local":
        args += ["hydra/launcher=dsmv_local"]
    proc = run_cli("dsmv", *args)
    assert proc.returncode == 0, proc.stderr
    if launcher != "dsmv_local":  # (submitit keeps a worker's console in its log)
        # the jobs' progress through the sweep: each count once, however close together two jobs end
        assert [proc.stdout.count(f"({k} of 4 jobs done)") for k in (1, 2, 3, 4)] == [1, 1, 1, 1], proc.stdout
    jobs = job_dirs(tmp_path)
    assert len(jobs) == 4
    assert all(json.loads((j / "result.json").read_text())["status"] == "ok" for j in jobs)

    runs = mlflow_runs(tmp_path)
    parents = [r for r in runs if r.data.tags.get("dsmv.role") == "sweep"]
    children = [r for r in runs if "mlflow.parentRunId" in r.data.tags]
    assert len(parents) == 1 and len(children) == 4 and len(runs) == 5
    parent = parents[0]
    assert parent.info.status == "FINISHED" and parent.data.metrics["jobs_ok"] == 4
    assert {c.data.tags["mlflow.parentRunId"] for c in children} == {parent.info.run_id}
    assert all(c.info.status == "FINISHED" for c in children)
    # nothing lost in parallel writes: every job's params and metrics arrived
    got = sorted((c.data.params["landing.velocity_m_s"], c.data.params["soil.su0_pa"]) for c in children)
    assert got == [("0.5", "4000"), ("0.5", "6000"), ("1.0", "4000"), ("1.0", "6000")]
    assert all("max_sinkage_m" in c.data.metrics for c in children)
    # named by what they compute: the sweep by its overrides, a job by its values, solver and soil law;
    # where results go and how they are kept (output, hydra, paths, tracking) name nothing
    assert parent.info.run_name == "sweep velocity_m_s=0.5,1.0 su0_pa=4000,6000"
    names = {c.info.run_name for c in children}
    assert "velocity_m_s=1.0 su0_pa=6000 cel2d einav_randolph" in names and len(names) == 4
    sweep_dir = jobs[0].parent
    assert (sweep_dir / "sweep_summary.csv").read_text().count("\n") == 5


BROKEN_SOLVER = '''
from pydantic import BaseModel, ConfigDict

class Config(BaseModel):
    model_config = ConfigDict(extra="allow")
    name: str

class BrokenSolver:
    config_model = Config
    def __init__(self, scene):
        self.scene = scene
    def solve(self, run_dir=None):
        raise RuntimeError("kaboom in the solver")
'''


def test_a_solver_that_raises_leaves_result_json_and_a_failed_run(run_cli, tmp_path, install_plugin):
    install_plugin("broken_solver", BROKEN_SOLVER, "dsmv.solvers", "broken", "BrokenSolver")
    proc = run_cli("dsmv-plugins")
    assert "broken" in proc.stdout and "broken_solver:BrokenSolver" in proc.stdout
    proc = run_cli("dsmv", "solver.name=broken")
    assert proc.returncode == 1
    assert "kaboom in the solver" in proc.stderr
    (job,) = job_dirs(tmp_path)
    result = json.loads((job / "result.json").read_text())
    assert result["status"] == "failed" and "kaboom" in result["message"]
    (run,) = mlflow_runs(tmp_path)
    assert run.info.status == "FAILED"
    assert "kaboom" in run.data.tags["dsmv.error"] and run.data.tags["dsmv.status"] == "failed"


def test_bearing_failure_is_a_finished_run_with_its_status(run_cli, tmp_path):
    proc = run_cli("dsmv", "soil.law=tresca", "soil.su0_pa=2000", "soil.ks_pa_per_m=0")
    assert proc.returncode == 0, proc.stderr
    assert "bearing_failure" in proc.stdout
    (run,) = mlflow_runs(tmp_path)
    assert run.info.status == "FINISHED" and run.data.tags["dsmv.status"] == "bearing_failure"


def test_dsmv_plugins_lists_groups_and_builtins(run_cli):
    out = run_cli("dsmv-plugins").stdout
    for line in ("dsmv.soil_laws:", "dsmv.solvers:", "dsmv.surrogates:", "tresca", "analytic_energy"):
        assert line in out


@pytest.mark.server  # an MLflow server process: with the other server tests, which CI runs apart
def test_tracking_server_option_logs_to_a_local_server(run_cli, tmp_path):
    """tracking=server with tracking.uri pointing at an MLflow server on the loopback address."""
    from mlflow.tracking import MlflowClient

    with mlflow_server(f"sqlite:///{tmp_path / 'server.db'}", tmp_path) as uri:
        proc = run_cli("dsmv", "tracking=server", f"tracking.uri={uri}")
        assert proc.returncode == 0, proc.stderr
        assert f"browse  : {uri}" in proc.stdout
        client = MlflowClient(uri)
        (experiment,) = [e for e in client.search_experiments() if e.name == "dsmv-default_scene"]
        (run,) = client.search_runs([experiment.experiment_id])
        assert run.info.status == "FINISHED" and run.data.tags["dsmv.status"] == "ok"
        assert {"result.json", "history.csv"} <= {a.path for a in client.list_artifacts(run.info.run_id)}


def test_a_wrong_job_in_a_sweep_is_recorded_and_the_others_run(run_cli, tmp_path):
    proc = run_cli("dsmv", "-m", "soil.su0_pa=4000,-1,6000")
    assert "soil.su0_pa = -1" in proc.stderr
    assert proc.returncode == 1  # the sweep's worst job: failed
    assert "dsmv: sweep done: 2 ok, 1 failed" in proc.stdout
    jobs = job_dirs(tmp_path)
    statuses = sorted(json.loads((j / "result.json").read_text())["status"] for j in jobs)
    assert statuses == ["failed", "ok", "ok"]
    runs = mlflow_runs(tmp_path)
    (parent,) = [r for r in runs if r.data.tags.get("dsmv.role") == "sweep"]
    assert parent.info.status == "FINISHED"
    assert parent.data.metrics["jobs_ok"] == 2 and parent.data.metrics["jobs_failed"] == 1


def test_a_push_summary_reports_its_depth_and_bearing_factors(compose_cfg, capsys, tmp_path):
    """A push has no landing mass and no 'max sinkage' to report: the summary says how far it went
    and q/su at the sampled depths; a landing keeps its max sinkage; a failed run says what happened."""
    from dsmv.results import SolveResult
    from dsmv.app.runner import print_summary
    from dsmv.config.scene import build_scene

    push = build_scene(compose_cfg(["experiment=verify_prandtl", "landing.displacement_m=0.06"]))
    metrics = {"max_sinkage_m": 0.06, "nc_at_0p02B": 4.894, "nc_at_0p05B": 5.532}
    print_summary(push, SolveResult("ok", "pushed to 0.06 m", metrics), tmp_path, None, multirun=False)
    out = capsys.readouterr().out
    assert "dsmv: ok — pushed to 0.0600 m; q/su 4.894 at 0.02 B, 5.532 at 0.05 B" in out
    assert "push to 0.06 m at 0.1 m/s" in out and " kg" not in out
    landing = build_scene(compose_cfg([]))
    print_summary(landing, SolveResult("ok", "came to rest", {"max_sinkage_m": 0.122}), tmp_path, None, multirun=True)
    assert capsys.readouterr().out.strip().endswith("ok: max sinkage 0.1220 m of the 2D cross-section")
    print_summary(push, SolveResult("unstable", "NaN in the velocities", {}), tmp_path, None, multirun=True)
    assert capsys.readouterr().out.strip().endswith("unstable: NaN in the velocities")


def test_a_track_s_summary_names_its_sinkages_and_a_section_its_3d_estimate(compose_cfg, capsys, tmp_path):
    """The 3D track reports its grouser tips and its plates; the 2D cross-section never passes for the
    track: it prints the 3D estimate (the section + the measured 3D–2D difference, with its range) and
    the command that lands the track in 3D."""
    from dsmv.app.runner import SECTION_TO_TRACK_M, print_summary
    from dsmv.config.scene import build_scene
    from dsmv.results import SolveResult, add_plate_sinkage

    track = build_scene(compose_cfg(["solver=cel3d"]))
    result = SolveResult("ok", "came to rest", {"max_sinkage_m": 0.1185})
    add_plate_sinkage(result, track.geometry.grouser_height_m)
    print_summary(track, result, tmp_path, None, multirun=False)
    out = capsys.readouterr().out
    assert "dsmv: ok — max sinkage 0.1185 m at the grouser tips, 0.0685 m at the plates" in out
    assert "3D track:" not in out
    section = build_scene(compose_cfg(["soil.su0_pa=6000"]))
    print_summary(section, SolveResult("ok", "came to rest", {"max_sinkage_m": 0.0532}), tmp_path, None,
                  multirun=False, overrides=["soil.su0_pa=6000", "mesh=fine"])
    out = capsys.readouterr().out
    low, high = 0.0532 + SECTION_TO_TRACK_M["least"], 0.0532 + SECTION_TO_TRACK_M["largest"]
    assert "dsmv: ok — max sinkage 0.0532 m of the 2D cross-section" in out
    assert (f"3D track: about {0.0532 + SECTION_TO_TRACK_M['median']:.3f} m at the grouser tips "
            f"({low:.3f}–{high:.3f} m") in out
    assert "the 3D answer: dsmv solver=cel3d soil.su0_pa=6000\n" in out  # the user's mesh is 2D's, not 3D's
    table = "soil.profile={depth_m:[0,3],su_pa:[5000,9500]}"  # braces a shell would expand, quoted
    print_summary(build_scene(compose_cfg([table])), SolveResult("ok", "came to rest", {"max_sinkage_m": 0.0532}),
                  tmp_path, None, multirun=False, overrides=[table])
    assert shlex.split(capsys.readouterr().out.split("the 3D answer: ")[1].splitlines()[0]) == [
        "dsmv", "solver=cel3d", table]


def test_the_slurm_launcher_composes_with_dsmv_s_defaults(compose_cfg):
    """hydra/launcher=dsmv_slurm: submitit's SLURM launcher, one cpu and one Numba thread per job."""
    cfg = compose_cfg(["hydra/launcher=dsmv_slurm", "hydra.launcher.partition=long"], return_hydra_config=True)
    launcher = cfg.hydra.launcher
    assert launcher._target_.endswith("submitit_launchers.SlurmLauncher")
    assert launcher.partition == "long" and launcher.cpus_per_task == 1
    assert list(launcher.setup) == ["export NUMBA_NUM_THREADS=1"]


def test_a_slurm_array_s_time_limit_is_its_longest_cost_estimate_with_a_margin_never_below_the_floor():
    """3× the longest job's estimate plus the cold start, at least ``timeout_min``."""
    from hydra_plugins.dsmv_launcher.submitit_launchers import COLD_START_S, COST_MARGIN, time_limit_min

    assert (COST_MARGIN, COLD_START_S) == (3.0, 150.0)
    assert time_limit_min([10.0, 20.0], 60) == 60  # short jobs: the floor
    assert time_limit_min([1230.0, 60.0], 1) == 64  # (3 · 1230 + 150) / 60, the longest job's
    assert time_limit_min([1200.0, 60.0], 1) == 63  # 62.5, rounded up


def test_the_slurm_array_asks_for_its_longest_job_s_limit(tmp_path):
    """The sbatch script dsmv_slurm submits (``sbatch`` stands in here and refuses the job): one array
    task per job, two at most at once, ``--time`` from the longest job's cost estimate."""
    from dsmv.app.runner import estimated_wall_s
    from dsmv.testing import compose_config
    from hydra_plugins.dsmv_launcher.submitit_launchers import time_limit_min

    fake = tmp_path / "bin"
    fake.mkdir()
    (fake / "sbatch").write_text(f"#!/bin/sh\ncp \"$1\" {tmp_path}/submitted.sh\necho 'no cluster here' >&2\nexit 1\n")
    (fake / "sbatch").chmod(0o755)
    (fake / "srun").write_text("#!/bin/sh\nexit 1\n")  # submitit looks for it before it submits
    (fake / "srun").chmod(0o755)
    cells_m = ("0.04", "0.005")
    env = dict(os.environ, PATH=f"{fake}:{os.environ['PATH']}", HYDRA_FULL_ERROR="0")
    proc = subprocess.run([str(BIN / "dsmv"), "-m", "hydra/launcher=dsmv_slurm", "hydra.launcher.timeout_min=1",
                           "hydra.launcher.array_parallelism=2", f"mesh.cell_size_m={','.join(cells_m)}", "tracking=disabled"],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode != 0 and "no cluster here" in proc.stdout + proc.stderr
    script = (tmp_path / "submitted.sh").read_text()
    estimates = [estimated_wall_s(compose_config("config", f"mesh.cell_size_m={h}", "tracking=disabled")) for h in cells_m]
    assert 0 < estimates[0] < estimates[1]
    expected = time_limit_min(estimates, 1)
    assert expected >= 4  # the fine job's estimate (over 40 s), not the cold start alone
    assert f"#SBATCH --time={expected}\n" in script and "#SBATCH --array=0-1%2\n" in script
    assert "#SBATCH --cpus-per-task=1\n" in script and "export NUMBA_NUM_THREADS=1" in script


def test_a_resumed_sweep_runs_only_the_jobs_not_yet_finished(run_cli, tmp_path):
    """Half a 2×2 sweep first; the whole sweep again with resume=true runs only the two missing jobs
    (four job runs in the store, not six), reuses the others' runs without starting new ones, and its
    summary lists every job with the run that holds it. Every job run carries the solver code's hash."""
    common = ["mesh=coarse", "output.plots=false"]
    first = run_cli("dsmv", "-m", "landing.mass_kg=4500", "soil.su0_pa=4000,6000", *common)
    assert first.returncode == 0, first.stderr
    again = run_cli("dsmv", "-m", "landing.mass_kg=4500,6500", "soil.su0_pa=4000,6000", *common, "resume=true")
    assert again.returncode == 0, again.stderr
    assert again.stdout.count("reused run") == 2
    runs = mlflow_runs(tmp_path)
    jobs = [r for r in runs if r.data.tags.get("dsmv.role") != "sweep"]
    assert len(jobs) == 4 and all(r.info.status == "FINISHED" for r in jobs)
    assert len({r.data.tags["dsmv.code_hash"] for r in jobs}) == 1
    assert all(r.data.tags["dsmv.identity"].endswith(r.data.tags["dsmv.code_hash"]) for r in jobs)
    import csv

    (summary,) = sorted(tmp_path.glob("runs/multirun/*/*/sweep_summary.csv"))[-1:]
    rows = list(csv.DictReader(summary.open()))
    assert len(rows) == 4 and {row["run_id"] for row in rows} == {r.info.run_id for r in jobs}
    assert sorted(row["reused"] for row in rows) == ["False", "False", "True", "True"]
    assert all("resume" not in r.info.run_name for r in jobs)
