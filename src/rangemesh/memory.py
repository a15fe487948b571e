"""The memory model: what meshing an image needs, and what the machine has free.

`check_memory` refuses an image before any work when its meshing would need
more than the memory available now (`available_memory`, Linux's
``MemAvailable``, read at most once a second); `vertex_ceiling` is where an
error bound's search stops for lack of memory. The figures a pixel and a
vertex are measured by ``benchmarks/memory.py``.
"""

from __future__ import annotations

import math
import time

__all__ = ["available_memory", "memory_need", "check_memory", "vertex_ceiling", "size_text",
           "BYTES_PER_PIXEL", "REFINE_BYTES_PER_PIXEL", "REFINE_BYTES_PER_VERTEX",
           "MEMINFO_SECONDS"]

# Peak working memory of `run` per image pixel, bytes: float64 depth, weights, the mask and
# the rest, measured by benchmarks/memory.py (4.2x a float32 image, 17 bytes a pixel), rounded up.
BYTES_PER_PIXEL = 20
# method="refine": bytes a pixel (depth, mask, the reference and render of an error bound) plus
# bytes a vertex (the insertion's triangles, heap and keys, the faces, the fit's system), from
# `python benchmarks/memory.py --refine` (2000 x 2000: 11-25 B a pixel, 370-640 B a vertex
# with strips; the report's dense max_error mesh 600), rounded up.
REFINE_BYTES_PER_PIXEL = 32
REFINE_BYTES_PER_VERTEX = 700


# `available_memory` reads /proc/meminfo at most once in this many seconds: the read weighs on
# a call on a small image, and a check that old still stops a runaway image.
MEMINFO_SECONDS = 1.0
_meminfo = [-math.inf, None]  # when read (time.monotonic), what was read


def available_memory() -> int | None:
    """Bytes of memory the system can give without swapping (Linux ``MemAvailable``), or None.

    Read at most once every `MEMINFO_SECONDS`.
    """
    now = time.monotonic()
    if now - _meminfo[0] < MEMINFO_SECONDS:
        return _meminfo[1]
    free = None
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    free = int(line.split()[1]) * 1024
                    break
    except (OSError, ValueError, IndexError):
        pass
    _meminfo[0], _meminfo[1] = now, free
    return free


def memory_need(shape, method: str = "paper", vertices: int | None = None) -> int:
    """Bytes `run` needs to mesh an image of `shape` with `method`, as `check_memory` counts them.

    ``'paper'``: BYTES_PER_PIXEL a pixel. ``'refine'``: REFINE_BYTES_PER_PIXEL a
    pixel plus REFINE_BYTES_PER_VERTEX for each of `vertices` (at most one a
    pixel; None: none counted, the error bound's search watches its count
    itself, `vertex_ceiling`).

    Examples
    --------
    >>> memory_need((100, 100)), memory_need((100, 100), "refine", 1000)
    (200000, 1020000)
    """
    pixels = int(shape[0]) * int(shape[1])
    if method != "refine":
        return pixels * BYTES_PER_PIXEL
    return pixels * REFINE_BYTES_PER_PIXEL + min(int(vertices or 0), pixels) * REFINE_BYTES_PER_VERTEX


def check_memory(shape, method: str = "paper", vertices: int | None = None) -> None:
    """Refuse an image whose meshing would need more memory than the machine has free.

    The rule: `memory_need` (20 bytes a pixel for the paper's method; for
    refine 32 a pixel and 700 a requested vertex), against the memory
    available now. Failing at once with a clear message beats being killed by
    the kernel's out-of-memory handler half way, or swapping the machine to a
    halt.

    Raises
    ------
    MemoryError
    """
    need = memory_need(shape, method, vertices)
    free = available_memory()
    if free is not None and need > free:
        per = (f"{BYTES_PER_PIXEL} bytes a pixel" if method != "refine" else
               f"{REFINE_BYTES_PER_PIXEL} bytes a pixel and {REFINE_BYTES_PER_VERTEX} a vertex")
        budget = f" with {vertices} vertices" if method == "refine" and vertices else ""
        raise MemoryError(
            f"a {shape[0]}x{shape[1]} image needs about {size_text(need)} of memory to mesh{budget} "
            f"({per}) and {size_text(free)} are available; mesh it in parts, with fewer vertices "
            f"or on a larger machine"
        )


def vertex_ceiling(shape) -> int | None:
    """Vertices method="refine" can make in the memory available now (None: not known).

    An error bound's search stops there (`run`) and says that memory, not
    the bound, ended it: its count is not known before the work.
    """
    free = available_memory()
    if free is None:
        return None
    rest = free - int(shape[0]) * int(shape[1]) * REFINE_BYTES_PER_PIXEL
    return max(rest // REFINE_BYTES_PER_VERTEX, 0)


def size_text(n: int) -> str:
    """Bytes as the messages write them: ``1.5 GiB``, ``30.0 MiB``."""
    return f"{n / 2**30:.1f} GiB" if n >= 2**30 else f"{n / 2**20:.1f} MiB"
