"""Ouster recordings and sensors through the vendor's SDK (`ouster-sdk`, ``rangemesh[ouster]``).

One reader, `OusterReader`, for every command that takes an Ouster source:
``rangemesh live`` (`rangemesh.live.sources`), ``rangemesh info`` / ``mesh``
(one scan, `read_one_scan`) and ``rangemesh batch`` (every scan, as a recording:
`OusterRecording` gives `rangemesh.recordings.meshing.mesh_recording` its
frames). Each scan is the destaggered RANGE field (millimetres, 0 for no
return) with the SDK's exact per-pixel geometry: a `Rays` camera and the
beam-origin offsets `with_offsets` adds to the vertices.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from types import SimpleNamespace
from typing import NamedTuple

import numpy as np

from .._optional import require
from ..camera import Rays
from .reading import Frame

__all__ = ["OUSTER_SUFFIXES", "OusterReader", "OusterRecording", "OusterScan", "is_ouster",
           "ouster_geometry", "read_one_scan", "with_offsets"]

OUSTER_SUFFIXES = (".pcap", ".osf")
FEATURE = "an Ouster LiDAR or recording"
FRAME_ID = "os_lidar"
TOPIC = "/os_lidar"  # names the frames in reports (``/os_lidar@991.587364520``); markers on /os_lidar/mesh


def is_ouster(path: str | os.PathLike) -> bool:
    """Whether `path` names an Ouster recording (``.pcap`` or ``.osf``)."""
    return Path(path).suffix.lower() in OUSTER_SUFFIXES


class OusterScan(NamedTuple):
    """One scan: its place, the sensor's stamp (ns) and the destaggered range image (mm)."""

    index: int
    stamp: int
    ranges: np.ndarray


def ouster_geometry(info):
    """Each pixel's unit ray and beam-origin offset (metres) from the SDK's XYZ lookup table, destaggered.

    `ouster.sdk.core.XYZLut` maps a range image (millimetres) to points,
    ``range * ray + offset`` (a range of 0, no return, to the origin): the
    points at 1 m and 2 m give both. Both are destaggered, as the range image is.
    """
    core = require("ouster.sdk.core", FEATURE)
    lut = core.XYZLut(info)
    h, w = info.format.pixels_per_column, info.format.columns_per_frame
    one = np.asarray(lut(np.full((h, w), 1000, np.uint32)), np.float64)
    ray = np.asarray(lut(np.full((h, w), 2000, np.uint32)), np.float64) - one
    offset = one - ray
    return core.destagger(info, ray), core.destagger(info, offset)


def with_offsets(mesh, offsets):
    """The mesh with each vertex moved by its pixel's beam-origin offset (Ouster's exact points)."""
    if offsets is None or not len(mesh.vertices):
        return mesh
    r, c = mesh.pixels[:, 0], mesh.pixels[:, 1]
    return dataclasses.replace(mesh, vertices=mesh.vertices + offsets[r, c])


