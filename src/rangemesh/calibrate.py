"""Data-driven disparity threshold: the paper's ``Delta = mu + 2 sigma``."""

from __future__ import annotations

import numpy as np

from .pipeline import triangulate
from .resolve import call_options, resolve_params

__all__ = ["calibrate_delta", "triangle_disparities"]


def _unit_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    p = vertices[faces]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    return np.divide(n, norm, out=np.zeros_like(n), where=norm > 0)


def _angles(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise angle in radians between vectors (atan2 form, robust near 0 and pi)."""
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b))


def triangle_disparities(depth, labels, params=None, *, background=None, camera=None,
                         **overrides) -> np.ndarray:
    """Disparities, in degrees, of the triangles that lie inside one surface.

    The image is meshed without flips (the plain 2.5-D Delaunay mesh). For every
    triangle T whose three vertices carry the same label, and every vertex V of
    T all of whose triangles carry that label too, the disparity is the angle
    between T's normal and the normal of V's span (the sum of the unit normals
    of V's other triangles). This is the quantity of the paper's eq. (5)
    before it is capped at Delta.

    Parameters
    ----------
    depth : (H, W) array_like
        Range image.
    labels : (H, W) array_like of int
        Ground-truth segmentation: one id per surface; negative ids mark
        pixels that belong to no surface.
    params, background, camera, **overrides
        As for `triangulate` (``flips`` is forced to None).

    Returns
    -------
    (N,) ndarray of float64
        One disparity per (triangle, vertex) pair, in degrees.

    Raises
    ------
    ValueError
        If `labels` has another shape than `depth`.
    """
    params = resolve_params(params, overrides).replace(flips=None)
    labels = np.asarray(labels)
    if labels.shape != np.shape(depth):
        raise ValueError(
            f"labels must have the shape of depth {np.shape(depth)}, got {labels.shape}"
        )
    if not np.issubdtype(labels.dtype, np.integer):
        raise TypeError(f"labels must be an integer array, got dtype {labels.dtype}")
    mesh = triangulate(depth, method="paper", background=background, camera=camera,
                       **call_options(params, "paper"))
    if mesh.is_empty:
        return np.zeros(0)
    vlab = labels[mesh.pixels[:, 0], mesh.pixels[:, 1]]
    f = mesh.faces.astype(np.int64)
    flab = vlab[f]
    pure = (flab[:, 0] == flab[:, 1]) & (flab[:, 1] == flab[:, 2]) & (flab[:, 0] >= 0)
    normals = _unit_normals(mesh.vertices, f)
    n_v = len(mesh.vertices)
    total = np.zeros((n_v, 3))
    n_inc = np.zeros(n_v, np.int64)
    n_pure = np.zeros(n_v, np.int64)
    for k in range(3):
        np.add.at(total, f[:, k], normals)
        np.add.at(n_inc, f[:, k], 1)
        np.add.at(n_pure, f[:, k], pure.astype(np.int64))
    inside = (n_inc == n_pure) & (n_inc >= 2)
    t_idx, k_idx = np.nonzero(pure[:, None] & inside[f])
    v = f[t_idx, k_idx]
    span = total[v] - normals[t_idx]
    return np.degrees(_angles(span, normals[t_idx]))


def calibrate_delta(depth, labels, params=None, *, background=None, camera=None,
                    **overrides) -> float:
    """The paper's disparity threshold ``Delta = mean + 2 std``, in degrees.

    Parameters
    ----------
    depth, labels, params, background, camera, **overrides
        As for `triangle_disparities`.

    Returns
    -------
    float
        ``mu + 2 sigma`` of `triangle_disparities`, in degrees: pass it as
        ``delta=`` to `triangulate`.

    Raises
    ------
    ValueError
        If no triangle lies inside one surface.

    Notes
    -----
    The paper computes Delta on a manually segmented training image and
    reports 20 degrees for its scanner. On exact planes the disparities are 0
    (Delta = 0); curvature and noise raise it.
    """
    d = triangle_disparities(depth, labels, params, background=background, camera=camera,
                             **overrides)
    if d.size == 0:
        raise ValueError("no triangle lies inside one surface of labels; cannot calibrate delta")
    return float(d.mean() + 2.0 * d.std())
