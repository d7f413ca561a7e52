"""Command-line entry points: thin Hydra mains and plain tools."""

from __future__ import annotations

import argparse
from pathlib import Path

import hydra
from hydra.core.plugins import Plugins
from omegaconf import DictConfig

import dsmv.scene  # noqa: F401  (registers the OmegaConf resolvers used by conf/)
from hydra_plugins.dsmv_sweeper.case_sweeper import CaseSweeper

from dsmv import registry

# Hydra finds sweepers by walking the hydra_plugins namespace, which an editable install
# does not expose to that walk: register ours by hand (a no-op when Hydra found it).
Plugins.instance().register(CaseSweeper)

#: the Hydra config tree of the source checkout (dsmv is installed editable)
CONFIG_DIR = str(Path(__file__).resolve().parent.parent / "conf")


@hydra.main(version_base="1.3", config_path=CONFIG_DIR, config_name="config")
def simulate(cfg: DictConfig) -> None:
    """``dsmv``: run one scene, or a sweep with ``-m``."""
    from dsmv.runner import run_job

    run_job(cfg)


@hydra.main(version_base="1.3", config_path=CONFIG_DIR, config_name="train")
def _train_app(cfg: DictConfig) -> None:
    from dsmv.surrogate.train import main

    main(cfg)


def train() -> None:
    """``dsmv-train``: train and evaluate a surrogate on a study's tracked runs."""
    import sys

    from dsmv.surrogate.train import check_surrogate_choice

    check_surrogate_choice(sys.argv[1:], CONFIG_DIR)
    _train_app()


def list_plugins(argv: list[str] | None = None) -> None:
    """``dsmv-plugins``: list installed plugins by entry-point group."""
    parser = argparse.ArgumentParser(prog="dsmv-plugins", description=list_plugins.__doc__)
    parser.parse_args(argv)
    for kind, group in registry.GROUPS.items():
        plugins = registry.available(kind)
        print(f"{group}:")
        if not plugins:
            print("  (none installed)")
        for name, ep in plugins.items():
            dist = f"  [{ep.dist.name} {ep.dist.version}]" if ep.dist else ""
            print(f"  {name:<20} {ep.value}{dist}")
