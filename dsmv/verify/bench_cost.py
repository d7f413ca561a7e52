"""``dsmv-bench --cost``: measure the throughputs the cost model uses, then hold its estimates
and the progress ETA against actual runs.

1. **Throughputs.** Per dimension, soil law and thread count, the default landing on two meshes
   (warm, median of repeats); a step's wall time is a fixed overhead plus a time per soil cell
   (:mod:`dsmv.cel.cost`), the overhead per dimension and the rates solved by least squares.
   Written to :data:`dsmv.cel.cost.THROUGHPUT_FILE` with the machine and commit.
2. **Estimates against runs.** The scenes of the table in ``docs/verification/performance.md``,
   each as a user runs it (2D serial, 3D on every Numba thread): the estimate before the run
   against the solve's wall time, the expected duration against the time to rest, and the ETA
   the progress line gives when a quarter of the run's wall time has passed against the time
   that was in fact left. The table is written to ``cost.md`` under ``--out`` and into the page
   between its ``cost-table`` markers.
"""

from __future__ import annotations

import json
import statistics
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dsmv import registry
from dsmv.cel import controller as C
from dsmv.cel import cost as cost_model
from dsmv.config.tree import compose_scene
from dsmv.verify.threads import threads_unless_set

COMMON = ["tracking=disabled", "output.plots=false", "solver.progress=off"]
LAWS = ("tresca", "einav_randolph")
#: (dimension, threads, the two meshes) measured for each law
THROUGHPUT_CASES = ((2, 1, ("mesh=medium", "mesh=fine")), (3, 1, ("mesh=coarse", "mesh=medium")),
                    (3, 2, ("mesh=coarse", "mesh=medium")))
#: runs shorter than this (s) are repeated, the median kept
REPEAT_BELOW_S = 5.0
#: the scenes whose estimate and ETA the page tabulates (label, overrides)
CHECKS = (
    ("2D default landing", ["solver=cel2d"]),
    ("2D sample_II, 6500 kg, L = 5.2 m", ["solver=cel2d", "soil=sample_II", "landing.mass_kg=6500",
                                          "geometry.contact_length_m=5.2"]),
    ("2D default, Tresca, 0.01 m", ["solver=cel2d", "soil.law=tresca", "mesh=fine"]),
    ("3D coarse", ["solver=cel3d", "mesh=coarse"]),
    ("3D medium", ["solver=cel3d", "mesh=medium"]),
    ("3D coarse, Tresca", ["solver=cel3d", "mesh=coarse", "soil.law=tresca"]),
)
#: the share of the run's wall time at which the ETA is read
ETA_AT = 0.25
PAGE = Path(__file__).resolve().parents[2] / "docs" / "verification" / "performance.md"
MARKERS = ("<!-- cost-table -->", "<!-- /cost-table -->")


def solver_of(overrides: list[str]):
    scene = compose_scene(overrides + COMMON)
    return registry.load("solvers", scene.solver.name, "solver.name")(scene)


def timed(overrides: list[str]) -> tuple[float, float, float]:
    """(soil cells, steps, solve wall time s) of a warm run, the median of repeats for short ones."""
    walls = []
    while True:
        solver = solver_of(overrides)
        estimate = solver.cost()
        result = solver.solve()
        walls.append(result.metrics["wall_s"])
        if sum(walls) >= REPEAT_BELOW_S or len(walls) >= 5:
            return estimate["soil_cells"], result.metrics["steps"], statistics.median(walls)


def measure_throughput() -> dict:
    """The step overhead per dimension and soil-cell rates per law and thread count (least squares
    of wall/steps = overhead + soil cells / rate over the cases of a dimension)."""
    rows: dict[int, list] = {2: [], 3: []}
    for dim, threads, meshes in THROUGHPUT_CASES:
        for law in LAWS:
            base = [f"solver=cel{dim}d", f"soil.law={law}"] + ([f"solver.threads={threads}"] if dim == 3 else [])
            solver_of(base + [meshes[0]]).solve()  # compile or load the kernels first
            for mesh in meshes:
                soil, steps, wall = timed(base + [mesh])
                print(f"  {dim}D {law:<15} {threads} thread(s) {mesh:<12} {soil:9,.0f} soil cells × {steps:6,.0f} "
                      f"steps: {wall:7.2f} s", flush=True)
                rows[dim].append((law, threads, soil, steps, wall))
    overhead, rates = {}, {}
    for dim, runs in rows.items():
        keys = sorted({(law, threads) for law, threads, *_ in runs})
        a = np.array([[1.0] + [soil if (law, threads) == k else 0.0 for k in keys]
                      for law, threads, soil, _, _ in runs])
        b = np.array([wall / steps for *_, steps, wall in runs])
        solution = np.linalg.lstsq(a, b, rcond=None)[0]
        if solution[0] < 0.0:  # no measurable overhead: rates alone
            solution = np.concatenate([[0.0], np.linalg.lstsq(a[:, 1:], b, rcond=None)[0]])
        overhead[f"{dim}d"] = float(solution[0])
        for (law, threads), inverse in zip(keys, solution[1:]):
            rates.setdefault(f"{dim}d", {}).setdefault(law, {})[str(threads)] = float(1.0 / inverse)
    return {"step_overhead_s": overhead, "soil_cell_updates_per_s": rates}


