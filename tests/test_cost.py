"""The cost model: what a run will take, estimated from measured throughputs and the fast landing
model's time to rest (dsmv.cel.cost; docs/verification/performance.md holds the estimates against runs)."""

import numpy as np
import pytest

from dsmv import registry
from dsmv.analytic.dynamic import fast_landing
from dsmv.cel import cost
from dsmv.config.tree import compose_scene
from dsmv.verify.bench_cost import EtaProbe

THROUGHPUT = cost.Throughput(
    step_overhead_s={"2d": 1e-4, "3d": 2e-4},
    soil_cell_updates_per_s={"2d": {"tresca": {"1": 4e7}, "einav_randolph": {"1": 1e7}},
                             "3d": {"tresca": {"1": 5e6, "2": 9e6}, "einav_randolph": {"1": 2e6, "2": 3.5e6}}})


def solver_of(*overrides):
    scene = compose_scene([*overrides, "tracking=disabled"])
    return registry.load("solvers", scene.solver.name, "solver.name")(scene)


def test_a_step_costs_its_overhead_and_its_soil_cells_at_the_law_s_rate():
    assert THROUGHPUT.wall_s(2, "tresca", 1, 4e4, 1000) == pytest.approx(1000 * (1e-4 + 4e4 / 4e7))
    assert THROUGHPUT.wall_s(3, "einav_randolph", 2, 1e5, 10) == pytest.approx(10 * (2e-4 + 1e5 / 3.5e6))


def test_a_law_or_thread_count_not_measured_takes_the_safe_side():
    assert THROUGHPUT.rate(2, "my_plugin_law", 1) == 1e7           # the slowest law measured
    assert THROUGHPUT.rate(3, "tresca", 8) == 9e6                   # the most threads measured
    assert THROUGHPUT.rate(2, "tresca", 2) == 4e7                   # 2D is serial: one thread's rate


def test_the_committed_throughputs_cover_both_dimensions_and_both_laws():
    measured = cost.measured()
    for dim in (2, 3):
        for law in ("tresca", "einav_randolph"):
            assert measured.rate(dim, law, 1) > 0
    # a law with state and a rate effect costs more per cell than Tresca
    assert measured.rate(2, "einav_randolph", 1) < measured.rate(2, "tresca", 1)


def test_a_landing_is_expected_to_last_the_fast_model_s_time_to_rest():
    solver = solver_of("solver=cel2d", "mesh=medium")
    rest = fast_landing(solver.scene).solve().metrics["time_to_rest_s"]
    assert solver.expected_duration_s() == rest
    assert solver_of("solver=cel2d", "solver.economies.stop_at_rest=false").expected_duration_s() == 2 * rest
    # the 3D track: the fast model with Skempton's shape factor
    three = solver_of("solver=cel3d", "mesh=coarse")
    assert three.expected_duration_s() == fast_landing(three.scene, "skempton").solve().metrics["time_to_rest_s"]


def test_the_expected_duration_is_the_cel_s_time_to_rest_within_5_percent():
    """The default landing at 0.04 m cells comes to rest after 0.0921 s; the fast model says 0.0913 s."""
    solver = solver_of("solver=cel2d", "mesh=medium", "output.plots=false", "solver.progress=off")
    result = solver.solve()
    ran = result.history["time_s"][-1]
    assert result.status == "ok" and solver.expected_duration_s() == pytest.approx(ran, rel=0.05)


def test_the_void_above_the_mudline_costs_no_soil_cells():
    """A lighter, longer track on a weaker soil gets a taller domain of void; its soil cells are the same."""
    default = solver_of("solver=cel2d").cost()
    tall = solver_of("solver=cel2d", "soil=sample_II", "landing.mass_kg=6500", "geometry.contact_length_m=5.2").cost()
    assert tall["cells"] > 2 * default["cells"] and tall["soil_cells"] == default["soil_cells"]


def test_field_output_over_50_mb_is_sized_before_the_run():
    three = solver_of("solver=cel3d", "mesh=coarse", "output.fields=true").cost()
    assert three["fields_b"] == pytest.approx(cost.FIELD_BYTES_PER_CELL[3] * three["cells"] * 41)
    assert three["fields_b"] > cost.FIELD_NOTICE_B > solver_of("solver=cel2d", "output.fields=true").cost()["fields_b"]
    assert solver_of("solver=cel3d", "mesh=coarse").cost()["fields_b"] == 0.0


