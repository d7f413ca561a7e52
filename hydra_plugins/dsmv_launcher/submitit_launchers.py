"""``hydra/launcher=dsmv_local`` and ``dsmv_slurm``: Hydra's submitit launchers, with a worker per core
on this machine, and time limits from the jobs' cost estimates.

Hydra's ``submitit_local`` starts one process per job, all of a sweep's jobs at once. Each pays
Python's start, the imports and the kernels' loading from Numba's cache, about 1.3 s of CPU, which
on the medium mesh is four times the solve. :class:`LocalLauncher` submits one submitit job per
worker instead (as many as the machine's cores hold tasks of ``cpus_per_task``), and each worker
runs the sweep's jobs in turn, taking the next unclaimed one as joblib's workers do: a job is
claimed by creating its file in the launch's claims folder, which one process only can do. Every
Hydra job still runs through the plugin's own ``__call__`` (its config composed, its own directory),
and the results come back in the sweep's order. SLURM keeps one array task per job (``dsmv_slurm``).

A SLURM array's time limit is its longest job's cost estimate with a margin (:func:`time_limit_min`),
never below ``timeout_min``: each job's config is composed and its scene sized in the sweep's
process, as the job will (:func:`dsmv.app.runner.estimated_wall_s`). A local worker's is ``timeout_min``
per job of its share: composing every job beforehand took 0.45 s a job on the busy 2-core machine
(7.2 s for 16), more than a medium-mesh job's solve, and a local run waits in no queue.
"""

from __future__ import annotations

import math
import os
import time
import uuid
from pathlib import Path
from typing import Any, Sequence

from hydra.core.singleton import Singleton
from hydra.core.utils import JobReturn, filter_overrides

from dsmv.app import interrupts

try:
    from hydra_plugins.hydra_submitit_launcher import submitit_launcher as plugin
except ImportError:  # without dsmv[cluster] there is no dsmv_local, and Hydra's plugin scan must not warn
    plugin = None

__all__ = ["LocalLauncher", "SlurmLauncher", "time_limit_min", "worker_count"]

#: a job's limit over its cost estimate (dsmv.cel.cost, from measured throughputs): the estimates in
#: docs/verification/performance.md's cost table are within 2× of the solve; 3× leaves room for a busy node
COST_MARGIN = 3.0
#: what a job may take before it steps (s): the 3D kernels' cold compile took 92–107 s (dsmv-bench --3d)
COLD_START_S = 150.0


def time_limit_min(estimates_s: Sequence[float], floor_min: float) -> int:
    """The time limit (min) for jobs of these cost estimates (s), each its own task: the longest
    estimate times :data:`COST_MARGIN` plus :data:`COLD_START_S`, at least ``floor_min``."""
    return math.ceil(max(float(floor_min), (COST_MARGIN * max(estimates_s) + COLD_START_S) / 60.0))


def worker_count(cpus_per_task: int | None) -> int:
    """The workers this machine runs at once: its usable cores over the cpus each task pins."""
    return max(1, len(os.sched_getaffinity(0)) // max(1, int(cpus_per_task or 1)))


def _claim(claims: Path, index: int) -> bool:
    """Claim job ``index`` for this worker; False if another worker has it."""
    try:
        os.close(os.open(claims / str(index), os.O_CREAT | os.O_EXCL | os.O_WRONLY))
        return True
    except FileExistsError:
        return False


class LocalLauncher(plugin.LocalLauncher if plugin else object):
    """submitit's local executor with one process per worker; each takes the sweep's jobs in turn."""

    def launch(self, job_overrides: Sequence[Sequence[str]], initial_job_idx: int) -> Sequence[JobReturn]:
        import submitit

        workers = min(len(job_overrides), worker_count(self.params.get("cpus_per_task")))

        assert self.config is not None
        sweep_dir = Path(str(self.config.hydra.sweep.dir))
        sweep_dir.mkdir(parents=True, exist_ok=True)
        if "mode" in self.config.hydra.sweep:
            os.chmod(sweep_dir, mode=int(str(self.config.hydra.sweep.mode), 8))
        executor = submitit.AutoExecutor(cluster=self._EXECUTOR, folder=self.params["submitit_folder"])
        parameters = {k: v for k, v in self.params.items() if k != "submitit_folder"}
        rounds = -(-len(job_overrides) // workers)  # a worker's limit: its share of the jobs' limits
        parameters["timeout_min"] = int(parameters["timeout_min"]) * rounds
        executor.update_parameters(**parameters)
        plugin.log.info(f"Submitit '{self._EXECUTOR}' sweep output dir : {sweep_dir} ({workers} workers)")
        state = Singleton.get_state()
        jobs = []
        for offset, overrides in enumerate(job_overrides):
            idx = initial_job_idx + offset
            plugin.log.info(f"\t#{idx} : {' '.join(filter_overrides(overrides))}")
            jobs.append((list(overrides), "hydra.sweep.dir", idx, f"job_id_for_{idx}", state))
        claims = sweep_dir / ".submitit" / f"claims-{uuid.uuid4().hex[:12]}"
        claims.mkdir(parents=True)
        with interrupts.children_ignore_ctrl_c():  # a controller taking Ctrl-C kills its worker a second later
            submitted = executor.map_array(self.work, [claims] * workers, [jobs] * workers)
        returns: dict[int, JobReturn] = {}
        for worker in submitted:
            returns.update(worker.results()[0])
        return [returns[job[2]] for job in jobs]

    def work(self, claims: Path, jobs: list[tuple[Any, ...]]) -> dict[int, JobReturn]:
        """A worker's loop: run every job no other worker has claimed, in the sweep's order."""
        return {job[2]: self(*job) for job in jobs if _claim(claims, job[2])}


class SlurmLauncher(plugin.SlurmLauncher if plugin else object):
    """submitit's SLURM array, its time limit that of the sweep's longest job (:func:`time_limit_min`)."""

    def launch(self, job_overrides: Sequence[Sequence[str]], initial_job_idx: int) -> Sequence[JobReturn]:
        from dsmv.app.runner import estimated_wall_s

        started = time.perf_counter()
        loader = self.hydra_context.config_loader
        estimates = [estimated_wall_s(loader.load_sweep_config(self.config, list(o))) for o in job_overrides]
        floor = self.config.hydra.launcher.timeout_min  # the configured one: a batch's limit is its own
        self.params = {**self.params, "timeout_min": time_limit_min(estimates, floor)}
        plugin.log.info(f"time limit {self.params['timeout_min']} min: the longest of {len(estimates)} jobs is "
                        f"estimated at {max(estimates):.0f} s ({time.perf_counter() - started:.1f} s to estimate)")
        return super().launch(job_overrides, initial_job_idx)
