"""Reading a recording: ROS 1 ``.bag`` files, ROS 2 bag folders, ``.db3`` and ``.mcap`` files.

`rosbags` reads them all (no ROS installation). `Recording` lists the image
topics, finds the depth topic, matches each depth message with its camera
(`CameraInfo`) and, when asked, with the nearest frame of a registered colour
topic, and yields `Frame` objects: a message's header and its undecoded
`Payload`, to be decoded and meshed wherever there is a core free.
"""

from __future__ import annotations

import functools
import os
import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._optional import require
from ..camera import Pinhole
from ..camera_files import DISTORTION_MODELS, distortion_rays
from .decode import DEPTH_SCALES, Payload, depth_shape, is_depth, payload_of

__all__ = ["Recording", "Frame", "ImageTopic", "CameraInfo", "is_recording",
           "RECORDING_SUFFIXES", "stamp_text"]

RECORDING_SUFFIXES = (".bag", ".mcap", ".db3")
IMAGE_TYPES = ("sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage")
INFO_TYPE = "sensor_msgs/msg/CameraInfo"
FEATURE = "reading ROS recordings"
# Messages of a depth topic read for its size when the first ones are not images (headers only)
SIZE_PROBES = 16


def is_recording(path: str | os.PathLike) -> bool:
    """Whether `path` names a recording: a ``.bag``/``.mcap``/``.db3`` file or a ROS 2 bag folder."""
    p = Path(path)
    if p.is_dir():
        return (p / "metadata.yaml").is_file()
    return p.suffix.lower() in RECORDING_SUFFIXES


def stamp_text(stamp: int) -> str:
    """A stamp in nanoseconds as ``seconds.nanoseconds`` (``360.815089000``)."""
    sec, ns = divmod(int(stamp), 1_000_000_000)
    return f"{sec}.{ns:09d}"


def _stamp(header) -> int:
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)


@dataclass(frozen=True)
class ImageTopic:
    """An image topic of a recording, described by its first message.

    A depth topic is one by its encoding or format alone; its size is that
    of the first of its first `SIZE_PROBES` messages whose header describes
    an image (a compressedDepth message's PNG header: nothing is decoded).
    When none does, the size is 0 x 0 and `problem` says why.
    """

    topic: str
    msgtype: str
    count: int
    encoding: str
    height: int
    width: int
    depth: bool
    problem: str = ""

    @property
    def depth_scale(self) -> float:
        """Metres per stored value of a depth topic, by its encoding (REP 118)."""
        return DEPTH_SCALES[self.encoding.split(";")[0].strip()]

    def to_dict(self) -> dict:
        """The fields as a dictionary (``rangemesh info --json``)."""
        return {"topic": self.topic, "type": self.msgtype, "count": self.count,
                "encoding": self.encoding, "height": self.height, "width": self.width,
                "depth": self.depth, "problem": self.problem}


@dataclass(frozen=True)
class CameraInfo:
    """What a ``sensor_msgs/CameraInfo`` message says of a camera."""

    topic: str
    stamp: int
    frame_id: str
    k: tuple
    d: tuple
    distortion_model: str
    height: int
    width: int

    @classmethod
    def of(cls, topic: str, msg) -> CameraInfo:
        """From a deserialised message: ROS 1 spells the fields ``K``, ``D``, ROS 2 ``k``, ``d``."""
        k = getattr(msg, "k", None)
        k = getattr(msg, "K", None) if k is None else k
        d = getattr(msg, "d", None)
        d = getattr(msg, "D", None) if d is None else d
        return cls(topic, _stamp(msg.header), str(msg.header.frame_id),
                   tuple(float(v) for v in np.ravel(k)), tuple(float(v) for v in np.ravel(d)),
                   str(msg.distortion_model), int(msg.height), int(msg.width))

    def pinhole(self, depth_scale: float) -> Pinhole:
        """The camera of ``K``: ``fx = K[0], fy = K[4], cx = K[2], cy = K[5]``."""
        if len(self.k) != 9 or not all(np.isfinite(self.k)) or self.k[0] <= 0 or self.k[4] <= 0:
            raise ValueError(f"{self.topic}: the CameraInfo's K {list(self.k)} is no camera "
                             f"matrix (fx and fy must be positive); give --intrinsics")
        return Pinhole(self.k[0], self.k[4], self.k[2], self.k[5], depth_scale=depth_scale)

    def camera(self, depth_scale: float):
        """`pinhole`, or with non-zero ``D`` of a known model the exact per-pixel `Rays`.

        The rays are those of `rangemesh.camera_files.distortion_rays` (each pixel
        centre undistorted); a model it does not know is meshed as the pinhole
        (`Recording.frames` warns).
        """
        pin = self.pinhole(depth_scale)
        if not any(self.d) or self.distortion_model.strip().lower() not in DISTORTION_MODELS:
            return pin
        return _rays(self.k, self.d, self.distortion_model, self.height, self.width,
                     depth_scale, self.topic)


