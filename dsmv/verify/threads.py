"""The Numba threads a benchmark runs on.

Numba is imported with dsmv, so setting ``NUMBA_NUM_THREADS`` afterwards reaches only child
processes: the kernels of this process run on the thread pool's size (one thread per core unless the
variable was set before). :func:`threads_unless_set` sets both, and leaves a variable the user set alone.
"""

from __future__ import annotations

import os


def threads_unless_set(count: int) -> int:
    """Run this process's compiled kernels, and its child processes', on ``count`` threads unless
    NUMBA_NUM_THREADS was set; returns the threads now in use."""
    import numba

    if "NUMBA_NUM_THREADS" not in os.environ:
        os.environ["NUMBA_NUM_THREADS"] = str(count)
        numba.set_num_threads(min(count, numba.config.NUMBA_DEFAULT_NUM_THREADS))
    return numba.get_num_threads()
