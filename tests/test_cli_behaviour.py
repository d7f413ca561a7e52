"""The real ``dsmv`` command as a user meets it: exit codes per status, and interrupts.

SIGTERM (a timeout, a cancelled job) and SIGINT (Ctrl-C) stop a CEL run within seconds: result.json
says ``interrupted``, the MLflow run is closed KILLED with the reason, one line is printed and no
traceback, and the exit code is the documented one (dsmv.results.EXIT_CODES).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from dsmv.results import EXIT_CODES, RESULT_FILE

BIN = Path(sys.executable).parent
QUICK = ["solver=cel2d", "mesh=coarse", "output.plots=false", "solver.progress=off"]


def dsmv(tmp_path, *overrides, tracking="disabled"):
    env = dict(os.environ, NUMBA_NUM_THREADS="1", HYDRA_FULL_ERROR="0")
    run_dir = tmp_path / "run"
    proc = subprocess.run([str(BIN / "dsmv"), *QUICK, f"tracking={tracking}", *overrides, f"hydra.run.dir={run_dir}",
                           f"paths.runs_dir={tmp_path / 'runs'}"], cwd=tmp_path, env=env, capture_output=True,
                          text=True, timeout=600)
    result = json.loads((run_dir / RESULT_FILE).read_text()) if (run_dir / RESULT_FILE).exists() else None
    return proc, result


def test_a_store_that_cannot_be_written_is_a_warning_and_the_answer_is_kept(tmp_path):
    """The MLflow store fails (here its path runs through a file): the run still answers, exit 0, its
    result.json complete, and says in one line that its MLflow run was not written."""
    (tmp_path / "afile").write_text("")
    proc, result = dsmv(tmp_path, f"tracking.uri=sqlite:///{tmp_path / 'afile' / 'mlflow.db'}", tracking="local")
    assert proc.returncode == 0 and result["status"] == "ok" and result["metrics"]["max_sinkage_m"] > 0.0
    assert "warning: the MLflow run was not written (FileExistsError" in proc.stderr


@pytest.mark.parametrize("overrides, status", [
    ((), "ok"),
    (("solver.cfl=1.0",), "unstable"),
    (("solver.initial_travel_m=0.03",), "out_of_domain"),
    (("soil.su0_pa=2000", "soil.ks_pa_per_m=0", "landing.mass_kg=10500"), "bearing_failure"),
])
def test_the_exit_code_tells_the_status(tmp_path, overrides, status):
    proc, result = dsmv(tmp_path, *overrides)
    assert result["status"] == status, result["message"]
    assert proc.returncode == EXIT_CODES[status], proc.stderr
    assert "Traceback" not in proc.stderr


def test_a_config_error_exits_2_in_one_line(tmp_path):
    proc, result = dsmv(tmp_path, "landing.mass_kg=-1")
    assert proc.returncode == 2 and result is None
    assert len(proc.stderr.strip().splitlines()) == 1 and "landing.mass_kg" in proc.stderr


def _store_status(runs_dir: Path) -> str:
    from mlflow.tracking import MlflowClient

    client = MlflowClient(f"sqlite:///{runs_dir / 'mlflow.db'}")
    runs = [r for e in client.search_experiments() for r in client.search_runs([e.experiment_id])]
    assert len(runs) == 1
    return runs[0].info.status, runs[0].data.tags.get("dsmv.status")


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_a_signal_stops_the_run_and_keeps_its_record(tmp_path, sig):
    """A fine mesh keeps the run busy for minutes; the signal comes once it steps (its log says so)."""
    env = dict(os.environ, NUMBA_NUM_THREADS="1")
    run_dir, runs = tmp_path / "run", tmp_path / "runs"
    proc = subprocess.Popen([str(BIN / "dsmv"), "solver=cel2d", "mesh.cell_size_m=0.005", "output.plots=false",
                             "solver.progress=on", "tracking=local", f"paths.runs_dir={runs}",
                             f"hydra.run.dir={run_dir}"], cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 300
    while time.time() < deadline and not (run_dir / "config_resolved.yaml").exists():
        time.sleep(0.2)
    time.sleep(3.0)  # compiled or loaded from the cache, stepping
    proc.send_signal(sig)
    sent = time.time()
    out, err = proc.communicate(timeout=60)
    # stopped at the next look between compiled slices (POLL_S) and wrapped up, not run on to the
    # end (about 90 s): under 5 s on an idle machine, 6.2 s with both cores busy; the bound only tells
    # the two apart, it times nothing
    assert time.time() - sent < 30.0
    assert proc.returncode == EXIT_CODES["interrupted"], err
    assert "Traceback" not in err + out
    result = json.loads((run_dir / RESULT_FILE).read_text())
    assert result["status"] == "interrupted" and signal.Signals(sig).name in result["message"]
    assert [line for line in err.splitlines() if line.startswith("dsmv:")] == [
        f"dsmv: {result['message']}; result.json written in {run_dir}"]
    assert _store_status(runs) == ("KILLED", "interrupted")


def test_the_cost_guard_refuses_a_run_of_hours_at_once(tmp_path):
    """0.5 mm cells: 4.6 million cells × 290 000 steps. Refused before any state is allocated."""
    started = time.time()
    proc, result = dsmv(tmp_path, "mesh.cell_size_m=0.0005")
    assert time.time() - started < 5.0 + 3.0  # + the interpreter's and Hydra's start-up
    assert proc.returncode == 2 and result is None
    assert len(proc.stderr.strip().splitlines()) == 1 and "solver.max_wall_s" in proc.stderr


def test_the_estimate_is_kept_beside_the_wall_time(tmp_path):
    proc, result = dsmv(tmp_path)
    assert result["status"] == "ok" and result["units"]["estimated_wall_s"] == "s"
    assert 0.0 < result["metrics"]["estimated_wall_s"] < 3600.0


def test_a_sweep_exits_with_its_worst_job():
    from dsmv.app.sweep import sweep_exit_code

    assert sweep_exit_code(["ok"] * 12 + ["bearing_failure", "failed"]) == ("12 ok, 1 bearing_failure, 1 failed", 1)
    assert sweep_exit_code(["ok", "bearing_failure"]) == ("1 ok, 1 bearing_failure", 0)  # an answer
    assert sweep_exit_code(["ok", "out_of_domain", "unstable"])[1] == EXIT_CODES["unstable"]
    assert sweep_exit_code(["ok", "interrupted", "unstable"])[1] == EXIT_CODES["interrupted"]


# --------------------------------------------------------------------------- mistakes typed on the command line


def _no_output_dirs(tmp_path: Path) -> bool:
    """Nothing a refused run could have left: neither the run dir nor anything under the runs dir."""
    return not (tmp_path / "run").exists() and not any((tmp_path / "runs").glob("*"))


TYPED_MISTAKES = [  # (override, what the one line must say)
    ("landing.mass_kg=-1", "dsmv: error: landing.mass_kg = -1: must be greater than 0"),
    ("soil=nope", "dsmv: error: soil = 'nope': not a soil option; available: ccz_box_core, nodule_field, sample_I"),
    ("landing.mass_kg=abc", "dsmv: error: landing.mass_kg = 'abc': must be a valid number"),
    ("soil.poisson_ratio=0.5", "dsmv: error: soil.poisson_ratio = 0.5: must be less than 0.5"),
    ("geometry.width_m=0", "dsmv: error: geometry.width_m = 0: must be greater than 0"),
    ("soil.su0_pa=0", "dsmv: error: soil.su0_pa = 0: must be greater than 0"),
    ("landing.mas_kg=1", "dsmv: error: landing.mas_kg = 1: no such config key; did you mean landing.mass_kg?"),
    ("+landing.mas_kg=1", "dsmv: error: landing.mas_kg = 1: no such config key; did you mean landing.mass_kg?"),
    ("mesh.cell_size_m=0.0005", "dsmv: error: solver.max_wall_s = 3600.0: "),
    ("landing.velocity_m_s=1000", "dsmv: error: landing.velocity_m_s = 1000.0: must be at most 26.7 m/s, a tenth "
                                  "of the soil's elastic wave speed c = √((K + 4G/3)/ρ) = 267 m/s"),
    ("mesh.cell_size_m=0.5", "dsmv: error: mesh.cell_size_m = 0.5: must be at most 0.3 m, half the body's width"),
    ("soil.su0_pa=4000,6000", "dsmv: error: soil.su0_pa = '4000,6000': a sweep needs -m (--multirun)"),
    ("hydra/launcher=jobib", "dsmv: error: hydra/launcher = 'jobib': not a hydra/launcher option; available: basic"),
    ("~landing.mas_kg", "dsmv: error: ~landing.mas_kg: no such config key to delete; did you mean landing.mass_kg?"),
]


@pytest.mark.parametrize("override, line", TYPED_MISTAKES, ids=[m[0] for m in TYPED_MISTAKES])
def test_a_typed_mistake_is_one_line_exit_2_and_leaves_no_dir(tmp_path, override, line):
    """Caught before Hydra composes the job or makes its dir: exactly one line on stderr, exit code 2,
    nothing on stdout, no run dir (not even .hydra/ and an empty cli.log), nothing in the runs dir."""
    proc, result = dsmv(tmp_path, override)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert proc.stderr.splitlines() == [proc.stderr.strip()] and proc.stderr.startswith(line), proc.stderr
    assert proc.stdout == "" and result is None
    assert _no_output_dirs(tmp_path), sorted(str(p) for p in tmp_path.rglob("*"))


def _unwritable_runs_dirs(tmp_path: Path) -> list[tuple[Path, str]]:
    """A runs dir under a regular file, which no one can create; and, unless we are root (who writes
    through chmod), a read-only directory (mode 0o555)."""
    (tmp_path / "afile").write_text("not a directory\n")
    cases = [(tmp_path / "afile" / "runs", f"cannot be created: {tmp_path / 'afile'} is not a directory")]
    if os.geteuid() != 0:
        read_only = tmp_path / "read_only"
        read_only.mkdir(mode=0o555)
        cases.append((read_only, "is not writable"))
    elif Path("/proc/self").is_dir():  # root writes wherever permissions allow, not where the file system refuses
        cases.append((Path("/proc/dsmv_runs"), "cannot be created in /proc: No such file or directory"))
    return cases


@pytest.mark.parametrize("tracking", ["disabled", "local"])
def test_an_unwritable_runs_dir_is_one_line_naming_paths_runs_dir(tmp_path, tracking):
    env = dict(os.environ, NUMBA_NUM_THREADS="1", HYDRA_FULL_ERROR="0")
    cases = _unwritable_runs_dirs(tmp_path)
    before = sorted(tmp_path.rglob("*"))
    for runs_dir, reason in cases:
        proc = subprocess.run([str(BIN / "dsmv"), *QUICK, f"tracking={tracking}", f"paths.runs_dir={runs_dir}"],
                              cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
        assert proc.returncode == 2, proc.stdout + proc.stderr
        assert proc.stderr.splitlines() == [f"dsmv: error: paths.runs_dir = '{runs_dir}': {reason}"], proc.stderr
        assert "Traceback" not in proc.stdout + proc.stderr
    assert sorted(tmp_path.rglob("*")) == before  # nothing made anywhere


def test_a_refused_run_leaves_no_day_dir_in_the_runs_dir(tmp_path):
    """Without hydra.run.dir, Hydra would have made runs/outputs/<day>/<time>/ with .hydra/ and cli.log."""
    env = dict(os.environ, NUMBA_NUM_THREADS="1", HYDRA_FULL_ERROR="0")
    proc = subprocess.run([str(BIN / "dsmv"), *QUICK, "tracking=local", "landing.mass_kg=-1"], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


def test_a_dir_refused_in_the_job_is_removed_only_when_hydra_alone_wrote_it(tmp_path):
    """The job's own fallback, behind the command line's checks: a refused run's dir goes when it holds
    only .hydra/ (its three files) and the job's log, with its empty parents inside the runs dir; a dir
    holding anything else stays whole."""
    from types import SimpleNamespace

    from dsmv.app.runner import remove_unstarted_run_dir

    hydra_cfg = SimpleNamespace(output_subdir=".hydra", job=SimpleNamespace(name="cli"))

    def job_dir(name: str) -> Path:
        run_dir = tmp_path / "runs" / "outputs" / "day" / name
        (run_dir / ".hydra").mkdir(parents=True)
        for file in ("config.yaml", "hydra.yaml", "overrides.yaml"):
            (run_dir / ".hydra" / file).write_text("{}\n")
        (run_dir / "cli.log").write_text("")
        return run_dir

    kept = job_dir("kept")
    (kept / "notes.txt").write_text("mine\n")
    assert not remove_unstarted_run_dir(kept, hydra_cfg, tmp_path / "runs")
    assert (kept / "notes.txt").exists() and (kept / ".hydra" / "config.yaml").exists()
    extra = job_dir("extra")
    (extra / ".hydra" / "other.yaml").write_text("{}\n")
    assert not remove_unstarted_run_dir(extra, hydra_cfg, tmp_path / "runs") and (extra / ".hydra").exists()

    gone = job_dir("gone")
    assert remove_unstarted_run_dir(gone, hydra_cfg, tmp_path / "runs")
    assert not gone.exists() and kept.exists()  # the day dir stays: it is not empty
    for path in (kept, extra):
        import shutil

        shutil.rmtree(path)
    last = job_dir("last")
    assert remove_unstarted_run_dir(last, hydra_cfg, tmp_path / "runs")
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["runs"]  # the runs dir itself stays


# --------------------------------------------------------------------------- physically meaningful values


def test_the_stress_suites_fast_scenes_stay_legal_and_the_limits_are_stated(compose_cfg):
    """10 m/s on the default soil is 0.037 c (c = 267 m/s); the table 3 design's fastest, 8 m/s on su0 = 2 kPa,
    is 0.047 c; a cone's cells are sized to its penetration, so the core-cell bound leaves it alone."""
    from dsmv.errors import ConfigError
    from dsmv.config.scene import build_scene, elastic_wave_speed_m_s

    for overrides in (["landing.velocity_m_s=10", "landing.mass_kg=10500"],
                      ["soil.law=einav_randolph", "soil.rate.eta=0.15", "landing.velocity_m_s=10"],
                      ["soil.su0_pa=2000", "landing.velocity_m_s=8"],
                      ["geometry=fall_cone_30deg", "landing.velocity_m_s=1"], ["mesh=coarse", "geometry=tbar"]):
        build_scene(compose_cfg(["solver=cel2d", "tracking=disabled", *overrides]))
    scene = build_scene(compose_cfg(["tracking=disabled"]))
    assert elastic_wave_speed_m_s(scene.soil) == pytest.approx(267.04, abs=0.01)
    with pytest.raises(ConfigError, match=r"landing.velocity_m_s = 27.0: must be at most 26.7 m/s"):
        build_scene(compose_cfg(["tracking=disabled", "landing.velocity_m_s=27"]))
    with pytest.raises(ConfigError, match=r"mesh.cell_size_m = 0.3: must be at most 0.25 m"):
        build_scene(compose_cfg(["tracking=disabled", "solver=cel2d", "geometry=tbar", "mesh.cell_size_m=0.3"]))
    # the energy method has no mesh: its cells are not judged
    build_scene(compose_cfg(["tracking=disabled", "solver=analytic_energy", "mesh.cell_size_m=0.5"]))


