"""Stage four: how well a mesh approximates its range image (paper III, SPEC 4)."""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from .cleanup import clean_inplace
from .geometry.curvature import curvature, valid_span
from .mesh import Mesh, check_arrays
from .params import MeshParams
from .prepare import to_depth_and_mask
from .render import deviation_scale, per_span, relative_error, render_depth

__all__ = ["Evaluation", "evaluate", "render_depth", "discontinuity_mask", "relative_error"]


@dataclass(frozen=True)
class Evaluation:
    """Approximation error of a mesh against its range image.

    All errors are percentages of the valid depth range (max - min), as in the
    paper's relative error.

    Attributes
    ----------
    relative_error : float
        Mean absolute depth difference over covered valid pixels, % (the paper's figure).
    rms_error, max_error : float
        Root-mean-square and largest difference over the same pixels, %.
    uncovered : float
        Share of valid pixels that no triangle covers, %.
    edge_band_error : float
        `relative_error` restricted to covered valid pixels within 2 pixels of a
        discontinuity, % (NaN when there is no such pixel).
    valid_pixels, covered_pixels, edge_band_pixels : int
        Pixel counts behind the figures.
    depth_range : float
        The normaliser, in depth units.
    max_deviation, mean_deviation : float
        Largest and mean ``|depth - mesh|`` over the same pixels along each
        pixel's ray, in metres with a `Pinhole` (z-depth), `Spherical` or
        `Rays` camera (range; z-depth with ``z_depth=True``), in depth units
        with `Orthographic`: what `triangulate`'s ``max_deviation`` and
        ``mean_deviation`` bound (`rangemesh.render.deviation_scale`).
    """

    relative_error: float
    rms_error: float
    max_error: float
    uncovered: float
    edge_band_error: float
    valid_pixels: int
    covered_pixels: int
    edge_band_pixels: int
    depth_range: float
    max_deviation: float = float("nan")
    mean_deviation: float = float("nan")

    def to_dict(self) -> dict:
        """Plain-Python dictionary (JSON-ready; NaN stays NaN)."""
        return asdict(self)


def discontinuity_mask(depth: np.ndarray, valid: np.ndarray, threshold: float = 20.0) -> np.ndarray:
    """Pixels on a jump or crease edge, derived from the image itself.

    A valid pixel is on a discontinuity when its single-resolution curvature
    (SPEC 1.2: sum of absolute second differences along rows and columns),
    scaled to a 0..255 depth range, is at least `threshold` (default 20, the
    paper's curvature floor), or when a stencil through it reaches background
    (a silhouette). Planar regions have zero second difference whatever their
    slope, so creases and jumps stand out while planes do not.

    Parameters
    ----------
    depth : (H, W) ndarray of float64
    valid : (H, W) ndarray of bool
    threshold : float, default 20

    Returns
    -------
    (H, W) ndarray of bool
    """
    if not valid.any():
        return np.zeros(depth.shape, bool)
    span = float(depth[valid].max() - depth[valid].min())
    K = curvature(depth, valid, levels=1)
    if span > 0:
        K = per_span(K, span, 255.0, out=K)
    return valid & (K >= threshold)


def dilate_square(mask: np.ndarray, radius: int) -> np.ndarray:
    """Pixels within `radius` of a True pixel, in both directions (a (2r+1) x (2r+1) square).

    What ``scipy.ndimage.binary_dilation`` gives with a 3x3 structure and
    `radius` iterations (pixels outside the image are False), in two passes
    of shifted ORs: importing SciPy's ndimage took 0.43 s of a 0.45 s
    ``rangemesh mesh`` process (cProfile, chair image), the dilation itself
    about a millisecond either way.

    Examples
    --------
    >>> m = np.zeros((5, 5), bool); m[0, 0] = True
    >>> dilate_square(m, 1).astype(int)[:3, :3]
    array([[1, 1, 0],
           [1, 1, 0],
           [0, 0, 0]])
    """
    rows = mask.copy()
    for k in range(1, min(radius, mask.shape[1] - 1) + 1):
        rows[:, k:] |= mask[:, :-k]
        rows[:, :-k] |= mask[:, k:]
    out = rows.copy()
    for k in range(1, min(radius, mask.shape[0] - 1) + 1):
        out[k:, :] |= rows[:-k, :]
        out[:-k, :] |= rows[k:, :]
    return out


