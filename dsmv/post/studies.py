"""Sweep-level summaries of the parametric studies: tables and plots from the jobs' outputs.

Each function reads a finished sweep dir (one sub-dir per job with ``result.json`` and
``.hydra/overrides.yaml``) and writes a CSV and a PNG next to the jobs; the sweep callback
logs both to the sweep's parent MLflow run. Nothing here runs a solver.

- :func:`one_at_a_time` — the reference study's Figures 7, 9 and 11: max sinkage against
  each parameter varied alone (``hydra.sweeper.vary``), and the direction of each trend.
- :func:`compare_analytic` — Figure 14: CEL against the energy method, case by case, with
  the gap split into what the mechanics adds (CEL with Tresca against the energy method:
  embedment, side shear, soil inertia, the track's real shape) and what the soil law adds
  (Einav–Randolph against Tresca in the CEL: softening and rate).
- :func:`mesh_study` — Table 2 and Figure 6: resistance against depth for each core cell size,
  its relative error against the finest mesh, and wall times.
- :func:`section_factors` — the 2D cross-section against the 3D track, the gap as a product of
  factors, each measured on its own scene (``compare_2d_3d``).
- :func:`bearing_curves` — the verification pushes (``verify_prandtl``, ``verify_tbar``): q/su
  against travel for each job, beside the exact factors and the embedded strip's bounds.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from omegaconf import OmegaConf

from dsmv.analytic.bearing import (NOTCHED_STRIP_LOWER_BOUND_AT_0P05B, PRANDTL_NC, STRIP_LOWER_BOUND_AT_0P05B,
                                   TBAR_NC, embedded_strip_upper_bound, green_radial_factor, green_vertical)
from dsmv.convergence import richardson
from dsmv.results import HISTORY_FILE, RESULT_FILE


@dataclass
class Job:
    """One finished job of a sweep."""

    name: str
    overrides: list[str]
    result: dict
    path: Path
    values: dict[str, str] = field(default_factory=dict)  # override key → value, as written

    @property
    def ok(self) -> bool:
        return self.result["status"] == "ok"

    def metric(self, name: str) -> float:
        return float(self.result["metrics"].get(name, np.nan))

    def history(self) -> dict[str, np.ndarray] | None:
        path = self.path / HISTORY_FILE
        if not path.exists():
            return None
        table = np.genfromtxt(path, delimiter=",", names=True)
        return {name: np.atleast_1d(table[name]) for name in table.dtype.names}


def sweep_jobs(sweep_dir: Path) -> list[Job]:
    """Every job below a sweep dir that wrote result.json, in job order."""
    jobs = []
    for result_file in Path(sweep_dir).glob(f"*/{RESULT_FILE}"):
        job_dir = result_file.parent
        overrides_file = job_dir / ".hydra" / "overrides.yaml"
        overrides = [str(o) for o in OmegaConf.load(overrides_file)] if overrides_file.exists() else []
        values = dict(o.split("=", 1) for o in overrides if "=" in o)
        jobs.append(Job(job_dir.name, overrides, json.loads(result_file.read_text()), job_dir, values))
    return sorted(jobs, key=lambda job: (0, int(job.name)) if job.name.isdigit() else (1, job.name))


def _sweep_config(sweep_dir: Path):
    """The config the sweep ran with (saved by Hydra's sweeper as multirun.yaml), or None."""
    saved = Path(sweep_dir) / "multirun.yaml"
    return OmegaConf.load(saved) if saved.exists() else None


def _sweeper_vary(config) -> dict[str, list]:
    """The sweep's ``hydra.sweeper.vary`` block: {parameter: [values]}."""
    vary = config.hydra.sweeper.get("vary") if config is not None else None
    return OmegaConf.to_container(vary) if vary else {}


def trend(values: list[float], sinkages: list[float]) -> str:
    """``up`` / ``down`` when sinkage moves strictly one way as the parameter grows, else ``mixed``."""
    order = np.argsort(values)
    steps = np.diff(np.asarray(sinkages, dtype=float)[order])
    if len(steps) and np.all(steps > 0):
        return "up"
    if len(steps) and np.all(steps < 0):
        return "down"
    return "mixed"


def one_at_a_time(sweep_dir: Path, path: Path) -> Path | None:
    """Max sinkage against each parameter varied alone; writes ``one_at_a_time.csv`` and the PNG.

    The CSV has one row per job (parameter, value, status, max_sinkage_m, wall_s) and one
    ``trend`` row per parameter (``up``, ``down`` or ``mixed`` over the ``ok`` runs; a
    parameter with any non-``ok`` run is ``incomplete``).
    """
    config = _sweep_config(sweep_dir)
    jobs, vary = sweep_jobs(sweep_dir), _sweeper_vary(config)
    if not jobs or not vary:
        return None
    rows, panels = [], {}
    for key in vary:
        varied = [job for job in jobs if key in job.values]
        points = [(float(job.values[key]), job.metric("max_sinkage_m"), job) for job in varied]
        points.sort(key=lambda p: p[0])
        panels[key] = points
        for value, sinkage, job in points:
            rows.append({"parameter": key, "value": value, "status": job.result["status"],
                         "max_sinkage_m": sinkage, "wall_s": job.metric("wall_s")})
        complete = points and all(job.ok for _, _, job in points)
        direction = trend([p[0] for p in points], [p[1] for p in points]) if complete else "incomplete"
        rows.append({"parameter": key, "value": "", "status": "trend", "max_sinkage_m": "", "wall_s": "",
                     "trend": direction})
    _write_csv(Path(path).with_suffix(".csv"), rows)

    plt = _pyplot()
    fig, axes = plt.subplots(1, len(panels), figsize=(3.6 * len(panels), 3.6), constrained_layout=True,
                             squeeze=False)
    for ax, (key, points) in zip(axes[0], panels.items()):
        good = [(v, s) for v, s, job in points if job.ok]
        bad = [(v, job.result["status"]) for v, s, job in points if not job.ok]
        if good:
            ax.plot(*zip(*good), "o-", color="tab:blue")
        for value, status in bad:
            ax.axvline(value, color="tab:red", ls=":", lw=1)
            ax.annotate(status, (value, 0.5), xycoords=("data", "axes fraction"), rotation=90, fontsize=7,
                        color="tab:red")
        ax.set_xlabel(key)
        ax.set_ylabel("max sinkage (m)")
        ax.grid(alpha=0.3)
    fig.suptitle(f"{config.get('study', '')}: max sinkage, one parameter at a time around the default scene "
                 f"({config.soil.law}, core cells {config.mesh.cell_size_m} m)", fontsize=9)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return Path(path)


def compare_analytic(sweep_dir: Path, path: Path) -> Path | None:
    """CEL against the energy method and the fast landing model per case; writes
    ``compare_analytic.csv`` and the PNG.

    A case is a job's overrides without ``solver`` and ``soil.law``. Per case: the energy
    method's sinkage, the CEL's with Tresca and with Einav–Randolph, the relative difference
    (CEL Einav–Randolph against the energy method), and its two parts: mechanics
    (CEL Tresca / energy − 1) and soil law (CEL Einav–Randolph / CEL Tresca − 1). Where the sweep
    also ran ``solver=analytic_dynamic``: its sinkage with each law and its error against the CEL
    with the same law.
    """
    jobs = sweep_jobs(sweep_dir)
    # a case: what sets a job apart from the others, apart from its solver and law
    shared = set.intersection(*(set(job.overrides) for job in jobs)) if jobs else set()
    cases: dict[str, dict[tuple[str, str], Job]] = {}
    for job in jobs:
        case = " ".join(o for o in job.overrides if o not in shared and o.split("=", 1)[0] not in ("solver", "soil.law"))
        cases.setdefault(case, {})[job.values.get("solver", "cel2d"), job.values.get("soil.law", "tresca")] = job
    rows = []
    for number, (case, by_run) in enumerate(cases.items(), start=1):
        analytic = by_run.get(("analytic_energy", "einav_randolph")) or by_run.get(("analytic_energy", "tresca"))
        softening = by_run.get(("cel2d", "einav_randolph"))
        if analytic is None or softening is None:
            continue

        def sinkage(job):
            return job.metric("max_sinkage_m") if job is not None and job.ok else np.nan

        z_a, z_t, z_er = sinkage(analytic), sinkage(by_run.get(("cel2d", "tresca"))), sinkage(softening)
        row = {"case": number, "overrides": case, "analytic_m": z_a, "cel_tresca_m": z_t,
               "cel_einav_randolph_m": z_er, "relative_difference": z_er / z_a - 1,
               "mechanics_part": z_t / z_a - 1, "soil_law_part": z_er / z_t - 1,
               "cel_status": softening.result["status"]}
        if ("analytic_dynamic", "einav_randolph") in by_run:
            z_d, z_dt = (sinkage(by_run.get(("analytic_dynamic", law))) for law in ("einav_randolph", "tresca"))
            row |= {"dynamic_m": z_d, "dynamic_tresca_m": z_dt, "dynamic_error": z_d / z_er - 1,
                    "dynamic_tresca_error": z_dt / z_t - 1}
        if ("cel3d", "einav_randolph") in by_run:  # the track in 3D beside its cross-section
            z_3, z_3t = (sinkage(by_run.get(("cel3d", law))) for law in ("einav_randolph", "tresca"))
            row |= {"cel3d_einav_randolph_m": z_3, "cel3d_tresca_m": z_3t, "cel3d_over_cel2d": z_3 / z_er,
                    "cel3d_over_cel2d_tresca": z_3t / z_t}
        rows.append(row)
    if not rows:
        return None
    _write_csv(Path(path).with_suffix(".csv"), rows)

    plt = _pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.5), constrained_layout=True)
    z_a = np.array([r["analytic_m"] for r in rows])
    z_t = np.array([r["cel_tresca_m"] for r in rows])
    z_er = np.array([r["cel_einav_randolph_m"] for r in rows])
    z_d = np.array([r.get("dynamic_m", np.nan) for r in rows])
    z_3 = np.array([r.get("cel3d_einav_randolph_m", np.nan) for r in rows])
    top = 1.15 * np.nanmax(np.concatenate([z_a, z_t, z_er, z_d, z_3]))
    line = np.array([0, top])
    left.plot(line, line, "k-", lw=1, label="equal")
    left.fill_between(line, 0.85 * line, 1.15 * line, color="0.88", label="±15 %")
    left.plot(z_a, z_er, "s", color="tab:blue", label="energy method, CEL Einav–Randolph")
    left.plot(z_a, z_t, "o", mfc="none", color="tab:gray", label="energy method, CEL Tresca")
    if np.isfinite(z_d).any():
        left.plot(z_d, z_er, "^", color="tab:red", label="fast model (analytic_dynamic), CEL Einav–Randolph")
    if np.isfinite(z_3).any():
        left.plot(z_a, z_3, "D", mfc="none", color="tab:green", label="energy method, CEL 3D track Einav–Randolph")
    for r in rows:
        left.annotate(str(r["case"]), (r["analytic_m"], r["cel_einav_randolph_m"]), fontsize=7,
                      xytext=(3, 3), textcoords="offset points")
    _parity_axes(left, top, "model sinkage (m)", "CEL max sinkage (m)")
    index = np.arange(len(rows))
    right.bar(index - 0.2, [100 * r["mechanics_part"] for r in rows], 0.4, label="mechanics (CEL Tresca / energy)")
    right.bar(index + 0.2, [100 * r["soil_law_part"] for r in rows], 0.4, label="soil law (E–R / Tresca)")
    right.plot(index, [100 * r["relative_difference"] for r in rows], "kD", label="total (E–R / energy)")
    if np.isfinite(z_d).any():
        right.plot(index, [100 * r["dynamic_error"] for r in rows], "^", color="tab:red",
                   label="fast model / CEL E–R")
    right.axhline(0, color="k", lw=0.8)
    right.set_xticks(index, [str(r["case"]) for r in rows])
    right.set_xlabel("case")
    right.set_ylabel("difference (%)")
    right.legend(fontsize=8)
    right.grid(alpha=0.3, axis="y")
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return Path(path)


