"""``dsmv-bench``: run time against error, throughput, and what each economy saves — as figures.

Three parts, every timing a median of repeats and every ratio measured in the same run:

1. **Run time against error.** The Prandtl strip (q/su at s = 0.05·B against 2 + π) and the
   default landing (max sinkage against its value extrapolated from three fine meshes, computed
   once and cached in ``runs/bench/``) over core cell sizes, then one solver knob at a time around the
   default (CFL number, advection order, hourglass and bulk-viscosity coefficients). The
   Pareto front (no other setting both faster and more accurate) is drawn, and the default
   is placed on it.
2. **Throughput.** Cell-updates per second against grid size (cost should grow linearly with
   cells × steps: the fitted exponent is reported), one Numba thread against two, and the
   cold start (compile) against the warm one (cache), each in a fresh process.
3. **Skipping.** Each economy of the solver switched off and on in the same run, with the
   speed-up and the change in the result.

Writes ``bench.md`` (the tables), ``bench.csv`` (every run) and ``bench.png`` under
``--out`` (default ``runs/bench``). ``--quick`` runs a short version (coarser levels, one
repeat) in under three minutes; ``--3d`` the 3D solver's throughput, threads, cold start and
memory per cell instead (``bench_3d.md``); ``--cost`` the throughputs behind the cost estimate and
the estimates and ETAs against runs (:mod:`dsmv.verify.bench_cost`); ``--sweeps`` what tracking and the launchers cost a job
(:mod:`dsmv.verify.bench_sweeps`).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dsmv import registry
from dsmv.analytic.bearing import PRANDTL_NC
from dsmv.config.scene import OutputConfig
from dsmv.config.tree import compose_scene
from dsmv.convergence import richardson
from dsmv.verify import bench_cost, bench_sweeps, canonical, regression
from dsmv.verify.threads import threads_unless_set

#: the Prandtl case: the canonical verification scene (conf/experiment/verify_prandtl.yaml: a rough
#: strip B = 1 m on weightless Tresca soil, su 10 kPa, E = 500·su, the soil free to part from its
#: walls) as one run, pushed quasi-statically just past s = 0.05·B
PRANDTL = [*canonical.PRANDTL, "landing.displacement_m=0.065"]
#: the default landing on the CEL solver
LANDING = list(canonical.LANDING)
COMMON = ["tracking=disabled", "output.plots=false", "solver.progress=off"]
#: economies are timed on/off interleaved at least this often: their gains can be a few per cent
ECONOMY_REPEATS = 5
#: a setting is repeated until this much wall time is spent (s): a 2-minute run is timed once
REPEAT_BUDGET_S = 60.0


@dataclass
class Plan:
    """What a bench run covers; --quick shrinks it."""

    prandtl_cells_m: list[float]
    landing_cells_m: list[float]
    reference_cell_m: float
    knob_cell_m: float
    knobs: dict[str, list]
    throughput_cells_m: list[float]
    repeats: int


FULL = Plan(
    prandtl_cells_m=[0.1, 0.05, 0.025],
    landing_cells_m=[0.08, 0.06, 0.04, 0.03, 0.02],
    reference_cell_m=0.01,
    knob_cell_m=0.02,
    knobs={"solver.cfl": [0.25, 0.9], "solver.advection_order": [1], "solver.hourglass": [0.02, 0.1],
           "solver.bulk_viscosity_linear": [0.03, 0.12], "solver.bulk_viscosity_quadratic": [0.6, 2.4]},
    throughput_cells_m=[0.08, 0.06, 0.04, 0.03],
    repeats=3,
)
QUICK = Plan(
    prandtl_cells_m=[0.1, 1 / 15],
    landing_cells_m=[0.08, 0.06],
    reference_cell_m=0.04,
    knob_cell_m=0.08,
    knobs={"solver.cfl": [0.9], "solver.advection_order": [1]},
    throughput_cells_m=[0.08, 0.06, 0.04],
    repeats=1,
)


@dataclass
class Row:
    """One benchmarked setting: its result, its error and its median wall time."""

    part: str
    label: str
    overrides: list[str]
    value: float = math.nan        # the result: q/su at 0.05 B, or max sinkage (m)
    error: float = math.nan        # relative error against the exact or the reference value
    wall_s: float = math.nan       # median over repeats (s), compile excluded
    cells: float = math.nan
    steps: float = math.nan
    cell_updates_per_s: float = math.nan
    zigzag: float = math.nan       # hourglass_mode_ratio: the zig-zag share of the velocity field (-)
    status: str = ""
    extra: dict = field(default_factory=dict)


def solve(overrides: list[str], repeats: int, run_dir: Path | None = None) -> tuple[dict, str, list[float]]:
    """Run a scene up to ``repeats`` times in this process (within REPEAT_BUDGET_S); metrics of the last
    run, its status, and every run's wall time (s, compile excluded)."""
    from dsmv.cel.solver2d import Cel2DSolver

    walls, metrics, status = [], {}, ""
    while len(walls) < repeats and sum(walls) < REPEAT_BUDGET_S:  # long runs vary less: fewer repeats
        scene = compose_scene(overrides + COMMON)
        result = Cel2DSolver(scene).solve(run_dir)
        walls.append(result.metrics.get("wall_s", math.nan))
        metrics, status = result.metrics, result.status
    return metrics, status, walls


