"""What a CEL run will cost, from throughputs measured on this kind of machine.

A step costs a fixed overhead (the parallel regions, the trackers between chunks) plus a time per
cell that holds soil: the kernels skip void cells, so the grid's void above the mudline costs
almost nothing, and counting it made the old estimate 0.5–2× off between scenes of one solver.
The rates differ by dimension, by soil law (a law with state and a rate effect costs 2–3× Tresca)
and, in 3D, by thread count. ``dsmv-bench --cost`` measures them (two meshes per case, the overhead
and the rates of a dimension by least squares) and writes :data:`THROUGHPUT_FILE` with the machine it ran on; it then
runs the scenes of ``docs/verification/performance.md``'s cost table, estimate against actual.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

#: the measured throughputs (``dsmv-bench --cost`` writes it)
THROUGHPUT_FILE = Path(__file__).with_name("throughput.json")
#: bytes on disk per cell of one field frame (VTU, float32 cell data, zlib): the default landing's
#: frames measured 52 B (2D, 0.02 m, 6,230 cells: 9.1 MB in 28 frames) and 67 B (3D coarse, 47,600
#: cells: 124 MB in 39 frames)
FIELD_BYTES_PER_CELL = {2: 52.0, 3: 67.0}
#: field output larger than this (B) is announced before the run, with its size
FIELD_NOTICE_B = 50e6


@dataclass(frozen=True)
class Throughput:
    """Per dimension: the fixed cost of a step (s) and soil-cell updates per second by soil law and
    Numba threads (``{"einav_randolph": {"1": 1.2e7}}``)."""

    step_overhead_s: dict[str, float]
    soil_cell_updates_per_s: dict[str, dict[str, dict[str, float]]]
    machine: str = ""

    def rate(self, dim: int, law: str, threads: int) -> float:
        """Soil-cell updates per second; a law not measured gets the slowest measured law's rate,
        more threads than measured the rate of the most measured."""
        by_law = self.soil_cell_updates_per_s[f"{dim}d"]
        rates = by_law.get(law) or min(by_law.values(), key=lambda r: min(r.values()))
        counts = sorted(int(n) for n in rates)
        return rates[str(max([n for n in counts if n <= threads] or counts[:1]))]

    def wall_s(self, dim: int, law: str, threads: int, soil_cells: float, steps: float) -> float:
        """The estimated solve time (s), compile excluded."""
        return steps * (self.step_overhead_s[f"{dim}d"] + soil_cells / self.rate(dim, law, threads))


@lru_cache(maxsize=1)
def measured() -> Throughput:
    """The committed measurement (:data:`THROUGHPUT_FILE`)."""
    data = json.loads(THROUGHPUT_FILE.read_text())
    return Throughput(data["step_overhead_s"], data["soil_cell_updates_per_s"], data.get("machine", ""))


def field_output_b(dim: int, cells: float, frames: int) -> float:
    """What a run's field output takes on disk (B): up to 2N + 1 frames of ``cells``."""
    return FIELD_BYTES_PER_CELL[dim] * cells * (2 * frames + 1)


def duration(seconds: float) -> str:
    """A wall time as a person reads it: 'about 40 s', 'about 12 min', 'about 3.5 h'."""
    if seconds < 90.0:
        return f"about {max(seconds, 1.0):.0f} s"
    if seconds < 5400.0:
        return f"about {seconds / 60.0:.0f} min"
    return f"about {seconds / 3600.0:,.1f} h"
