"""Where a live run's meshes go: a Foxglove WebSocket server, an MCAP file, a folder of mesh files.

The server and the MCAP file are sinks of one `foxglove.Context` (the
``foxglove-sdk``, ``rangemesh[live]``): each frame is logged once, on four
channels, and reaches both.

* ``/rangemesh/mesh``: ``foxglove.SceneUpdate``, the mesh as a
  ``TriangleListPrimitive`` (`rangemesh.live.messages`);
* ``/rangemesh/calibration``: ``foxglove.CameraCalibration`` of a depth
  camera's pinhole (none for a LiDAR or a distorted camera's rays);
* ``/rangemesh/tf``: ``foxglove.FrameTransform`` from ``world`` (x forward,
  z up) to the mesh's frame (a camera's optical frame is turned so);
* ``/rangemesh/stats``: the run's figures (JSON), once a frame.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from .._optional import require
from ..camera import Pinhole
from .messages import OPTICAL_ROTATION, scene_update_bytes

__all__ = ["FoxgloveChannels", "parse_address", "FolderSink", "WORLD", "TOPICS"]

WORLD = "world"
FEATURE = "rangemesh live's Foxglove server and MCAP output"
TOPICS = {"mesh": "/rangemesh/mesh", "calibration": "/rangemesh/calibration",
          "tf": "/rangemesh/tf", "stats": "/rangemesh/stats"}
STATS_SCHEMA = {"type": "object", "properties": {
    k: {"type": "number"} for k in ("fps_in", "fps_out", "frames_in", "frames_out", "dropped",
                                    "latency_ms", "latency_p95_ms")}}


def parse_address(text: str) -> tuple[str, int]:
    """``(host, port)`` of ``--foxglove [HOST:]PORT``; the host defaults to 127.0.0.1.

    Raises
    ------
    ValueError
        No port in 0..65535, naming ``foxglove``.
    """
    host, _, port = str(text).rpartition(":")
    host = host.strip("[]") or "127.0.0.1"
    try:
        number = int(port)
    except ValueError:
        number = -1
    if not 0 <= number <= 65535:
        raise ValueError(f"foxglove must be [HOST:]PORT with a port in 0..65535, got {text!r}")
    return host, number


def _timestamp(m, stamp: int):
    sec, nsec = divmod(int(stamp), 1_000_000_000)
    return m.Timestamp(sec=sec, nsec=nsec)


class FoxgloveChannels:
    """A `foxglove.Context` with the run's channels, and its sinks: a server, an MCAP file.

    Parameters
    ----------
    server : (str, int), optional
        Host and port of the WebSocket server (port 0: one the system picks).
    mcap : str or os.PathLike, optional
        The MCAP file to write.
    overwrite : bool, default False
        Replace an existing MCAP file.
    """

    def __init__(self, server=None, mcap=None, overwrite: bool = False):
        fox = require("foxglove", FEATURE)
        self._m = require("foxglove.messages", FEATURE)
        channels = require("foxglove.channels", FEATURE)
        self.context = fox.Context()
        self.server = self.writer = None
        self.url = None
        self.mcap = None if mcap is None else Path(mcap)
        if self.mcap is not None:
            if self.mcap.exists() and not overwrite:
                raise ValueError(f"{self.mcap}: exists; give --overwrite to replace it")
            self.writer = fox.open_mcap(os.fspath(self.mcap), allow_overwrite=overwrite,
                                        context=self.context)
        try:
            if server is not None:
                host, port = server
                self.server = fox.start_server(name="rangemesh live", host=host, port=port,
                                               context=self.context)
                self.url = f"ws://{host}:{self.server.port}"
            self.scene = fox.Channel(TOPICS["mesh"], schema=self._m.SceneUpdate.get_schema(),
                                     message_encoding="protobuf", context=self.context)
            self.calibration = channels.CameraCalibrationChannel(TOPICS["calibration"],
                                                                 context=self.context)
            self.tf = channels.FrameTransformChannel(TOPICS["tf"], context=self.context)
            self.stats = fox.Channel(TOPICS["stats"], message_encoding="json", context=self.context,
                                     schema=fox.Schema(name="rangemesh.LiveStats",
                                                       encoding="jsonschema",
                                                       data=json.dumps(STATS_SCHEMA).encode()))
        except BaseException:
            self.close()
            raise

    def publish(self, stamp: int, frame_id: str, mesh, shape) -> None:
        """Log one frame's mesh, its camera's calibration and its frame transform."""
        m = self._m
        ts = _timestamp(m, stamp)
        optical = mesh.camera.__class__.__name__ != "Rays" or mesh.camera.z_depth
        rot = OPTICAL_ROTATION if optical else (0.0, 0.0, 0.0, 1.0)
        self.tf.log(m.FrameTransform(timestamp=ts, parent_frame_id=WORLD, child_frame_id=frame_id,
                                     translation=m.Vector3(x=0.0, y=0.0, z=0.0),
                                     rotation=m.Quaternion(x=rot[0], y=rot[1], z=rot[2], w=rot[3])))
        cam = mesh.camera
        if isinstance(cam, Pinhole):
            k = [cam.fx, 0.0, cam.cx, 0.0, cam.fy, cam.cy, 0.0, 0.0, 1.0]
            p = [cam.fx, 0.0, cam.cx, 0.0, 0.0, cam.fy, cam.cy, 0.0, 0.0, 0.0, 1.0, 0.0]
            self.calibration.log(m.CameraCalibration(
                timestamp=ts, frame_id=frame_id, width=int(shape[1]), height=int(shape[0]),
                distortion_model="plumb_bob", D=[0.0] * 5, K=k,
                R=[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0], P=p))
        self.scene.log(scene_update_bytes(mesh.vertices, mesh.faces, stamp, frame_id, mesh.colors))

    def log_stats(self, figures: dict) -> None:
        """The run's figures on the stats channel."""
        self.stats.log({k: v for k, v in figures.items() if v is not None})

    def close(self) -> None:
        """Close the MCAP file (readable from here on) and stop the server."""
        if self.writer is not None:
            self.writer.close()
            self.writer = None
        if self.server is not None:
            self.server.stop()
            self.server = None


class FolderSink:
    """One mesh file per frame, named by its stamp (``360.815089000.ply``), as ``batch`` writes them."""

    def __init__(self, folder: str | os.PathLike, fmt: str = ".ply", overwrite: bool = False,
                 write_options: dict | None = None):
        from ..io import MESH_SUFFIXES

        if fmt not in MESH_SUFFIXES:
            raise ValueError(f"fmt must be one of {MESH_SUFFIXES}, got {fmt!r}")
        self.folder, self.fmt, self.overwrite = Path(folder), fmt, overwrite
        self.write_options = write_options or {}
        self.folder.mkdir(parents=True, exist_ok=True)
        self._seen: dict[str, int] = {}

    def write(self, stamp: int, mesh) -> Path:
        """Write one frame's mesh; a stamp seen before (a looped recording) gets its pass number."""
        from ..io import write_mesh
        from ..recordings.reading import stamp_text

        name = stamp_text(stamp)
        n = self._seen.get(name, 0)
        self._seen[name] = n + 1
        path = self.folder / ((name if n == 0 else f"{name}.{n}") + self.fmt)
        if path.exists() and not self.overwrite:
            raise ValueError(f"{path}: exists; give --overwrite to replace it")
        write_mesh(mesh, path, **self.write_options)
        return path
