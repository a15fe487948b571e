"""Meshes back into time: a ROS 2 bag in MCAP storage of ``visualization_msgs/Marker`` messages.

Each mesh is one ``TRIANGLE_LIST`` marker (three points per triangle, in the
camera's optical frame: metres with a `Pinhole` camera from a CameraInfo)
with the depth message's header, so RViz and Foxglove show it in step with
the recording; every marker has the same namespace and id, so each replaces
the one before. The markers are serialised from the meshes' arrays in the
layout of the Humble message definition (`marker_bytes`: no Python object
per point) and `rosbags` writes them, with the definitions the file carries.
"""

from __future__ import annotations

import os
import shutil
import struct
import tempfile
from pathlib import Path

import numpy as np

from .._optional import require
from ..io.files import part_owner
from ..mesh import Mesh

__all__ = ["marker_bytes", "MarkerBag", "MARKER_TYPE", "GREY"]

MARKER_TYPE = "visualization_msgs/msg/Marker"
GREY = (0.8, 0.8, 0.8, 1.0)  # the one colour of a mesh without vertex colours
FEATURE = "writing meshes to an MCAP recording"
_TYPESTORE = None


def typestore():
    """The ROS 2 Humble type store of `rosbags` (made once per process)."""
    global _TYPESTORE
    if _TYPESTORE is None:
        typesys = require("rosbags.typesys", FEATURE)
        _TYPESTORE = typesys.get_typestore(typesys.Stores.ROS2_HUMBLE)
    return _TYPESTORE


def marker_bytes(mesh: Mesh, stamp: int, frame_id: str, *, ns: str = "rangemesh") -> bytes:
    """A mesh as a serialised (CDR) ``visualization_msgs/msg/Marker`` of type ``TRIANGLE_LIST``.

    The bytes are written from the mesh's arrays as they are (no Python
    object per point), in the layout of the Humble definition `rosbags`
    serialises: the same bytes as its ``serialize_cdr`` of the message.

    Parameters
    ----------
    mesh : Mesh
    stamp : int
        The header's stamp, nanoseconds.
    frame_id : str
    ns : str, default 'rangemesh'

    Returns
    -------
    bytes
        Points ``vertices[faces].reshape(-1, 3)``; per-point ``colors``
        (RGBA in [0, 1]) when the mesh has colours, else one grey ``color``.
    """
    faces = np.asarray(mesh.faces).reshape(-1)
    corners = np.asarray(mesh.vertices, np.float64)[faces].astype("<f8", copy=False)
    colors = None
    if mesh.colors is not None and len(faces):
        # per vertex then per corner: the same float32 values as rounding each corner's c / 255.0
        rgba = np.ones((len(mesh.colors), 4), "<f4")
        rgba[:, :3] = np.asarray(mesh.colors) / 255.0
        colors = rgba[faces]
    sec, nsec = divmod(int(stamp), 1_000_000_000)
    header = (sec, nsec, frame_id)
    cdr = _Cdr()
    cdr.header(header)
    cdr.string(ns)
    cdr.pack(4, "<iii", 0, MARKER_TRIANGLE_LIST, MARKER_ADD)  # id, type, action
    cdr.pack(8, "<10d", 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0,  # pose: origin, identity
             1.0, 1.0, 1.0)  # scale: RViz scales the points
    cdr.pack(4, "<4f", *((1.0, 1.0, 1.0, 1.0) if colors is not None else GREY))
    cdr.pack(4, "<iI?", 0, 0, False)  # lifetime (forever), frame_locked
    cdr.sequence(corners, 8)  # points: geometry_msgs/Point, three float64
    cdr.sequence(colors, 4)  # colors: std_msgs/ColorRGBA, four float32
    cdr.string("")  # texture_resource
    cdr.header(header)  # texture: sensor_msgs/CompressedImage with the marker's header,
    cdr.string("")  # no format
    cdr.sequence(None, 1)  # and no data
    cdr.sequence(None, 4)  # uv_coordinates
    cdr.string("")  # text
    cdr.string("")  # mesh_resource
    cdr.string("")  # mesh_file: visualization_msgs/MeshFile, no filename
    cdr.sequence(None, 1)  # and no data
    cdr.pack(1, "<?", False)  # mesh_use_embedded_materials
    return cdr.bytes()


