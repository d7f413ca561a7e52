"""A built wheel is self-contained: it carries the Hydra config tree and runs a scene outside the checkout.

The wheel is built by pip from a copy of the sources (so the checkout gets no build/ or egg-info),
with build isolation: the build backend pyproject.toml asks for comes from the package index (or
pip's cache). It is unpacked into a folder that stands for site-packages, and dsmv runs from there
under ``python -S``: no .pth file is read, so the editable install of the checkout cannot be
imported, and the dependencies come from this interpreter's site-packages, named explicitly.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SOURCES = ("pyproject.toml", "README.md", "dsmv", "plugins", "hydra_plugins", "conf")

RUN_FROM_WHEEL = """
import sys
import dsmv, dsmv.app.cli, dsmv.config.tree
print("dsmv from", dsmv.__file__, file=sys.stderr)
print("config from", dsmv.config.tree.CONFIG_DIR, file=sys.stderr)
assert dsmv.__file__.startswith(sys.argv[1]), dsmv.__file__
assert dsmv.config.tree.CONFIG_DIR.startswith(sys.argv[1]), dsmv.config.tree.CONFIG_DIR
sys.argv = ["dsmv", *sys.argv[2:]]
dsmv.app.cli.simulate()
"""


def _build_wheel(tmp_path: Path) -> Path:
    src = tmp_path / "src"
    src.mkdir()
    for name in SOURCES:
        if (ROOT / name).is_dir():
            shutil.copytree(ROOT / name, src / name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        else:
            shutil.copy2(ROOT / name, src / name)
    dist = tmp_path / "dist"
    proc = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--quiet", "-w", str(dist), str(src)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    (wheel,) = dist.glob("dsmv-*.whl")
    return wheel


def test_the_wheel_carries_the_config_tree_and_runs_a_scene(tmp_path):
    wheel = _build_wheel(tmp_path)
    names = set(zipfile.ZipFile(wheel).namelist())
    tree = {p.relative_to(ROOT).as_posix() for pattern in ("*.yaml", "*.csv") for p in (ROOT / "conf").rglob(pattern)}
    missing = {name for name in tree if f"dsmv/{name}" not in names}
    assert not missing, f"config files not in the wheel: {sorted(missing)}"
    packages = {p.relative_to(ROOT).as_posix() for p in (ROOT / "dsmv").rglob("__init__.py")}
    assert not packages - names, f"packages not in the wheel: {sorted(packages - names)}"

    site = tmp_path / "site"
    zipfile.ZipFile(wheel).extractall(site)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = dict(os.environ, NUMBA_NUM_THREADS="1", HYDRA_FULL_ERROR="0",
               PYTHONPATH=os.pathsep.join([str(site), sysconfig.get_paths()["purelib"]]))
    args = ["solver=analytic_energy", "tracking=disabled", "output.plots=false"]
    proc = subprocess.run([sys.executable, "-S", "-c", RUN_FROM_WHEEL, str(site), *args],
                          cwd=elsewhere, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert f"dsmv from {site}" in proc.stderr
    assert "dsmv: ok" in proc.stdout
    (result,) = elsewhere.glob("runs/outputs/*/*/result.json")
    assert json.loads(result.read_text())["status"] == "ok"
