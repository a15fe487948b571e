"""Unorganised LiDAR clouds to organised range images: `project_scan`.

A spinning LiDAR's cloud as a driver or a data set stores it (KITTI's ``.bin``:
float32 ``x y z intensity``, dropped returns left out) has no rows and
columns. `project_scan` puts each point in the pixel of its beam (row) and
azimuth step (column), keeping the nearest point where two meet, and returns
the range image with its `rangemesh.Spherical` camera, so that
``triangulate(scan.ranges, camera=scan.camera)`` meshes the cloud.

Where the beams come from:

* ``beams=``: a beams file (the layout of `rangemesh.Spherical.from_beams`):
  each point goes to the row of the nearest elevation and the column of its
  azimuth on that row's grid. A cloud the file describes exactly (the RELLIS
  scan's points, within 3 um) gives the file's own range image.
* ``sensor=`` (a Velodyne preset, `SENSORS`) or ``rows=``: the beams are
  found from the cloud. Elevations ``asin(z / r)`` split into `rows` groups
  at their largest gaps (beams lie 0.3-2 degrees apart, a beam's points
  within a few hundredths), each beam's elevation the median of its group.
  The azimuth step is the median step between a beam's neighbouring points
  (``cols`` when given); a beam whose points sit on a grid of that step (an
  Ouster's staggered beams) gets its own azimuth offset, the circular mean
  of its points' phase on the grid (`PHASE_COHERENCE`); others (a Velodyne's
  firing times drift with the motor) take column 0 at azimuth 0.

Columns run clockwise seen from above (azimuth falls along a row, as the
Ouster and RELLIS images have it), so the image is not mirrored and a mesh of
it faces the sensor. Vertices lie on the camera's rays: with found beams, at
most half a step in azimuth and the beam's spread in elevation from the
measured points.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .camera import Spherical, read_beams
from .checks import whole_number
from .cloud_files import CLOUD_SUFFIXES, ouster_head

__all__ = ["Scan", "SENSORS", "project_scan", "read_cloud", "find_beams", "write_beams",
           "CLOUD_SUFFIX", "CLOUD_SUFFIXES"]

CLOUD_SUFFIX = ".bin"

# Velodyne presets: beams and their nominal elevations (degrees, from the sensors' manuals), top
# first. Only the count is used to find the beams (real heads differ from the nominal angles by
# their calibration); the table is the fallback when a beam has no point.
SENSORS = {
    "vlp16": [15.0 - 2.0 * k for k in range(16)],
    "vlp32c": [15.0, 10.333, 7.0, 4.667, 3.333, 2.333, 1.667, 1.333, 1.0, 0.667, 0.333, 0.0,
               -0.333, -0.667, -1.0, -1.333, -1.667, -2.0, -2.333, -2.667, -3.0, -3.333, -3.667,
               -4.0, -4.667, -5.333, -6.148, -7.254, -8.843, -11.31, -15.639, -25.0],
    "hdl32": [10.667 - 4.0 / 3.0 * k for k in range(32)],
    "hdl64": [2.0 - k / 3.0 for k in range(32)] + [-8.833 - 0.5 * k for k in range(32)],
}

# A beam's azimuths lie on a grid of the step when the mean of exp(2 pi i A / step) over its points
# is at least this long (1: every point on the grid; uniform phases: about 1/sqrt(n)).
PHASE_COHERENCE = 0.5


@dataclass(frozen=True, eq=False)
class Scan:
    """An organised range image made from a cloud by `project_scan`.

    Attributes
    ----------
    ranges : (H, W) ndarray of float64
        Distance of each pixel's point from the sensor; 0 where no point fell (no return).
    camera : Spherical
        The pixels' rays (``point = range * ray``).
    beams : dict
        The camera as a beams file (`write_beams`; `rangemesh.Spherical.from_beams` reads it).
    index : (H, W) ndarray of int64
        The cloud row each pixel holds; -1 where none.
    intensity : (H, W) ndarray of float32 or None
        The cloud's fourth column, when it has one (0 where no point fell).
    points : int
        Points with a return (finite, not at the origin).
    collisions : int
        Points left out because a nearer point fell in their pixel.
    """

    ranges: np.ndarray
    camera: Spherical
    beams: dict
    index: np.ndarray
    intensity: np.ndarray | None
    points: int
    collisions: int


def read_cloud(path: str | os.PathLike, *, ring: bool = False):
    """A LiDAR cloud file's points as an (N, 4) float32 array: ``x y z intensity``.

    ``.bin`` (KITTI's float32 records), ``.pcd`` (ASCII or binary, with
    `pypcd4`) or ``.ply`` (`plyfile`); intensity is 0 where the file has none
    (`rangemesh.cloud_files`).

    Parameters
    ----------
    path : str or os.PathLike
    ring : bool, default False
        Also return the file's beam field (``ring``, ``beam``, ``channel``,
        ``laser_id`` or ``line``): ``(points, ring)``, ring None without one.

    Raises
    ------
    ValueError
        A file that cannot be read, with no x, y, z, or whose size is not a whole number of records.
    """
    from .cloud_files import read_cloud_file

    points, beams = read_cloud_file(path)
    return (points, beams) if ring else points


def _returns(points) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The cloud checked: xyz (float64), the kept rows' ids, and the ranges of those rows."""
    arr = np.asarray(points)
    if arr.dtype.kind not in "iuf":
        raise TypeError(f"points must be an array of numbers, got dtype {arr.dtype}")
    if arr.ndim != 2 or arr.shape[1] < 3:
        raise ValueError(f"points must be (N, 3) or (N, 4): x, y, z (, intensity), got shape "
                         f"{arr.shape}")
    xyz = arr[:, :3].astype(np.float64)
    with np.errstate(over="ignore", invalid="ignore"):
        r = np.sqrt(np.sum(xyz * xyz, axis=1))
    keep = np.flatnonzero(np.isfinite(r) & (r > 0))  # (0, 0, 0) is KITTI's no return
    return xyz[keep], keep, r[keep]