@dataclass(frozen=True)
class Frame:
    """One depth message of a recording with what it is meshed with.

    Attributes
    ----------
    index : int
        Its place in the recording's order (0, 1, ...).
    stamp : int
        The header's stamp, nanoseconds.
    log_time : int
        When the recording received it, nanoseconds.
    frame_id : str
    depth : Payload
    camera : Pinhole, Rays, Orthographic or None
        None when `error` says why there is none.
    color : Payload or None
    error : str
        Why the frame cannot be meshed ("" when it can).
    topic : str
    offsets : (H, W, 3) ndarray or None
        Per-pixel beam-origin offsets added to the vertices (an Ouster scan), metres.
    """

    index: int
    stamp: int
    log_time: int
    frame_id: str
    depth: Payload
    camera: object
    color: Payload | None = None
    error: str = ""
    topic: str = ""
    offsets: np.ndarray | None = None

    @property
    def name(self) -> str:
        """``topic@stamp``, naming the frame in reports."""
        return f"{self.topic}@{stamp_text(self.stamp)}"


@functools.lru_cache(maxsize=8)
def _rays(k, d, model, height, width, depth_scale, topic):
    """A CameraInfo's rays, made once for all the frames of its topic, not once a frame."""
    return distortion_rays(k, d, model, (height, width), depth_scale=depth_scale, where=topic)


def _shared(a: str, b: str) -> int:
    """Leading topic-name components `a` and `b` share."""
    n = 0
    for x, y in zip(a.strip("/").split("/"), b.strip("/").split("/"), strict=False):
        if x != y:
            break
        n += 1
    return n


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