#: the scenes of ``compare_2d_3d`` in order, each told by its overrides, and what its factor on the
#: scene before it measures
SECTION_SCENES = (
    ("cross-section (cel2d)", lambda v: v.get("solver") == "cel2d", ""),
    ("cross-section as a 3D slab", lambda v: v.get("geometry") == "strip", "the 3D solver itself"),
    ("flat plate B × L", lambda v: v.get("geometry") == "rectangular_plate", "the ends of a finite L"),
    ("track, no grousers", lambda v: v.get("geometry.grouser_height_m") in ("0", "0.0"), "the sprocket arcs"),
    ("track", lambda v: v.get("solver") == "cel3d" and "geometry" not in v and "geometry.grouser_height_m" not in v,
     "the grousers"),
)


def _answer(job: Job) -> tuple[float, float]:
    """A job's max sinkage and its mesh error (m): the extrapolated answer when the job estimated it
    (``solver.error_estimate``), else its own mesh's with no error known (NaN)."""
    if not job.ok:
        return np.nan, np.nan
    extrapolated = job.metric("max_sinkage_extrapolated_m")
    if np.isfinite(extrapolated):
        return extrapolated, job.metric("max_sinkage_error_m")
    return job.metric("max_sinkage_m"), np.nan


def _ratio(top: tuple[float, float], bottom: tuple[float, float]) -> tuple[float, float]:
    """top / bottom and its error, the two mesh errors taken as independent."""
    ratio = top[0] / bottom[0]
    return ratio, abs(ratio) * math.hypot(top[1] / top[0], bottom[1] / bottom[0])


