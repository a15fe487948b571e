"""Camera models: how a pixel ``(r, c)`` with depth ``z`` becomes a 3-D point.

The move from the image to 3-D happens here and in the matching kernel
``lift`` of the compiled core (``_core/geometry/vectors.hpp``), nowhere else.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .checks import real_number, whole_number

__all__ = ["Orthographic", "Pinhole", "Spherical", "Rays", "backproject", "as_camera",
           "check_reach", "check_shape", "toward_sensor", "read_beams"]

# Kind codes shared with the kernels (first slot of ``Camera.as_array()``).
ORTHOGRAPHIC = 0.0
PINHOLE = 1.0
RAYS = 2.0  # a ray per pixel: [2, H, W, range_scale, 0, 0, then the (H, W, 3) rays flat]
# Bounds on numbers read from a beams file, checked before they size an array: a beams file is
# a few kilobytes; 2**26 pixels of rays take 1.6 GB (sensors have under 2**19).
MAX_BEAMS_BYTES = 1 << 24
MAX_RAY_PIXELS = 1 << 26


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

    x along the rows (down the image), y along the columns, z the depth
    value: unlike `Pinhole`, whose x runs along the columns.

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


def _angles(name, values, length=None) -> np.ndarray:
    try:
        arr = np.array(values, dtype=np.float64, copy=True)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a sequence of numbers (degrees), got {values!r:.60}") \
            from None
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"{name} must be a non-empty 1-D sequence of degrees, got shape {arr.shape}")
    if length is not None and arr.size != length:
        raise ValueError(f"{name} must have {length} values (one per row), got {arr.size}")
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} must be finite")
    arr.setflags(write=False)
    return arr


class _RayCamera:
    """What `Spherical` and `Rays` share: one unit ray per pixel, ``point = range * ray``."""

    directions: np.ndarray
    range_scale: float

    @property
    def shape(self) -> tuple[int, int]:
        """The image shape ``(H, W)`` the camera is made for."""
        return self.directions.shape[:2]

    @property
    def lifts(self) -> np.ndarray:
        """What a stored value is multiplied by, per pixel: ``point = value * range_scale * lifts``.

        The unit rays, or with ``Rays(..., z_depth=True)`` the rays scaled to ``z = 1``.
        """
        return self.directions

    def as_array(self) -> np.ndarray:
        """Parameters packed for the kernels: ``[2, H, W, range_scale, 0, 0, rays...]``."""
        h, w = self.shape
        return np.concatenate([[RAYS, h, w, self.range_scale, 0.0, 0.0], self.lifts.ravel()])

    def __eq__(self, other):
        # to 1e-9 (degrees, or ray components): a camera read back from a file's text is equal
        return (type(self) is type(other) and self.range_scale == other.range_scale
                and getattr(self, "z_depth", False) == getattr(other, "z_depth", False)
                and all(a.shape == b.shape and np.allclose(a, b, rtol=0.0, atol=1e-9)
                        for a, b in zip(self._key(), other._key(), strict=True)))

    def __hash__(self):
        return hash((type(self).__name__, self.range_scale, self.shape))


@dataclass(frozen=True, eq=False)
class Spherical(_RayCamera):
    """A spinning LiDAR: one elevation per row, one azimuth per column, ``point = range * ray``.

    The ray of pixel ``(r, c)`` is ``(cos e cos A, cos e sin A, sin e)`` with
    ``e = elevation[r]`` and ``A = azimuth[c] + row_azimuth[r]`` (degrees),
    in the sensor frame of Ouster and Velodyne drivers: x forward, y left,
    z up. Ranges are distances along the ray, times `range_scale`.

    Parameters
    ----------
    elevation : (H,) sequence of float
        Elevation of each row (beam), degrees; row 0 is usually the highest.
    azimuth : (W,) sequence of float
        Azimuth of each column, degrees.
    row_azimuth : (H,) sequence of float, optional
        Per-row azimuth offset, degrees (what is left of staggered beams once
        the columns are destaggered); default 0.
    range_scale : float, default 1.0
        Multiplier from stored range values to 3-D units.

    Examples
    --------
    >>> cam = Spherical([0.0, -30.0], [0.0, 90.0, 180.0, 270.0])
    >>> np.round(backproject([1], [1], [2.0], cam), 6)
    array([[ 0.      ,  1.732051, -1.      ]])
    >>> cam.wraps
    True
    """

    elevation: np.ndarray
    azimuth: np.ndarray
    row_azimuth: np.ndarray | None = None
    range_scale: float = 1.0

    def __post_init__(self):
        el = _angles("elevation", self.elevation)
        az = _angles("azimuth", self.azimuth)
        off = np.zeros(el.size) if self.row_azimuth is None else self.row_azimuth
        off = _angles("row_azimuth", off, el.size)
        # every column and row its own ray: a degenerate table maps pixels onto one line
        if (np.abs(el) > 90.0).any():
            raise ValueError("elevation must be within -90 .. 90 degrees")
        for name, a in (("elevation", el), ("azimuth", az)):
            d = np.diff(a)
            if a.size > 1 and not ((d > 0).all() or (d < 0).all()):
                raise ValueError(f"{name} must change strictly one way from each row or column "
                                 f"to the next (equal neighbours map pixels onto one ray)")
        if az.size > 1 and abs(float(az[-1] - az[0])) >= 360.0:
            raise ValueError(f"azimuth spans {abs(float(az[-1] - az[0])):g} degrees: columns "
                             f"must not go round more than once")
        object.__setattr__(self, "elevation", el)
        object.__setattr__(self, "azimuth", az)
        object.__setattr__(self, "row_azimuth", off)
        object.__setattr__(self, "range_scale", _positive("range_scale", self.range_scale))
        e = np.radians(el)[:, None]
        a = np.radians(az[None, :] + off[:, None])
        rays = np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a),
                         np.broadcast_to(np.sin(e), a.shape)], axis=-1)
        rays.setflags(write=False)
        object.__setattr__(self, "directions", rays)

    def _key(self):
        return (self.elevation, self.azimuth, self.row_azimuth)

    @property
    def step(self) -> float:
        """The median azimuth step between neighbouring columns, degrees (signed)."""
        return float(np.median(np.diff(self.azimuth))) if self.azimuth.size > 1 else 0.0

    @property
    def wraps(self) -> bool:
        """True when the columns go once round (360 degrees, to within half a step).

        Then column W-1 is the neighbour of column 0, and `triangulate`
        meshes the seam between them by default (``wrap=None``).
        """
        step = self.step
        if self.azimuth.size < 3 or step == 0.0:
            return False
        d = np.diff(self.azimuth)
        if not ((d > 0).all() or (d < 0).all()):
            return False
        turn = abs(float(self.azimuth[-1] - self.azimuth[0])) + abs(step)
        return abs(turn - 360.0) <= 0.5 * abs(step)

    @classmethod
    def from_beams(cls, beams, *, range_scale: float = 1.0, image_shape=None) -> Spherical:
        """The camera described by a ``.beams.json`` file (or its parsed dictionary).

        The layout (that of ``rellis3d_os1-64_000000.beams.json``; see
        docs/method.md): ``elevation_deg`` (one per row), ``azimuth0_deg``,
        ``azimuth_step_deg``, ``cols``, and optionally
        ``azimuth_row_residual_deg`` (one per row). Column ``c`` of row ``r``
        has azimuth ``azimuth0_deg + azimuth_row_residual_deg[r] + c *
        azimuth_step_deg``. Other keys are ignored.

        Parameters
        ----------
        beams : dict or str or os.PathLike
            The parsed file, or its path.
        range_scale : float, default 1.0
        image_shape : (int, int), optional
            The shape of the image the camera is for: checked before any
            array is sized by the file's numbers.

        Raises
        ------
        ValueError
            A missing key or a value of the wrong kind, naming it; a camera
            for another image shape, or one larger than `MAX_RAY_PIXELS`.
        """
        if not isinstance(beams, dict):
            beams = read_beams(beams)
        missing = [k for k in ("elevation_deg", "azimuth0_deg", "azimuth_step_deg", "cols")
                   if k not in beams]
        if missing:
            raise ValueError(f"beams: missing {', '.join(missing)} (see the beams layout in docs/method.md)")
        try:  # JSON numbers only: strings are never read as numbers, nor 2048.9 as 2048
            cols = whole_number("beams: cols", beams["cols"], minimum=1)
            az0 = real_number("beams: azimuth0_deg", beams["azimuth0_deg"])
            step = real_number("beams: azimuth_step_deg", beams["azimuth_step_deg"])
            el = beams_numbers("elevation_deg", beams["elevation_deg"])
            off = beams.get("azimuth_row_residual_deg")
            off = None if off is None else beams_numbers("azimuth_row_residual_deg", off)
            rows = beams.get("rows")
            if rows is not None and whole_number("beams: rows", rows, minimum=1) != el.size:
                raise ValueError(f"beams: rows is {rows} but elevation_deg has {el.size} values")
        except TypeError as exc:
            raise ValueError(str(exc)) from None
        if step == 0:
            raise ValueError("beams: azimuth_step_deg must be non-zero")
        # sizes read from a file are checked before they size the rays
        if image_shape is not None and (el.size, cols) != tuple(int(n) for n in image_shape):
            raise ValueError(f"the beams file describes a {el.size}x{cols} image, not this "
                             f"{image_shape[0]}x{image_shape[1]} one")
        if el.size * cols > MAX_RAY_PIXELS:
            raise ValueError(f"beams: {el.size} rows x {cols} cols is more than the "
                             f"{MAX_RAY_PIXELS} pixels a per-pixel camera may have")
        return cls(el, az0 + step * np.arange(cols), off, range_scale)


@dataclass(frozen=True, eq=False)
class Rays(_RayCamera):
    """The most general camera: any unit ray per pixel, ``point = range * ray``.

    Parameters
    ----------
    directions : (H, W, 3) array_like of float
        The ray of each pixel (normalised here; none may be zero).
    range_scale : float, default 1.0
        Multiplier from stored range values to 3-D units.
    z_depth : bool, default False
        True when the stored values are depths along the optical axis (Z, as
        depth cameras store them) rather than distances along the ray: then
        ``point = value * range_scale * ray / ray_z``, and every ray must
        point forward (``ray_z > 0``). `rangemesh.read_camera` makes these
        for a depth camera with lens distortion.
    """

    directions: np.ndarray
    range_scale: float = 1.0
    z_depth: bool = False

    def __post_init__(self):
        if np.iscomplexobj(self.directions):
            raise TypeError("directions must be real numbers, not complex")
        d = np.array(self.directions, dtype=np.float64, copy=True)
        if d.ndim != 3 or d.shape[2] != 3 or min(d.shape[:2]) < 1:
            raise ValueError(f"directions must be (H, W, 3), got shape {d.shape}")
        if not np.isfinite(d).all():
            raise ValueError("directions must be finite and non-zero")
        big = np.abs(d).max(axis=2, keepdims=True)
        if not (big > 0).all():
            raise ValueError("directions must be finite and non-zero")
        with np.errstate(over="ignore", under="ignore"):
            norm = np.linalg.norm(d, axis=2, keepdims=True)
        # a very long or very short vector's norm overflows or underflows: scale it first
        far = ~np.isfinite(norm[..., 0]) | (norm[..., 0] < 1e-150)
        d[far] /= big[far]
        norm[far] = np.linalg.norm(d[far], axis=1, keepdims=True)
        d /= norm
        d.setflags(write=False)
        object.__setattr__(self, "directions", d)
        object.__setattr__(self, "range_scale", _positive("range_scale", self.range_scale))
        if not isinstance(self.z_depth, (bool, np.bool_)):
            raise TypeError(f"z_depth must be True or False, got {self.z_depth!r}")
        object.__setattr__(self, "z_depth", bool(self.z_depth))
        if self.z_depth:
            # a depth along the optical axis lifts a ray only if it points forward
            if not (d[..., 2] > 1e-12).all():
                raise ValueError("with z_depth=True every ray must point forward (z > 0)")
            lifts = d / d[..., 2:3]
            lifts.setflags(write=False)
            object.__setattr__(self, "_lifts", lifts)

    @property
    def lifts(self) -> np.ndarray:
        """What a stored value is multiplied by, per pixel (see `_RayCamera.lifts`)."""
        return self._lifts if self.z_depth else self.directions

    def _key(self):
        return (self.directions,)

    @property
    def wraps(self) -> bool:
        """False: a ray table says nothing of which columns are neighbours."""
        return False


def beams_numbers(key: str, values, *, whole: bool = False) -> np.ndarray:
    """A beams file's list of numbers as a 1-D array (int64 when `whole`), or an error naming `key`.

    Raises
    ------
    ValueError
        Not a list of JSON numbers (a string, a bool, a nested list), or a
        number that is not finite (not whole, with `whole`).
    """
    if not isinstance(values, (list, tuple)) or not values:
        raise ValueError(f"beams: {key} must be a list of numbers, one per row")
    try:
        if whole:
            return np.array([whole_number(f"beams: {key}[{i}]", v)
                             for i, v in enumerate(values)], dtype=np.int64)
        return np.array([real_number(f"beams: {key}[{i}]", v) for i, v in enumerate(values)])
    except TypeError as exc:
        raise ValueError(str(exc)) from None
    except OverflowError:
        raise ValueError(f"beams: {key} holds a number beyond 64 bits") from None


def read_beams(path) -> dict:
    """The JSON object of a ``.beams.json`` file (layout: `Spherical.from_beams`).

    Raises
    ------
    ValueError
        A file that cannot be read, is not JSON, or holds no JSON object.
    """
    import json
    from pathlib import Path

    path = Path(path)
    try:
        if not path.is_file():
            raise OSError("not a regular file" if path.exists() else "no such file")
        if path.stat().st_size > MAX_BEAMS_BYTES:
            raise OSError(f"{path.stat().st_size} bytes; a beams file has at most "
                          f"{MAX_BEAMS_BYTES}")
        beams = json.loads(path.read_text())
    except (OSError, ValueError, RecursionError) as exc:
        raise ValueError(f"{path}: cannot read it as a beams file "
                         f"({type(exc).__name__ if isinstance(exc, RecursionError) else exc})") \
            from None
    if not isinstance(beams, dict):
        raise ValueError(f"{path}: a beams file holds a JSON object")
    return beams


Camera = Orthographic | Pinhole | Spherical | Rays
CAMERAS = (Orthographic, Pinhole, Spherical, Rays)
_UNIT = Orthographic()  # the default camera; frozen, so one instance serves every call


def pixel_aspect(camera) -> float:
    """How far apart neighbouring rows are, against neighbouring columns, in the sensor's units.

    Orthographic: ``kx / ky`` (3-D units). Pinhole: ``fx / fy`` (the angle
    between rows against that between columns, near the principal point).
    Spherical: the median elevation step against the median azimuth step
    (an Ouster OS1-64: 0.55 against 0.176 degrees, about 3.1). Rays: the
    median angle between vertically neighbouring rays against that between
    horizontally neighbouring ones. 1.0 for ``None`` and for a single row
    or column.

    Examples
    --------
    >>> pixel_aspect(Orthographic(2.0, 1.0))
    2.0
    >>> round(pixel_aspect(Spherical([1.0, 0.5, 0.0], [0.0, 0.25, 0.5, 0.75])), 6)
    2.0
    """
    if camera is None:
        return 1.0
    if isinstance(camera, Orthographic):
        return camera.kx / camera.ky
    if isinstance(camera, Pinhole):
        return camera.fx / camera.fy
    if isinstance(camera, Spherical):
        if camera.elevation.size < 2 or camera.azimuth.size < 2:
            return 1.0
        rows = float(np.median(np.abs(np.diff(camera.elevation))))
        cols = float(np.median(np.abs(np.diff(camera.azimuth))))
    elif isinstance(camera, Rays):
        d = camera.directions
        if d.shape[0] < 2 or d.shape[1] < 2:
            return 1.0
        rows = float(np.median(np.arccos(np.clip((d[1:] * d[:-1]).sum(axis=2), -1.0, 1.0))))
        cols = float(np.median(np.arccos(np.clip((d[:, 1:] * d[:, :-1]).sum(axis=2), -1.0,
                                                   1.0))))
    else:
        raise TypeError(f"pixel_aspect: not a camera: {camera!r}")
    if rows > 0.0 and cols > 0.0:
        return rows / cols
    return 1.0


def as_camera(camera) -> Camera:
    """Return a camera object from ``None``, a camera, or a 3-tuple ``(kx, ky, kz)``.

    Parameters
    ----------
    camera : None, Orthographic, Pinhole, Spherical, Rays or sequence of 3 floats
        ``None`` means ``Orthographic(1, 1, 1)``; a 3-sequence is ``(kx, ky, kz)``.

    Raises
    ------
    TypeError
        For anything else.
    """
    if camera is None:
        return _UNIT
    if isinstance(camera, CAMERAS):
        return camera
    if isinstance(camera, (tuple, list)) and len(camera) == 3:
        return Orthographic(*camera)
    raise TypeError(
        "camera must be None, rangemesh.Orthographic, Pinhole, Spherical, Rays or a "
        f"(kx, ky, kz) tuple, got {camera!r}"
    )


def check_shape(camera, image_shape) -> None:
    """Refuse a per-pixel camera (`Spherical`, `Rays`) made for another image shape.

    Raises
    ------
    ValueError
    """
    if isinstance(camera, _RayCamera) and tuple(camera.shape) != tuple(image_shape):
        h, w = camera.shape
        raise ValueError(f"the camera has rays for a {h}x{w} image, not for this "
                         f"{image_shape[0]}x{image_shape[1]} one")


def backproject(r, c, z, camera=None) -> np.ndarray:
    """Map pixels ``(r, c)`` with depth values ``z`` to 3-D points.

    Parameters
    ----------
    r, c : (N,) array_like of int or float
        Pixel rows and columns (whole pixels inside the image for
        `Spherical` and `Rays`).
    z : (N,) array_like of float
        Depth values as stored in the image (before any scaling).
    camera : Orthographic, Pinhole, Spherical or Rays, optional
        Default ``Orthographic(1, 1, 1)``.

    Returns
    -------
    points : (N, 3) ndarray of float64
    """
    camera = as_camera(camera)
    if isinstance(camera, _RayCamera):
        ri, ci = np.asarray(r), np.asarray(c)
        h, w = camera.shape
        if ri.size and (not np.array_equal(ri, np.round(ri)) or not np.array_equal(ci, np.round(ci))
                        or ri.min() < 0 or ri.max() >= h or ci.min() < 0 or ci.max() >= w):
            raise ValueError(f"a per-pixel camera maps whole pixels of its {h}x{w} image only")
        s = np.asarray(z, dtype=np.float64) * camera.range_scale
        return s[..., None] * camera.lifts[ri.astype(np.int64), ci.astype(np.int64)]
    r = np.asarray(r, dtype=np.float64)
    c = np.asarray(c, dtype=np.float64)
    z = np.asarray(z, dtype=np.float64)
    shape = z.shape if r.shape == c.shape == z.shape else np.broadcast_shapes(r.shape, c.shape, z.shape)
    out = np.empty(shape + (3,))
    if isinstance(camera, Orthographic):
        np.multiply(camera.kx, r, out=out[..., 0])
        np.multiply(camera.ky, c, out=out[..., 1])
        np.multiply(camera.kz, z, out=out[..., 2])
        return out
    zz = np.multiply(z, camera.depth_scale, out=out[..., 2])
    out[..., 0] = (c - camera.cx) * zz / camera.fx
    out[..., 1] = (r - camera.cy) * zz / camera.fy
    return out


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
    if isinstance(camera, _RayCamera):
        with np.errstate(over="ignore"):
            reach = max(abs(depth_lo), abs(depth_hi)) * camera.range_scale
        if not math.isfinite(reach):
            raise ValueError(f"{type(camera).__name__} camera's range_scale "
                             f"{camera.range_scale:g} maps ranges up to "
                             f"{max(abs(depth_lo), abs(depth_hi)):g} beyond the float range")
        return
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


def toward_sensor(camera, points: np.ndarray) -> np.ndarray:
    """Direction from each point toward the sensor (not normalised).

    The sensor of `Pinhole`, `Spherical` and `Rays` is at the origin; an
    `Orthographic` camera looks along +Z (stored depth grows away from it),
    so every point sees it toward -Z.

    Parameters
    ----------
    camera : a camera
    points : (N, 3) ndarray

    Returns
    -------
    (N, 3) ndarray
    """
    if isinstance(camera, Orthographic):
        out = np.zeros_like(points)
        out[:, 2] = -1.0
        return out
    return -points
