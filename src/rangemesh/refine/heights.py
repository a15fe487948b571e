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

import functools

import numpy as np

from .. import _core
from ..camera import Pinhole
from ..threads import threads

__all__ = ["fit_heights", "height_rule"]

# A pixel whose error under the copied depths exceeds OUTLIER_MADS robust
# standard deviations (1.4826 x the median error) of all errors is left out: it
# belongs to another surface than its triangle. A jump lies far beyond that
# bound; below it is mostly clutter (foliage in a LiDAR scan) that the fit should
# follow (docs/benchmarks.md, docs/decisions.md).
OUTLIER_MADS = 6.0
# The bound never falls below OUTLIER_FLOOR of the vertices' value range, a
# rounding error's size: when most pixels fit their triangles exactly (quantised
# disparities, dense meshes), only exact pixels would be fitted, so the copied
# depths are kept as they are (`fit_heights` skips its pass and solve). A larger
# floor would keep small steps in the fit and move vertices off exact planes
# (``python benchmarks/heights.py [--floor 0.005]``).
OUTLIER_FLOOR = 1e-9
# Ridge towards the copied value, relative to a vertex's own weight: it keeps a
# vertex that touches no kept pixel where it was, and the system definite.
RIDGE = 1e-3
# The errors' median is taken over a sample of the pixels: those of every k-th triangle in
# their spatial order (`face_order`), k >= RESIDUAL_STRIDE and at most about RESIDUAL_SAMPLE
# triangles, when that visits RESIDUAL_MIN triangles or more; else every 4th row of every
# triangle. The median needs no more; with many small triangles skipping whole triangles
# saves their set-up, which skipping rows does not, and with few a sample of triangles
# would give a noisy median.
RESIDUAL_STRIDE = 4
RESIDUAL_MIN = 500
RESIDUAL_SAMPLE = 2000
# The faces are visited in the order of these square cells of pixels (`face_order`) in images
# of ORDER_MIN_PIXELS or more, for the cache; smaller images stay in the cache whatever
# the order, and are visited as the faces come.
ORDER_TILE = 8
ORDER_MIN_PIXELS = 150_000
# Conjugate gradients stop at this relative residual: on the shared images at 1-10 % and the
# default target the mean error is that of 1e-8 to four digits and a vertex's depth moves from
# 1e-8's by at most 0.1 % of the depth range (under 0.01 % in 53 of 60 cases), in 5-11 steps
# instead of 9-17: each factor of 100 costs 4-6 steps (``python benchmarks/fit_tolerance.py``;
# docs/benchmarks.md).
CG_RTOL = 1e-6