@pytest.mark.parametrize("seconds, text", [(0.2, "about 1 s"), (42.4, "about 42 s"), (720.0, "about 12 min"),
                                           (12600.0, "about 3.5 h")])
def test_durations_read_as_a_person_says_them(seconds, text):
    assert cost.duration(seconds) == text


def test_the_time_left_is_paced_from_the_first_chunk_on(monkeypatch):
    """A cold start's first chunk holds the compile: the pace is taken from the chunks after it. Half
    the simulated time after 3 s of stepping past a 10 s compile: 3 s are left."""
    from dsmv.cel import controller

    clock = iter([10.0, 13.0])
    monkeypatch.setattr(controller.time, "perf_counter", lambda: next(clock))
    progress = controller.Progress(expected_s=0.1, terminal=False)
    run = type("Run", (), {"time_s": 0.02})()
    assert progress.time_left_s(run) is None
    run.time_s = 0.06
    assert progress.time_left_s(run) == pytest.approx(3.0 * 0.04 / 0.04)


def test_past_the_expected_duration_the_progress_gives_no_time_left(monkeypatch, capsys):
    """A body that turns settles later than the fast model's vertical landing rests (the vehicle rolling
    0.5° rested at 1.15 s against 0.038 s expected): past the expected time the line says the body still
    moves and gives no time left, where it read '3000 % of the expected', 'about 0:00 left'."""
    from dsmv.cel import controller

    clock = iter([10.0, 13.0, 13.0, 30.0])
    monkeypatch.setattr(controller.time, "perf_counter", lambda: next(clock))
    progress = controller.Progress(expected_s=0.1, terminal=False)
    progress.started = progress.last = 0.0
    run = type("Run", (), {"time_s": 0.02, "sinkage_m": 0.05, "body": np.zeros(45), "steps": 10})()
    assert progress.time_left_s(run) is None
    run.time_s = 3.0
    progress.after_chunk(run)
    line = capsys.readouterr().err
    assert "past the expected 0.100 s, still moving: no estimate" in line and "about" not in line


def test_the_progress_of_a_body_free_to_slide_and_turn_says_how_far_and_how_fast(monkeypatch, capsys):
    """A vehicle set down on a slope runs for seconds at one sinkage while it slides: its line gives the
    slide along the seabed (m, from the body's x and y displacement) and its speed, its tilt now and at
    most, and, beside its base's middle, its base's lowest point so far (a body touching down tilted
    starts with its middle above the mudline)."""
    from dsmv.cel import controller
    from dsmv.cel.layout import B_MAXEDGE, B_MAXROT, B_OFFSET_X, B_OFFSET_Y, B_ROT_Y, B_VX, B_VY

    monkeypatch.setattr(controller.time, "perf_counter", lambda: 20.0)
    progress = controller.Progress(expected_s=5.0, terminal=False, slides=True, turns=True)
    progress.started = progress.last = 0.0
    body = np.zeros(45)
    body[B_OFFSET_X], body[B_OFFSET_Y], body[B_VX], body[B_VY] = 0.3, 0.4, 0.06, -0.08
    body[B_MAXROT], body[B_ROT_Y], body[B_MAXEDGE] = np.radians(0.25), np.radians(-0.2), 0.0412
    run = type("Run", (), {"time_s": 1.5, "sinkage_m": 0.0848, "start_sinkage_m": 0.05, "turned_deg": 0.2,
                           "body": body, "steps": 20000})()
    progress.after_chunk(run)
    line = capsys.readouterr().err
    assert ("sinkage 0.0848 m at the base's middle, its lowest point 0.0912 m deep at most, velocity 0.000 m/s, "
            "slid 0.5000 m at 0.100 m/s, tilted 0.20° (0.25° at most), 20,000 steps") in line
    vertical = controller.Progress(expected_s=5.0, terminal=False)
    assert "slid" not in vertical.line(run) and "turned" not in vertical.line(run)


def test_the_benchmark_reads_the_progress_line_s_estimate_at_a_quarter_of_the_run():
    probe = EtaProbe(expected_s=0.1)
    probe.samples = [(1.0, 0.02, None), (3.0, 0.05, 2.5), (6.0, 0.1, 0.0)]
    assert probe.eta_left_s(0.25) == (3.0, 2.5)


