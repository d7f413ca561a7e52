"""One job: validate the scene, solve it, write the result contract, track it.

Nothing is lost on failure: a solver that raises still leaves result.json (status
``failed``, the error as message), the resolved config, and a FAILED MLflow run; a run stopped by
SIGINT or SIGTERM leaves result.json with status ``interrupted`` and a KILLED MLflow run. A
single run exits with its status's code (:data:`dsmv.results.EXIT_CODES`); how a sweep stops is in
:mod:`dsmv.app.interrupts`. What a job prints also goes to its log (:mod:`dsmv.app.joblog`).
"""

from __future__ import annotations

import math
import os
import shlex
import signal
import sys
import threading
import traceback
from contextlib import contextmanager, nullcontext
from pathlib import Path

from hydra.core.hydra_config import HydraConfig
from hydra.types import RunMode
from omegaconf import DictConfig, OmegaConf

from dsmv import registry, safety
from dsmv.app import interrupts, ui
from dsmv.app.joblog import job_output
from dsmv.config.scene import Scene, build_scene
from dsmv.errors import DsmvError
from dsmv.cel import fields
from dsmv.cel.contact import ContactRules
from dsmv.post.plots import FIELD_PLOT_FILE, HISTORY_PLOT_FILE, plot_field_contours, plot_history
from dsmv.results import EXIT_CODES, SolveResult, write_history, write_result
from dsmv.tracking import runs
from dsmv.tracking.run_writer import WriterError

RESOLVED_CONFIG_FILE = "config_resolved.yaml"
#: a tilted base meets the soil about a cell early (docs/decisions/0030): how much shallower the track's section
#: rolled 8° (cel2d, Tresca, free to sink, slide and roll) read its base's deepest point with its drop across so
#: many core cells than on 0.00375 m cells (22 across; itself still 6 % deeper than on 0.0075 m)
EARLY_TOUCH_SHALLOW = ((1.4, 0.35), (2.8, 0.21), (5.6, 0.13), (11.1, 0.06))


#: the track's side view landing (cel2d, geometry.view=longitudinal, default scene) on 0.01 m cells: its
#: grousers' envelope bearing from its tips' first touch, and its grousers drawn as blades 0.01 m thick
#: cutting in from the mudline (m; decision 0045)
ENVELOPE_FROM_TIPS_M, BLADES_DRAWN_M = 0.0707, 0.116


def attitude_note(drop_m: float, cell_m: float, envelope: bool = False) -> str:
    """The summary's line on a tilted touchdown: its drop across the base in core cells, and what the staircase
    makes of it (a level drawing under one cell; else an early touch, with the measured shallowness nearest
    to this many cells); for a track whose grousers are the soil they trap (``envelope``), that the envelope
    bears from their tips wherever its plates are still above the mudline, on any mesh."""
    cells = drop_m / cell_m
    note = f"its base drops {drop_m:.3g} m across at touchdown, {cells:.2g} core cells"
    if cells < 1.0:
        note += ": under one cell, the staircase draws it level (finer mesh.cell_size_m shows the tilt)"
    else:
        measured, shallow = min(EARLY_TOUCH_SHALLOW, key=lambda point: abs(math.log(point[0] / cells)))
        note += (f"; its high side meets the soil about a cell early, so its deepest point reads shallow (the "
                 f"track's section rolled 8° read {100 * shallow:.0f} % shallow at {measured:g} cells across; finer "
                 f"mesh.cell_size_m shows more)")
    if envelope:
        note += (f"; and its grousers' envelope bears from their tips where its plates are still above the mudline, "
                 f"on any mesh, where the blades would cut in: shallow again (the side view landing so read "
                 f"{ENVELOPE_FROM_TIPS_M:g} m, its grousers drawn {BLADES_DRAWN_M:g} m; the fast vehicle model's "
                 f"patches bear from their plates)")
    return note


def pin_numba_threads(n: int) -> None:
    """Limit Numba to ``n`` threads: two threads per job on two cores collapse in parallel sweeps."""
    os.environ["NUMBA_NUM_THREADS"] = str(n)
    if "numba" in sys.modules:
        import numba

        numba.set_num_threads(min(n, numba.config.NUMBA_NUM_THREADS))


