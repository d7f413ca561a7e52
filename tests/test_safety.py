"""The landing's safety verdict (``safety.*``): each answer against its limit, its margin, the verdict."""

from __future__ import annotations

import json

import numpy as np
import pytest

from dsmv.app.runner import SECTION_TO_TRACK_M
from dsmv.config.scene import SafetyConfig, build_scene
from dsmv.results import SolveResult
from dsmv.safety import G0_M_S2, assess, max_deceleration_g, verdict

from conftest import mlflow_runs


def test_the_deceleration_is_the_fastest_fall_of_the_downward_speed():
    """A body slowed at 3 g for 10 ms and then at 1 g: the largest deceleration between the history's
    samples is 3 g, to round-off; a body that only speeds up has 0."""
    time = np.linspace(0.0, 0.03, 31)
    speed = np.where(time <= 0.01, 1.5 - 3 * G0_M_S2 * time, 1.5 - 3 * G0_M_S2 * 0.01 - G0_M_S2 * (time - 0.01))
    assert max_deceleration_g({"time_s": time, "velocity_m_s": speed}) == pytest.approx(3.0, rel=1e-9)
    assert max_deceleration_g({"time_s": time, "velocity_m_s": 1.0 + time}) == 0.0
    assert max_deceleration_g(None) is None


def _result(status="ok", **metrics):
    return SolveResult(status, "", {"max_sinkage_m": 0.08, **metrics}, {})


def test_each_limit_gets_its_margin_and_any_one_exceeded_makes_the_landing_unsafe(compose_cfg):
    scene = build_scene(compose_cfg(["solver=analytic_dynamic", "safety.max_sinkage_m=0.1", "safety.max_tilt_deg=2",
                                     "safety.max_slide_m=0.05"]))
    result = _result(max_rotation_deg=2.5)
    assess(scene, result)
    m = result.metrics
    assert m["safety_margin_sinkage"] == pytest.approx(0.02) and m["safety_margin_tilt"] == pytest.approx(-0.5)
    assert m["safety_margin_slide"] == 0.05  # a run that gives no slide slid 0
    assert m["safe"] == 0.0 and "safety_margin_deceleration" not in m  # that limit was not set
    said = verdict(scene.safety, result)
    assert said.startswith("unsafe — ") and "tilt 2.5° > 2° (margin -0.5°)" in said and "sinkage 0.08 m ≤ 0.1 m" in said
    within = _result(max_rotation_deg=1.0)
    assess(scene, within)
    assert within.metrics["safe"] == 1.0 and verdict(scene.safety, within).startswith("safe — ")


def test_a_bearing_failure_is_unsafe_and_a_run_without_limits_or_an_answer_is_not_judged(compose_cfg):
    limited = build_scene(compose_cfg(["solver=analytic_dynamic", "safety.max_sinkage_m=0.1"]))
    failed = SolveResult("bearing_failure", "the body passes 5 B without stopping", {}, {})
    assess(limited, failed)
    assert failed.metrics["safe"] == 0.0 and verdict(limited.safety, failed).startswith("unsafe: the soil does not stop")
    for scene, result in ((build_scene(compose_cfg(["solver=analytic_dynamic"])), _result()),
                          (limited, SolveResult("unstable", "a guard tripped", {}, {}))):
        assess(scene, result)
        assert "safe" not in result.metrics and verdict(scene.safety, result) is None


def test_limits_must_be_positive_numbers(compose_cfg):
    from dsmv.errors import ConfigError

    with pytest.raises(ConfigError, match="safety.max_tilt_deg"):
        build_scene(compose_cfg(["safety.max_tilt_deg=-1"]))
    assert SafetyConfig().max_sinkage_m is None


def test_the_cross_section_is_judged_by_the_most_the_3d_track_sinks_and_the_verdict_is_logged(run_cli, tmp_path):
    """The fast model lands the track's 2D cross-section: its sinkage limit is judged against the 3D
    track's largest estimate (the section + the largest measured 3D–2D difference), the summary and
    result.json carry the verdict and margins, and MLflow the tag dsmv.safety."""
    done = run_cli("dsmv", "solver=analytic_dynamic", "safety.max_sinkage_m=0.1", "safety.max_deceleration_g=15")
    assert done.returncode == 0, done.stderr
    line = next(l for l in done.stdout.splitlines() if l.strip().startswith("safety"))
    assert "unsafe — sinkage 0.138 m (the 3D track's, at most, from the section) > 0.1 m" in line
    (run,) = mlflow_runs(tmp_path)
    assert run.data.tags["dsmv.safety"] == line.split(": ", 1)[1]
    result = json.loads(next(tmp_path.glob("runs/outputs/*/*/result.json")).read_text())
    section = result["metrics"]["max_sinkage_m"]
    assert result["metrics"]["judged_sinkage_m"] == pytest.approx(section + SECTION_TO_TRACK_M["largest"], rel=1e-12)
    assert result["metrics"]["safe"] == 0.0 and result["units"]["max_deceleration_g"] == "g"
    assert 0.0 < result["metrics"]["max_deceleration_g"] < 15.0


def test_a_sweep_tallies_its_verdicts(run_cli):
    """Each job is judged; the sweep says how many of its judged landings were unsafe, and by what (from
    the jobs' metrics in sweep_summary.csv, as strings there; a bearing failure is unsafe)."""
    from dsmv.safety import sweep_tally

    rows = [{"status": "ok", "safe": "1.0", "safety_margin_sinkage": "0.02"},
            {"status": "ok", "safe": "0.0", "safety_margin_sinkage": "-0.01", "safety_margin_deceleration": "-2"},
            {"status": "bearing_failure", "safe": "0.0"},
            {"status": "unstable"}]
    assert sweep_tally(rows) == ("2 of 3 judged landings unsafe: sinkage 1, deceleration 1, "
                                 "the soil did not stop the body 1")
    assert sweep_tally([{"status": "ok"}]) is None
    done = run_cli("dsmv", "-m", "landing.velocity_m_s=0.5,3", "solver=analytic_dynamic", "safety.max_sinkage_m=0.15",
                   "tracking=disabled")
    assert done.returncode == 0, done.stderr
    assert "dsmv: safety: 1 of 2 judged landings unsafe: sinkage 1" in done.stdout


def test_a_body_that_turns_is_judged_by_its_base_s_lowest_point(compose_cfg):
    """A tilted base sinks deeper at its edge than at its middle: the verdict judges the edge."""
    scene = build_scene(compose_cfg(["solver=analytic_dynamic", "safety.max_sinkage_m=0.1"]))
    result = _result(max_edge_sinkage_m=0.11, max_rotation_deg=2.0)
    assess(scene, result)
    assert result.metrics["judged_sinkage_m"] == 0.11 and result.metrics["safe"] == 0.0
    assert "sinkage 0.11 m (the base's lowest point) > 0.1 m" in verdict(scene.safety, result)
