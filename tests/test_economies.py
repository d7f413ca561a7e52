"""Each economy of the CEL solver leaves the result as it was (dsmv-bench times what it saves).

Truths: skipping arithmetic that multiplies by exactly 1 changes nothing (to the last few bits, where
two compiled variants of the loop may round differently); running
on after the body has come to rest cannot change the run up to that moment; the half
model with a symmetry plane is the whole section's mirror image, to the asymmetry of the
directionally split remap (tolerance 1e-3 relative).
"""

from __future__ import annotations

import numpy as np
import pytest

from dsmv.cel.solver2d import Cel2DSolver
from dsmv.config.scene import build_scene
from dsmv.errors import ConfigError

#: the default landing on Tresca soil: an inactive law is what one economy skips
BASE = ["solver=cel2d", "soil.law=tresca", "mesh=coarse", "tracking=disabled", "output.plots=false",
        "solver.progress=off"]


@pytest.fixture
def landing_result(compose_cfg):
    def _run(*overrides):
        result = Cel2DSolver(build_scene(compose_cfg([*BASE, *overrides]))).solve(None)
        assert result.status == "ok", result.message
        return result

    return _run


@pytest.fixture
def landing(landing_result):
    return lambda *overrides: landing_result(*overrides).metrics


def test_skipping_an_inactive_law_changes_nothing(landing):
    """Tresca's factor is exactly 1, so calling it changes no arithmetic. The loop that skips it is a
    second compiled variant (law=None), whose fused multiply-adds the compiler may place otherwise:
    measured 4.8e-16 (max sinkage) and 2.2e-16 (plastic work), relative — a few ulps."""
    on, off = landing(), landing("solver.economies.skip_inactive_law=false")
    assert off["max_sinkage_m"] == pytest.approx(on["max_sinkage_m"], rel=5e-15, abs=0)
    assert off["energy_plastic_j"] == pytest.approx(on["energy_plastic_j"], rel=5e-15, abs=0)


def test_stopping_at_rest_keeps_the_max_sinkage_and_time_to_rest(landing_result):
    """Running on is the same run up to rest, sample for sample. After it the body rebounds on
    the soil's elastic spring and falls back; the second fall may end a little deeper (coarse
    default landing: 0.4 %), which a landing that ends at rest does not see."""
    on, off = landing_result(), landing_result("solver.economies.stop_at_rest=false")
    at_rest = on.metrics["time_to_rest_s"]
    assert off.metrics["time_to_rest_s"] == at_rest
    before = on.history["time_s"] < at_rest
    for column in ("time_s", "sinkage_m", "velocity_m_s", "force_n"):
        assert (off.history[column][: before.sum()] == on.history[column][before]).all(), column
    # the deepest point lies after the deepest sample, by at most what the decelerating body travels
    # over one sampling interval at that sample's speed
    deepest = int(on.history["sinkage_m"].argmax())
    interval = np.diff(on.history["time_s"])[min(deepest, len(on.history["time_s"]) - 2)]
    beyond = on.metrics["max_sinkage_m"] - on.history["sinkage_m"][deepest]
    assert 0.0 <= beyond <= abs(on.history["velocity_m_s"][deepest]) * interval
    assert off.metrics["max_sinkage_m"] >= on.metrics["max_sinkage_m"]
    assert off.metrics["steps"] > 1.9 * on.metrics["steps"]  # it did run on, to twice the time at rest
    assert off.metrics["energy_error"] < 0.02


@pytest.mark.parametrize("contact", ["solver.contact_separation=false", "solver.contact_separation=auto"])
def test_the_half_model_is_the_whole_section_mirrored(landing, contact):
    """With the soil tied to the faces or free to part from them: the whole section lands as the half."""
    half = landing(contact)
    whole = landing(contact, "solver.economies.symmetry=false")
    assert whole["cells"] == 2 * half["cells"] == half["cells_whole_body"] == whole["cells_whole_body"]
    assert whole["max_sinkage_m"] == pytest.approx(half["max_sinkage_m"], rel=1e-3)
    assert whole["mass_error"] < 1e-10 and whole["energy_error"] < 0.02


def test_the_whole_section_refuses_an_axisymmetric_body(compose_cfg):
    with pytest.raises(ConfigError, match="solver.economies.symmetry"):
        build_scene(compose_cfg([*BASE, "solver.economies.symmetry=false", "geometry=fall_cone_30deg"]))


def test_skipping_void_cells_changes_nothing_but_round_off(landing):
    on, off = landing(), landing("solver.economies.skip_void=false")
    # void cells hold φ ≤ 0: at most round-off negatives left by the remap contribute
    assert off["max_sinkage_m"] == pytest.approx(on["max_sinkage_m"], rel=1e-12)