MARKER_TRIANGLE_LIST, MARKER_ADD = 11, 0  # visualization_msgs/Marker's constants


class _Cdr:
    """Little-endian CDR (ROS 2's XCDR1): each primitive aligned to its size from the payload's start."""

    def __init__(self):
        self.parts = [b"\x00\x01\x00\x00"]  # encapsulation: CDR_LE, no options
        self.pos = 0  # payload bytes so far (alignment counts from after the encapsulation)

    def _put(self, data) -> None:
        self.parts.append(data)
        self.pos += len(data)

    def pack(self, align: int, fmt: str, *values) -> None:
        if pad := -self.pos % align:
            self._put(bytes(pad))
        self._put(struct.pack(fmt, *values))

    def string(self, text: str) -> None:
        data = text.encode()
        self.pack(4, "<I", len(data) + 1)  # the length counts the closing NUL
        self._put(data + b"\x00")

    def header(self, header: tuple[int, int, str]) -> None:
        sec, nsec, frame_id = header
        self.pack(4, "<iI", sec, nsec)
        self.string(frame_id)

    def sequence(self, rows: np.ndarray | None, align: int) -> None:
        """A uint32 count, then the rows' bytes aligned to their widest primitive (none: no padding)."""
        n = 0 if rows is None else len(rows)
        self.pack(4, "<I", n)
        if n:
            if pad := -self.pos % align:
                self._put(bytes(pad))
            self._put(memoryview(np.ascontiguousarray(rows)).cast("B"))

    def bytes(self) -> bytes:
        return b"".join(self.parts)


class MarkerBag:
    """An MCAP file of markers on one topic, written atomically (a context manager).

    The ROS 2 bag is written by `rosbags` into a temporary folder beside
    `path`; on success its ``.mcap`` file is renamed to `path` (the bag's
    ``metadata.yaml`` is dropped: ROS 2 tools, Foxglove and `rosbags` read
    the ``.mcap`` alone). On failure nothing is left.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.mcap`` file to write.
    topic : str
        The markers' topic.
    """

    def __init__(self, path: str | os.PathLike, topic: str):
        self.path = Path(path)
        self.topic = topic
        self.count = 0

    def __enter__(self) -> MarkerBag:
        rosbag2 = require("rosbags.rosbag2", FEATURE)
        if not hasattr(rosbag2, "StoragePlugin"):  # rosbags < 0.10 (ouster-sdk 1.0 pins 0.9.23)
            raise ImportError(f"{self.path}: writing MCAP needs rosbags>=0.10, and this "
                              f"environment has an older one (ouster-sdk 1.0 pins "
                              f"rosbags==0.9.23): write a folder of meshes instead (-o FOLDER)")
        folder = self.path.parent if str(self.path.parent) else Path(".")
        if not folder.is_dir():
            raise FileNotFoundError(f"{folder}: folder does not exist")
        if self.path.is_dir():
            raise IsADirectoryError(f"{self.path}: is a folder, not a file to write")
        self._tmp = Path(tempfile.mkdtemp(dir=folder, prefix=f".{self.path.name}.{part_owner()}.",
                                          suffix=".part"))
        try:
            self._writer = rosbag2.Writer(self._tmp / "bag", version=8,
                                          storage_plugin=rosbag2.StoragePlugin.MCAP)
            self._writer.open()
            self._conn = self._writer.add_connection(self.topic, MARKER_TYPE, typestore=typestore())
        except BaseException:
            shutil.rmtree(self._tmp, ignore_errors=True)
            raise
        return self

    def write(self, log_time: int, data: bytes) -> None:
        """Write one serialised marker, received at `log_time` (nanoseconds)."""
        self._writer.write(self._conn, int(log_time), data)
        self.count += 1

    def __exit__(self, kind, exc, tb):
        try:
            if kind is None:
                self._writer.close()
                os.replace(self._tmp / "bag" / "bag.mcap", self.path)
            else:
                self._writer.abort() if hasattr(self._writer, "abort") else None
        finally:
            shutil.rmtree(self._tmp, ignore_errors=True)
