"""Frame sources: a RealSense camera or recording, an Ouster LiDAR or recording, a ROS recording.

Every source yields `LiveFrame` objects (a depth image, its camera, a stamp)
and says whether it is a `device` (frames arrive by themselves, at the
sensor's rate) or a recording (the playback clock of `rangemesh.live.pacing`
releases them). Everything after the frame is shared: a device path differs
from its recording's only in how the SDK is opened.

* ``realsense`` / ``realsense:SERIAL`` / a RealSense SDK ``.bag``: `pyrealsense2`
  (``rangemesh[realsense]``); the depth scale, intrinsics and distortion come
  from the SDK.
* an Ouster hostname, or a ``.pcap``/``.osf`` with ``meta=FILE.json``:
  `ouster-sdk` (``rangemesh[ouster]``); each pixel's ray and beam-origin offset
  come from the SDK's XYZ lookup table (`rangemesh.recordings.ouster`, the
  reader ``info``, ``mesh`` and ``batch`` use too).
* a ROS recording (``.bag``, ``.db3``, ``.mcap``, ROS 2 bag folder), read as
  ``rangemesh batch`` reads it (`rangemesh.recordings`).
"""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np

from .._optional import require
from ..camera import Pinhole
from ..recordings.ouster import FRAME_ID, OUSTER_SUFFIXES, OusterReader, ouster_geometry, with_offsets
from ..timing import now

__all__ = ["LiveFrame", "open_source", "source_kind", "is_realsense_bag", "SOURCE_KINDS",
           # the Ouster reader's helpers live with it (rangemesh.recordings.ouster); kept here by name
           "OUSTER_SUFFIXES", "ouster_geometry", "with_offsets"]

SOURCE_KINDS = ("realsense", "ouster", "ros")
# a RealSense SDK recording starts with these topics (librealsense's rosbag format)
_REALSENSE_TOPICS = ("/file_version", "/device_0/")
_WAIT_MS = 5000  # no frame from the SDK for this long: a device's error, a recording's end
# a looped RealSense recording whose decoded depth frames fit in this many bytes is replayed from
# memory after its first pass (the SDK decodes it once): 256 MiB, 436 frames of 640 x 480 z16
REPLAY_BYTES = 256 * 2**20
# how long one wait for a RealSense frame lasts before the playback's state is read: a camera's
# frames come every 33 ms or less; a recording's end is seen within a few ms, so that a looped run at
# --pace 30 does not hold a frame back while the first pass ends (it dropped one)
_POLL_MS = 50
_POLL_PLAYBACK_MS = 5


class LiveFrame(NamedTuple):
    """One depth frame of a source.

    Attributes
    ----------
    stamp : int
        The sensor's or the recording's stamp, nanoseconds.
    frame_id : str
        The frame the mesh's vertices are in.
    depth : ndarray
        The depth (or range) image as stored; 0 and below is no return.
    camera : Pinhole or Rays
        Lifts the stored values to metres.
    offsets : (H, W, 3) ndarray or None
        Per-pixel beam-origin offsets added to the lifted points (Ouster), metres.
    """

    stamp: int
    frame_id: str
    depth: np.ndarray
    camera: object
    offsets: np.ndarray | None = None


def is_realsense_bag(path: Path) -> bool:
    """Whether a ``.bag`` file is a RealSense SDK recording (its topics, read with `rosbags`).

    Without `rosbags` only the SDK can say: a ``.bag`` is then taken as RealSense.
    """
    try:
        highlevel = require("rosbags.highlevel", "reading ROS recordings")
    except ImportError:
        return True
    try:
        with highlevel.AnyReader([path]) as reader:
            topics = {c.topic for c in reader.connections}
    except Exception:  # not a bag rosbags reads: let the ROS reader say why in one line
        return False
    return "/file_version" in topics and any(t.startswith("/device_0/") for t in topics)


