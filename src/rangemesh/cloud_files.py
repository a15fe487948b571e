"""LiDAR cloud files and Ouster metadata for `rangemesh.clouds.project_scan`.

* ``.bin``: KITTI's float32 ``x y z intensity`` records (read here with NumPy).
* ``.pcd``: PCL's point cloud files, ASCII, binary or binary_compressed,
  organised or not, read with `pypcd4` (the ``pcd`` extra, which already
  reads organised clouds as depth images: `rangemesh.io`).
* ``.ply``: the ``vertex`` element's ``x y z`` (and intensity, ring), read
  with `plyfile` (a dependency of the core).

A driver's beam index (``ring`` from the Velodyne and Ouster ROS drivers;
``beam``, ``channel``, ``laser_id``, ``line`` elsewhere) comes back with the
points: `project_scan(points, ring=...)` then puts each point in its own
beam's row instead of the row nearest its elevation.

An Ouster sensor's metadata JSON (the SDK's and ouster-ros's, legacy flat or
nested layout) gives its head exactly: `ouster_head` returns the beams (the
altitude and azimuth angle of each beam, the columns) and what places its
beam origins (`lidar_origin_to_beam_origin_mm`, `lidar_to_sensor_transform`).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from ._optional import require

__all__ = ["CLOUD_SUFFIXES", "RING_FIELDS", "INTENSITY_FIELDS", "read_cloud_file", "ouster_head",
           "pcd_height"]

RING_FIELDS = ("ring", "beam", "channel", "laser_id", "line")
INTENSITY_FIELDS = ("intensity", "reflectivity", "i", "scalar_intensity")
MAX_META_BYTES = 16 << 20  # an Ouster metadata file is some kB; refuse to parse anything huge


def _bin(path: Path) -> np.ndarray:
    size = path.stat().st_size
    if not path.is_file():
        raise OSError("not a regular file")
    if size == 0 or size % 16:
        raise ValueError(f"{size} bytes is not a whole number of float32 x, y, z, intensity "
                         f"records (16 bytes a point)")
    return np.fromfile(path, dtype="<f4").reshape(-1, 4)


def _columns(names, get, what: str):
    """(N, 4) x, y, z, intensity (0 without one) and the ring (or None) from named fields."""
    missing = [f for f in "xyz" if f not in names]
    if missing:
        raise ValueError(f"the {what} has no {', '.join(missing)} field (fields: {', '.join(names)})")
    xyz = [np.asarray(get(f), np.float32).ravel() for f in "xyz"]
    inten = next((f for f in INTENSITY_FIELDS if f in names), None)
    i = np.asarray(get(inten), np.float32).ravel() if inten else np.zeros_like(xyz[0])
    points = np.stack([*xyz, i], axis=1)
    name = next((f for f in RING_FIELDS if f in names), None)
    if name is None:
        return points, None
    raw = np.asarray(get(name)).ravel()
    if raw.dtype.kind == "f":
        if not (np.isfinite(raw).all() and (raw == np.round(raw)).all()):
            raise ValueError(f"the {what}'s {name} field holds numbers that are not whole beams")
    ring = raw.astype(np.int64)
    if len(ring) and ring.min() < 0:
        raise ValueError(f"the {what}'s {name} field holds {int(ring.min())}: beams count from 0")
    return points, ring


def _pcd(path: Path):
    pypcd4 = require("pypcd4", "reading .pcd clouds")
    pc = pypcd4.PointCloud.from_path(path)
    names = list(pc.fields)
    return _columns(names, lambda f: pc.numpy((f,)), "point cloud")


def _ply(path: Path):
    from plyfile import PlyData

    ply = PlyData.read(str(path))
    if "vertex" not in ply:
        raise ValueError("the PLY file has no vertex element")
    v = ply["vertex"]
    names = [p.name for p in v.properties]
    return _columns(names, lambda f: v[f], "PLY file's vertex element")


# The cloud readers by suffix, each giving (points, ring or None): a format is one entry here.
_READERS = {".bin": lambda path: (_bin(path), None), ".pcd": _pcd, ".ply": _ply}
CLOUD_SUFFIXES = tuple(_READERS)


def read_cloud_file(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray | None]:
    """A cloud file's points, (N, 4) float32 ``x y z intensity``, and its ring field (or None).

    Raises
    ------
    ValueError
        An unknown suffix; a file that cannot be read, has no x, y, z, or a ring
        field that is not whole beams >= 0 (the reason, naming the file).
    ImportError
        A ``.pcd`` file without `pypcd4` (``pip install "rangemesh[pcd]"``).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in CLOUD_SUFFIXES:
        raise ValueError(f"{path}: not a cloud file ({', '.join(CLOUD_SUFFIXES)})")
    try:
        if not path.exists():
            raise OSError("no such file")
        return _READERS[suffix](path)
    except OSError as exc:
        raise ValueError(f"{path}: {exc.strerror or exc}") from None
    except ImportError:
        raise
    except Exception as exc:  # a damaged file: the library's reason, in one line
        text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ValueError(text if text.startswith(str(path)) else f"{path}: {text}") from None


