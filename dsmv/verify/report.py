"""``dsmv-report``: the verification report, generated from runs and stamped with the commit it measured.

Each check is a scene with an exact or published answer (or, for the default landing, none: its
reference is its own extrapolated value), run on a sequence of core cell sizes. The report gives,
per check, the result on every mesh, its error, the order observed over the three finest meshes
(:func:`dsmv.convergence.richardson`), the extrapolated value and its error, and the wall time,
and draws the errors against the cell size on one figure.

``dsmv-report`` runs the full set and writes ``docs/verification/report.md`` (the site's page) and
its figure beside it. ``dsmv-report --only WORD …`` reruns the checks named and merges them into the
committed page: each check keeps the stamp of the commit it was measured on, and the page lists them.
``dsmv-report --quick`` runs coarse meshes of a subset in a few minutes and writes under
``runs/report/``, never over the committed page. Exit codes: 0 written, 1 a check did
not end ``ok`` (the page is still written, the run marked), 2 bad arguments or a check whose scene does
not compose (one line: the key, the value, what is allowed); SIGINT or SIGTERM stops
the report after the run under way, writes the checks done to ``runs/report/report.interrupted.md``
and exits with the code of ``interrupted``.
"""

from __future__ import annotations

import argparse
import json
from collections import Counter
import math
import re
import platform
import subprocess
import sys
import time
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

from dsmv import registry
from dsmv.cel import cost as cost_model
from dsmv.analytic.bearing import bonded_moment_upper_bound, effective_width_moment, green_radial_factor
from dsmv.convergence import richardson
from dsmv.errors import ConfigError
from dsmv.results import EXIT_CODES
from dsmv.verify.regression import QUIET

PAGE = Path("docs/verification/report.md")
NO_WALL_LIMIT_S = 1e9  # solver.max_wall_s for the report's runs (s): about 32 years
QUICK_DIR = Path("runs/report")
FIGURE = "report_convergence.png"

#: the small-strain push of the exact strip and plate solutions: weightless Tresca soil, su 10 kPa,
#: the analysis on the undeformed grid (what the exact solutions refer to)
SMALL_STRAIN = ("experiment=verify_prandtl", "hydra.mode=RUN", "solver.remap=false", "solver.contact_separation=false")


#: the figures a check may read that a run does not report itself, each from the run's own metrics:
#: how far the strip's end load lies beyond Green's V–H envelope along its ray (1: on it), the
#: moment of a strip that holds no tension over Meyerhof's effective width's at the same V, and the
#: bonded strip's over the circular scoop's upper bound at the same V and H (H towards the edge pressed down)
DERIVED = {
    "green_radial_factor": lambda m: green_radial_factor(abs(m["end_horizontal_factor"]), m["end_vertical_factor"]),
    "effective_width_factor": lambda m: abs(m["end_moment_factor"]) / effective_width_moment(m["end_vertical_factor"]),
    "scoop_factor": lambda m: abs(m["end_moment_factor"]) / bonded_moment_upper_bound(
        m["end_vertical_factor"], math.copysign(1.0, m["end_moment_factor"]) * m["end_horizontal_factor"]),
}


def push_along(degrees: float) -> tuple[str, str]:
    """A push at 0.1 m/s ``degrees`` below the horizontal (+x), as landing overrides."""
    angle = math.radians(degrees)
    return (f"landing.velocity_m_s={0.1 * math.sin(angle):.6f}",
            f"landing.horizontal_velocity_m_s={0.1 * math.cos(angle):.6f}")


#: the 3D track's meshes, B/30, B/16 and B/8 across its 0.6 m: each at most twice the grousers' 0.05 m, the
#: coarsest that measures the soil they trap (docs/decisions/0042); B/4's held wall is the base's half cell,
#: 0.075 m, and made three meshes that included it read order 2.8 and ± 0.0001 m where B/30 lay 0.0003 m off
TRAPPED_SOIL_CELLS_M = (0.02, 0.0375, 0.075)


@dataclass(frozen=True)
class Check:
    """A scene with a reference answer, run on a sequence of core cell sizes (m, fine to coarse).
    ``key`` names it in the pages' figures (``{{ report.<key>.value }}``, :func:`fill_figures`)."""

    key: str
    name: str
    metric: str
    reference: float | None  # None: the check's own extrapolated value is its reference
    source: str
    overrides: tuple[str, ...]
    cells_m: tuple[float, ...]
    quick_cells_m: tuple[float, ...] | None  # None: not in the quick report
    length_m: float  # the body's size the cells are quoted against (B or D)
    length_name: str = "B"


