"""Every option of every config group runs, or is refused when it is composed, in one line.

In the spirit of lightning-hydra-template's tests/test_sweeps.py: each option is composed with
quick settings (coarse mesh, no tracking, no plots, no progress bar, pushes shortened to
SHORT_PUSH_M) and either

(a) runs, in this process, to a result whose status is one of the documented physics outcomes
    (``failed`` is what the runner records when the code raised, so it does not count), or
(b) is refused by :func:`dsmv.config.scene.build_scene` with a one-line :class:`~dsmv.errors.ConfigError`,
    exactly what the CLI prints before it exits with status 2.

The body groups (geometry × landing × solver) are run as a full product; soil and mesh options
one at a time around the default scene; tracking options are composed and validated (runs use
tracking=disabled). Each experiment is a sweep (hydra.mode: MULTIRUN): the first job of its
sweep (the first value of every swept parameter, the first case) is composed through Hydra's
compose API and run here, with the experiment's own CEL mesh and push replaced by quick ones;
under ``-m slow`` each first job runs as written (its own mesh and push: about 2 minutes, most of
it verify_tbar and verify_prandtl), and so does the fine mesh. The surrogate group belongs to
dsmv-train (tests/test_surrogate.py).
"""

from __future__ import annotations

import re

import itertools
import subprocess

import pytest
from omegaconf import OmegaConf

from dsmv import registry
from dsmv.config.scene import build_scene, build_tracking
from dsmv.errors import ConfigError
from dsmv.results import STATUSES
from tests.conftest import BIN, group_options

#: what a run may end with; 'failed' means the code raised
OUTCOMES = set(STATUSES) - {"failed"}
QUICK = ["tracking=disabled", "output.plots=false"]
SHORT_PUSH_M = 0.05
PLATES = ("rectangular_plate", "circular_plate")
#: a 3D body's quick core cells: a quarter of its width (B = 1 m), a few thousand cells
QUICK_3D_CELL_M = 0.25


def _compose(compose_cfg, overrides, quick_mesh=True, short_push=True):
    """The config of ``overrides`` with the quick settings that apply to its solver and landing."""
    overrides = [*overrides, *QUICK]
    cfg = compose_cfg(overrides)
    extra = []
    if cfg.solver.name in ("cel2d", "cel3d"):
        extra.append("solver.progress=off")
        if quick_mesh:  # mesh=coarse's, also over an experiment's own
            extra.append(f"mesh.cell_size_m={0.08 if cfg.solver.name == 'cel2d' else QUICK_3D_CELL_M}")
    if short_push and cfg.landing.kind == "push":
        extra.append(f"landing.displacement_m={min(SHORT_PUSH_M, cfg.landing.displacement_m)}")
    return compose_cfg(overrides + extra) if extra else cfg


def run_or_refuse(cfg):
    """('refused', message) at composition, else ('ran', result)."""
    try:
        scene = build_scene(cfg)
    except ConfigError as error:
        message = str(error)
        assert "\n" not in message and message.startswith(f"{error.path} = "), message
        return "refused", message
    result = registry.load("solvers", scene.solver.name, "solver.name")(scene).solve()
    assert result.status in OUTCOMES, f"{result.status}: {result.message}"
    return "ran", result


# ---------------------------------------------------------------------------- the scene's groups

#: a track alone, and two as a vehicle (the 2D section and the fast models land one of its tracks)
TRACKS = ("track_pioneer_i", "vehicle_pioneer_i")
BODIES = list(itertools.product(group_options("geometry"), group_options("landing"), group_options("solver")))


def refused_key(geometry: str, landing: str, solver: str) -> str | None:
    """The key a combination is refused on, None for one that runs."""
    if geometry == "fall_cone_30deg" and landing == "push":
        return "landing.velocity_m_s"  # the fall cone is released from rest: a push needs a speed
    if solver == "analytic_energy" and geometry in ("tbar", "fall_cone_30deg"):
        return "geometry.kind"  # the energy method models tracks, strips and plates
    fast_model = solver in ("analytic_dynamic", "analytic_dynamic_3d")  # the section's and the 3D track's
    if fast_model and geometry not in (*TRACKS, "strip"):
        return "geometry.kind"  # the fast landing model was measured on tracks and strips
    if fast_model and landing == "push":
        return "landing.kind"  # it lands bodies; a push is the energy method's
    if solver == "cel2d" and geometry == "rectangular_plate":
        return "geometry.kind"  # a rectangle is a 3D body (a circle is axisymmetric in 2D)
    if solver == "cel3d" and geometry not in ("strip", *TRACKS, *PLATES):
        return "geometry.kind"  # the 3D solver runs strips (as slabs), plates and the track
    return None