def fail_user_error(error: DsmvError, program: str = "dsmv") -> None:
    """Report a user mistake in one line on stderr and exit with status 2."""
    print(f"{program}: error: {error}", file=sys.stderr)
    sys.exit(2)


def estimated_wall_s(cfg: DictConfig) -> float:
    """What a job's solve is estimated to take (s; :meth:`dsmv.cel.solver.CelSolver.cost`), 0 for a
    solver without a cost estimate or a scene that will fail (the job itself says why)."""
    try:
        scene = build_scene(cfg)
    except DsmvError:
        return 0.0
    solver = registry.load("solvers", scene.solver.name, "solver.name")(scene)
    return float(solver.cost()["wall_s"]) if hasattr(solver, "cost") else 0.0


def run_job(cfg: DictConfig) -> dict:
    """Run the scene of one Hydra job; return result.json's content.

    What the job prints also goes to its log (dsmv.app.joblog); a job of a sweep takes SIGINT and SIGTERM
    as dsmv.app.interrupts describes."""
    hydra_cfg = HydraConfig.get()
    run_dir = Path(hydra_cfg.runtime.output_dir)
    multirun = hydra_cfg.mode == RunMode.MULTIRUN
    launcher = str(hydra_cfg.launcher.get("_target_", "")) if multirun else ""
    if "joblib" in launcher:  # jobs share the machine's cores
        pin_numba_threads(1)
    elif "submitit" in launcher:  # a job owns the cpus its task (dsmv_local: its worker) was given
        pin_numba_threads(int(hydra_cfg.launcher.get("cpus_per_task") or 1))
    elif "ray" in launcher.lower():  # a Ray task holds the cpus it asked for: one unless ray.remote says more
        remote = hydra_cfg.launcher.get("ray", {}).get("remote", {}) or {}
        pin_numba_threads(int(remote.get("num_cpus") or 1))

    with job_output():
        if not multirun:
            return _run(cfg, hydra_cfg, run_dir, None, {"signal": None})
        sweep_dir = Path(hydra_cfg.sweep.dir)
        with interrupts.sweep_job_signals(sweep_dir) as caught:
            return _run(cfg, hydra_cfg, run_dir, sweep_dir, caught)


