"""A `triangulate` call on a small image with no option and no camera: one native call.

`rangemesh.pipeline.triangulate` hands such a call here before it resolves anything; this checks
what `rangemesh.pipeline.run` would check of it (the image's kind and size, a count of 3 or more,
the background, the memory) and `rangemesh.refine.small` meshes it with one native function.
Anything else, and a call the native function declines, goes the general way (None), which
refuses bad input with its own message or meshes it: the same mesh and stats either way.
"""

from __future__ import annotations

import math

import numpy as np

from . import memory
from .mesh import Mesh
from .params import OPTIONS_BY_NAME
from .refine.small import SMALL_PIXELS, mesh_small
from .resolve import defaults
from .timing import now

__all__ = ["small_call", "FLIPS_UNSET"]

# `triangulate`'s value of flips= when not given (its other options: None).
FLIPS_UNSET = OPTIONS_BY_NAME["flips"].unset
# The dtypes `rangemesh._core.refine_image` takes (native byte order).
_DTYPES = frozenset(np.dtype(t) for t in (np.float64, np.float32, np.uint16, np.uint8, np.int16,
                                          np.int32, np.uint32, np.int64, np.uint64, np.int8))
# The memory a small call needs at most (`memory_need` of SMALL_PIXELS pixels and as many
# vertices): with that much free, `check_memory` passes and an error bound's `vertex_ceiling` is
# beyond the default target's cap, so the small call checks nothing else.
SMALL_NEED = memory.memory_need((SMALL_PIXELS, 1), "refine", SMALL_PIXELS)
_FILL_GAPS = defaults().fill_gaps


def small_call(image: np.ndarray, vertices, background) -> Mesh | None:
    """``triangulate(image, vertices=vertices, background=background)`` as one native call, or None.

    `image` is an ndarray (its type checked by the caller); None: not a small image, a count or
    background the general path must check, too little memory free, or the native call declined.
    """
    t0 = now()
    if image.ndim != 2 or image.dtype not in _DTYPES or not image.flags.c_contiguous:
        return None
    h, w = image.shape
    n = h * w
    if h < 2 or w < 2 or n >= SMALL_PIXELS:
        return None
    if vertices is not None and not (type(vertices) is int and 3 <= vertices <= n):
        return None
    if type(background) is str:
        if background != "auto":
            return None
        # (`guess_background` without a camera: 0 in integer images, nothing in float ones)
        marker = 0.0 if image.dtype.kind != "f" else math.nan
    elif background is None:
        marker = math.nan  # (NaN and infinities only)
    elif (type(background) is int and -2**53 <= background <= 2**53) or \
            (type(background) is float and math.isfinite(background)):
        marker = float(background)
    else:
        return None
    free = memory.available_memory()
    if free is not None and free < SMALL_NEED:
        return None  # (the general path checks the memory: it refuses, or meshes)
    return mesh_small(image, vertices, marker, _FILL_GAPS, t0, now)
