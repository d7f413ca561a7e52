"""Command-line entry points: thin Hydra mains and plain tools.

Hydra and the config tree are imported when a command runs, not with this module: ``dsmv`` starts
its MLflow writer first, so that MLflow's import overlaps all of the command's own work.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from dsmv import registry
from dsmv.app.template import KINDS, write_package
from dsmv.errors import ConfigError, DsmvError
from dsmv.results import EXIT_CODES

if TYPE_CHECKING:
    from omegaconf import DictConfig


def _hydra_main(task, config_name: str):
    """``task`` as a Hydra main over dsmv's config tree."""
    import hydra

    from dsmv.config.tree import CONFIG_DIR

    return hydra.main(version_base="1.3", config_path=CONFIG_DIR, config_name=config_name)(task)


def _simulate_job(cfg: DictConfig) -> float:
    """One job; returns its objective (dsmv.config.objective), the number an optimising sweeper minimises."""
    from omegaconf import OmegaConf

    from dsmv.config.objective import objective_config, objective_value
    from dsmv.app.runner import run_job

    result = run_job(cfg)
    config = OmegaConf.to_container(cfg, resolve=True)
    return objective_value(objective_config(config), result, config.get("geometry", {}))


#: flags after which dsmv prints and runs nothing (no MLflow writer is started for them)
INFO_FLAGS = {"--help", "-h", "--hydra-help", "--cfg", "-c", "--info", "-i", "--resolve", "--package", "-p",
              "--shell-completion", "-sc", "--version"}


def simulate() -> None:
    """``dsmv``: run one scene, or a sweep with ``-m``; ``dsmv ui``: the MLflow UI on its store
    (:mod:`dsmv.app.ui`, taken before Hydra reads the command line)."""
    import os

    if sys.argv[1:2] == ["ui"]:
        from dsmv.app.ui import main as ui_main

        sys.exit(ui_main(sys.argv[2:]))
    # MLflow's messages go to the job's log (dsmv.app.joblog), not to a console handler of MLflow's own
    os.environ.setdefault("MLFLOW_CONFIGURE_LOGGING", "false")
    args = sys.argv[1:]
    if not set(args) & INFO_FLAGS and "tracking=disabled" not in args:
        from dsmv.tracking.run_writer import writer

        # first of all: MLflow's import (2-3 s) runs on the other core while the command line is
        # checked, Hydra composes and the job solves; a command line refused below closes it unused
        writer()
    from dsmv.app.command_line import check_app_command_line

    registry.register_plugin_configs()
    try:
        check_app_command_line("dsmv", args)
        _hydra_main(_simulate_job, "config")()
    except KeyboardInterrupt as exc:  # before a job started, or a sweep aborted by a second signal
        from dsmv.app.sweep import abort_sweep

        sweep_dir = abort_sweep(f"{exc or 'SIGINT'} again: the sweep was aborted")
        print("dsmv: interrupted" + (f"; the sweep was aborted, its MLflow runs closed KILLED: {sweep_dir}"
                                     if sweep_dir else ""), file=sys.stderr)
        sys.exit(EXIT_CODES["interrupted"])


def _remove_refused_run_dir(cfg: DictConfig) -> None:
    """The run dir Hydra made for a job refused before it wrote anything goes (as ``dsmv``'s does)."""
    from hydra.core.hydra_config import HydraConfig

    from dsmv.app.runner import remove_unstarted_run_dir

    if HydraConfig.initialized():
        hydra_cfg = HydraConfig.get()
        run_dir = Path(hydra_cfg.runtime.output_dir)
        remove_unstarted_run_dir(run_dir, hydra_cfg, str(cfg.get("paths", {}).get("runs_dir", run_dir.parent)))


def _job_in_its_run_dir(cfg: DictConfig, target: str, program: str) -> None:
    """``target`` (``module:function``, called with the config and the run dir); a user mistake ends in
    one line and exit status 2, and leaves no run dir behind."""
    import importlib

    from hydra.core.hydra_config import HydraConfig

    from dsmv.app.runner import fail_user_error

    module, _, name = target.partition(":")
    try:
        getattr(importlib.import_module(module), name)(cfg, Path(HydraConfig.get().runtime.output_dir))
    except DsmvError as error:
        _remove_refused_run_dir(cfg)
        fail_user_error(error, program)


