"""dsmv — landing sinkage of deep-sea mining vehicles on ultra-soft seabed clay.

Scenes are composed from Hydra YAML (``conf/``), validated into typed objects
(:mod:`dsmv.config.scene`), solved by a solver plugin (analytic energy method or the CEL
solver) with a soil-law plugin, and tracked in MLflow (:mod:`dsmv.tracking.runs`).
SI units throughout: m, kg, s, Pa, N, J.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("dsmv")
except PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0.0.0+unknown"

# Before any CEL kernel is defined: Numba's cache goes to a directory keyed on the CEL sources.
from dsmv.numba_cache import configure as _configure_numba_cache

_configure_numba_cache()
