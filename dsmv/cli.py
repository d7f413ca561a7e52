"""Command-line entry points: thin Hydra mains and plain tools."""

from __future__ import annotations

import argparse
import sys
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


def find_config_dir() -> Path:
    """The Hydra config tree: ``dsmv/conf`` in an installed wheel, else ``conf/`` of the source checkout.

    pyproject.toml maps the checkout's top-level ``conf/`` into the wheel as the package data
    ``dsmv/conf``; an editable install or a plain checkout reads ``conf/`` beside the package.
    """
    package = Path(__file__).resolve().parent
    for candidate in (package / "conf", package.parent / "conf"):
        if (candidate / "config.yaml").is_file():
            return candidate
    raise FileNotFoundError(f"no Hydra config tree (conf/config.yaml) in {package} or beside it")


#: the Hydra config tree every entry point composes from
CONFIG_DIR = str(find_config_dir())


def check_group_choices(argv: list[str], program: str, config_dir: str = CONFIG_DIR) -> None:
    """Fail in one line (exit 2) on ``group=option`` naming no ``conf/<group>/<option>.yaml``.

    Hydra's own message for an unknown option is many lines long. Sweeps (``soil=a,b``) are
    checked value by value; Hydra's own groups (``hydra/launcher=…``), deletions (``~group``)
    and sweep functions (``range(…)``) are left to Hydra.
    """
    from dsmv.errors import ConfigError
    from dsmv.runner import fail_user_error

    for arg in argv:
        key, sep, value = arg.partition("=")
        group = key.lstrip("+")
        folder = Path(config_dir) / group
        if not sep or key.startswith("~") or "/" in group or "(" in value or not folder.is_dir():
            continue
        options = sorted(p.stem for p in folder.glob("*.yaml"))
        for choice in value.split(","):
            if choice not in options and choice != "null":
                fail_user_error(ConfigError(group, choice, f"not a {group} option; available: {', '.join(options)}"),
                                program)


@hydra.main(version_base="1.3", config_path=CONFIG_DIR, config_name="config")
def _simulate_app(cfg: DictConfig) -> None:
    from dsmv.runner import run_job

    run_job(cfg)


def simulate() -> None:
    """``dsmv``: run one scene, or a sweep with ``-m``."""
    check_group_choices(sys.argv[1:], "dsmv")
    _simulate_app()


@hydra.main(version_base="1.3", config_path=CONFIG_DIR, config_name="train")
def _train_app(cfg: DictConfig) -> None:
    from dsmv.surrogate.train import main

    main(cfg)


def train() -> None:
    """``dsmv-train``: train and evaluate a surrogate on a study's tracked runs."""
    check_group_choices(sys.argv[1:], "dsmv-train")
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