# --------------------------------------------------------------------------- each job's log

WARNING_SOLVER = '''
import warnings

import numpy as np
from pydantic import BaseModel, ConfigDict

from dsmv.results import SolveResult


class Config(BaseModel):
    model_config = ConfigDict(extra="allow")
    name: str


class WarningSolver:
    config_model = Config

    def __init__(self, scene):
        self.scene = scene

    def solve(self, run_dir=None):
        warnings.warn("a library grumbles", RuntimeWarning)
        t = np.linspace(0.0, 0.1, 5)
        history = {"time_s": t, "sinkage_m": t, "velocity_m_s": 1.0 - t, "force_n": 10.0 * t}
        return SolveResult("ok", "came to rest", {"max_sinkage_m": 0.1}, {"max_sinkage_m": "m"}, history)
'''


def _job_logs(root: Path) -> list[Path]:
    return sorted(root.glob("runs/**/cli.log"))


def test_a_jobs_console_and_its_library_warnings_go_to_its_log(run_cli, tmp_path, install_plugin):
    """cli.log holds what the job printed (the summary, the solver's estimate line) and the library
    warnings (matplotlib's, for an unwritable MPLCONFIGDIR; a Python warning of the solver; MLflow's
    messages); the console keeps the job's own lines and none of the libraries' ([HYDRA] or otherwise)."""
    (tmp_path / "afile").write_text("")
    install_plugin("warning_solver", WARNING_SOLVER, "dsmv.solvers", "warns", "WarningSolver")
    for overrides in ([*QUICK[:2], "solver.progress=on"], ["solver.name=warns"]):
        env_mpl = {"MPLCONFIGDIR": str(tmp_path / "afile" / "mpl")}
        proc = _run_with_env(tmp_path, env_mpl, "dsmv", *overrides, "tracking=local")
        assert proc.returncode == 0, proc.stderr
        assert "dsmv: ok — max sinkage" in proc.stdout
        console = proc.stdout + proc.stderr
        for library in ("matplotlib", "Matplotlib", "grumbles", "mlflow.store", "alembic", "[HYDRA]", "WARNING",
                        "INFO"):
            assert library not in console, console
    logs = _job_logs(tmp_path)
    assert len(logs) == 2
    cel, plugin = (log.read_text() for log in logs)
    for text in (cel, plugin):
        assert "[dsmv.stdout][INFO] - dsmv: ok — max sinkage" in text and "  outputs : " in text
        assert "[matplotlib][WARNING] - " in text and "MPLCONFIGDIR" in text
        assert "[mlflow.store.db.utils][INFO] - " in cel or "[mlflow" in plugin
    assert "[dsmv.stderr][INFO] -   825 cells, about" in cel  # the CEL estimate, printed on stderr
    assert "[py.warnings][WARNING] - " in plugin and "RuntimeWarning: a library grumbles" in plugin


