"""Camera models: how a pixel ``(r, c)`` with depth ``z`` becomes a 3-D point.

The move from the image to 3-D happens here and in the matching kernel
``rangemesh.geometry.vectors.lift``, nowhere else.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Orthographic", "Pinhole", "backproject", "as_camera", "check_reach"]

# Kind codes shared with the kernels (first slot of ``Camera.as_array()``).
ORTHOGRAPHIC = 0.0
PINHOLE = 1.0


def _positive(name, value, allow_negative=False):
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise TypeError(f"{name} must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value) or value == 0.0 or (value < 0 and not allow_negative):
        kind = "non-zero" if allow_negative else "positive"
        raise ValueError(f"{name} must be a finite {kind} number, got {value!r}")
    return value


@dataclass(frozen=True)
class Orthographic:
    """The paper's mapping, eq. (4): ``X = kx*r, Y = ky*c, Z = kz*depth``.

    Parameters
    ----------
    kx, ky, kz : float, default 1.0
        Scale of rows, columns and depth values in 3-D units. ``kz`` may be
        negative (for images where a larger value means nearer).

    Examples
    --------
    >>> backproject([2], [3], [10.0], Orthographic(0.5, 0.5, 2.0))
    array([[ 1. ,  1.5, 20. ]])
    """

    kx: float = 1.0
    ky: float = 1.0
    kz: float = 1.0

    def __post_init__(self):
        object.__setattr__(self, "kx", _positive("kx", self.kx))
        object.__setattr__(self, "ky", _positive("ky", self.ky))
        object.__setattr__(self, "kz", _positive("kz", self.kz, allow_negative=True))

    def as_array(self) -> np.ndarray:
        """Parameters packed for the kernels: ``[kind, kx, ky, kz, 0, 0]``."""
        return np.array([ORTHOGRAPHIC, self.kx, self.ky, self.kz, 0.0, 0.0])


@dataclass(frozen=True)
class Pinhole:
    """A pinhole depth camera: ``((c-cx)*Z/fx, (r-cy)*Z/fy, Z)``, ``Z = depth*depth_scale``.

    The 3-D frame is the usual camera frame of depth sensors (x right, y down,
    z forward), so with depth in metres (``depth_scale=0.001`` for millimetres,
    ``0.0002`` for TUM's 1/5000 m) the vertices are metric points.

    Parameters
    ----------
    fx, fy : float
        Focal lengths in pixels.
    cx, cy : float
        Principal point (column, row) in pixels.
    depth_scale : float, default 1.0
        Multiplier from stored depth values to 3-D units (Z).

    Examples
    --------
    >>> backproject([240], [420], [2000.0], Pinhole(500, 500, 320, 240, 0.001))
    array([[0.4, 0. , 2. ]])
    """

    fx: float
    fy: float
    cx: float
    cy: float
    depth_scale: float = 1.0

    def __post_init__(self):
        object.__setattr__(self, "fx", _positive("fx", self.fx))
        object.__setattr__(self, "fy", _positive("fy", self.fy))
        for name in ("cx", "cy"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)):
                raise TypeError(f"{name} must be a number, got {v!r}")
            if not math.isfinite(float(v)):
                raise ValueError(f"{name} must be finite, got {v!r}")
            object.__setattr__(self, name, float(v))
        object.__setattr__(self, "depth_scale", _positive("depth_scale", self.depth_scale))

    def as_array(self) -> np.ndarray:
        """Parameters packed for the kernels: ``[kind, fx, fy, cx, cy, depth_scale]``."""
        return np.array([PINHOLE, self.fx, self.fy, self.cx, self.cy, self.depth_scale])


Camera = Orthographic | Pinhole


def as_camera(camera) -> Orthographic | Pinhole:
    """Return a camera object from ``None``, a camera, or a 3-tuple ``(kx, ky, kz)``.

    Parameters
    ----------
    camera : None, Orthographic, Pinhole or sequence of 3 floats
        ``None`` means ``Orthographic(1, 1, 1)``; a 3-sequence is ``(kx, ky, kz)``.

    Raises
    ------
    TypeError
        For anything else.
    """
    if camera is None:
        return Orthographic()
    if isinstance(camera, (Orthographic, Pinhole)):
        return camera
    if isinstance(camera, (tuple, list)) and len(camera) == 3:
        return Orthographic(*camera)
    raise TypeError(
        "camera must be None, rangemesh.Orthographic, rangemesh.Pinhole or a "
        f"(kx, ky, kz) tuple, got {camera!r}"
    )


def backproject(r, c, z, camera=None) -> np.ndarray:
    """Map pixels ``(r, c)`` with depth values ``z`` to 3-D points.

    Parameters
    ----------
    r, c : (N,) array_like of int or float
        Pixel rows and columns.
    z : (N,) array_like of float
        Depth values as stored in the image (before any scaling).
    camera : Orthographic or Pinhole, optional
        Default ``Orthographic(1, 1, 1)``.

    Returns
    -------
    points : (N, 3) ndarray of float64
    """
    camera = as_camera(camera)
    r = np.asarray(r, dtype=np.float64)
    c = np.asarray(c, dtype=np.float64)
    z = np.asarray(z, dtype=np.float64)
    if isinstance(camera, Orthographic):
        return np.stack([camera.kx * r, camera.ky * c, camera.kz * z], axis=-1)
    zz = z * camera.depth_scale
    x = (c - camera.cx) * zz / camera.fx
    y = (r - camera.cy) * zz / camera.fy
    return np.stack([x, y, zz], axis=-1)


def check_reach(camera, image_shape, depth_lo: float, depth_hi: float) -> None:
    """Refuse a camera that maps some pixel of the image beyond the float range.

    Every coordinate of `backproject` is monotonic in row, column and depth
    taken one at a time, and is computed in the same order here, so its
    largest magnitude (intermediate products included) is reached at a corner
    of the image with the smallest or largest valid depth: checking those
    eight points checks every vertex the image can give.

    Parameters
    ----------
    camera : Orthographic or Pinhole
    image_shape : (int, int)
    depth_lo, depth_hi : float
        The smallest and largest valid depth values.

    Raises
    ------
    ValueError
        If a vertex would be infinite or NaN.
    """
    if isinstance(camera, Orthographic) and max(camera.kx, camera.ky, abs(camera.kz)) <= 1.0:
        return  # no coordinate can grow: the image's own values are finite
    h, w = image_shape
    r, c, z = (np.array(a, np.float64).ravel()
               for a in np.meshgrid([0, h - 1], [0, w - 1], [depth_lo, depth_hi]))
    with np.errstate(over="ignore", invalid="ignore"):
        pts = backproject(r, c, z, camera)
    if not np.isfinite(pts).all():
        raise ValueError(
            f"camera {camera} maps depth values up to {max(abs(depth_lo), abs(depth_hi)):g} "
            f"beyond the floating-point range (infinite vertices); check its parameters "
            f"and depth_scale"
        )