CHECKS = (
    Check("prandtl_rough", "Prandtl: rough strip, small strain, q/su at 0.05 B", "nc_at_0p05B", 2 + math.pi,
          "Prandtl (1920): 2 + π", (*SMALL_STRAIN, "landing.displacement_m=0.06"),
          (0.025, 0.05, 0.1), (0.05, 0.1, 0.2), 1.0),
    Check("prandtl_smooth", "Prandtl: smooth strip, small strain, q/su at 0.05 B", "nc_at_0p05B", 2 + math.pi,
          "Prandtl (1920), Hill (1950): 2 + π",
          (*SMALL_STRAIN, "geometry.roughness=smooth", "landing.displacement_m=0.06"),
          (0.025, 0.05, 0.1), None, 1.0),
    Check("davis_booker_smooth_4",
          "Davis & Booker: smooth strip, su = su0 + k·z, k·B/su0 = 4, small strain, q/su0 at 0.02 B", "nc_at_0p02B",
          7.80, "Davis & Booker (1973); PLAXIS 2D validation manual 3.2: 7.80",
          (*SMALL_STRAIN, "geometry.roughness=smooth", "soil.ks_pa_per_m=40000", "soil.youngs_modulus_pa=1e7",
           "landing.displacement_m=0.04", "solver.initial_travel_m=0.1"),
          (0.025, 0.05, 0.1), (0.05, 0.1, 0.2), 1.0),
    Check("davis_booker_smooth_4_table",
          "Davis & Booker as above, the strength a table (soil.profile), q/su0 at 0.02 B", "nc_at_0p02B",
          7.80, "Davis & Booker (1973): 7.80; the table [[0, 10 kPa], [100 m, 4010 kPa]] is su0 + k·z",
          (*SMALL_STRAIN, "geometry.roughness=smooth", "soil.ks_pa_per_m=0", "soil.profile=[[0,10000],[100,4010000]]",
           "soil.youngs_modulus_pa=1e7", "landing.displacement_m=0.04", "solver.initial_travel_m=0.1"),
          (0.025, 0.05, 0.1), None, 1.0),
    *(Check(f"davis_booker_rough_{k}",
            f"Davis & Booker: rough strip, su = su0 + k·z, k·B/su0 = {k}, small strain, q/su0 at 0.02 B",
            "nc_at_0p02B", reference, f"Davis & Booker (1973), their chart read: about {reference}",
            (*SMALL_STRAIN, "soil.ks_pa_per_m=" + str(10000 * k), "soil.youngs_modulus_pa=1e7",
             "landing.displacement_m=0.04", "solver.initial_travel_m=0.1"),
            (0.025, 0.05, 0.1), None, 1.0)
      for k, reference in ((2, 7.57), (4, 9.0), (6, 10.5))),
    Check("circle_axisymmetric_rough",
          "Circular plate: rough, axisymmetric, small strain, q/su at 0.1 B", "nc_at_0p1B", 6.05,
          "Cox, Eason & Hopkins (1961): 6.05",
          (*SMALL_STRAIN, "solver=cel2d", "geometry=circular_plate", "landing.displacement_m=0.11"),
          (0.025, 0.05, 0.1), (0.05, 0.1, 0.2), 1.0),
    Check("circle_axisymmetric_smooth",
          "Circular plate: smooth, axisymmetric, small strain, q/su at 0.1 B", "nc_at_0p1B", 5.69,
          "Cox, Eason & Hopkins (1961): 5.69",
          (*SMALL_STRAIN, "solver=cel2d", "geometry=circular_plate", "geometry.roughness=smooth",
           "landing.displacement_m=0.11"),
          (0.025, 0.05, 0.1), None, 1.0),
    Check("tbar_rough", "T-bar: rough, pushed 2 D with the remap, steady q/su", "nc_deep", 11.94,
          "Randolph & Houlsby (1984): 11.94", ("experiment=verify_tbar", "hydra.mode=RUN", "geometry.roughness=rough"),
          (0.025, 0.05), None, 0.5, "D"),
    Check("tbar_smooth", "T-bar: smooth, pushed 2 D with the remap, steady q/su", "nc_deep", 9.20,
          "Martin & Randolph (2006): 9.20", ("experiment=verify_tbar", "hydra.mode=RUN", "geometry.roughness=smooth"),
          (0.025, 0.05), None, 0.5, "D"),
    Check("square_3d_rough", "Square plate: rough, 3D quarter model, small strain, q/su at 0.1 B", "nc_at_0p1B",
          (2 + math.pi) * (1 + 0.214 - 0.067), "Gourvenec (2007): (2 + π)·(1 + 0.214·B/L − 0.067·(B/L)²) = 5.90",
          (*SMALL_STRAIN, "solver=cel3d", "geometry=rectangular_plate", "geometry.contact_length_m=1",
           "solver.yield_surface=tresca", "landing.displacement_m=0.11"),
          (0.05, 0.1, 0.2), (0.25,), 1.0),
    *(Check(f"circle_3d_{roughness}",
            f"Circular plate: {roughness}, 3D quarter model, small strain, q/su at 0.1 B", "nc_at_0p1B", reference,
            f"Cox, Eason & Hopkins (1961): {reference}",
            (*SMALL_STRAIN, "solver=cel3d", "geometry=circular_plate", f"geometry.roughness={roughness}",
             "landing.displacement_m=0.11"),
            (0.05, 0.1), None, 1.0)
      for roughness, reference in (("rough", 6.05), ("smooth", 5.69))),
    Check("slide_rough", "Rough strip slid sideways 0.05 B, whole section, small strain, H/(B·su)",
          "end_horizontal_factor", 1.0, "Green (1954): H = B·su, the strip slides along its base",
          (*SMALL_STRAIN, "landing.velocity_m_s=0", "landing.horizontal_velocity_m_s=0.1", "landing.displacement_m=0.05"),
          (0.025, 0.05, 0.1), (0.05, 0.1, 0.2), 1.0),
    *(Check(f"green_h{str(h).replace('.', 'p')}", f"Rough strip pushed {degrees:g}° below the horizontal 0.05 B, whole "
            f"section, small strain, ending near h = {h}: λ, its end load over Green's envelope along its ray",
            "green_radial_factor", 1.0,
            "Green (1954): λ = 1 on V/(B·su) = 1 + π − arcsin h + √(1 − h²), h = H/(B·su)",
            (*SMALL_STRAIN, *push_along(degrees), "landing.displacement_m=0.05"), (0.025, 0.05, 0.1), None, 1.0)
      # the directions end on the envelope near h = 0.25, 0.5, 0.75 extrapolated (0.249, 0.504, 0.755)
      for h, degrees in ((0.25, 48.5), (0.5, 37.0), (0.75, 26.3))),
    Check("slide_followed", "Rough strip slid sideways 0.5 B, the grid following it (large deformation), "
          "whole section, H/(B·su) at its end", "end_horizontal_factor", None,
          "its own value extrapolated; Green's B·su for a slide along the base, before any soil is ploughed",
          ("experiment=verify_prandtl", "hydra.mode=RUN", "solver.contact_separation=false", "landing.velocity_m_s=0",
           "landing.horizontal_velocity_m_s=0.1", "landing.displacement_m=0.5"),
          (0.025, 0.05, 0.1), None, 1.0),
    Check("moment_bonded", "Bonded rough strip turned 4° free to slide, whole section, small strain, M/(B²·su)",
          "end_moment_factor", None, "its own value extrapolated; under the scoop mechanism's rigorous 0.690",
          (*SMALL_STRAIN, "landing.velocity_m_s=0", "landing.roll_rate_rad_s=0.1", "landing.rotation_deg=4",
           "landing.free=[x,z]"),
          (0.0125, 0.025, 0.05, 0.1), None, 1.0),  # B/80: the edges' singular stress converges slowly
    *(Check(f"moment_no_tension_{ratio}", f"Rough strip that holds no tension, turned 4° while pushed down (its edge "
            f"{ratio}× as fast as its middle) free to slide, whole section, small strain: M over the effective "
            "width's at its V", "effective_width_factor", None,
            "its own value extrapolated; Meyerhof's (1953) effective width is a lower bound (`effective_width_moment`): "
            "at least 1",
            ("experiment=verify_prandtl", "hydra.mode=RUN", "solver.remap=false", "solver.contact_separation=true",
             "landing.free=[x]", "landing.roll_rate_rad_s=0.1", f"landing.velocity_m_s={0.05 / ratio:g}",
             "landing.rotation_deg=4", "landing.displacement_m=0.05"), (0.025, 0.05, 0.1), None, 1.0)
      for ratio in (2, 4)),
    *(Check(f"moment_bonded_vm_{ratio}", f"Bonded rough strip turned 4° while pushed down (its edge {ratio}× as "
            "fast as its middle) free to slide, whole section, small strain: M over the circular scoop's upper bound "
            "at its V and H", "scoop_factor", None,
            "its own value extrapolated; the scoop (`bonded_moment_upper_bound`) is an upper bound: at most 1; Green's "
            f"field under the effective width (`effective_width_inclined_moment`) a lower bound: at least about {floor} there",
            (*SMALL_STRAIN, "landing.free=[x]", "landing.roll_rate_rad_s=0.1", f"landing.velocity_m_s={0.05 / ratio:g}",
             "landing.rotation_deg=4", "landing.displacement_m=0.05"), (0.0125, 0.025, 0.05, 0.1), None, 1.0)
      # the lower bound over the upper at the (V, H)/(B·su) each probe ends near (B/40: (3.36, 0.01), (2.40, 0.03))
      for ratio, floor in ((2, 0.88), (4, 0.91))),
    Check("moment_turned", "Bonded rough strip turned 4° free to slide, redrawn as it turns (large deformation), "
          "whole section, M/(B²·su) at its end", "end_moment_factor", None,
          "its own value extrapolated; the small-strain moment above",
          ("experiment=verify_prandtl", "hydra.mode=RUN", "solver.contact_separation=false", "landing.velocity_m_s=0",
           "landing.roll_rate_rad_s=0.1", "landing.rotation_deg=4", "landing.free=[x,z]"),
          (0.025, 0.05, 0.1), None, 1.0),
    Check("moment_circle_3d", "Bonded rough circular plate turned 4° free to slide, 3D half model, small strain, "
          "M/(A·D·su)", "end_moment_factor", 0.670,
          "the spherical scoop's rigorous upper bound 0.670 (`spherical_scoop_moment_upper_bound`); Vulpe, Gourvenec "
          "& Power (2014) tabulate 0.67",
          (*SMALL_STRAIN, "solver=cel3d", "geometry=circular_plate", "solver.yield_surface=tresca",
           "landing.velocity_m_s=0", "landing.roll_rate_rad_s=0.1", "landing.rotation_deg=4", "landing.free=[x,y,z]"),
          (0.025, 0.05, 0.1, 0.2), None, 1.0, "D"),
    Check("moment_rectangle_3d", "Bonded rough rectangular plate L/B = 2 turned 4° across B free to slide, 3D half "
          "model, small strain, M/(A·B·su)", "end_moment_factor", None,
          "its own value extrapolated; under the cylindrical scoop's rigorous 0.790 (`scoop_moment_upper_bound(2)`)",
          (*SMALL_STRAIN, "solver=cel3d", "geometry=rectangular_plate", "geometry.contact_length_m=2",
           "solver.yield_surface=tresca", "landing.velocity_m_s=0", "landing.roll_rate_rad_s=0.1",
           "landing.rotation_deg=4", "landing.free=[x,y,z]"),
          (0.05, 0.1, 0.2), None, 1.0),
    Check("landing_default", "Default landing: max sinkage (m), Einav–Randolph, no exact answer", "max_sinkage_m",
          None,
          "its own value extrapolated from the three finest meshes", ("solver=cel2d",),
          (0.005, 0.01, 0.02, 0.04), (0.02, 0.04, 0.08), 0.6),  # the track's B
    Check("track_3d", "The track in 3D (cel3d): default landing, max sinkage (m), no exact answer", "max_sinkage_m",
          None, "its own value extrapolated from the three meshes", ("solver=cel3d",),
          TRAPPED_SOIL_CELLS_M, None, 0.6),
    Check("vehicle_3d", "The vehicle on two tracks 2.6 m apart (cel3d): default landing, max sinkage per track (m), "
          "no exact answer", "max_sinkage_m", None, "its own value extrapolated from the three meshes",
          ("geometry=vehicle_pioneer_i",), TRAPPED_SOIL_CELLS_M, None, 0.6),
    Check("landing_tresca", "Default landing on Tresca soil: max sinkage (m), no exact answer", "max_sinkage_m", None,
          "its own value extrapolated from the three finest meshes", ("solver=cel2d", "soil.law=tresca"),
          (0.005, 0.01, 0.02, 0.04), None, 0.6),
)


