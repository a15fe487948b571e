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


@njit(cache=True)
def valid_faces(vr, vc, tv, valid):
    """The triangles whose three corners are valid pixels, and the vertices they use.

    Parameters
    ----------
    vr, vc : (V,) int arrays
        Each vertex's pixel.
    tv : (3 * T,) int array
        Triangles as vertex ids, three a triangle.
    valid : (H, W) bool array

    Returns
    -------
    faces : (F, 3) int32
        The kept triangles, in their order, corners in their order, numbered
        as the vertices they use keep their order.
    pixels : (U, 2) int32
        ``(row, col)`` of those vertices.

    (In one pass: NumPy's fancy indexing, mask and renumbering took 4 ms on
    a 28,000-vertex mesh of a 640x480 frame, this 1 ms.)
    """
    n_t = tv.size // 3
    keep = np.zeros(n_t, np.bool_)
    used = np.zeros(vr.size, np.bool_)
    n_keep = 0
    for t in range(n_t):
        a = tv[3 * t]
        b = tv[3 * t + 1]
        c = tv[3 * t + 2]
        if valid[vr[a], vc[a]] and valid[vr[b], vc[b]] and valid[vr[c], vc[c]]:
            keep[t] = True
            used[a] = True
            used[b] = True
            used[c] = True
            n_keep += 1
    new_id = np.full(vr.size, -1, np.int64)
    n_used = 0
    for i in range(vr.size):
        if used[i]:
            new_id[i] = n_used
            n_used += 1
    faces = np.empty((n_keep, 3), np.int32)
    k = 0
    for t in range(n_t):
        if keep[t]:
            for j in range(3):
                faces[k, j] = new_id[tv[3 * t + j]]
            k += 1
    pixels = np.empty((n_used, 2), np.int32)
    for i in range(vr.size):
        if used[i]:
            pixels[new_id[i], 0] = vr[i]
            pixels[new_id[i], 1] = vc[i]
    return faces, pixels
