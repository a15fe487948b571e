"""How many threads a call of method="refine" may use: the one place that decides.

The strips (`rangemesh.refine.strips`) run their two halves on two native
threads inside the compiled core, and the fit's pass (`rangemesh.refine.heights`)
splits its faces between threads the same way. The result never depends on
the number of threads.
"""

from __future__ import annotations

import contextlib
import os
import threading

__all__ = ["threads", "THREADS_VARIABLE", "one_thread"]

# Batch workers set it to 1: one process per core already uses the cores.
THREADS_VARIABLE = "RANGEMESH_THREADS"


def threads() -> int:
    """Two where this process may use two cores, unless ``RANGEMESH_THREADS`` says fewer; else one.

    One on a thread within `one_thread` (a frame worker of `rangemesh.live`).
    """
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    value = os.environ.get(THREADS_VARIABLE, "").strip()
    setting = int(value) if value.isdigit() else 2
    if getattr(_local, "one", False):  # a worker of a pool that already uses the cores
        setting = 1
    return max(1, min(2, cores or 1, setting))


_local = threading.local()


@contextlib.contextmanager
def one_thread():
    """Within it, calls on this thread use one native thread (`rangemesh.live`'s frame workers)."""
    before = getattr(_local, "one", False)
    _local.one = True
    try:
        yield
    finally:
        _local.one = before
