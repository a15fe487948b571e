"""The mesh greedy insertion starts from: the image's (or a strip's) corners and a coarse grid."""

from __future__ import annotations

import numpy as np

from ..geometry.delaunay import delaunay_sweep

__all__ = ["corner_depths", "first_mesh"]


def corner_depths(depth: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Depth at the four image corners, from the nearest valid pixel where a corner is background.

    The corners are (0, 0), (H-1, 0), (H-1, W-1), (0, W-1), the first vertices
    of greedy insertion. Ties between equally near pixels go to the smallest
    (row, col). Only square windows around each corner are searched, doubling
    until the nearest pixel found lies within the window's reach: O(window),
    not a distance transform of the whole image (which took 10 ms at 640x480,
    a third of the insertion's own time).
    """
    h, w = depth.shape
    out = np.zeros(4)
    for i, (r, c) in enumerate(((0, 0), (h - 1, 0), (h - 1, w - 1), (0, w - 1))):
        if valid[r, c]:
            out[i] = depth[r, c]
            continue
        k = 8
        while True:
            rs = slice(0, min(k, h)) if r == 0 else slice(max(h - k, 0), h)
            cs = slice(0, min(k, w)) if c == 0 else slice(max(w - k, 0), w)
            rr, cc = np.nonzero(valid[rs, cs])
            if len(rr):
                rr = rr + rs.start
                cc = cc + cs.start
                d = (rr - r) ** 2 + (cc - c) ** 2
                j = np.lexsort((cc, rr, d))[0]
                # every pixel outside the window is at least k away (ties too: strict)
                if d[j] < k * k or (k >= h and k >= w):
                    out[i] = depth[rr[j], cc[j]]
                    break
            elif k >= h and k >= w:
                raise ValueError("corner_depths: the image has no valid pixel")
            k *= 2
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
        (`rangemesh.greedy.strips`).
    seam : sequence of (rows, column), optional
        Valid pixels on the strip's first or last column to start with as
        vertices besides the corners (the seam's vertices).

    Returns
    -------
    vr, vc, vz, tv, he : ndarrays
        As `rangemesh.greedy.kernels.greedy_insert` takes them.
    """
    h = depth.shape[0]
    c_lo, c_hi = (0, depth.shape[1] - 1) if cols is None else cols
    w = c_hi - c_lo + 1
    corner_z = corner_depths(depth[:, c_lo:c_hi + 1], valid[:, c_lo:c_hi + 1])
    vr = np.array([0, h - 1, h - 1, 0], np.int64)
    vc = np.array([c_lo, c_lo, c_hi, c_hi], np.int64)
    sr, sc = scales
    gr = int(round(np.sqrt(n_grid * h * sr / (w * sc)))) if n_grid >= 4 else 0
    gc = int(round(np.sqrt(n_grid * w * sc / (h * sr)))) if n_grid >= 4 else 0
    if gr >= 2 and gc >= 2:
        rows = ((np.arange(gr) + 0.5) * h / gr).astype(np.int64)
        cols_ = c_lo + ((np.arange(gc) + 0.5) * w / gc).astype(np.int64)
        r, c = np.meshgrid(np.unique(rows), np.unique(cols_), indexing="ij")
        r, c = r.ravel(), c.ravel()
        keep = valid[r, c] & ~(((r == 0) | (r == h - 1)) & ((c == c_lo) | (c == c_hi)))
        if cols is not None:  # nothing on a strip's first or last column but the seam
            keep &= (c != c_lo) & (c != c_hi)
        vr = np.concatenate([vr, r[keep]])
        vc = np.concatenate([vc, c[keep]])
    if seam is not None:
        rows, col = seam
        rows = np.asarray(rows, np.int64)
        rows = rows[(rows > 0) & (rows < h - 1)]  # the corners are in already
        vr = np.concatenate([vr, rows])
        vc = np.concatenate([vc, np.full(len(rows), col, np.int64)])
    if len(vr) > 4:
        tv, he, n_t = delaunay_sweep(vr * sr, vc * sc)  # same triangles, same orientation
        if n_t == 0:
            raise RuntimeError("first_mesh: the image corners cannot be collinear")
        tv, he = tv[: 3 * n_t].copy(), he[: 3 * n_t].copy()
    else:
        # (0,0) (H-1,0) (H-1,W-1) and (0,0) (H-1,W-1) (0,W-1): counter-clockwise in (r, c)
        tv = np.array([0, 1, 2, 0, 2, 3], np.int64)
        he = np.array([-1, -1, 3, 2, -1, -1], np.int64)
    vz = np.concatenate([corner_z, depth[vr[4:], vc[4:]]])
    return vr, vc, vz, tv, he
