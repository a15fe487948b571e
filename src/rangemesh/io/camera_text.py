"""The camera as text in a mesh file's comments, written and read back."""

from __future__ import annotations

import math

import numpy as np

from ..camera import MAX_RAY_PIXELS, Orthographic, Pinhole, Spherical

# Header lines stay well under RPly's 1,024 characters (Open3D aborts on longer ones).
MAX_COMMENT_CHARS = 900


def _camera_comments(camera) -> list[str]:
    """The camera as PLY comments of at most `MAX_COMMENT_CHARS` characters each.

    The first is ``rangemesh camera ...`` (`_camera_text`); a spherical
    camera's per-row values, too long for one line, continue on
    ``rangemesh camera+ ...`` lines, read back in order.
    """
    words = ("rangemesh camera " + _camera_text(camera)).split(" ")
    lines, line = [], words[0] + " " + words[1]
    for word in words[2:]:
        if len(line) + 1 + len(word) > MAX_COMMENT_CHARS:
            lines.append(line)
            line = "rangemesh camera+"
        line += " " + word
    return [*lines, line]


def _camera_text(camera) -> str:
    """The camera as a PLY comment: ``orthographic kx ky kz`` or ``pinhole fx fy cx cy scale``.

    A `Spherical` camera with evenly spaced columns is ``spherical scale H W
    azimuth0 step`` then the H elevations and H row offsets; other per-pixel
    cameras are named only (``rays``), and reading the file needs the camera.
    """
    if isinstance(camera, Spherical):
        az = camera.azimuth
        even = az[0] + camera.step * np.arange(az.size)
        if np.allclose(az, even, rtol=0.0, atol=1e-9):
            values = [camera.range_scale, az[0], camera.step, *camera.elevation,
                      *camera.row_azimuth]
            h, w = camera.shape
            return f"spherical {h} {w} " + " ".join(repr(float(v)) for v in values)
        return "rays"
    if hasattr(camera, "directions"):
        return "rays"
    if isinstance(camera, Pinhole):
        values = (camera.fx, camera.fy, camera.cx, camera.cy, camera.depth_scale)
        return "pinhole " + " ".join(repr(float(v)) for v in values)
    return "orthographic " + " ".join(repr(float(v)) for v in (camera.kx, camera.ky, camera.kz))


def _camera_from_text(parts, image_shape=(0, 0)):
    """The camera of a ``rangemesh camera ...`` comment, or None if it cannot be read.

    A spherical camera must be for `image_shape` (when known, not ``(0, 0)``):
    that is checked before the file's numbers size its rays.

    Raises
    ------
    ValueError
        A spherical camera for another image shape, or too large to be one.
    """
    try:
        values = [float(p) for p in parts[1:]]
    except ValueError:
        return None  # another writer's comment, or a damaged one: the caller's camera decides
    try:  # a damaged value (0, NaN, a degenerate table) reads as no camera
        if parts[0] == "pinhole" and len(values) == 5:
            return Pinhole(*values[:4], depth_scale=values[4])
        if parts[0] == "orthographic" and len(values) == 3:
            return Orthographic(*values)
    except ValueError:
        return None
    if parts[0] != "spherical" or len(values) < 5 or not all(map(math.isfinite, values[:2])):
        return None
    h, w = int(values[0]), int(values[1])
    scale, az0, step = values[2:5]
    rest = values[5:]
    if len(rest) != 2 * h or w < 1:
        return None
    shape = tuple(int(n) for n in image_shape)
    if shape != (0, 0) and (h, w) != shape:
        raise ValueError(f"the file's camera is for a {h}x{w} image, not for this "
                         f"{shape[0]}x{shape[1]} one")
    if h * w > MAX_RAY_PIXELS:
        raise ValueError(f"the file's camera has {h}x{w} pixels, more than {MAX_RAY_PIXELS}")
    try:
        return Spherical(rest[:h], az0 + step * np.arange(w), rest[h:], scale)
    except ValueError:
        return None
