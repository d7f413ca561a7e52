"""The Hydra config tree: where it is (:data:`CONFIG_DIR`), what it needs to compose (the OmegaConf
resolvers of :mod:`dsmv.config.scene`; dsmv's case sweeper, ``hydra/sweeper=cases``, registered with
Hydra on import) and composing from it outside a command (:func:`compose`, :func:`compose_scene`),
the plugin packages' config groups on the search path."""

from __future__ import annotations

from hydra.core.plugins import Plugins

from dsmv.config.location import CONFIG_DIR  # noqa: F401 (where the entry points find it)
from dsmv.config.scene import Scene, build_scene
from dsmv.registry import register_plugin_configs
from hydra_plugins.dsmv_sweeper.case_sweeper import CaseSweeper

# Hydra finds sweepers and launchers by walking the hydra_plugins namespace, which an editable
# install does not expose to that walk: register ours by hand (a no-op when Hydra found them). The
# sweeper is imported before Hydra's first walk, which cannot load its dataclasses itself; the
# launchers are the commands' (dsmv.app.command_line).
Plugins.instance().register(CaseSweeper)




def compose(config_name: str, overrides: list[str]):
    """The composed (unvalidated) config ``config_name`` (``config``: a scene, ``train``: a surrogate's
    training) with ``overrides`` (Hydra syntax, as on the command line)."""
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra

    register_plugin_configs()
    GlobalHydra.instance().clear()
    try:
        with initialize_config_dir(config_dir=CONFIG_DIR, version_base="1.3"):
            return hydra_compose(config_name, overrides=list(overrides))
    finally:
        GlobalHydra.instance().clear()


def compose_scene(overrides: list[str]) -> Scene:
    """The validated scene of ``overrides``, composed from the config tree exactly as the CLI does."""
    return build_scene(compose("config", overrides))