def _run(cfg: DictConfig, hydra_cfg, run_dir: Path, sweep_dir: Path | None, caught: dict) -> dict:
    multirun = sweep_dir is not None
    names = str(cfg.get("solver", {}).get("name")), str(cfg.get("soil", {}).get("law"))
    if multirun and (reason := interrupts.interrupted(sweep_dir)):
        result = SolveResult("interrupted", f"not started: the sweep was interrupted ({reason})")
        write_result(run_dir, result, *names, "")
        print(f"[{run_dir.name}] interrupted: {result.message}{runs.sweep_progress(run_dir.parent, run_dir.name)}")
        return {"status": result.status, "metrics": {}}
    try:
        scene = build_scene(cfg)
        if multirun and cfg.get("resume") and (earlier := runs.finished_run(cfg, scene)) is not None:
            return _reuse(earlier, scene, run_dir, names)
        try:
            tracker = runs.start_job(cfg, scene, run_dir, runs.run_name(scene, hydra_cfg.overrides.task), sweep_dir)
        except WriterError as error:  # the writer cannot be reached: the run answers into result.json alone
            print(f"dsmv: warning: no MLflow run ({error}); result.json in {run_dir} will hold the answer",
                  file=sys.stderr)
            tracker = None
    except DsmvError as error:
        if not multirun:  # (dsmv.app.command_line.check_command_line refuses most before Hydra makes the run dir)
            print(f"dsmv: error: {error}", file=sys.stderr)
            remove_unstarted_run_dir(run_dir, hydra_cfg, str(cfg.get("paths", {}).get("runs_dir", run_dir.parent)))
            sys.exit(2)
        # in a sweep, one wrong job is recorded and counted; the others still run
        print(f"dsmv: error: {error}", file=sys.stderr)
        write_result(run_dir, SolveResult("failed", str(error)), *names, "")
        runs.job_done(run_dir.parent, run_dir.name)
        return {"status": "failed", "metrics": {}}

    error_text, end_status = None, "FAILED"
    try:
        # a sweep's job only raises a flag on a signal (dsmv.app.interrupts); a single run stops where it is
        with interrupts_as_keyboard_interrupt() if not multirun else nullcontext():
            (run_dir / RESOLVED_CONFIG_FILE).write_text(OmegaConf.to_yaml(cfg, resolve=True))
            try:
                if caught["signal"] is not None:
                    raise KeyboardInterrupt
                solver = registry.load("solvers", scene.solver.name, "solver.name")(scene)
                result = solver.solve(run_dir)
            except DsmvError as error:
                result, error_text = SolveResult("failed", str(error)), str(error)
            except KeyboardInterrupt:  # outside the CEL controller, which stops a run itself
                by = f" by {signal.Signals(caught['signal']).name}" if caught["signal"] is not None else ""
                result = SolveResult("interrupted", f"interrupted{by} before the solver finished")
            except Exception as error:  # a bug: keep everything, report it, exit non-zero below
                result = SolveResult("failed", f"{type(error).__name__}: {error}")
                error_text = traceback.format_exc()
            safety.assess(scene, result, track_sinkage_bound(scene, result))
            files = write_outputs(scene, result, run_dir)
            if tracker is not None:
                judged = safety.verdict(scene.safety, result)
                try:
                    tracker.finish(result, files, error_text, note=f"{result.status}: {_answer(scene, result)}",
                                   tags={"dsmv.safety": judged} if judged else None)
                except WriterError as error:  # the answer is on disk; the store's failure is said, not fatal
                    print(f"dsmv: warning: the MLflow run was not written ({error}); result.json in {run_dir} "
                          f"holds the answer", file=sys.stderr)
                    tracker.terminate("FAILED")  # as far as the store lets it
                    tracker = None  # the summary names no run
            end_status = None
    except KeyboardInterrupt:  # a second signal while the outputs were being written
        end_status = "KILLED"
        print(f"dsmv: interrupted while writing {run_dir}", file=sys.stderr)
        sys.exit(EXIT_CODES["interrupted"])
    finally:
        if tracker is not None and end_status is not None:  # never leave a run RUNNING
            tracker.terminate(end_status)

    if multirun and result.status == "interrupted":
        interrupts.mark(sweep_dir, f"job {run_dir.name} {result.message}")
    if result.status == "interrupted" and not multirun:
        print(f"dsmv: {result.message}; result.json written in {run_dir}", file=sys.stderr)
    else:
        print_summary(scene, result, run_dir, tracker, multirun, list(hydra_cfg.overrides.task))
    if error_text is not None and not multirun:
        print(f"dsmv: the run failed: {result.message}", file=sys.stderr)
    if not multirun and EXIT_CODES[result.status] != 0:
        sys.exit(EXIT_CODES[result.status])
    return {"status": result.status, "metrics": result.metrics}


def _reuse(run, scene: Scene, run_dir: Path, names: tuple[str, str]) -> dict:
    """``resume=true``: the job's identity already has a finished run with an answer. Start no run; write
    its result.json from that run (its status, metrics, and a message naming it) and note its id."""
    metrics = {k: v for k, v in run.data.metrics.items() if not k.startswith("history.")}
    status, message = run.data.tags["dsmv.status"], run.data.tags.get("dsmv.message", "")
    result = SolveResult(status, f"reused run {run.info.run_id} (resume=true): {message}", metrics)
    write_result(run_dir, result, *names, scene.config_hash)
    runs.record_job_run(run_dir, run.info.run_id, reused=True)
    print(f"[{run_dir.name}] {status}: reused run {run.info.run_id}{runs.sweep_progress(run_dir.parent, run_dir.name)}")
    return {"status": status, "metrics": metrics}


#: what Hydra writes into a job's dir before the job starts
HYDRA_JOB_FILES = {"config.yaml", "hydra.yaml", "overrides.yaml"}


