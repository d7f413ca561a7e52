"""A body that slides and turns (``landing.free``, ``landing.horizontal_velocity_m_s``,
``landing.roll_rate_rad_s``, ``landing.cg_offset_m``) in plane strain and in 3D.

Truths: Green's (1954) exact V–H envelope of a rough strip on weightless Tresca soil, whose flat
part is sliding at H = B·su; the mirror image of a push; and a symmetric landing, which keeps its
body upright and in place whatever freedoms it is given. The strip's small-strain probes converge at
first order: the rigid corner shears the one-cell wedge of soil beside it (+2·su·h on the slide), so
the truth is compared with the answer extrapolated from B/10 and B/20.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from dsmv import registry
from dsmv.analytic.bearing import green_radial_factor
from dsmv.cel.solver2d import Cel2DSolver
from dsmv.config.scene import build_scene
from dsmv.errors import ConfigError
from dsmv.verify import canonical

#: Prandtl's strip (B = 1 m, su = 10 kPa, weightless Tresca), bonded, small strain, the whole section
STRIP = [*canonical.PRANDTL_BONDED, "solver.progress=off", "solver.remap=false", "solver.initial_travel_m=0.1"]
SU, B = 10_000.0, 1.0


def probe(compose_cfg, cell_m, direction_deg, *overrides, distance_m=0.05):
    """A displacement probe: the strip pushed ``distance_m`` along ``direction_deg`` below the horizontal
    (+x), at 0.1 m/s; its metrics."""
    angle = math.radians(direction_deg)
    motion = [f"landing.horizontal_velocity_m_s={0.1 * math.cos(angle):.12g}",
              f"landing.velocity_m_s={0.1 * math.sin(angle):.12g}", f"landing.displacement_m={distance_m}"]
    scene = build_scene(compose_cfg([*STRIP, f"mesh.cell_size_m={cell_m}", *motion, *overrides]))
    result = Cel2DSolver(scene).solve()
    assert result.status == "ok", result.message
    return result


def extrapolated_load(compose_cfg, direction_deg):
    """(h, v) = (H, V)/(B·su) at the probe's end on B/10 and B/20, extrapolated at first order."""
    loads = []
    for cell in (0.1, 0.05):
        m = probe(compose_cfg, cell, direction_deg).metrics
        loads.append(np.array([-m["end_horizontal_force_n"], m["end_force_n"]]) / (B * SU))
    return 2.0 * loads[1] - loads[0], loads


def test_a_sliding_strip_resists_with_b_su(compose_cfg):
    """Pure slide (h = 1): H = B·su exactly; the grid adds the corner wedges' 2·su·h (measured
    1.2004 and 1.1001 at B/10 and B/20; extrapolated 0.9998)."""
    (h, v), (coarse, fine) = extrapolated_load(compose_cfg, 0.0)
    assert coarse[0] == pytest.approx(1.0 + 2 * 0.1, rel=3e-3) and fine[0] == pytest.approx(1.0 + 2 * 0.05, rel=3e-3)
    assert h == pytest.approx(1.0, abs=2e-3)
    assert abs(v) < 1e-3  # a bonded strip slid sideways takes (almost) no vertical load


@pytest.mark.parametrize("direction_deg, measured", [(37.76, 0.99995), (30.0, 1.0082), (20.7, 1.0087)])
def test_inclined_probes_end_on_greens_envelope(compose_cfg, direction_deg, measured):
    """Pushed along a direction, the load ends on Green's envelope: the extrapolated point's radial
    distance from it (λ = 1 on it) within 3 % (measured ``measured``, at h = 0.49, 0.69 and 0.85)."""
    (h, v), _ = extrapolated_load(compose_cfg, direction_deg)
    assert 0.0 < h < 1.0
    assert green_radial_factor(h, v) == pytest.approx(1.0, abs=0.03)


def test_mirrored_pushes_give_mirrored_reactions(compose_cfg):
    """Pushed along +x and −x, the strip feels the mirror images: the same vertical force, the
    horizontal force and the moment of opposite signs, to round-off."""
    right = probe(compose_cfg, 0.1, 30.0, distance_m=0.02)
    left = probe(compose_cfg, 0.1, 150.0, distance_m=0.02)
    for name in ("force_n", "horizontal_force_n", "moment_n_m"):
        sign = 1.0 if name == "force_n" else -1.0
        scale = np.abs(right.history[name]).max()
        assert np.abs(left.history[name] - sign * right.history[name]).max() <= 1e-11 * scale, name


def test_a_symmetric_landing_stays_upright_bit_for_bit(compose_cfg):
    """A symmetric landing given every freedom of the plane (z, x, ry) is today's vertical one: the
    half model's symmetry plane holds the slide and the turn, and the answers are identical."""
    landing = ["solver=cel2d", "mesh=coarse", "solver.progress=off"]
    vertical = Cel2DSolver(build_scene(compose_cfg(landing))).solve()
    free = Cel2DSolver(build_scene(compose_cfg([*landing, "landing.free=[z,x,ry]"]))).solve()
    assert free.status == vertical.status == "ok"
    assert free.metrics["max_sinkage_m"] == vertical.metrics["max_sinkage_m"]
    assert np.array_equal(free.history["force_n"], vertical.history["force_n"])
    assert free.metrics["max_rotation_deg"] == 0.0 and free.metrics["max_horizontal_displacement_m"] == 0.0


@pytest.mark.parametrize("overrides, key", [
    (["landing.free=[z,z]"], "landing.free"),
    (["landing.free=[x]"], "landing.free"),  # a drop falls free in z
    (["landing=push", "landing.velocity_m_s=0"], "landing.velocity_m_s"),
    (["landing=push", "landing.velocity_m_s=0", "landing.roll_rate_rad_s=0.1"], "landing.rotation_deg"),
    (["geometry=fall_cone_30deg", "landing.cg_offset_m=[0.01,0,0]"], "landing.cg_offset_m"),  # axisymmetric
    (["landing.cg_offset_m=[0.1,0,0]", "solver.contact_separation=false", "solver.remap=true"], "solver.remap"),
    (["solver=cel3d", "landing.free=[z,x]"], "solver.remap"),  # small strain so far
    (["landing=push", "landing.lateral_velocity_m_s=0.1", "solver.remap=false"], "landing.lateral_velocity_m_s"),
    (["landing.pitch_rate_rad_s=0.1"], "landing.pitch_rate_rad_s"),  # a drop touches down without turning
])
def test_motions_the_solvers_cannot_honour_are_refused_by_key(compose_cfg, overrides, key):
    with pytest.raises(ConfigError) as refused:  # the scene's own check, then the solver's
        scene = build_scene(compose_cfg(["solver=cel2d", "solver.progress=off", *overrides]))
        registry.load("solvers", scene.solver.name, "solver.name").check_capabilities(scene)
    assert refused.value.path == key
