"""Rendering a mesh back into its image: the depth it predicts at every pixel.

Used by the error measures (`rangemesh.metrics`) and by the searches that
stop on an error bound; it knows only meshes, cameras and the rasteriser.
"""

from __future__ import annotations

import math

import numpy as np

from ._core import covered_error, rasterize, valid_range
from .blocks import BLOCK, blocks, filled, take
from .camera import Orthographic, Pinhole, Rays, Spherical
from .mesh import Mesh

__all__ = ["render_depth", "relative_error", "deviation_scale"]


def _image_coords(mesh: Mesh) -> tuple[np.ndarray, np.ndarray]:
    """Image-plane position of each vertex: its pixel if known, else its projection."""
    if mesh.pixels is not None and len(mesh.pixels) == len(mesh.vertices):
        return mesh.pixels[:, 0].astype(np.float64), mesh.pixels[:, 1].astype(np.float64)
    cam = mesh.camera
    v = mesh.vertices
    if isinstance(cam, Orthographic):
        r, c = v[:, 0] / cam.kx, v[:, 1] / cam.ky
    elif isinstance(cam, Spherical):
        r, c = _spherical_pixels(cam, v)
    elif isinstance(cam, Rays):
        raise ValueError("a mesh made with a Rays camera needs its vertices' pixels to be "
                         "rendered (write PLY files with pixels=True)")
    else:
        with np.errstate(divide="ignore", invalid="ignore"):
            r, c = v[:, 1] * cam.fy / v[:, 2] + cam.cy, v[:, 0] * cam.fx / v[:, 2] + cam.cx
    # Vertices read back from float32 files project a hair off their pixel; snap them
    # so that coverage along shared edges is decided exactly as for the original mesh.
    return _snap(r), _snap(c)


