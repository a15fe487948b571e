"""The multiresolution curvature of a range image: the paper's sampling weight and the evaluation's jumps.

Paper II.A.1, SPEC.md 1.2-1.3. Two users: the paper's stage one weighs
its samples by it (`rangemesh.paper.sampling.sampling_weights`) and
`rangemesh.evaluate` finds depth discontinuities with it
(`rangemesh.metrics.discontinuity_mask`); neither method owns it.
"""

from __future__ import annotations

import numpy as np

from .. import _core
from .._core import valid_range

__all__ = ["curvature", "valid_span"]


def valid_span(depth: np.ndarray, valid: np.ndarray) -> float:
    """Max - min of the valid depths (0 when there is none)."""
    r = valid_range(np.ascontiguousarray(depth, dtype=np.float64),
                    np.ascontiguousarray(valid, dtype=np.bool_))
    return float(r.hi - r.lo) if r.count else 0.0


def curvature(depth: np.ndarray, valid: np.ndarray, levels: int = 2) -> np.ndarray:
    """Multiresolution curvature image ``K``, paper II.A.1 and SPEC 1.2-1.3.

    ``K1 = |R(r-1,c) - 2R(r,c) + R(r+1,c)| + |R(r,c-1) - 2R(r,c) + R(r,c+1)|``;
    level ``l`` applies the same operator to ``R[::2**l, ::2**l]`` and is added
    back at full resolution as ``K_l[r >> l, c >> l]``.

    Parameters
    ----------
    depth : (H, W) ndarray of float64
    valid : (H, W) ndarray of bool
    levels : int, default 2
        Number of resolutions added (1 = full resolution only).

    Returns
    -------
    K : (H, W) ndarray of float64
        In depth units (not normalised). A stencil that leaves the image adds 0;
        a stencil that mixes valid and background pixels adds the scene's
        valid depth range (max - min), the size we give a silhouette jump.

    Notes
    -----
    The jump size is the scene's depth range rather than a local one: after
    normalisation (`rangemesh.paper.sampling.sampling_weights`) a silhouette
    then always weighs ``log(255)``, the most any jump inside the scene can
    weigh, whatever the background marker or the depth unit.
    """
    v = np.ascontiguousarray(valid, dtype=np.bool_)
    d = np.ascontiguousarray(depth, dtype=np.float64)
    # The kernel never reads a background depth, so no masked copy is needed.
    K = np.zeros(d.shape)
    _core.add_curvature(d, v, valid_span(d, v), int(levels), K)
    return K