@dataclass
class Outcome:
    """One check on one mesh."""

    cell_m: float
    status: str
    value: float
    wall_s: float


def solver_of(check: Check, cell_m: float):
    """The solver of the check's scene on core cells ``cell_m``."""
    from dsmv.config.tree import compose_scene

    # no refusal by run time: the report states its runs' estimated time before it starts them
    scene = compose_scene([*check.overrides, f"mesh.cell_size_m={cell_m}", "solver.progress=off",
                           f"solver.max_wall_s={NO_WALL_LIMIT_S:g}", *QUIET])
    return registry.load("solvers", scene.solver.name, "solver.name")(scene)


def estimated_wall_s(check: Check, cell_m: float) -> float:
    """The solver's own estimate of the run's wall time (s; ``dsmv.cel.cost``), before it runs."""
    return float(solver_of(check, cell_m).cost()["wall_s"])


def run(check: Check, cell_m: float) -> Outcome:
    """The check's scene on core cells ``cell_m``, in this process (compile time not counted)."""
    result = solver_of(check, cell_m).solve()
    metrics = result.metrics
    value = DERIVED[check.metric](metrics) if check.metric in DERIVED and result.status == "ok" else \
        metrics.get(check.metric, math.nan)
    return Outcome(cell_m, result.status, float(value), float(result.metrics.get("wall_s", math.nan)))