class EtaProbe(C.Progress):
    """The progress line's estimate, silent: (wall time, simulated time, time left) after every chunk."""

    def __init__(self, expected_s: float):
        super().__init__(expected_s, terminal=False)
        self.samples: list[tuple[float, float, float | None]] = []

    def after_chunk(self, run: C.Run) -> None:
        left = self.time_left_s(run)
        self.samples.append((time.perf_counter() - self.started, run.time_s, left))

    def eta_left_s(self, share: float) -> tuple[float, float]:
        """At the first chunk past ``share`` of the run's wall time: (wall time then, the time the
        progress line says is left)."""
        total = self.samples[-1][0]
        elapsed, _, left = next(s for s in self.samples if s[0] >= share * total and s[2] is not None)
        return elapsed, left


@dataclass
class Check:
    label: str
    estimate_s: float
    actual_s: float
    expected_duration_s: float
    rest_s: float
    eta_left_s: float
    actual_left_s: float
    extra: dict = field(default_factory=dict)


def check(label: str, overrides: list[str]) -> Check:
    solver = solver_of(overrides)
    solver.solve()  # warm
    solver = solver_of(overrides)
    estimate, expected = solver.cost()["wall_s"], solver.expected_duration_s()
    probe = EtaProbe(expected)

    def with_probe(state, run_dir, build=solver.trackers):
        trackers, zigzag = build(state, run_dir)
        return trackers + [probe], zigzag

    solver.trackers = with_probe
    result = solver.solve()
    elapsed, left = probe.eta_left_s(ETA_AT)
    total = probe.samples[-1][0]
    row = Check(label, estimate, result.metrics["wall_s"], expected, probe.samples[-1][1], left, total - elapsed)
    print(f"  {label:<36} estimate {estimate:7.1f} s, actual {row.actual_s:7.1f} s; expected {expected:.3f} s "
          f"simulated, ran {row.rest_s:.3f} s; ETA at {ETA_AT:.0%}: {left:6.1f} s left, in fact {row.actual_left_s:6.1f} s",
          flush=True)
    return row


def table(rows: list[Check], stamp: dict) -> str:
    lines = [f"Measured by `dsmv-bench --cost` at {stamp['commit'][:7]} ({stamp['tree']} tree), {stamp['date']}; "
             f"{stamp['machine']}. Solve times warm (compile apart).", "",
             "| scene | estimate (s) | solve (s) | estimate / solve | expected / simulated duration "
             f"| ETA left at {ETA_AT:.0%} (s) | in fact left (s) | ETA / actual |",
             "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r.label} | {r.estimate_s:.1f} | {r.actual_s:.1f} | {r.estimate_s / r.actual_s:.2f} "
                     f"| {r.expected_duration_s / r.rest_s:.2f} | {r.eta_left_s:.1f} | {r.actual_left_s:.1f} "
                     f"| {r.eta_left_s / r.actual_left_s:.2f} |")
    return "\n".join(lines) + "\n"


def write_page(text: str, page: Path = PAGE) -> bool:
    """Put the table between the page's markers; False when the page (an installed copy) has none."""
    if not page.exists():
        return False
    content = page.read_text()
    start, end = content.find(MARKERS[0]), content.find(MARKERS[1])
    if start < 0 or end < start:
        return False
    page.write_text(content[:start + len(MARKERS[0])] + "\n" + text + content[end:])
    return True


def main(out: Path, quick: bool = False) -> None:
    from dsmv.verify.report import provenance

    threads_unless_set(2)
    out.mkdir(parents=True, exist_ok=True)
    stamp = provenance()
    if not quick:
        print("dsmv-bench --cost: throughputs", flush=True)
        measured = measure_throughput() | {"machine": stamp["machine"], "commit": stamp["commit"],
                                           "date": stamp["date"], "command": "dsmv-bench --cost"}
        cost_model.THROUGHPUT_FILE.write_text(json.dumps(measured, indent=2) + "\n")
        cost_model.measured.cache_clear()
        print(f"  written {cost_model.THROUGHPUT_FILE}", flush=True)
    print("estimates and ETAs against runs", flush=True)
    text = table([check(label, overrides) for label, overrides in (CHECKS[:1] if quick else CHECKS)], stamp)
    (out / "cost.md").write_text(text)
    print(text + f"written {out / 'cost.md'}" + (f" and {PAGE}" if not quick and write_page(text) else ""))
