"""Recordings for the tests, written with `rosbags`' writers (not rangemesh's code).

ROS 1 ``.bag`` files (the Noetic definitions: CameraInfo fields ``K``, ``D``) and
ROS 2 bag folders in ``.db3`` or ``.mcap`` storage (Humble: ``k``, ``d``).
"""

import struct
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

T0 = 1_700_000_000 * 10**9  # the first frame's stamp, ns
PERIOD = 33_000_000  # between frames, ns
LAG = 4_000_000  # receive time after the stamp, ns
DEPTH_TOPIC = "/camera/depth/image_rect_raw"
INFO_TOPIC = "/camera/depth/camera_info"
COLOR_TOPIC = "/camera/color/image_raw"
FRAME_ID = "camera_depth_optical_frame"
# slambook2 ch7 / TUM fr1 intrinsics (shared/data/README.md)
K_TUM = (520.9, 521.0, 325.1, 249.7)


@dataclass
class Topic:
    """One topic's messages: each an array (or raw bytes for CompressedImage) with its stamp."""

    name: str
    kind: str  # 'image', 'compressed' or 'info'
    encoding: str = ""  # Image encoding, CompressedImage format
    frames: list = field(default_factory=list)
    stamps: list = field(default_factory=list)
    frame_id: str = FRAME_ID
    k: tuple = K_TUM
    d: tuple = (0.0, 0.0, 0.0, 0.0, 0.0)
    size: tuple = (480, 640)


@dataclass
class RawImage:
    """An Image message's fields as given, whatever they describe (a broken size, too little data)."""

    height: int
    width: int
    step: int
    data: bytes


def image_topic(frames, encoding, name=DEPTH_TOPIC, frame_id=FRAME_ID, stamps=None):
    stamps = stamps or [T0 + i * PERIOD for i in range(len(frames))]
    return Topic(name, "image", encoding, list(frames), list(stamps), frame_id)


def info_topic(stamps=(T0,), k=K_TUM, name=INFO_TOPIC, frame_id=FRAME_ID, d=None, size=(480, 640)):
    """CameraInfo messages; k: one (fx, fy, cx, cy) for all, or a list of one per message."""
    return Topic(name, "info", frames=[None] * len(stamps), stamps=list(stamps), frame_id=frame_id,
                 k=k, d=d or (0.0,) * 5, size=size)


def compressed_depth(depth, encoding, quant_a=0.0, quant_b=0.0):
    """A compressedDepth payload by the format's definition: int32 + 2 float32, then a PNG."""
    import imageio.v3 as iio

    png = iio.imwrite("<bytes>", np.asarray(depth, np.uint16), extension=".png", plugin="pillow")
    fmt = f"{encoding}; compressedDepth png"
    return fmt, struct.pack("<iff", 0 if encoding == "32FC1" else -1, quant_a, quant_b) + png


def _time(ts, stamp):
    sec, ns = divmod(stamp, 10**9)
    return ts.types["builtin_interfaces/msg/Time"](sec=sec, nanosec=ns)


def _header(ts, stamp, frame_id, ros1):
    extra = {"seq": 0} if ros1 else {}
    return ts.types["std_msgs/msg/Header"](stamp=_time(ts, stamp), frame_id=frame_id, **extra)


def _message(ts, topic, i, ros1):
    t = ts.types
    header = _header(ts, topic.stamps[i], topic.frame_id, ros1)
    if topic.kind == "info":
        fx, fy, cx, cy = topic.k[i] if isinstance(topic.k, list) else topic.k
        k = np.array([fx, 0, cx, 0, fy, cy, 0, 0, 1], np.float64)
        r = np.eye(3).ravel()
        p = np.array([fx, 0, cx, 0, 0, fy, cy, 0, 0, 0, 1, 0], np.float64)
        names = ("D", "K", "R", "P") if ros1 else ("d", "k", "r", "p")
        roi = t["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0,
                                                    do_rectify=False)
        return t["sensor_msgs/msg/CameraInfo"](
            header=header, height=topic.size[0], width=topic.size[1], distortion_model="plumb_bob",
            **dict(zip(names, (np.array(topic.d, np.float64), k, r, p), strict=True)),
            binning_x=0, binning_y=0, roi=roi)
    if topic.kind == "compressed":
        data = topic.frames[i]
        return t["sensor_msgs/msg/CompressedImage"](header=header, format=topic.encoding,
                                                    data=np.frombuffer(data, np.uint8))
    if isinstance(topic.frames[i], RawImage):
        f = topic.frames[i]
        return t["sensor_msgs/msg/Image"](
            header=header, height=f.height, width=f.width, encoding=topic.encoding, is_bigendian=0,
            step=f.step, data=np.frombuffer(f.data, np.uint8))
    arr = np.ascontiguousarray(topic.frames[i])
    h, w = arr.shape[:2]
    return t["sensor_msgs/msg/Image"](
        header=header, height=h, width=w, encoding=topic.encoding, is_bigendian=0,
        step=arr.nbytes // h, data=np.frombuffer(arr.tobytes(), np.uint8))


def write_bag(path, topics, kind):
    """Write `topics` into a recording at `path`; kind 'ros1', 'db3' or 'mcap'. Returns its path.

    'ros1' writes ``path`` (a .bag file); 'db3' and 'mcap' a ROS 2 bag folder at ``path``.
    """
    from rosbags.typesys import Stores, get_typestore

    path = Path(path)
    ros1 = kind == "ros1"
    ts = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    if ros1:
        from rosbags.rosbag1 import Writer

        writer = Writer(path)
    else:
        from rosbags.rosbag2 import StoragePlugin, Writer

        plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
        writer = Writer(path, version=8, storage_plugin=plugin)
    types = {"image": "sensor_msgs/msg/Image", "compressed": "sensor_msgs/msg/CompressedImage",
             "info": "sensor_msgs/msg/CameraInfo"}
    messages = []
    with writer:
        for topic in topics:
            conn = writer.add_connection(topic.name, types[topic.kind], typestore=ts)
            for i, stamp in enumerate(topic.stamps):
                messages.append((stamp + LAG, len(messages), conn, topic, i))
        for log_time, _, conn, topic, i in sorted(messages, key=lambda m: m[:2]):
            msg = _message(ts, topic, i, ros1)
            data = ts.serialize_ros1(msg, conn.msgtype) if ros1 else ts.serialize_cdr(msg, conn.msgtype)
            writer.write(conn, log_time, data)
    return path


def mcap_file(folder):
    """The .mcap file inside a ROS 2 bag folder written with MCAP storage."""
    (hit,) = Path(folder).glob("*.mcap")
    return hit