def section_factors(sweep_dir: Path, path: Path) -> Path | None:
    """The 2D cross-section against the 3D track: each scene's max sinkage and its factor on the scene
    before it (the section as a 3D slab over the section: the 3D solver itself; a flat plate over the
    slab: its finite length; the track without grousers over the plate: the sprocket arcs; the track
    over that: its grousers); writes ``section_factors.csv`` (with the factors' product, the track over
    the section) and the PNG. With ``solver.error_estimate`` every sinkage is the extrapolated answer
    and every factor carries the error of its two answers (m)."""
    jobs = sweep_jobs(sweep_dir)
    found = [(name, why, next((job for job in jobs if test(job.values)), None)) for name, test, why in SECTION_SCENES]
    if any(job is None for _, _, job in found):
        return None
    rows, answers = [], []
    for name, why, job in found:
        answer = _answer(job)
        factor = _ratio(answer, answers[-1]) if answers else ("", "")
        answers.append(answer)
        rows.append({"scene": name, "status": job.result["status"], "max_sinkage_m": answer[0],
                     "mesh_error_m": answer[1], "finest_mesh_sinkage_m": job.metric("max_sinkage_m"),
                     "core_cell_size_m": job.metric("core_cell_size_m"), "cells": job.metric("cells"),
                     "wall_s": job.metric("wall_s"), "factor": factor[0], "factor_error": factor[1], "measures": why})
    # the factors' product is the track over the section: only the two ends' errors remain
    product, product_error = _ratio(answers[-1], answers[0])
    rows.append({"scene": "product: track / cross-section", "status": "", "max_sinkage_m": "", "mesh_error_m": "",
                 "finest_mesh_sinkage_m": "", "core_cell_size_m": "", "cells": "", "wall_s": "", "factor": product,
                 "factor_error": product_error, "measures": "the whole gap"})
    _write_csv(Path(path).with_suffix(".csv"), rows)

    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8.5, 4), constrained_layout=True)
    scenes = rows[:-1]
    index = np.arange(len(scenes))
    values = [r["max_sinkage_m"] for r in scenes]
    errors = [r["mesh_error_m"] if np.isfinite(r["mesh_error_m"]) else 0.0 for r in scenes]
    ax.bar(index, values, 0.6, yerr=errors, capsize=3, color=["tab:gray"] + ["tab:blue"] * (len(scenes) - 1))
    for i, r in enumerate(scenes):
        label = f"{r['max_sinkage_m']:.4f} m" + (f"\n×{r['factor']:.3f}\n{r['measures']}" if r["factor"] != "" else "")
        ax.annotate(label, (i, r["max_sinkage_m"] + errors[i]), ha="center", va="bottom", fontsize=7, xytext=(0, 2),
                    textcoords="offset points")
    ax.set_xticks(index, [r["scene"] for r in scenes], fontsize=7)
    extrapolated = all(np.isfinite(errors_m) for errors_m in (r["mesh_error_m"] for r in scenes))
    ax.set_ylabel("max sinkage, extrapolated ± mesh error (m)" if extrapolated else "max sinkage (m)")
    ax.set_ylim(0, 1.3 * np.nanmax(values))
    ax.set_title(f"2D cross-section to 3D track: ×{product:.3f}"
                 + (f" ± {product_error:.3f}" if np.isfinite(product_error) else "")
                 + f" (finest core cells {scenes[0]['core_cell_size_m']:.3g} m)", fontsize=9)
    ax.grid(alpha=0.3, axis="y")
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return Path(path)


