"""What every entry point (``dsmv``, ``dsmv-train``, ``dsmv-predict``) composes with, and the command
line's checks before Hydra composes: dsmv's own sweeper and launchers, which group choices and keys a
command names, whether its output folders can be written. A mistake is one line naming the key, exit
code 2. The config tree itself is :mod:`dsmv.config.tree`'s."""

from __future__ import annotations

import difflib
import sys
from pathlib import Path
from typing import Callable

from hydra.core.plugins import Plugins
from omegaconf import DictConfig, OmegaConf

from dsmv import registry
from dsmv.app.joblog import keep_early_output
from dsmv.app.runner import fail_user_error
from dsmv.config.tree import CONFIG_DIR  # (with dsmv's case sweeper registered, and conf/'s resolvers)
from dsmv.errors import ConfigError, DsmvError
from hydra_plugins.dsmv_launcher import submitit_launchers

# Hydra finds launchers by walking the hydra_plugins namespace, which an editable install does not
# expose to that walk: register ours by hand (a no-op when Hydra found them).
if submitit_launchers.plugin is not None:  # dsmv_local and dsmv_slurm need dsmv[cluster]
    Plugins.instance().register(submitit_launchers.LocalLauncher)
    Plugins.instance().register(submitit_launchers.SlurmLauncher)


def config_roots(argv: list[str], config_dir: str = CONFIG_DIR) -> list[Path]:
    """Every config tree Hydra will search for this command line: dsmv's own, the plugin packages'
    (entry points in ``dsmv.configs``), ``--config-dir``/``-cd`` and ``hydra.searchpath`` entries."""
    roots = [Path(config_dir), *(Path(d) for d in registry.config_dirs())]
    for i, arg in enumerate(argv):
        if arg in ("--config-dir", "-cd") and i + 1 < len(argv):
            roots.append(Path(argv[i + 1]))
        elif arg.startswith("--config-dir="):
            roots.append(Path(arg.partition("=")[2]))
        elif arg.lstrip("+").startswith("hydra.searchpath="):
            for entry in arg.partition("=")[2].strip("[]").split(","):
                entry = entry.strip().strip("'\"")
                if entry.startswith("file://"):
                    roots.append(Path(entry[len("file://"):]))
                elif entry.startswith("pkg://"):
                    roots += [Path(d) for d in registry.package_folders(entry[len("pkg://"):].replace("/", ".")) or []]
                elif entry:
                    roots.append(Path(entry))
    return roots


def check_group_choices(argv: list[str], program: str, config_dir: str = CONFIG_DIR) -> None:
    """Fail in one line (exit 2) on ``group=option`` naming no ``conf/<group>/<option>.yaml``.

    Hydra's own message for an unknown option is many lines long. Sweeps (``soil=a,b``) are
    checked value by value; Hydra's own groups (``hydra/launcher=…``), deletions (``~group``)
    and sweep functions (``range(…)``) are left to Hydra.
    """
    roots = config_roots(argv, config_dir)
    for arg in argv:
        key, sep, value = arg.partition("=")
        group = key.lstrip("+")
        folders = [root / group for root in roots if (root / group).is_dir()]
        if not sep or key.startswith("~") or "/" in group or "(" in value or not folders:
            continue
        own = sorted(p.stem for p in (roots[0] / group).glob("*.yaml"))  # dsmv's, then those of plugins and dirs
        others = sorted({p.stem for folder in folders for p in folder.glob("*.yaml")} - set(own))
        listing = ", ".join(own) + (f"; from plugins and config dirs: {', '.join(others)}" if others else "")
        for choice in value.split(","):
            if choice not in own and choice not in others and choice != "null":
                fail_user_error(ConfigError(group, choice, f"not a {group} option; available: {listing}"), program)


#: Hydra flags after which the command does not compose and run a job: left to Hydra entirely
HYDRA_ONLY_FLAGS = ("help", "hydra_help", "cfg", "info", "shell_completion", "config_path", "config_name",
                    "config_dir", "experimental_rerun")


#: the Hydra apps: their primary config, and the check each one's job makes of its config before it
#: starts (``module:function``, raising a DsmvError), which the command line makes first, before Hydra
#: creates anything; imported only when a single run's config is there to check
APPS = {
    "dsmv": ("config", "dsmv.config.scene:build_scene"),  # the whole scene, the solver's cost guard included
    "dsmv-train": ("train", "dsmv.surrogate.train:check_config"),
    "dsmv-predict": ("predict", "dsmv.surrogate.predict:check_config"),
    "dsmv-calibrate": ("calibrate", "dsmv.calibration.run:check_config"),
}