def source_kind(source: str, kind: str | None = None) -> str:
    """Which reader takes `source`: ``'realsense'``, ``'ouster'`` or ``'ros'``.

    ``realsense`` and ``realsense:SERIAL`` are a device; a ``.pcap``/``.osf`` is
    Ouster; a ``.bag`` of the RealSense SDK's topics goes to `pyrealsense2`
    when it is installed, any other recording to the ROS reader; a name that
    is no file and has no recording's suffix is an Ouster sensor's hostname. `kind` overrides.

    Raises
    ------
    ValueError
        An unknown `kind`.
    """
    if kind is not None:
        if kind not in SOURCE_KINDS:
            raise ValueError(f"source kind must be one of {', '.join(SOURCE_KINDS)}, got {kind!r}")
        return kind
    if source == "realsense" or source.startswith("realsense:"):
        return "realsense"
    p = Path(source)
    if p.suffix.lower() in OUSTER_SUFFIXES:
        return "ouster"
    if p.suffix.lower() == ".bag" and p.is_file():
        try:
            import pyrealsense2  # noqa: F401
        except ImportError:
            return "ros"
        return "realsense" if is_realsense_bag(p) else "ros"
    from ..recordings.reading import RECORDING_SUFFIXES

    if p.exists() or p.suffix.lower() in RECORDING_SUFFIXES:
        return "ros"
    return "ouster"  # a hostname (os-122201000998.local) or an address


def open_source(source: str | os.PathLike, *, kind: str | None = None, meta=None,
                topic: str | None = None, loop: bool = False):
    """The source of `source`: an object with ``device`` (bool), ``frames()`` and ``close()``.

    Parameters
    ----------
    source : str or os.PathLike
        See `source_kind`.
    kind : {'realsense', 'ouster', 'ros'}, optional
        Overrides the choice by name.
    meta : str or os.PathLike, optional
        An Ouster recording's metadata JSON (``--meta``).
    topic : str, optional
        A ROS recording's depth topic.
    loop : bool, default False
        Replay a recording without end.

    Raises
    ------
    FileNotFoundError, ValueError
        No such recording, no device, a recording the SDK cannot read.
    ImportError
        The SDK is missing (``pip install "rangemesh[realsense]"`` / ``[ouster]`` / ``[ros]``).
    """
    source = os.fspath(source)
    which = source_kind(source, kind)
    if meta is not None and which != "ouster":
        raise ValueError("meta (--meta) goes with an Ouster recording (.pcap or .osf)")
    if topic is not None and which != "ros":
        raise ValueError("topic (--topic) goes with a ROS recording")
    if which == "realsense":
        return RealSenseSource(source, loop=loop)
    if which == "ouster":
        return OusterSource(source, meta=meta, loop=loop)
    return RosSource(source, topic=topic, loop=loop)


# ------------------------------------------------------------------------- RealSense


def realsense_camera(intrinsics, depth_scale: float):
    """The camera of a `pyrealsense2.intrinsics`: `Pinhole`, or `Rays` for Brown-Conrady distortion.

    Raises
    ------
    ValueError
        A distortion model other than Brown-Conrady with non-zero coefficients.
    """
    from ..camera_files import distortion_rays

    k = (intrinsics.fx, 0.0, intrinsics.ppx, 0.0, intrinsics.fy, intrinsics.ppy, 0.0, 0.0, 1.0)
    d = tuple(float(v) for v in intrinsics.coeffs)
    model = str(intrinsics.model).rsplit(".", 1)[-1]
    if not any(d):
        return Pinhole(intrinsics.fx, intrinsics.fy, intrinsics.ppx, intrinsics.ppy,
                       depth_scale=depth_scale)
    if model != "brown_conrady":  # librealsense's other models are not OpenCV's plumb_bob
        raise ValueError(f"RealSense distortion model {model} with coefficients {list(d)} is not "
                         f"supported (brown_conrady is)")
    return distortion_rays(k, d, "brown_conrady", (intrinsics.height, intrinsics.width),
                           depth_scale=depth_scale, where="RealSense depth stream")