def mesh_study(sweep_dir: Path, path: Path) -> Path | None:
    """Max sinkage against core cell size with its extrapolated value, resistance against depth per
    core cell size, relative error against the finest, wall times.

    Writes ``mesh_study.csv``: per mesh the cell size, status, max sinkage and its error against
    the finest mesh, wall time, cells, and the mean and largest relative error of the energy
    the soil has absorbed, E(z) = ∫ R dz, against the finest mesh over the depths all runs
    reached (excluding the first 10 %). E(z) rather than R(z) itself: a landing's resistance
    rings with elastic waves, and pointwise ratios of ringing curves measure the phase of the
    ringing, not the mesh.
    """
    jobs = [job for job in sweep_jobs(sweep_dir) if "mesh.cell_size_m" in job.values]
    curves = []
    for job in jobs:
        history = job.history()
        if history is None or not job.ok:
            continue
        # the loading branch only: up to the max sinkage, where the curve is single-valued
        end = int(np.argmax(history["sinkage_m"])) + 1
        curves.append((float(job.values["mesh.cell_size_m"]), job, history["sinkage_m"][:end],
                       history["force_n"][:end]))
    if not curves:
        return None
    curves.sort(key=lambda c: c[0])
    reference_depth, reference_force = curves[0][2], curves[0][3]
    # the depths every run went through, less the first tenth (a trapped-soil track starts below the mudline)
    start, reach = max(c[2][0] for c in curves), min(c[2].max() for c in curves)
    depths = np.linspace(start + 0.1 * (reach - start), reach, 50)
    reference = np.interp(depths, *_absorbed_energy(reference_depth, reference_force))
    finest_sinkage = curves[0][1].metric("max_sinkage_m")
    rows, errors = [], []
    for size, job, depth, force in curves:
        error = np.abs(np.interp(depths, *_absorbed_energy(depth, force)) / reference - 1)
        errors.append(error)
        rows.append({"cell_size_m": size, "status": job.result["status"], "max_sinkage_m": job.metric("max_sinkage_m"),
                     "sinkage_error": job.metric("max_sinkage_m") / finest_sinkage - 1,
                     "wall_s": job.metric("wall_s"), "cells": job.metric("cells"),
                     "mean_relative_error": float(error.mean()), "max_relative_error": float(error.max())})
    _write_csv(Path(path).with_suffix(".csv"), rows)

    plt = _pyplot()
    fig, (sinkage_ax, curve_ax, error_ax, time_ax) = plt.subplots(1, 4, figsize=(18, 4.2), constrained_layout=True)
    _plot_sinkage_against_cell_size(sinkage_ax, rows)
    for (size, job, depth, force), error in zip(curves, errors):
        curve_ax.plot(depth, force / 1e3, label=f"{size:g} m")
        error_ax.plot(depths, 100 * error, label=f"{size:g} m")
    curve_ax.set_xlabel("sinkage (m)")
    curve_ax.set_ylabel("soil resistance per track (kN)")
    curve_ax.legend(title="core cells", fontsize=8)
    error_ax.set_xlabel("sinkage (m)")
    error_ax.set_ylabel(f"|E / E({curves[0][0]:g} m) − 1| (%), E = ∫R dz")
    time_ax.bar([f"{r['cell_size_m']:g}" for r in rows], [r["wall_s"] for r in rows], color="tab:green")
    time_ax.set_xlabel("core cell size (m)")
    time_ax.set_ylabel("wall time (s)")
    for ax in (sinkage_ax, curve_ax, error_ax, time_ax):
        ax.grid(alpha=0.3)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return Path(path)


def _plot_sinkage_against_cell_size(ax, rows: list[dict]) -> None:
    """Max sinkage against core cell size, with its value extrapolated from the three finest meshes
    (Richardson with the observed order, dsmv.convergence) and that estimate's error band."""
    sizes = np.array([r["cell_size_m"] for r in rows])
    sinkages = np.array([r["max_sinkage_m"] for r in rows])
    ax.plot(sizes, sinkages, "o-", color="tab:blue", label="max sinkage")
    if len(rows) >= 3:
        estimate = richardson(tuple(sizes[:3]), tuple(sinkages[:3]))
        ax.axhline(estimate.extrapolated, color="k", ls="--", lw=1,
                   label=f"extrapolated {estimate.extrapolated:.4f} ± {estimate.error:.4f} m (order {estimate.order:.2f})")
        ax.axhspan(estimate.extrapolated - estimate.error, estimate.extrapolated + estimate.error, color="k", alpha=0.08)
    ax.set_xlim(left=0.0)
    ax.set_xlabel("core cell size (m)")
    ax.set_ylabel("max sinkage (m)")
    ax.legend(fontsize=8)