def remove_unstarted_run_dir(run_dir: Path, hydra_cfg, runs_dir: str | Path) -> bool:
    """Remove the dir Hydra made for a run refused before it started, if it holds only what Hydra put
    there (``.hydra/`` with its three files, the job's log): a refused run leaves nothing behind. Empty
    parents (``outputs/<day>``) go too, up to the runs dir (which stays). Anything else in it: the dir stays."""
    subdir = hydra_cfg.output_subdir
    log_name = f"{hydra_cfg.job.name}.log"
    try:
        entries = {p.name: p for p in run_dir.iterdir()}
        hydra_dir = run_dir / str(subdir) if subdir else None
        if set(entries) - {log_name, str(subdir)}:
            return False
        if hydra_dir is not None and hydra_dir.exists():
            if not hydra_dir.is_dir() or hydra_dir.is_symlink():
                return False
            if any(not p.is_file() or p.name not in HYDRA_JOB_FILES for p in hydra_dir.iterdir()):
                return False
        if log_name in entries and not entries[log_name].is_file():
            return False
        _close_log_handlers(run_dir)
        for p in (list(hydra_dir.iterdir()) if hydra_dir is not None and hydra_dir.exists() else ()):
            p.unlink()
        if hydra_dir is not None and hydra_dir.exists():
            hydra_dir.rmdir()
        if log_name in entries:
            entries[log_name].unlink()
        run_dir.rmdir()
    except OSError:
        return False
    stop = Path(runs_dir).resolve()
    parent = run_dir.resolve().parent
    while stop in parent.parents:  # strictly inside the runs dir, which stays
        try:
            parent.rmdir()  # only when empty
        except OSError:
            break
        parent = parent.parent
    return True


def _close_log_handlers(run_dir: Path) -> None:
    """Close and detach the root logger's file handlers writing into ``run_dir``."""
    import logging

    root = logging.getLogger()
    for handler in list(root.handlers):
        if isinstance(handler, logging.FileHandler) and Path(handler.baseFilename).parent == run_dir.resolve():
            root.removeHandler(handler)
            handler.close()


