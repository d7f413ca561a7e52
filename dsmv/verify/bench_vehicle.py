"""``dsmv-bench --vehicle``: the default vehicle's 3D landing, time against its mesh error.

The default vehicle scene (``dsmv geometry=vehicle_pioneer_i``: two tracks, the centre of gravity over
their middle, upright, level seabed) landed by cel3d on core cells of B/30, B/16 and B/8 (its default
mesh) across a track, the meshes of the verification report's ``vehicle_3d`` (each at most twice the
grousers' height, so each measures the soil they trap), each timed once after a warm-up, on the Numba
threads NUMBA_NUM_THREADS gives (unset: one per core). Its largest sinkage extrapolated from the three meshes
(``dsmv.convergence.richardson``) is the reference: each mesh's error against it and its wall time
against the two minutes a design answer may take, with the verdict against the limits of
``experiment=study_vehicle_safety`` (0.15 m, 1°). The default landing sinks only (its centre of gravity
over the tracks' middle, nothing free to turn): its tilt is zero by symmetry on any mesh. Writes
``bench_vehicle.md`` under the output folder.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from dsmv.verify.report import TRAPPED_SOIL_CELLS_M

#: the design answer's time budget (s) and the mesh error it may carry (-)
BUDGET_S, ERROR_BUDGET = 120.0, 0.02
#: core cells (m), fine to coarse; the last is the default mesh
CELLS_M = TRAPPED_SOIL_CELLS_M
SCENE = ["geometry=vehicle_pioneer_i", "tracking=disabled", "output.plots=false", "solver.progress=off",
         "safety.max_sinkage_m=0.15", "safety.max_tilt_deg=1"]


def land(cell_m: float, run_dir: Path):
    """The default vehicle landed by cel3d on core cells ``cell_m`` (m), judged: its scene and result."""
    from dsmv import registry, safety
    from dsmv.config.tree import compose_scene

    scene = compose_scene([*SCENE, f"mesh.cell_size_m={cell_m}"])
    result = registry.load("solvers", "cel3d", "solver.name")(scene).solve(run_dir)
    safety.assess(scene, result)
    return scene, result


def main(out: Path, quick: bool = False) -> dict:
    """Land, time, extrapolate; print and write the table and the ratios."""
    import numba

    from dsmv import safety
    from dsmv.convergence import richardson

    out.mkdir(parents=True, exist_ok=True)
    cells = CELLS_M[1:] if quick else CELLS_M  # quick: B/16 and B/8, no estimate
    with tempfile.TemporaryDirectory() as scratch:
        land(CELLS_M[-1], Path(scratch))  # the warm-up: the compiled kernels loaded before any timing
        runs = {cell: land(cell, Path(scratch)) for cell in cells}
    sinkage = {cell: runs[cell][1].metrics["max_sinkage_m"] for cell in cells}
    estimate = richardson(cells, tuple(sinkage[c] for c in cells)) if len(cells) == 3 else None
    reference = estimate.extrapolated if estimate else None
    lines = [f"The default vehicle (cel3d, {numba.get_num_threads()} Numba thread(s)); it sinks only, its "
             "tilt zero by symmetry", "",
             f"| core cell | cells | steps | wall (s) | max sinkage (m) | error | wall / {BUDGET_S:.0f} s | verdict |",
             "|---|---|---|---|---|---|---|---|"]
    for cell in cells:
        scene, result = runs[cell]
        m = result.metrics
        error = f"{100 * (m['max_sinkage_m'] / reference - 1):+.2f} %" if reference else "—"
        lines.append(f"| {cell:g} m | {m['cells']:,.0f} | {m['steps']:,.0f} | {m['wall_s']:.1f} | "
                     f"{m['max_sinkage_m']:.5f} | {error} | {m['wall_s'] / BUDGET_S:.2f} | "
                     f"{safety.verdict(scene.safety, result)} |")
    if estimate:
        lines += ["", f"Extrapolated {estimate.extrapolated:.5f} m ± {estimate.error:.2g} m "
                      f"(order {estimate.order:.2f}{'' if estimate.asymptotic else ', outside [0.5, 3]: first order'})."]
        default = CELLS_M[-1]
        m = runs[default][1].metrics
        lines += [f"- default mesh ({default:g} m): wall / {BUDGET_S:.0f} s = {m['wall_s'] / BUDGET_S:.3f}, "
                  f"|error| / {100 * ERROR_BUDGET:.0f} % = {abs(m['max_sinkage_m'] / reference - 1) / ERROR_BUDGET:.3f}"]
    text = "\n".join(lines) + "\n"
    (out / "bench_vehicle.md").write_text(text)
    print(text, flush=True)
    return {"sinkage_m": sinkage, "extrapolated_m": reference}