def bearing_curves(sweep_dir: Path, path: Path) -> Path | None:
    """q/su against travel/B for each push of a sweep, with the truths it is checked against.

    q is the soil's force over the body's width times its length, B·L (a T-bar: D·L), and su its
    ``soil.su0_pa``. A strip is drawn with Prandtl's 2 + π, the upper bounds of the same strip
    wished in place at depth s (:func:`~dsmv.analytic.bearing.embedded_strip_upper_bound`: the
    embedment alone, no heave) and, at s = 0.05 B, the limit analysis's bounds: for pushes whose
    soil may part from the walls (``solver.contact_separation``), the lower bound of the strip with
    the notch it opens beside them; for pushes tied to the walls, the bracket on the strip wished in
    place with the soil tied to them. A T-bar is drawn with its exact deep factor. Writes
    ``bearing_curves.csv`` (each job's roughness, contact separation, cell size, push speed, q/su at
    its last sample ``nc_end``, its ``nc_*`` metrics and wall time) and the PNG. Jobs that are not
    pushes of a strip or a T-bar are left out.
    """
    curves, rows, separations = [], [], set()
    for job in sweep_jobs(sweep_dir):
        history, config_file = job.history(), job.path / "config_resolved.yaml"
        if history is None or not config_file.exists():
            continue
        config = OmegaConf.load(config_file)
        body, soil = config.geometry, config.soil
        if config.landing.kind != "push" or body.kind not in ("strip", "tbar"):
            continue
        # a push parts from the walls only when asked (auto: landings only; the key is newer than some runs)
        separation = OmegaConf.select(config, "solver.contact_separation", default=False) is True
        if body.kind == "strip":
            separations.add(separation)
        scale = float(soil.su0_pa) * float(body.width_m) * float(body.contact_length_m)
        label = f"{body.roughness}, h = {float(config.mesh.cell_size_m):g} m, {float(config.landing.velocity_m_s):g} m/s"
        nc = history["force_n"] / scale
        curves.append((body.kind, str(body.roughness), label, history["sinkage_m"] / float(body.width_m), nc))
        rows.append({"job": job.name, "status": job.result["status"], "body": body.kind,
                     "roughness": body.roughness, "contact_separation": separation,
                     "cell_size_m": float(config.mesh.cell_size_m),
                     "velocity_m_s": float(config.landing.velocity_m_s), "nc_end": float(nc[-1]),
                     **{k: job.metric(k) for k in ("nc_at_0p02B", "nc_at_0p05B", "nc_at_0p1B", "nc_at_1B", "nc_deep",
                                                  "nc_roughness", "wall_s") if k in job.result["metrics"]}})
    if not curves:
        return None
    _write_csv(Path(path).with_suffix(".csv"), rows)

    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7.5, 4.8), constrained_layout=True)
    for kind, roughness, label, travel, nc in curves:
        ax.plot(travel, nc, label=label)
    travel_max = max(c[3].max() for c in curves)
    kinds = {c[0] for c in curves}
    if "strip" in kinds:
        ax.axhline(PRANDTL_NC, color="k", lw=1, label="Prandtl 2 + π (surface)")
        s = np.linspace(0.0, travel_max, 50)
        for rough, style in ((True, "--"), (False, ":")):
            ax.plot(s, [embedded_strip_upper_bound(d, rough) for d in s], "k" + style, lw=1,
                    label=f"upper bound, wished in place at s, {'rough' if rough else 'smooth'} walls")
        if False in separations:
            for offset, (roughness, lower) in enumerate(STRIP_LOWER_BOUND_AT_0P05B.items()):
                upper = embedded_strip_upper_bound(0.05, roughness == "rough")
                ax.errorbar(0.05 + 0.02 * (offset - 0.5) * travel_max, 0.5 * (lower + upper),
                            yerr=0.5 * (upper - lower), fmt="none", ecolor=("k", "0.5")[offset], elinewidth=2,
                            capsize=3, label=f"{roughness}, wished in place 0.05 B deep, soil tied to the walls: "
                                             f"{lower}–{upper:.3f}")
        if True in separations:
            for offset, (roughness, lower) in enumerate(NOTCHED_STRIP_LOWER_BOUND_AT_0P05B.items()):
                ax.plot([0.05 + 0.02 * (offset - 0.5) * travel_max], [lower], "^", color=("k", "0.5")[offset],
                        label=f"{roughness}, pushed 0.05 B, soil free to part from the walls: ≥ {lower}")
    if "tbar" in kinds:
        for roughness in sorted({c[1] for c in curves} & set(TBAR_NC)):
            ax.axhline(TBAR_NC[roughness], color="k", lw=1, ls="--" if roughness == "rough" else ":",
                       label=f"exact, {roughness}: {TBAR_NC[roughness]}")
    ax.set_xlabel({frozenset({"strip"}): "travel / B (-)", frozenset({"tbar"}): "travel / D (-)"}.get(
        frozenset(kinds), "travel / B or D (-)"))
    ax.set_ylabel("q / su (-)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return Path(path)


def _absorbed_energy(depth: np.ndarray, force: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """E(z) = ∫ R dz (J) on strictly increasing depths, as np.interp needs."""
    energy = np.concatenate([[0.0], np.cumsum(0.5 * (force[1:] + force[:-1]) * np.diff(depth))])
    keep = np.concatenate([[True], np.diff(np.maximum.accumulate(depth)) > 0])
    return depth[keep], energy[keep]


def green_envelope(sweep_dir: Path, path: Path) -> Path | None:
    """The end loads of a sweep's probes of a strip (``verify_green``) in the (H, V)/(B·su) plane, beside
    Green's (1954) exact envelope, per cell size, with the points extrapolated at first order from each
    direction's two finest cells (the corner's one-cell wedge makes the error first order). Writes
    ``green_envelope.csv`` (each probe's cell size, push direction, h, v and λ, its radial distance from
    the envelope: 1 on it; then the extrapolated points) and the PNG. A vertical push gives its
    ``nc_at_0p05B`` at h = 0."""
    probes = {}
    for job in sweep_jobs(sweep_dir):
        config_file = job.path / "config_resolved.yaml"
        if job.result["status"] != "ok" or not config_file.exists():
            continue
        config = OmegaConf.load(config_file)
        if config.landing.kind != "push" or config.geometry.kind != "strip":
            continue
        down = float(config.landing.velocity_m_s)
        across = float(OmegaConf.select(config, "landing.horizontal_velocity_m_s", default=0.0))
        if "end_vertical_factor" in job.result["metrics"]:
            h, v = job.metric("end_horizontal_factor"), job.metric("end_vertical_factor")
        else:
            h, v = 0.0, job.metric("nc_at_0p05B")
        direction = round(math.degrees(math.atan2(down, across)), 2)
        probes.setdefault(direction, {})[float(config.mesh.cell_size_m)] = (abs(h), v)
    if not probes:
        return None
    rows = [{"direction_deg": d, "cell_size_m": cell, "h": h, "v": v, "lambda": green_radial_factor(h, v)}
            for d, cells in sorted(probes.items()) for cell, (h, v) in sorted(cells.items())]
    extrapolated = []
    for d, cells in sorted(probes.items()):
        if len(cells) >= 2:
            fine, coarse = sorted(cells)[:2]
            ratio = coarse / fine
            point = [(ratio * a - b) / (ratio - 1.0) for a, b in zip(cells[fine], cells[coarse])]
            extrapolated.append((d, *point))
            rows.append({"direction_deg": d, "cell_size_m": 0.0, "h": point[0], "v": point[1],
                         "lambda": green_radial_factor(min(max(point[0], 0.0), 1e9), point[1])})
    _write_csv(Path(path).with_suffix(".csv"), rows)

    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7.0, 4.8), constrained_layout=True)
    hs = np.linspace(0.0, 1.0, 200)
    ax.plot(np.append(hs, 1.0), np.append([green_vertical(x) for x in hs], 0.0), "k-", lw=1.2,
            label="Green (1954): 1 + π − arcsin h + √(1 − h²); sliding at h = 1")
    for cell in sorted({c for cells in probes.values() for c in cells}, reverse=True):
        points = np.array([cells[cell] for cells in probes.values() if cell in cells])
        ax.plot(points[:, 0], points[:, 1], "o", ms=5, label=f"CEL, core cells {cell:g} m")
    if extrapolated:
        points = np.array([p[1:] for p in extrapolated])
        ax.plot(points[:, 0], points[:, 1], "k*", ms=10, label="extrapolated from the two finest")
    ax.set_xlabel("H / (B·su) (-)")
    ax.set_ylabel("V / (B·su) (-)")
    ax.set_xlim(0.0, 1.3)
    ax.set_ylim(0.0, 5.6)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower left")
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return Path(path)