@contextmanager
def interrupts_as_keyboard_interrupt():
    """SIGTERM (a timeout, a cancelled job) ends the job as Ctrl-C does, through the same path that
    writes result.json and closes the MLflow run; the CEL controller catches both while it steps."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def write_outputs(scene: Scene, result: SolveResult, run_dir: Path) -> list[Path]:
    """result.json, the history CSV and its plot, the fields and their contours, the resolved config: the files of a job."""
    files = [write_result(run_dir, result, scene.solver.name, scene.soil.law, scene.config_hash)]
    if result.history is not None:
        files.append(write_history(run_dir, result.history))
        if scene.output.plots and len(result.history["time_s"]) > 1:
            title = f"{scene.label} — {scene.solver.name}: {result.status}"
            files.append(plot_history(result.history, run_dir / HISTORY_PLOT_FILE, title))
    if scene.output.fields:  # written by a solver that keeps fields (CEL); the others write none
        field_files = fields.written_files(run_dir)
        files += field_files
        if field_files and scene.output.plots:
            title = f"{scene.soil.name} ({scene.soil.law}), {scene.geometry.name} — {result.status}"
            files.extend(plot_field_contours(run_dir / fields.MAX_SINKAGE_FRAME, run_dir / FIELD_PLOT_FILE, title,
                                             fields.penetration_frame(run_dir, result.history)))
    files.append(run_dir / RESOLVED_CONFIG_FILE)
    return files


def _answer(scene: Scene, result: SolveResult) -> str:
    """What the run found, in one phrase: a landing's max sinkage; a push's depth and its bearing
    factors q/su at the sampled depths (the nc_* metrics; T-bar: the deep factor)."""
    sinkage = result.metrics.get("max_sinkage_m")
    if result.status != "ok" or sinkage is None:  # only an 'ok' run has an answer: say what happened
        return result.message
    motion = _motion(result.metrics, scene.landing)
    if scene.landing.kind != "push":
        plates = result.metrics.get("plate_sinkage_m", sinkage)
        section = " of the 2D cross-section" if is_cross_section(scene) else ""
        where = f" at the grouser tips, {plates:.4f} m at the plates{section}" if plates != sinkage else section
        if scene.geometry.vehicle:  # the middle of its base: each track's own, when it tilts, follows
            where = (where + ", each track" if "max_sinkage_left_track_m" not in result.metrics
                     else " (the base's middle)" + where)
        if "max_sinkage_error_m" in result.metrics:  # solver.error_estimate: the mesh's share of doubt
            return (f"max sinkage {sinkage:.4f} m{where}; extrapolated {result.metrics['max_sinkage_extrapolated_m']:.4f} m "
                    f"± {result.metrics['max_sinkage_error_m']:.4f} m (mesh){motion}")
        return f"max sinkage {sinkage:.4f} m{where}{motion}"
    factors = [f"{result.metrics[name]:.3f} at {label}" for name, label in
               (("nc_at_0p02B", "0.02 B"), ("nc_at_0p05B", "0.05 B"), ("nc_at_0p1B", "0.1 B"),
                ("nc_at_1B", "1 B"), ("nc_deep", "depth (nc_deep)")) if name in result.metrics]
    cycles = sorted((int(name.rpartition("_")[2]), value) for name, value in result.metrics.items()
                    if name.startswith("nc_cycle_"))
    if cycles:  # a cyclic push: each cycle's penetration at mid-stroke
        factors.append("cycles " + ", ".join(f"{value:.3f}" for _, value in cycles) + " at mid-stroke")
    if "end_vertical_factor" in result.metrics:  # a probe along or about another axis: its end load
        m = result.metrics
        factors = [f"V/(A·su) {m['end_vertical_factor']:.3f}, H/(A·su) {m['end_horizontal_factor']:.3f}, "
                   f"M/(A·B·su) {m['end_moment_factor']:.3f} at the end"]
        return f"pushed to {sinkage:.4f} m{motion}; " + factors[0]
    return f"pushed to {sinkage:.4f} m" + (f"; q/su {', '.join(factors)}" if factors else "")


def _motion(metrics: dict, landing) -> str:
    """A body that may slide or turn: how far it did, in words (only the motions it has)."""
    if "max_rotation_deg" not in metrics:
        return ""
    moves = {n for n in ("x", "y", "rx", "ry", "rz") if n in landing.freedoms or landing.given_velocity(n)}
    words = []
    if moves & {"rx", "ry", "rz"}:
        words.append(f"turned {metrics['max_rotation_deg']:.2f}° at most")
    if moves & {"x", "y"}:
        words.append(f"slid {metrics['max_horizontal_displacement_m']:.4f} m at most")
    if moves & {"rx", "ry", "rz"}:
        words.append(f"its base's lowest point {metrics['max_edge_sinkage_m']:.4f} m deep at most")
    if "max_sinkage_left_track_m" in metrics:  # a vehicle that may tilt: each track's own, its deepest point
        deepest = [max(metrics.get(f"max_sinkage_{side}_track{end}_m", -math.inf) for end in ("", "_front", "_rear"))
                   for side in ("left", "right")]
        words.append("its tracks {:.4f} m (−x) and {:.4f} m (+x) deep at most".format(*deepest))
    return "".join(f", {w}" for w in words)


#: the 3D track's max sinkage (grouser tips, cel3d's default mesh) less the 2D cross-section's (cel2d's),
#: over the 22 landings of docs/verification/track-3d.md ("The section and the track": the default,
#: Tresca, and the levels of the study's eight parameters), with 0.05 m grousers: median, least and
#: largest (m). The two differ by about the grouser height, not by a factor (1.03-5.2 over the same landings)
SECTION_TO_TRACK_M = {"grouser_height_m": 0.05, "median": 0.0514, "least": 0.0067, "largest": 0.0682}


def is_cross_section(scene: Scene) -> bool:
    """A track's 2D cross-section (no grousers, no ends): what cel2d and the fast models land by default."""
    body = scene.geometry
    if body.kind != "track" or getattr(body, "view", "cross_section") != "cross_section":
        return False
    flat_section = (getattr(scene.solver, "shape_factor", None) == "plane_strain" and not getattr(scene.solver, "grousers", False)
                    and not body.vehicle)  # the fast models land a vehicle as cel3d does
    return scene.solver.name in ("cel2d", "cel2d_check") or flat_section


