"""The inverse answer of dsmv-predict checked by the CEL solver itself

A small dataset: ten CEL landings of the default scene on the coarse mesh, touchdown velocity
0.5–5 m/s. A random forest with scaled conformal intervals (dsmv-train's choices) is trained on
it and asked for the largest velocity whose 90 % upper bound stays under a 0.3 m limit. The
truth is a CEL run at that answer: its sinkage must stay under the limit. A run at 20 % more
must sink deeper, and the answer must not be so timid that a run at 50 % more still passes
(the intervals would then be useless for descent planning).
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

from dsmv.cel.solver2d import Cel2DSolver
from dsmv.config.scene import build_scene
from dsmv.surrogate.dataset import TARGET_METRIC
from dsmv.surrogate.features import LeakFreeFeatures, target
from dsmv.surrogate.intervals import ConformalRegressor, calibration_record
from dsmv.surrogate.inverse import solve_inverse
from dsmv.surrogate.model import TrainedSurrogate, scene_table
from dsmv.surrogate.predictor import Calibration, Predictor

BASE = ["solver=cel2d", "mesh=coarse", "tracking=disabled", "output.plots=false", "solver.progress=off"]
VELOCITIES_M_S = np.linspace(0.5, 5.0, 10)
LIMIT_M = 0.3


@pytest.fixture
def cel(compose_cfg):
    """velocity (m/s) → (scene, max sinkage (m)) of a CEL landing of the default scene."""

    def land(velocity_m_s: float):
        scene = build_scene(compose_cfg([*BASE, f"landing.velocity_m_s={velocity_m_s!r}"]))
        result = Cel2DSolver(scene).solve(None)
        assert result.status == "ok", result.message
        return scene, result.metrics["max_sinkage_m"]

    return land


def test_inverse_answer_holds_in_cel(cel):
    from plugins.rf import RandomForestSurrogate

    runs = [cel(float(v)) for v in VELOCITIES_M_S]
    table = scene_table([scene for scene, _ in runs])
    table[TARGET_METRIC] = [z for _, z in runs]
    assert np.all(np.diff(table[TARGET_METRIC]) > 0)  # the dataset itself: deeper with speed
    features = LeakFreeFeatures()
    make = functools.partial(RandomForestSurrogate(seed=0).make, n_estimators=100)
    conformal = ConformalRegressor(make, folds=5, confidence=0.9, method="pooled", score="scaled")
    conformal.fit(features.transform(table), target(table))
    ranges = {c: [float(table[c].min()), float(table[c].max())] for c in table.columns if table[c].notna().all()}
    model = TrainedSurrogate(conformal.estimator_, features, {"ranges": ranges})
    calibration = Calibration.from_record(calibration_record(conformal, "z_over_b"), "test")
    predictor = Predictor("test", "1", "-", model, calibration)

    answer = solve_inverse(predictor.upper(0.9), table.iloc[[0]], "landing.velocity_m_s",
                           (VELOCITIES_M_S[0], VELOCITIES_M_S[-1]), LIMIT_M)
    assert answer.status == "ok", answer
    at_answer = cel(answer.value)[1]
    faster = cel(1.2 * answer.value)[1]
    much_faster = cel(1.5 * answer.value)[1]
    print(f"answer {answer.value:.3f} m/s: CEL {at_answer:.4f} m; ×1.2 {faster:.4f} m; ×1.5 {much_faster:.4f} m")
    assert at_answer <= LIMIT_M
    assert faster > at_answer
    assert much_faster > LIMIT_M