def check_app_command_line(program: str, argv: list[str], config_dir: str = CONFIG_DIR) -> None:
    """:func:`check_command_line` for one of the :data:`APPS`, with its primary config and its job's check."""
    import importlib

    config_name, target = APPS[program]
    module, _, name = target.partition(":")

    def validate(cfg: DictConfig) -> None:
        getattr(importlib.import_module(module), name)(cfg)

    check_command_line(argv, program, config_name, validate, config_dir)


def check_command_line(argv: list[str], program: str, config_name: str = "config",
                       validate: Callable[[DictConfig], object] | None = None, config_dir: str = CONFIG_DIR) -> None:
    """Catch a mistyped command line before Hydra composes it or creates any directory: one line, exit 2.

    On top of :func:`check_group_choices`: an override Hydra cannot parse; an unknown key, with or
    without ``+`` (the closest valid key is suggested); a sweep (``a,b``) without ``-m``; a single
    run's config, checked by ``validate`` as the job would check it (:data:`APPS`: ``dsmv``'s whole
    scene, ``dsmv-train``'s and ``dsmv-predict``'s settings); and ``paths.runs_dir`` and the run or
    sweep dir Hydra is about to create, which must be creatable. Flags that only show something
    (``--help``, ``--cfg``, ``--info`` ...) and other config dirs or names are left to Hydra. Warnings
    and log records raised meanwhile are kept for the job's log (:func:`dsmv.app.joblog.keep_early_output`),
    not printed.
    """
    check_group_choices(argv, program, config_dir)
    if "--version" in argv:
        return
    from hydra._internal.utils import get_args_parser

    try:
        args = get_args_parser().parse_args(argv)
    except SystemExit:  # a malformed flag: Hydra prints its usage
        raise SystemExit(2)
    if any(getattr(args, flag) for flag in HYDRA_ONLY_FLAGS):
        return
    with keep_early_output():
        try:
            _check_overrides(args, program, config_name, validate, config_dir)
        except Exception:  # not a mistake of the command line (a plugin's bug): the job meets and reports it
            pass


def _one_line(exc: BaseException) -> str:
    """The first line of an exception and of each of its causes, joined: Hydra's errors in one line."""
    parts: list[str] = []
    while exc is not None and len(parts) < 3:
        first = next((line.strip() for line in str(exc).splitlines() if line.strip()), "")
        if first and first != "None" and not any(first in part for part in parts):
            parts.append(first)
        exc = exc.__cause__ or exc.__context__
    return ": ".join(parts) or "invalid"


def _fail(program: str, message: str) -> None:
    print(f"{program}: error: {message}", file=sys.stderr)
    sys.exit(2)