def _train_job(cfg: DictConfig) -> None:
    """One training (:func:`dsmv.surrogate.train.run_training`)."""
    _job_in_its_run_dir(cfg, "dsmv.surrogate.train:run_training", "dsmv-train")


def _calibrate_job(cfg: DictConfig) -> None:
    """One calibration (:func:`dsmv.calibration.run.run_calibration`)."""
    _job_in_its_run_dir(cfg, "dsmv.calibration.run:run_calibration", "dsmv-calibrate")


def _predict_job(cfg: DictConfig):
    """One prediction (:func:`dsmv.surrogate.predict.predict`); a refused one leaves no run dir behind."""
    from dsmv.surrogate.predict import predict as predict_job

    try:
        return predict_job(cfg)
    except SystemExit as stop:
        if stop.code == 2:  # a user mistake, told in one line
            _remove_refused_run_dir(cfg)
        raise


def train() -> None:
    """``dsmv-train``: train and evaluate a surrogate on a study's tracked runs."""
    from dsmv.app.command_line import check_app_command_line

    registry.register_plugin_configs()
    check_app_command_line("dsmv-train", sys.argv[1:])
    _hydra_main(_train_job, "train")()


def calibrate() -> None:
    """``dsmv-calibrate``: fit a soil law's parameters to site tests, with their uncertainty
    (:mod:`dsmv.calibration`)."""
    from dsmv.app.command_line import check_app_command_line

    registry.register_plugin_configs()
    check_app_command_line("dsmv-calibrate", sys.argv[1:])
    try:
        _hydra_main(_calibrate_job, "calibrate")()
    except KeyboardInterrupt as exc:  # a signal, in a CEL run (its state is in its folder) or between them
        print(f"dsmv-calibrate: interrupted{f': {exc}' if str(exc) else ''}", file=sys.stderr)
        sys.exit(EXIT_CODES["interrupted"])


def predict() -> None:
    """``dsmv-predict``: sinkage of a scene from a registered surrogate with its interval, and the
    inverse questions (:mod:`dsmv.surrogate.predict`)."""
    from dsmv.app.command_line import check_app_command_line

    registry.register_plugin_configs()
    check_app_command_line("dsmv-predict", sys.argv[1:])
    _hydra_main(_predict_job, "predict")()


def list_plugins(argv: list[str] | None = None) -> None:
    """``dsmv-plugins``: list installed plugins by entry-point group; ``--check`` loads them; ``new`` writes one."""
    parser = argparse.ArgumentParser(prog="dsmv-plugins", description=list_plugins.__doc__,
                                     epilog="dsmv-plugins new soil-law|surrogate NAME [--dir DIR]: write a plugin "
                                            "package (the plugin, its config option, its tests) into DIR")
    parser.add_argument("--check", action="store_true",
                        help="load every plugin and name those that do not load (exit 1 if any)")
    parser.add_argument("new", nargs="*", metavar="new soil-law|surrogate NAME", help="write a new plugin package")
    parser.add_argument("--dir", default=".", help="with new: the folder to write the package into (default .)")
    args = parser.parse_args(argv)
    if args.new:
        if len(args.new) != 3 or args.new[0] != "new" or args.new[1] not in KINDS:
            parser.error(f"expected: dsmv-plugins new {{{'|'.join(KINDS)}}} NAME")
        try:
            root = write_package(args.new[1], args.new[2], Path(args.dir))
        except ConfigError as error:
            print(f"dsmv-plugins: error: {error}", file=sys.stderr)
            sys.exit(2)
        print(f"dsmv-plugins: wrote {root}; install it with: pip install -e {root}")
        return
    if args.check:
        problems = registry.broken()
        for line in problems:
            print(f"dsmv-plugins: broken: {line}", file=sys.stderr)
        total = sum(len(registry.available(kind)) for kind in registry.GROUPS)
        print(f"dsmv-plugins: {total - len(problems)} of {total} plugins load")
        sys.exit(1 if problems else 0)
    for kind, group in registry.GROUPS.items():
        plugins = registry.available(kind)
        print(f"{group}:")
        if not plugins:
            print("  (none installed)")
        for name, ep in plugins.items():
            dist = f"  [{ep.dist.name} {ep.dist.version}]" if ep.dist else ""
            print(f"  {name:<20} {ep.value}{dist}")
    configs = registry.config_packages()
    if configs:  # packages whose config groups are on Hydra's search path
        print(f"{registry.CONFIG_GROUP}:")
        for name, package in configs.items():
            print(f"  {name:<20} {package}")
