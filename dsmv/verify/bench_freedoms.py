"""``dsmv-bench --freedoms``: what a body that slides and turns costs against one that only sinks.

The default landing in large deformation (the remap on: the grid follows the slide, the turn is
redrawn), timed interleaved in one process: the vertical landing on the half model, the same on the
whole section, the default scene free to sink, slide and turn (symmetric, so it keeps the half model
and its slide and turn stay 0), and the landing with its centre of gravity 0.1 m off the axis, free to
sink, slide and turn (which needs the whole section). The ratios say what the freedoms cost at equal
cells and what the lost symmetry plane costs. Writes ``bench_freedoms.md`` under the output folder.
"""

from __future__ import annotations

import statistics
import tempfile
from pathlib import Path

from dsmv.verify import canonical

#: timed this often each, interleaved, so that a load change hits all alike
REPEATS = 7
LANDING = [*canonical.LANDING, "tracking=disabled", "output.plots=false", "solver.progress=off"]
CASES = {
    "vertical, half model": LANDING,
    "vertical, whole section": [*LANDING, "solver.economies.symmetry=false"],
    "free to sink, slide and turn, the default scene (symmetric)": [*LANDING, "landing.free=[z,x,ry]"],
    "free to sink, slide and turn, centre of gravity 0.1 m off": [
        *LANDING, "landing.free=[z,x,ry]", "landing.cg_offset_m=[0.1,0,0.3]"],
}


def main(out: Path, quick: bool = False) -> dict[str, float]:
    """Time the cases; print and write the medians and the ratios."""
    out.mkdir(parents=True, exist_ok=True)
    from dsmv.cel.solver2d import Cel2DSolver
    from dsmv.config.tree import compose_scene

    walls = {name: [] for name in CASES}
    metrics = {}
    with tempfile.TemporaryDirectory() as scratch:
        for name, overrides in CASES.items():  # warm the compiled variants
            Cel2DSolver(compose_scene(overrides)).solve(Path(scratch))
        for _ in range(3 if quick else REPEATS):
            for name, overrides in CASES.items():
                metrics[name] = Cel2DSolver(compose_scene(overrides)).solve(Path(scratch)).metrics
                walls[name].append(metrics[name]["wall_s"])
    median = {name: statistics.median(w) for name, w in walls.items()}
    vertical_half, vertical_whole, free_symmetric, free = median.values()
    # a landing that turns comes to rest later (it rocks and settles): per step says what the freedoms and
    # the redraws cost, the whole run what the user waits
    per_step = {name: median[name] / metrics[name]["steps"] for name in CASES}
    ratios = {"free, the default scene / vertical, half model": free_symmetric / vertical_half,
              "free, 0.1 m off / vertical, whole section": free / vertical_whole,
              "free, 0.1 m off / vertical, half model": free / vertical_half,
              "per step, free 0.1 m off / vertical, whole section": per_step[list(CASES)[3]] / per_step[list(CASES)[1]]}
    lines = ["| landing (default scene, large deformation) | cells | steps | wall (s, median) | per step (µs) | "
             "max sinkage (m) | rotation (°) | redraws |", "|---|---|---|---|---|---|---|---|"]
    for name in CASES:
        m = metrics[name]
        lines.append(f"| {name} | {m['cells']:,.0f} | {m['steps']:,.0f} | {median[name]:.4f} | {1e6 * per_step[name]:.1f} | "
                     f"{m['max_sinkage_m']:.4f} | {m.get('rotation_deg', 0.0):.2f} | {m.get('redraws', 0):.0f} |")
    lines += ["", *(f"- {name}: {value:.2f}×" for name, value in ratios.items())]
    text = "\n".join(lines) + "\n"
    (out / "bench_freedoms.md").write_text(text)
    print(text, flush=True)
    return ratios