def _check_overrides(args, program: str, config_name: str, validate, config_dir: str) -> None:
    from hydra import compose, initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra
    from hydra.core.override_parser.overrides_parser import OverridesParser
    from hydra.core.utils import setup_globals
    from hydra.errors import HydraException
    from omegaconf.errors import OmegaConfBaseException

    setup_globals()  # ${now:...} in hydra.run.dir
    GlobalHydra.instance().clear()
    try:
        with initialize_config_dir(config_dir=config_dir, version_base="1.3"):
            loader = GlobalHydra.instance().config_loader()
            try:
                overrides = OverridesParser.create(config_loader=loader).parse_overrides(args.overrides)
            except HydraException as exc:
                _fail(program, f"cannot parse the command line: {_one_line(exc)} "
                               f"(see https://hydra.cc/docs/advanced/override_grammar/basic)")

            groups = [o for o in overrides if _is_group(o, loader)]
            keys = [o for o in overrides if o not in groups]
            for o in groups:
                _check_choices(o, loader, program)

            def composed(lines: list[str]):
                try:
                    return compose(config_name, overrides=lines, return_hydra_config=True)
                except (HydraException, OmegaConfBaseException) as exc:
                    _fail(program, _one_line(exc))

            variants = _group_variants(groups)
            one_job = [o.input_line for o in keys if not o.is_sweep_override()]
            # the common command line, no sweep and no key added or deleted: if it composes, every key
            # exists, and that one composition is the job's config
            cfg = None
            if not any(o.is_sweep_override() or o.is_add() or o.is_force_add() or o.is_delete() for o in overrides):
                try:
                    cfg = compose(config_name, overrides=variants[0] + one_job, return_hydra_config=True)
                except (HydraException, OmegaConfBaseException):
                    pass  # the checks below name the mistake
            # the keys that exist: the defaults with the chosen groups, each swept choice in turn
            search = [o.input_line for o in keys if o.key_or_group == "hydra.searchpath"]  # where options are found
            trees = [cfg] if cfg is not None else [composed(variant + search) for variant in variants]
            known: set[str] = set()
            for tree in trees:
                known |= set(_paths(OmegaConf.to_container(tree, resolve=False)))
            for o in keys:
                _check_key(o, trees[0], known, program)

            base = trees[0]
            mode = OmegaConf.select(base, "hydra.mode")
            multirun = (args.multirun or getattr(mode, "name", mode) == "MULTIRUN"
                        or any(o.key_or_group == "hydra.mode" and str(o.value()) == "MULTIRUN" for o in keys))
            if not multirun:
                for o in overrides:
                    if o.is_sweep_override():
                        fail_user_error(ConfigError(o.key_or_group, _value_text(o),
                                                    "a sweep needs -m (--multirun); a list is written [a,b], "
                                                    "a string 'a,b'"), program)
            # one job's config: every override, the first choice of each sweep
            cfg = cfg if cfg is not None else composed(variants[0] + one_job)
            if validate is not None and not multirun:
                try:
                    validate(cfg)
                except DsmvError as error:
                    fail_user_error(error, program)
            _check_output_dirs(cfg, multirun, program)
    finally:
        GlobalHydra.instance().clear()


def _value_text(o) -> str:
    """An override's value as typed."""
    return (o.input_line or "").partition("=")[2]


def _is_group(o, loader) -> bool:
    """A config-group override (``soil=sample_I``, ``hydra/launcher=joblib``), not a key."""
    try:
        return loader.repository.group_exists(o.key_or_group)
    except Exception:
        return False


def _check_choices(o, loader, program: str) -> None:
    """Hydra's own groups (``hydra/launcher=jobib``): an unknown option in one line, as for conf/'s."""
    if o.is_delete() or "/" not in o.key_or_group or not (o.is_choice_sweep() or not o.is_sweep_override()):
        return
    options = loader.get_group_options(o.key_or_group)
    choices = list(o.sweep_string_iterator()) if o.is_choice_sweep() else [o.get_value_element_as_str()]
    for choice in choices:
        if choice not in options and choice != "null":
            fail_user_error(ConfigError(o.key_or_group, choice, f"not a {o.key_or_group} option; available: "
                                                                f"{', '.join(sorted(options))}"), program)


def _group_variants(groups) -> list[list[str]]:
    """Group overrides with one choice per sweep; then, one swept group at a time, its other choices."""
    def line(o, choice: str) -> str:
        return f"{o.get_key_element()}={choice}"

    def choices(o) -> list[str]:
        if o.is_choice_sweep():
            return list(o.sweep_string_iterator()) or [""]
        return [o.get_value_element_as_str()]

    first = [line(o, choices(o)[0]) if o.is_sweep_override() else o.input_line for o in groups]
    variants = [first]
    for k, o in enumerate(groups):
        if o.is_choice_sweep():
            for choice in choices(o)[1:]:
                variants.append(first[:k] + [line(o, choice)] + first[k + 1:])
    return variants


def _paths(tree, prefix: str = "") -> list[str]:
    """Every dotted key of a plain config tree, mappings included (lists are leaves)."""
    out = []
    for key, value in tree.items() if isinstance(tree, dict) else ():
        path = f"{prefix}{key}"
        out.append(path)
        out += _paths(value, path + ".")
    return out


def _node(tree, key: str):
    """The node at a dotted key of a composed config, unresolved, or None."""
    node = tree
    for part in key.split("."):
        if not isinstance(node, DictConfig) or part not in node.keys():
            return None
        node = node._get_node(part)
    return node


#: dsmv-calibrate's known values, nested as the soil's keys are
SYNTHETIC_TRUTH = "calibrate.synthetic.truth."
#: an uncertain parameter of dsmv-predict's exceedance, named by its scene key
UNCERTAIN = "uncertainty."