def _write_csv(path: Path, rows: list[dict]) -> Path:
    columns = list(dict.fromkeys(k for row in rows for k in row))
    with Path(path).open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows)
    return Path(path)


def _parity_axes(ax, top: float, xlabel: str, ylabel: str) -> None:
    """One answer against another on equal axes from 0 to ``top``."""
    ax.set_xlim(0, top)
    ax.set_ylim(0, top)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def safe_region(sweep_dir: Path, path: Path) -> Path | None:
    """The verdicts of a sweep over two parameters (``hydra.sweeper.params``, the first across, the second
    up) as a map of the safe region: each landing safe or unsafe and why (the limits it broke), and
    the line where the smallest margin, each taken over its limit, passes 0 (interpolated between the
    landings). Writes ``safe_region.csv`` (per landing: both values, status, ``safe``, each margin) and the
    PNG. None without two swept parameters or a judged landing."""
    config = _sweep_config(sweep_dir)
    params = list(OmegaConf.to_container(config.hydra.sweeper.get("params") or {})) if config is not None else []
    jobs = [job for job in sweep_jobs(sweep_dir) if len(params) >= 2 and all(p in job.values for p in params[:2])]
    if len(params) < 2 or not any("safe" in job.result["metrics"] for job in jobs):
        return None
    across, up = params[:2]
    limits = {what: float(config.safety[key]) for key, what in (("max_sinkage_m", "sinkage"), ("max_tilt_deg", "tilt"),
              ("max_slide_m", "slide"), ("max_deceleration_g", "deceleration")) if config.safety.get(key) is not None}
    rows, points = [], []
    for job in jobs:
        x, y = float(job.values[across]), float(job.values[up])
        margins = {what: job.metric(f"safety_margin_{what}") for what in limits}
        broken = [what for what, margin in margins.items() if margin < 0.0]
        if job.result["status"] == "bearing_failure":
            broken.append("the soil did not stop it")
        worst = min((margin / limits[what] for what, margin in margins.items()), default=np.nan)
        safe = job.metric("safe") == 1.0
        rows.append({across: x, up: y, "status": job.result["status"], "safe": int(safe),
                     **{f"margin_{what}": margin for what, margin in margins.items()},
                     "broken": " & ".join(broken)})
        points.append((x, y, safe, worst, " & ".join(broken)))
    rows.sort(key=lambda r: (r[across], r[up]))
    _write_csv(Path(path).with_suffix(".csv"), rows)

    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.8), constrained_layout=True)
    xs, ys = sorted({p[0] for p in points}), sorted({p[1] for p in points})
    grid = np.full((len(ys), len(xs)), np.nan)
    for x, y, _, worst, _ in points:
        grid[ys.index(y), xs.index(x)] = worst
    if len(xs) > 1 and len(ys) > 1 and np.isfinite(grid).sum() >= 4:
        ax.contourf(xs, ys, grid, levels=[-np.inf, 0.0, np.inf], colors=["#f4c7c3", "#cfe8cf"], alpha=0.8)
        ax.contour(xs, ys, grid, levels=[0.0], colors="k", linewidths=1.2)
    causes = sorted({p[4] for p in points if not p[2]})
    markers = dict(zip(causes, "xsd^v<>p*h"))
    ax.plot([p[0] for p in points if p[2]], [p[1] for p in points if p[2]], "o", color="tab:green", label="safe")
    for cause in causes:
        chosen = [p for p in points if not p[2] and p[4] == cause]
        ax.plot([p[0] for p in chosen], [p[1] for p in chosen], markers[cause], color="tab:red",
                label=f"unsafe: {cause or 'not judged'}")
    ax.set_xlabel(across)
    ax.set_ylabel(up)
    judged = ", ".join(f"{what} ≤ {limit:g}" for what, limit in limits.items())
    ax.set_title(f"{config.get('study', '')}: the safe region ({judged}; the line: the smallest margin 0)",
                 fontsize=9)
    ax.legend(fontsize=7, loc="best")
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return Path(path)