def provenance() -> dict[str, str]:
    """The commit measured, whether its tree was clean, the date and the machine."""
    def git(*args: str) -> str:
        try:
            return subprocess.run(["git", *args], capture_output=True, text=True, check=True,
                                  cwd=Path(__file__).resolve().parent).stdout.strip()
        except (OSError, subprocess.CalledProcessError):
            return ""

    import numba

    commit = git("rev-parse", "HEAD") or "unknown (not a git checkout)"
    # the report's own pages (an earlier report's) are outputs, not the code measured
    dirty = [line for line in git("status", "--porcelain", "--untracked-files=no").splitlines()
             if not line[3:].startswith(str(PAGE.parent / "report"))]
    cpu = next((line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                if line.startswith("model name")), platform.processor()) if Path("/proc/cpuinfo").exists() else ""
    return {"commit": commit, "tree": "modified" if dirty else "clean",
            "date": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
            "machine": f"{cpu or platform.machine()}, {numba.config.NUMBA_NUM_THREADS} Numba thread(s), "
                       f"Python {platform.python_version()}, Numba {numba.__version__}"}


def estimate(outcomes: list[Outcome]):
    """Richardson over the three finest meshes that ended ok (None with fewer)."""
    ok = [o for o in outcomes if o.status == "ok" and math.isfinite(o.value)][:3]
    if len(ok) < 3:
        return None
    return richardson(tuple(o.cell_m for o in ok), tuple(o.value for o in ok))