def _spherical_pixels(cam: Spherical, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Fractional (row, col) of points seen by a spherical camera (rows by elevation)."""
    el = np.degrees(np.arctan2(v[:, 2], np.hypot(v[:, 0], v[:, 1])))
    rows = np.arange(cam.elevation.size, dtype=np.float64)
    order = np.argsort(cam.elevation)
    r = np.interp(el, cam.elevation[order], rows[order])
    ri = np.clip(np.round(r).astype(np.int64), 0, cam.elevation.size - 1)
    az = np.degrees(np.arctan2(v[:, 1], v[:, 0])) - cam.row_azimuth[ri]
    step = cam.step if cam.azimuth.size > 1 else 1.0
    c = (az - cam.azimuth[0]) / step
    c = np.mod(c + 0.5, 360.0 / abs(step)) - 0.5 if cam.wraps else c
    return r, c


def _snap(x: np.ndarray, tol: float = 1e-3) -> np.ndarray:
    near = np.round(x)
    return np.where(np.abs(x - near) < tol, near, x)
def render_depth(mesh: Mesh, shape: tuple[int, int] | None = None, *,
                 step: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Depth the mesh predicts at every pixel centre, in stored depth units.

    Each pixel is intersected with the triangle that covers it in the image
    plane (closed triangles; on a shared edge the first face in order wins).
    With an orthographic camera depth is interpolated linearly; with a pinhole
    camera inverse depth is, which is the exact intersection of the pixel's ray
    with the flat 3-D triangle (so is that of a ``Rays(..., z_depth=True)``
    camera's depth); with `Spherical` and `Rays` cameras the range
    is interpolated linearly. Seam faces of a wrap-around mesh
    (`rangemesh.geometry.seam`) cover no pixel centre and are skipped.

    Parameters
    ----------
    mesh : Mesh
    shape : (int, int), optional
        Image shape; default ``mesh.image_shape``.
    step : int, default 1
        Render every `step`-th pixel of every `step`-th row only (pixel
        ``(i, j)`` of the result is pixel ``(step*i, step*j)`` of the image):
        pictures of large images need no full-resolution buffers.

    Returns
    -------
    depth : (ceil(H/step), ceil(W/step)) ndarray of float64
        NaN where no triangle covers the pixel.
    face : (ceil(H/step), ceil(W/step)) ndarray of int64
        Index of the covering face, -1 where none.
    """
    h, w = mesh.image_shape if shape is None else shape
    h, w = -(-h // step), -(-w // step)
    # (whole images and every face: a block at a time, so Ctrl-C is seen between blocks)
    out = filled((h, w), np.nan)
    face = filled((h, w), -1, np.int64)
    if mesh.is_empty:
        return out, face
    r, c = _image_coords(mesh)
    if step != 1:
        r, c = r / step, c / step
    cam = mesh.camera
    z = mesh.vertices[:, 2]
    if isinstance(cam, Orthographic):
        val = z / cam.kz
    elif isinstance(cam, Pinhole):
        with np.errstate(divide="ignore", over="ignore"):
            val = 1.0 / z
        # a subnormal depth scale puts 3-D depths where 1/z overflows: interpolate the inverse
        # of the stored depth instead (the same prediction, in range)
        stored = not np.isfinite(val[z != 0]).all()
        if stored:
            with np.errstate(divide="ignore"):
                val = cam.depth_scale / z
    elif getattr(cam, "z_depth", False):
        # depths along the axis, as a pinhole's: their inverse is interpolated
        with np.errstate(divide="ignore"):
            val = cam.range_scale / z
    else:
        val = np.linalg.norm(mesh.vertices, axis=1) / cam.range_scale
    f = mesh.faces
    if 3 * len(f) <= BLOCK:
        fr, fc, fv, seam = _face_corners(f, r, c, val, w)
    else:  # a block of faces at a time: Ctrl-C is seen between blocks
        fr, fc, fv = (np.empty((len(f), 3)) for _ in range(3))
        seam = np.empty(len(f), bool)
        for b in blocks(len(f), per=3):
            fr[b], fc[b], fv[b], seam[b] = _face_corners(f[b], r, c, val, w)
    index = np.flatnonzero(~seam)
    if len(index) != len(f):
        fr, fc, fv = take(fr, index), take(fc, index), take(fv, index)
    rasterize(fr, fc, fv, out, face)
    if len(index) != len(f):
        for b in blocks(h, per=w):
            fb = face[b]
            hit = fb >= 0
            fb[hit] = index[fb[hit]]
    if isinstance(cam, Pinhole):
        with np.errstate(divide="ignore", invalid="ignore"):
            for b in blocks(h, per=w):
                o = out[b]
                np.divide(1.0, o, out=o)
                if not stored:
                    np.divide(o, cam.depth_scale, out=o)
    elif getattr(cam, "z_depth", False):
        with np.errstate(divide="ignore", invalid="ignore"):
            for b in blocks(h, per=w):
                np.divide(1.0, out[b], out=out[b])
    return out, face


def _face_corners(f, r, c, val, w):
    """Faces' corner rows, columns and values (F, 3 each), and which are seam faces.

    Seam faces of a wrap-around mesh are clockwise and as wide as the image
    (other meshes' faces may be clockwise, but not that wide); they cover no
    pixel centre.
    """
    fr, fc = r[f], c[f]
    area = (fr[:, 1] - fr[:, 0]) * (fc[:, 2] - fc[:, 0]) - (fc[:, 1] - fc[:, 0]) * (fr[:, 2] - fr[:, 0])
    return fr, fc, val[f], (area < 0) & (fc.max(axis=1) - fc.min(axis=1) > 0.5 * w)


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
    depth = np.asarray(depth, np.float64)
    valid = np.asarray(valid, np.bool_)
    covered = covered_error(pred, depth, valid)
    total, n = covered.total, covered.count
    if n == 0:
        return float("nan")
    r = valid_range(depth, valid)
    return float(per_span(total / n, float(r.hi - r.lo), 100.0))


def per_span(x, span: float, full: float, *, out=None):
    """``x * full / span`` (``x`` a number or an array): a share of the depth range.

    0 when the span is 0 (a constant image has no error). For a subnormal
    span, ``full / span`` overflows, so ``x`` is divided first; otherwise the
    factor is applied as one multiplication. `out` (an array, possibly `x`)
    receives the result without a new array.
    """
    if not span > 0:
        return np.multiply(x, 0.0, out=out)
    factor = full / span
    if math.isfinite(factor):
        return np.multiply(x, factor, out=out)
    return np.multiply(np.divide(x, span, out=out), full, out=out)


def deviation_scale(camera) -> tuple[float, bool]:
    """``(scale, inverse)``: metres of one stored depth unit, and whether the render interpolates its inverse.

    A pixel's deviation is ``|predicted - measured| * scale``, its prediction
    that of `rangemesh.render.render_depth`: z-depth before a `Pinhole`
    (``depth_scale``, inverse depth interpolated), range along the ray before
    `Spherical` and `Rays` (``range_scale``; z-depth, inverse interpolated,
    with ``z_depth=True``), depth units with `Orthographic` (scale 1).

    Examples
    --------
    >>> from rangemesh.camera import Pinhole
    >>> deviation_scale(Pinhole(500.0, 500.0, 320.0, 240.0, depth_scale=0.001))
    (0.001, True)
    """
    if isinstance(camera, Orthographic):
        return 1.0, False
    if isinstance(camera, Pinhole):
        return float(camera.depth_scale), True
    return float(camera.range_scale), bool(getattr(camera, "z_depth", False))