def measured(part: str, label: str, overrides: list[str], repeats: int, truth: float, metric: str,
             run_dir: Path | None = None) -> Row:
    metrics, status, walls = solve(overrides, repeats, run_dir)
    value = metrics.get(metric, math.nan)
    row = Row(part, label, overrides, value=value, error=abs(value / truth - 1), wall_s=statistics.median(walls),
              cells=metrics.get("cells", math.nan), steps=metrics.get("steps", math.nan),
              zigzag=metrics.get("hourglass_mode_ratio", math.nan), status=status)
    row.cell_updates_per_s = row.cells * max(row.steps - 1, 1) / row.wall_s
    print(f"  {part:<10} {label:<34} {metric} = {value:.5g}  error {row.error:7.2%}  wall {row.wall_s:7.2f} s  "
          f"[{status}]", flush=True)
    return row


def solver_fingerprint(overrides: list[str]) -> str:
    """What a cached result depends on: the solver's source and the scene's composed settings."""
    import hashlib

    digest = hashlib.sha256()
    for source in sorted((Path(__file__).resolve().parents[1] / "cel").glob("*.py")):
        digest.update(source.read_bytes())
    digest.update(compose_scene(overrides).config_hash.encode())
    return digest.hexdigest()[:16]


def landing_reference(plan: Plan, out: Path) -> float:
    """The default landing's max sinkage extrapolated to zero cell size (m): Richardson with the
    observed order (dsmv.convergence) from the reference mesh h and 2h, 4h; cached in ``out`` until
    the solver's code or settings change."""
    h = plan.reference_cell_m
    sizes = (h, 2 * h, 4 * h)
    fingerprint = solver_fingerprint(LANDING + [f"mesh.cell_size_m={h}"])
    cache = out / f"reference_landing_{h:g}m.json"
    if cache.exists():
        cached = json.loads(cache.read_text())
        if cached.get("fingerprint") == fingerprint and "extrapolated_m" in cached:
            return cached["extrapolated_m"]
    print(f"  reference: default landing on {', '.join(f'{s:g}' for s in sizes)} m core cells, extrapolated "
          f"(computed once per solver version)")
    sinkages = []
    for size in sizes:
        metrics, status, _ = solve(LANDING + [f"mesh.cell_size_m={size}"], 1)
        if status != "ok":
            raise SystemExit(f"dsmv-bench: the reference landing on {size:g} m cells ended '{status}'")
        sinkages.append(metrics["max_sinkage_m"])
    estimate = richardson(sizes, tuple(sinkages))
    cache.write_text(json.dumps({"extrapolated_m": estimate.extrapolated, "error_m": estimate.error,
                                 "order": estimate.order, "cell_sizes_m": sizes, "max_sinkage_m": sinkages,
                                 "fingerprint": fingerprint}) + "\n")
    return estimate.extrapolated


def pareto_front(rows: list[Row]) -> list[Row]:
    """Rows no other row beats on both wall time and error, fastest first."""
    ok = sorted((r for r in rows if math.isfinite(r.error) and math.isfinite(r.wall_s)), key=lambda r: (r.wall_s, r.error))
    front, best = [], math.inf
    for row in ok:
        if row.error < best:
            front.append(row)
            best = row.error
    return front