def _error(value: float, reference: float | None) -> str:
    return "" if reference is None or not math.isfinite(value) else f"{100 * (value / reference - 1):+.2f} %"


def check_section(check: Check, outcomes: list[Outcome]) -> tuple[str, dict]:
    """The check's markdown section and its summary row."""
    est = estimate(outcomes)
    reference = check.reference if check.reference is not None else (est.extrapolated if est else None)
    lines = [f"### {check.name}", "", f"Reference: {check.source}.", "",
             f"| core cell | {check.length_name}/h | {check.metric} | error | wall time |", "|---|---|---|---|---|"]
    for o in outcomes:
        shown = f"{o.value:.5g}" if o.status == "ok" else f"{o.status}"
        lines.append(f"| {o.cell_m:g} m | {check.length_m / o.cell_m:.4g} | {shown} | {_error(o.value, reference)} | "
                     f"{o.wall_s:.3g} s |")
    if est is not None:
        order = f"{est.order:.2f}" if est.asymptotic else "outside [0.5, 3]: first order and 3·|z(h) − z(2h)| assumed"
        lines += ["", f"Observed order {order}; extrapolated {est.extrapolated:.5g} ± {est.error:.2g}"
                  + (f" ({_error(est.extrapolated, check.reference)} from the reference)." if check.reference else ".")]
    finest = next((o for o in outcomes if o.status == "ok"), None)
    row = {"check": check.name, "reference": f"{reference:.5g}" if reference is not None else "",
           "finest": f"{finest.value:.5g} ({check.length_name}/{check.length_m / finest.cell_m:.3g})" if finest else "—",
           "error": _error(finest.value, reference) if finest else "",
           "order": f"{est.order:.2f}" if est is not None and est.asymptotic else ("—" if est is None else "1 (assumed)"),
           "extrapolated": f"{est.extrapolated:.5g} ± {est.error:.2g}" if est is not None else "—",
           "wall": f"{sum(o.wall_s for o in outcomes if math.isfinite(o.wall_s)):.0f} s"}
    return "\n".join(lines), row


