"""The second thread of method="refine": how many threads a call may use, and the one worker.

The strips (`rangemesh.greedy.strips`) run their two halves on two native
threads inside the compiled core; the fit's pass (`rangemesh.greedy.heights`)
hands half its work to one worker thread and does the other half itself. The
result never depends on the number of threads.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

__all__ = ["threads", "executor"]

_pool = None


def _setting() -> int | None:
    """``RANGEMESH_THREADS``, else ``NUMBA_NUM_THREADS`` (the paper's kernels' setting), if a number."""
    for name in ("RANGEMESH_THREADS", "NUMBA_NUM_THREADS"):
        value = os.environ.get(name, "").strip()
        if value.isdigit():
            return int(value)
    return None


def threads() -> int:
    """Two where this process may use two cores, unless ``RANGEMESH_THREADS=1``; else one.

    ``NUMBA_NUM_THREADS=1`` (what batch workers set for the paper's kernels)
    keeps one too when ``RANGEMESH_THREADS`` is not set.
    """
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    setting = _setting()
    return max(1, min(2, cores or 1, 2 if setting is None else setting))


def executor() -> ThreadPoolExecutor:
    """The one worker thread, started on first use."""
    global _pool
    if _pool is None:
        _pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="rangemesh")
    return _pool
