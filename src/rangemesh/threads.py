"""How many native threads a meshing call may use: the one place that decides.

Refine's strips (`rangemesh.refine.strips`) run their two halves on two native
threads inside the compiled core, its fit's pass (`rangemesh.refine.heights`)
splits its faces between threads the same way, and the paper's stage one shares
its tiles between threads (`rangemesh.paper.sampling`). No result depends on
the number of threads.
"""

from __future__ import annotations

import contextlib
import os
import threading

__all__ = ["threads", "THREADS_VARIABLE", "one_thread"]

# Batch workers set it to 1: one process per core already uses the cores.
THREADS_VARIABLE = "RANGEMESH_THREADS"


def threads(most: int = 2) -> int:
    """`most` threads (refine's two), within the cores and ``RANGEMESH_THREADS``; at least one.

    No more than the cores this process may use, nor than ``RANGEMESH_THREADS`` says. One on a
    thread within `one_thread` (a frame worker of `rangemesh.live`).
    """
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    value = os.environ.get(THREADS_VARIABLE, "").strip()
    setting = int(value) if value.isdigit() else most
    if getattr(_local, "one", False):  # a worker of a pool that already uses the cores
        setting = 1
    return max(1, min(int(most), cores or 1, setting))


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
