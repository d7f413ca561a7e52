"""``hydra/launcher=dsmv_local``: Hydra's submitit launcher with a worker per core, not a process per job.

Hydra's ``submitit_local`` starts one process per job, all of a sweep's jobs at once. Each pays
Python's start, the imports and the kernels' loading from Numba's cache, about 1.3 s of CPU, which
on the medium mesh is four times the solve. :class:`LocalLauncher` submits one submitit job per
worker instead (as many as the machine's cores hold tasks of ``cpus_per_task``), and each worker
runs the sweep's jobs in turn, taking the next unclaimed one as joblib's workers do: a job is
claimed by creating its file in the launch's claims folder, which one process only can do. Every
Hydra job still runs through the plugin's own ``__call__`` (its config composed, its own directory),
and the results come back in the sweep's order. SLURM keeps one array task per job (``dsmv_slurm``).
"""

from __future__ import annotations

import os
import uuid
from pathlib import Path
from typing import Any, Sequence

from hydra.core.singleton import Singleton
from hydra.core.utils import JobReturn, filter_overrides

from dsmv import interrupts

try:
    from hydra_plugins.hydra_submitit_launcher import submitit_launcher as plugin
except ImportError:  # without dsmv[cluster] there is no dsmv_local, and Hydra's plugin scan must not warn
    plugin = None

__all__ = ["LocalLauncher", "worker_count"]


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
        rounds = -(-len(job_overrides) // workers)  # a worker's limit is its share of the jobs' limits
        parameters["timeout_min"] = int(parameters.get("timeout_min") or 60) * rounds
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
        return [returns[initial_job_idx + offset] for offset in range(len(jobs))]

    def work(self, claims: Path, jobs: list[tuple[Any, ...]]) -> dict[int, JobReturn]:
        """A worker's loop: run every job no other worker has claimed, in the sweep's order."""
        return {job[2]: self(*job) for job in jobs if _claim(claims, job[2])}
