"""ROS recordings in, meshes back in the recording (rangemesh.recordings, `rangemesh batch`).

The recordings are written by `rosbags`' writers from a synthetic RGB-D frame (tests/images.py),
or are the real RealSense bag, and the markers we write are read back by `rosbags`: expected values
come from the arrays the fixtures wrote and from `rangemesh.triangulate` on them.
"""

import csv
import json
import struct
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import rangemesh
import rangemesh.memory
from rangemesh.cli import main
from rangemesh.recordings import Recording, mesh_bag, mesh_recording
from rangemesh.recordings.decode import depth_image

from .images import rgbd_frame
from .pngs import PNG_SIGNATURE, chunk, png_header, zeros_png
from .rosbag_writer import (
    COLOR_TOPIC,
    DEPTH_TOPIC,
    FRAME_ID,
    INFO_TOPIC,
    K_TUM,
    LAG,
    PERIOD,
    T0,
    RawImage,
    Topic,
    compressed_depth,
    image_topic,
    info_topic,
    mcap_file,
    write_bag,
)

KINDS = ("ros1", "db3", "mcap")
N = 300  # vertices per frame: small meshes, quick tests
REALSENSE = "rosbag/librealsense_d435_single_depth_color_640x480.bag"


@pytest.fixture(scope="module")
def frames():
    """Three TUM depth frames in 1/5000 m (a Kinect-like frame, twice with noise) and colour."""
    depth, color = rgbd_frame((480, 640))
    rng = np.random.default_rng(7)
    out = [depth]
    for _ in range(2):
        noisy = depth.astype(np.int32) + rng.integers(-20, 21, depth.shape)
        out.append(np.where(depth > 0, np.clip(noisy, 1, 65535), 0).astype(np.uint16))
    return out, color


def mm(tum):
    """TUM units (1/5000 m) to millimetres, 0 kept (16UC1 by REP 118)."""
    return np.where(tum > 0, np.maximum(np.round(tum / 5.0), 1), 0).astype(np.uint16)


def metres(tum):
    """TUM units to float32 metres, missing depth NaN (32FC1)."""
    return np.where(tum > 0, tum / 5000.0, np.nan).astype(np.float32)


def pinhole(scale):
    return rangemesh.Pinhole(*K_TUM, depth_scale=scale)


@pytest.fixture(scope="module")
def bags(frames, tmp_path_factory):
    """kind -> {encoding: path}: 16UC1 with colour and CameraInfo, 32FC1 with CameraInfo."""
    depth, color = frames
    root = tmp_path_factory.mktemp("bags")
    out = {}
    for kind in KINDS:
        suffix = ".bag" if kind == "ros1" else ""
        out[kind] = {
            "16UC1": write_bag(root / f"mm-{kind}{suffix}",
                               [image_topic([mm(d) for d in depth], "16UC1"),
                                image_topic([color] * len(depth), "rgb8", COLOR_TOPIC,
                                            "camera_color_optical_frame"),
                                info_topic()], kind),
            "32FC1": write_bag(root / f"m-{kind}{suffix}",
                               [image_topic([metres(d) for d in depth], "32FC1"), info_topic()],
                               kind),
        }
    return out


def expected(arrays, scale, **kw):
    return [rangemesh.triangulate(a, camera=pinhole(scale), background=0, vertices=N, **kw)
            for a in arrays]


def same_mesh(a, b):
    np.testing.assert_array_equal(a.faces, b.faces)
    np.testing.assert_array_equal(a.vertices, b.vertices)


def smooth(h=48, w=64):
    """A small smooth 16UC1 depth image (0.7 to 1.3 m in millimetres), no file needed."""
    return (1000 + 300 * np.add.outer(np.sin(np.arange(h) / 5),
                                      np.cos(np.arange(w) / 7))).astype(np.uint16)


def stamp_of(i):
    """The stamp text of frame `i` of a written topic (``seconds.nanoseconds``)."""
    return f"{(T0 + i * PERIOD) // 10**9}.{(T0 + i * PERIOD) % 10**9:09d}"


def compressed_bag(path, payloads, fmt="16UC1; compressedDepth png", size=(48, 64)):
    """A ROS 1 bag of compressedDepth messages given as bytes, with a CameraInfo of `size`."""
    topic = Topic(DEPTH_TOPIC, "compressed", fmt, list(payloads),
                  [T0 + i * PERIOD for i in range(len(payloads))])
    return write_bag(path, [topic, info_topic(size=size)], "ros1")


class Opened:
    """Counts the images Pillow opens (each decode starts with ``PIL.Image.open``)."""

    def __init__(self, monkeypatch):
        import PIL.Image

        self.calls, real = 0, PIL.Image.open

        def spy(*args, **kwargs):
            self.calls += 1
            return real(*args, **kwargs)

        monkeypatch.setattr(PIL.Image, "open", spy)


# ---------------------------------------------------------------- reading and decoding


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("encoding", ["16UC1", "32FC1"])
def test_decoded_depth_is_the_array_written(bags, frames, kind, encoding):
    want = [mm(d) if encoding == "16UC1" else metres(d) for d in frames[0]]
    with Recording(bags[kind][encoding]) as rec:
        got = list(rec.frames(DEPTH_TOPIC))
    assert len(got) == len(want)
    for f, w, i in zip(got, want, range(len(want)), strict=True):
        depth, scale = depth_image(f.depth)
        np.testing.assert_array_equal(depth, w)  # NaN where NaN
        assert depth.dtype == w.dtype
        assert scale == (0.001 if encoding == "16UC1" else 1.0)
        assert f.stamp == T0 + i * PERIOD and f.log_time == f.stamp + LAG
        assert f.frame_id == FRAME_ID
        assert f.camera == pinhole(scale)  # K of the CameraInfo (upper case in ROS 1)


