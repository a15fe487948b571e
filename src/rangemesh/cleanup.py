"""Clean-up of the validity mask before meshing: depth limits, then small regions.

Both run in the preparation step (`rangemesh.pipeline.prepare`), after the
background marker is turned into the mask and before `fill_gaps`, so every
entry point (`triangulate`, the command line, `evaluate`, batches,
recordings) sees the same pixels as missing. The error bound's reference
image and `evaluate` drop the same pixels: they are no data the mesh should
follow.
"""

from __future__ import annotations

import warnings

import numpy as np

from .camera import Pinhole
from .regions import drop_small_regions

__all__ = ["metric_scale", "apply_depth_limits", "clean_inplace", "zeros_like_a_marker",
           "warn_zero_marker", "ZeroMarkerWarning", "MARKER_STEP"]


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


# Exact zeros look like a no-return marker when, where they touch data, they step away from it
# by more than this many times the data's own large steps (the 90th percentile between
# neighbours). Measured: the markers of RELLIS, Middlebury, SUN and TUM step 15 to 60+ times it;
# a terrain or ramp through 0 steps 0.6-0.75 times it.
MARKER_STEP = 3.0


def zeros_like_a_marker(depth: np.ndarray, valid: np.ndarray) -> int:
    """How many valid pixels are exactly 0 when they look like a no-return marker, else 0.

    With an `Orthographic` camera 0 can be data (a height, a disparity at
    infinity), so it is not missing depth; but a float range image that
    writes 0 for no return meshes those pixels at depth 0, silently. The
    zeros look like such a marker when both hold:

    * every other valid value has one sign (the zeros sit at one end of the
      data, apart from it), and
    * they are cut off from the data: where a zero pixel and a non-zero
      valid pixel are 4-neighbours, the median step between them is more
      than `MARKER_STEP` (3) times the 90th percentile of the steps between
      neighbouring non-zero valid pixels (when no zero touches the data:
      the smallest non-zero magnitude is). A terrain rising from 0 or a
      ramp through 0 steps off its zeros as it steps elsewhere: data.

    Parameters
    ----------
    depth : (H, W) ndarray of float64
        The depths, zeros among them.
    valid : (H, W) ndarray of bool
        The pixels that hold data; the zeros looked at are among them.

    Returns
    -------
    int
        The count of exact zeros among the valid pixels, or 0 when they do
        not look like a marker (or there are none).

    Examples
    --------
    >>> d = np.array([[0.0, 0.0, 5.0, 5.1], [0.0, 5.0, 5.1, 5.2]])
    >>> zeros_like_a_marker(d, np.ones(d.shape, bool))
    3
    >>> ramp = np.array([[0.0, 0.1, 0.2, 0.3], [0.0, 0.1, 0.2, 0.3]])
    >>> zeros_like_a_marker(ramp, np.ones(ramp.shape, bool))
    0
    """
    zero = valid & (depth == 0.0)
    n = int(np.count_nonzero(zero))
    data = valid & ~zero
    if n == 0 or not data.any():
        return 0
    values = depth[data]
    if values.min() < 0.0 < values.max():  # the data lies on both sides of 0
        return 0
    border, inner = [], []
    for a, b in (((slice(None), slice(1, None)), (slice(None), slice(None, -1))),
                 ((slice(1, None), slice(None)), (slice(None, -1), slice(None)))):
        za, zb, da, db = zero[a], zero[b], data[a], data[b]
        step = np.abs(depth[a] - depth[b])
        border.append(step[(za & db) | (zb & da)])
        inner.append(step[da & db])
    border, inner = np.concatenate(border), np.concatenate(inner)
    typical = float(np.percentile(inner, 90)) if inner.size else 0.0
    off = float(np.median(border)) if border.size else float(np.abs(values).min())
    return n if off > MARKER_STEP * typical else 0


class ZeroMarkerWarning(UserWarning):
    """Exact zeros of an `Orthographic` image look like a no-return marker (`zeros_like_a_marker`)."""


_warned = []  # the warning is said once a process: a stream of frames would repeat it


def warn_zero_marker(depth: np.ndarray, valid: np.ndarray) -> int:
    """Warn once (a `ZeroMarkerWarning`) when the valid zeros look like a no-return marker.

    Returns
    -------
    int
        The count the warning names (0 when it was not said).
    """
    if _warned:
        return 0
    n = zeros_like_a_marker(depth, valid)
    if n:
        _warned.append(n)
        warnings.warn(f"{n} valid pixels are exactly 0 and look like a no-return marker: with "
                      f"Orthographic, 0 is data, meshed at depth 0; if 0 means no return, give "
                      f"background=0 or the sensor's camera (said once)", ZeroMarkerWarning,
                      stacklevel=_outside_stacklevel())
    return n


def _outside_stacklevel() -> int:
    """The stack level of the first frame outside rangemesh: the user's call."""
    import sys

    frame, level = sys._getframe(1), 1
    while frame is not None and frame.f_globals.get("__name__", "").startswith("rangemesh"):
        frame, level = frame.f_back, level + 1
    return level
