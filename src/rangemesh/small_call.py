"""A `triangulate` call on a small image with no option and no camera: one native call.

`rangemesh.pipeline.triangulate` hands such a call here before it resolves anything; this checks
what `rangemesh.pipeline.run` would check of its count, background and memory, and
`rangemesh.refine.small` meshes it with one native function, which checks the image itself (its
kind and size). Anything else, and a call the native function declines, goes the general way
(None), which refuses bad input with its own message or meshes it: the same mesh and stats
either way.
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
# The memory a small call needs at most (`memory_need` of SMALL_PIXELS pixels and as many
# vertices): with that much free, `check_memory` passes and an error bound's `vertex_ceiling` is
# beyond the default target's cap, so the small call checks nothing else.
SMALL_NEED = memory.memory_need((SMALL_PIXELS, 1), "refine", SMALL_PIXELS)
_FILL_GAPS = defaults().fill_gaps
# the markers of missing depth in an integer image and in a float one (NaN: none), and the fill:
# `guess_background` without a camera (0 in integer images, nothing in float ones), and None's
_AUTO_MASKING = (0.0, math.nan, _FILL_GAPS)
_NAN_MASKING = (math.nan, math.nan, _FILL_GAPS)  # (NaN and infinities only)


def small_call(image: np.ndarray, vertices, background) -> Mesh | None:
    """``triangulate(image, vertices=vertices, background=background)`` as one native call, or None.

    `image` is an ndarray (its type checked by the caller); None: not a small image, a count or
    background the general path must check, too little memory free, or the native call declined.
    """
    t0 = now()
    # (a count beyond the image's pixels: the native call finds too few valid ones, and declines)
    if vertices is not None and not (type(vertices) is int and 3 <= vertices < SMALL_PIXELS):
        return None
    if type(background) is str:
        if background != "auto":
            return None
        masking = _AUTO_MASKING
    elif background is None:
        masking = _NAN_MASKING
    elif (type(background) is int and -2**53 <= background <= 2**53) or \
            (type(background) is float and math.isfinite(background)):
        masking = (float(background), float(background), _FILL_GAPS)
    else:
        return None
    free = memory.available_memory()
    if free is not None and free < SMALL_NEED:
        return None  # (the general path checks the memory: it refuses, or meshes)
    return mesh_small(image, vertices, masking, t0, now)