class OusterReader:
    """An Ouster sensor (its hostname) or a ``.pcap``/``.osf`` recording with its metadata.

    Parameters
    ----------
    source : str
        A recording's path, or a sensor's hostname.
    meta : str or os.PathLike, optional
        The metadata JSON (``--meta``); optional when the SDK finds it beside the recording.
    loop : bool, default False
        Replay a recording without end.

    Raises
    ------
    FileNotFoundError
        No such recording or metadata file.
    ValueError
        The SDK cannot open it (its reason in one line).
    ImportError
        `ouster-sdk` is missing: ``pip install "rangemesh[ouster]"``.
    """

    frame_id = FRAME_ID

    def __init__(self, source: str | os.PathLike, *, meta=None, loop: bool = False):
        source = os.fspath(source)
        p = Path(source)
        self.device = not is_ouster(p) and not p.exists()
        if not self.device and not p.is_file():
            raise FileNotFoundError(f"{source}: no such file")
        if meta is not None and not Path(meta).is_file():
            raise FileNotFoundError(f"{meta}: no such metadata file")
        sdk = require("ouster.sdk", FEATURE)
        self._core = require("ouster.sdk.core", FEATURE)
        self._open = lambda: sdk.open_source(source, meta=[os.fspath(meta)] if meta else None)
        try:
            self._src = self._open()
        except Exception as exc:  # the SDK's own errors: no metadata, unreachable sensor, bad file
            text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            hint = "" if meta or self.device else " (give its metadata with --meta FILE.json)"
            raise ValueError(f"{source}: ouster-sdk cannot open it: {text}{hint}") from None
        self.info = self._src.sensor_info[0]
        rays, self.offsets = ouster_geometry(self.info)
        self.camera = Rays(rays, range_scale=0.001)  # RANGE is in millimetres
        fmt = self.info.format
        self.fps = float(fmt.fps)
        self.shape = (int(fmt.pixels_per_column), int(fmt.columns_per_frame))
        # every column of the circle is read: column W-1 is beside column 0 (the seam is closed)
        self.wraps = tuple(fmt.column_window) == (0, fmt.columns_per_frame - 1)
        self.name, self._loop = source, loop

    def __enter__(self) -> OusterReader:
        return self

    def __exit__(self, *exc):
        self.close()

    def scans(self):
        """The scans in order, destaggered (a recording: to its end, or without end with `loop`)."""
        core, index = self._core, 0
        while True:
            for group in self._src:
                scan = group if hasattr(group, "timestamp") else group[0]  # a FrameSet of one sensor
                if scan is None:
                    continue
                rng = core.destagger(self.info, scan.field(core.ChanField.RANGE))
                col = scan.get_first_valid_column()
                stamp = int(scan.timestamp[col]) if 0 <= col < len(scan.timestamp) else 0
                yield OusterScan(index, stamp, np.ascontiguousarray(rng))
                index += 1
            if self.device or not self._loop:
                return
            self._src.close()
            self._src = self._open()

    def close(self):
        """Close the SDK's source."""
        self._src.close()


def read_one_scan(source, *, meta=None, frame: int = 0) -> tuple[OusterScan, OusterReader]:
    """Scan `frame` (0: the first) of an Ouster recording, and its (closed) reader for the geometry.

    Raises
    ------
    ValueError
        A recording of fewer scans (``--frame`` named), or one the SDK cannot open.
    """
    if isinstance(frame, bool) or not isinstance(frame, (int, np.integer)) or frame < 0:
        raise ValueError(f"frame (--frame) must be a whole number >= 0, got {frame!r}")
    seen = 0
    with OusterReader(source, meta=meta) as reader:
        for scan in reader.scans():
            if scan.index == frame:
                return scan, reader
            seen = scan.index + 1
    raise ValueError(f"{source}: --frame {frame} is past the recording's end (it has {seen} "
                     f"scans, counted from 0)")


class OusterRecording:
    """An Ouster recording as `mesh_recording` reads a ROS one: `Frame` objects, one per scan."""

    def __init__(self, path: str | os.PathLike, *, meta=None):
        self._reader = OusterReader(path, meta=meta)
        if self._reader.device:
            self._reader.close()
            raise FileNotFoundError(f"{path}: no such file")
        self.wraps = self._reader.wraps

    def __enter__(self) -> OusterRecording:
        return self

    def __exit__(self, *exc):
        self._reader.close()

    def depth_topic(self, topic: str | None = None):
        """What the batch reports of the frames: their name (``/os_lidar``); the count is not known."""
        _no_ros_options(topic=topic)
        return SimpleNamespace(topic=TOPIC, count=None, depth_scale=0.001)

    def frames(self, topic: str | None = None, *, color_topic: str | None = None, camera=None,
               camera_info_topic: str | None = None):
        """The scans as `Frame` objects: the range image, the SDK's rays and beam-origin offsets."""
        _no_ros_options(topic=topic, color_topic=color_topic, camera=camera,
                        camera_info_topic=camera_info_topic)
        r = self._reader
        return (Frame(s.index, s.stamp, s.stamp, FRAME_ID, s.ranges, r.camera, topic=TOPIC,
                      offsets=r.offsets) for s in r.scans())


def _no_ros_options(**given) -> None:
    """An Ouster recording has one stream and the SDK's geometry: a ROS option is an error."""
    for name, value in given.items():
        if value is not None:
            flag = "--" + name.replace("_", "-")
            raise ValueError(f"{name} ({flag}) goes with a ROS recording; an Ouster recording has "
                             f"one range stream and the SDK's own geometry")