def _run_with_env(tmp_path: Path, extra: dict, program: str, *args: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, NUMBA_NUM_THREADS="1", HYDRA_FULL_ERROR="0", **extra)
    return subprocess.run([str(BIN / program), *args], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=300)


@pytest.mark.parametrize("launcher", ["basic", "joblib"])
def test_each_job_of_a_sweep_logs_its_lines_and_the_sweep_its_own(tmp_path, launcher):
    (tmp_path / "afile").write_text("")
    args = ["-m", "solver=analytic_energy", "landing.velocity_m_s=1,2", "tracking=local"]
    if launcher == "joblib":
        args += ["hydra/launcher=joblib", "hydra.launcher.n_jobs=2"]
    proc = _run_with_env(tmp_path, {"MPLCONFIGDIR": str(tmp_path / "afile" / "mpl")}, "dsmv", *args)
    assert proc.returncode == 0, proc.stderr
    console = proc.stdout + proc.stderr
    assert "matplotlib" not in console and "mlflow.store" not in console and "Traceback" not in console
    assert "[0] ok: max sinkage" in proc.stdout and "[1] ok: max sinkage" in proc.stdout
    logs = _job_logs(tmp_path)
    assert [log.parent.name for log in logs] == ["0", "1"]
    for n, log in enumerate(logs):
        text = log.read_text()
        assert f"[dsmv.stdout][INFO] - [{n}] ok: max sinkage" in text
        if n == 0 or launcher == "joblib":  # matplotlib warns when imported: once per process
            assert "[matplotlib][WARNING] - " in text
        assert f"[{1 - n}] ok" not in text  # the other job's line is in its own log
    sweep_log = (logs[0].parent.parent / "sweep.log").read_text()
    assert "[mlflow.store.db.utils][INFO] - Creating initial MLflow database tables" in sweep_log
    assert "[HYDRA]" not in sweep_log and "#0 : " in sweep_log  # Hydra's launcher lines, in the sweep's log too


