"""Vertex depths fitted to the pixels by least squares, jumps left out.

Greedy insertion copies each vertex's depth from its pixel: one noisy sample
decides a plane that covers hundreds of pixels. Here every vertex depth is
chosen instead to minimise the squared error over the pixels its triangles
cover, the mesh's connectivity and image positions unchanged. Pixels whose
error under the copied depths is far beyond the image's typical error are
left out of the fit: they lie across a jump (the far surface seen through a
wall triangle), and fitting them would pull the near edge towards the far
one.

The fit is linear: a pixel's predicted value is ``w0*h0 + w1*h1 + w2*h2``
with its barycentric weights in the triangle that covers it. With an
orthographic camera the value is depth; with a pinhole camera it is inverse
depth, the quantity a flat 3-D triangle interpolates linearly along the
image, so the fitted mesh is rendered exactly as it was fitted.
"""

from __future__ import annotations

import numpy as np

from ..camera import Orthographic
from ..geometry.raster import rasterize
from ..geometry.signals import holding_signals

__all__ = ["fit_heights"]

# A pixel whose error under the copied depths exceeds OUTLIER_MADS robust
# standard deviations (1.4826 MAD) of all errors, and OUTLIER_FLOOR of the
# depth range, is left out: it belongs to another surface than its triangle.
OUTLIER_MADS = 4.0
OUTLIER_FLOOR = 0.005
# Ridge towards the copied value, relative to a vertex's own weight: it keeps a
# vertex that touches no kept pixel where it was, and the system definite.
RIDGE = 1e-3


@holding_signals
def fit_heights(pixels: np.ndarray, faces: np.ndarray, depth: np.ndarray, valid: np.ndarray,
                camera) -> np.ndarray:
    """Least-squares vertex depths for a mesh of `depth` with fixed image positions.

    Parameters
    ----------
    pixels : (V, 2) ndarray of int
        Each vertex's (row, col); it stays there.
    faces : (F, 3) ndarray of int
        Triangles, counter-clockwise or not.
    depth, valid : (H, W) ndarrays
        The prepared image: float64 depth in stored units, bool mask.
    camera : Orthographic or Pinhole
        Decides what is interpolated: depth (orthographic) or inverse depth.

    Returns
    -------
    (V,) ndarray of float64
        Fitted depth per vertex, in stored units. Vertices no kept pixel
        touches keep the depth of their pixel.
    """
    from scipy import sparse
    from scipy.sparse.linalg import spsolve

    pr = pixels[:, 0].astype(np.int64)
    pc = pixels[:, 1].astype(np.int64)
    n = len(pr)
    ortho = isinstance(camera, Orthographic)
    with np.errstate(divide="ignore"):
        image = depth if ortho else 1.0 / depth  # the interpolated quantity
    h0 = image[pr, pc]
    if not np.isfinite(h0).all():
        raise ValueError("fit_heights: every vertex must sit on a valid pixel")
    f = np.ascontiguousarray(faces, dtype=np.int64)
    fr = np.ascontiguousarray(pr[f].astype(np.float64))
    fc = np.ascontiguousarray(pc[f].astype(np.float64))
    pred = np.full(depth.shape, np.nan)
    face = np.full(depth.shape, -1, np.int64)
    rasterize(fr, fc, np.ascontiguousarray(h0[f]), depth.shape[0], depth.shape[1], pred, face)
    use = valid & (face >= 0)
    rows, cols = np.nonzero(use)
    t = face[rows, cols]
    target = image[rows, cols]
    resid = np.abs(pred[rows, cols] - target)
    mad = np.median(np.abs(resid - np.median(resid))) if len(resid) else 0.0
    span = float(np.ptp(target)) if len(target) else 0.0
    keep = resid <= max(OUTLIER_MADS * 1.4826 * mad, OUTLIER_FLOOR * span)
    rows, cols, t, target = rows[keep], cols[keep], t[keep], target[keep]
    # barycentric weights of each kept pixel in its triangle
    r0, r1, r2 = fr[t, 0], fr[t, 1], fr[t, 2]
    c0, c1, c2 = fc[t, 0], fc[t, 1], fc[t, 2]
    area = (r1 - r0) * (c2 - c0) - (c1 - c0) * (r2 - r0)
    w = np.empty((len(t), 3))
    w[:, 0] = ((r2 - r1) * (cols - c1) - (c2 - c1) * (rows - r1)) / area
    w[:, 1] = ((r0 - r2) * (cols - c2) - (c0 - c2) * (rows - r2)) / area
    w[:, 2] = 1.0 - w[:, 0] - w[:, 1]
    # normal equations, summed per triangle first (9 entries a triangle, not 9 a pixel)
    nf = len(f)
    block = np.empty((nf, 3, 3))
    rhs = np.zeros(n)
    for i in range(3):
        rhs += np.bincount(f[t, i], weights=w[:, i] * target, minlength=n)
        for j in range(i, 3):
            block[:, i, j] = block[:, j, i] = np.bincount(t, weights=w[:, i] * w[:, j],
                                                          minlength=nf)
    ii = np.repeat(f, 3, axis=1).ravel()
    jj = np.tile(f, (1, 3)).ravel()
    m = sparse.csc_matrix((block.ravel(), (ii, jj)), shape=(n, n))
    diag = m.diagonal()
    ridge = RIDGE * np.maximum(diag, 1.0)
    m = m + sparse.diags(ridge, format="csc")
    fitted = spsolve(m, rhs + ridge * h0)
    if not np.isfinite(fitted).all():
        raise RuntimeError("fit_heights: the least-squares solve failed")
    return fitted if ortho else 1.0 / fitted
