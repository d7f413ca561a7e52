"""Plugin discovery through standard entry points.

One entry-point group per kind of plugin; the entry-point name is the option name a
config uses (``soil.law=tresca``, ``solver.name=analytic_energy``). Built-in plugins are
registered in dsmv's own ``pyproject.toml`` and go through the same path as third-party
ones. Plugins load lazily: listing them imports nothing.
"""

from __future__ import annotations

import functools
import sys
import warnings
from importlib.metadata import EntryPoint, entry_points

from dsmv.errors import ConfigError

GROUPS = {
    "soil_laws": "dsmv.soil_laws",
    "solvers": "dsmv.solvers",
    "surrogates": "dsmv.surrogates",
}


@functools.cache
def _registered(group: str, search_path: tuple[str, ...]) -> tuple[EntryPoint, ...]:
    """A group's entry points on this import path, read once: reading them scans every installed
    distribution's metadata (35–70 ms a call, and building a scene loads nine plugins)."""
    return tuple(entry_points(group=group))


def registered(group: str) -> tuple[EntryPoint, ...]:
    """The entry points of ``group`` installed on the current import path."""
    return _registered(group, tuple(sys.path))


def available(kind: str) -> dict[str, EntryPoint]:
    """Installed plugins of one kind, by name (first registration wins on duplicates)."""
    found: dict[str, EntryPoint] = {}
    for ep in registered(GROUPS[kind]):
        if ep.name in found and found[ep.name].value != ep.value:
            warnings.warn(
                f"dsmv plugin {kind}:{ep.name} is registered twice "
                f"({found[ep.name].value} and {ep.value}); using the first",
                stacklevel=2,
            )
            continue
        found.setdefault(ep.name, ep)
    return dict(sorted(found.items()))


#: plugin packages that ship config groups (soil profiles, …): entry-point name → the package holding them
CONFIG_GROUP = "dsmv.configs"


def config_packages() -> dict[str, str]:
    """The packages plugins register under ``dsmv.configs`` (each holds config groups as folders)."""
    return {ep.name: ep.value for ep in sorted(registered(CONFIG_GROUP), key=lambda ep: ep.name)}


def package_folders(package: str) -> list[str] | None:
    """The folders of an importable package (a dotted name), or None when it does not import."""
    import importlib.util

    try:
        spec = importlib.util.find_spec(package)
    except (ImportError, ValueError):
        return None
    return list(spec.submodule_search_locations) if spec is not None and spec.submodule_search_locations else None


def config_dirs() -> list[str]:
    """The folders of the plugin packages' config trees (those that import), for listing their options."""
    folders = []
    for name, package in config_packages().items():
        found = package_folders(package)
        if found is None:
            warnings.warn(f"dsmv plugin {CONFIG_GROUP}:{name} names {package!r}, not an importable package",
                          stacklevel=2)
            continue
        folders += found
    return folders


def register_plugin_configs() -> None:
    """Put the plugin packages' config trees (entry points in ``dsmv.configs``) on Hydra's search path,
    after dsmv's own, for every composition in this process (the commands, ``--help``, the compose
    API): a search-path plugin registered with Hydra by hand, since Hydra's own discovery of
    ``hydra_plugins`` cannot see into editable installs. Idempotent."""
    from hydra.core.plugins import Plugins

    Plugins.instance().register(_plugin_config_search_path())


@functools.cache
def _plugin_config_search_path():
    """The search-path plugin class, made once (Hydra is imported only when dsmv composes)."""
    from hydra.plugins.search_path_plugin import SearchPathPlugin

    class PluginConfigs(SearchPathPlugin):
        def manipulate_search_path(self, search_path) -> None:
            for name, package in config_packages().items():
                search_path.append(provider=f"dsmv-plugin:{name}", path=f"pkg://{package}")

    return PluginConfigs


def check_name(kind: str, name: str, config_path: str) -> EntryPoint:
    """The entry point of ``name``; a ConfigError listing what is installed when it is not a plugin of ``kind``."""
    names = available(kind)
    if name not in names:
        listing = ", ".join(names) or "none installed"
        raise ConfigError(config_path, name, f"not an installed {kind[:-1].replace('_', ' ')}; available: {listing}")
    return names[name]


def load(kind: str, name: str, config_path: str):
    """Load the object registered as ``name`` in the group of ``kind``; a target that does not import is
    a ConfigError naming the entry point (a typo in a plugin's ``pyproject.toml`` fails at composition)."""
    entry = check_name(kind, name, config_path)
    try:
        return entry.load()
    except Exception as error:  # ImportError, AttributeError, or the plugin's own import-time bug
        raise ConfigError(config_path, name, f"its entry point {entry.value} in {GROUPS[kind]} does not load: "
                          f"{type(error).__name__}: {error}") from None


def broken() -> list[str]:
    """Every installed plugin that does not load, one line each (``dsmv-plugins --check``)."""
    lines = []
    for kind, group in GROUPS.items():
        for name, entry in available(kind).items():
            try:
                load(kind, name, group)
            except ConfigError as error:
                lines.append(f"{group}:{name} = {entry.value}: {error.allowed}")
    for name, package in config_packages().items():
        if package_folders(package) is None:
            lines.append(f"{CONFIG_GROUP}:{name} = {package}: not an importable package")
    return lines