def test_image_payloads_decode_by_their_encoding(rng):
    from rangemesh.recordings.decode import Payload, color_image

    rgb = rng.integers(0, 256, (5, 7, 3), dtype=np.uint8)
    alpha = np.full((5, 7, 1), 9, np.uint8)
    pad = 3  # a row step longer than the row: the padding is dropped
    cases = {"rgb8": rgb, "bgr8": rgb[..., ::-1], "rgba8": np.concatenate([rgb, alpha], 2),
             "bgra8": np.concatenate([rgb[..., ::-1], alpha], 2)}
    for enc, arr in cases.items():
        rows = arr.reshape(5, -1)
        data = np.concatenate([rows, np.zeros((5, pad), np.uint8)], 1).tobytes()
        got = color_image(Payload(False, enc, 5, 7, rows.shape[1] + pad, False, data))
        np.testing.assert_array_equal(got, rgb, err_msg=enc)
    grey = rgb[..., 0]
    np.testing.assert_array_equal(
        color_image(Payload(False, "mono8", 5, 7, 7, False, grey.tobytes())), grey)
    with pytest.raises(ValueError, match="'yuv422'"):
        color_image(Payload(False, "yuv422", 5, 7, 14, False, bytes(70)))
    # big-endian 16-bit depth and float depth
    d = rng.integers(0, 5000, (5, 7)).astype(np.uint16)
    got, scale = depth_image(Payload(False, "16UC1", 5, 7, 14, True, d.astype(">u2").tobytes()))
    np.testing.assert_array_equal(got, d)
    f = rng.random((5, 7)).astype(np.float32)
    got, scale = depth_image(Payload(False, "32FC1", 5, 7, 28, False, f.tobytes()))
    np.testing.assert_array_equal(got, f)
    assert scale == 1.0
    with pytest.raises(ValueError, match="truncated"):
        depth_image(Payload(False, "16UC1", 5, 7, 14, False, d.tobytes()[:-20]))


@pytest.mark.parametrize("kind", KINDS)
def test_mesh_bag_gives_triangulate_s_meshes_with_the_headers(bags, frames, kind):
    want = expected([mm(d) for d in frames[0]], 0.001)
    got = list(mesh_bag(bags[kind]["16UC1"], DEPTH_TOPIC, vertices=N))
    assert [(s, f) for s, f, _ in got] == [(T0 + i * PERIOD, FRAME_ID) for i in range(3)]
    for (_, _, m), w in zip(got, want, strict=True):
        same_mesh(m, w)
        assert m.stats.vertices == N


def test_mesh_bag_takes_triangulate_s_options(bags, frames):
    want = expected([metres(d) for d in frames[0]], 1.0, walls=False)
    got = [m for _, _, m in mesh_bag(bags["mcap"]["32FC1"], vertices=N, walls=False)]
    for m, w in zip(got, want, strict=True):
        same_mesh(m, w)
    with pytest.raises(ValueError, match="tiles"):  # an option of the other method: at the call
        mesh_bag(bags["mcap"]["32FC1"], vertices=N, tiles=3)


def test_a_recording_takes_the_deviation_targets(bags, frames, tmp_path, capsys):
    # mesh_bag, mesh_recording and `batch` on a recording refused max_deviation and
    # mean_deviation as unknown options, though triangulate and `rangemesh mesh` take them
    first = metres(frames[0][0])
    want = rangemesh.triangulate(first, camera=pinhole(1.0), background=0, max_deviation=0.01)
    got = next(iter(mesh_bag(bags["mcap"]["32FC1"], max_deviation=0.01))).mesh
    same_mesh(got, want)
    assert rangemesh.evaluate(got, first, background=0).max_deviation <= 0.01
    with pytest.raises(ValueError, match="max_deviation and vertices exclude each other"):
        mesh_bag(bags["mcap"]["32FC1"], max_deviation=0.01, vertices=N)
    out = tmp_path / "m.mcap"
    code, _, err = _cli(["batch", bags["mcap"]["32FC1"], "-o", out, "--mean-deviation", "0.002",
                         "--workers", 1], capsys)
    assert code == 0, err
    markers = read_markers(out)
    want = [rangemesh.triangulate(metres(d), camera=pinhole(1.0), background=0,
                                  mean_deviation=0.002) for d in frames[0]]
    check_markers(markers, want)


def test_depth_of_zero_and_below_is_no_return_in_a_recording(tmp_path, frames):
    # F16: a 32FC1 frame's negative depths were meshed behind the camera (z < 0), exit 0
    depth = metres(frames[0][0])
    depth[100:160, 200:300] = -1.0  # behind the camera: no depth camera measures it
    depth[300:320, 50:90] = 0.0
    flipped = -np.nan_to_num(metres(frames[0][0]), nan=1.0)  # every depth negative
    path = write_bag(tmp_path / "neg", [image_topic([depth, flipped], "32FC1"), info_topic()],
                     "mcap")
    (_, _, m), (_, _, empty) = mesh_bag(path, vertices=N)
    assert m.vertices[:, 2].min() > 0
    same_mesh(m, rangemesh.triangulate(np.where(depth > 0, depth, np.nan), camera=pinhole(1.0),
                                       background=None, vertices=N))
    assert empty.is_empty and "no valid pixel" in empty.stats.reason


def test_a_bare_mcap_file_reads_as_its_folder(bags, frames):
    folder = bags["mcap"]["32FC1"]
    a = [(s, f, m.faces) for s, f, m in mesh_bag(folder, vertices=N)]
    b = [(s, f, m.faces) for s, f, m in mesh_bag(mcap_file(folder), vertices=N)]
    assert [x[:2] for x in a] == [x[:2] for x in b]
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x[2], y[2])


@pytest.mark.parametrize("kind", ["ros1", "db3"])
def test_compressed_depth_16uc1_is_the_png_s_values(tmp_path, frames, kind):
    arrays = [mm(d) for d in frames[0][:2]]
    payloads = [compressed_depth(a, "16UC1") for a in arrays]
    topic = image_topic([p[1] for p in payloads], payloads[0][0], DEPTH_TOPIC + "/compressedDepth")
    topic.kind = "compressed"
    path = write_bag(tmp_path / ("c.bag" if kind == "ros1" else "c"), [topic, info_topic()], kind)
    with Recording(path) as rec:
        (t,) = [t for t in rec.image_topics() if t.depth]
        assert (t.topic, t.encoding, t.height, t.width, t.count) == \
            (DEPTH_TOPIC + "/compressedDepth", "16UC1; compressedDepth png", 480, 640, 2)
        got = [depth_image(f.depth) for f in rec.frames()]
    for (d, scale), a in zip(got, arrays, strict=True):
        np.testing.assert_array_equal(d, a)
        assert scale == 0.001
    # beside /camera/depth/...: the CameraInfo of /camera/depth/camera_info
    meshes = [m for _, _, m in mesh_bag(path, vertices=N)]
    for m, w in zip(meshes, expected(arrays, 0.001), strict=True):
        same_mesh(m, w)


