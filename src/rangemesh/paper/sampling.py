"""Stage one: the sampling weights, tiling and the sample grid.

Paper section II.A; SPEC.md section 1. Everything here works on a float64
``depth`` image and a boolean ``valid`` mask. The background marker has been
turned into ``valid == False`` before any of these functions runs, so no
background value ever reaches arithmetic (SPEC P1).
"""

from __future__ import annotations

import math

import numpy as np

from .. import _core
from ..blocks import blocks
from ..geometry.curvature import curvature, valid_span  # shared steps, their names kept here
from ..params import MeshParams
from ..prepare import fill_gaps, fill_gaps_inplace  # noqa: F401 - shared steps, re-exported
from ..threads import threads

__all__ = [
    "fill_gaps",
    "curvature",
    "valid_span",
    "sampling_weights",
    "fill_gaps_inplace",
    "tile_bounds",
    "sample_grid",
]

# The paper's images are 8-bit: its curvature floor of 20 lives on a 0..255 scale.
_PAPER_SCALE = 255.0


def sampling_weights(depth: np.ndarray, valid: np.ndarray, params: MeshParams, *,
                     out: np.ndarray | None = None) -> np.ndarray:
    """Per-pixel weight ``f`` that stage one integrates (paper eq. 1, SPEC 1.4).

    ``f = log(max(K * 255 / range, curvature_floor))`` for adaptive sampling,
    ``f = 1`` for uniform sampling. ``range`` is the valid depth range, which
    makes ``f`` independent of the depth unit. The paper's factor Gamma would
    only scale ``f``; the inverse distribution is unchanged by it, so it is
    not a parameter.

    Parameters
    ----------
    depth : (H, W) ndarray of float64
    valid : (H, W) ndarray of bool
    params : MeshParams
    out : (H, W) ndarray of float64, optional
        Write the weights here (a buffer reused from frame to frame) instead
        of a new array.

    Returns
    -------
    f : (H, W) ndarray of float64, strictly positive
    """
    fresh = out is None
    if fresh:  # zeros from calloc: its pages are first touched by the kernel, which polls Ctrl-C
        out = np.zeros(depth.shape)
    # (whole-image steps go a block of rows at a time: Ctrl-C is seen between blocks)
    rows = list(blocks(out.shape[0], per=out.shape[1]))
    if params.sampling == "uniform":
        for b in rows:
            out[b] = 1.0
        return out
    if not fresh:
        for b in rows:
            out[b] = 0.0
    v = np.ascontiguousarray(valid, dtype=np.bool_)
    d = np.ascontiguousarray(depth, dtype=np.float64)
    span = valid_span(d, v)
    if out.dtype == np.float64 and out.flags.c_contiguous:
        _core.add_curvature(d, v, span, int(params.levels), out)
    else:  # the kernel writes C-contiguous float64 only
        out[:] = curvature(d, v, int(params.levels))
    factor = _PAPER_SCALE / span if span > 0.0 else 0.0
    for b in rows:
        o = out[b]
        if span > 0.0:
            if math.isfinite(factor):
                np.multiply(o, factor, out=o)
            else:  # a subnormal span: 255 / span overflows, so divide first
                np.divide(o, span, out=o)
                np.multiply(o, _PAPER_SCALE, out=o)
        else:
            o[...] = 0.0  # a constant scene has no curvature anywhere
        # in place: this runs on every pixel, and each temporary would be a block more
        np.maximum(o, params.curvature_floor, out=o)
        np.log(o, out=o)
    return out


def _tile_threads(workers: int) -> int:
    """Threads for stage one's tiles: `workers`, within the limits of `rangemesh.threads`.

    The cores this process may use, ``RANGEMESH_THREADS`` (batch workers set it to 1), and one
    within a live frame worker.
    """
    return threads(workers)