def _find(doc: dict, key: str):
    """A key of the metadata: at the top (legacy layout) or in one of its sections (SDK 0.x/1.x)."""
    if key in doc:
        return doc[key]
    for section in ("beam_intrinsics", "lidar_intrinsics", "lidar_data_format", "data_format",
                    "config_params", "sensor_info"):
        part = doc.get(section)
        if isinstance(part, dict) and key in part:
            return part[key]
    return None


def ouster_head(meta: str | os.PathLike | dict) -> dict:
    """An Ouster head from its metadata JSON: a beams file's layout, plus its beam origins.

    Returns
    -------
    dict
        ``rows``, ``cols``, ``elevation_deg`` (``beam_altitude_angles``, top first),
        ``azimuth0_deg`` 0, ``azimuth_step_deg`` ``-360 / cols`` (columns run
        clockwise, as the sensor turns), ``azimuth_row_residual_deg`` (minus
        ``beam_azimuth_angles``: where each beam points against the encoder),
        ``beam_origin_m`` (``lidar_origin_to_beam_origin_mm`` in metres) and
        ``lidar_to_sensor`` (4x4, metres; the frame the SDK's points are in).

    Raises
    ------
    ValueError
        Not readable, not JSON, or without the beam angles or the column count.
    """
    if isinstance(meta, dict):
        doc, where = meta, "the metadata"
    else:
        where = os.fspath(meta)
        try:
            p = Path(meta)
            if not p.is_file():
                raise OSError("no such file" if not p.exists() else "not a regular file")
            if p.stat().st_size > MAX_META_BYTES:
                raise OSError(f"{p.stat().st_size} bytes is too large for Ouster metadata")
            doc = json.loads(p.read_text())
        except (OSError, ValueError, RecursionError) as exc:
            raise ValueError(f"{where}: cannot read it as Ouster metadata ({exc})") from None
        if not isinstance(doc, dict):
            raise ValueError(f"{where}: Ouster metadata is a JSON object")
    alt, azi = _find(doc, "beam_altitude_angles"), _find(doc, "beam_azimuth_angles")
    cols = _find(doc, "columns_per_frame")
    if cols is None and isinstance(_find(doc, "lidar_mode"), str):
        cols = _find(doc, "lidar_mode").split("x")[0]  # "1024x10": columns x Hz
    try:
        alt, azi = np.asarray(alt, np.float64), np.asarray(azi, np.float64)
        cols = int(cols)
        if alt.ndim != 1 or alt.shape != azi.shape or len(alt) < 1 or cols < 1 \
                or not (np.isfinite(alt).all() and np.isfinite(azi).all()):
            raise ValueError
    except (TypeError, ValueError):
        raise ValueError(f"{where}: Ouster metadata needs beam_altitude_angles and "
                         f"beam_azimuth_angles (one per beam) and columns_per_frame or "
                         f"lidar_mode") from None
    origin = float(_find(doc, "lidar_origin_to_beam_origin_mm") or 0.0) / 1000.0
    t = _find(doc, "lidar_to_sensor_transform")
    m = np.eye(4) if t is None else np.asarray(t, np.float64).reshape(4, 4)
    m = m.copy()
    m[:3, 3] /= 1000.0  # millimetres in the metadata
    return {"rows": len(alt), "cols": cols, "elevation_deg": [float(a) for a in alt],
            "azimuth0_deg": 0.0, "azimuth_step_deg": -360.0 / cols,
            "azimuth_row_residual_deg": [float(-a) for a in azi],
            "beam_origin_m": origin, "lidar_to_sensor": m.tolist()}


def pcd_height(path: str | os.PathLike) -> int:
    """The HEIGHT of a ``.pcd`` file's header: 1 for an unorganised cloud (a header line, not a reader).

    Raises
    ------
    OSError, ValueError
        Not readable, or no HEIGHT before DATA in the first 64 kB.
    """
    with open(path, "rb") as f:
        head = f.read(65536)
    for line in head.split(b"\n"):
        words = line.split()
        if words[:1] == [b"HEIGHT"] and len(words) == 2:
            return int(words[1])
        if words[:1] == [b"DATA"]:
            break
    raise ValueError(f"{path}: no HEIGHT line in its .pcd header")