def cost_exponent(rows: list[Row]) -> float:
    """Slope of log(wall) against log(cells × steps): 1 when cost grows linearly with the work."""
    work = np.log([r.cells * r.steps for r in rows])
    wall = np.log([r.wall_s for r in rows])
    return float(np.polyfit(work, wall, 1)[0]) if len(rows) > 1 else math.nan


def in_subprocess(overrides: list[str], env: dict) -> dict:
    """Run one scene through the CLI in a fresh process; its result.json metrics."""
    with tempfile.TemporaryDirectory() as scratch:
        command = [str(Path(sys.executable).parent / "dsmv"), *overrides, *COMMON, f"hydra.run.dir={scratch}/run"]
        done = subprocess.run(command, env={**os.environ, **env}, capture_output=True, text=True, cwd=scratch)
        if done.returncode != 0:
            raise SystemExit(f"dsmv-bench: a subprocess run failed:\n{done.stderr[-2000:]}")
        return json.loads((Path(scratch) / "run" / "result.json").read_text())["metrics"]


def economies(plan: Plan) -> list[dict]:
    """Each economy off and on in the same run: speed-up (off/on wall time) and result change."""
    cell = [f"mesh.cell_size_m={plan.knob_cell_m}"]
    cases = [
        ("no softening or rate arithmetic for Tresca", LANDING + cell, ["solver.economies.skip_inactive_law=false"]),
        ("stop when the body has come to rest", LANDING + cell, ["solver.economies.stop_at_rest=false"]),
        # off: a domain sized for the largest sinkage of Table 3's design (about 1 m) instead of this scene's
        ("domain sized from the analytic estimate", LANDING + cell, ["solver.initial_travel_m=1.0"]),
        ("void cells skipped (no force arithmetic)", LANDING + cell, ["solver.economies.skip_void=false"]),
        ("symmetry plane on the body's axis (half model)", LANDING + cell, ["solver.economies.symmetry=false"]),
        # off: the remap every step, though the soil moves about 1 % of a cell per step
        ("remap once soil has moved 0.05 of a cell", LANDING + cell, ["solver.remap_courant=0"]),
    ]
    if "fields" in OutputConfig.model_fields:
        cases.append(("no field output unless asked", LANDING + cell, ["output.fields=true"]))
    rows = []
    repeats = max(plan.repeats, ECONOMY_REPEATS)
    for name, base, switch_off in cases:
        on_walls, off_walls = [], []
        with tempfile.TemporaryDirectory() as scratch:
            for _ in range(repeats):  # interleaved, so that a load change hits both alike
                on_metrics, _, wall = solve(base, 1, Path(scratch))
                on_walls += wall
                off_metrics, _, wall = solve(base + switch_off, 1, Path(scratch))
                off_walls += wall
        on, off = statistics.median(on_walls), statistics.median(off_walls)
        change = abs(off_metrics["max_sinkage_m"] / on_metrics["max_sinkage_m"] - 1)
        rows.append({"economy": name, "switch_off": " ".join(switch_off), "wall_on_s": on, "wall_off_s": off,
                     "speed_up": off / on, "result_change": change})
        print(f"  economy    {name:<44} speed-up {off / on:5.2f}x  result change {change:.2e}", flush=True)
    for name, why in (("far-field cells at rest skipped", "not implemented: waves reach every cell of a landing"),):
        rows.append({"economy": name, "switch_off": why, "wall_on_s": math.nan, "wall_off_s": math.nan,
                     "speed_up": math.nan, "result_change": math.nan})
    return rows


#: the figure #3 asks for: the Prandtl push at B/20, cold and warm, on the 2-core machine
THROUGHPUT_CASE = PRANDTL + ["mesh.cell_size_m=0.05"]