# --------------------------------------------------------------------------- interrupting a sweep

#: four jobs: a quick one (0.08 m cells, a fraction of a second), then three of about 14 s each (0.007 m
#: cells; at 0.01 m they took about 5 s warm, and a job started a second before the test's 4 s wait
#: could end before the signal)
SLOW_SWEEP = ["-m", "mesh.cell_size_m=0.08,0.007,0.0071,0.0072", "solver=cel2d", "mesh=coarse", "output.plots=false",
              "tracking=local"]


def _sweep_runs(tmp_path: Path):
    from mlflow.tracking import MlflowClient

    client = MlflowClient(f"sqlite:///{tmp_path / 'runs' / 'mlflow.db'}")
    runs = [r for e in client.search_experiments() for r in client.search_runs([e.experiment_id])]
    parent = [r for r in runs if r.data.tags.get("dsmv.role") == "sweep"]
    children = {r.data.params["mesh.cell_size_m"]: r for r in runs if "mlflow.parentRunId" in r.data.tags}
    return parent, children


@pytest.mark.parametrize("launcher, how", [("joblib", "SIGTERM to the sweep"), ("joblib", "Ctrl-C"),
                                           ("basic", "Ctrl-C"),
                                           pytest.param("dsmv_local", "SIGTERM to the sweep", marks=pytest.mark.server),
                                           pytest.param("dsmv_local", "Ctrl-C", marks=pytest.mark.server)])