#: parts of a check's name that the figure's legend leaves out (the table beside it says them)
LEGEND_DROPS = ("small strain", "q/su", "pushed", "steady", "su = su0", "no exact answer", "axisymmetric",
                "3D quarter", "3D half")


def short_name(check: Check) -> str:
    """A check's name for a legend: its first part and what tells it from its neighbours."""
    first, *rest = check.name.split(", ")
    return ", ".join([first, *(part for part in rest if not any(word in part for word in LEGEND_DROPS))])


def figure(path: Path, results: list[tuple[Check, list[Outcome]]]) -> Path:
    """|error| against the relative cell size on log-log axes, one line per check."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(10, 5), constrained_layout=True)
    # 20 colours and 9 markers: no two of the first 180 checks alike
    colours, markers = plt.get_cmap("tab20").colors, "osD^v<>ph"
    for k, (check, outcomes) in enumerate(results):
        est = estimate(outcomes)
        reference = check.reference if check.reference is not None else (est.extrapolated if est else None)
        points = [(o.cell_m / check.length_m, abs(o.value / reference - 1)) for o in outcomes
                  if reference and o.status == "ok" and math.isfinite(o.value) and o.value != reference]
        if points:
            h, err = zip(*points)
            colour = colours[(2 * k) % 20 + (k // 10) % 2]  # the dark tab20 shades first, then the light ones
            ax.loglog(h, [100 * e for e in err], marker=markers[k % len(markers)], color=colour,
                      label=short_name(check) + ("" if check.reference is not None else " (vs extrapolated)"))
    ax.set_xlabel("core cell / body size (h/B or h/D)")
    ax.set_ylabel("|error| (%)")
    ax.grid(alpha=0.3, which="both")
    if ax.get_legend_handles_labels()[0]:  # none when no check has two meshes that ended ok
        ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.02, 0.5))
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path


def write_page(path: Path, results: list[tuple[Check, list[Outcome]]], quick: bool, stamp: dict,
               stamps: list[dict] | None = None) -> Path:
    """The page, its figure and its numbers (``<page>.json``: the stamp and every outcome) beside it.
    ``stamps``: each check's own (a merged report's), by default ``stamp`` for all."""
    from dataclasses import asdict

    stamps = stamps or [stamp] * len(results)
    numbers = {"stamp": stamp, "quick": quick,
               "checks": [{"key": c.key, "name": c.name, "metric": c.metric, "reference": c.reference,
                           "stamp": own, "outcomes": [asdict(o) for o in outcomes]}
                          for (c, outcomes), own in zip(results, stamps)]}
    path.with_suffix(".json").write_text(json.dumps(numbers, indent=1, default=float) + "\n")
    mixed = any(own != stamp for own in stamps)
    sections, rows = zip(*(check_section(c, o) for c, o in results)) if results else ((), ())
    if mixed:   # each section says which commit measured it
        sections = [f"{section}\n\nMeasured on commit `{own['commit'][:10]}` ({own['tree']} tree), {own['date']}."
                    for section, own in zip(sections, stamps)]
    figure(path.parent / FIGURE, results)
    mode = "quick (coarse meshes, a subset: `dsmv-report --quick`)" if quick else "full (`dsmv-report`)"
    if mixed:
        counts = Counter((own["commit"], own["tree"], own["date"]) for own in stamps)
        measured = [f"- commit `{commit}` ({tree} tree), {date}: {n} check{'s' if n > 1 else ''}"
                    for (commit, tree, date), n in sorted(counts.items(), key=lambda kv: kv[0][2], reverse=True)]
        mode = "merged: checks rerun by `dsmv-report --only` beside those measured before, each with its commit"
    else:
        measured = [f"- commit `{stamp['commit']}` ({stamp['tree']} tree)", f"- {stamp['date']}"]
    lines = ["# Verification report", "",
             "Generated by `dsmv-report` from runs; every figure on this page is measured, none typed by hand.", "",
             *measured, f"- machine: {stamp['machine']}", f"- mode: {mode}", "",
             "Error: against the reference (the exact or published value; the landing's own extrapolated "
             "value). Order: observed over the three finest meshes, Richardson extrapolation "
             "([Outputs](../guide/outputs.md#the-mesh-error)). Wall time: the solve, compile time excluded.", "",
             "## Summary", "",
             "| check | reference | finest mesh | error | order | extrapolated | wall time |",
             "|---|---|---|---|---|---|---|"]
    lines += [f"| {r['check']} | {r['reference']} | {r['finest']} | {r['error']} | {r['order']} | {r['extrapolated']} | "
              f"{r['wall']} |" for r in rows]
    lines += ["", f"![|error| against the cell size, every check]({FIGURE})", "", "## The checks", ""]
    lines += [s + "\n" for s in sections]
    path.write_text("\n".join(lines))
    return path


#: a figure the report measured, written in a page as ``{{ report.<key>.<field>[@<core cell, m>][:<format>] }}``:
#: ``{{ report.square_3d_rough.value@0.05:.4g }}``, ``{{ report.circle_3d_rough.error:+.1f }}`` (no ``|``: the
#: figures sit in tables)
FIGURE_PLACEHOLDER = re.compile(r"\{\{\s*report\.(\w+)\.(\w+)(?:@([0-9.]*[0-9]))?(?::([^}\s]+))?\s*\}\}")
#: value and wall (s) of one mesh, error (%) against the reference, order, extrapolated and its uncertainty
FIGURE_FIELDS = ("value", "wall", "error", "order", "extrapolated", "uncertainty")


def figure_value(numbers: dict, key: str, field: str, cell_m: float | None = None) -> float:
    """A figure of the report's numbers (``report.json``): ``field`` of the check ``key``, on the mesh of
    core cell ``cell_m`` (default: the finest that ended ok) for value, wall and error."""
    check = next((c for c in numbers["checks"] if c.get("key") == key), None)
    if check is None:
        raise ValueError(f"report.{key}: no such check; the report has "
                         f"{', '.join(c.get('key', '?') for c in numbers['checks'])}")
    if field not in FIGURE_FIELDS:
        raise ValueError(f"report.{key}.{field}: no such figure; one of {', '.join(FIGURE_FIELDS)}")
    outcomes = [Outcome(**o) for o in check["outcomes"]]
    est = estimate(outcomes)
    if field in ("order", "extrapolated", "uncertainty"):
        if est is None:
            raise ValueError(f"report.{key}.{field}: the check has fewer than three meshes that ended ok")
        return {"order": est.order, "extrapolated": est.extrapolated, "uncertainty": est.error}[field]
    ok = [o for o in outcomes if o.status == "ok" and (cell_m is None or math.isclose(o.cell_m, cell_m))]
    if not ok:
        raise ValueError(f"report.{key}.{field}@{cell_m}: no mesh of that core cell ended ok; the report has "
                         f"{', '.join(f'{o.cell_m:g}' for o in outcomes)} m")
    outcome = ok[0]
    if field == "value":
        return outcome.value
    if field == "wall":
        return outcome.wall_s
    reference = check["reference"] if check["reference"] is not None else (est.extrapolated if est else None)
    if reference is None:
        raise ValueError(f"report.{key}.error: the check has neither a reference nor an extrapolated value")
    return 100.0 * (outcome.value / reference - 1.0)


def fill_figures(text: str, numbers: dict) -> str:
    """A page with each ``{{ report.… }}`` replaced by the figure the report measured (format ``.4g``
    unless given; a minus sign is written −): how the hand-written verification pages quote the report
    rather than retype it. An unknown check, field or mesh raises ValueError."""
    def figure(match: re.Match) -> str:
        key, field, cell, spec = match.groups()
        value = figure_value(numbers, key, field, float(cell) if cell else None)
        return format(value, spec or ".4g").replace("-", "−")

    return FIGURE_PLACEHOLDER.sub(figure, text)


def committed_numbers(docs_dir: Path = PAGE.parents[1]) -> dict:
    """The numbers behind the committed report page (``docs/verification/report.json``)."""
    return json.loads((docs_dir / PAGE.relative_to(PAGE.parents[1])).with_suffix(".json").read_text())


def on_page_markdown(markdown: str, page, config, files) -> str:
    """The documentation site's hook (``hooks:`` in mkdocs.yml): every page's report figures filled
    in at build time; a figure the report does not have fails the build."""
    return fill_figures(markdown, committed_numbers(Path(config["docs_dir"])))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="dsmv-report", description="Run the verification checks and write the "
                                     "report, stamped with the commit (full: docs/verification/report.md).")
    parser.add_argument("--quick", action="store_true", help="coarse meshes of a subset, written under runs/report/")
    parser.add_argument("--only", nargs="*", help="only the checks whose key is, or whose name contains, one of "
                        "these words, merged into the committed report (each check keeps the commit it was measured on)")
    args = parser.parse_args(argv)
    checks = [c for c in CHECKS if (c.quick_cells_m is not None or not args.quick)
              and (not args.only or any(w.lower() in c.name.lower() or w == c.key for w in args.only))]
    page = QUICK_DIR / "report.md" if args.quick else PAGE
    page.parent.mkdir(parents=True, exist_ok=True)
    stamp = provenance()
    plan = [(check, check.quick_cells_m if args.quick else check.cells_m) for check in checks]
    try:
        estimates = {(check.key, cell): estimated_wall_s(check, cell) for check, cells in plan for cell in cells}
    except ConfigError as error:
        print(f"dsmv-report: {error}", file=sys.stderr)
        return 2
    print(f"dsmv-report: {len(checks)} check{'s' * (len(checks) != 1)}, {len(estimates)} run{'s' * (len(estimates) != 1)}, "
          f"{cost_model.duration(sum(estimates.values()))} "
          f"by the solvers' estimates (compile time apart)", flush=True)
    results, failed = [], 0
    for check, cells in plan:
        outcomes = []
        for cell in cells:
            print(f"dsmv-report: {check.key} at {cell:g} m, {cost_model.duration(estimates[check.key, cell])} ...",
                  flush=True)
            start = time.perf_counter()
            outcome = run(check, cell)
            failed += outcome.status != "ok"
            print(f"dsmv-report: {check.name} at {cell:g} m: {outcome.status} {check.metric} = {outcome.value:.6g} "
                  f"({time.perf_counter() - start:.0f} s)", flush=True)
            outcomes.append(outcome)
            if outcome.status == "interrupted":  # a signal stopped the run: stop the report, keep what it has
                results.append((check, outcomes))
                QUICK_DIR.mkdir(parents=True, exist_ok=True)
                partial = write_page(QUICK_DIR / "report.interrupted.md", results, args.quick, stamp)
                print(f"dsmv-report: interrupted; the checks done so far are in {partial}", file=sys.stderr)

                return EXIT_CODES["interrupted"]
        results.append((check, outcomes))
    stamps = None
    if args.only and not args.quick and page.with_suffix(".json").exists():
        results, stamps = merged(results, stamp, json.loads(page.with_suffix(".json").read_text()))
    write_page(page, results, args.quick, stamp, stamps)
    kept = f", {len(results) - len(checks)} kept" if stamps else ""
    print(f"dsmv-report: wrote {page} ({len(checks)} checks run{kept}, commit {stamp['commit'][:10]}, {stamp['tree']} tree)")
    return 1 if failed else 0


def merged(results: list[tuple[Check, list[Outcome]]], stamp: dict, stored: dict):
    """The checks just run (stamped ``stamp``) and, in :data:`CHECKS`' order, every other check the stored
    report holds, with its outcomes and its own stamp (a report written before checks carried one: the
    report's). A stored check no longer in :data:`CHECKS` is dropped."""
    fresh = {check.key: outcomes for check, outcomes in results}
    kept = {c["key"]: c for c in stored["checks"]}
    out, stamps = [], []
    for check in CHECKS:
        if check.key in fresh:
            out.append((check, fresh[check.key]))
            stamps.append(stamp)
        elif check.key in kept:
            out.append((check, [Outcome(**o) for o in kept[check.key]["outcomes"]]))
            stamps.append(kept[check.key].get("stamp", stored["stamp"]))
    return out, stamps


if __name__ == "__main__":
    sys.exit(main())
