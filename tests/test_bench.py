"""dsmv-bench's bookkeeping (the timings themselves are benchmark output, never asserted here)."""

from __future__ import annotations

import math

import pytest

from dsmv.verify.bench import Row, cost_exponent, pareto_front


def _row(wall, error, cells=100.0, steps=10.0):
    return Row("landing", f"{wall}/{error}", [], error=error, wall_s=wall, cells=cells, steps=steps)


def test_pareto_front_keeps_only_settings_nothing_beats_on_both_counts():
    rows = [_row(1, 0.10), _row(2, 0.05), _row(3, 0.08), _row(4, 0.01), _row(0.5, 0.20), _row(5, math.nan)]
    front = pareto_front(rows)
    assert [(r.wall_s, r.error) for r in front] == [(0.5, 0.20), (1, 0.10), (2, 0.05), (4, 0.01)]


def test_cost_exponent_is_one_for_cost_linear_in_cells_times_steps():
    rows = [_row(2e-7 * c * s, 0.0, c, s) for c, s in ((1e3, 1e3), (4e3, 2e3), (1.6e4, 4e3))]
    assert cost_exponent(rows) == pytest.approx(1.0, abs=1e-9)
    quadratic = [_row((c * s) ** 2, 0.0, c, s) for c, s in ((1e3, 1e3), (4e3, 2e3))]
    assert cost_exponent(quadratic) == pytest.approx(2.0, abs=1e-9)


def test_the_reference_landing_is_recomputed_when_the_solver_changes(tmp_path, monkeypatch):
    from dsmv.verify import bench

    runs = []

    def fake_solve(overrides, repeats, run_dir=None):
        runs.append(overrides)
        return {"max_sinkage_m": 0.1 + 0.01 * len(runs), "wall_s": 1.0}, "ok", [1.0]

    monkeypatch.setattr(bench, "solve", fake_solve)
    monkeypatch.setattr(bench, "solver_fingerprint", lambda overrides: "version-a")
    first = bench.landing_reference(bench.QUICK, tmp_path)
    assert bench.landing_reference(bench.QUICK, tmp_path) == first and len(runs) == 3  # cached (h, 2h, 4h)
    monkeypatch.setattr(bench, "solver_fingerprint", lambda overrides: "version-b")
    assert bench.landing_reference(bench.QUICK, tmp_path) != first and len(runs) == 6  # stale: run again


def test_the_reference_landing_is_the_extrapolated_answer(tmp_path, monkeypatch):
    """A sinkage exactly first order in h, z = 0.2 − 0.5·h, extrapolates to its limit 0.2 m: the
    Pareto front measures error against the answer at zero cell size, not against one finer mesh."""
    from dsmv.verify import bench

    def first_order(overrides, repeats, run_dir=None):
        h = float(next(o for o in overrides if o.startswith("mesh.cell_size_m=")).split("=")[1])
        return {"max_sinkage_m": 0.2 - 0.5 * h, "wall_s": 1.0}, "ok", [1.0]

    monkeypatch.setattr(bench, "solve", first_order)
    monkeypatch.setattr(bench, "solver_fingerprint", lambda overrides: "version-a")
    assert bench.landing_reference(bench.FULL, tmp_path) == pytest.approx(0.2, abs=1e-12)


def test_the_vehicle_bench_measures_each_mesh_against_the_extrapolated_sinkage(tmp_path, monkeypatch):
    """dsmv-bench --vehicle's table: a sinkage exactly second order in h, z = 0.08 + 2·h², extrapolates to
    0.08 m, and each mesh's error is against that, with the wall time against two minutes and the verdict
    of the run's own limits."""
    from dsmv import safety
    from dsmv.config.tree import compose_scene
    from dsmv.results import SolveResult
    from dsmv.verify import bench_vehicle

    def second_order(cell_m, run_dir):
        scene = compose_scene([*bench_vehicle.SCENE, f"mesh.cell_size_m={cell_m}"])
        result = SolveResult("ok", "", {"max_sinkage_m": 0.08 + 2.0 * cell_m**2, "cells": 1e4 / cell_m,
                                        "steps": 10.0 / cell_m, "wall_s": 6.0})
        safety.assess(scene, result)
        return scene, result

    monkeypatch.setattr(bench_vehicle, "land", second_order)
    answer = bench_vehicle.main(tmp_path)
    assert answer["extrapolated_m"] == pytest.approx(0.08, abs=1e-12)
    table = (tmp_path / "bench_vehicle.md").read_text()
    assert "| 0.075 m | 133,333 | 133 | 6.0 | 0.09125 | +14.06 % | 0.05 | safe — sinkage 0.0912 m ≤ 0.15 m" in table
    assert "wall / 120 s = 0.050, |error| / 2 % = 7.031" in table


def test_a_benchmark_runs_on_the_threads_it_asks_for_unless_the_user_set_them():
    """dsmv is imported (and with it Numba) before a benchmark asks for its threads: the pool runs them
    anyway, and the variable reaches its child processes; a NUMBA_NUM_THREADS the user set wins."""
    import os
    import subprocess
    import sys

    code = ("import dsmv.verify.bench, numba, os; from dsmv.verify.threads import threads_unless_set; "
            "print(threads_unless_set(1), numba.get_num_threads(), os.environ['NUMBA_NUM_THREADS'])")
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_NUM_THREADS"}
    unset = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert unset.stdout.split() == ["1", "1", "1"], unset.stderr
    given = subprocess.run([sys.executable, "-c", code], env={**env, "NUMBA_NUM_THREADS": "2"}, capture_output=True,
                           text=True, timeout=120)
    assert given.stdout.split()[2] == "2" and given.stdout.split()[0] == given.stdout.split()[1], given.stderr