def test_compressed_depth_32fc1_is_the_quantised_inverse_depth(tmp_path, frames):
    # image_transport_plugins' defaults: quantisation 100, depth_max 10 m
    a = np.float32(100.0 * 101.0)
    b = np.float32(1.0 - a / 10.0)
    depth = metres(frames[0][0])
    with np.errstate(invalid="ignore", divide="ignore"):
        q = np.where(np.isfinite(depth) & (depth < 10), a / depth + b, 0)
    q = q.astype(np.uint16)  # the encoder's cast: truncation
    fmt, data = compressed_depth(q, "32FC1", float(a), float(b))
    topic = image_topic([data], fmt, DEPTH_TOPIC + "/compressedDepth")
    topic.kind = "compressed"
    path = write_bag(tmp_path / "c", [topic, info_topic()], "mcap")
    with Recording(path) as rec:
        (f,) = rec.frames()
    got, scale = depth_image(f.depth)
    assert scale == 1.0 and got.dtype == np.float32
    assert np.array_equal(np.isnan(got), q == 0)
    ok = q > 0
    # depth = A / (q - B), in float32
    np.testing.assert_allclose(got[ok], a / (q[ok].astype(np.float32) - b), rtol=1e-6)
    # and within the quantisation step of the depth written: d^2 / A per unit of q
    step = depth[ok] ** 2 / a
    assert np.all(np.abs(got[ok] - depth[ok]) <= step * 1.01)


def test_camera_info_of_the_frame_id_first(tmp_path, frames):
    arrays = [mm(d) for d in frames[0]]
    topics = [image_topic(arrays, "16UC1"),
              # beside the depth topic, but another frame id: not taken
              info_topic(k=(1.0, 1.0, 1.0, 1.0), frame_id="other"),
              # far from the topic, with the frame id of the depth
              info_topic(name="/elsewhere/camera_info")]
    path = write_bag(tmp_path / "k.bag", topics, "ros1")
    with Recording(path) as rec:
        assert [f.camera for f in rec.frames()] == [pinhole(0.001)] * 3