def evaluate(mesh: Mesh, depth, *, background="auto", discontinuities: np.ndarray | None = None,
             band: int = 2, depth_limits=None, min_region: int | None = None) -> Evaluation:
    """The paper's relative error and companions, exact and vectorised.

    Parameters
    ----------
    mesh : Mesh
    depth : (H, W) array_like
        The original range image (not gap-filled).
    background : float, 'auto', 'nonpositive' or None, default 'auto'
        What marks missing depth, as given to `triangulate` (``'auto'``: 0
        and below with the mesh's `Pinhole`, `Spherical` or `Rays` camera, else
        0 in integer images). NaN and infinite pixels are always background.
    discontinuities : (H, W) ndarray of bool, optional
        Known jump and crease pixels (synthetic scenes). Default:
        `discontinuity_mask` of the image.
    band : int, default 2
        Half-width in pixels (Chebyshev distance) of the edge band.
    depth_limits : (float, float), optional
    min_region : int, optional
        As given to `triangulate`: the pixels they drop are missing depth
        here too (in the units of the mesh's camera; `rangemesh.cleanup`).

    Returns
    -------
    Evaluation

    Raises
    ------
    ValueError
        If the mesh was made from an image of another shape, or its arrays
        cannot be a mesh (see `rangemesh.mesh.check_arrays`).

    Notes
    -----
    For every valid pixel covered by a triangle in the image plane, the error
    is ``|depth - plane(pixel centre)|``; figures are divided by the valid
    depth range and given in percent. The paper averages over all valid
    pixels; here uncovered pixels (holes the mesh does not span) are left out
    of the mean and reported separately as `uncovered`.
    """
    d, valid = to_depth_and_mask(depth, background, camera=mesh.camera)
    if depth_limits is not None or min_region is not None:
        clean_inplace(d, valid, MeshParams(depth_limits=depth_limits, min_region=min_region),
                      mesh.camera)
    check_arrays(mesh.vertices, mesh.faces, mesh.pixels, mesh.image_shape)
    if mesh.image_shape != d.shape:
        raise ValueError(f"depth has shape {d.shape} but the mesh was made from {mesh.image_shape}")
    if isinstance(band, bool) or not isinstance(band, (int, np.integer)) or band < 0:
        raise ValueError(f"band must be a whole number >= 0, got {band!r}")
    if discontinuities is None:
        discontinuities = discontinuity_mask(d, valid)
    elif np.shape(discontinuities) != d.shape:
        raise ValueError(
            f"discontinuities must have the image's shape {d.shape}, "
            f"got {np.shape(discontinuities)}"
        )
    near = np.asarray(discontinuities, bool)
    if band > 0:
        near = dilate_square(near, int(band))
    n_valid = int(np.count_nonzero(valid))
    span = valid_span(d, valid)
    # Full-size buffers are the memory of a large image: reuse them in place and
    # drop each as soon as it is spent (peak about 6.5x a float32 image).
    pred, face = render_depth(mesh)
    del face
    covered = valid & np.isfinite(pred)
    del valid
    n_cov = int(np.count_nonzero(covered))
    np.subtract(pred, d, out=pred)
    del d
    err = pred[covered]
    del pred
    np.abs(err, out=err)
    scale = deviation_scale(mesh.camera)[0]
    max_deviation = float(err.max()) * scale if n_cov else float("nan")
    mean_deviation = float(err.mean()) * scale if n_cov else float("nan")
    per_span(err, span, 100.0, out=err)
    in_band = near[covered]
    return Evaluation(
        relative_error=float(err.mean()) if n_cov else float("nan"),
        rms_error=float(np.sqrt(np.mean(err**2))) if n_cov else float("nan"),
        max_error=float(err.max()) if n_cov else float("nan"),
        uncovered=100.0 * (n_valid - n_cov) / n_valid if n_valid else float("nan"),
        edge_band_error=float(err[in_band].mean()) if in_band.any() else float("nan"),
        valid_pixels=n_valid,
        covered_pixels=n_cov,
        edge_band_pixels=int(in_band.sum()),
        depth_range=span,
        max_deviation=max_deviation,
        mean_deviation=mean_deviation,
    )