@pytest.mark.parametrize("geometry,landing,solver", BODIES, ids=["-".join(c) for c in BODIES])
def test_every_body_landing_and_solver(compose_cfg, geometry, landing, solver):
    """A T-bar's free landing (geometry=tbar, landing=drop) runs in cel2d: the energy estimate that
    sizes its domain takes a T-bar."""
    outcome, what = run_or_refuse(_compose(compose_cfg, [f"geometry={geometry}", f"landing={landing}",
                                                         f"solver={solver}", "mesh=coarse"]))
    key = refused_key(geometry, landing, solver)
    if key is None:
        assert outcome == "ran", what
    else:
        assert outcome == "refused" and what.startswith(f"{key} = "), what


@pytest.mark.parametrize("soil", group_options("soil"))
def test_every_soil(compose_cfg, soil):
    outcome, what = run_or_refuse(_compose(compose_cfg, [f"soil={soil}", "mesh=coarse"]))
    assert outcome == "ran", what


MESHES = [pytest.param(m, marks=[pytest.mark.slow] if m == "fine" else []) for m in group_options("mesh")]


@pytest.mark.parametrize("mesh", MESHES)
def test_every_mesh(compose_cfg, mesh):
    outcome, what = run_or_refuse(_compose(compose_cfg, [f"mesh={mesh}"], quick_mesh=False))
    assert outcome == "ran", what
    assert what.metrics["core_cell_size_m"] <= build_scene(compose_cfg([f"mesh={mesh}"])).mesh.cell_size_m


@pytest.mark.parametrize("tracking", group_options("tracking"))
def test_every_tracking_option_validates(compose_cfg, tracking):
    cfg = compose_cfg([f"tracking={tracking}"])
    assert build_tracking(cfg).enabled == (tracking != "disabled")
    build_scene(cfg)


def test_a_refused_combination_is_one_line_and_exit_2(tmp_path):
    proc = subprocess.run([str(BIN / "dsmv"), "solver=analytic_energy", "geometry=tbar", "tracking=disabled"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [
        "dsmv: error: geometry.kind = 'tbar': the energy method models tracks, strips and plates; use solver=cel2d for "
        "this body"
    ]


# ---------------------------------------------------------------------------- experiments


def first_value(values) -> str:
    """A swept parameter's first value: of a list ``a,b,c`` the first, of Optuna's ``interval(lo, hi)`` lo."""
    text = str(values)
    interval = re.match(r"\s*interval\(\s*([^,]+),", text)
    return interval.group(1).strip() if interval else text.split(",")[0]


def first_job(compose_cfg, experiment: str) -> list[str]:
    """The overrides of the first job of an experiment's sweep: each swept parameter's first value, the first case."""
    from hydra_plugins.dsmv_sweeper.case_sweeper import load_function, one_at_a_time

    sweeper = compose_cfg([f"experiment={experiment}"], return_hydra_config=True).hydra.sweeper
    sweeper = OmegaConf.to_container(sweeper)
    job = [f"{key}={first_value(values)}" for key, values in (sweeper.get("params") or {}).items()]
    cases = one_at_a_time(sweeper["vary"]) if sweeper.get("vary") else []
    cases += sweeper.get("cases") or []
    if not cases and sweeper.get("cases_from"):
        cases = load_function(sweeper["cases_from"])(compose_cfg([f"experiment={experiment}"]))
    return [f"experiment={experiment}", *job, *(cases[0] if cases else [])]


EXPERIMENTS = group_options("experiment")


@pytest.mark.parametrize("experiment", EXPERIMENTS)
def test_every_experiment_s_first_job(compose_cfg, experiment):
    cfg = _compose(compose_cfg, first_job(compose_cfg, experiment))
    outcome, what = run_or_refuse(cfg)
    assert outcome == "ran", what
    assert build_scene(cfg).study == experiment


@pytest.mark.slow
@pytest.mark.parametrize("experiment", EXPERIMENTS)
def test_every_experiment_s_first_job_as_written(compose_cfg, experiment):
    cfg = _compose(compose_cfg, first_job(compose_cfg, experiment), quick_mesh=False, short_push=False)
    outcome, what = run_or_refuse(cfg)
    assert outcome == "ran", what
