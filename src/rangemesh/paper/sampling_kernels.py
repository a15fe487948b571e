"""Numba kernels of stage one (paper II.A): gap filling, curvature, inverse-CDF tile sampling.

Kernels trust their inputs; `rangemesh.paper.sampling` checks and allocates.
"""

import math

import numpy as np
from numba import njit, prange


@njit(cache=True)
def fill_gaps_inplace(depth, valid):
    """SPEC 1.1 in one pass, in place: a background pixel with 8 valid neighbours gets their mean.

    `depth` holds 0.0 on background. Holes are found first and filled after,
    so a pixel filled in this pass never counts as a valid neighbour of
    another. The 8 neighbours are added in row-major order, the order of the
    NumPy reference, so results agree bit for bit. Returns the number filled.
    """
    h, w = depth.shape
    rows = np.zeros(16, np.int64)
    cols = np.zeros(16, np.int64)
    vals = np.zeros(16)
    n = 0
    for r in range(1, h - 1):
        for c in range(1, w - 1):
            if valid[r, c]:
                continue
            ok = True
            for dr in range(-1, 2):
                for dc in range(-1, 2):
                    if (dr != 0 or dc != 0) and not valid[r + dr, c + dc]:
                        ok = False
            if not ok:
                continue
            total = 0.0
            for dr in range(-1, 2):
                for dc in range(-1, 2):
                    if dr != 0 or dc != 0:
                        total += depth[r + dr, c + dc]
            if n == rows.size:
                rows = np.concatenate((rows, np.zeros(n, np.int64)))
                cols = np.concatenate((cols, np.zeros(n, np.int64)))
                vals = np.concatenate((vals, np.zeros(n)))
            rows[n] = r
            cols[n] = c
            vals[n] = total / 8.0
            n += 1
    for k in range(n):
        depth[rows[k], cols[k]] = vals[k]
        valid[rows[k], cols[k]] = True
    return n


@njit(cache=True, inline="always")
def _second_diff(a, b, c, va, vb, vc, jump):
    n_valid = int(va) + int(vb) + int(vc)
    if n_valid == 3:
        return abs(a - 2.0 * b + c)
    if n_valid == 0:
        return 0.0
    return jump


@njit(cache=True)
def curvature_kernel(d, v, jump, levels, K):
    """SPEC 1.2-1.3 in loops: K += K_l[r >> l, c >> l] for each level l (K starts at 0).

    Level l reads the image one pixel in 2**l; a stencil leaving the (sub-sampled)
    image adds 0, one mixing valid and background pixels adds `jump`. Per level
    the row term is added before the column term, as in the NumPy reference,
    so results agree bit for bit.
    """
    h, w = d.shape
    for level in range(levels):
        step = 1 << level
        hs = (h + step - 1) // step
        ws = (w + step - 1) // step
        if hs < 3 and ws < 3:
            break
        # level 0 accumulates straight into K (0.0 + x == x, so the sums are unchanged)
        k = K if level == 0 else np.zeros((hs, ws))
        for i in range(1, hs - 1):  # along rows (axis 0)
            r0 = (i - 1) * step
            r1 = i * step
            r2 = (i + 1) * step
            for j in range(ws):
                c = j * step
                k[i, j] += _second_diff(d[r0, c], d[r1, c], d[r2, c], v[r0, c], v[r1, c],
                                        v[r2, c], jump)
        for i in range(hs):  # along columns (axis 1)
            r = i * step
            for j in range(1, ws - 1):
                c0 = (j - 1) * step
                c1 = j * step
                c2 = (j + 1) * step
                k[i, j] += _second_diff(d[r, c0], d[r, c1], d[r, c2], v[r, c0], v[r, c1],
                                        v[r, c2], jump)
        if level > 0:
            for r in range(h):
                kr = r >> level
                for c in range(w):
                    K[r, c] += k[kr, c >> level]