#: the agreement the fast vehicle model is held to against the 3D CEL (docs/decisions/0033): sinkage
#: within this fraction, tilt within TILT_AGREEMENT_DEG or the same fraction
SINKAGE_AGREEMENT = 0.15
TILT_AGREEMENT_DEG = 1.0
#: what a vehicle study reads of each landing: the base's lowest point (as the verdict judges it), the
#: largest tilt from level, the tilt at the end and the largest slide
VEHICLE_RESPONSE = (("max_edge_sinkage_m", "deepest point of the base (m)"), ("max_rotation_deg", "largest tilt (°)"),
                    ("final_tilt_deg", "tilt at the end (°)"),
                    ("max_horizontal_displacement_m", "largest slide along the seabed (m)"))
#: keys that tilt the vehicle at touchdown: its largest tilt is then that attitude, and the tilt it is
#: compared by is the one it ends at
ATTITUDE_KEYS = ("landing.roll_deg", "landing.pitch_deg")
#: readable names of the keys a vehicle study varies
VEHICLE_KEYS = {"landing.cg_offset_m.0": "centre of gravity across the tracks (m)",
                "landing.cg_offset_m.1": "centre of gravity along the tracks (m)",
                "landing.cg_offset_m.2": "centre of gravity above the base (m)",
                "landing.roll_deg": "roll at touchdown (°)", "landing.pitch_deg": "pitch at touchdown (°)",
                "landing.horizontal_velocity_m_s": "drift across at touchdown (m/s)",
                "landing.velocity_m_s": "touchdown speed (m/s)", "soil.slope_deg": "seabed slope (°)"}


def _scene_key(job: Job, config, keys) -> frozenset:
    """The scene a job landed, told by the varied keys it set away from the sweep's base value (a
    landing at the base of two parameters' lists is one scene)."""
    moved = set()
    for key in keys:
        if key in job.values and float(job.values[key]) != float(OmegaConf.select(config, key, default=np.nan)):
            moved.add((key, float(job.values[key])))
    return frozenset(moved)