class Recording:
    """An open recording (a context manager).

    Parameters
    ----------
    path : str or os.PathLike
        A ROS 1 ``.bag`` file, a ROS 2 bag folder (``metadata.yaml`` with
        ``.db3`` or ``.mcap`` storage), or a bare ``.db3`` or ``.mcap`` file.

    Raises
    ------
    FileNotFoundError
        No such file or folder.
    ValueError
        Not a recording, or one that cannot be read (truncated, damaged), in one line.
    ImportError
        `rosbags` is not installed (the ``ros`` extra).
    """

    def __init__(self, path: str | os.PathLike):
        self.path = Path(path)
        self._reader = None

    def __enter__(self) -> Recording:
        highlevel = require("rosbags.highlevel", FEATURE)
        typesys = require("rosbags.typesys", FEATURE)
        p = self.path
        if not p.exists():
            raise FileNotFoundError(f"{p}: no such file or folder")
        if not is_recording(p):
            raise ValueError(f"{p}: not a recording (a .bag, .db3 or .mcap file, or a ROS 2 bag "
                             f"folder with metadata.yaml)")
        try:
            reader = highlevel.AnyReader(
                [p], default_typestore=typesys.get_typestore(typesys.Stores.ROS2_HUMBLE))
            reader.open()
        except Exception as exc:  # rosbags raises its own errors, struct's, sqlite's, KeyError...
            raise ValueError(f"{p}: cannot read it as a ROS recording "
                             f"({type(exc).__name__}: {_one_line(exc)})") from None
        self._reader = reader
        self._infos = None
        self._topics = None
        return self

    def __exit__(self, *exc):
        if self._reader is not None:
            self._reader.close()
            self._reader = None

    # -- reading, with errors in one line --------------------------------------------------

    def _messages(self, connections):
        try:
            for conn, log_time, raw in self._reader.messages(connections=connections):
                yield conn, log_time, self._reader.deserialize(raw, conn.msgtype)
        except (ValueError, OSError):
            raise
        except Exception as exc:  # a truncated or damaged file: rosbags' errors, struct's...
            raise ValueError(f"{self.path}: cannot read it to the end "
                             f"({type(exc).__name__}: {_one_line(exc)})") from None

    def _connections(self, topic: str):
        return [c for c in self._reader.connections if c.topic == topic]

    # -- what it holds ----------------------------------------------------------------------

    def image_topics(self) -> list[ImageTopic]:
        """Every image topic, with its encoding and size (`ImageTopic`), by topic name (read once, kept).

        Kept: a looped playback (``rangemesh live --loop``) asks at every pass, and each
        asking reads (and decompresses) each topic's first message.
        """
        if self._topics is None:
            self._topics = self._image_topics()
        return list(self._topics)

    def _image_topics(self) -> list[ImageTopic]:
        out = []
        topics = sorted({c.topic for c in self._reader.connections if c.msgtype in IMAGE_TYPES})
        for topic in topics:
            conns = self._connections(topic)
            count = sum(c.msgcount for c in conns)
            first, size, problem, read = None, (0, 0), "", 0
            for _, _, msg in self._messages(conns):
                pay = payload_of(msg)
                first = first or pay
                read += 1
                if not is_depth(pay):
                    size = (pay.height, pay.width)
                    break
                stamp = stamp_text(_stamp(msg.header))
                try:  # by the header: a compressed frame's PNG is not decoded
                    size = depth_shape(pay, stamp)
                    break
                except ValueError as exc:
                    problem = problem or _one_line(exc).replace(f"{stamp}: ", f"({stamp}): ", 1)
                if read >= SIZE_PROBES:
                    break
            if first is None:
                continue
            if size != (0, 0):
                problem = ""
            elif problem and count == 1:
                problem = f"its one message is not a depth image this reads; that message {problem}"
            elif problem:
                some = f"first {read}" if count > read else str(read)
                problem = f"none of its {some} messages is a depth image this reads; the first {problem}"
            out.append(ImageTopic(topic, conns[0].msgtype.replace("/msg/", "/"), count,
                                  first.encoding, *size, is_depth(first), problem))
        return out

    def depth_topic(self, topic: str | None = None) -> ImageTopic:
        """The depth topic named, or the only one.

        Raises
        ------
        ValueError
            No such topic (the depth topics named), a topic that is not depth
            (its encoding named), none or several depth topics without `topic`.
        """
        topics = self.image_topics()
        depth = [t for t in topics if t.depth]
        names = ", ".join(t.topic for t in depth) or "none"
        if topic is None:
            if len(depth) == 1:
                return depth[0]
            if not depth:
                found = "; ".join(f"{t.topic} ({t.encoding})" for t in topics) or "no image topic"
                raise ValueError(f"{self.path}: no depth topic (16UC1, mono16, 32FC1 or "
                                 f"compressedDepth images); found {found}")
            raise ValueError(f"{self.path}: {len(depth)} depth topics ({names}); choose one "
                             f"with --topic")
        hit = next((t for t in topics if t.topic == topic), None)
        if hit is None:
            what = "an image topic" if any(c.topic == topic for c in self._reader.connections) \
                else "a topic"
            raise ValueError(f"{self.path}: {topic} is not {what} of the recording; its depth "
                             f"topics: {names}")
        if not hit.depth:
            kind = "format" if hit.msgtype.endswith("CompressedImage") else "encoding"
            raise ValueError(f"{self.path}: {topic} has {kind} {hit.encoding!r}, not depth "
                             f"(16UC1, mono16 or 32FC1 Images; 16UC1 or 32FC1 compressedDepth)")
        return hit

    def camera_infos(self) -> list[CameraInfo]:
        """Every CameraInfo message, in the recording's order (read once, kept)."""
        if self._infos is None:
            conns = [c for c in self._reader.connections if c.msgtype == INFO_TYPE]
            self._infos = [CameraInfo.of(c.topic, m) for c, _, m in self._messages(conns)] \
                if conns else []
        return self._infos

    def camera_info(self, topic: str, frame_id: str, stamp: int, shape=None,
                    info_topic: str | None = None) -> CameraInfo | None:
        """The CameraInfo of an image: same frame id when set, the nearest topic, nearest stamp.

        Candidates are the CameraInfo messages on `info_topic` when given;
        else those with the image's frame id, when the image has one and some
        do; else all. Of these, those of the right size (when the CameraInfo
        gives one) on the topic that shares the longest leading part of its
        name with the image topic (``/camera/depth/camera_info`` beside
        ``/camera/depth/image_rect_raw``), and of those the one nearest in time.

        Raises
        ------
        ValueError
            Two CameraInfo topics are equally near the image topic.
        """
        infos = self.camera_infos()
        if info_topic is not None:
            infos = [i for i in infos if i.topic == info_topic]
        elif frame_id and any(i.frame_id == frame_id for i in infos):
            infos = [i for i in infos if i.frame_id == frame_id]
        if shape is not None:
            infos = [i for i in infos if i.height * i.width == 0 or (i.height, i.width) == shape]
        if not infos:
            return None
        best = max(_shared(topic, i.topic) for i in infos)
        near = sorted({i.topic for i in infos if _shared(topic, i.topic) == best})
        if len(near) > 1:
            raise ValueError(f"{self.path}: CameraInfo topics {', '.join(near)} are equally near "
                             f"{topic}; choose one with --camera-info-topic")
        return min((i for i in infos if i.topic == near[0]), key=lambda i: abs(i.stamp - stamp))

    # -- the frames -------------------------------------------------------------------------

    def frames(self, topic: str | None = None, *, color_topic: str | None = None,
               camera=None, camera_info_topic: str | None = None) -> Iterator[Frame]:
        """The depth messages of `topic` in the recording's order, each with its camera.

        Parameters
        ----------
        topic : str, optional
            Default: the only depth topic.
        color_topic : str, optional
            A colour topic registered with the depth: each frame gets the
            colour message nearest in stamp.
        camera : Pinhole, Orthographic, ..., optional
            Used as given for every frame instead of the CameraInfo.
        camera_info_topic : str, optional
            Take the CameraInfo from this topic only.

        Raises
        ------
        ValueError
            The topics cannot be used (see `depth_topic`), no CameraInfo and
            no `camera`, colour and depth of different sizes.
        """
        dt = self.depth_topic(topic)
        if dt.problem:  # said before its camera is looked for: no size to look for it by
            raise ValueError(f"{self.path}: {dt.topic}: {dt.problem}")
        ct = self._color_topic(color_topic, dt) if color_topic is not None else None
        if camera is None:
            shape = (dt.height, dt.width)
            cam_topic = camera_info_topic
            if cam_topic is not None and not any(i.topic == cam_topic for i in self.camera_infos()):
                raise ValueError(f"{self.path}: {cam_topic} holds no CameraInfo message")
            if self.camera_info(dt.topic, "", 0, shape, cam_topic) is None:
                raise ValueError(f"{self.path}: no CameraInfo for {dt.topic} ({dt.width}x"
                                 f"{dt.height}); give the camera (--intrinsics FX,FY,CX,CY, or "
                                 f"--scale for pixels as units)")
            self._warn_distortion(dt.topic, shape, cam_topic)
            if ct is not None:
                self._warn_unregistered(dt.topic, ct.topic, shape, cam_topic)
        return self._frames(dt, ct, camera, camera_info_topic)

    def _color_topic(self, color_topic: str, dt: ImageTopic) -> ImageTopic:
        from .decode import COLOR_ENCODINGS

        hit = next((t for t in self.image_topics() if t.topic == color_topic), None)
        if hit is None:
            raise ValueError(f"{self.path}: {color_topic} is not an image topic of the recording")
        compressed = hit.msgtype.endswith("CompressedImage")
        if not compressed and hit.encoding not in COLOR_ENCODINGS:
            raise ValueError(f"{self.path}: {color_topic} has encoding {hit.encoding!r}, not a "
                             f"colour encoding ({', '.join(COLOR_ENCODINGS)})")
        if not compressed and (hit.height, hit.width) != (dt.height, dt.width):
            raise ValueError(f"{self.path}: colour {color_topic} is {hit.width}x{hit.height} and "
                             f"depth {dt.topic} {dt.width}x{dt.height}; the colour must be "
                             f"registered to the depth (same size, pixel to pixel)")
        return hit

    def _warn_distortion(self, topic, shape, info_topic):
        info = self.camera_info(topic, "", 0, shape, info_topic)
        # known models are meshed with exact per-pixel rays (CameraInfo.camera)
        if info is not None and any(v != 0.0 for v in info.d) \
                and info.distortion_model.strip().lower() not in DISTORTION_MODELS:
            warnings.warn(f"{info.topic}: distortion model {info.distortion_model!r} is none "
                          f"of {', '.join(sorted(DISTORTION_MODELS))}; the depth is meshed as "
                          f"if rectified", stacklevel=3)

    def _warn_unregistered(self, depth_topic, color_topic, shape, info_topic):
        d = self.camera_info(depth_topic, "", 0, shape, info_topic)
        c = self.camera_info(color_topic, "", 0, shape)
        if d is not None and c is not None and c.topic != d.topic \
                and not np.allclose(d.k, c.k, rtol=1e-6):
            warnings.warn(f"{color_topic}: its camera ({c.topic}) has another K than the "
                          f"depth's ({d.topic}): the colour looks unregistered, so vertex "
                          f"colours will be off", stacklevel=3)

    def _frames(self, dt: ImageTopic, ct: ImageTopic | None, camera, info_topic):
        conns = self._connections(dt.topic)
        color_conns = self._connections(ct.topic) if ct is not None else []
        depth_ids = {id(c) for c in conns}
        pending: list[tuple] = []  # depth messages waiting for the colour after them
        last = None  # the latest colour message: (stamp, payload)
        index = 0

        def made(item, color):
            nonlocal index
            frame = self._frame(index, dt.topic, *item, camera, info_topic, color, ct is not None)
            index += 1
            return frame

        for conn, log_time, msg in self._messages(conns + color_conns):
            if id(conn) in depth_ids:
                item = (_stamp(msg.header), log_time, str(msg.header.frame_id), payload_of(msg))
                if ct is None:
                    yield made(item, None)
                else:
                    pending.append(item)
                continue
            color = (_stamp(msg.header), payload_of(msg))
            while pending and pending[0][0] <= color[0]:
                item = pending.pop(0)
                near = color if last is None or \
                    abs(color[0] - item[0]) < abs(last[0] - item[0]) else last
                yield made(item, near[1])
            last = color
        for item in pending:
            yield made(item, None if last is None else last[1])

    def _frame(self, index, topic, stamp, log_time, frame_id, payload, camera, info_topic,
               color, want_color) -> Frame:
        error = ""
        cam = camera
        name = f"{topic}@{stamp_text(stamp)}"
        try:  # not depth, or not an image: said before its camera is looked for (headers only)
            shape = depth_shape(payload, name)
        except ValueError as exc:
            error = _one_line(exc).removeprefix(name + ": ")
        if cam is None and not error:
            try:
                info = self.camera_info(topic, frame_id, stamp, shape, info_topic)
                if info is None:
                    raise ValueError("no CameraInfo of its size and frame id")
                cam = info.camera(DEPTH_SCALES[payload.depth_encoding])
            except ValueError as exc:
                error = _one_line(exc)
        if want_color and color is None and not error:
            error = "no colour message in the recording to go with it"
        return Frame(index, stamp, log_time, frame_id, payload, cam, color, error, topic)
