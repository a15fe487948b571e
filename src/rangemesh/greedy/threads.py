"""The second thread of method="refine": how many threads a call may use, and the one worker.

Kernels that run without the GIL (`rangemesh.greedy.strips`, the fit's pass in
`rangemesh.greedy.heights`) hand half their work to one worker thread and do
the other half themselves; the result never depends on the number of threads.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numba

__all__ = ["threads", "executor"]

_pool = None


def threads() -> int:
    """Two where this process may use two cores, unless ``NUMBA_NUM_THREADS=1``; else one."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return max(1, min(2, cores or 1, numba.config.NUMBA_NUM_THREADS))


def executor() -> ThreadPoolExecutor:
    """The one worker thread, started on first use."""
    global _pool
    if _pool is None:
        _pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="rangemesh")
    return _pool