def tile_bounds(n: int, tiles: int, *, name: str = "tiles") -> np.ndarray:
    """Tile borders ``b_k = round(k*(n-1)/tiles)``, ``k = 0..tiles`` (SPEC 1.5).

    Tile ``k`` covers ``b_k..b_{k+1}`` inclusive, so neighbours share one line.
    Rounding is half up, in exact integer arithmetic.

    Parameters
    ----------
    n : int
        Image size along the axis (rows or columns).
    tiles : int
        Number of tiles along that axis.
    name : str
        Name used in the error message.

    Returns
    -------
    bounds : (tiles + 1,) ndarray of int64

    Raises
    ------
    ValueError
        If a tile would be thinner than 2 pixels.

    Examples
    --------
    >>> tile_bounds(9, 4)
    array([0, 2, 4, 6, 8])
    """
    k = np.arange(tiles + 1, dtype=np.int64)
    bounds = (2 * k * (n - 1) + tiles) // (2 * tiles)
    if tiles > n - 1 or np.any(np.diff(bounds) < 1):
        raise ValueError(
            f"{name}={tiles} is too many for an image axis of {n} pixels: every tile must "
            f"be at least 2 pixels thick, so at most {max(n - 1, 0)} tiles fit"
        )
    return bounds


# Small images may have grids larger than themselves (samples then repeat pixels).
SMALL_GRID = 1 << 16


def max_grid_entries(shape) -> int:
    """The largest sample grid allowed for an image: one entry per pixel, or 65,536.

    A grid with more entries than the image has pixels can only repeat pixels;
    its memory (8 bytes an entry, and as much again to find the distinct
    ones) is what `sample_grid` refuses to spend on repeats. Small images may
    still use grids up to 65,536 entries (half a megabyte).
    """
    return max(int(shape[0]) * int(shape[1]), SMALL_GRID)


def check_grid_size(params: MeshParams, shape) -> None:
    """Refuse a grid larger than `max_grid_entries` before anything is allocated.

    Raises
    ------
    ValueError
        Naming the samples, the tiles and the largest grid allowed.
    """
    gr, gc = params.grid_shape
    limit = max_grid_entries(shape)
    if gr * gc > limit:
        raise ValueError(
            f"samples={params.samples} with tiles={params.tiles} make a grid of {gr}x{gc} = "
            f"{gr * gc} samples on a {shape[0]}x{shape[1]} image; at most {limit} are allowed "
            f"(one per pixel, or 65536 on small images): more only repeat pixels"
        )


def sample_grid(depth: np.ndarray, valid: np.ndarray, params: MeshParams | None = None,
                *, weights: np.ndarray | None = None, workers: int = 1) -> np.ndarray:
    """The sample grid of stage one (paper II.A.2-3, SPEC 1.5-1.8).

    Each tile's pixel rows are sampled at ``Z`` columns by inverting the
    cumulative weight along the row; the resulting vertical curves are then
    sampled at ``Rs`` rows the same way. The first and last samples of every
    tile are its border lines, so tiles meet exactly.

    Parameters
    ----------
    depth : (H, W) ndarray of float64
        Depth after gap filling (background values are ignored).
    valid : (H, W) ndarray of bool
    params : MeshParams, optional
        Tiles, samples, sampling mode, curvature settings.
    weights : (H, W) ndarray of float64, optional
        Precomputed ``sampling_weights`` (reused across budgets by callers that
        try several grids).
    workers : int, default 1
        Threads sharing the tiles (each takes a fixed share of them); the grid
        is the same for any number.

    Returns
    -------
    grid : (Gr, Gc, 2) ndarray of int32
        ``(row, col)`` of every sample, ``Gr = (Rs-1)V + 1``, ``Gc = (Z-1)H + 1``.
        Samples may repeat (more samples than pixels in a tile) and may be
        background pixels; stage two drops both.

    Notes
    -----
    The inversion interpolates linearly between the two pixels whose
    cumulative weights bracket a target and rounds half up to a pixel.
    """
    params = params or MeshParams()
    h, w = depth.shape
    v_tiles, h_tiles = params.tiles
    rb = tile_bounds(h, v_tiles, name="tiles (rows)")
    cb = tile_bounds(w, h_tiles, name="tiles (columns)")
    rs, zs = params.samples
    check_grid_size(params, (h, w))  # before anything is allocated
    f = sampling_weights(depth, valid, params) if weights is None else weights
    f = np.ascontiguousarray(f, dtype=np.float64)
    grid = np.zeros(params.grid_shape + (2,), np.int32)
    _core.sample_tiles(f, rb, cb, rs, zs, grid, _tile_threads(workers))
    return grid
