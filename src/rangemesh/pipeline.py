"""The whole method in one call: `triangulate`."""

from __future__ import annotations

import dataclasses
import time

from .camera import as_camera
from .flipping import flip_edges
from .mesh import Mesh, Stats, empty_mesh
from .params import MeshParams
from .prepare import to_depth_and_mask
from .sampling import fill_gaps, sample_grid
from .triangulation import delaunay_mesh

__all__ = ["triangulate", "resolve_params"]


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


def triangulate(image, params: MeshParams | None = None, *, background=None, camera=None,
                **overrides) -> Mesh:
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
        empty and ``stats.reason`` says why.

    Raises
    ------
    ValueError
        Bad image shape, or parameters out of range (e.g. more tiles than fit).
    TypeError
        Wrong kind of image, camera or parameter.

    See Also
    --------
    sample_grid, delaunay_mesh, flip_edges : the three stages, callable one by one.
    evaluate : relative error of the result.

    Notes
    -----
    Vertices take their depth from the gap-filled image (paper eq. 4 uses the
    filtered image ``R_f``). Stage timings are in ``stats.seconds``.

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
    params = resolve_params(params, overrides)
    camera = as_camera(camera)
    seconds = {}
    t0 = time.perf_counter()
    depth, valid = to_depth_and_mask(image, background)
    if params.fill_gaps:
        depth, valid = fill_gaps(depth, valid)
    t1 = time.perf_counter()
    seconds["prepare"] = t1 - t0
    if not valid.any():
        # Still check the tiling so that bad parameters fail the same way on any image.
        sample_grid(depth, valid, params.replace(sampling="uniform"))
        stats = Stats(grid_shape=params.grid_shape, seconds={**seconds, "total": t1 - t0},
                      reason="the image has no valid pixel (all background)")
        return empty_mesh(camera, depth.shape, stats)
    grid = sample_grid(depth, valid, params)
    t2 = time.perf_counter()
    seconds["sampling"] = t2 - t1
    mesh = delaunay_mesh(grid, depth, valid, camera)
    t3 = time.perf_counter()
    seconds["triangulation"] = t3 - t2
    mesh = flip_edges(mesh, depth, valid, params)
    t4 = time.perf_counter()
    seconds["flipping"] = t4 - t3
    seconds["total"] = t4 - t0
    stats = dataclasses.replace(mesh.stats, seconds=seconds)
    return dataclasses.replace(mesh, stats=stats)
