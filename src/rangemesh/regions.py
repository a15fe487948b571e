"""Speckle removal: connected regions of valid pixels, split at depth jumps.

A depth camera leaves specks: a few valid pixels alone in a hole or an
invalid border, or a flying pixel off its surroundings. Meshed, each pulls a
fan of long triangles to its neighbours (issue 41: one valid pixel at (0, 0)
in a 100-pixel invalid border of a Kinect frame gives 27 triangles and 8 % of
the mesh's area). ``min_region=K`` drops every region of fewer than K pixels,
as OpenCV's ``cv::filterSpeckles`` and RealSense's speckle filtering do.

How regions are made: two valid 8-neighbours ``a``, ``b`` belong to one region
when::

    |za - zb| <= REGION_JUMP * min(|za|, |zb|) * L

with ``L = 1`` along a row or column and ``sqrt(2)`` across a diagonal: the
rule of `rangemesh.geometry.walls` (a step above 5 % of the local depth per
pixel is a jump), in stored units (the ratio is the same in metres). OpenCV
compares with a fixed ``maxDiff`` in disparity units; a share of the depth
follows a depth camera's noise, which grows with the depth, and on a
disparity image it is the same share of the depth (``d ~ 1/z``). Diagonal
neighbours join, as a mesh's triangles join them (OpenCV takes 4-neighbours
only).
"""

from __future__ import annotations

import numpy as np

from ._core import label_regions as _label_regions

__all__ = ["REGION_JUMP", "label_regions", "drop_small_regions"]

# A step above this share of the smaller depth per pixel splits two neighbours' regions:
# MeshParams.jump's default, the walls' rule (rangemesh.geometry.walls).
REGION_JUMP = 0.05


def label_regions(depth: np.ndarray, valid: np.ndarray, share: float = REGION_JUMP):
    """Each valid pixel's region and each region's size (the rule in the module's docstring).

    Parameters
    ----------
    depth : (H, W) array_like of float
    valid : (H, W) array_like of bool
    share : float, default REGION_JUMP
        The largest step between joined neighbours, as a share of the
        smaller depth per pixel of length.

    Returns
    -------
    labels : (H, W) ndarray of int32
        Region ids 0, 1, ... in row-major order of each region's first
        pixel; -1 on invalid pixels.
    sizes : (N,) ndarray of int64
        Pixels of each region.

    Examples
    --------
    >>> d = np.array([[1.0, 1.0, 0.0, 5.0]])
    >>> labels, sizes = label_regions(d, d > 0)
    >>> labels.tolist(), sizes.tolist()
    ([[0, 0, -1, 1]], [2, 1])
    """
    # a flood over every pixel of each frame, so C++ (geometry/regions.cpp: 7 ms a VGA frame,
    # loaded machine); scipy.ndimage.label cannot split at jumps, a jump-aware graph through
    # scipy.sparse.csgraph took 55-65 ms
    d = np.ascontiguousarray(depth, dtype=np.float64)
    v = np.ascontiguousarray(valid, dtype=np.bool_)
    if d.ndim != 2 or v.shape != d.shape:
        raise ValueError(f"depth and valid must be 2-D arrays of one shape, got {d.shape} and {v.shape}")
    labels = np.empty(d.shape, np.int32)
    sizes = _label_regions(d, v, float(share), labels)
    return labels, sizes


def drop_small_regions(depth: np.ndarray, valid: np.ndarray, min_region: int,
                       share: float = REGION_JUMP) -> int:
    """Mark the pixels of regions smaller than `min_region` missing, in place.

    Parameters
    ----------
    depth : (H, W) ndarray of float64
        Set to 0.0 where a pixel is dropped (the background's value).
    valid : (H, W) ndarray of bool
    min_region : int
        Regions of fewer pixels are dropped.
    share : float, default REGION_JUMP

    Returns
    -------
    int
        Pixels dropped.

    Examples
    --------
    >>> d = np.array([[1.0, 1.0, 0.0, 5.0]]); v = d > 0
    >>> drop_small_regions(d, v, 2), v.tolist()
    (1, [[True, True, False, False]])
    """
    if min_region <= 1 or not valid.any():
        return 0
    labels, sizes = label_regions(depth, valid, share)
    small = sizes < min_region
    if not small.any():
        return 0
    drop = valid & small[np.maximum(labels, 0)]
    valid[drop] = False
    depth[drop] = 0.0
    return int(np.count_nonzero(drop))
