"""The compiled kernels load from Numba's on-disk cache in a new process: the typed containers
(NamedTuples of arrays and scalars) and the soil law's kernel tuple are cacheable argument types."""

from __future__ import annotations

import json
import os
import subprocess
import sys

PROBE = """
import json
from hydra import compose, initialize_config_dir
from dsmv.cli import CONFIG_DIR
from dsmv.scene import build_scene
from dsmv.cel import stepper
from dsmv.cel.kernels import nodes, plane, remap2d
from dsmv.cel.solver import Cel2DSolver
with initialize_config_dir(config_dir=CONFIG_DIR, version_base="1.3"):
    cfg = compose("config", overrides=["solver=cel2d", "mesh=coarse", "tracking=disabled", "solver.progress=off",
                                       "soil.law=einav_randolph"])
result = Cel2DSolver(build_scene(cfg)).solve()
dispatchers = [f for m in (stepper, nodes, plane, remap2d) for f in vars(m).values() if hasattr(f, "stats")]
print(json.dumps({"status": result.status, "run_steps_hits": sum(stepper.run_steps.stats.cache_hits.values()),
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
