"""Where the Hydra config tree is: :data:`CONFIG_DIR`."""

from __future__ import annotations

from pathlib import Path


def find_config_dir() -> Path:
    """The Hydra config tree: ``dsmv/conf`` in an installed wheel, else ``conf/`` of the source checkout.

    pyproject.toml maps the checkout's top-level ``conf/`` into the wheel as the package data
    ``dsmv/conf``; an editable install or a plain checkout reads ``conf/`` beside the package.
    """
    package = Path(__file__).resolve().parents[1]
    for candidate in (package / "conf", package.parent / "conf"):
        if (candidate / "config.yaml").is_file():
            return candidate
    raise FileNotFoundError(f"no Hydra config tree (conf/config.yaml) in {package} or beside it")


#: the Hydra config tree every entry point composes from
CONFIG_DIR = str(find_config_dir())


def data_path(value) -> Path:
    """A data file named in a config (a strength profile's CSV, a site test's): a relative path from the
    working folder, else from the project's folder (the one holding ``conf/``), as the configs name them."""
    path = Path(value)
    if path.is_absolute() or path.exists():
        return path
    return Path(CONFIG_DIR).parent / path
