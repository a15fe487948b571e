"""Clean-up of the validity mask before meshing: depth limits, then small regions.

Both run in the preparation step (`rangemesh.pipeline.prepare`), after the
background marker is turned into the mask and before `fill_gaps`, so every
entry point (`triangulate`, the command line, `evaluate`, batches,
recordings) sees the same pixels as missing. The error bound's reference
image and `evaluate` drop the same pixels: they are no data the mesh should
follow.
"""

from __future__ import annotations

import numpy as np

from .camera import Pinhole
from .regions import drop_small_regions

__all__ = ["metric_scale", "apply_depth_limits", "clean_inplace"]


def metric_scale(camera) -> float:
    """What a stored value is multiplied by to compare with `depth_limits`.

    A `Pinhole` camera's ``depth_scale`` and a `Spherical` or `Rays`
    camera's ``range_scale`` (limits in metres when the camera is metric);
    1 for `Orthographic` (limits in stored depth units, not ``kz``).
    """
    if isinstance(camera, Pinhole):
        return camera.depth_scale
    return float(getattr(camera, "range_scale", 1.0))


def apply_depth_limits(depth: np.ndarray, valid: np.ndarray, limits, camera=None) -> int:
    """Mark pixels whose depth lies outside ``limits = (near, far)`` missing, in place.

    Parameters
    ----------
    depth : (H, W) ndarray of float64
        Stored values; set to 0.0 where a pixel is dropped.
    valid : (H, W) ndarray of bool
    limits : (float, float)
        Inclusive: a depth of exactly `near` or `far` is kept.
    camera : optional
        The values compared are ``depth * metric_scale(camera)``.

    Returns
    -------
    int
        Pixels dropped.
    """
    near, far = limits
    z = depth * metric_scale(camera)
    out = valid & ((z < near) | (z > far))
    n = int(np.count_nonzero(out))
    if n:
        valid[out] = False
        depth[out] = 0.0
    return n


def clean_inplace(depth: np.ndarray, valid: np.ndarray, params, camera=None) -> dict:
    """`params.depth_limits`, then `params.min_region`, on a prepared depth and mask, in place.

    Returns
    -------
    dict
        Pixels dropped by each: ``{'depth_limits': n, 'min_region': m}``
        (only those asked for).
    """
    dropped = {}
    limits = getattr(params, "depth_limits", None)
    if limits is not None:
        dropped["depth_limits"] = apply_depth_limits(depth, valid, limits, camera)
    k = getattr(params, "min_region", None)
    if k is not None:
        dropped["min_region"] = drop_small_regions(depth, valid, k)
    return dropped
