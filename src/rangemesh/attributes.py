"""Per-vertex attributes from images registered with the range image, and normals.

Functions of a `rangemesh.Mesh` (read by attribute: this module sits below
`rangemesh.mesh`, whose methods call it).

A colour image (or a LiDAR intensity image) of the same size as the range
image gives each vertex a value: that of its own pixel, or the mean over the
pixels it stands for. Normals come from the faces and are turned to face the
sensor.
"""

from __future__ import annotations

import numpy as np

from ._core import rasterize
from .camera import toward_sensor
from .geometry.seam import is_seam

__all__ = ["vertex_values", "as_rgb8", "vertex_normals", "texture_uv", "HOW_CHOICES"]

HOW_CHOICES = ("pixel", "mean")


def as_rgb8(image) -> np.ndarray:
    """An image as (H, W, 3) uint8: RGB(A) kept (alpha dropped), grey repeated.

    8-bit images are kept as they are; 16-bit ones are divided by 257; float
    RGB images in [0, 1] are scaled by 255; any other (a LiDAR intensity, a
    depth, any one-channel float image) is stretched from its 1st to its
    99th percentile, so that a few bright returns do not leave the rest black.

    Raises
    ------
    ValueError
        Not (H, W), (H, W, 3) or (H, W, 4), or no finite value.
    """
    a = np.asarray(image)
    if a.ndim == 3 and a.shape[2] in (3, 4):
        a = a[:, :, :3]
    elif a.ndim == 3 and a.shape[2] == 1:
        a = a[:, :, 0]
    if (a.ndim != 2 and not (a.ndim == 3 and a.shape[2] == 3)) or a.dtype == bool \
            or not np.issubdtype(a.dtype, np.number) or np.issubdtype(a.dtype, np.complexfloating):
        raise ValueError(f"a colour image is (H, W), (H, W, 1), (H, W, 3) or (H, W, 4) real "
                         f"numbers, got {a.dtype} of shape {np.shape(image)}")
    if a.dtype == np.uint8:
        out = a
    elif a.dtype == np.uint16:
        out = (a.astype(np.uint32) // 257).astype(np.uint8)
    else:
        with np.errstate(over="ignore", invalid="ignore"):  # uint64 and float128 beyond float64
            f = a.astype(np.float64)
        finite = np.isfinite(f)
        if not finite.any():
            raise ValueError("the colour image has no finite value")
        if a.ndim == 3 and f[finite].min() >= 0 and f[finite].max() <= 1:
            lo, hi = 0.0, 1.0
        else:
            with np.errstate(over="ignore", invalid="ignore"):  # percentiles between huge values
                lo, hi = np.percentile(f[finite], [1, 99])
            if not hi > lo:
                lo, hi = float(f[finite].min()), float(f[finite].max()) + (f[finite].max() == f[finite].min())
        f = np.where(finite, f, lo)
        if not hi > lo:  # one value, too large to be told from value + 1: black, as any constant
            t = np.zeros_like(f)
        elif abs(hi) < 8e307 and abs(lo) < 8e307:
            t = (f - lo) / (hi - lo)
        else:  # a range beyond float64 (from -1e308 to 1e308, say): halved first
            t = (f / 2 - lo / 2) / (hi / 2 - lo / 2)
        out = np.clip(np.round(t * 255.0), 0, 255).astype(np.uint8)
    if out.ndim == 2:
        out = np.repeat(out[:, :, None], 3, axis=2)
    return np.ascontiguousarray(out)


def _check_registered(mesh, image: np.ndarray, what: str) -> None:
    if tuple(image.shape[:2]) != tuple(mesh.image_shape):
        raise ValueError(f"the {what} is {image.shape[0]}x{image.shape[1]} and the range image "
                         f"{mesh.image_shape[0]}x{mesh.image_shape[1]}: they must be registered "
                         f"pixel to pixel (same size)")
    if len(mesh.pixels) != len(mesh.vertices):
        raise ValueError(f"the mesh has no vertex pixels to take its {what} from")


def _owners(mesh) -> tuple[np.ndarray, np.ndarray]:
    """For each covered pixel, the vertex it belongs to: the corner of its face with the largest weight.

    Returns flat pixel indices and their vertices. Each vertex owns its own pixel.
    """
    h, w = mesh.image_shape
    plain = np.flatnonzero(~is_seam(mesh.pixels, mesh.faces))  # seam faces cover no pixel
    f = mesh.faces[plain].astype(np.int64)
    face = np.full((h, w), -1, np.int64)
    rasterize(np.ascontiguousarray(mesh.pixels[f, 0], np.float64),
              np.ascontiguousarray(mesh.pixels[f, 1], np.float64), np.zeros(f.shape),
              np.full((h, w), np.nan), face)
    hit = face >= 0
    face[hit] = plain[face[hit]]
    rr, cc = np.nonzero(face >= 0)
    f = mesh.faces[face[rr, cc]].astype(np.int64)
    pr = mesh.pixels[f, 0].astype(np.float64)
    pc = mesh.pixels[f, 1].astype(np.float64)
    # barycentric weights in the image plane: weight k = area opposite corner k
    weights = np.empty_like(pr)
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        weights[:, k] = np.abs((pr[:, j] - pr[:, i]) * (cc - pc[:, i])
                               - (pc[:, j] - pc[:, i]) * (rr - pr[:, i]))
    owner = f[np.arange(len(f)), np.argmax(weights, axis=1)]
    flat = rr * w + cc
    own = mesh.pixels[:, 0].astype(np.int64) * w + mesh.pixels[:, 1]
    return np.concatenate([flat, own]), np.concatenate([owner, np.arange(len(mesh.pixels))])


def vertex_values(mesh, image, how: str = "pixel") -> np.ndarray:
    """Each vertex's value in `image`, an image registered with the range image.

    Parameters
    ----------
    mesh : Mesh
    image : (H, W) or (H, W, C) array_like
        Same height and width as the range image.
    how : {'pixel', 'mean'}, default 'pixel'
        ``'pixel'``: the value at the vertex's pixel. ``'mean'``: the mean
        over the pixels the vertex stands for: its own pixel and every pixel
        whose covering triangle has this vertex as its nearest corner (the
        corner of largest barycentric weight); with fitted depths this
        matches what a vertex summarises.

    Returns
    -------
    (V,) or (V, C) ndarray of float64

    Raises
    ------
    ValueError
        An image of another size, or an unknown `how`.
    """
    if how not in HOW_CHOICES:
        raise ValueError(f"how must be one of {HOW_CHOICES}, got {how!r}")
    img = np.asarray(image)
    _check_registered(mesh, img, "image")
    flat_img = img.reshape(img.shape[0] * img.shape[1], -1).astype(np.float64)
    if how == "pixel" or mesh.is_empty:
        out = flat_img[mesh.pixels[:, 0].astype(np.int64) * img.shape[1] + mesh.pixels[:, 1]]
    else:
        flat, owner = _owners(mesh)
        n = len(mesh.pixels)
        count = np.bincount(owner, minlength=n).astype(np.float64)
        out = np.stack([np.bincount(owner, flat_img[flat, k], minlength=n)
                        for k in range(flat_img.shape[1])], axis=1) / count[:, None]
    return out[:, 0] if img.ndim == 2 else out


def vertex_normals(mesh) -> np.ndarray:
    """Unit vertex normals facing the sensor.

    Each vertex takes the sum of its faces' normals weighted by their areas.
    Faces are counter-clockwise in the image plane, so their normals all point
    to the same side of the surface as seen from the sensor; that side is
    chosen for the whole mesh as the one facing the sensor on most of the
    area (`rangemesh.camera.toward_sensor`: the origin, or -Z for an
    orthographic camera). A vertex whose faces cancel out gets the direction
    toward the sensor.

    Returns
    -------
    (V, 3) ndarray of float64
    """
    v = mesh.vertices
    n_v = np.zeros_like(v)
    if mesh.is_empty:
        return n_v
    tri = v[mesh.faces]
    fn = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])  # length = twice the area
    view = toward_sensor(mesh.camera, tri.mean(axis=1))
    if np.sum(fn * view) < 0:
        fn = -fn
    for k in range(3):
        np.add.at(n_v, mesh.faces[:, k], fn)
    norm = np.linalg.norm(n_v, axis=1)
    flat = ~(norm > 0)
    if flat.any():
        n_v[flat] = toward_sensor(mesh.camera, v[flat])
        norm[flat] = np.linalg.norm(n_v[flat], axis=1)
        norm[~(norm > 0)] = 1.0
    return n_v / norm[:, None]


def texture_uv(mesh) -> np.ndarray:
    """Texture coordinates ``(u, v) = (col / (W-1), row / (H-1))``: each vertex's own pixel.

    The image convention (origin at the top left, as glTF's): the OBJ writer
    stores ``1 - v``, as OBJ's origin is at the bottom left.
    """
    h, w = mesh.image_shape
    p = mesh.pixels.astype(np.float64)
    return np.stack([p[:, 1] / max(w - 1, 1), p[:, 0] / max(h - 1, 1)], axis=1)
