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


@njit(cache=True)
def nearest_valid(valid, r, c):
    """The valid pixel nearest pixel (r, c), ties to the smallest (row, col); (-1, -1) if none.

    Square windows around (r, c), doubling until the nearest pixel found lies
    within the window's reach (every pixel outside it is at least as far as
    its half-width): O(window), not a distance transform of the whole image.
    Visited row by row, a strictly nearer pixel replaces the best, so the
    first of equally near ones stays.
    """
    h, w = valid.shape
    k = 8
    while True:
        r0, r1 = max(r - k + 1, 0), min(r + k - 1, h - 1)
        c0, c1 = max(c - k + 1, 0), min(c + k - 1, w - 1)
        best, br, bc = -1, -1, -1
        for i in range(r0, r1 + 1):
            for j in range(c0, c1 + 1):
                if valid[i, j]:
                    d = (i - r) * (i - r) + (j - c) * (j - c)
                    if best < 0 or d < best:
                        best, br, bc = d, i, j
        whole = r0 == 0 and c0 == 0 and r1 == h - 1 and c1 == w - 1
        if (best >= 0 and best < k * k) or whole:
            return br, bc
        k *= 2


@njit(cache=True)
def grid_pixels(valid, n_rows, n_cols, c_lo, c_hi, inner):
    """The corners of columns `c_lo`..`c_hi`, then the valid centres of an `n_rows` x `n_cols` grid.

    Returns ``(rows, cols)``, int64: (0, c_lo), (H-1, c_lo), (H-1, c_hi),
    (0, c_hi), then row by row the distinct grid pixels ``((i + 0.5) * H /
    n_rows, c_lo + (j + 0.5) * W / n_cols)`` (truncated; W the strip's width)
    that are valid and no corner, and with `inner` none on the first or last
    column either. No grid when `n_rows` or `n_cols` is below 2.
    """
    h = valid.shape[0]
    w = c_hi - c_lo + 1
    if n_rows < 2 or n_cols < 2:
        n_rows = n_cols = 0
    rows = np.empty(n_rows, np.int64)
    cols = np.empty(n_cols, np.int64)
    n_r = 0
    for i in range(n_rows):  # non-decreasing: distinct values are consecutive
        x = int((i + 0.5) * h / n_rows)
        if n_r == 0 or x != rows[n_r - 1]:
            rows[n_r] = x
            n_r += 1
    n_c = 0
    for j in range(n_cols):
        x = c_lo + int((j + 0.5) * w / n_cols)
        if n_c == 0 or x != cols[n_c - 1]:
            cols[n_c] = x
            n_c += 1
    vr = np.empty(4 + n_r * n_c, np.int64)
    vc = np.empty(4 + n_r * n_c, np.int64)
    vr[0], vr[1], vr[2], vr[3] = 0, h - 1, h - 1, 0
    vc[0], vc[1], vc[2], vc[3] = c_lo, c_lo, c_hi, c_hi
    n = 4
    for i in range(n_r):
        r = rows[i]
        for j in range(n_c):
            c = cols[j]
            if not valid[r, c]:
                continue
            if (r == 0 or r == h - 1) and (c == c_lo or c == c_hi):
                continue
            if inner and (c == c_lo or c == c_hi):
                continue
            vr[n] = r
            vc[n] = c
            n += 1
    return vr[:n].copy(), vc[:n].copy()