def test_camera_info_of_the_nearest_stamp(tmp_path, frames):
    arrays = [mm(d) for d in frames[0]]
    k2, k3 = (600.0, 601.0, 320.0, 240.0), (610.0, 611.0, 321.0, 241.0)
    # frames at T0, T0 + P, T0 + 2P; CameraInfo at T0 (k2) and T0 + 1.6P (k3)
    info = info_topic(stamps=[T0, T0 + 16 * PERIOD // 10], k=[k2, k3])
    path = write_bag(tmp_path / "n", [image_topic(arrays, "16UC1"), info], "db3")
    with Recording(path) as rec:
        assert [(f.camera.fx, f.camera.cy) for f in rec.frames()] == \
            [(600.0, 240.0), (610.0, 241.0), (610.0, 241.0)]


def test_camera_info_topics_equally_near_are_refused_or_chosen(tmp_path, frames):
    arrays = [mm(d) for d in frames[0][:1]]
    path = write_bag(tmp_path / "e", [image_topic(arrays, "16UC1"),
                                      info_topic(k=(600.0, 601.0, 320.0, 240.0)),
                                      info_topic(name=INFO_TOPIC + "_b")], "db3")
    with Recording(path) as rec:
        with pytest.raises(ValueError, match="equally near"):
            list(rec.frames())
        (f,) = rec.frames(camera_info_topic=INFO_TOPIC + "_b")
        assert f.camera == pinhole(0.001)


def test_a_distorted_camera_info_meshes_with_its_exact_rays(tmp_path, frames):
    # issue 41: CameraInfo.D is no longer meshed as if rectified
    from rangemesh.camera_files import distortion_rays

    d = (0.1, -0.02, 0.001, 0.0, 0.0)
    path = write_bag(tmp_path / "d.bag", [image_topic([mm(frames[0][0])], "16UC1"),
                                          info_topic(d=d)], "ros1")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ((_, _, got),) = list(mesh_bag(path, vertices=N))
    fx, fy, cx, cy = K_TUM
    cam = distortion_rays([[fx, 0, cx], [0, fy, cy], [0, 0, 1]], d, "plumb_bob", (480, 640),
                          depth_scale=0.001)
    assert isinstance(got.camera, rangemesh.Rays) and got.camera == cam
    same_mesh(got, rangemesh.triangulate(mm(frames[0][0]), camera=cam, background=0, vertices=N))


# ---------------------------------------------------------------- errors in one line


def test_no_camera_info_is_one_line_and_a_camera_mends_it(tmp_path, frames):
    path = write_bag(tmp_path / "x", [image_topic([mm(frames[0][0])], "16UC1")], "mcap")
    with pytest.raises(ValueError, match="no CameraInfo .*--intrinsics"):
        mesh_bag(path)
    (got,) = [m for _, _, m in mesh_bag(path, camera=pinhole(0.001), vertices=N)]
    same_mesh(got, expected([mm(frames[0][0])], 0.001)[0])


def _cli(argv, capsys):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


# F11: a broken size (height 0, width 0, a height the data cannot hold) is no image, said as such
@pytest.mark.parametrize("height, width, step", [(0, 64, 128), (48, 0, 0), (2**31 - 1, 64, 128)])
def test_a_broken_image_size_is_said_before_the_camera_is_looked_for(tmp_path, capsys, height,
                                                                       width, step):
    raw = RawImage(height, width, step, bytes(6144))
    path = write_bag(tmp_path / "s.bag", [image_topic([raw, raw], "16UC1"),
                                          info_topic(size=(48, 64))], "ros1")
    code, _, err = _cli(["batch", path, "-o", tmp_path / "o.mcap", "--workers", 1], capsys)
    assert code == 2 and err.count("\n") == 1, err
    assert "not an image" in err and "CameraInfo" not in err
    code, out, _ = _cli(["info", path], capsys)
    assert f"{width}x{height}" not in out
    assert "none of its 2 messages is a depth image this reads" in out and "not an image" in out


def test_a_frame_that_is_not_an_image_fails_alone(tmp_path):
    # F11: the topic's size comes from a message that is an image; the broken one fails alone
    d = smooth()
    path = write_bag(tmp_path / "s.bag", [image_topic([RawImage(0, 64, 128, bytes(6144)), d, d],
                                                      "16UC1"), info_topic(size=(48, 64))],
                     "ros1")
    res = mesh_recording(path, tmp_path / "o.mcap", workers=1, vertices=N)
    assert [r.status for r in res] == ["failed", "meshed", "meshed"]
    assert res[0].error == ("ValueError: a 16UC1 image of 0x64 pixels with a row step of 128 "
                            "bytes is not an image")


@pytest.fixture
def odd_bags(tmp_path, frames):
    d = mm(frames[0][0])
    return {
        "8UC1": write_bag(tmp_path / "u8", [image_topic([(d % 256).astype(np.uint8)], "8UC1",
                                                        DEPTH_TOPIC), info_topic()], "db3"),
        "two": write_bag(tmp_path / "two.bag", [image_topic([d], "16UC1"),
                                                image_topic([d], "16UC1", "/other/depth"),
                                                info_topic()], "ros1"),
        "small_color": write_bag(tmp_path / "sc.bag", [
            image_topic([d], "16UC1"),
            image_topic([np.zeros((240, 320, 3), np.uint8)], "rgb8", COLOR_TOPIC), info_topic()],
            "ros1"),
    }


def test_bad_inputs_are_one_line(odd_bags, tmp_path):
    with pytest.raises(ValueError, match="'8UC1'") as e:
        mesh_bag(odd_bags["8UC1"], DEPTH_TOPIC)
    assert "\n" not in str(e.value)
    with pytest.raises(ValueError, match="2 depth topics .*/camera/depth/image_rect_raw.*--topic"):
        mesh_bag(odd_bags["two"])
    assert len(list(mesh_bag(odd_bags["two"], "/other/depth", vertices=N))) == 1
    with pytest.raises(ValueError, match="/nope is not a topic"):
        mesh_bag(odd_bags["two"], "/nope")
    with pytest.raises(ValueError, match="registered"):
        mesh_bag(odd_bags["small_color"], color_topic=COLOR_TOPIC)
    with pytest.raises(FileNotFoundError):
        mesh_bag(tmp_path / "absent.bag")


@pytest.mark.parametrize("case, text", [
    ("8UC1", "'8UC1'"),
    ("two", "2 depth topics"),
    ("nope", "/nope is not a topic"),
    ("small_color", "registered"),
    ("truncated", "cannot read"),
])
def test_bad_inputs_through_the_cli(odd_bags, bags, tmp_path, capsys, case, text):
    extra = []
    path = odd_bags.get(case)
    if case == "8UC1":
        extra = ["--topic", DEPTH_TOPIC]
    elif case == "nope":
        path, extra = odd_bags["two"], ["--topic", "/nope"]
    elif case == "small_color":
        extra = ["--color-topic", COLOR_TOPIC]
    elif case == "truncated":
        src = bags["ros1"]["16UC1"]
        path = tmp_path / "cut.bag"
        path.write_bytes(src.read_bytes()[: src.stat().st_size // 2])
    code, out, err = _cli(["batch", path, "-o", tmp_path / "o.mcap", "--workers", "1", *extra],
                          capsys)
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("rangemesh: error: ") and text in err, err
    assert not (tmp_path / "o.mcap").exists()


def test_truncated_mcap_is_one_line(bags, tmp_path):
    src = mcap_file(bags["mcap"]["16UC1"])
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(src.read_bytes()[: src.stat().st_size // 2])
    with pytest.raises(ValueError, match="cut.mcap") as e:
        list(mesh_bag(cut, DEPTH_TOPIC, vertices=N))
    assert "\n" not in str(e.value)


def test_missing_rosbags_names_the_extra(monkeypatch, bags):
    for name in [m for m in sys.modules if m == "rosbags" or m.startswith("rosbags.")]:
        monkeypatch.setitem(sys.modules, name, None)
    monkeypatch.setitem(sys.modules, "rosbags", None)
    monkeypatch.setitem(sys.modules, "rosbags.highlevel", None)
    with pytest.raises(ImportError, match=r'pip install "rangemesh\[ros\]"'):
        mesh_bag(bags["mcap"]["16UC1"])


# ---------------------------------------------------------------- meshes back in the recording


def read_markers(path):
    """(topic, log time, message) of every message of an MCAP file, read by rosbags."""
    from pathlib import Path

    from rosbags.highlevel import AnyReader

    with AnyReader([Path(path)]) as r:
        return [(c.topic, t, r.deserialize(raw, c.msgtype), c.msgtype)
                for c, t, raw in r.messages()]


def check_markers(markers, want, colors=None):
    assert len(markers) == len(want)
    for i, ((topic, t, msg, msgtype), w) in enumerate(zip(markers, want, strict=True)):
        assert msgtype == "visualization_msgs/msg/Marker" and topic == DEPTH_TOPIC + "/mesh"
        stamp = T0 + i * PERIOD
        assert t == stamp + LAG  # written at the depth message's receive time
        assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == divmod(stamp, 10**9)
        assert msg.header.frame_id == FRAME_ID
        assert msg.type == 11 and msg.action == 0  # TRIANGLE_LIST, ADD
        assert len(msg.points) == 3 * len(w.faces)
        pts = np.array([[p.x, p.y, p.z] for p in msg.points])
        np.testing.assert_array_equal(pts, w.vertices[w.faces].reshape(-1, 3))
        if colors is None:
            assert msg.colors == []
            assert msg.color.a == 1.0
        else:
            got = np.array([[c.r, c.g, c.b, c.a] for c in msg.colors])
            rgb = w.with_colors(colors).colors[w.faces].reshape(-1, 3)
            np.testing.assert_allclose(got[:, :3] * 255.0, rgb, atol=1e-9)
            assert (got[:, 3] == 1.0).all()


@pytest.mark.parametrize("kind", KINDS)
def test_batch_writes_markers_read_back_by_rosbags(bags, frames, tmp_path, kind):
    depth, color = frames
    out = tmp_path / "meshes.mcap"
    res = mesh_recording(bags[kind]["16UC1"], out, DEPTH_TOPIC, color_topic=COLOR_TOPIC,
                         workers=1, vertices=N)
    assert [r.status for r in res] == ["meshed"] * 3
    check_markers(read_markers(out), expected([mm(d) for d in depth], 0.001), colors=color)
    doc = json.loads((tmp_path / "meshes.rangemesh-batch.json").read_text())
    assert doc["summary"]["meshed"] == 3
    assert [r["input"] for r in doc["results"]] == \
        [f"{DEPTH_TOPIC}@{(T0 + i * PERIOD) // 10**9}.{(T0 + i * PERIOD) % 10**9:09d}"
         for i in range(3)]
    with pytest.raises(ValueError, match="exists"):  # never replaced silently
        mesh_recording(bags[kind]["16UC1"], out, workers=1, vertices=N)


def test_an_mcap_output_removes_what_killed_runs_left_beside_it(tmp_path):
    # F10: a killed batch's hidden partial bag (and report) of a process that is gone is removed
    from rangemesh.io.files import part_owner

    path = write_bag(tmp_path / "s.bag", [image_topic([smooth()], "16UC1"),
                                          info_topic(size=(48, 64))], "ros1")
    gone = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True).stdout.strip()
    host = part_owner().rsplit(".", 1)[0]
    dead = tmp_path / f".o.mcap.{host}.{gone}.k1ll3d00.part"
    (dead / "bag").mkdir(parents=True)
    (dead / "bag" / "bag.mcap").write_bytes(b"half a bag")
    dead_report = tmp_path / f".o.rangemesh-batch.csv.{host}.{gone}.k1ll3d01.part.csv"
    dead_report.write_text("half a report")
    kept = [tmp_path / f".o.mcap.{part_owner()}.runn1ng0.part",  # a run still going (this one)
            tmp_path / f".p.mcap.{host}.{gone}.k1ll3d02.part",  # another output's
            tmp_path / ".o.mcap.mine.part"]  # not tagged by a writer: not surely a leftover
    for k in kept:
        k.mkdir()
    res = mesh_recording(path, tmp_path / "o.mcap", workers=1, vertices=N)
    assert [r.status for r in res] == ["meshed"]
    assert not dead.exists() and not dead_report.exists()
    assert all(k.is_dir() for k in kept)
    assert sorted(p.name for p in tmp_path.iterdir() if not p.name.startswith(".")) == \
        ["o.mcap", "o.rangemesh-batch.csv", "o.rangemesh-batch.json", "s.bag"]


def test_the_cli_writes_markers_without_colour(bags, frames, tmp_path, capsys):
    out = tmp_path / "m.mcap"
    code, _, err = _cli(["batch", bags["db3"]["32FC1"], "-o", out, "--vertices", N, "--workers",
                         1], capsys)
    assert code == 0, err
    assert "meshed 3, skipped 0 (already there), failed 0 of 3" in err
    check_markers(read_markers(out), expected([metres(d) for d in frames[0]], 1.0))


def test_a_bad_frame_is_reported_and_the_rest_go_on(tmp_path, frames):
    arrays = [mm(frames[0][0]), np.zeros((480, 640), np.uint16), mm(frames[0][1])]
    path = write_bag(tmp_path / "b.bag", [image_topic(arrays, "16UC1"), info_topic()], "ros1")
    out = tmp_path / "b.mcap"
    res = mesh_recording(path, out, workers=1, vertices=N)
    assert [r.status for r in res] == ["meshed", "failed", "meshed"]
    assert res[1].error.startswith("ValueError: nothing to mesh") and "\n" not in res[1].error
    markers = read_markers(out)
    assert [m[2].header.stamp.nanosec for m in markers] == \
        [(T0 + i * PERIOD) % 10**9 for i in (0, 2)]


_HEAD = struct.pack("<iff", -1, 0.0, 0.0)  # a 16UC1 compressedDepth message's 12-byte header


# F3: a damaged compressedDepth frame, the first one too, fails alone; the topic is depth by its format
@pytest.mark.parametrize("damage, says", [
    ("cut", "the PNG inside the message cannot be decoded (the PNG header is cut short"),
    ("junk", "the PNG inside the message cannot be decoded"),
    ("idat", "the PNG inside the message cannot be decoded"),
    ("8-bit", "the PNG of compressedDepth must be 16-bit grey, got 8-bit grey"),
    ("rgb", "the PNG of compressedDepth must be 16-bit grey, got 16-bit RGB"),
    ("empty", "a compressedDepth message is a 12-byte header and a PNG; this one (0 bytes) is not"),
])
def test_a_damaged_compressed_frame_fails_alone_and_the_others_mesh(tmp_path, damage, says):
    d = smooth()
    _, good = compressed_depth(d, "16UC1")
    bad = {"cut": good[:40],
           "junk": _HEAD + PNG_SIGNATURE + bytes(range(60)),
           "idat": _HEAD + png_header(48, 64) + chunk(b"IDAT", b"not deflate data")
           + chunk(b"IEND", b""),
           "8-bit": _HEAD + zeros_png(48, 64, bit_depth=8),
           "rgb": _HEAD + zeros_png(48, 64, color_type=2),
           "empty": b""}[damage]
    path = compressed_bag(tmp_path / "b.bag", [bad, good, good])
    out = tmp_path / "b.mcap"
    res = mesh_recording(path, out, workers=1, vertices=N)
    assert [r.status for r in res] == ["failed", "meshed", "meshed"]
    assert res[0].input == f"{DEPTH_TOPIC}@{stamp_of(0)}"
    assert res[0].error.startswith(f"ValueError: {says}") and "\n" not in res[0].error
    (want,) = expected([d], 0.001)
    markers = read_markers(out)
    assert [(m[2].header.stamp.sec, m[2].header.stamp.nanosec) for m in markers] == \
        [divmod(T0 + i * PERIOD, 10**9) for i in (1, 2)]
    for m in markers:
        pts = np.array([[p.x, p.y, p.z] for p in m[2].points])
        np.testing.assert_array_equal(pts, want.vertices[want.faces].reshape(-1, 3))


def test_mesh_bag_skips_a_damaged_frame_when_asked_and_stops_at_it_by_default(tmp_path):
    # a generator that raised cannot go on: errors='skip' warns, names the frame and meshes the rest
    from rangemesh.recordings import SkippedFrame

    d = smooth()
    _, good = compressed_depth(d, "16UC1")
    path = compressed_bag(tmp_path / "b.bag", [good, good[:40], good])
    (want,) = expected([d], 0.001)
    with pytest.warns(SkippedFrame, match=rf"{DEPTH_TOPIC}@{stamp_of(1)}.*cannot be decoded.*skipped"):
        got = list(mesh_bag(path, vertices=N, errors="skip"))
    assert [stamp for stamp, _, _ in got] == [T0, T0 + 2 * PERIOD]
    for _, _, mesh in got:
        np.testing.assert_array_equal(mesh.vertices, want.vertices)
    frames = mesh_bag(path, vertices=N)
    assert next(frames).stamp == T0
    with pytest.raises(ValueError, match=rf"{DEPTH_TOPIC}@{stamp_of(1)}"):
        next(frames)
    with pytest.raises(ValueError, match="errors must be 'raise' or 'skip'"):
        mesh_bag(path, vertices=N, errors="ignore")


def test_mesh_bag_leaves_the_callers_warnings_alone_between_frames(tmp_path):
    import warnings

    _, good = compressed_depth(smooth(), "16UC1")
    path = compressed_bag(tmp_path / "b.bag", [good, good])
    before = list(warnings.filters)
    frames = mesh_bag(path, vertices=N)
    next(frames)
    silence = ("ignore", None, UserWarning, None, 0)  # what the generator silences frames with
    # (imported libraries may add filters of their own on the first frame: those are not ours)
    assert warnings.filters.count(silence) == before.count(silence)
    frames.close()


def test_the_cli_names_the_damaged_compressed_frame_and_meshes_the_rest(tmp_path, capsys):
    # F3: through the command, with and without --topic, and what info says of the topic
    _, good = compressed_depth(smooth(), "16UC1")
    path = compressed_bag(tmp_path / "b.bag", [good[:40], good, good])
    for i, extra in enumerate(([], ["--topic", DEPTH_TOPIC])):
        code, _, err = _cli(["batch", path, "-o", tmp_path / f"o{i}.mcap", "--workers", 1,
                             "--vertices", N, *extra], capsys)
        assert code == 1, err
        assert f"failed: {DEPTH_TOPIC}@{stamp_of(0)}: ValueError: the PNG inside the message " \
            f"cannot be decoded" in err
        assert "meshed 2, skipped 0 (already there), failed 1 of 3" in err
    code, out, _ = _cli(["info", path], capsys)
    assert code == 0
    assert f"{DEPTH_TOPIC}: 64x48 16UC1; compressedDepth png, 3 messages; camera {INFO_TOPIC}" in out


def test_rvl_compressed_depth_is_refused_with_its_own_reason(tmp_path, capsys):
    # F3: RVL is depth by its format, and not read: its own message, never "not depth"
    path = compressed_bag(tmp_path / "r.bag", [_HEAD + bytes(100)] * 2,
                          fmt="16UC1; compressedDepth rvl")
    for extra in ([], ["--topic", DEPTH_TOPIC]):
        code, _, err = _cli(["batch", path, "-o", tmp_path / "o.mcap", "--workers", 1, *extra],
                            capsys)
        assert code == 2 and err.count("\n") == 1, err
        assert "(RVL) is not supported; record the topic as PNG compressedDepth or raw" in err
        assert "not depth" not in err and "no depth topic" not in err


def test_a_frame_is_checked_by_its_png_header_before_it_is_decoded(tmp_path, monkeypatch):
    # F4: the size from the PNG header, against the memory check and the CameraInfo's size
    import rangemesh.pipeline

    _, good = compressed_depth(smooth(), "16UC1")
    _, other = compressed_depth(smooth(60, 80), "16UC1")
    path = compressed_bag(tmp_path / "m.bag", [good, other])
    opened = Opened(monkeypatch)
    res = mesh_recording(path, tmp_path / "m.mcap", workers=1, vertices=N)
    # 80x60 has no CameraInfo (48x64 only): refused undecoded, as a raw Image of that size is
    assert [r.status for r in res] == ["meshed", "failed"]
    assert res[1].error == "ValueError: no CameraInfo of its size and frame id"
    assert opened.calls == 1
    # refine with N vertices needs 48 * 64 * 32 + 300 * 700 = 308,304 bytes: 100,000 are too few
    monkeypatch.setattr(rangemesh.memory, "available_memory", lambda: 100_000)
    res = mesh_recording(path, tmp_path / "n.mcap", workers=1, vertices=N)
    assert res[0].status == "failed"
    assert res[0].error.startswith("MemoryError: a 48x64 image needs about 0.3 MiB of memory")
    assert opened.calls == 1  # nothing more decoded


def test_folder_output_one_file_per_frame_named_by_stamp(bags, frames, tmp_path, capsys, open3d):
    out = tmp_path / "meshes"
    code, _, err = _cli(["batch", bags["ros1"]["16UC1"], "-o", out, "--vertices", N,
                         "--workers", 1, "--color-topic", COLOR_TOPIC], capsys)
    assert code == 0, err
    want = expected([mm(d) for d in frames[0]], 0.001)
    names = [f"{(T0 + i * PERIOD) // 10**9}.{(T0 + i * PERIOD) % 10**9:09d}.ply" for i in range(3)]
    assert sorted(p.name for p in out.glob("*.ply")) == names
    for name, w in zip(names, want, strict=True):
        o3 = open3d.io.read_triangle_mesh(str(out / name))
        np.testing.assert_array_equal(np.asarray(o3.triangles), w.faces)
        np.testing.assert_allclose(np.asarray(o3.vertices), w.vertices, rtol=1e-6, atol=1e-9)
        rgb = w.with_colors(frames[1]).colors
        np.testing.assert_allclose(np.asarray(o3.vertex_colors) * 255, rgb, atol=1e-6)
    # a second run skips what is there and loses nothing: the rows keep each mesh's figures
    code, _, err = _cli(["batch", bags["ros1"]["16UC1"], "-o", out, "--vertices", N,
                         "--workers", 1, "--color-topic", COLOR_TOPIC], capsys)
    assert code == 0 and "skipped 3 (already there)" in err, err
    with open(out / "rangemesh-batch.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["status"] for r in rows] == ["meshed"] * 3
    assert [int(r["vertices"]) for r in rows] == [len(w.vertices) for w in want]
    # a run with other options is refused in one line that names --overwrite (exit status 2)
    code, _, err = _cli(["batch", bags["ros1"]["16UC1"], "-o", out, "--vertices", 2 * N,
                         "--workers", 1, "--color-topic", COLOR_TOPIC], capsys)
    assert code == 2 and "other options" in err and "--overwrite" in err, err
    assert sorted(p.name for p in out.glob("*.ply")) == names


def test_info_lists_the_depth_topics(odd_bags, bags, capsys):
    code, out, _ = _cli(["info", odd_bags["two"]], capsys)
    assert code == 0
    assert f"{DEPTH_TOPIC}: 640x480 16UC1, 1 messages; camera {INFO_TOPIC}" in out
    assert "/other/depth: 640x480 16UC1, 1 messages" in out
    code, out, _ = _cli(["info", bags["mcap"]["16UC1"], "--json"], capsys)
    doc = json.loads(out)
    (d,) = doc["depth_topics"]
    assert (d["topic"], d["width"], d["height"], d["encoding"], d["count"]) == \
        (DEPTH_TOPIC, 640, 480, "16UC1", 3)
    assert (d["fx"], d["fy"], d["cx"], d["cy"]) == K_TUM
    assert [t["topic"] for t in doc["other_image_topics"]] == [COLOR_TOPIC]


def test_info_reads_a_compressed_topic_s_size_from_the_png_header(tmp_path, capsys, monkeypatch):
    # F4: info decodes nothing; a 3000 x 4000 frame of 24 MB of rows is 25 KB of PNG
    path = compressed_bag(tmp_path / "big.bag", [_HEAD + zeros_png(3000, 4000)], size=(3000, 4000))
    opened = Opened(monkeypatch)
    code, out, _ = _cli(["info", path], capsys)
    assert code == 0
    assert f"{DEPTH_TOPIC}: 4000x3000 16UC1; compressedDepth png, 1 messages; camera " \
        f"{INFO_TOPIC}" in out
    assert opened.calls == 0


@pytest.mark.slow
def test_dask_workers_write_what_one_process_writes(bags, tmp_path):
    a, b = tmp_path / "a.mcap", tmp_path / "b.mcap"
    mesh_recording(bags["mcap"]["16UC1"], a, color_topic=COLOR_TOPIC, workers=1, vertices=N)
    res = mesh_recording(bags["mcap"]["16UC1"], b, color_topic=COLOR_TOPIC, workers=2,
                         vertices=N)
    assert [r.status for r in res] == ["meshed"] * 3
    ma, mb = read_markers(a), read_markers(b)
    assert [(t, m.header.stamp.nanosec, len(m.points)) for _, t, m, _ in ma] == \
        [(t, m.header.stamp.nanosec, len(m.points)) for _, t, m, _ in mb]
    for (_, _, x, _), (_, _, y, _) in zip(ma, mb, strict=True):
        assert [(p.x, p.y, p.z) for p in x.points] == [(p.x, p.y, p.z) for p in y.points]
        assert [(c.r, c.g, c.b, c.a) for c in x.colors] == [(c.r, c.g, c.b, c.a) for c in y.colors]
        assert len(x.colors) == len(x.points)


# ---------------------------------------------------------------- the real RealSense recording


def test_the_realsense_recording(shared_data, tmp_path):
    from rosbags.highlevel import AnyReader

    path = shared_data / REALSENSE
    with AnyReader([path]) as r:  # the reference: rosbags' own decoding of the messages
        conns = [c for c in r.connections if c.topic.endswith("Depth_0/image/data")]
        raw = [r.deserialize(d, c.msgtype) for c, _, d in r.messages(connections=conns)]
    ref = [np.frombuffer(m.data.tobytes(), "<u2").reshape(480, 640) for m in raw]
    got = list(mesh_bag(path, vertices=N))
    assert [(s, f) for s, f, _ in got] == [(360_815_089_000, "0"), (360_981_765_000, "0")]
    # README: fx = fy = 390.43145751953125, cx = 331.38787841796875, cy = 242.18734741210938
    cam = rangemesh.Pinhole(390.43145751953125, 390.43145751953125, 331.38787841796875,
                            242.18734741210938, depth_scale=0.001)
    for (_, _, m), d in zip(got, ref, strict=True):
        assert m.camera == cam
        same_mesh(m, rangemesh.triangulate(d, camera=cam, background=0, vertices=N))
        z = m.vertices[:, 2]
        assert 0.3 < z.min() and z.max() < 3.3  # valid depth 341 .. 3182 mm
    out = tmp_path / "rs.mcap"
    mesh_recording(path, out, workers=1, vertices=N)
    markers = read_markers(out)
    assert [(m.header.frame_id, m.header.stamp.sec, m.header.stamp.nanosec)
            for _, _, m, _ in markers] == [("0", 360, 815_089_000), ("0", 360, 981_765_000)]
    assert markers[0][0] == "/device_0/sensor_0/Depth_0/image/data/mesh"


def test_the_realsense_colour_is_said_to_look_unregistered(shared_data):
    with pytest.warns(UserWarning, match="unregistered"):
        mesh_bag(shared_data / REALSENSE, color_topic="/device_0/sensor_1/Color_0/image/data")


def test_compressed_colour_topic_gives_the_png_s_colours(tmp_path, frames):
    import imageio.v3 as iio

    depth, color = frames
    png = iio.imwrite("<bytes>", color, extension=".png", plugin="pillow")
    ctopic = image_topic([png], "rgb8; png compressed rgb8", COLOR_TOPIC + "/compressed")
    ctopic.kind = "compressed"
    path = write_bag(tmp_path / "cc", [image_topic([mm(depth[0])], "16UC1"), ctopic,
                                       info_topic()], "db3")
    (got,) = [m for _, _, m in mesh_bag(path, color_topic=COLOR_TOPIC + "/compressed",
                                        vertices=N)]
    want = expected([mm(depth[0])], 0.001)[0]
    np.testing.assert_array_equal(got.colors, color[want.pixels[:, 0], want.pixels[:, 1]])


def test_an_output_never_replaces_the_recording(tmp_path, frames, capsys):
    """`-o` naming the recording itself, or a file or folder inside a bag folder, is refused
    before anything is written; the recording stays byte for byte."""
    import shutil

    folder = write_bag(tmp_path / "rec", [image_topic([mm(frames[0][0])], "16UC1"), info_topic()],
                       "mcap")
    bare = tmp_path / "bare.mcap"
    shutil.copy(mcap_file(folder), bare)
    before = {p: p.read_bytes() for p in [bare, *Path(folder).iterdir()]}
    for rec, out in [(bare, bare), (folder, Path(folder) / "x.mcap"),
                     (folder, mcap_file(folder)), (folder, Path(folder))]:
        code, _, err = _cli(["batch", rec, "-o", out, "--workers", 1, "--overwrite"], capsys)
        assert code == 2 and "must not be the recording" in err and err.count("\n") == 1, err
    assert {p: p.read_bytes() for p in [bare, *Path(folder).iterdir()]} == before


# ---------------------------------------------------------------- the markers' bytes


def marker_by_rosbags(mesh, stamp, frame_id, ns="rangemesh"):
    """The reference: the Marker built as rosbags message objects (a Point per corner) and
    serialised by rosbags' own ``serialize_cdr`` -- what `marker_bytes` gave before its fast path."""
    from rangemesh.recordings.writing import GREY, MARKER_TYPE, typestore

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
        scale=t["geometry_msgs/msg/Vector3"](x=1.0, y=1.0, z=1.0),
        color=rgba(r=1.0, g=1.0, b=1.0, a=1.0) if colors else rgba(*GREY),
        lifetime=t["builtin_interfaces/msg/Duration"](sec=0, nanosec=0),
        frame_locked=False, points=points, colors=colors, texture_resource="",
        texture=t["sensor_msgs/msg/CompressedImage"](header=header, format="", data=np.zeros(0, np.uint8)),
        uv_coordinates=[], text="", mesh_resource="",
        mesh_file=t["visualization_msgs/msg/MeshFile"](filename="", data=np.zeros(0, np.uint8)),
        mesh_use_embedded_materials=False)
    return bytes(ts.serialize_cdr(msg, MARKER_TYPE))


def small_mesh(vertices, faces, colors=None):
    return rangemesh.Mesh(np.asarray(vertices, np.float64).reshape(-1, 3),
                          np.asarray(faces, np.int32).reshape(-1, 3),
                          np.zeros((len(vertices), 2), np.int32), rangemesh.Orthographic(), (1, 1),
                          colors=None if colors is None else np.asarray(colors, np.uint8))


@st.composite
def small_meshes(draw):
    """Up to 6 vertices and 5 faces (none: an empty mesh), with or without colours."""
    nv = draw(st.integers(1, 6))
    coord = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False, width=64)
    vertices = draw(st.lists(st.tuples(coord, coord, coord), min_size=nv, max_size=nv))
    faces = draw(st.lists(st.tuples(*[st.integers(0, nv - 1)] * 3), max_size=5))
    colors = draw(st.none() | st.lists(st.tuples(*[st.integers(0, 255)] * 3), min_size=nv,
                                        max_size=nv))
    return small_mesh(vertices, faces, colors)


NAMES = st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"),
                max_size=9)  # every length mod 4 and multi-byte UTF-8: the alignment after strings


@settings(max_examples=150, deadline=None)
@given(mesh=small_meshes(), stamp=st.integers(0, 2**31 * 10**9 - 1), frame_id=NAMES, ns=NAMES)
def test_marker_bytes_are_rosbags_own_serialisation(mesh, stamp, frame_id, ns):
    from rangemesh.recordings.writing import MARKER_TYPE, marker_bytes, typestore

    data = marker_bytes(mesh, stamp, frame_id, ns=ns)
    assert data == marker_by_rosbags(mesh, stamp, frame_id, ns)
    msg = typestore().deserialize_cdr(data, MARKER_TYPE)  # and back to the same message
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == divmod(stamp, 10**9)
    assert (msg.header.frame_id, msg.ns, msg.type, msg.texture.header.frame_id) == \
        (frame_id, ns, 11, frame_id)
    corners = mesh.vertices[mesh.faces].reshape(-1, 3)
    np.testing.assert_array_equal(np.array([[p.x, p.y, p.z] for p in msg.points]).reshape(-1, 3),
                                  corners)
    if mesh.colors is None or mesh.is_empty:
        assert msg.colors == [] and (msg.color.r, msg.color.a) == (np.float32(0.8), 1.0)
    else:
        got = np.array([[c.r, c.g, c.b, c.a] for c in msg.colors])
        rgb = mesh.colors[mesh.faces].reshape(-1, 3)
        np.testing.assert_allclose(got[:, :3] * 255.0, rgb, rtol=1e-6)
        assert (got[:, 3] == 1.0).all()


@pytest.mark.parametrize("colors", [None, [[255, 0, 128]] * 3])
@pytest.mark.parametrize("faces", [[[0, 1, 2]], np.zeros((0, 3))], ids=["one", "empty"])
def test_marker_bytes_of_one_triangle_and_of_an_empty_mesh(faces, colors):
    """A single triangle (an odd corner count) and an empty mesh, with and without colours."""
    from rangemesh.recordings.writing import marker_bytes

    mesh = small_mesh([[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.5, 2.0]], faces, colors)
    data = marker_bytes(mesh, 1_500_000_001, "cam")
    assert data == marker_by_rosbags(mesh, 1_500_000_001, "cam")
    # by hand: header 4+4+(4+4) and ns 4+10 end at 30; id, type, action from 32; pose and scale 80
    # bytes from 48 (8-aligned); color 16, lifetime 8, frame_locked 1 -> 153; points' count at 156
    n = 3 * len(mesh.faces)
    assert struct.unpack_from("<I", data, 4 + 156) == (n,)
    if n:  # the points start 8-aligned at 160
        assert struct.unpack_from("<9d", data, 4 + 160) == \
            (0.0, 0.0, 1.0, 1.0, 0.0, 1.0, 0.0, 1.5, 2.0)
