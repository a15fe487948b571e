"""Meshes back into time: a ROS 2 bag in MCAP storage of ``visualization_msgs/Marker`` messages.

Each mesh is one ``TRIANGLE_LIST`` marker (three points per triangle, in the
camera's optical frame: metres with a `Pinhole` camera from a CameraInfo)
with the depth message's header, so RViz and Foxglove show it in step with
the recording; every marker has the same namespace and id, so each replaces
the one before. `rosbags` serialises and writes them (the Humble message
definitions, which the file carries).
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

from .._optional import require
from ..io import part_owner
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
    ts = typestore()
    t = ts.types
    point, rgba = t["geometry_msgs/msg/Point"], t["std_msgs/msg/ColorRGBA"]
    sec, nsec = divmod(int(stamp), 1_000_000_000)
    header = t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec),
                                      frame_id=frame_id)
    corners = np.asarray(mesh.vertices, np.float64)[mesh.faces].reshape(-1, 3)
    points = [point(x=x, y=y, z=z) for x, y, z in corners.tolist()]
    colors = []
    if mesh.colors is not None and len(corners):
        c = (mesh.colors[mesh.faces].reshape(-1, 3) / 255.0).tolist()
        colors = [rgba(r=r, g=g, b=b, a=1.0) for r, g, b in c]
    marker_t = t[MARKER_TYPE]
    msg = marker_t(
        header=header, ns=ns, id=0, type=marker_t.TRIANGLE_LIST, action=marker_t.ADD,
        pose=t["geometry_msgs/msg/Pose"](
            position=point(x=0.0, y=0.0, z=0.0),
            orientation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)),
        scale=t["geometry_msgs/msg/Vector3"](x=1.0, y=1.0, z=1.0),  # RViz scales the points
        color=rgba(r=1.0, g=1.0, b=1.0, a=1.0) if colors else rgba(*GREY),
        lifetime=t["builtin_interfaces/msg/Duration"](sec=0, nanosec=0),
        frame_locked=False, points=points, colors=colors, texture_resource="",
        texture=t["sensor_msgs/msg/CompressedImage"](header=header, format="", data=np.zeros(0, np.uint8)),
        uv_coordinates=[], text="", mesh_resource="",
        mesh_file=t["visualization_msgs/msg/MeshFile"](filename="", data=np.zeros(0, np.uint8)),
        mesh_use_embedded_materials=False)
    return bytes(ts.serialize_cdr(msg, MARKER_TYPE))


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
