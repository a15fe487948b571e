"""Kernels on the pixel grid: turning a raw image into float depth and a validity mask."""

import math

import numpy as np
from numba import njit


@njit(cache=True)
def mask_image(arr, has_background, background, depth, valid):
    """Float depth and validity of a raw image: NaN, inf and `background` are invalid.

    Background pixels get depth 0.0, a value no later stage reads. Integers are
    compared as float64, exactly as NumPy compares them with a float marker.
    """
    h, w = arr.shape
    for r in range(h):
        for c in range(w):
            x = np.float64(arr[r, c])
            ok = math.isfinite(x)
            if ok and has_background and x == background:
                ok = False
            valid[r, c] = ok
            depth[r, c] = x if ok else 0.0


@njit(cache=True)
def valid_range(depth, valid):
    """(min, max, count) of the valid depths; (0, 0, 0) when there is none."""
    lo = np.inf
    hi = -np.inf
    n = 0
    h, w = depth.shape
    for r in range(h):
        for c in range(w):
            if valid[r, c]:
                x = depth[r, c]
                n += 1
                if x < lo:
                    lo = x
                if x > hi:
                    hi = x
    if n == 0:
        return 0.0, 0.0, 0
    return lo, hi, n


@njit(cache=True)
def covered_error(pred, depth, valid):
    """(sum of |pred - depth|, count) over the valid pixels where `pred` is finite.

    One pass, no temporary arrays: `rangemesh.render.relative_error` on a
    NumPy mask and fancy indexing spent more time here than in the render.
    """
    total = 0.0
    n = 0
    h, w = depth.shape
    for r in range(h):
        for c in range(w):
            if valid[r, c]:
                p = pred[r, c]
                if math.isfinite(p):
                    total += abs(p - depth[r, c])
                    n += 1
    return total, n