def test_interrupting_a_sweep_keeps_finished_jobs_and_closes_every_run(tmp_path, launcher, how):
    """SIGTERM to the sweep's process alone (a scheduler, a timeout) or SIGINT to its process group (Ctrl-C
    in a terminal), once jobs are stepping: the finished job keeps its result and FINISHED run, the
    running ones end 'interrupted' (KILLED), the one not started is recorded 'interrupted' too; the
    summary counts all four, the parent run is KILLED (never left RUNNING) and the sweep exits 130.
    Two workers either way: joblib's pool, or dsmv_local's submitit workers (with the scale-out tests)."""
    args = [*SLOW_SWEEP]
    if launcher == "joblib":
        args += ["hydra/launcher=joblib", "hydra.launcher.n_jobs=2"]
    elif launcher == "dsmv_local":
        args += ["hydra/launcher=dsmv_local"]
    env = dict(os.environ, NUMBA_NUM_THREADS="1", HYDRA_FULL_ERROR="0")
    proc = subprocess.Popen([str(BIN / "dsmv"), *args], cwd=tmp_path, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    running = 2 if launcher == "basic" else 3  # job dirs that must have started (the second worker's too)
    deadline = time.time() + 300
    while time.time() < deadline and len(list(tmp_path.glob("runs/multirun/*/*/*/config_resolved.yaml"))) < running:
        time.sleep(0.2)
    time.sleep(4.0)  # compiled or loaded from the cache, stepping
    if how.startswith("SIGTERM"):
        proc.send_signal(signal.SIGTERM)
    else:
        os.killpg(proc.pid, signal.SIGINT)
    sent = time.time()
    out, err = proc.communicate(timeout=120)
    assert time.time() - sent < 30.0, "the sweep did not stop promptly"
    assert proc.returncode == EXIT_CODES["interrupted"], out + err
    assert "Traceback" not in out + err

    (sweep_dir,) = tmp_path.glob("runs/multirun/*/*")
    results = {job: json.loads((sweep_dir / job / RESULT_FILE).read_text()) for job in "0123"}
    assert results["0"]["status"] == "ok"
    started = ["1"] if launcher == "basic" else ["1", "2"]
    for job in started:
        assert results[job]["status"] == "interrupted" and results[job]["message"].startswith("interrupted by SIG")
    for job in sorted(set("123") - set(started)):
        assert results[job]["status"] == "interrupted" and results[job]["message"].startswith("not started")
    assert "1 ok, 3 interrupted" in out
    assert (sweep_dir / "sweep_summary.csv").read_text().count("\n") == 5

    parent, children = _sweep_runs(tmp_path)
    assert [p.info.status for p in parent] == ["KILLED"]
    assert children["0.08"].info.status == "FINISHED" and children["0.08"].data.tags["dsmv.status"] == "ok"
    cells = {"1": "0.007", "2": "0.0071"}
    for job in started:
        run = children[cells[job]]
        assert run.info.status == "KILLED" and run.data.tags["dsmv.status"] == "interrupted"
    assert len(children) == 1 + len(started)  # a job never started opened no MLflow run
    assert all(r.info.status != "RUNNING" for r in [*parent, *children.values()])


def test_a_progress_bar_on_a_terminal_is_logged_as_a_few_plain_lines(tmp_path):
    """stderr on a terminal (a pseudo-terminal here): the console gets tqdm's bar, redrawn in place; the
    log gets its first state and its last, as plain lines without carriage returns."""
    import fcntl
    import pty
    import struct
    import termios
    import threading

    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 120, 0, 0))  # tqdm draws nothing in 0 columns
    env = dict(os.environ, NUMBA_NUM_THREADS="1", HYDRA_FULL_ERROR="0")
    proc = subprocess.Popen([str(BIN / "dsmv"), *QUICK[:2], "output.plots=false", "solver.progress=on",
                             "tracking=disabled", f"hydra.run.dir={tmp_path / 'run'}"], cwd=tmp_path, env=env,
                            stdout=subprocess.PIPE, stderr=slave, text=True)
    os.close(slave)
    seen = bytearray()

    def read():
        while True:
            try:
                chunk = os.read(master, 4096)
            except OSError:
                return
            if not chunk:
                return
            seen.extend(chunk)

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    out, _ = proc.communicate(timeout=300)
    reader.join(timeout=10)
    os.close(master)
    assert proc.returncode == 0 and "dsmv: ok" in out
    assert b"\r  simulated" in bytes(seen)  # the bar, on the terminal
    log = (tmp_path / "run" / "cli.log").read_text()
    bars = [line for line in log.splitlines() if "[dsmv.stderr]" in line and "simulated" in line]
    assert 1 <= len(bars) <= 3 and "\r" not in log, log
    assert bars[-1].split(" - ", 1)[1].startswith("  simulated")