def threads_and_compile(plan: Plan) -> dict:
    """The Prandtl push at B/20, each run in a fresh process: a cold start (empty compile cache),
    a warm one, and a warm one on 2 Numba threads. Wall times (s) exclude the compile, which
    is reported apart, as is the kernels' cache load on a warm start."""
    figures = {}
    with tempfile.TemporaryDirectory() as cache:
        cold = in_subprocess(THROUGHPUT_CASE, {"NUMBA_CACHE_DIR": cache, "NUMBA_NUM_THREADS": "1"})
        warm = in_subprocess(THROUGHPUT_CASE, {"NUMBA_CACHE_DIR": cache, "NUMBA_NUM_THREADS": "1"})
        two = in_subprocess(THROUGHPUT_CASE, {"NUMBA_CACHE_DIR": cache, "NUMBA_NUM_THREADS": "2"})
    figures["compile_cold_s"], figures["compile_warm_s"] = cold["compile_s"], warm["compile_s"]
    figures["wall_cold_s"], figures["wall_1_thread_s"] = cold["wall_s"], warm["wall_s"]
    figures["wall_2_threads_s"] = two["wall_s"]
    figures["cell_updates_1_thread"] = warm["cell_updates_per_s"]
    figures["cell_updates_2_threads"] = two["cell_updates_per_s"]
    figures["speed_up_2_threads"] = warm["wall_s"] / two["wall_s"]
    print(f"  Prandtl B/20: cold start {cold['compile_s']:.2f} s compile + {cold['wall_s']:.2f} s, warm "
          f"{warm['compile_s']:.2f} s cache load + {warm['wall_s']:.2f} s "
          f"({warm['cell_updates_per_s'] / 1e6:.1f} M cell-updates/s); 2 threads {two['wall_s']:.2f} s "
          f"({figures['speed_up_2_threads']:.2f}x of 1)", flush=True)
    return figures


#: the 3D throughput cases: the rough square plate (quarter model) with the remap, pushed 0.02 B, on
#: B/10 cells (28,800) and B/20 (137,853, above the 100,000 where two threads are asked to pay off)
SOLID_CASE = ["geometry=rectangular_plate", "landing=push", "soil.law=tresca", "soil.su0_pa=10000",
              "soil.ks_pa_per_m=0", "soil.youngs_modulus_pa=5e6", "landing.gravity_m_s2=0",
              "landing.velocity_m_s=0.1", "landing.displacement_m=0.02"]
SOLID_CELLS_M = (0.1, 0.05)
#: the 2D run and each 3D case on one and two threads run in turn this many times (medians): on a
#: shared machine one run alone varied by a third, and with three repeats the two-thread speed-up of
#: 132,651 cells read 1.80×, 1.65× and 1.55× in three benchmarks within two hours (five: 1.41×)
SOLID_REPEATS = 5


def state_bytes_per_cell(overrides: list[str]) -> tuple[float, float]:
    """The bytes per cell a solver's state holds (every array of its containers, nodes and contact
    included), and what its cost estimate assumes."""
    scene = compose_scene(overrides)
    solver = registry.load("solvers", scene.solver.name, "solver.name")(scene)
    state = solver.initial_state()
    arrays = [a for part in (state.mesh, state.cells, state.faces, state.nodes, state.contact, state.inflow)
              for a in part if isinstance(a, np.ndarray)]
    return sum(a.nbytes for a in arrays) / state.cells.phi.size, solver.bytes_per_cell