class RealSenseSource:
    """A RealSense device (``realsense``, ``realsense:SERIAL``) or a RealSense SDK ``.bag``.

    A looped recording is played by the SDK once. When its decoded depth
    frames fit in `REPLAY_BYTES` (a short recording: the shared bag's 2
    frames are 1.2 MB) they are kept, the SDK's pipeline is stopped at the
    end of that pass, and later passes hand out the kept frames (read-only
    arrays): they cost no decoding, and measure none of the SDK's. A longer
    recording is played again by the SDK from its start each pass (a new
    pipeline, on the reading thread, under a lock `close` takes too). The
    SDK's own repeat (``repeat_playback``) is not used: librealsense 2.59
    crashes (``ros_reader::enable_stream``) when such a playback is stopped
    as it restarts, and reopens the file each pass (about 4 ms of CPU a
    frame on the 2-frame bag).
    """

    frame_id = "realsense_depth_optical_frame"
    # the SDK reads and decodes a recording on threads of its own (and a short looped one is
    # replayed from memory): the frame workers take its frames without a read-ahead thread
    reads_ahead = True

    def __init__(self, source: str, *, loop: bool = False):
        rs = require("pyrealsense2", "a RealSense camera or .bag")
        self.device = source == "realsense" or source.startswith("realsense:")
        self._rs, self._loop = rs, loop
        self._lock = threading.Lock()  # a pass's restart and `close` never overlap
        self._closed = False
        self._running = False
        cfg = rs.config()
        if self.device:
            serial = source.partition(":")[2]
            found = [d.get_info(rs.camera_info.serial_number) for d in rs.context().query_devices()]
            if not found:
                raise ValueError(f"{source}: no RealSense device is connected")
            if serial and serial not in found:
                raise ValueError(f"{source}: no RealSense device of serial {serial}; connected: "
                                 f"{', '.join(found)}")
            if serial:
                cfg.enable_device(serial)
        else:
            if not Path(source).is_file():
                raise FileNotFoundError(f"{source}: no such file")
            cfg.enable_device_from_file(source, repeat_playback=False)
        cfg.enable_stream(rs.stream.depth)
        self._cfg = cfg
        self._pipe = rs.pipeline()
        try:
            profile = self._start()
        except RuntimeError as exc:
            raise ValueError(f"{source}: the RealSense SDK cannot play it ({exc})") from None
        dev = profile.get_device()
        # the SDK keeps it as a float32 (0.0010000000474974513): the decimal it stands for
        self.depth_scale = float(str(np.float32(dev.first_depth_sensor().get_depth_scale())))
        stream = profile.get_stream(rs.stream.depth).as_video_stream_profile()
        self.intrinsics = stream.get_intrinsics()
        self.fps = float(stream.fps())
        self.camera = realsense_camera(self.intrinsics, self.depth_scale)
        self.name = source

    def _start(self):
        """Start the SDK's pipeline (a recording: from its start); its profile."""
        if not self.device:
            # a recording is made non-real-time before it starts: set after `start`, a call held
            # up on a busy machine let the SDK play its first frames in real time and drop them
            resolved = self._cfg.resolve(self._rs.pipeline_wrapper(self._pipe))
            resolved.get_device().as_playback().set_real_time(False)
        profile = self._pipe.start(self._cfg)
        self._running = True
        self._playback = None if self.device else profile.get_device().as_playback()
        if self._playback is not None:
            self._playback.set_real_time(False)  # the playback clock paces it, not the SDK
        return profile

    def _stop(self):
        """Stop the SDK's pipeline, once."""
        if self._running:
            self._running = False
            try:
                self._pipe.stop()
            except RuntimeError:
                pass

    def _pass(self, count: int | None = None):
        """The SDK's depth frames to the recording's end (a device: without end), or `count` frames.

        A recording has ended when no frame comes and the SDK's playback has
        stopped (its position runs ahead of the frames handed out, so it
        cannot tell); a device that gives no frame for `_WAIT_MS` is an error.
        A pass of a recording whose length is known (`count`: the first
        pass's) ends at its last frame, without that wait.
        """
        rs, waited, seen, n = self._rs, 0, False, 0
        poll = _POLL_MS if self._playback is None else _POLL_PLAYBACK_MS
        while count is None or n < count:
            ok, got = self._pipe.try_wait_for_frames(poll)
            if not ok:
                waited += poll
                stopped = self._playback is not None \
                    and self._playback.current_status() == rs.playback_status.stopped
                if stopped and seen:
                    return
                if waited >= _WAIT_MS:
                    if self.device:
                        raise ValueError(f"{self.name}: no frame from the camera in {_WAIT_MS} ms")
                    return
                continue
            waited = 0
            depth = got.get_depth_frame()
            if not depth:
                continue
            seen = True
            n += 1
            image = np.array(depth.get_data(), dtype=np.uint16, copy=True)
            yield LiveFrame(int(round(depth.get_timestamp() * 1e6)), self.frame_id, image, self.camera)

    def frames(self):
        """The depth frames as they come (a recording: to its end, or without end with `loop`).

        A looped recording's later passes replay the first pass's decoded
        frames when they fit in `REPLAY_BYTES`, else the SDK plays it again.
        """
        if self.device or not self._loop:
            yield from self._pass()
            return
        kept, size, length = [], 0, None
        while True:
            n = 0
            for frame in self._pass(length):  # later passes end at the first pass's length
                n += 1
                if kept is not None:
                    size += frame.depth.nbytes
                    if size <= REPLAY_BYTES:
                        frame.depth.flags.writeable = False  # handed out again: nobody writes it
                        kept.append(frame)
                    else:
                        kept = None  # too long to keep: the SDK plays every pass
                yield frame
            if n == 0:  # no depth frame in the recording: nothing to replay
                return
            length = length or n
            if kept is not None:
                with self._lock:
                    self._stop()  # the SDK's part is done; later passes come from memory
                while True:
                    yield from kept
            self._wait_stopped()
            with self._lock:
                if self._closed:
                    return
                self._stop()
                self._start()

    def _wait_stopped(self):
        """Wait (up to `_WAIT_MS`) for the playback to stop at the recording's end.

        Restarted before, the next pass may give no frame at all.
        """
        stopped, end = self._rs.playback_status.stopped, now() + _WAIT_MS / 1e3
        while self._playback.current_status() != stopped and now() < end:
            time.sleep(0.001)

    def close(self):
        """Stop the SDK's pipeline (after a pass's restart under way, if any)."""
        with self._lock:
            self._closed = True
            self._stop()