def vehicle_response(sweep_dir: Path, path: Path) -> Path | None:
    """A vehicle study, one parameter at a time (``hydra.sweeper.vary``): the base's deepest point, the
    largest tilt, the tilt at the end and the largest slide against each parameter, one line per solver. Where the sweep ran
    a CEL solver and a fast model on the same scenes, each scene's gap between them and whether it lies
    within the agreement asked of the fast vehicle model (15 % on sinkage; 1°, or 15 %, on the largest
    tilt, or on the tilt at the end for a vehicle that touched down tilted), the count in the title. Writes ``vehicle_response.csv`` (a row per landing, then a row per compared scene) and the PNG."""
    config = _sweep_config(sweep_dir)
    vary = _sweeper_vary(config)
    jobs = [job for job in sweep_jobs(sweep_dir) if any(key in job.values for key in vary)]
    if not jobs:
        return None
    rows, by_scene = [], {}
    for job in jobs:
        key = next(k for k in vary if k in job.values)
        solver = job.result.get("solver", job.values.get("solver", "?"))
        rows.append({"parameter": key, "value": float(job.values[key]), "solver": solver,
                     "status": job.result["status"], **{name: job.metric(name) for name, _ in VEHICLE_RESPONSE},
                     "wall_s": job.metric("wall_s")})
        by_scene.setdefault(_scene_key(job, config, vary), {})[solver] = rows[-1]
    solvers = list(dict.fromkeys(row["solver"] for row in rows))
    reference = next((s for s in ("cel3d", "cel2d") if s in solvers), None)
    compared = []
    for scene, by_solver in by_scene.items():
        truth = by_solver.get(reference)
        for solver, row in by_solver.items():
            if truth is None or solver == reference or not row["status"] == truth["status"] == "ok":
                continue
            tilt = "final_tilt_deg" if any(key in ATTITUDE_KEYS for key, _ in scene) else "max_rotation_deg"
            sinkage_gap = row["max_edge_sinkage_m"] / truth["max_edge_sinkage_m"] - 1
            tilt_gap = row[tilt] - truth[tilt]
            within = abs(sinkage_gap) <= SINKAGE_AGREEMENT and (
                abs(tilt_gap) <= max(TILT_AGREEMENT_DEG, SINKAGE_AGREEMENT * abs(truth[tilt])))
            compared.append({"parameter": "scene", "value": " ".join(f"{k}={v:g}" for k, v in sorted(scene)) or "base",
                             "solver": f"{solver} against {reference}", "status": "within" if within else "outside",
                             "sinkage_gap": sinkage_gap, "tilt_compared": tilt, "tilt_gap_deg": tilt_gap})
    _write_csv(Path(path).with_suffix(".csv"), rows + compared)

    plt = _pyplot()
    fig, axes = plt.subplots(len(VEHICLE_RESPONSE), len(vary), figsize=(3.4 * len(vary), 2.8 * len(VEHICLE_RESPONSE)),
                             constrained_layout=True, squeeze=False)
    markers = dict(zip(solvers, "os^Dv"))
    for column, key in enumerate(vary):
        for solver in solvers:
            points = sorted((r["value"], r) for r in rows if r["parameter"] == key and r["solver"] == solver)
            for ax, (name, label) in zip(axes[:, column], VEHICLE_RESPONSE):
                good = [(value, r[name]) for value, r in points if r["status"] == "ok"]
                if good:
                    ax.plot(*zip(*good), markers[solver] + "-", mfc="none" if solver != reference else None,
                            label=solver)
                for value, r in points:
                    if r["status"] != "ok":
                        ax.axvline(value, color="tab:red", ls=":", lw=1)
                        ax.annotate(f"{solver}: {r['status']}", (value, 0.5), xycoords=("data", "axes fraction"),
                                    rotation=90, fontsize=7, color="tab:red")
                ax.set_ylabel(label)
                ax.grid(alpha=0.3)
        axes[-1, column].set_xlabel(VEHICLE_KEYS.get(key, key))
    axes[0, 0].legend(fontsize=7)
    title = f"{config.get('study', '')}: the vehicle's deepest point and tilt, one parameter at a time"
    if compared:
        inside = sum(c["status"] == "within" for c in compared)
        title += (f"\nfast model within {SINKAGE_AGREEMENT:.0%} (sinkage) and {TILT_AGREEMENT_DEG:g}° (tilt) of "
                  f"{reference} on {inside} of {len(compared)} scenes")
    fig.suptitle(title, fontsize=9)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return Path(path)


def per_vehicle(sweep_dir: Path, path: Path) -> Path | None:
    """Each scene landed on one track carrying the whole mass (``geometry=track_pioneer_i``, the reference
    study's) and on the vehicle's two tracks (``geometry=vehicle_pioneer_i``): the two max sinkages and
    their ratio. A scene is a job's overrides without ``geometry``. Writes ``per_vehicle.csv`` and the PNG."""
    jobs = sweep_jobs(sweep_dir)
    shared = set.intersection(*(set(job.overrides) for job in jobs)) if jobs else set()
    pairs: dict[str, dict[str, Job]] = {}
    for job in jobs:
        case = " ".join(o for o in job.overrides if o not in shared and o.split("=", 1)[0] != "geometry")
        pairs.setdefault(case, {})[job.values.get("geometry", "")] = job
    rows = []
    for case, by_geometry in pairs.items():
        track, vehicle = by_geometry.get("track_pioneer_i"), by_geometry.get("vehicle_pioneer_i")
        if track is None or vehicle is None:
            continue
        one, two = (job.metric("max_sinkage_m") if job.ok else np.nan for job in (track, vehicle))
        rows.append({"scene": case, "one_track_m": one, "vehicle_m": two, "ratio": two / one,
                     "one_track_status": track.result["status"], "vehicle_status": vehicle.result["status"]})
    if not rows:
        return None
    _write_csv(Path(path).with_suffix(".csv"), rows)

    one, two = (np.array([r[k] for r in rows]) for k in ("one_track_m", "vehicle_m"))
    ratio = two / one
    plt = _pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4.3), constrained_layout=True)
    top = 1.05 * np.nanmax(np.concatenate([one, two]))
    left.plot([0, top], [0, top], "k-", lw=1, label="equal")
    left.plot(one, two, "o", ms=3, color="tab:blue", label="a scene")
    _parity_axes(left, top, "one track carrying m: max sinkage (m)", "the vehicle, m on two tracks: max sinkage (m)")
    finite = ratio[np.isfinite(ratio)]
    right.hist(finite, bins=20, color="tab:blue")
    right.set_xlabel("vehicle / one track")
    right.set_ylabel("scenes")
    right.grid(alpha=0.3)
    failed = len(rows) - len(finite)
    fig.suptitle(f"the Table 3 scenes per vehicle: {len(finite)} scenes, the vehicle sinks {np.median(finite):.2f} "
                 f"(median; {finite.min():.2f}–{finite.max():.2f}) of the one track's depth"
                 + (f"; {failed} not compared (a landing not ok)" if failed else ""), fontsize=9)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return Path(path)