def _angles(xyz, r):
    elevation = np.degrees(np.arcsin(np.clip(xyz[:, 2] / r, -1.0, 1.0)))
    azimuth = np.degrees(np.arctan2(xyz[:, 1], xyz[:, 0]))
    return elevation, azimuth


def _ring_groups(ring, keep, rows: int | None):
    """The kept points' ring values as groups 0..K-1 (inverse) and K, checked against `rows`."""
    r = np.asarray(ring)
    if r.ndim != 1 or r.dtype.kind not in "iu" and not (r.dtype.kind == "f" and
                                                        (r == np.round(r)).all()):
        raise ValueError(f"ring must be one whole beam number a point, got dtype {r.dtype} shape "
                         f"{r.shape}")
    uniq, inverse = np.unique(r[keep].astype(np.int64), return_inverse=True)
    if rows is not None and len(uniq) > rows:
        raise ValueError(f"the ring field holds {len(uniq)} beams with a return, more than the "
                         f"{rows} rows of the sensor")
    return inverse, len(uniq)


def _group_elevations(el, inverse, k):
    """The median elevation of each of `k` groups."""
    order = np.argsort(inverse, kind="stable")
    bounds = np.searchsorted(inverse[order], np.arange(k + 1))
    return np.array([np.median(el[order[bounds[g]:bounds[g + 1]]]) for g in range(k)])


def find_beams(points, rows: int, *, cols: int | None = None, ring=None) -> dict:
    """The beams of a spinning LiDAR found from its cloud (the rule in the module's docstring).

    Parameters
    ----------
    points : (N, 3+) array_like
        x, y, z (metres, sensor frame); points at the origin or not finite are left out.
    rows : int
        The sensor's beams.
    cols : int, optional
        Azimuth steps a turn; default: 360 over the median step between a beam's neighbours.
    ring : (N,) array_like of int, optional
        Each point's beam as the driver gives it (``ring``): the beams are these
        groups, ordered by their median elevation (top first), not split at gaps.

    Returns
    -------
    dict
        A beams file's layout (`rangemesh.Spherical.from_beams`).

    Raises
    ------
    ValueError
        Fewer points than beams, or a cloud whose elevations do not split into `rows` beams.
    """
    rows = whole_number("rows", rows, minimum=1)
    xyz, keep, r = _returns(points)
    if len(r) < 2 * rows:
        raise ValueError(f"the cloud has {len(r)} points with a return: too few to find {rows} beams")
    el, az = _angles(xyz, r)
    if ring is not None:
        inverse, k = _ring_groups(ring, keep, rows)
        if k != rows:
            raise ValueError(f"the ring field has {k} beams with a return, not the sensor's {rows}")
        elevation = _group_elevations(el, inverse, k)
        top = np.argsort(-elevation, kind="stable")  # row 0: the highest beam
        rank = np.empty(k, np.int64)
        rank[top] = np.arange(k)
        return _azimuths(rank[inverse], elevation[top], az, rows, cols)
    order = np.argsort(el)
    s = el[order]
    gaps = np.diff(s)
    cuts = np.sort(np.argsort(gaps)[len(gaps) - (rows - 1):]) + 1 if rows > 1 else np.array([], int)
    groups = np.split(np.arange(len(s)), cuts)
    if min(len(g) for g in groups) < 2 or (rows > 1 and gaps[cuts - 1].min() <= 0.0):
        raise ValueError(f"the cloud's elevations do not split into {rows} beams (a beam with "
                         f"fewer than 2 points): is rows={rows} the sensor's?")
    beam_of = np.empty(len(s), np.int64)
    for b, g in enumerate(groups[::-1]):  # row 0: the highest beam
        beam_of[order[g]] = b
    elevation = np.array([np.median(s[g]) for g in groups[::-1]])
    return _azimuths(beam_of, elevation, az, rows, cols)


