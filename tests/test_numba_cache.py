"""Numba's cache directory is keyed on the CEL sources (<base>/<hash of dsmv/cel/**/*.py>), and the
compiled kernels load from it in a new process: the typed containers (NamedTuples of arrays and
scalars) and the soil law's kernel tuple are cacheable argument types."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

from dsmv import numba_cache
from dsmv.numba_cache import CEL_DIR, source_hash


def _copy_cel(dest: Path) -> Path:
    shutil.copytree(CEL_DIR, dest, ignore=shutil.ignore_patterns("__pycache__"))
    return dest


def test_one_changed_byte_gives_another_hash(tmp_path):
    a, b = _copy_cel(tmp_path / "a"), _copy_cel(tmp_path / "b")
    assert source_hash(a) == source_hash(b) == source_hash(CEL_DIR)
    kernels = b / "kernels" / "elements2d.py"
    data = bytearray(kernels.read_bytes())
    data[-2] = ord("#") if data[-2] != ord("#") else ord(" ")
    kernels.write_bytes(bytes(data))
    assert source_hash(b) != source_hash(a)
    assert len(source_hash(a)) == numba_cache.HASH_CHARS


def test_the_paths_are_hashed_too(tmp_path):
    a, b = _copy_cel(tmp_path / "a"), _copy_cel(tmp_path / "b")
    (b / "grid.py").rename(b / "grid2.py")
    assert source_hash(b) != source_hash(a)
    (a / "sub").mkdir()
    (a / "sub" / "extra.py").write_text("")  # subfolders count, empty files too
    assert source_hash(a) != source_hash(_copy_cel(tmp_path / "c"))


def test_the_given_base_is_keyed_once(tmp_path):
    key = source_hash()
    first = numba_cache.keyed_dir(str(tmp_path / "base"), key)
    assert first == tmp_path / "base" / key
    # a subprocess inherits the keyed directory and keeps it
    assert numba_cache.keyed_dir(str(first), key) == first


def test_default_base_is_under_the_user_cache_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert numba_cache.keyed_dir(None, "k") == tmp_path / "xdg" / "dsmv" / "numba" / "k"
    assert numba_cache.keyed_dir("", "k") == tmp_path / "xdg" / "dsmv" / "numba" / "k"


KERNEL_CACHE = """
import sys
{first}
import dsmv
import numba
from dsmv.cel import stepper2d
from dsmv.cel.kernels import elements2d
print(numba.config.CACHE_DIR)
print(stepper2d.run_steps._cache._cache_path)
print(elements2d.update_stress._cache._cache_path)
"""


def _in_subprocess(script: str, tmp_path: Path, **env: str) -> list[str]:
    environ = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"} | env
    proc = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, env=environ, capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout.split()


def test_the_kernels_cache_in_the_keyed_dir(tmp_path):
    keyed = str(tmp_path / "base" / source_hash())
    lines = _in_subprocess(KERNEL_CACHE.format(first=""), tmp_path, NUMBA_CACHE_DIR=str(tmp_path / "base"))
    assert lines[0] == keyed
    assert all(line.startswith(keyed + os.sep) for line in lines[1:])


def test_the_kernels_cache_in_the_keyed_dir_when_numba_came_first(tmp_path):
    keyed = str(tmp_path / "base" / source_hash())
    lines = _in_subprocess(KERNEL_CACHE.format(first="import numba"), tmp_path,
                           NUMBA_CACHE_DIR=str(tmp_path / "base"))
    assert lines[0] == keyed
    assert all(line.startswith(keyed + os.sep) for line in lines[1:])


def test_without_numba_cache_dir_the_user_cache_dir_is_the_base(tmp_path):
    keyed = str(tmp_path / "xdg" / "dsmv" / "numba" / source_hash())
    lines = _in_subprocess(KERNEL_CACHE.format(first=""), tmp_path, XDG_CACHE_HOME=str(tmp_path / "xdg"))
    assert lines[0] == keyed
    assert all(line.startswith(keyed + os.sep) for line in lines[1:])


COMPILE_AFTER_NUMBA = """
import sys
import numba
import dsmv
sys.path.insert(0, sys.argv[1])
import tiny
assert tiny.twice(2.0) == 4.0
print(numba.config.CACHE_DIR)
"""


def test_a_compilation_after_numba_came_first_writes_the_keyed_dir(tmp_path):
    """numba.config.CACHE_DIR takes effect, and Numba's re-read of the environment at compile keeps it."""
    (tmp_path / "mod").mkdir()
    (tmp_path / "mod" / "tiny.py").write_text("from numba import njit\n\n\n@njit(cache=True)\n"
                                              "def twice(x):\n    return 2.0 * x\n")
    keyed = tmp_path / "base" / source_hash()
    environ = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"} | {"NUMBA_CACHE_DIR": str(tmp_path / "base")}
    proc = subprocess.run([sys.executable, "-c", COMPILE_AFTER_NUMBA, str(tmp_path / "mod")], cwd=tmp_path,
                          env=environ, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == [str(keyed)]
    assert list(keyed.rglob("tiny.twice-*.nbi")), sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*"))
    assert not list((tmp_path / "mod").rglob("*.nbi"))


PROBE = """
import json
from hydra import compose, initialize_config_dir
from dsmv.cel import stepper2d
from dsmv.cel.kernels import nodes, elements2d, remap2d
from dsmv.cel.solver2d import Cel2DSolver
from dsmv.config.scene import build_scene
from dsmv.config.tree import CONFIG_DIR
with initialize_config_dir(config_dir=CONFIG_DIR, version_base="1.3"):
    cfg = compose("config", overrides=["solver=cel2d", "mesh=coarse", "tracking=disabled", "solver.progress=off",
                                       "soil.law=einav_randolph"])
result = Cel2DSolver(build_scene(cfg)).solve()
dispatchers = [f for m in (stepper2d, nodes, elements2d, remap2d) for f in vars(m).values() if hasattr(f, "stats")]
print(json.dumps({"status": result.status, "run_steps_hits": sum(stepper2d.run_steps.stats.cache_hits.values()),
                  "hits": sum(sum(f.stats.cache_hits.values()) for f in dispatchers),
                  "misses": sum(sum(f.stats.cache_misses.values()) for f in dispatchers)}))
"""


def probe(env):
    out = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_a_second_process_compiles_nothing(tmp_path):
    env = dict(os.environ, NUMBA_NUM_THREADS="1")
    env.setdefault("NUMBA_CACHE_DIR", str(tmp_path / "numba"))
    probe(env)  # compiles what the cache lacks
    second = probe(env)
    assert second["status"] == "ok"
    assert second["misses"] == 0 and second["run_steps_hits"] == 1, second
