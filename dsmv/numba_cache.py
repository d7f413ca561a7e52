"""Numba's on-disk cache, keyed on the source of every CEL kernel.

Numba keys a cached function only on its own file: ``run_steps`` (dsmv/cel/stepper2d.py) would keep
the kernels it inlined from dsmv/cel/kernels/ after they changed. So the cache lives in a
directory named after a hash of every ``dsmv/cel/**/*.py`` file: ``<base>/<hash>``, where the base
is ``$NUMBA_CACHE_DIR`` when it is set, else ``$XDG_CACHE_HOME/dsmv/numba`` (``~/.cache/dsmv/numba``).
A change to any CEL source starts a fresh cache; the old ones stay until the base is removed.

:func:`configure` runs when ``dsmv`` is imported, before any kernel is defined. Numba reads
``NUMBA_CACHE_DIR`` when it is imported and again whenever an ``NUMBA_*`` variable changed before
a compilation; a cached function takes its cache directory when it is defined. configure sets
the variable (inherited by subprocesses and launcher workers, which keep it), and
``numba.config.CACHE_DIR`` too when numba was imported first.
"""

from __future__ import annotations

import hashlib
import os
import sys
from pathlib import Path

#: the sources hashed: every Python file below it
CEL_DIR = Path(__file__).resolve().parent / "cel"
HASH_CHARS = 16


def source_hash(root: Path = CEL_DIR) -> str:
    """A short sha256 over every ``*.py`` below ``root``: relative paths (sorted) and contents."""
    digest = hashlib.sha256()
    files = sorted(p for p in Path(root).rglob("*.py") if "__pycache__" not in p.parts)
    for path in files:
        data = path.read_bytes()
        digest.update(f"{path.relative_to(root).as_posix()}\0{len(data)}\0".encode())
        digest.update(data)
    return digest.hexdigest()[:HASH_CHARS]


def default_base() -> Path:
    """Where the caches go when NUMBA_CACHE_DIR is not set."""
    cache_home = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(cache_home) / "dsmv" / "numba"


def keyed_dir(given: str | None, key: str) -> Path:
    """``<given or the default base>/<key>``; a directory already keyed (a parent process's) is kept."""
    if given and Path(given).name == key:
        return Path(given)
    return Path(given or default_base()) / key


def configure() -> Path:
    """Point Numba's cache at ``<base>/<hash of dsmv/cel>`` and return that directory."""
    numba = sys.modules.get("numba")
    given = os.environ.get("NUMBA_CACHE_DIR") or (numba.config.CACHE_DIR if numba is not None else "")
    cache_dir = keyed_dir(given, source_hash())
    os.environ["NUMBA_CACHE_DIR"] = str(cache_dir)
    if numba is not None:  # imported first: it read the variable already
        numba.config.CACHE_DIR = str(cache_dir)
    return cache_dir
