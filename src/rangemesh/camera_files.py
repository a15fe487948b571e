"""Calibration files: a ROS ``camera_info`` YAML, an OpenCV FileStorage YAML/XML, an Open3D JSON.

`read_camera` reads one into a `Pinhole`, or with lens distortion into exact
per-pixel `Rays` (``z_depth=True``): each pixel centre undistorted by
inverting the distortion model, as OpenCV's ``undistortPoints`` does, so
vertices land where the sensor measured. `distortion_rays` is that step alone
(recordings use it for ``CameraInfo.D``).
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np

from .camera import MAX_RAY_PIXELS, Pinhole, Rays

__all__ = ["read_camera", "distortion_rays", "DISTORTION_MODELS"]

# Model names as calibration tools write them -> the model evaluated here.
DISTORTION_MODELS = {
    "plumb_bob": "brown", "rational_polynomial": "brown", "brown_conrady": "brown",
    "radtan": "brown", "opencv": "brown",
    "equidistant": "equidistant", "fisheye": "equidistant", "kannala_brandt": "equidistant",
}
_MAX_BYTES = 1 << 20  # a calibration file is a few kilobytes: anything larger is not one
_TOL = 1e-14  # convergence of the inversion, in normalised image coordinates (~1e-11 px)

_K_NAMES = ("camera_matrix", "K", "cameraMatrix", "intrinsic_matrix")
_D_NAMES = ("distortion_coefficients", "D", "distCoeffs", "dist_coeffs")
_W_NAMES = ("image_width", "width")
_H_NAMES = ("image_height", "height")


def _brown(x, y, d):
    """Brown-Conrady (OpenCV) forward model and its Jacobian at normalised points (x, y)."""
    k1, k2, p1, p2, k3, k4, k5, k6 = d
    r2 = x * x + y * y
    a = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    b = 1 + r2 * (k4 + r2 * (k5 + r2 * k6))
    rad = a / b
    da = k1 + r2 * (2 * k2 + 3 * k3 * r2)
    db = k4 + r2 * (2 * k5 + 3 * k6 * r2)
    drad = (da * b - a * db) / (b * b)  # d rad / d r2
    fx = x * rad + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    fy = y * rad + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    jxx = rad + 2 * x * x * drad + 2 * p1 * y + 6 * p2 * x
    jxy = 2 * x * y * drad + 2 * p1 * x + 2 * p2 * y
    jyy = rad + 2 * y * y * drad + 6 * p1 * y + 2 * p2 * x
    return fx, fy, jxx, jxy, jxy, jyy


def _undistort_brown(xd, yd, d, where):
    """Points (x, y) that the Brown-Conrady model `d` maps to (xd, yd): damped Newton steps."""
    x, y = xd.copy(), yd.copy()
    for _ in range(100):
        fx, fy, a, b, c, e = _brown(x, y, d)
        ex, ey = fx - xd, fy - yd
        err = np.maximum(np.abs(ex), np.abs(ey))
        if err.max(initial=0.0) <= _TOL:
            return x, y
        det = a * e - b * c
        with np.errstate(divide="ignore", invalid="ignore"):
            sx, sy = (e * ex - b * ey) / det, (a * ey - c * ex) / det
        sx = np.where(np.isfinite(sx), sx, 0.0)
        sy = np.where(np.isfinite(sy), sy, 0.0)
        step = np.ones_like(x)
        for _ in range(30):  # halve a step that does not reduce the residual
            nx, ny = x - step * sx, y - step * sy
            gx, gy = _brown(nx, ny, d)[:2]
            worse = np.maximum(np.abs(gx - xd), np.abs(gy - yd)) > err
            if not worse.any():
                break
            step = np.where(worse, step / 2, step)
        x, y = nx, ny
    raise ValueError(f"{where}: the distortion cannot be inverted at every pixel (the model "
                     f"folds over inside the image): check the coefficients")


def _undistort_equidistant(xd, yd, d, where):
    """The fisheye model: angle theta from the axis with theta_d = theta (1 + k1 t^2 + ... k4 t^8)."""
    k1, k2, k3, k4 = d
    rd = np.hypot(xd, yd)
    t = np.minimum(rd, math.pi / 2)
    for _ in range(100):
        t2 = t * t
        f = t * (1 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4)))) - rd
        if np.abs(f).max(initial=0.0) <= _TOL:
            break
        df = 1 + t2 * (3 * k1 + t2 * (5 * k2 + t2 * (7 * k3 + t2 * 9 * k4)))
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.clip(t - np.where(df > 0, f / df, 0.0), 0.0, math.pi / 2)
    else:
        raise ValueError(f"{where}: the fisheye distortion cannot be inverted at every pixel: "
                         f"check the coefficients")
    if (t >= math.pi / 2 - 1e-9).any():
        raise ValueError(f"{where}: the fisheye model puts pixels at 90 degrees or more from "
                         f"the axis, where a depth along the axis cannot lift them")
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(rd > 0, np.tan(t) / rd, 1.0)
    return xd * s, yd * s


def distortion_rays(k, d, model: str, shape, *, depth_scale: float = 1.0, where: str = "camera"):
    """The camera of a pinhole matrix `k` with distortion `d`: `Pinhole`, or `Rays` if distorted.

    Each pixel centre ``(r, c)`` is undistorted, inverting the model to
    1e-14 in normalised coordinates, and its ray is ``(x, y, 1)`` in the
    camera frame (x right, y down, z forward); the image's values are depths
    along z (``Rays(..., z_depth=True)``).

    Parameters
    ----------
    k : (3, 3) array_like or 9 numbers
        The camera matrix ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]`` (skew `s` allowed).
    d : sequence of float
        ``plumb_bob``: k1, k2, p1, p2[, k3[, k4, k5, k6]] (the rational model);
        ``equidistant``: k1..k4. All zero (or none) gives a `Pinhole`.
    model : str
        A name of `DISTORTION_MODELS`.
    shape : (int, int)
        The image's rows and columns.
    depth_scale : float, default 1.0
    where : str
        What to name in errors (the file).

    Raises
    ------
    ValueError
        An unknown model, coefficients of the wrong count, or a model that
        cannot be inverted over the image.
    """
    k = np.asarray(k, dtype=np.float64).reshape(3, 3)
    if not np.isfinite(k).all() or k[0, 0] <= 0 or k[1, 1] <= 0 or k[1, 0] != 0 \
            or k[2, 0] != 0 or k[2, 1] != 0 or k[2, 2] != 1:
        raise ValueError(f"{where}: camera_matrix {k.ravel().tolist()} is no camera matrix "
                         f"([[fx, s, cx], [0, fy, cy], [0, 0, 1]], fx and fy positive)")
    d = np.asarray(d, dtype=np.float64).ravel()
    if not np.isfinite(d).all():
        raise ValueError(f"{where}: distortion_coefficients must be finite numbers")
    fx, s, cx, fy, cy = k[0, 0], k[0, 1], k[0, 2], k[1, 1], k[1, 2]
    if not d.any() and s == 0:  # any model without distortion is the pinhole
        return Pinhole(fx, fy, cx, cy, depth_scale=depth_scale)
    kind = DISTORTION_MODELS.get(str(model).strip().lower())
    if kind is None:
        raise ValueError(f"{where}: distortion_model {model!r} is not one of "
                         f"{', '.join(sorted(DISTORTION_MODELS))}")
    if kind == "brown":
        if d.size not in (0, 4, 5, 8) and not (d.size in (12, 14) and not d[8:].any()):
            raise ValueError(f"{where}: distortion_coefficients has {d.size} values; "
                             f"{model} takes 4, 5 or 8 (k1 k2 p1 p2 [k3 [k4 k5 k6]]); thin-prism "
                             f"and tilt terms are not supported")
        d = np.concatenate([d[:8], np.zeros(8 - min(d.size, 8))])
    elif d.size != 4 and not (d.size > 4 and not d[4:].any()):
        raise ValueError(f"{where}: distortion_coefficients has {d.size} values; the "
                         f"equidistant (fisheye) model takes 4 (k1 k2 k3 k4)")
    else:
        d = d[:4]
    h, w = (int(n) for n in shape)
    if h < 1 or w < 1 or h * w > MAX_RAY_PIXELS:
        raise ValueError(f"{where}: image size {w}x{h} is no image a camera is made for")
    r, c = np.meshgrid(np.arange(h, dtype=np.float64), np.arange(w, dtype=np.float64),
                       indexing="ij")
    yd = (r - cy) / fy
    xd = (c - cx - s * yd) / fx
    if kind == "brown":
        x, y = _undistort_brown(xd.ravel(), yd.ravel(), d, where)
    else:
        x, y = _undistort_equidistant(xd.ravel(), yd.ravel(), d, where)
    rays = np.stack([x, y, np.ones_like(x)], axis=-1).reshape(h, w, 3)
    return Rays(rays, range_scale=depth_scale, z_depth=True)


# ---------------------------------------------------------------------------- the file formats

def _number_list(text, where, field):
    """Numbers from a parsed list (YAML) or a text of numbers (XML, "[...]")."""
    try:
        if isinstance(text, (list, tuple)):
            if any(isinstance(v, bool) for v in text):
                raise ValueError
            return [float(v) for v in text]
        return [float(v) for v in re.split(r"[\s,]+", str(text).strip().strip("[]").strip()) if v]
    except (TypeError, ValueError):
        raise ValueError(f"{where}: {field} must hold numbers, got {str(text).strip()!r:.60}") from None


def _yaml_scalar(text: str):
    text = text.strip()
    if len(text) >= 2 and text[0] == text[-1] and text[0] in "\"'":
        return text[1:-1]
    return text


def _read_yaml(text: str, where: str) -> dict:
    """The top-level mapping of a ROS camera_info YAML or an OpenCV FileStorage YAML, by PyYAML.

    OpenCV writes a ``%YAML:1.0`` directive and ``!!opencv-matrix`` tags, which YAML
    1.1 does not know: the directive is dropped and any unknown tag read as its plain
    mapping, list or scalar.
    """
    import yaml

    class Loader(yaml.SafeLoader):
        """SafeLoader that reads nodes of unknown tags as untagged ones."""

    def untagged(loader, suffix, node):
        if isinstance(node, yaml.MappingNode):
            return loader.construct_mapping(node, deep=True)
        if isinstance(node, yaml.SequenceNode):
            return loader.construct_sequence(node, deep=True)
        return loader.construct_scalar(node)

    Loader.add_multi_constructor("", untagged)
    text = re.sub(r"\A\s*%YAML:[^\n]*\n", "", text)
    try:
        fields = yaml.load(text, Loader=Loader)  # noqa: S506 (a SafeLoader)
    except yaml.YAMLError as e:
        problem = str(e).splitlines()[0] if str(e) else type(e).__name__
        raise ValueError(f"{where}: not a camera_info or OpenCV YAML file ({problem})") from None
    if not isinstance(fields, dict):
        raise ValueError(f"{where}: not a camera_info or OpenCV YAML file (no mapping at the top)")
    return fields


def _read_xml(text: str, where: str) -> dict:
    import xml.etree.ElementTree as ET

    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise ValueError(f"{where}: not an OpenCV XML file ({exc})") from None
    if root.tag != "opencv_storage":
        raise ValueError(f"{where}: an OpenCV XML file's root is <opencv_storage>, not <{root.tag}>")
    out: dict = {}
    for node in root:
        if len(node):
            out[node.tag] = {child.tag: (child.text or "").strip() for child in node}
        else:
            out[node.tag] = _yaml_scalar(node.text or "")
    return out


def _matrix(value, where, field, shapes):
    """A matrix field (an OpenCV/ROS ``rows, cols, data`` node or a flat list) as a flat array."""
    if isinstance(value, dict):
        if "data" not in value:
            raise ValueError(f"{where}: {field} has no data")
        data = np.array(_number_list(value["data"], where, f"{field}.data"))
        if "rows" in value and "cols" in value:
            try:
                rows, cols = int(value["rows"]), int(value["cols"])
            except ValueError:
                raise ValueError(f"{where}: {field} rows and cols must be whole numbers") from None
            if rows * cols != data.size:
                raise ValueError(f"{where}: {field} is {rows}x{cols} but holds {data.size} values")
            if shapes is not None and (rows, cols) not in shapes:
                raise ValueError(f"{where}: {field} must be 3x3, not {rows}x{cols}")
    else:
        data = np.array(_number_list(str(value), where, field))
    if shapes is not None and data.size != 9:
        raise ValueError(f"{where}: {field} must hold 9 values (3x3), got {data.size}")
    return data


def _field(fields, names, where, needed=True):
    for name in names:
        if name in fields:
            return name, fields[name]
    if needed:
        raise ValueError(f"{where}: no {names[0]} (nor {', '.join(names[1:])})")
    return None, None


def _whole(value, where, field) -> int:
    try:
        n = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{where}: {field} must be a whole number, got {value!r:.40}") from None
    if not n.is_integer() or not 1 <= n <= MAX_RAY_PIXELS:
        raise ValueError(f"{where}: {field} must be a positive whole number, got {value!r:.40}")
    return int(n)


def read_camera(path, *, depth_scale: float = 1.0, image_shape=None):
    """The camera of a calibration file: `Pinhole`, or per-pixel `Rays` with lens distortion.

    Reads a ROS ``camera_info`` YAML (``camera_calibration``,
    ``camera_info_manager``), an OpenCV FileStorage YAML (``%YAML:1.0``) or
    XML (``<opencv_storage>``), as OpenCV's calibration sample and RTAB-Map
    write them (``camera_matrix`` or ``K``, ``distortion_coefficients`` or
    ``D``, ``image_width``, ``image_height``, optionally ``distortion_model``),
    or an Open3D ``PinholeCameraIntrinsic`` JSON (``width``, ``height``,
    ``intrinsic_matrix``, 9 values column-major). Distortion ``plumb_bob`` /
    ``rational_polynomial`` (Brown-Conrady, OpenCV's default when a file names
    no model) or ``equidistant`` (fisheye, k1..k4) gives exact per-pixel rays
    (`distortion_rays`); none, or all coefficients 0, a `Pinhole`. The
    rectification and projection matrices are not used: the rays are those of
    the raw image, the one a depth sensor stores.

    Parameters
    ----------
    path : str or os.PathLike
    depth_scale : float, default 1.0
        Multiplier from stored depth values to metres (0.001 for millimetres):
        the files carry none.
    image_shape : (int, int), optional
        The image's rows and columns: checked against the file's size.

    Returns
    -------
    Pinhole or Rays

    Raises
    ------
    ValueError
        A file that cannot be read, or a missing or malformed field, naming
        the file and the field.
    """
    path = Path(path)
    where = str(path)
    try:
        if not path.is_file():
            raise OSError("not a regular file" if path.exists() else "no such file")
        if path.stat().st_size > _MAX_BYTES:
            raise OSError(f"{path.stat().st_size} bytes is too large for a calibration file")
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise ValueError(f"{where}: cannot read the calibration file ({exc})") from None
    head = text.lstrip()
    if head.startswith("{") and "intrinsic_matrix" in text:  # (a flow-style YAML starts so too)
        try:
            data = json.loads(text)
        except (ValueError, RecursionError) as exc:
            raise ValueError(f"{where}: not a JSON file ({type(exc).__name__})") from None
        if not isinstance(data, dict):
            raise ValueError(f"{where}: an Open3D intrinsics file holds a JSON object")
        for key in ("width", "height", "intrinsic_matrix"):
            if key not in data:
                raise ValueError(f"{where}: no {key} (an Open3D PinholeCameraIntrinsic JSON)")
        m = data["intrinsic_matrix"]
        if not isinstance(m, list) or len(m) != 9 or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) for v in m):
            raise ValueError(f"{where}: intrinsic_matrix must be 9 numbers (3x3 column-major)")
        k = np.array(m, dtype=np.float64).reshape(3, 3).T  # Open3D stores it column-major
        width = _whole(data["width"], where, "width")
        height = _whole(data["height"], where, "height")
        d, model = (), "plumb_bob"
    else:
        fields = _read_xml(text, where) if head.startswith("<") else _read_yaml(text, where)
        name, kv = _field(fields, _K_NAMES, where)
        k = _matrix(kv, where, name, {(3, 3)}).reshape(3, 3)
        name, dv = _field(fields, _D_NAMES, where, needed=False)
        d = () if dv is None else _matrix(dv, where, name, None)
        model = str(fields.get("distortion_model") or "plumb_bob")
        _, w = _field(fields, _W_NAMES, where, needed=False)
        _, h = _field(fields, _H_NAMES, where, needed=False)
        if w is None and "cameraResolution" in fields:  # OpenCV's interactive calibration
            res = _number_list(str(fields["cameraResolution"]), where, "cameraResolution")
            w, h = res if len(res) == 2 else (None, None)
        if w is None or h is None:
            raise ValueError(f"{where}: no image_width and image_height (the size the "
                             f"calibration is for)")
        width = _whole(w, where, "image_width")
        height = _whole(h, where, "image_height")
    if image_shape is not None and tuple(int(n) for n in image_shape) != (height, width):
        raise ValueError(f"{where}: the calibration is for a {width}x{height} image, not this "
                         f"{image_shape[1]}x{image_shape[0]} one")
    return distortion_rays(k, d, model, (height, width), depth_scale=depth_scale, where=where)