@njit(cache=True)
def _invert_cdf(cum, n, count, out):
    """Invert a strictly increasing cumulative weight at `count` equally spaced targets.

    ``cum[0] = 0`` and ``cum[n-1] = M``. Target ``j`` is ``j*M/(count-1)``; its
    position is interpolated linearly between the two pixels that bracket it and
    rounded half up (``floor(x + 0.5)``). The first and last targets are pinned
    to 0 and n-1 so that neighbouring tiles meet exactly.
    """
    m = cum[n - 1]
    out[0] = 0
    out[count - 1] = n - 1
    k = 0
    for j in range(1, count - 1):
        y = j * m / (count - 1)
        while k < n - 2 and cum[k + 1] < y:
            k += 1
        lo = cum[k]
        hi = cum[k + 1]
        x = k + (y - lo) / (hi - lo)
        out[j] = int(math.floor(x + 0.5))


@njit(cache=True)
def _sample_tile(f, v, h, r0, nr, c0, nc, rs, zs, grid, cum, pos_c, pos_r, hs):
    """One tile of stage one: rows sampled at zs columns, then the curves at rs rows."""
    # Horizontal pass: each pixel row of the tile sampled at zs columns.
    for i in range(nr):
        r = r0 + i
        cum[0] = 0.0
        for k in range(1, nc):
            cum[k] = cum[k - 1] + f[r, c0 + k]
        _invert_cdf(cum, nc, zs, pos_c)
        for j in range(zs):
            hs[i, j] = c0 + pos_c[j]
    # Vertical pass: each curve (r, HS(r, j)) sampled at rs rows.
    for j in range(zs):
        cum[0] = 0.0
        for k in range(1, nr):
            cum[k] = cum[k - 1] + f[r0 + k, hs[k, j]]
        _invert_cdf(cum, nr, rs, pos_r)
        for i in range(rs):
            gi = v * (rs - 1) + i
            gj = h * (zs - 1) + j
            grid[gi, gj, 0] = r0 + pos_r[i]
            grid[gi, gj, 1] = hs[pos_r[i], j]


@njit(cache=True)
def sample_tiles(f, row_bounds, col_bounds, rs, zs, grid):
    """Fill the sample grid tile by tile (paper II.A.3, SPEC 1.6-1.8).

    Parameters
    ----------
    f : (H, W) float64, positive weights.
    row_bounds, col_bounds : int64 arrays of V+1 and H+1 tile borders.
    rs, zs : samples per tile along rows and columns.
    grid : ((rs-1)V+1, (zs-1)H+1, 2) int32, filled in place.
    """
    n_v = row_bounds.size - 1
    n_h = col_bounds.size - 1
    max_rows = 0
    for v in range(n_v):
        max_rows = max(max_rows, row_bounds[v + 1] - row_bounds[v] + 1)
    max_cols = 0
    for h in range(n_h):
        max_cols = max(max_cols, col_bounds[h + 1] - col_bounds[h] + 1)
    cum = np.zeros(max(max_rows, max_cols))
    pos_c = np.zeros(zs, np.int64)
    pos_r = np.zeros(rs, np.int64)
    hs = np.zeros((max_rows, zs), np.int64)
    for v in range(n_v):
        for h in range(n_h):
            r0 = row_bounds[v]
            c0 = col_bounds[h]
            _sample_tile(f, v, h, r0, row_bounds[v + 1] - r0 + 1, c0, col_bounds[h + 1] - c0 + 1,
                         rs, zs, grid, cum, pos_c, pos_r, hs)


@njit(cache=True, parallel=True)
def sample_tiles_parallel(f, row_bounds, col_bounds, rs, zs, grid):
    """`sample_tiles` with the tiles shared among threads (paper: "inherently parallel").

    Each tile writes only its own part of the grid (neighbours write the same
    values on shared borders), so the result is the same as the serial one.
    """
    n_v = row_bounds.size - 1
    n_h = col_bounds.size - 1
    for tile in prange(n_v * n_h):
        v = tile // n_h
        h = tile % n_h
        r0 = row_bounds[v]
        nr = row_bounds[v + 1] - r0 + 1
        c0 = col_bounds[h]
        nc = col_bounds[h + 1] - c0 + 1
        _sample_tile(f, v, h, r0, nr, c0, nc, rs, zs, grid, np.zeros(max(nr, nc)),
                     np.zeros(zs, np.int64), np.zeros(rs, np.int64), np.zeros((nr, zs), np.int64))