def section_at_grouser_tips(scene: Scene) -> bool:
    """A cross-section of the track cel3d lands (``geometry.section_base=grouser_tips``), not the study's."""
    return is_cross_section(scene) and getattr(scene.geometry, "section_base", "plates") == "grouser_tips"


def holds_trapped_soil(scene: Scene) -> bool:
    """A CEL track drawn as its grousers' envelope, whose trapped soil holds under contact separation."""
    body = scene.geometry
    return (body.kind == "track" and getattr(body, "grousers", None) == "trapped_soil" and body.grouser_height_m > 0
            and scene.solver.name in ("cel2d", "cel3d") and (not is_cross_section(scene) or section_at_grouser_tips(scene)))


def track_sinkage_bound(scene: Scene, result: SolveResult) -> float | None:
    """For a 2D cross-section's landing with the grousers the difference was measured with: the most the
    3D track sinks by it (the section + the largest measured difference, m); None for anything else."""
    sinkage = result.metrics.get("max_sinkage_m")
    if (sinkage is None or scene.landing.kind == "push" or not is_cross_section(scene) or scene.soil.slope_deg
            or section_at_grouser_tips(scene) or scene.geometry.grouser_height_m != SECTION_TO_TRACK_M["grouser_height_m"]):
        return None
    return sinkage + SECTION_TO_TRACK_M["largest"]


def track_estimate(scene: Scene, result: SolveResult, overrides: list[str] = ()) -> str | None:
    """For a 2D cross-section's landing: the 3D track's max sinkage it implies, with its measured spread,
    and the command that computes it; None for anything else."""
    sinkage = result.metrics.get("max_sinkage_m")
    if result.status != "ok" or sinkage is None or scene.landing.kind == "push" or not is_cross_section(scene):
        return None
    # quoted as a shell reads it: a table's braces and brackets would expand
    kept = [o for o in overrides if not o.split("=")[0].lstrip("+~").startswith(("solver", "mesh", "geometry.section_base"))]
    command = shlex.join(["dsmv", "solver=cel3d", *kept])
    offset = SECTION_TO_TRACK_M
    if section_at_grouser_tips(scene):
        return ("not estimated for the section at the grousers' tips (the 3D–2D difference is measured on the "
                f"study's section, on its plates); the 3D answer: {command}")
    if scene.soil.slope_deg:
        return f"not estimated on a sloping seabed (the 3D–2D difference is measured on level ones); the 3D answer: {command}"
    if scene.geometry.grouser_height_m != offset["grouser_height_m"]:
        return (f"not estimated for {scene.geometry.grouser_height_m:g} m grousers (measured with "
                f"{offset['grouser_height_m']:g} m); the 3D answer: {command}")
    return (f"about {sinkage + offset['median']:.3f} m at the grouser tips ({sinkage + offset['least']:.3f}–"
            f"{sinkage + offset['largest']:.3f} m: the section + the 3D–2D difference measured over 22 landings); "
            f"the 3D answer: {command}")


#: the reference study's 3D track model at 0.04 m core cells: 1,248,912 Eulerian elements (Zeng et al.
#: 2025, Table 2, case 3)
REFERENCE_TRACK_ELEMENTS = 1_248_912


