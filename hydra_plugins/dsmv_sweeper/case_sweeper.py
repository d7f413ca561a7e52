"""``hydra/sweeper=cases``: Hydra's basic sweeper plus explicit lists of cases.

Hydra's basic sweeper runs the Cartesian product of its ``params``. Studies need three more
shapes, which this sweeper adds (and multiplies with that product):

- ``vary``: one parameter at a time around the default scene, ``{key: [values]}`` — the
  reference study's Figures 7, 9 and 11 are such sweeps, not products;
- ``cases``: an explicit list of cases, each a list of overrides (the eight Table 3
  combinations of ``compare_analytic``);
- ``cases_from``: ``"module:function"`` computing the cases from the composed config
  (``function(cfg) -> list[list[str]]``), for designs whose size is itself a config value
  (the Table 3 dataset's ``dataset.n_samples``).

Every job gets ordinary overrides (``soil.su0_pa=4000``), so its ``overrides.yaml``, MLflow run
name and params say exactly what the case was. It lives in ``hydra_plugins`` because Hydra only
loads sweepers from that namespace.
"""

from __future__ import annotations

import importlib
import itertools
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional

from hydra.core.config_store import ConfigStore
from hydra.core.override_parser.overrides_parser import OverridesParser
from hydra.plugins.sweeper import Sweeper
from omegaconf import OmegaConf


@dataclass
class CaseSweeperConf:
    _target_: str = "hydra_plugins.dsmv_sweeper.case_sweeper.CaseSweeper"
    max_batch_size: Optional[int] = None
    params: Optional[dict[str, str]] = field(default_factory=dict)
    vary: Optional[dict[str, Any]] = None
    cases: Optional[list[Any]] = None
    cases_from: Optional[str] = None


ConfigStore.instance().store(group="hydra/sweeper", name="cases", node=CaseSweeperConf, provider="dsmv")


def one_at_a_time(vary: dict[str, list]) -> list[list[str]]:
    """``{key: [v1, v2]}`` → ``[[key=v1], [key=v2], ...]``, keys in the given order."""
    cases = []
    for key, values in vary.items():
        if not isinstance(values, (list, tuple)) or not values:
            raise ValueError(f"hydra.sweeper.vary.{key}: expected a non-empty list of values, got {values!r}")
        cases += [[f"{key}={value}"] for value in values]
    return cases


def _plain(node):
    """An OmegaConf node as plain Python (lists and dicts), None unchanged."""
    return OmegaConf.to_container(node) if OmegaConf.is_config(node) else node


def load_function(path: str):
    """``"package.module:function"`` → the function."""
    module, _, name = path.partition(":")
    if not name:
        raise ValueError(f"hydra.sweeper.cases_from = {path!r}: expected 'module:function'")
    return getattr(importlib.import_module(module), name)


class CaseSweeper(Sweeper):
    """The basic sweeper's product of ``params`` and command-line sweeps, times the cases.

    Not a subclass of Hydra's BasicSweeper: Hydra's plugin scan re-executes its core plugin
    modules, after which BasicSweeper's own ``super(BasicSweeper, self)`` would name another
    class than the one subclassed. Only its pure static helpers are borrowed.
    """

    def __init__(self, max_batch_size: Optional[int] = None, params: Optional[dict[str, str]] = None,
                 vary: Optional[dict[str, Any]] = None, cases: Optional[list[Any]] = None,
                 cases_from: Optional[str] = None) -> None:
        super().__init__()
        self.max_batch_size = max_batch_size
        self.params = _plain(params) or {}
        self.vary = _plain(vary)
        self.explicit_cases = _plain(cases)
        self.cases_from = cases_from
        self.config = self.launcher = self.hydra_context = None

    def setup(self, *, hydra_context, task_function, config) -> None:
        from hydra.core.plugins import Plugins

        self.hydra_context, self.config = hydra_context, config
        self.launcher = Plugins.instance().instantiate_launcher(
            hydra_context=hydra_context, task_function=task_function, config=config)

    def cases(self) -> list[list[str]]:
        cases: list[list[str]] = []
        if self.vary:
            cases += one_at_a_time(self.vary)
        for number, case in enumerate(self.explicit_cases or []):
            if not isinstance(case, list) or not all(isinstance(o, str) and "=" in o for o in case):
                raise ValueError(f"hydra.sweeper.cases[{number}] = {case!r}: expected a list of 'key=value' overrides")
            cases.append(list(case))
        if self.cases_from:
            cases += [list(case) for case in load_function(self.cases_from)(self.config)]
        return cases or [[]]

    def jobs(self, arguments: list[str]) -> list[list[str]]:
        """Every job's overrides: the basic sweeper's product, each job repeated for every case."""
        from hydra._internal.core_plugins.basic_sweeper import BasicSweeper

        parser = OverridesParser.create(config_loader=self.hydra_context.config_loader)
        overrides = parser.parse_overrides([f"{k}={v}" for k, v in self.params.items()] + list(arguments))
        product = [job for batch in BasicSweeper.split_arguments(overrides, None) for job in batch]
        return [base + case for base, case in itertools.product(product, self.cases())]

    def sweep(self, arguments: list[str]) -> Any:
        jobs = self.jobs(arguments)
        sweep_dir = Path(self.config.hydra.sweep.dir)
        sweep_dir.mkdir(parents=True, exist_ok=True)
        OmegaConf.save(self.config, sweep_dir / "multirun.yaml")
        from dsmv.tracking.runs import write_sweep_size

        write_sweep_size(sweep_dir, len(jobs))
        batch_size = self.max_batch_size or len(jobs)
        returns, first = [], 0
        for start in range(0, len(jobs), batch_size):
            batch = jobs[start : start + batch_size]
            self.validate_batch_is_legal(batch)  # composition errors surface before any job runs
            results = self.launcher.launch(batch, initial_job_idx=first)
            for result in results:
                _ = result.return_value  # raises if the job raised
            first += len(batch)
            returns.append(results)
        return returns


__all__ = ["CaseSweeper", "CaseSweeperConf", "one_at_a_time"]
