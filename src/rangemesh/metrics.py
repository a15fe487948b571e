"""Stage four: how well a mesh approximates its range image (paper III, SPEC 4)."""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from . import _kernels
from .camera import Orthographic
from .mesh import Mesh
from .prepare import to_depth_and_mask
from .sampling import curvature

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

    def to_dict(self) -> dict:
        """Plain-Python dictionary (JSON-ready; NaN stays NaN)."""
        return asdict(self)


def _image_coords(mesh: Mesh) -> tuple[np.ndarray, np.ndarray]:
    """Image-plane position of each vertex: its pixel if known, else its projection."""
    if mesh.pixels is not None and len(mesh.pixels) == len(mesh.vertices):
        return mesh.pixels[:, 0].astype(np.float64), mesh.pixels[:, 1].astype(np.float64)
    cam = mesh.camera
    v = mesh.vertices
    if isinstance(cam, Orthographic):
        r, c = v[:, 0] / cam.kx, v[:, 1] / cam.ky
    else:
        with np.errstate(divide="ignore", invalid="ignore"):
            r, c = v[:, 1] * cam.fy / v[:, 2] + cam.cy, v[:, 0] * cam.fx / v[:, 2] + cam.cx
    # Vertices read back from float32 files project a hair off their pixel; snap them
    # so that coverage along shared edges is decided exactly as for the original mesh.
    return _snap(r), _snap(c)


def _snap(x: np.ndarray, tol: float = 1e-3) -> np.ndarray:
    near = np.round(x)
    return np.where(np.abs(x - near) < tol, near, x)


def render_depth(mesh: Mesh, shape: tuple[int, int] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Depth the mesh predicts at every pixel centre, in stored depth units.

    Each pixel is intersected with the triangle that covers it in the image
    plane (closed triangles; on a shared edge the first face in order wins).
    With an orthographic camera depth is interpolated linearly; with a pinhole
    camera inverse depth is, which is the exact intersection of the pixel's ray
    with the flat 3-D triangle.

    Parameters
    ----------
    mesh : Mesh
    shape : (int, int), optional
        Image shape; default ``mesh.image_shape``.

    Returns
    -------
    depth : (H, W) ndarray of float64
        NaN where no triangle covers the pixel.
    face : (H, W) ndarray of int64
        Index of the covering face, -1 where none.
    """
    h, w = mesh.image_shape if shape is None else shape
    out = np.full((h, w), np.nan)
    face = np.full((h, w), -1, np.int64)
    if mesh.is_empty:
        return out, face
    r, c = _image_coords(mesh)
    cam = mesh.camera
    z = mesh.vertices[:, 2]
    if isinstance(cam, Orthographic):
        val = z / cam.kz
    else:
        with np.errstate(divide="ignore"):
            val = 1.0 / z
    f = mesh.faces.astype(np.int64)
    _kernels.rasterize(np.ascontiguousarray(r[f]), np.ascontiguousarray(c[f]),
                       np.ascontiguousarray(val[f]), h, w, out, face)
    if not isinstance(cam, Orthographic):
        with np.errstate(divide="ignore", invalid="ignore"):
            out = 1.0 / out / cam.depth_scale
    return out, face


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
        K = K * (255.0 / span)
    return valid & (K >= threshold)


def relative_error(mesh: Mesh, depth: np.ndarray, valid: np.ndarray) -> float:
    """The paper's relative error alone, in percent (the first figure of `evaluate`).

    Parameters
    ----------
    mesh : Mesh
    depth : (H, W) ndarray of float64
        Original depth (background values are ignored).
    valid : (H, W) ndarray of bool

    Returns
    -------
    float
        NaN when no valid pixel is covered.
    """
    pred, _ = render_depth(mesh, depth.shape)
    covered = valid & np.isfinite(pred)
    if not covered.any():
        return float("nan")
    span = float(depth[valid].max() - depth[valid].min())
    scale = 100.0 / span if span > 0 else 0.0
    return float(np.mean(np.abs(pred[covered] - depth[covered]))) * scale


def evaluate(mesh: Mesh, depth, *, background=None, discontinuities: np.ndarray | None = None,
             band: int = 2) -> Evaluation:
    """The paper's relative error and companions, exact and vectorised.

    Parameters
    ----------
    mesh : Mesh
    depth : (H, W) array_like
        The original range image (not gap-filled).
    background : float, optional
        Value that marks missing depth, as given to `triangulate`. NaN and
        infinite pixels are always background.
    discontinuities : (H, W) ndarray of bool, optional
        Known jump and crease pixels (synthetic scenes). Default:
        `discontinuity_mask` of the image.
    band : int, default 2
        Half-width in pixels (Chebyshev distance) of the edge band.

    Returns
    -------
    Evaluation

    Notes
    -----
    For every valid pixel covered by a triangle in the image plane, the error
    is ``|depth - plane(pixel centre)|``; figures are divided by the valid
    depth range and given in percent. The paper averages over all valid
    pixels; here uncovered pixels (holes the mesh does not span) are left out
    of the mean and reported separately as `uncovered`.
    """
    d, valid = to_depth_and_mask(depth, background)
    if mesh.image_shape != d.shape:
        raise ValueError(f"depth has shape {d.shape} but the mesh was made from {mesh.image_shape}")
    n_valid = int(valid.sum())
    span = float(d[valid].max() - d[valid].min()) if n_valid else 0.0
    pred, _ = render_depth(mesh)
    covered = valid & np.isfinite(pred)
    n_cov = int(covered.sum())
    scale = 100.0 / span if span > 0 else 0.0
    err = np.abs(pred[covered] - d[covered]) * scale
    if discontinuities is None:
        discontinuities = discontinuity_mask(d, valid)
    elif np.shape(discontinuities) != d.shape:
        raise ValueError(
            f"discontinuities must have the image's shape {d.shape}, "
            f"got {np.shape(discontinuities)}"
        )
    if isinstance(band, bool) or not isinstance(band, (int, np.integer)) or band < 0:
        raise ValueError(f"band must be a whole number >= 0, got {band!r}")
    near = np.asarray(discontinuities, bool)
    if band > 0:
        from scipy import ndimage  # imported here: start-up time of the command line matters
  # iterations=0 would mean "until nothing changes" to SciPy
        near = ndimage.binary_dilation(near, structure=np.ones((3, 3), bool), iterations=band)
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
    )