def print_summary(scene: Scene, result: SolveResult, run_dir: Path, tracker, multirun: bool,
                  overrides: list[str] = ()) -> None:
    """A short human summary: status, what the run found (with units), where outputs and MLflow are."""
    what = _answer(scene, result)
    if multirun:
        print(f"[{run_dir.name}] {result.status}: {what}{runs.sweep_progress(run_dir.parent, run_dir.name)}")
        return
    print(f"\ndsmv: {result.status} — {what}")
    print(f"  scene   : {scene.label}, solver {scene.solver.name}")
    assumed = registry.load("soil_laws", scene.soil.law, "soil.law")(scene.soil).assumptions()
    if scene.geometry.vehicle:  # the study gives no vehicle
        assumed = [*assumed, f"geometry.gauge_m = {scene.geometry.gauge_m:g} m"]
        landing = scene.landing
        if {"rx", "ry", "rz"} & set(landing.freedoms):  # a vehicle that may turn: its mass's layout
            assumed.append(f"landing.cg_offset_m = {list(landing.cg_offset_m)} m (its height above the base included)")
            if landing.rotational_inertia_kg_m2 is None:
                assumed.append("landing.rotational_inertia_kg_m2 = a uniform box of the vehicle's span, length and "
                               "sprocket height")
    if assumed:
        print(f"  assumed : {', '.join(assumed)} (provisional: no published source)")
    print(f"  message : {result.message}")
    if (judged := safety.verdict(scene.safety, result)) is not None:
        print(f"  safety  : {judged}")
    if (estimate := track_estimate(scene, result, overrides)) is not None:
        print(f"  3D track: {estimate}")
    m = result.metrics
    if "cells" in m and "cell_updates_per_s" in m:  # a CEL run: its grid and what it cost
        whole, notes = m.get("cells_whole_body", m["cells"]), []
        if whole != m["cells"]:
            notes.append(f"{whole:,.0f} for the whole {'section' if scene.solver.name == 'cel2d' else 'body'}")
            if scene.geometry.kind == "track" and scene.solver.name == "cel3d" and not scene.geometry.vehicle:
                notes.append(f"the reference study's track: {REFERENCE_TRACK_ELEMENTS / 1e6:.2f} M elements")
        extent = f" ({'; '.join(notes)})" if notes else ""
        print(f"  model   : {m['cells']:,.0f} cells{extent}, {m['steps']:,.0f} steps, {m['wall_s']:.1f} s, "
              f"{m['cell_updates_per_s'] / 1e6:.2f} M cell-updates/s")
        if scene.landing.moves_beyond_vertical:  # which symmetry economy the scene allowed
            print("  symmetry: " + ("the model keeps the mid-planes the landing is symmetric about; the slide and "
                                    "turn across them stay 0" if whole != m["cells"] else
                                    "none: the landing " + ("or the seabed's slope " if scene.soil.slope_deg else "")
                                    + "is not symmetric about the body's mid-planes, the whole body is modelled"))
        if "attitude_drop_m" in m:  # a tilted touchdown: whether its staircase shows the tilt
            print("  attitude: " + attitude_note(m["attitude_drop_m"], m["core_cell_size_m"], holds_trapped_soil(scene)))
        if "redraws" in m:  # a body redrawn as it turned: whether its soil may part from it
            parts = ContactRules.of(scene, False, draws_turns=True).separation
            def step_deg(span_m):  # one core cell across a span, as an angle
                return math.degrees(math.atan(m["core_cell_size_m"] / span_m))

            steps = f"across its span in steps of about {step_deg(2.0 * scene.geometry.half_span_m):.2g}°"
            if scene.solver.name == "cel3d":
                steps += f" and along its length of {step_deg(scene.geometry.contact_length_m):.2g}°"
            print(f"  turn    : redrawn into the grid {m['redraws']:.0f} times as it turned, a rough staircase of "
                  f"cells that draws a tilt {steps} (one cell), " + (
                "whose soil lets go where it pulls away (contact separation)" + (
                    ", but for the soil its grousers trap, which holds" if holds_trapped_soil(scene) else "") if parts else
                "tied to its soil (solver.contact_separation=false: the soil holds it in tension)"))
    print(f"  outputs : {run_dir}")
    if tracker is not None:
        uri = tracker.uri
        print(f"  MLflow  : {uri}  (experiment {runs.experiment_name(scene.study)}, run {tracker.run_id})")
        if uri.startswith("http"):
            print(f"  browse  : {uri}")
        else:
            print(f"  browse  : {ui.command_for(overrides)}")