def _check_key(o, tree, known: set[str], program: str) -> None:
    """An override of a key the config does not have fails in one line, with or without ``+``.

    Exceptions, where a new key is legal: ``+``/``++`` under ``hydra.`` (Hydra's own, e.g.
    ``hydra.job.env_set``); a new key in a mapping the config leaves empty for them (``soil.params``,
    ``surrogate.params``); a key of a solver plugin whose config model allows extra keys; a synthetic
    calibration's known value of a soil key the config has (``+calibrate.synthetic.truth.soil.…``); an
    uncertain parameter of a scene key the config has (``+uncertainty.soil.profile_scale=…``).
    """
    key = o.key_or_group
    if key in known:
        return
    added = o.is_add() or o.is_force_add()
    if added and key.startswith("hydra."):
        return
    parent_key, _, _ = key.rpartition(".")
    parent = _node(tree, parent_key) if parent_key else None
    if added and isinstance(parent, DictConfig) and len(parent) == 0:
        return
    if added and key.startswith("solver.") and _solver_allows_extra(tree):
        return
    if added and program == "dsmv-calibrate" and key.startswith(SYNTHETIC_TRUTH + "soil.") and (
            key[len(SYNTHETIC_TRUTH):] in known or key.startswith(SYNTHETIC_TRUTH + "soil.params.")):
        return
    if added and program == "dsmv-predict" and key.startswith(UNCERTAIN) and key[len(UNCERTAIN):] in known:
        return
    value = _value_text(o) if o.is_sweep_override() or o.is_delete() else o.value()
    # the closest key: a sibling first (same parent), else any key of the config but the key's own parents
    name = key.rpartition(".")[2]
    siblings = {k.rpartition(".")[2]: k for k in known if k.rpartition(".")[0] == parent_key}
    scope = [k for k in known if k.startswith("hydra.") == key.startswith("hydra.") and not key.startswith(k + ".")
             and k not in siblings.values()]
    close = [siblings[n] for n in difflib.get_close_matches(name, list(siblings), n=1, cutoff=0.6)]
    close = close or difflib.get_close_matches(key, scope, n=1, cutoff=0.6)
    if close:
        hint = f"did you mean {close[0]}?"
    elif isinstance(parent, DictConfig):
        hint = f"{parent_key} has {', '.join(str(k) for k in parent.keys())}"
    else:
        hint = f"the config has {', '.join(sorted(k for k in known if '.' not in k and k != 'hydra'))}"
    if o.is_delete():
        _fail(program, f"~{key}: no such config key to delete; {hint}")
    fail_user_error(ConfigError(key, value, f"no such config key; {hint}"), program)


def _solver_allows_extra(tree) -> bool:
    try:
        model = registry.load("solvers", str(tree.solver.name), "solver.name").config_model
        return model.model_config.get("extra") == "allow"
    except Exception:
        return False


def _check_output_dirs(cfg, multirun: bool, program: str) -> None:
    """``paths.runs_dir`` and the run (sweep) dir Hydra will create must be directories dsmv can create
    and write in; checked without creating anything (a refused run leaves nothing behind)."""
    for key in ("paths.runs_dir", "hydra.sweep.dir" if multirun else "hydra.run.dir"):
        try:
            value = OmegaConf.select(cfg, key)
        except Exception:  # interpolates what exists only inside a job (hydra.job.*): Hydra's to judge
            continue
        if value is None:
            continue
        problem = unwritable(Path(str(value)))
        if problem:
            fail_user_error(ConfigError(key, str(value), problem), program)


def unwritable(path: Path) -> str | None:
    """Why ``path`` cannot be used as an output directory (it need not exist yet), or None."""
    import os

    probe = path.absolute()
    while not probe.exists() and not probe.is_symlink() and probe != probe.parent:
        probe = probe.parent
    if not probe.is_dir():
        return ("is not a directory" if probe == path.absolute() else
                f"cannot be created: {probe} is not a directory")
    if not os.access(probe, os.W_OK | os.X_OK):
        return ("is not writable: give a directory dsmv can write in" if probe == path.absolute() else
                f"cannot be created: {probe} is not writable")
    import tempfile

    try:  # permissions can say yes where the file system says no (root on /proc, a read-only mount)
        os.rmdir(tempfile.mkdtemp(prefix=".dsmv-probe-", dir=probe))
    except OSError as error:
        return f"cannot be created in {probe}: {error.strerror}"
    return None
