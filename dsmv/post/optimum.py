"""The answer of an optimising sweep (``hydra/sweeper=optuna``; ``experiment=optimise_track``), in words and
units: what Hydra's Optuna sweeper leaves in ``optimization_results.yaml`` (the best trial's parameters
and objective, a bare number) read beside the trials' own results.

For ``objective.name: contact_area_m2`` (:mod:`dsmv.config.objective`) the summary gives the best
track's B and L (m) and contact area (m²), its max sinkage (m) against ``objective.sinkage_limit_m``
with the margin, and, when the best trial sank past the limit (the penalty let a smaller area win),
the smallest area that stayed under it. For any other objective, the best parameters and the
objective with its unit. Then the trials by status and the results file. Nothing here runs a solver.
"""

from __future__ import annotations

import math
from collections import Counter
from pathlib import Path

from omegaconf import OmegaConf

from dsmv.config.objective import CONTACT_AREA, ObjectiveConfig
from dsmv.post.studies import Job, sweep_jobs
from dsmv.results import EXIT_SEVERITY

#: what Hydra's Optuna sweeper writes into the sweep dir at its end
OPTIMIZATION_RESULTS_FILE = "optimization_results.yaml"
WIDTH, LENGTH = "geometry.width_m", "geometry.contact_length_m"


def best_job(jobs: list[Job], best_params: dict) -> Job | None:
    """The trial whose swept values are ``best_params`` (an ok one first, should two share them)."""
    def matches(job: Job) -> bool:
        try:
            return all(math.isclose(float(job.values[key]), float(value), rel_tol=1e-12)
                       for key, value in best_params.items())
        except (KeyError, ValueError):
            return False

    found = [job for job in jobs if matches(job)]
    return next((job for job in found if job.ok), found[0] if found else None)


def job_geometry(job: Job) -> dict:
    """The job's ``geometry`` as it ran (its ``.hydra/config.yaml``, resolved), or {}."""
    try:
        config = OmegaConf.load(job.path / ".hydra" / "config.yaml")
        return OmegaConf.to_container(config.geometry, resolve=True)
    except Exception:
        return {}


def trial_tally(jobs: list[Job], trials: int | None) -> str:
    """``24 (20 ok, 3 bearing_failure, 1 failed)``, or ``3 of 4 run (…)`` when some never ran."""
    counts = Counter(job.result["status"] for job in jobs)
    order = [*reversed(EXIT_SEVERITY), *sorted(set(counts) - set(EXIT_SEVERITY))]
    statuses = ", ".join(f"{counts[s]} {s}" for s in order if counts[s]) or "none ran"
    if trials is not None and trials != len(jobs):
        return f"{len(jobs)} of {trials} run ({statuses})"
    return f"{len(jobs)} ({statuses})"


def _area(job: Job) -> tuple[float, float, float]:
    geometry = job_geometry(job)
    width, length = float(geometry.get("width_m", math.nan)), float(geometry.get("contact_length_m", math.nan))
    return width, length, width * length


def optimum_summary(sweep_dir: Path, objective: ObjectiveConfig, trials: int | None = None,
                    study: str = "optimum") -> list[str] | None:
    """The lines that end an optimising sweep, or None when the sweep left no ``optimization_results.yaml``."""
    path = (Path(sweep_dir) / OPTIMIZATION_RESULTS_FILE).resolve()
    if not path.is_file():
        return None
    results = OmegaConf.to_container(OmegaConf.load(path), resolve=True)
    jobs = sweep_jobs(sweep_dir)
    tally = f"  trials   : {trial_tally(jobs, trials)}"
    where = f"  results  : {path}"
    if "best_params" not in results:  # several objectives: a Pareto front, no single best
        return [f"dsmv: {study}: {len(results.get('solutions', []))} Pareto-optimal trials", tally, where]
    best_params = results["best_params"]
    job = best_job(jobs, best_params)
    if job is None or not job.ok:
        what = f"job {job.name} ended {job.result['status']}: {job.result['message']}" if job else "its job is missing"
        params = ", ".join(f"{k} = {v:.4g}" for k, v in best_params.items())
        return [f"dsmv: {study}: no trial ended ok; the best proposed ({params}) {what}", tally, where]

    if objective.name != CONTACT_AREA:
        name, value = objective.name, job.metric(objective.name)
        unit = job.result.get("units", {}).get(name, "")
        params = ", ".join(f"{k} = {v:.4g}" for k, v in best_params.items())
        return [f"dsmv: {study}: best {name} = {value:.4g}{f' {unit}' if unit and unit != '-' else ''} (job {job.name})",
                f"  best     : {params}", tally, where]

    width, length, area = _area(job)
    limit, sinkage = float(objective.sinkage_limit_m), job.metric("max_sinkage_m")
    margin = limit - sinkage
    lines = [f"dsmv: {study}: " + (f"the smallest track found under the sinkage limit (job {job.name})" if margin >= 0
                                   else f"the best trial (job {job.name}) sinks past the limit"),
             f"  best     : B = {width:.4f} m, L = {length:.4f} m, contact area B·L = {area:.3f} m²",
             f"  sinkage  : max {sinkage:.4f} m against the limit {limit:g} m: "
             + (f"margin {margin:.4f} m" if margin >= 0 else f"over it by {-margin:.4f} m")]
    if margin < 0:  # the penalty let a smaller area beat every trial under the limit
        under = [(a, j, w, l) for j in jobs if j.ok and j.metric("max_sinkage_m") <= limit
                 for w, l, a in [_area(j)] if math.isfinite(a)]
        if under:
            a, j, w, l = min(under, key=lambda u: u[0])
            lines.append(f"  under it : the smallest area that stayed under the limit: B = {w:.4f} m, L = {l:.4f} m, "
                         f"{a:.3f} m², max sinkage {j.metric('max_sinkage_m'):.4f} m (job {j.name})")
        else:
            lines.append("  under it : no trial stayed under the limit")
    return [*lines, tally, where]
