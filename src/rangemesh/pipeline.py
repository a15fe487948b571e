"""The whole method in one call: `triangulate`."""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from . import _kernels
from .camera import as_camera
from .flipping import flip_edges
from .mesh import Mesh, Stats, empty_mesh
from .params import MeshParams
from .prepare import to_depth_and_mask
from .sampling import sample_grid
from .triangulation import delaunay_mesh

_BUDGET_KEYS = ("vertices", "max_error", "max_edge")

__all__ = ["triangulate", "resolve_params", "prepare", "mesh_prepared"]


def resolve_params(params: MeshParams | None, overrides: dict) -> MeshParams:
    """`params` (or the defaults) with keyword overrides applied and checked.

    Raises
    ------
    TypeError
        If `params` is not a `MeshParams` or an override is not one of its fields.
    """
    if params is None:
        params = MeshParams()
    elif not isinstance(params, MeshParams):
        raise TypeError(
            f"params must be a rangemesh.MeshParams or None, got {type(params).__name__}"
        )
    return params.replace(**overrides) if overrides else params


def prepare(image, params: MeshParams, background=None) -> tuple[np.ndarray, np.ndarray]:
    """Depth and validity mask as stage one sees them: checked, masked, gap-filled.

    Parameters
    ----------
    image : (H, W) array_like
    params : MeshParams
        Only ``fill_gaps`` is read.
    background : float, optional

    Returns
    -------
    depth : (H, W) ndarray of float64
    valid : (H, W) ndarray of bool
    """
    depth, valid = to_depth_and_mask(image, background)
    if params.fill_gaps:
        # the arrays are ours and hold 0.0 on background: fill in place, no copies
        _kernels.fill_gaps_inplace(depth, valid)
    return depth, valid


def mesh_prepared(depth: np.ndarray, valid: np.ndarray, params: MeshParams, camera, *,
                  weights: np.ndarray | None = None, max_edge: float | None = None,
                  workers: int = 1) -> Mesh:
    """Stages one to three on an already prepared image (see `prepare`).

    Parameters
    ----------
    depth, valid : (H, W) ndarrays
        From `prepare`.
    params : MeshParams
    camera : Orthographic or Pinhole
    weights : (H, W) ndarray, optional
        Precomputed `sampling_weights` for `params` (reused across tries).
    max_edge : float, optional
        Longest triangle edge allowed in the image plane, pixels.
    workers : int, default 1
        Threads for stage one's tiles.

    Returns
    -------
    Mesh
        With ``stats.seconds`` for ``sampling``, ``triangulation``, ``flipping``.
    """
    t1 = time.perf_counter()
    grid = sample_grid(depth, valid, params, weights=weights, workers=workers)
    t2 = time.perf_counter()
    mesh = delaunay_mesh(grid, depth, valid, camera, max_edge=max_edge)
    t3 = time.perf_counter()
    mesh = flip_edges(mesh, depth, valid, params, max_edge=max_edge)
    t4 = time.perf_counter()
    seconds = {"sampling": t2 - t1, "triangulation": t3 - t2, "flipping": t4 - t3}
    return dataclasses.replace(mesh, stats=dataclasses.replace(mesh.stats, seconds=seconds))


def _check_budget(vertices, max_error, max_edge, overrides):
    if vertices is not None and max_error is not None:
        raise ValueError("vertices and max_error exclude each other: give one target")
    given = [k for k, v in (("vertices", vertices), ("max_error", max_error),
                            ("max_edge", max_edge)) if v is not None]
    if given and "samples" in overrides:
        raise ValueError(
            f"{' and '.join(given)} choose the samples per tile themselves; "
            f"do not give samples={overrides['samples']!r} as well"
        )
    if vertices is not None:
        if isinstance(vertices, bool) or not float(vertices).is_integer() or vertices < 3:
            raise ValueError(f"vertices must be a whole number >= 3, got {vertices!r}")
    if max_error is not None:
        if isinstance(max_error, bool) or not np.isfinite(max_error) or max_error <= 0:
            raise ValueError(f"max_error must be a positive number of percent, got {max_error!r}")
    if max_edge is not None:
        if isinstance(max_edge, bool) or not np.isfinite(max_edge) or max_edge < 1.5:
            raise ValueError(
                f"max_edge must be at least 1.5 pixels (a pixel's diagonal is 1.41), got {max_edge!r}"
            )
    return given


