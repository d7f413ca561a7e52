"""``hydra/sweeper=cases``: Hydra's basic sweeper plus explicit lists of cases.

Hydra's basic sweeper runs the Cartesian product of its ``params``. Studies need two more
shapes, which this sweeper adds (and multiplies with that product):

- ``vary``: one parameter at a time around the default scene, ``{key: [values]}`` — the
  reference study's Figures 7, 9 and 11 are such sweeps, not products;
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
from typing import Any, Optional

from hydra.core.config_store import ConfigStore
from hydra.core.plugins import Plugins
from omegaconf import OmegaConf

# Hydra's first plugin scan re-executes its core plugin modules: scan before subclassing
# BasicSweeper, or its own super(BasicSweeper, self) would name a different class than ours.
Plugins.instance()
from hydra._internal.core_plugins.basic_sweeper import BasicSweeper  # noqa: E402


@dataclass
class CaseSweeperConf:
    _target_: str = "hydra_plugins.dsmv_sweeper.case_sweeper.CaseSweeper"
    max_batch_size: Optional[int] = None
    params: Optional[dict[str, str]] = field(default_factory=dict)
    vary: Optional[dict[str, Any]] = None
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


def load_function(path: str):
    """``"package.module:function"`` → the function."""
    module, _, name = path.partition(":")
    if not name:
        raise ValueError(f"hydra.sweeper.cases_from = {path!r}: expected 'module:function'")
    return getattr(importlib.import_module(module), name)


class CaseSweeper(BasicSweeper):
    """The basic sweeper's product of ``params`` and command-line sweeps, times the cases."""

    def __init__(self, max_batch_size: Optional[int] = None, params: Optional[dict[str, str]] = None,
                 vary: Optional[dict[str, Any]] = None, cases_from: Optional[str] = None) -> None:
        super().__init__(max_batch_size=max_batch_size, params=params)
        self.vary = OmegaConf.to_container(vary) if vary is not None and not isinstance(vary, dict) else vary
        self.cases_from = cases_from

    def cases(self) -> list[list[str]]:
        cases: list[list[str]] = []
        if self.vary:
            cases += one_at_a_time(self.vary)
        if self.cases_from:
            cases += [list(case) for case in load_function(self.cases_from)(self.config)]
        return cases or [[]]

    def split_arguments(self, overrides, max_batch_size):  # an instance method: it needs the cases
        """The basic sweeper's job list, each job repeated for every case, in batches."""
        product = [job for batch in BasicSweeper.split_arguments(overrides, None) for job in batch]
        jobs = [base + case for base, case in itertools.product(product, self.cases())]
        if not max_batch_size:
            return [jobs]
        return list(BasicSweeper.split_overrides_to_chunks(jobs, max_batch_size))


__all__ = ["CaseSweeper", "CaseSweeperConf", "one_at_a_time"]