def sample_strides(n_faces: int) -> tuple[int, int]:
    """(row stride, face stride) of the pixels whose errors' median the fit takes.

    Every k-th face in `face_order` (k >= RESIDUAL_STRIDE, at most about
    RESIDUAL_SAMPLE faces) when that is RESIDUAL_MIN faces or more; else every
    RESIDUAL_STRIDE-th row of every face.
    """
    if n_faces < RESIDUAL_STRIDE * RESIDUAL_MIN:
        return RESIDUAL_STRIDE, 1
    return 1, max(RESIDUAL_STRIDE, n_faces // RESIDUAL_SAMPLE)


def height_rule(n_valid: int) -> _core.HeightRule:
    """These rules for the native refine call (`rangemesh._core.refine_mesh`).

    Read at each call, as `fit_heights` reads them (benchmarks set them).
    Its threads are `_default_threads` when a mesh of the image can reach
    FIT_SPLIT_MIN_FACES faces (at most two a vertex, a vertex a valid pixel),
    else 1, as `fit_heights` chooses them.
    """
    threads = 1 if 2 * n_valid < _core.FIT_SPLIT_MIN_FACES else _default_threads()
    return _rule((OUTLIER_MADS, OUTLIER_FLOOR, RIDGE, CG_RTOL, RESIDUAL_STRIDE, RESIDUAL_MIN,
                  RESIDUAL_SAMPLE, ORDER_TILE, ORDER_MIN_PIXELS, threads))


@functools.lru_cache(maxsize=8)
def _rule(values: tuple) -> _core.HeightRule:
    """The `height_rule` of these values, made once (the native call copies it, never writes it)."""
    rule = _core.HeightRule()
    (rule.outlier_mads, rule.outlier_floor, rule.ridge, rule.rtol, rule.residual_stride,
     rule.residual_min, rule.residual_sample, rule.order_tile, rule.order_min_pixels,
     rule.threads) = values
    return rule


def _default_threads() -> int:
    """The pass's threads when the caller names none: `rangemesh.threads.threads`."""
    return threads()


def _direct_solve(ids, block, rhs, h0):
    """The system `_core.solve_blocks` solves, by a sparse LU (the fallback when CG does not converge)."""
    from scipy import sparse
    from scipy.sparse.linalg import spsolve

    n = len(h0)
    system = _core.gather_blocks(ids, block, rhs, h0, RIDGE)
    m = sparse.csr_matrix((block.ravel(), (np.repeat(ids, 3, axis=1).ravel(),
                                           np.tile(ids, (1, 3)).ravel())), shape=(n, n))
    return spsolve((m + sparse.diags(system.ridge, format="csr")).tocsc(), system.rhs)


def fit_settings(lo: float, hi: float, n_faces: int, n_vertices: int, n_valid: int,
                 threads: int | None = None) -> _core.FitSettings:
    """The core's settings of the fit (`rangemesh._core.FitSettings`) for a mesh and image.

    Parameters
    ----------
    lo, hi : float
        The fitted values' bounds: the valid pixels' range of the fitted quantity.
    n_faces, n_vertices : int
        The mesh's size: its faces set the sample of errors (`sample_strides`)
        and the threads, its vertices conjugate gradients' steps.
    n_valid : int
        The image's valid pixels, at most as many sampled errors.
    threads : int, optional
        Threads of the pass over the pixels; by default 1 below
        ``FIT_SPLIT_MIN_FACES`` faces, else `_default_threads`.

    Returns
    -------
    FitSettings
        This module's rules (read at each call: benchmarks set them).
    """
    settings = _core.FitSettings()
    settings.lo, settings.hi = lo, hi
    settings.row_stride, settings.face_stride = sample_strides(n_faces)
    settings.capacity = n_valid
    settings.outlier_mads = OUTLIER_MADS
    settings.outlier_floor = OUTLIER_FLOOR
    settings.ridge = RIDGE
    settings.rtol = CG_RTOL
    settings.max_iter = 10 * n_vertices
    settings.threads = (threads if threads is not None else
                        1 if n_faces < _core.FIT_SPLIT_MIN_FACES else _default_threads())
    return settings


def fit_heights(pixels: np.ndarray, faces: np.ndarray, depth: np.ndarray, valid: np.ndarray,
                camera, *, extent=None, threads: int | None = None) -> np.ndarray:
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
    extent : (float, float, int), optional
        ``valid_range(depth, valid)`` (`rangemesh._core`) when the
        caller has it: a pass over the image less.
    threads : int, optional
        Threads of the pass over the pixels (meshes of 4000 faces or more);
        by default `rangemesh.threads.threads`. The result is the same
        bit for bit for any number.

    Returns
    -------
    (V,) ndarray of float64
        Fitted depth per vertex, in stored units. Vertices no kept pixel
        touches keep the depth of their pixel.
    """
    ortho = not isinstance(camera, Pinhole)  # a pinhole's flat triangles are linear in 1/depth
    if extent is None:
        span = _core.valid_range(depth, valid)
        extent = (span.lo, span.hi, span.count)
    lo, hi, n_valid = extent
    if ortho:
        image = depth  # the interpolated quantity
    else:
        with np.errstate(divide="ignore"):
            image = 1.0 / depth
        # (The inverse of the largest depth is the smallest inverse exactly: rounding is monotone.)
        if lo > 0.0:
            lo, hi = 1.0 / hi, 1.0 / lo
        elif n_valid:  # depths <= 0 before a pinhole: the inverses' own range
            vals = image[valid]
            lo, hi = vals.min(), vals.max()
    order = None  # the faces as they come
    if depth.size >= ORDER_MIN_PIXELS:
        order = _core.face_order(np.ascontiguousarray(faces, dtype=np.int64),
                                 np.ascontiguousarray(pixels[:, 0], dtype=np.int64),
                                 np.ascontiguousarray(pixels[:, 1], dtype=np.int64),
                                 depth.shape[0], depth.shape[1], ORDER_TILE)
    # A vertex that few pixels pin down can be thrown far off (a negative range was seen on a
    # LiDAR scan at 500 vertices): no fitted value leaves [lo, hi], the valid pixels' values.
    settings = fit_settings(lo, hi, len(faces), len(pixels), int(n_valid), threads)
    fit = _core.fit_heights(faces, pixels, image, valid, order, settings)
    if fit.outcome == _core.FitOutcome.NOT_FINITE:
        r, c = pixels[fit.not_finite]
        if not ortho and depth[r, c] == 0:
            raise ValueError(f"depth 0 at pixel ({r}, {c}) cannot be fitted with a pinhole camera "
                             f"(its inverse depth is infinite): mark missing depth with "
                             f"background=0, or copy the depths with heights='pixel'")
        raise ValueError("fit_heights: every vertex must sit on a valid pixel")
    fitted = fit.values
    if fitted is None:
        # No valid pixel, or most pixels fit the copied depths exactly and only pixels within
        # rounding of them would be kept: the copied depths are the least-squares solution
        # (quantised disparities and exact scenes at dense budgets).
        return depth[pixels[:, 0], pixels[:, 1]].astype(np.float64)
    if fit.outcome == _core.FitOutcome.NOT_CONVERGED:  # ill-conditioned: a direct sparse solve of the system
        system = fit.system
        fitted = _direct_solve(system.ids, system.block, system.rhs, image[pixels[:, 0], pixels[:, 1]])
        if not np.isfinite(fitted).all():
            raise RuntimeError("fit_heights: the least-squares solve failed")
        np.minimum(np.maximum(fitted, lo, out=fitted), hi, out=fitted)  # np.clip, without its wrapper
    return fitted if ortho else np.divide(1.0, fitted, out=fitted)