def triangulate(image, params: MeshParams | None = None, *, background=None, camera=None,
                vertices: int | None = None, max_error: float | None = None,
                max_edge: float | None = None, workers: int = 1, **overrides) -> Mesh:
    """Mesh a range image: adaptive sampling, 2.5-D Delaunay, discontinuity-preserving flips.

    Parameters
    ----------
    image : (H, W) array_like of int or float
        The range image (depth, disparity or range values).
    params : MeshParams, optional
        All algorithm settings; keyword overrides below take precedence.
    background : float, optional
        Value that marks missing depth (``0``, ``65535``, ...). NaN and
        infinite pixels are always background.
    camera : Orthographic, Pinhole or (kx, ky, kz), optional
        How pixels become 3-D points; default ``Orthographic(1, 1, 1)``, the
        paper's eq. (4) with unit scales.
    vertices : int, optional
        Ask for about this many vertices instead of giving ``samples``: the
        grid (tiles unless given, then samples per tile) is searched so that
        the final count is within 2 % (see `rangemesh.budget.fit_vertices`).
    max_error : float, optional
        Ask for the smallest grid whose relative error (percent, as
        `evaluate`) is at most this (see `rangemesh.budget.fit_error`).
    max_edge : float, optional
        No triangle edge longer than this in the image plane, in pixels. Alone,
        it also chooses the samples per tile (see `rangemesh.budget.fit_edge`).
    workers : int, default 1
        Threads sharing stage one's tiles (the paper's parallel stage). The
        mesh is the same for any number.
    **overrides
        Any field of `MeshParams`: ``tiles``, ``samples``, ``sampling``,
        ``flips``, ``levels``, ``curvature_floor``, ``fill_gaps``, ``delta``,
        ``epsilon``, ``max_angle``, ``min_bend``, ``gain_threshold``.

    Returns
    -------
    Mesh
        ``vertices (V, 3)``, ``faces (F, 3)`` counter-clockwise in the image
        plane, ``pixels (V, 2)``, and ``stats``. When nothing can be meshed (no
        valid pixel, fewer than 3 valid samples, all collinear) the mesh is
        empty and ``stats.reason`` says why. With a target, ``stats.search``
        tells what was asked, what was achieved and which grid was chosen.

    Raises
    ------
    ValueError
        Bad image shape, parameters out of range (e.g. more tiles than fit),
        or ``samples`` together with a target.
    TypeError
        Wrong kind of image, camera or parameter.

    See Also
    --------
    sample_grid, delaunay_mesh, flip_edges : the three stages, callable one by one.
    evaluate : relative error of the result.

    Notes
    -----
    Vertices take their depth from the gap-filled image (paper eq. 4 uses the
    filtered image ``R_f``). Stage timings are in ``stats.seconds``. With a
    target, the tiles and samples of `params` are replaced by the search
    (tiles given as a keyword are kept).

    References
    ----------
    .. [1] M. A. Garcia and A. D. Sappa, "Efficient generation of
       discontinuity-preserving adaptive triangulations from range images",
       IEEE Trans. Systems, Man, and Cybernetics, Part B, 34(5), 2004.

    Examples
    --------
    >>> import numpy as np
    >>> r, c = np.mgrid[0:40, 0:50]
    >>> depth = np.where(c < 25, 100.0 + c, 150.0 - c)        # a roof crease
    >>> mesh = triangulate(depth, tiles=2, samples=5)
    >>> mesh.stats.vertices, mesh.faces.shape[1]
    (81, 3)
    """
    targets = _check_budget(vertices, max_error, max_edge, overrides)
    tiles_given = "tiles" in overrides
    params = resolve_params(params, overrides)
    camera = as_camera(camera)
    t0 = time.perf_counter()
    depth, valid = prepare(image, params, background)
    t1 = time.perf_counter()
    if not valid.any():
        # Still check the tiling so that bad parameters fail the same way on any image.
        sample_grid(depth, valid, params.replace(sampling="uniform"))
        stats = Stats(grid_shape=params.grid_shape, seconds={"prepare": t1 - t0, "total": t1 - t0},
                      reason="the image has no valid pixel (all background)")
        return empty_mesh(camera, depth.shape, stats)
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be a whole number >= 1, got {workers!r}")
    if not targets:
        mesh = mesh_prepared(depth, valid, params, camera, workers=workers)
        search = {}
    else:
        from . import budget

        tiles = params.tiles if tiles_given else None
        if vertices is not None:
            mesh, search = budget.fit_vertices(depth, valid, params, camera, int(vertices),
                                               tiles=tiles, max_edge=max_edge)
        elif max_error is not None:
            ref_depth, ref_valid = to_depth_and_mask(image, background)
            mesh, search = budget.fit_error(depth, valid, params, camera, float(max_error),
                                            ref_depth, ref_valid, tiles=tiles, max_edge=max_edge)
        else:
            mesh, search = budget.fit_edge(depth, valid, params, camera, float(max_edge),
                                           tiles=tiles)
    t4 = time.perf_counter()
    seconds = {"prepare": t1 - t0, **mesh.stats.seconds}
    if search:
        seconds["search"] = t4 - t1 - sum(mesh.stats.seconds.values())
    seconds["total"] = t4 - t0
    stats = dataclasses.replace(mesh.stats, seconds=seconds, search=search)
    return dataclasses.replace(mesh, stats=stats)
