"""How many threads a call of method="refine" may use: the one place that decides.

The strips (`rangemesh.refine.strips`) run their two halves on two native
threads inside the compiled core, and the fit's pass (`rangemesh.refine.heights`)
splits its faces between threads the same way. The result never depends on
the number of threads.
"""

from __future__ import annotations

import os

__all__ = ["threads", "THREADS_VARIABLE"]

# Batch workers set it to 1: one process per core already uses the cores.
THREADS_VARIABLE = "RANGEMESH_THREADS"


def threads() -> int:
    """Two where this process may use two cores, unless ``RANGEMESH_THREADS`` says fewer; else one."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    value = os.environ.get(THREADS_VARIABLE, "").strip()
    setting = int(value) if value.isdigit() else 2
    return max(1, min(2, cores or 1, setting))