def _azimuths(beam_of, elevation, az, rows, cols) -> dict:
    """The beams file of beams found: the azimuth step and each beam's offset on its grid."""
    if cols is None:
        steps = []
        for b in range(rows):
            a = np.sort(az[beam_of == b])
            d = np.diff(a)
            d = d[d > 1e-9]
            if len(d):
                steps.append(np.median(d))
        cols = int(round(360.0 / float(np.median(steps))))
    cols = whole_number("cols", cols, minimum=1)
    step = 360.0 / cols
    residual = np.zeros(rows)
    for b in range(rows):
        z = np.exp(2j * np.pi * az[beam_of == b] / step).mean()
        if abs(z) >= PHASE_COHERENCE:  # on a grid: the beam's own offset, within half a step
            residual[b] = np.angle(z) / (2 * np.pi) * step
    return {"rows": rows, "cols": cols, "elevation_deg": [round(float(e), 6) for e in elevation],
            "azimuth0_deg": 0.0, "azimuth_step_deg": -step,
            "azimuth_row_residual_deg": [round(float(x), 6) for x in residual]}


def project_scan(points, *, ring=None, beams=None, sensor: str | os.PathLike | None = None,
                 rows: int | None = None, cols: int | None = None) -> Scan:
    """An organised range image and its spherical camera from an unorganised LiDAR cloud.

    Parameters
    ----------
    points : (N, 3) or (N, 4) array_like
        x, y, z in metres in the sensor frame (x forward, y left, z up), and
        optionally intensity. Points at the origin (KITTI's dropped returns)
        or not finite are no return.
    ring : (N,) array_like of int, optional
        Each point's beam as the driver gives it (`read_cloud(path, ring=True)`):
        a ring's points go to one row, the row nearest their median elevation,
        whatever their own elevation. Alone, the ring field's beams are the rows.
    beams : dict or path, optional
        A beams file (`rangemesh.Spherical.from_beams`'s layout): the rows and columns as it gives them.
    sensor : {'vlp16', 'vlp32c', 'hdl32', 'hdl64'} or path, optional
        A Velodyne head: its beam count; the beams are found from the cloud
        (`find_beams`). Or an Ouster sensor's metadata ``.json``: its beams'
        altitude and azimuth angles and columns (`rangemesh.cloud_files.ouster_head`),
        each point's elevation taken from its beam's origin, as the SDK places
        the points (its sensor frame); vertices lie on the beams' rays from the
        origin, within the beam-origin offsets (about 5 cm on an OS-1) of the points.
    rows : int, optional
        The beam count of another sensor; the beams are found from the cloud.
    cols : int, optional
        Azimuth steps a turn, with `sensor` or `rows` (default: found from the cloud).

    Returns
    -------
    Scan

    Raises
    ------
    ValueError, TypeError
        No way to the beams given, or more than one; an unknown sensor; a
        malformed cloud; a cloud whose beams cannot be found.

    Examples
    --------
    >>> el, az = np.radians([10.0, -10.0]), np.radians(np.arange(0.0, 360.0, 90.0))
    >>> e, a = np.meshgrid(el, az, indexing="ij")
    >>> pts = 5.0 * np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], -1)
    >>> scan = project_scan(pts.reshape(-1, 3), rows=2, cols=4)
    >>> scan.ranges.shape, round(float(scan.ranges.max()), 9), scan.camera.wraps
    ((2, 4), 5.0, True)
    """
    given = [n for n, v in (("beams", beams), ("sensor", sensor), ("rows", rows)) if v is not None]
    if len(given) > 1 or (not given and ring is None):
        raise ValueError("project_scan needs one of beams= (a beams file), sensor= (a preset: "
                         f"{', '.join(SENSORS)}, or an Ouster metadata .json) or rows= (the beam "
                         f"count), or a ring field, got {' and '.join(given) or 'none'}")
    head = None
    if sensor is not None:
        if isinstance(sensor, (str, os.PathLike)) and Path(sensor).suffix.lower() == ".json":
            head = beams = ouster_head(sensor)
            if cols is not None:
                raise ValueError("cols goes with a Velodyne preset or rows=: Ouster metadata "
                                 "gives its own")
        elif sensor not in SENSORS:
            raise ValueError(f"sensor must be one of {tuple(SENSORS)} or an Ouster metadata "
                             f".json, got {sensor!r}")
        else:
            rows = len(SENSORS[sensor])
    if beams is None:
        if rows is None:  # the ring field alone: its beams are the sensor's
            rows = _ring_groups(ring, _returns(points)[1], None)[1]
        beams = find_beams(points, rows, cols=cols, ring=ring)
    elif cols is not None and head is None:
        raise ValueError("cols goes with sensor= or rows=: a beams file gives its own")
    elif not isinstance(beams, dict):
        beams = read_beams(beams)
    camera = Spherical.from_beams(beams)
    xyz, kept, r = _returns(points)
    el, az = _angles(xyz, r)
    if head is not None:  # the elevation each beam measures, from its own origin
        el = _beam_elevation(xyz, head)
    if ring is not None:  # a ring's points share its row: the row nearest their median elevation
        inverse, k = _ring_groups(ring, kept, camera.shape[0])
        ring_row = _nearest_rows(_group_elevations(el, inverse, k), camera.elevation)
        if len(np.unique(ring_row)) < k:
            raise ValueError("two rings of the ring field fall on one row of the beams")
        row = ring_row[inverse]
    else:
        row = _nearest_rows(el, camera.elevation)
    h, w = camera.shape
    az0, step = float(camera.azimuth[0]), float(camera.step)
    col = np.rint((az - az0 - camera.row_azimuth[row]) / step).astype(np.int64) % w
    if not camera.wraps:  # a camera over part of the circle: points beyond its columns are out
        raw = (az - az0 - camera.row_azimuth[row]) / step
        raw = raw - 360.0 / abs(step) * np.floor(raw / (360.0 / abs(step)))
        inside = np.rint(raw) < w
        row, col, r, kept = row[inside], np.rint(raw[inside]).astype(np.int64), r[inside], kept[inside]
    pixel = row * w + col
    order = np.lexsort((r, pixel))  # by pixel, the nearest first
    first = np.ones(len(order), bool)
    first[1:] = pixel[order][1:] != pixel[order][:-1]
    take = order[first]
    ranges = np.zeros(h * w)
    ranges[pixel[take]] = r[take]
    index = np.full(h * w, -1, np.int64)
    index[pixel[take]] = kept[take]
    arr = np.asarray(points)
    intensity = None
    if arr.shape[1] >= 4:
        intensity = np.zeros(h * w, np.float32)
        intensity[pixel[take]] = arr[kept[take], 3]
        intensity = intensity.reshape(h, w)
    return Scan(ranges.reshape(h, w), camera, dict(beams), index.reshape(h, w), intensity,
                points=len(r), collisions=len(r) - len(take))