# ------------------------------------------------------------------------- Ouster


class OusterSource:
    """An Ouster sensor (its hostname) or a ``.pcap``/``.osf`` recording with its metadata.

    The reader `rangemesh.recordings.ouster.OusterReader` is the one ``info``,
    ``mesh`` and ``batch`` use; this gives its scans as `LiveFrame` objects.
    """

    frame_id = FRAME_ID

    def __init__(self, source: str, *, meta=None, loop: bool = False):
        self._reader = OusterReader(source, meta=meta, loop=loop)
        r = self._reader
        self.device, self.info, self.camera, self.offsets = r.device, r.info, r.camera, r.offsets
        self.fps, self.wraps, self.name = r.fps, r.wraps, r.name

    def frames(self):
        """The scans, destaggered (a recording: to its end, or without end with `loop`)."""
        for scan in self._reader.scans():
            yield LiveFrame(scan.stamp, self.frame_id, scan.ranges, self.camera, self.offsets)

    def close(self):
        """Close the SDK's source."""
        self._reader.close()


# ------------------------------------------------------------------------- ROS


class RosSource:
    """A ROS recording's depth frames, each with its CameraInfo's camera (as ``batch`` reads them)."""

    device = False

    def __init__(self, source: str, *, topic: str | None = None, loop: bool = False):
        from ..recordings import Recording

        self._rec = Recording(source).__enter__()
        try:
            self._rec.frames(topic)  # the topics and the camera checked now, not at the first frame
            self.fps = None
        except BaseException:
            self._rec.__exit__(None, None, None)
            raise
        self.name, self._topic, self._loop = source, topic, loop

    def frames(self):
        """The decoded depth frames; a frame that cannot be meshed raises, naming it."""
        from ..recordings.decode import depth_image

        while True:
            for frame in self._rec.frames(self._topic):
                if frame.error:
                    raise ValueError(f"{frame.name}: {frame.error}")
                depth, _ = depth_image(frame.depth, frame.name)
                yield LiveFrame(frame.stamp, frame.frame_id or "camera_depth_optical_frame", depth,
                                frame.camera)
            if not self._loop:
                return

    def close(self):
        """Close the recording."""
        self._rec.__exit__(None, None, None)
