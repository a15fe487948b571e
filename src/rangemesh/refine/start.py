"""The mesh greedy insertion starts from: the image's (or a strip's) corners and a coarse grid."""

from __future__ import annotations

import numpy as np

from .._core import delaunay_sweep, grid_pixels, nearest_valid

__all__ = ["corner_depths", "first_mesh", "valid_hull"]

# The image rectangle cut in two, (0,0) (H-1,0) (H-1,W-1) and (0,0) (H-1,W-1) (0,W-1):
# counter-clockwise in (r, c); its triangles and twin half-edges.
_RECTANGLE = (np.array([0, 1, 2, 0, 2, 3], np.int64), np.array([-1, -1, 3, 2, -1, -1], np.int64))


def corner_depths(depth: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Depth at the four image corners, from the nearest valid pixel where a corner is background.

    The corners are (0, 0), (H-1, 0), (H-1, W-1), (0, W-1), the first vertices
    of greedy insertion. Ties between equally near pixels go to the smallest
    (row, col) (`rangemesh._core.nearest_valid`: a window search, not a
    distance transform of the whole image, which would cost more than the
    insertion).
    """
    h, w = depth.shape
    rows, cols = (0, h - 1, h - 1, 0), (0, 0, w - 1, w - 1)
    if valid[0, 0] and valid[h - 1, 0] and valid[h - 1, w - 1] and valid[0, w - 1]:  # the usual case
        return np.array([depth[0, 0], depth[h - 1, 0], depth[h - 1, w - 1], depth[0, w - 1]],
                        dtype=np.float64)
    out = np.zeros(4)
    for i, (r, c) in enumerate(zip(rows, cols, strict=True)):
        near = (r, c) if valid[r, c] else nearest_valid(valid, r, c)
        if near is None:
            raise ValueError("corner_depths: the image has no valid pixel")
        out[i] = depth[near]
    return out


def first_mesh(depth: np.ndarray, valid: np.ndarray, n_grid: int, scales=(1, 1), cols=None,
               seam=None):
    """The mesh greedy insertion starts from: image corners plus about `n_grid` grid pixels.

    Grid points sit at the centres of a grid of cells shaped like the image
    (rows counting ``scales[0]``, columns ``scales[1]``: `delaunay_scales`),
    and the mesh is Delaunay in those units; grid points on background pixels
    are left out. With fewer than 4 grid points the mesh is the image
    rectangle cut in two.

    Parameters
    ----------
    cols : (int, int), optional
        Mesh only the vertical strip of columns ``cols[0]`` to ``cols[1]``
        (both included): its corners come first, in image coordinates
        (`rangemesh.refine.strips`).
    seam : sequence of (rows, column), optional
        Valid pixels on the strip's first or last column to start with as
        vertices besides the corners (the seam's vertices).

    Returns
    -------
    vr, vc, vz, tv, he : ndarrays
        As `rangemesh._core.greedy_insert` takes them.
    """
    if n_grid < 4 and cols is None and seam is None:  # the image rectangle: a small call's start
        return (np.array([0, depth.shape[0] - 1, depth.shape[0] - 1, 0], np.int64),
                np.array([0, 0, depth.shape[1] - 1, depth.shape[1] - 1], np.int64),
                corner_depths(depth, valid), _RECTANGLE[0].copy(), _RECTANGLE[1].copy())
    h = depth.shape[0]
    c_lo, c_hi = (0, depth.shape[1] - 1) if cols is None else cols
    w = c_hi - c_lo + 1
    corner_z = corner_depths(depth[:, c_lo:c_hi + 1], valid[:, c_lo:c_hi + 1])
    sr, sc = scales
    gr = int(round(np.sqrt(n_grid * h * sr / (w * sc)))) if n_grid >= 4 else 0
    gc = int(round(np.sqrt(n_grid * w * sc / (h * sr)))) if n_grid >= 4 else 0
    # (compiled: on small images NumPy's grid, unique and masks weighed on the call)
    grid = grid_pixels(valid, gr, gc, c_lo, c_hi, cols is not None)
    vr, vc = grid.rows, grid.cols
    if seam is not None:
        rows, col = seam
        rows = np.asarray(rows, np.int64)
        rows = rows[(rows > 0) & (rows < h - 1)]  # the corners are in already
        vr = np.concatenate([vr, rows])
        vc = np.concatenate([vc, np.full(len(rows), col, np.int64)])
    if len(vr) > 4:
        tv, he = delaunay_sweep(vr * sr, vc * sc)  # same triangles, same orientation
        if len(tv) == 0:
            raise RuntimeError("first_mesh: the image corners cannot be collinear")
    else:
        tv, he = _RECTANGLE[0].copy(), _RECTANGLE[1].copy()
    vz = np.concatenate([corner_z, depth[vr[4:], vc[4:]]])
    return vr, vc, vz, tv, he


def valid_hull(valid: np.ndarray) -> np.ndarray:
    """Corners of the convex hull of the valid pixels, counter-clockwise in (row, col).

    Points on a hull edge are left out. Fewer than 3 corners when the valid
    pixels are fewer than 3 or all on one line.

    Returns
    -------
    (K, 2) ndarray of int64
    """
    rows = np.flatnonzero(valid.any(axis=1))
    if not len(rows):
        return np.zeros((0, 2), np.int64)
    w = valid.shape[1]
    first = np.argmax(valid[rows], axis=1)
    last = w - 1 - np.argmax(valid[rows, ::-1], axis=1)
    # each row's first and last valid pixels hold the hull's corners (monotone chain, exact ints)
    pts = sorted({(int(r), int(c)) for r, c in zip(np.concatenate([rows, rows]).tolist(),
                                                   np.concatenate([first, last]).tolist(),
                                                   strict=True)})

    def turn(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    def half(points):
        out = []
        for p in points:
            while len(out) >= 2 and turn(out[-2], out[-1], p) <= 0:
                out.pop()
            out.append(p)
        return out[:-1]

    hull = half(pts) + half(pts[::-1])
    if len(hull) < 3:
        return np.zeros((0, 2), np.int64)
    return np.array(hull, np.int64)