def _nearest_rows(el, elevation) -> np.ndarray:
    """The row of the nearest beam by elevation (rows strictly monotonic: a sorted search)."""
    h = len(elevation)
    up = elevation[0] > elevation[-1]
    e_sorted = elevation[::-1] if up else elevation
    j = np.clip(np.searchsorted(e_sorted, el), 1, max(h - 1, 1)) if h > 1 else np.zeros(len(el), int)
    if h > 1:
        j = np.where(np.abs(el - e_sorted[j - 1]) <= np.abs(e_sorted[j] - el), j - 1, j)
    return (h - 1 - j) if up else j


def _beam_elevation(xyz, head) -> np.ndarray:
    """An Ouster point's elevation from its beam's origin (degrees).

    Back to the lidar frame, less the beam-origin offset: near the sensor the
    36 mm and 16 mm of an OS-1 are a beam apart.
    """
    m = np.asarray(head["lidar_to_sensor"], np.float64)
    p = (xyz - m[:3, 3]) @ m[:3, :3]  # the inverse of the rigid transform, for row vectors
    rho = np.hypot(p[:, 0], p[:, 1]) - head["beam_origin_m"]
    return np.degrees(np.arctan2(p[:, 2], rho))


def write_beams(path: str | os.PathLike, beams: dict) -> None:
    """Write a beams file (`Scan.beams`, `find_beams`) as JSON, for ``--beams FILE.json``."""
    keys = ("rows", "cols", "elevation_deg", "azimuth0_deg", "azimuth_step_deg",
            "azimuth_row_residual_deg")
    doc = {k: beams[k] for k in keys if k in beams}
    doc["model"] = ("ray(row, col) = (cos e cos A, cos e sin A, sin e) with e = "
                    "elevation_deg[row], A = azimuth0_deg + azimuth_row_residual_deg[row] + col * "
                    "azimuth_step_deg; point = range * ray")
    Path(path).write_text(json.dumps(doc, indent=1) + "\n")