def test_the_estimate_of_a_landing_that_may_turn_says_it_is_at_least(compose_cfg, capsys):
    """The duration is the fast model's vertical landing; a body free to slide or turn comes to rest later
    (the 2D landing with its centre of gravity 0.1 m off takes 7.1 times the steps, dsmv-bench --freedoms)."""
    from dsmv.cel.solver2d import Cel2DSolver
    from dsmv.config.scene import build_scene

    for free, said in (("[z]", False), ("[z,x,ry]", True)):
        scene = build_scene(compose_cfg(["mesh=coarse", "solver.progress=on", "solver.max_steps=10",
                                         f"landing.free={free}", "landing.cg_offset_m=[0.1,0,0]"]))
        Cel2DSolver(scene).solve()
        line = next(l for l in capsys.readouterr().err.splitlines() if "cells, about" in l)
        assert ("at least: a body free to slide or turn" in line) == said, line


def test_a_vehicle_that_slides_on_is_expected_to_take_its_slide_of_one_width(compose_cfg, capsys):
    """The 30 t vehicle set down on 45°, 17 % past its envelope (38.4°): the fast vehicle model slides on
    (its guard ends it after 20 B, 4.80 s), the CEL's slide guard may end the run after one width B: the
    expected duration is the fast model's time to slide B (0.89 s; the section at the grousers' tips slid a
    width on 45.25° on B/8 and was ended by the guard), and the estimate line says what it counts. On 30°
    it rests, and the expected duration is its rest."""
    from dsmv.cel.solver2d import Cel2DSolver
    from dsmv.config.scene import build_scene

    heavy = ["geometry=vehicle_pioneer_i", "soil.law=tresca", "soil.su0_pa=20000", "soil.ks_pa_per_m=0",
             "soil.youngs_modulus_pa=1e7", "landing.velocity_m_s=0.05", "landing.mass_kg=30000",
             "landing.free=[z,x,ry]", "mesh=coarse", "solver=cel2d", "solver.progress=on", "solver.max_steps=10"]
    for slope, slides in ((45, True), (30, False)):
        solver = Cel2DSolver(build_scene(compose_cfg([*heavy, f"soil.slope_deg={slope}"])))
        modelled = solver.modelled_landing  # the fast vehicle model's landing of the same scene
        slid = np.asarray(modelled.history["horizontal_displacement_m"])
        if slides:
            assert modelled.status == "bearing_failure" and slid[-1] > 10.0
            width_at = float(np.asarray(modelled.history["time_s"])[np.argmax(slid >= 0.6)])
            assert solver.expected_duration_s() == width_at < 0.25 * modelled.metrics["time_to_rest_s"]
            solver.solve()
            line = next(l for l in capsys.readouterr().err.splitlines() if "cells, about" in l)
            assert "the fast model slides on: this counts the time it takes to slide one width" in line, line
        else:
            assert modelled.status == "ok" and solver.expected_duration_s() == modelled.metrics["time_to_rest_s"]
        assert solver.fast_model_slides_on() == slides


def test_a_vehicle_free_to_rock_is_expected_to_take_the_fast_vehicle_models_rest(compose_cfg, capsys):
    """A vehicle 0.3 m heavier on one side rocks to rest long after its fall stops (cel3d: 0.64 s against
    the vertical fall's 0.04 s): its expected duration is the fast vehicle model's time to rest of the
    same scene (free to slide too where it is), and the estimate says it is a lower bound."""
    from dsmv.analytic.dynamic import fast_vehicle
    from dsmv.cel.solver2d import Cel2DSolver
    from dsmv.config.scene import build_scene

    vehicle = ["geometry=vehicle_pioneer_i", "solver=cel2d", "mesh=coarse", "landing.cg_offset_m=[0.3,0,0]"]
    rest, sliding = (fast_vehicle(build_scene(compose_cfg([*vehicle, f"landing.free={free}", "solver=analytic_dynamic_3d"])))
                     .solve().metrics["time_to_rest_s"] for free in ("[z,ry]", "[z,x,ry]"))
    durations = [Cel2DSolver(build_scene(compose_cfg([*vehicle, f"landing.free={free}"]))).expected_duration_s()
                 for free in ("[z]", "[z,ry]", "[z,x,ry]")]
    assert durations[0] < 0.5 * rest and durations[1] == rest and durations[2] == sliding
    scene = build_scene(compose_cfg([*vehicle, "landing.free=[z,ry]", "solver.progress=on", "solver.max_steps=10"]))
    Cel2DSolver(scene).solve()
    line = next(l for l in capsys.readouterr().err.splitlines() if "cells, about" in l)
    assert "at least: a vehicle rocks to rest later in the CEL than the fast vehicle model" in line, line