def solid_throughput(out: Path) -> dict:
    """The 3D solver's figures, each run in a fresh process: cold and warm start, cell-updates per
    second on one and two threads, the cost of a 3D cell-update against a 2D one (the Prandtl push
    at B/20, one thread, same run), and the memory per cell (the state's arrays over its cells,
    against what the cost estimate assumes). Writes ``bench_3d.md``."""
    figures, rows = {}, []
    with tempfile.TemporaryDirectory() as cache:
        one = {"NUMBA_CACHE_DIR": cache, "NUMBA_NUM_THREADS": "1"}
        two = {"NUMBA_CACHE_DIR": cache, "NUMBA_NUM_THREADS": "2"}
        cases = [SOLID_CASE + [f"mesh.cell_size_m={h}"] for h in SOLID_CELLS_M]
        cold = in_subprocess(cases[0], one)
        planes, runs = [], {n: ([], []) for n in range(len(cases))}
        # 2D, then each 3D case on one thread and on two, in turn, SOLID_REPEATS times: a slow spell of
        # the machine touches every side, and each speed-up is a pair run back to back
        for _ in range(SOLID_REPEATS):
            planes.append(in_subprocess(THROUGHPUT_CASE, one)["cell_updates_per_s"])
            for n, case in enumerate(cases):
                runs[n][0].append(in_subprocess(case, one))
                runs[n][1].append(in_subprocess(case, two))
        for n in range(len(cases)):
            ones, twos = runs[n]
            warm, pair = (sorted(side, key=lambda m: m["wall_s"])[len(side) // 2] for side in (ones, twos))
            rows.append({"cells": warm["cells"], "steps": warm["steps"], "wall_1": warm["wall_s"],
                         "wall_2": pair["wall_s"], "rate_1": warm["cell_updates_per_s"],
                         "rate_2": pair["cell_updates_per_s"],
                         "speed_up": statistics.median(a["wall_s"] / b["wall_s"] for a, b in zip(ones, twos)),
                         "same": all(a["nc_at_0p02B"] == b["nc_at_0p02B"] for a, b in zip(ones, twos)),
                         "nc": warm["nc_at_0p02B"], "nc_2": pair["nc_at_0p02B"]})
    plane_rate = statistics.median(planes)
    figures["compile_cold_s"], figures["wall_cold_s"] = cold["compile_s"], cold["wall_s"]
    figures["cost_vs_2d"] = plane_rate / rows[0]["rate_1"]
    figures["speed_up_2_threads"] = {int(r["cells"]): r["speed_up"] for r in rows}
    figures["bytes_per_cell"], assumed = state_bytes_per_cell(SOLID_CASE + [f"mesh.cell_size_m={SOLID_CELLS_M[-1]}"])
    lines = ["# dsmv-bench: the 3D solver", "",
             "The rough square plate (quarter model) pushed 0.02 B with the remap, each run in a fresh process; "
             f"medians of {SOLID_REPEATS} runs on one thread and on two, run in turn; the speed-up is the median "
             "of the pairs' ratios.", "",
             "| cells | steps | 1 thread (s) | M cell-updates/s | 2 threads (s) | M cell-updates/s | speed-up | "
             "q/su at 0.02 B, 1 and 2 threads |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        same = "equal" if r["same"] else f"{r['nc']:.9g} / {r['nc_2']:.9g}"
        lines.append(f"| {r['cells']:,.0f} | {r['steps']:,.0f} | {r['wall_1']:.2f} | {r['rate_1'] / 1e6:.2f} | "
                     f"{r['wall_2']:.2f} | {r['rate_2'] / 1e6:.2f} | {r['speed_up']:.2f}× | {same} |")
    lines += ["", f"- cold start: **{figures['compile_cold_s']:.1f} s** compile + {figures['wall_cold_s']:.2f} s "
                  f"({rows[0]['cells']:,.0f} cells)",
              f"- a 3D cell-update costs **{figures['cost_vs_2d']:.2f}×** a 2D one (the Prandtl push at B/20, "
              f"{plane_rate / 1e6:.1f} M cell-updates/s, one thread; medians of {SOLID_REPEATS} runs of each, "
              f"alternating, this run)",
              f"- memory per cell: **{figures['bytes_per_cell']:,.0f} B** in the state's arrays "
              f"({rows[-1]['cells']:,.0f} cells; the cost estimate assumes {assumed:,.0f} B)"]
    (out / "bench_3d.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines), flush=True)
    return figures


def write_outputs(out: Path, rows: list[Row], economy_rows: list[dict], figures: dict, plan: Plan,
                  landing_ref: float) -> None:
    with (out / "bench.csv").open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["part", "label", "value", "error", "wall_s", "cells", "steps", "cell_updates_per_s",
                         "hourglass_mode_ratio", "status", "overrides"])
        for r in rows:
            writer.writerow([r.part, r.label, r.value, r.error, r.wall_s, r.cells, r.steps, r.cell_updates_per_s,
                             r.zigzag, r.status, " ".join(r.overrides)])
    lines = [f"# dsmv-bench ({'quick' if plan.repeats == 1 else 'full'}, medians of {plan.repeats} repeat(s))", ""]
    for part, what in (("prandtl", f"Prandtl: q/su at s = 0.05·B against 2 + π = {PRANDTL_NC:.4f}"),
                       ("landing", f"Default landing: max sinkage against its value extrapolated from "
                                   f"{plan.reference_cell_m:g}, {2 * plan.reference_cell_m:g} and "
                                   f"{4 * plan.reference_cell_m:g} m cells ({landing_ref:.4f} m)"),
                       ("knob", f"One knob at a time around the default ({plan.knob_cell_m:g} m cells), same reference")):
        part_rows = [r for r in rows if r.part == part]
        front = {id(r) for r in pareto_front([r for r in rows if r.part in ("landing", "knob")] if part != "prandtl"
                                             else part_rows)}
        lines += [f"## {what}", "",
                  "| setting | result | error | wall (s) | cells | steps | M cell-updates/s | zig-zag | Pareto |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for r in part_rows:
            lines.append(f"| {r.label} | {r.value:.5g} | {r.error:.2%} | {r.wall_s:.2f} | {r.cells:.0f} | {r.steps:.0f} "
                         f"| {r.cell_updates_per_s / 1e6:.2f} | {r.zigzag:.3f} | {'yes' if id(r) in front else ''} |")
        lines.append("")
    sizes = [r for r in rows if r.part == "landing"]
    lines += ["## Throughput", "",
              f"- cost against work (cells × steps), fitted exponent over the landing meshes: "
              f"**{figures['cost_exponent']:.2f}** (1 = linear)",
              f"- Prandtl push at B/20 on the 2-core machine, each in a fresh process: cold start "
              f"**{figures['compile_cold_s']:.2f} s** compile + {figures['wall_cold_s']:.2f} s; warm start "
              f"{figures['compile_warm_s']:.2f} s cache load + **{figures['wall_1_thread_s']:.2f} s** "
              f"(**{figures['cell_updates_1_thread'] / 1e6:.1f} M** cell-updates/s, one Numba thread); "
              f"2 Numba threads {figures['wall_2_threads_s']:.2f} s "
              f"({figures['cell_updates_2_threads'] / 1e6:.1f} M/s, {figures['speed_up_2_threads']:.2f}× of one: "
              f"the kernels are serial)",
              "- cell-updates per second by mesh: " + ", ".join(
                  f"{r.label} {r.cell_updates_per_s / 1e6:.2f} M/s" for r in sizes), "",
              "## Skipping", "", "| economy | switched off by | speed-up (off/on) | result change |", "|---|---|---|---|"]
    for e in economy_rows:
        speed = f"{e['speed_up']:.2f}×" if math.isfinite(e["speed_up"]) else "—"
        change = f"{e['result_change']:.1e}" if math.isfinite(e["result_change"]) else "—"
        lines.append(f"| {e['economy']} | {e['switch_off']} | {speed} | {change} |")
    (out / "bench.md").write_text("\n".join(lines) + "\n")
    plot(out / "bench.png", rows, figures)


def plot(path: Path, rows: list[Row], figures: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (prandtl_ax, landing_ax, rate_ax) = plt.subplots(1, 3, figsize=(15, 4.5), constrained_layout=True)
    for ax, parts, title in ((prandtl_ax, ("prandtl",), "Prandtl: q/su at 0.05·B against 2 + π"),
                             (landing_ax, ("landing", "knob"), "default landing against its extrapolated value")):
        chosen = [r for r in rows if r.part in parts]
        for r in chosen:
            marker = "o" if r.part != "knob" else "s"
            ax.plot(r.wall_s, 100 * r.error, marker, color="tab:blue" if r.part != "knob" else "tab:orange")
            ax.annotate(r.label, (r.wall_s, 100 * r.error), fontsize=7, xytext=(3, 3), textcoords="offset points")
        front = pareto_front(chosen)
        ax.plot([r.wall_s for r in front], [100 * r.error for r in front], "k--", lw=1, label="Pareto front")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel("relative error (%)")
        ax.set_title(title, fontsize=9)
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3, which="both")
    sizes = [r for r in rows if r.part in ("landing", "throughput")]
    rate_ax.plot([r.cells for r in sizes], [r.cell_updates_per_s / 1e6 for r in sizes], "o-")
    rate_ax.set_xscale("log")
    rate_ax.set_xlabel("cells")
    rate_ax.set_ylabel("M cell-updates / s (1 thread)")
    rate_ax.set_title(f"throughput; cost exponent {figures['cost_exponent']:.2f}", fontsize=9)
    rate_ax.grid(alpha=0.3, which="both")
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="dsmv-bench", description="Run time against error, throughput and "
                                     "skipping of the CEL solver, as tables and a plot under --out.")
    parser.add_argument("--quick", action="store_true", help="a short version (under three minutes)")
    parser.add_argument("--out", default="runs/bench", help="output folder (default runs/bench)")
    parser.add_argument("--regression", metavar="FILE", help="instead: every metric of the regression scenes "
                        "(dsmv.verify.regression) into FILE (JSON; scenes already there are kept)")
    parser.add_argument("--against", metavar="REF", help="with --regression: compare with a file written before")
    parser.add_argument("--scenes", nargs="*", help="with --regression: only these scenes")
    parser.add_argument("--3d", dest="solid", action="store_true", help="instead: the 3D solver's throughput, "
                        "threads, cold start and memory (bench_3d.md under --out)")
    parser.add_argument("--sweeps", action="store_true", help="instead: what MLflow tracking and the launchers "
                        "cost a job (bench_sweeps.md under --out)")
    parser.add_argument("--cost", action="store_true", help="instead: measure the throughputs of the cost "
                        "estimate (dsmv/cel/throughput.json) and hold estimates and ETAs against runs (cost.md "
                        "under --out; --quick: one scene against the committed throughputs)")
    parser.add_argument("--freedoms", action="store_true", help="instead: what a body free to slide and turn "
                        "costs against one that only sinks (bench_freedoms.md under --out)")
    parser.add_argument("--vehicle", action="store_true", help="instead: the default vehicle's 3D landing, time "
                        "against mesh error on NUMBA_NUM_THREADS threads, unset: one per core (bench_vehicle.md "
                        "under --out; --quick: two meshes)")
    args = parser.parse_args(argv)
    if args.vehicle:  # on the threads NUMBA_NUM_THREADS gives (unset: one per core)
        from dsmv.verify import bench_vehicle

        bench_vehicle.main(Path(args.out), args.quick)
        return
    if args.freedoms:
        threads_unless_set(1)
        from dsmv.verify import bench_freedoms

        bench_freedoms.main(Path(args.out), args.quick)
        return
    if args.cost:
        bench_cost.main(Path(args.out), args.quick)
        return
    if args.sweeps:
        bench_sweeps.main(Path(args.out), args.quick)
        return
    if args.regression:
        threads_unless_set(1)
        results = regression.write(Path(args.regression), args.scenes)
        if args.against:
            print("\n".join(regression.compare(json.loads(Path(args.against).read_text()), results)))
        return
    plan = QUICK if args.quick else FULL
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.solid:
        solid_throughput(out)
        return
    threads_unless_set(1)
    started = time.perf_counter()

    print("dsmv-bench: warming the compiled kernels", flush=True)
    solve(LANDING + ["mesh.cell_size_m=0.08"], 1)
    rows: list[Row] = []
    print("run time against error", flush=True)
    for h in plan.prandtl_cells_m:
        rows.append(measured("prandtl", f"B/{round(1 / h)}", PRANDTL + [f"mesh.cell_size_m={h}"], plan.repeats,
                             PRANDTL_NC, "nc_at_0p05B"))
    reference = landing_reference(plan, out)
    for h in plan.landing_cells_m:
        rows.append(measured("landing", f"{h:g} m cells", LANDING + [f"mesh.cell_size_m={h}"], plan.repeats,
                             reference, "max_sinkage_m"))
    base = [f"mesh.cell_size_m={plan.knob_cell_m}"]
    if plan.knob_cell_m not in plan.landing_cells_m:
        rows.append(measured("knob", "default", LANDING + base, plan.repeats, reference, "max_sinkage_m"))
    for knob, values in plan.knobs.items():
        for value in values:
            rows.append(measured("knob", f"{knob.split('.')[-1]}={value}", LANDING + base + [f"{knob}={value}"],
                                 plan.repeats, reference, "max_sinkage_m"))
    print("throughput", flush=True)
    for h in plan.throughput_cells_m:
        if h not in plan.landing_cells_m:
            rows.append(measured("throughput", f"{h:g} m cells", LANDING + [f"mesh.cell_size_m={h}"], plan.repeats,
                                 reference, "max_sinkage_m"))
    figures = threads_and_compile(plan)
    figures["cost_exponent"] = cost_exponent([r for r in rows if r.part in ("landing", "throughput")])
    print("skipping", flush=True)
    economy_rows = economies(plan)
    write_outputs(out, rows, economy_rows, figures, plan, reference)
    print(f"dsmv-bench: wrote {out / 'bench.md'}, bench.csv and bench.png in {time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    main()
