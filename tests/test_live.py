"""rangemesh live (issue 42): sources through the vendors' SDKs, pacing, dropping, Foxglove, MCAP."""

import base64
import importlib
import json
import os
import re
import signal
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import rangemesh
from rangemesh.live import pacing
from rangemesh.live.messages import SCENE_FIELDS, scene_update_bytes
from rangemesh.live.pacing import Playback, paced, parse_pace
from rangemesh.live.sources import LiveFrame, source_kind
from rangemesh.live.stats import Stats
from rangemesh.live.workers import Prefetch as workers_prefetch

REALSENSE = "rosbag/librealsense_d435_single_depth_color_640x480.bag"
PCAP = "lidar/OS-1-128_v2.3.0_1024x10_lb_n3.pcap"
META = "lidar/OS-1-128_v2.3.0_1024x10.json"
# the depth stream's K in the bag's CameraInfo (rosbag/README.md)
FX = FY = 390.43145751953125
CX, CY = 331.38787841796875, 242.18734741210938
ENV = {**os.environ, "RANGEMESH_THREADS": "1"}


def sdk(module: str):
    """The SDK, or a skip; a failure when CI lists it in RANGEMESH_REQUIRE_SDKS."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        if module.split(".")[0] in os.environ.get("RANGEMESH_REQUIRE_SDKS", "").split(","):
            pytest.fail(f"{module} cannot be imported and RANGEMESH_REQUIRE_SDKS lists it ({exc})")
        pytest.skip(f"{module} is not installed ({exc})")


def _cli(*args, **kw):
    return subprocess.run([sys.executable, "-m", "rangemesh", "live", *map(str, args)],
                          capture_output=True, text=True, env=ENV, timeout=300, **kw)


# ------------------------------------------------------------------ pacing, with a fake clock


class FakeClock:
    """Time moves only when the code sleeps or the fake mesher works."""

    def __init__(self):
        self.t = 0.0

    def now(self):
        return self.t

    def sleep(self, seconds):
        self.t += max(0.0, seconds)


def _frames(stamps_s):
    return [LiveFrame(int(round(s * 1e9)), "f", np.zeros((1, 1)), None) for s in stamps_s]


def _run(feed, queue, mesh_seconds, clock):
    stats = Stats(clock.now())
    out = []
    for frame, arrival in paced(feed, queue, stats):
        out.append((frame.stamp, arrival, clock.now()))
        clock.t += mesh_seconds  # meshing takes this long
    return out, stats


def test_the_newest_frame_wins_when_meshing_falls_behind():
    # 10 frames at --pace 10 are released at 0.0, 0.1, ..., 0.9 s; each mesh takes 0.25 s.
    # By hand: meshed at t=0 frame 0; at 0.25 frames 1, 2 are in, 1 dropped, 2 meshed; at 0.5
    # 3, 4, 5 in, 5 meshed (2 dropped); at 0.75 7 (6 dropped); at 1.0 9 (8 dropped): 5 dropped.
    clock = FakeClock()
    feed = Playback(_frames(np.arange(10) * 7.0), 10, clock)  # the stamps do not matter at a rate
    out, stats = _run(feed, 1, 0.25, clock)
    assert [round(s / 7e9) for s, _, _ in out] == [0, 2, 5, 7, 9]
    assert stats.dropped == 5 and stats.frames_in == 10
    # each frame was handed out when the mesher was free, after its release
    assert [(a, t) for _, a, t in out] == [(0.0, 0.0), (0.2, 0.25), (0.5, 0.5), (0.7, 0.75),
                                           (0.9, 1.0)]


def test_a_longer_queue_keeps_more_frames_and_drops_the_oldest():
    # --queue 2, same run. By hand: t=0: 0; 0.25: queue [1, 2], mesh 1; 0.5: [2, 3, 4, 5] -> drop
    # 2, 3, mesh 4; 0.75: [5, 6, 7] -> drop 5, mesh 6; 1.0: [7, 8, 9] -> drop 7, mesh 8;
    # 1.25: mesh 9. Dropped 2 + 1 + 1 = 4.
    clock = FakeClock()
    out, stats = _run(Playback(_frames(np.arange(10) * 1.0), 10, clock), 2, 0.25, clock)
    assert [round(s / 1e9) for s, _, _ in out] == [0, 1, 4, 6, 8, 9]
    assert stats.dropped == 4


def test_pace_fast_waits_for_the_mesher_and_drops_nothing():
    clock = FakeClock()
    out, stats = _run(Playback(_frames(np.arange(6) * 0.01), "fast", clock), 1, 0.5, clock)
    assert len(out) == 6 and stats.dropped == 0
    assert all(a == t for _, a, t in out)  # released when asked: no wait


def test_pace_recorded_releases_frames_at_their_stamps():
    # stamps 0, 0.3, 0.35, 1.0 s; meshing 0.1 s: 0 at 0; idle until 0.3; 1 at 0.3; 2 came at
    # 0.35 during it and is meshed at 0.4; idle until 1.0. Nothing dropped.
    clock = FakeClock()
    out, stats = _run(Playback(_frames([5.0, 5.3, 5.35, 6.0]), "recorded", clock), 1, 0.1, clock)
    assert [(round(a, 9), round(t, 9)) for _, a, t in out] == [(0.0, 0.0), (0.3, 0.3),
                                                                (0.35, 0.4), (1.0, 1.0)]
    assert stats.dropped == 0


def test_a_looped_recording_goes_on_one_frame_gap_after_its_end():
    # a loop of stamps 0, 0.5 at its recorded pace with fps 2: the second pass starts at 1.0
    clock = FakeClock()
    out, _ = _run(Playback(_frames([0.0, 0.5, 0.0, 0.5]), "recorded", clock, fps=2.0), 1, 0.0, clock)
    assert [a for _, a, _ in out] == [0.0, 0.5, 1.0, 1.5]


def test_a_looped_recording_of_unknown_rate_keeps_its_pace_pass_after_pass():
    # no fps: the gap between passes is the first pass's mean gap, 0.5 s here. It was the mean
    # over every frame released so far, so each pass came sooner (1/3 of the gap at the third,
    # 1/5 at the fourth: the ROS bag looped at --pace recorded went in at 11 frames/s, not 6)
    clock = FakeClock()
    out, stats = _run(Playback(_frames([0.0, 0.5] * 4), "recorded", clock), 1, 0.0, clock)
    assert [round(a, 9) for _, a, _ in out] == [0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5]
    assert stats.dropped == 0


def test_a_device_s_frames_dropped_before_the_mesher_takes_them_are_counted():
    # a sensor gave 1100 frames while the mesher was busy: the feed keeps the newest 64, the
    # queue the newest one; all 1100 arrived, 1099 were dropped, the last one is meshed
    frames = _frames(np.arange(1100) * 0.01)
    feed = pacing.DeviceFeed(iter(frames), pacing.Clock())
    end = time.monotonic() + 30
    while not feed.ended and time.monotonic() < end:
        time.sleep(0.01)
    stats = Stats(0.0)
    out = [f for f, _ in paced(feed, 1, stats)]
    assert out == [frames[-1]]
    assert (stats.frames_in, stats.dropped) == (1100, 1099)


@pytest.mark.parametrize("bad", ["slow", "0", "-3", "nan", "inf", None])
def test_a_bad_pace_is_a_value_error_naming_pace(bad):
    with pytest.raises(ValueError, match="pace"):
        parse_pace(bad)


def test_pace_words_and_rates():
    assert parse_pace("fast") == "fast" and parse_pace("Recorded") == "recorded"
    assert parse_pace("30") == 30.0


@pytest.mark.parametrize("bad", [0, -1, 1.5, True])
def test_a_bad_queue_is_a_value_error_naming_queue(bad):
    with pytest.raises(ValueError, match="queue"):
        next(paced(Playback([], "fast", FakeClock()), bad))


@given(st.lists(st.floats(0.0, 1e4, allow_nan=False), min_size=1, max_size=300),
       st.sampled_from([0, 5, 50, 95, 99.5, 100]))
def test_the_live_percentile_is_numpy_s_linear_one(values, q):
    from rangemesh.live.stats import percentile

    assert percentile(values, q) == pytest.approx(float(np.percentile(values, q)), rel=1e-12,
                                                  abs=1e-9)


def test_the_current_latency_p95_is_of_the_last_frames():
    from rangemesh.live.stats import RECENT

    stats = Stats(0.0)
    for i in range(RECENT + 100):  # latencies 0, 1, 2, ... ms: the first 100 fall out of the window
        stats.published(i, i, i + i / 1e3, 0.0, 0.0, 3, 1)
    f = stats.figures(RECENT + 100.0)
    # the last 256 latencies are 100..355 ms: the 95th percentile at (256 - 1) * 0.95 = 242.25
    assert f["latency_ms"] == pytest.approx(355.0)
    assert f["latency_p95_ms"] == pytest.approx(100 + 242.25)


# ------------------------------------------------------------------ frames meshed at once (threads)


def _two_workers(monkeypatch):
    """A run of two threads, whatever the machine's cores (`rangemesh.live.workers`)."""
    from rangemesh.live import workers

    monkeypatch.setenv("RANGEMESH_THREADS", "2")
    monkeypatch.setattr(workers, "cores", lambda: 2)
    assert workers.frame_workers() == 2


def test_the_frame_workers_follow_rangemesh_threads_and_the_cores(monkeypatch):
    from rangemesh.live import workers

    monkeypatch.setattr(workers, "cores", lambda: 4)
    for value, want in [("1", 1), ("2", 2), ("8", 4), ("", 4), ("x", 4), ("0", 4)]:
        monkeypatch.setenv("RANGEMESH_THREADS", value)
        assert workers.frame_workers() == want, value
    monkeypatch.setattr(workers, "cores", lambda: 1)  # taskset -c 0: one, whatever is asked
    monkeypatch.setenv("RANGEMESH_THREADS", "2")
    assert workers.frame_workers() == 1


class _Source:
    """A recording of `n` tiny frames (stamps 0, 1, ... s) whose reads the test can watch."""

    device = False
    fps = None

    def __init__(self, n, on_read=None):
        self.n, self.on_read, self.closed = n, on_read, False

    def frames(self):
        for i in range(self.n):
            if self.on_read is not None:
                self.on_read(i)
            yield LiveFrame(i * 10**9, "f", np.full((2, 2), i, np.uint16), None)

    def close(self):
        self.closed = True


class _Mesh:
    def __init__(self, i):
        self.index = i
        self.vertices = np.zeros((0, 3))


def _live_with(monkeypatch, source, mesh, **kw):
    """`rangemesh.live` of a fake source, `mesh(index)` standing for `triangulate`."""
    from rangemesh.live import session

    monkeypatch.setattr(session, "open_source", lambda *a, **k: source)
    monkeypatch.setattr(session, "triangulate",
                        lambda depth, **k: mesh(int(depth[0, 0])))
    return session.live("fake.bag", **kw)


def test_two_threads_mesh_two_frames_at_once(monkeypatch):
    # each of the first two frames' meshing waits for the other to start: one thread at a
    # time would never get past the first (the barrier breaks after its timeout)
    _two_workers(monkeypatch)
    both = threading.Barrier(2, timeout=20)

    def mesh(i):
        if i < 2:
            both.wait()
        return _Mesh(i)

    out = list(_live_with(monkeypatch, _Source(4), mesh, pace="fast"))
    assert [m.mesh.index for m in out] == [0, 1, 2, 3]


def test_a_recording_is_read_ahead_while_the_workers_mesh(monkeypatch):
    # frames 0 and 1 mesh only once frame 2 has been read: the reading must not wait for a
    # worker to be free (the RealSense SDK's playback read ran on the meshing thread)
    _two_workers(monkeypatch)
    read2 = threading.Event()

    def mesh(i):
        if i < 2:
            assert read2.wait(20), "frame 2 was not read while frames 0 and 1 were meshed"
        return _Mesh(i)

    source = _Source(3, on_read=lambda i: i == 2 and read2.set())
    out = list(_live_with(monkeypatch, source, mesh, pace="fast"))
    assert [m.mesh.index for m in out] == [0, 1, 2]


def test_one_thread_meshes_frames_in_turn_and_reads_on_the_caller_s_thread(monkeypatch):
    # RANGEMESH_THREADS=1: read, mesh, hand out in turn, all on the caller's thread
    from rangemesh.live import workers

    monkeypatch.setattr(workers, "cores", lambda: 2)
    monkeypatch.setenv("RANGEMESH_THREADS", "1")
    threads, busy = set(), []

    def mesh(i):
        busy.append(i)
        threads.add(threading.current_thread())
        assert len(busy) == 1
        busy.pop()
        return _Mesh(i)

    source = _Source(3, on_read=lambda i: threads.add(threading.current_thread()))
    out = list(_live_with(monkeypatch, source, mesh, pace="fast"))
    assert [m.mesh.index for m in out] == [0, 1, 2]
    assert threads == {threading.current_thread()}


def test_meshes_come_out_in_the_frames_order_whatever_order_they_are_made_in(monkeypatch):
    # frame 0 is finished only after frame 1: still handed out first
    _two_workers(monkeypatch)
    one_done = threading.Event()
    finished = []

    def mesh(i):
        if i == 0:
            assert one_done.wait(20)
        finished.append(i)
        if i == 1:
            one_done.set()
        return _Mesh(i)

    out = list(_live_with(monkeypatch, _Source(5), mesh, pace="fast"))
    assert finished.index(1) < finished.index(0)  # (frame 2 may finish before 0 too)
    assert [m.mesh.index for m in out] == [0, 1, 2, 3, 4]
    assert [m.stamp for m in out] == [i * 10**9 for i in range(5)]


def test_each_worker_meshes_with_one_native_thread(monkeypatch):
    from rangemesh import threads as refine_threads

    _two_workers(monkeypatch)
    seen = []
    out = list(_live_with(monkeypatch, _Source(4),
                          lambda i: seen.append(refine_threads.threads()) or _Mesh(i), pace="fast"))
    assert len(out) == 4 and seen == [1, 1, 1, 1]
    with refine_threads.one_thread():
        assert refine_threads.threads() == 1


class _Feed:
    """A device's frames, arriving when the test says (`DeviceFeed`'s interface)."""

    clock = pacing.Clock()

    def __init__(self):
        self._items, self.ended = [], False
        self._cond = threading.Condition()

    def arrive(self, frames, end=False):
        with self._cond:
            self._items += [(f, self.clock.now()) for f in frames]
            self.ended = end
            self._cond.notify()

    def take(self, now):
        with self._cond:
            out, self._items = self._items, []
        return out

    def lost(self):
        return 0

    def wait(self):
        with self._cond:
            while not self._items and not self.ended:
                self._cond.wait(0.05)
            return bool(self._items)

    def close(self):
        pass


def test_with_two_threads_a_worker_takes_its_next_frame_itself(monkeypatch):
    # a pacing thread took each frame and handed it to a free worker: two hand-overs of the GIL
    # between a frame's end and the next one's start (live42d)
    _two_workers(monkeypatch)
    taken_on = set()
    take = pacing.Playback.take
    monkeypatch.setattr(pacing.Playback, "take",
                        lambda self, now: taken_on.add(threading.current_thread().name)
                        or take(self, now))
    out = list(_live_with(monkeypatch, _Source(6), _Mesh, pace="fast"))
    assert [m.mesh.index for m in out] == list(range(6))
    assert taken_on and all(name.startswith("rangemesh-live-mesh") for name in taken_on), taken_on


@pytest.mark.parametrize("reads_ahead", [False, True])
def test_with_two_threads_only_a_source_that_does_not_read_ahead_itself_gets_a_reader(
        monkeypatch, reads_ahead):
    # the RealSense SDK reads ahead on threads of its own: a read-ahead thread between it and the
    # workers only added a hand-over of the GIL a frame (live42d)
    from rangemesh.live import session

    _two_workers(monkeypatch)
    made = []
    monkeypatch.setattr(session, "Prefetch",
                        lambda frames, ahead: made.append(ahead) or workers_prefetch(frames, ahead))
    source = _Source(5)
    source.reads_ahead = reads_ahead
    out = list(_live_with(monkeypatch, source, _Mesh, pace="fast"))
    assert [m.mesh.index for m in out] == list(range(5))
    assert made == ([] if reads_ahead else [2])


@pytest.mark.parametrize(("queue", "meshed", "dropped"), [(1, [0, 1, 5], 3), (2, [0, 1, 4, 5], 2)])
def test_with_two_threads_the_newest_frames_win_when_both_are_busy(queue, meshed, dropped):
    # by hand: frames 0 and 1 keep both workers busy while 2, 3, then 4, 5 arrive; when a worker
    # is free the queue keeps the newest `queue` of them, the others are dropped (counted)
    from rangemesh.live.workers import pooled

    feed, started, go = _Feed(), threading.Semaphore(0), threading.Event()
    frames = _frames(np.arange(6) * 1.0)

    def mesh(frame, arrival):
        i = round(frame.stamp / 1e9)
        if i < 2:
            started.release()
            assert go.wait(20)
        return i

    stats = Stats(0.0)
    out = []
    caller = threading.Thread(target=lambda: out.extend(pooled(feed, mesh, 2, queue, None, stats)))
    caller.start()
    try:
        for i in (0, 1):  # one by one: together, the queue of one would keep frame 1 only
            feed.arrive(frames[i:i + 1])
            assert started.acquire(timeout=20)
        feed.arrive(frames[2:4])
        time.sleep(0.2)  # (a pool that took frames before a worker was free would take 3 here)
        feed.arrive(frames[4:], end=True)
    finally:
        go.set()
        caller.join(20)
    assert out == meshed
    assert (stats.frames_in, stats.dropped) == (6, dropped)


def test_a_source_s_error_is_raised_after_the_frames_before_it(monkeypatch):
    _two_workers(monkeypatch)

    def fail(i):
        if i == 3:
            raise ValueError("frame 3: cannot be read")

    got = []
    with pytest.raises(ValueError, match="frame 3: cannot be read"):
        for m in _live_with(monkeypatch, _Source(5, on_read=fail), _Mesh, pace="fast"):
            got.append(m.mesh.index)
    assert got == [0, 1, 2]


@pytest.mark.parametrize("threads", ["1", "2"])
def test_frames_stops_after_that_many_meshes_with_any_threads(monkeypatch, threads):
    from rangemesh.live import workers

    monkeypatch.setattr(workers, "cores", lambda: 2)
    monkeypatch.setenv("RANGEMESH_THREADS", threads)
    made = []
    out = list(_live_with(monkeypatch, _Source(50), lambda i: made.append(i) or _Mesh(i),
                          pace="fast", frames=7))
    assert [m.mesh.index for m in out] == list(range(7))
    assert sorted(made) == list(range(7))  # no frame taken beyond the seventh


# ------------------------------------------------------------------ the SceneUpdate message


def _scene_class():
    m = sdk("foxglove.messages")
    descriptor_pb2 = sdk("google.protobuf.descriptor_pb2")
    from google.protobuf import descriptor_pool, message_factory

    pool = descriptor_pool.DescriptorPool()
    for f in descriptor_pb2.FileDescriptorSet.FromString(m.SceneUpdate.get_schema().data).file:
        pool.Add(f)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName("foxglove.SceneUpdate")), pool


def test_the_field_numbers_are_those_of_the_sdk_schema():
    _, pool = _scene_class()
    for (message, field), number in SCENE_FIELDS.items():
        package = "google.protobuf" if message == "Timestamp" else "foxglove"
        assert pool.FindMessageTypeByName(f"{package}.{message}").fields_by_name[field].number \
            == number, (message, field)


@pytest.mark.parametrize("colored", [False, True])
def test_a_scene_update_decodes_to_the_mesh_and_equals_the_sdk_s_own(colored, rng):
    m = sdk("foxglove.messages")
    cls, _ = _scene_class()
    v = rng.normal(size=(7, 3))
    f = np.array([[0, 1, 2], [2, 3, 4], [4, 5, 6]], np.int32)
    c = rng.integers(0, 256, (7, 3)).astype(np.uint8) if colored else None
    data = scene_update_bytes(v, f, 12_000_000_345, "cam", c)
    got = cls.FromString(data)
    tri = got.entities[0].triangles[0]
    assert np.array_equal([[p.x, p.y, p.z] for p in tri.points], v)
    assert list(tri.indices) == f.ravel().tolist()
    assert got.entities[0].frame_id == "cam"
    assert (got.entities[0].timestamp.seconds, got.entities[0].timestamp.nanos) == (12, 345)
    # the SDK builds the same message from one Python object per vertex
    colors = [m.Color(r=r / 255, g=g / 255, b=b / 255, a=1.0) for r, g, b in c.tolist()] \
        if colored else []
    sdk_msg = m.SceneUpdate(entities=[m.SceneEntity(
        timestamp=m.Timestamp(sec=12, nsec=345), frame_id="cam", id="mesh",
        triangles=[m.TriangleListPrimitive(
            pose=m.Pose(orientation=m.Quaternion(w=1.0)),
            points=[m.Point3(x=a, y=b, z=z) for a, b, z in v.tolist()], colors=colors,
            color=None if colored else m.Color(r=0.8, g=0.8, b=0.8, a=1.0),
            indices=f.ravel().tolist())])]).encode()
    assert cls.FromString(sdk_msg) == got


# ------------------------------------------------------------------ sources


def test_sources_are_chosen_by_name(shared_data):
    assert source_kind("realsense") == source_kind("realsense:728612070259") == "realsense"
    assert source_kind(str(shared_data / PCAP)) == "ouster"
    assert source_kind("os-122201000998.local") == "ouster"  # a hostname
    assert source_kind(str(shared_data / REALSENSE), "ros") == "ros"
    with pytest.raises(ValueError, match="source kind"):
        source_kind("x.bag", "kinect")


def test_a_realsense_sdk_bag_goes_to_pyrealsense2(shared_data):
    sdk("pyrealsense2")
    assert source_kind(str(shared_data / REALSENSE)) == "realsense"


def test_the_realsense_bag_through_the_sdk(shared_data):
    sdk("pyrealsense2")
    from rangemesh.live.sources import RealSenseSource
    from rangemesh.recordings import Recording
    from rangemesh.recordings.decode import depth_image

    src = RealSenseSource(str(shared_data / REALSENSE))
    try:
        frames = list(src.frames())
    finally:
        src.close()
    assert len(frames) == 2
    assert src.depth_scale == 0.001  # the SDK's float32 0.001 read as the decimal it stands for
    cam = frames[0].camera
    assert isinstance(cam, rangemesh.Pinhole)  # Brown-Conrady with five zero coefficients
    assert (cam.fx, cam.fy, cam.cx, cam.cy) == (FX, FY, CX, CY)
    assert cam.depth_scale == src.depth_scale
    # the same pixels as the ROS reader decodes from the same file
    with Recording(shared_data / REALSENSE) as rec:
        ros = [(f.stamp, depth_image(f.depth, f.name)[0]) for f in rec.frames()]
    for frame, (stamp, depth) in zip(frames, ros, strict=True):
        assert frame.depth.shape == (480, 640) and frame.depth.dtype == np.uint16
        assert frame.stamp == stamp
        assert np.array_equal(frame.depth, depth)


def test_a_realsense_bag_read_late_gives_every_frame(shared_data):
    # the SDK's playback position runs ahead of the frames handed out: ending the playback when
    # it reached the end lost the second frame when the reading began late
    sdk("pyrealsense2")
    from rangemesh.live.sources import RealSenseSource

    src = RealSenseSource(str(shared_data / REALSENSE))
    try:
        time.sleep(0.5)
        stamps = [frame.stamp for frame in src.frames()]
    finally:
        src.close()
    assert stamps == [360815089000, 360981765000]


def _ros_depths(shared_data):
    """The bag's depth frames as the ROS reader decodes them (an independent reader): stamp -> image."""
    from rangemesh.recordings import Recording
    from rangemesh.recordings.decode import depth_image

    with Recording(shared_data / REALSENSE) as rec:
        return {f.stamp: depth_image(f.depth, f.name)[0] for f in rec.frames()}


def test_a_looped_realsense_recording_replays_its_first_pass_from_memory(shared_data):
    # the SDK plays a short recording once: later passes hand out its first pass's decoded frames
    # (the SDK's repeat reopened the 2-frame bag each pass, about 4 ms of CPU a frame)
    sdk("pyrealsense2")
    from rangemesh.live.sources import RealSenseSource

    want = _ros_depths(shared_data)
    src = RealSenseSource(str(shared_data / REALSENSE), loop=True)
    it = src.frames()
    try:
        frames = [next(it) for _ in range(6)]
    finally:
        it.close()
        src.close()
    assert [f.stamp for f in frames] == [360815089000, 360981765000] * 3
    for f in frames:
        assert np.array_equal(f.depth, want[f.stamp])
        assert not f.depth.flags.writeable  # handed out again: nobody may change it
    assert frames[2].depth is frames[0].depth and frames[5].depth is frames[1].depth


def test_a_looped_ros_recording_reads_its_image_topics_once(shared_data, monkeypatch):
    # each pass asked for the topics again, reading (and decompressing) each image topic's first
    # message: 2.5 ms of the reader's 4 ms a frame on the 2-frame bag looped (live42d)
    from rangemesh.live.sources import RosSource
    from rangemesh.recordings import Recording

    want = _ros_depths(shared_data)
    reads = []  # the topics of each read through the recording's messages
    read = Recording._messages
    monkeypatch.setattr(Recording, "_messages",
                        lambda rec, conns: reads.append({c.topic for c in conns}) or read(rec, conns))
    src = RosSource(str(shared_data / REALSENSE), loop=True)
    it = src.frames()
    try:
        frames = [next(it) for _ in range(2)]
        reads.clear()  # the first pass's: the topics described, the CameraInfo read
        frames += [next(it) for _ in range(4)]
    finally:
        it.close()
        src.close()
    assert [f.stamp for f in frames] == [360815089000, 360981765000] * 3
    for f in frames:
        assert np.array_equal(f.depth, want[f.stamp])
    # passes 2 and 3: one read each, of the depth topic alone (the bag holds a colour topic too)
    depth_topic = {"/device_0/sensor_0/Depth_0/image/data"}
    assert reads == [depth_topic, depth_topic], reads


def test_a_looped_realsense_recording_too_long_to_keep_is_played_by_the_sdk_each_pass(
        shared_data, monkeypatch):
    sdk("pyrealsense2")
    from rangemesh.live import sources

    # 30 passes, each ended at the first pass's length: restarted before the SDK's playback had
    # stopped, a pass now and then gave no frame and the loop ended (4 runs of 100 frames in 6)
    monkeypatch.setattr(sources, "REPLAY_BYTES", 0)  # nothing fits: every pass from the file
    want = _ros_depths(shared_data)
    src = sources.RealSenseSource(str(shared_data / REALSENSE), loop=True)
    it = src.frames()
    try:
        frames = [next(it, None) for _ in range(60)]
    finally:
        it.close()
        src.close()
    assert None not in frames
    stamps = [f.stamp for f in frames]
    # the recording's two frames in turn (a playback may begin at its second: the SDK loses its
    # first now and then, about 1 start in 2900 here)
    assert set(stamps) == {360815089000, 360981765000}
    assert all(a != b for a, b in zip(stamps, stamps[1:], strict=False))
    for f in frames:
        assert np.array_equal(f.depth, want[f.stamp]) and f.depth.flags.writeable
    assert frames[2].depth is not frames[0].depth


_STOP_LOOPED = """
import random, sys, time
from rangemesh.live import sources
from rangemesh.live.workers import Prefetch
bag, runs = sys.argv[1], int(sys.argv[2])
rnd = random.Random(42)
for r in range(runs):
    sources.REPLAY_BYTES = 0 if r % 2 else 256 * 2**20  # odd runs: the SDK plays every pass
    src = sources.RealSenseSource(bag, loop=True)
    it = Prefetch(src.frames(), 2) if r % 4 >= 2 else src.frames()
    got = [next(it).stamp for _ in range(1 + r % 7)]
    time.sleep(rnd.random() * 0.02)
    it.close()
    src.close()
    # the recording's frames in its order, pass after pass; a playback may begin at the second
    # frame (the SDK loses its first now and then: 1 start in about 2900 here)
    looped = [360815089000, 360981765000] * 5
    if got not in (looped[:len(got)], looped[1:len(got) + 1]):
        sys.exit(f"run {r}: stamps {got}")
print("ok")
"""


@pytest.mark.slow
def test_stopping_a_looped_realsense_playback_at_any_frame_neither_crashes_nor_loses_frames(
        shared_data):
    # librealsense 2.59's own repeat crashed (ros_reader::enable_stream, 1 in 44 Ctrl-C runs) when
    # the playback was stopped as it restarted; a pass restarted before the playback stopped gave
    # no frame at all
    sdk("pyrealsense2")
    proc = subprocess.run([sys.executable, "-X", "faulthandler", "-c", _STOP_LOOPED,
                           str(shared_data / REALSENSE), "120"],
                          capture_output=True, text=True, env=ENV, timeout=600)
    assert proc.returncode == 0 and proc.stdout.strip() == "ok", proc.stderr[-2000:]


def test_closing_a_prefetch_whose_reader_waits_for_room_ends_it_at_once(monkeypatch):
    # the reader waited up to a poll (50 ms) for room before it saw the stop: a two-thread run's
    # end came that much after its last frame (live42d); a poll of an hour here shows it
    from rangemesh.live import workers

    monkeypatch.setattr(workers, "_POLL", 3600.0)
    monkeypatch.setattr(workers, "_JOIN", 2.0)
    read = []

    def frames():
        for i in range(100):
            read.append(i)
            yield i

    ahead = workers.Prefetch(frames(), 2)
    assert next(ahead) == 0
    deadline = time.monotonic() + 20
    while len(read) < 4 and time.monotonic() < deadline:  # 1 and 2 queued, 3 waiting for room
        time.sleep(0.01)
    t0 = time.monotonic()
    ahead.close()
    assert not ahead._thread.is_alive() and time.monotonic() - t0 < 1.0
    assert read == [0, 1, 2, 3]  # nothing read after the stop


def test_a_distorted_realsense_stream_meshes_with_exact_rays():
    from types import SimpleNamespace

    from rangemesh.camera_files import distortion_rays
    from rangemesh.live.sources import realsense_camera

    intr = SimpleNamespace(fx=FX, fy=FY, ppx=CX, ppy=CY, width=64, height=48,
                           model="distortion.brown_conrady", coeffs=[0.1, -0.05, 0.001, 0.002, 0.01])
    cam = realsense_camera(intr, 0.001)
    want = distortion_rays((FX, 0, CX, 0, FY, CY, 0, 0, 1), (0.1, -0.05, 0.001, 0.002, 0.01),
                           "plumb_bob", (48, 64), depth_scale=0.001)
    assert isinstance(cam, rangemesh.Rays) and cam.z_depth
    assert np.array_equal(cam.directions, want.directions) and cam.range_scale == 0.001
    intr.model = "distortion.inverse_brown_conrady"
    with pytest.raises(ValueError, match="inverse_brown_conrady"):
        realsense_camera(intr, 0.001)


def test_no_realsense_device_is_one_line():
    rs = sdk("pyrealsense2")
    if rs.context().query_devices().size():
        pytest.skip("a RealSense device is connected")
    with pytest.raises(ValueError, match="no RealSense device is connected"):
        rangemesh.live("realsense")


def test_a_realsense_recording_loses_no_frame_when_its_start_is_held_up(shared_data, monkeypatch):
    # a busy machine may hold the thread up just after the SDK's pipeline starts: the recording
    # must already play in non-real time then, or the SDK drops its first frames (1 of 2 seen)
    rs = sdk("pyrealsense2")
    start = rs.pipeline.start

    def held_up(self, *args):
        profile = start(self, *args)
        time.sleep(0.5)
        return profile

    monkeypatch.setattr(rs.pipeline, "start", held_up)
    got = list(rangemesh.live(shared_data / REALSENSE, pace="fast", vertices=300))
    assert len(got) == 2


def test_the_sdk_and_the_ros_reader_give_the_same_meshes(shared_data):
    sdk("pyrealsense2")
    a = list(rangemesh.live(shared_data / REALSENSE, pace="fast", vertices=300))
    b = list(rangemesh.live(shared_data / REALSENSE, kind="ros", pace="fast", vertices=300))
    assert len(a) == len(b) == 2
    for x, y in zip(a, b, strict=True):
        assert x.stamp == y.stamp
        assert np.array_equal(x.mesh.vertices, y.mesh.vertices)
        assert np.array_equal(x.mesh.faces, y.mesh.faces)


def test_the_ouster_pcap_s_three_frames_mesh_at_the_sdk_s_points(shared_data):
    sdk("ouster.sdk")
    core = sdk("ouster.sdk.core")
    from ouster.sdk import open_source

    got = list(rangemesh.live(shared_data / PCAP, meta=shared_data / META, pace="fast",
                              vertices=800, heights="pixel", fill_gaps=False))
    assert len(got) == 3
    src = open_source(str(shared_data / PCAP), meta=[str(shared_data / META)])
    info = src.sensor_info[0]
    lut = core.XYZLut(info)
    scans = [s[0] for s in src]
    src.close()
    for (stamp, frame_id, mesh), scan in zip(got, scans, strict=True):
        assert mesh.image_shape == (128, 1024) and mesh.stats.vertices == 800
        assert frame_id == "os_lidar" and stamp == scan.timestamp[scan.get_first_valid_column()]
        # each vertex (its own pixel's range; no gap filled) is the SDK's point of that pixel,
        # beam-origin offset included
        xyz = core.destagger(info, lut(scan))
        r, c = mesh.pixels.T
        assert np.allclose(mesh.vertices, xyz[r, c], rtol=0, atol=1e-9)


def test_an_ouster_scan_of_the_whole_circle_closes_its_seam(shared_data):
    sdk("ouster.sdk")
    kw = {"meta": shared_data / META, "pace": "fast", "frames": 1, "vertices": 800}
    closed = next(iter(rangemesh.live(shared_data / PCAP, **kw))).mesh
    opened = next(iter(rangemesh.live(shared_data / PCAP, wrap=False, **kw))).mesh

    def seam_faces(mesh):  # faces with corners on both the first and the last column
        cols = mesh.pixels[mesh.faces, 1]
        return int(((cols == 0).any(axis=1) & (cols == 1023).any(axis=1)).sum())

    assert seam_faces(closed) > 0 and seam_faces(opened) == 0


def test_meta_goes_with_an_ouster_recording(shared_data):
    with pytest.raises(ValueError, match="--meta"):
        rangemesh.live(shared_data / REALSENSE, kind="ros", meta=shared_data / META)


def test_rangemesh_live_is_the_package_and_the_function():
    import rangemesh.live as package

    assert callable(package) and callable(rangemesh.live)
    with pytest.raises(ValueError, match="pace"):
        package("x.bag", pace="slow")


def test_a_missing_sdk_is_named_with_its_pip_install(monkeypatch):
    from rangemesh.live.sinks import FoxgloveChannels

    monkeypatch.setitem(sys.modules, "foxglove", None)
    with pytest.raises(ImportError, match=r'pip install "rangemesh\[live\]"'):
        FoxgloveChannels(mcap="x.mcap")


# ------------------------------------------------------------------ sinks


def _expected_meshes(shared_data, **options):
    """The bag's frames meshed by `triangulate` on the ROS reader's depth and camera."""
    from rangemesh.recordings import Recording
    from rangemesh.recordings.decode import depth_image

    out = {}
    with Recording(shared_data / REALSENSE) as rec:
        for f in rec.frames():
            depth = depth_image(f.depth, f.name)[0]
            out[f.stamp] = rangemesh.triangulate(depth, background="nonpositive", camera=f.camera,
                                                 **options)
    return out


def _decoder():
    sdk("mcap_protobuf")
    from mcap.reader import make_reader
    from mcap_protobuf.decoder import DecoderFactory

    return make_reader, DecoderFactory


@pytest.mark.slow
def test_an_mcap_reads_back_with_mcap_s_protobuf_decoder(shared_data, tmp_path):
    sdk("foxglove")
    make_reader, DecoderFactory = _decoder()
    out = tmp_path / "live.mcap"
    r = _cli(shared_data / REALSENSE, "--source", "ros", "--pace", "fast", "--vertices", "300",
             "-o", out, "-o", tmp_path / "meshes", "--quiet")
    assert r.returncode == 0, r.stderr
    assert r.stdout == "" and r.stderr == ""
    want = _expected_meshes(shared_data, vertices=300)
    with open(out, "rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        topics = {c.topic: c for c in reader.get_summary().channels.values()}
        assert set(topics) == {"/rangemesh/mesh", "/rangemesh/calibration", "/rangemesh/tf",
                               "/rangemesh/stats"}
        scenes = [(m.log_time, d) for _, _, m, d in reader.iter_decoded_messages(
            topics=["/rangemesh/mesh"])]
        calibs = [d for _, _, _, d in reader.iter_decoded_messages(topics=["/rangemesh/calibration"])]
    assert len(scenes) == 2 and len(calibs) == 2
    for _, scene in scenes:
        e = scene.entities[0]
        mesh = want[e.timestamp.seconds * 10**9 + e.timestamp.nanos]
        tri = e.triangles[0]
        assert len(tri.points) == mesh.stats.vertices == 300
        assert np.array_equal([[p.x, p.y, p.z] for p in tri.points], mesh.vertices)
        assert np.array_equal(np.reshape(tri.indices, (-1, 3)), mesh.faces)
    assert list(calibs[0].K) == [FX, 0.0, CX, 0.0, FY, CY, 0.0, 0.0, 1.0]
    assert (calibs[0].width, calibs[0].height) == (640, 480)
    rows = (tmp_path / "live.rangemesh-live.csv").read_text().splitlines()
    assert len(rows) == 3 and rows[0].startswith("index,stamp,")
    # the folder: a mesh file per frame, named by its stamp as batch names them
    files = sorted(p.name for p in (tmp_path / "meshes").iterdir())
    assert files == ["360.815089000.ply", "360.981765000.ply"]
    back = rangemesh.read_mesh(tmp_path / "meshes" / "360.815089000.ply")
    assert np.allclose(back.vertices, want[360815089000].vertices)


def _ws_frames(url, want_topic, count, timeout=60.0):
    """Connect as a Foxglove client, subscribe to `want_topic`, return the channels and payloads."""
    sync = sdk("websockets.sync.client")
    with sync.connect(url, subprotocols=["foxglove.sdk.v1"], open_timeout=timeout,
                      max_size=None) as ws:
        assert ws.subprotocol == "foxglove.sdk.v1"
        channels, payloads, end = {}, [], time.monotonic() + timeout
        while len(payloads) < count:
            assert time.monotonic() < end, "no message from the server"
            msg = ws.recv(timeout=timeout)
            if isinstance(msg, str):
                op = json.loads(msg)
                if op.get("op") == "advertise":
                    for ch in op["channels"]:
                        channels[ch["topic"]] = ch
                        if ch["topic"] == want_topic:
                            ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                                {"id": 7, "channelId": ch["id"]}]}))
                continue
            assert msg[0] == 1  # messageData: opcode, subscription id, log time, payload
            (sub,) = struct.unpack_from("<I", msg, 1)
            assert sub == 7
            payloads.append(msg[13:])
    return channels, payloads


@pytest.mark.slow
def test_a_websocket_client_receives_scene_updates_as_meshed(shared_data):
    sdk("foxglove")
    cls, _ = _scene_class()
    proc = subprocess.Popen(
        [sys.executable, "-m", "rangemesh", "live", str(shared_data / REALSENSE), "--source", "ros",
         "--pace", "5", "--loop", "--vertices", "300", "--foxglove", "127.0.0.1:0", "--quiet"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV)
    try:
        url = proc.stdout.readline().strip()  # printed and flushed before the first frame
        assert url.startswith("ws://127.0.0.1:") and int(url.rsplit(":", 1)[1]) > 0
        channels, payloads = _ws_frames(url, "/rangemesh/mesh", 2)
    finally:
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert {"/rangemesh/mesh", "/rangemesh/calibration", "/rangemesh/tf",
            "/rangemesh/stats"} <= set(channels)
    mesh_ch = channels["/rangemesh/mesh"]
    assert (mesh_ch["encoding"], mesh_ch["schemaName"]) == ("protobuf", "foxglove.SceneUpdate")
    base64.b64decode(mesh_ch["schema"])  # a protobuf schema is advertised in base64
    want = _expected_meshes(shared_data, vertices=300)
    for data in payloads:
        e = cls.FromString(data).entities[0]
        mesh = want[e.timestamp.seconds * 10**9 + e.timestamp.nanos]
        tri = e.triangles[0]
        assert len(tri.points) == mesh.stats.vertices
        assert np.array_equal([[p.x, p.y, p.z] for p in tri.points], mesh.vertices)
        assert np.array_equal(np.reshape(tri.indices, (-1, 3)), mesh.faces)


@pytest.mark.slow
@pytest.mark.parametrize("threads", ["1", "2"])  # 2: frames meshed by workers, read ahead
@pytest.mark.parametrize("reader", ["ros", "realsense"])
def test_ctrl_c_leaves_a_readable_mcap(shared_data, tmp_path, reader, threads):
    sdk("foxglove")
    if reader == "realsense":  # the SDK's playback: its pipeline stopped before the MCAP closes
        sdk("pyrealsense2")
    make_reader, DecoderFactory = _decoder()
    out = tmp_path / "run.mcap"
    proc = subprocess.Popen(
        [sys.executable, "-m", "rangemesh", "live", str(shared_data / REALSENSE), "--source", reader,
         "--pace", "20", "--loop", "--vertices", "300", "--foxglove", "0", "-o", str(out)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env={**ENV, "RANGEMESH_THREADS": threads})
    try:
        assert proc.stdout.readline().startswith("ws://127.0.0.1:")
        csv = tmp_path / "run.rangemesh-live.csv"
        end = time.monotonic() + 60
        while time.monotonic() < end and out.stat().st_size < 200_000:  # a few frames written
            time.sleep(0.1)
    finally:
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err
    with open(out, "rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()  # written at close: None for a cut file
        assert summary is not None
        n = summary.statistics.channel_message_counts
        counts = {summary.channels[k].topic: v for k, v in n.items()}
        scenes = list(reader.iter_decoded_messages(topics=["/rangemesh/mesh"]))
    assert counts["/rangemesh/mesh"] == counts["/rangemesh/stats"] >= 1
    assert len(scenes) == counts["/rangemesh/mesh"]
    assert len(csv.read_text().splitlines()) == counts["/rangemesh/mesh"] + 1


def test_ctrl_c_while_a_frame_is_published_lets_its_stats_row_out_too(shared_data, tmp_path,
                                                                      monkeypatch):
    # Ctrl-C right after a frame's mesh went out (the subprocess test above caught it there 1 run
    # in ~40: one mesh more than stats rows): the frame's stats row still goes out, then the run ends
    sdk("foxglove")
    make_reader, DecoderFactory = _decoder()
    from rangemesh.live import run, sinks

    publish = sinks.FoxgloveChannels.publish
    sent = []

    def publish_then_ctrl_c(self, *args):
        publish(self, *args)
        sent.append(1)
        if len(sent) == 3:
            signal.raise_signal(signal.SIGINT)

    monkeypatch.setattr(sinks.FoxgloveChannels, "publish", publish_then_ctrl_c)
    monkeypatch.setenv("RANGEMESH_THREADS", "1")
    out = tmp_path / "run.mcap"
    with pytest.raises(KeyboardInterrupt):
        run(shared_data / REALSENSE, kind="ros", pace="fast", loop=True, vertices=300,
            outputs=[out], quiet=True)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    with open(out, "rb") as fh:
        summary = make_reader(fh, decoder_factories=[DecoderFactory()]).get_summary()
    counts = {summary.channels[k].topic: v
              for k, v in summary.statistics.channel_message_counts.items()}
    assert counts["/rangemesh/mesh"] == counts["/rangemesh/stats"] == 3
    assert len((tmp_path / "run.rangemesh-live.csv").read_text().splitlines()) == 3 + 1


@pytest.mark.parametrize("reader", ["ros", "realsense"])
def test_one_and_two_threads_publish_the_same_meshes_in_the_same_order(shared_data, tmp_path,
                                                                       monkeypatch, reader):
    # the bag's 2 frames looped to 6 at --pace fast, the default target: the MCAP's SceneUpdates
    # and the folder's files of a run of two threads are those of one, in order, and equal
    # triangulate's meshes of the frames (the ROS reader's decoding, `_expected_meshes`); through
    # the SDK, passes 2 and 3 are the first pass's frames replayed from memory
    sdk("foxglove")
    if reader == "realsense":
        sdk("pyrealsense2")
    make_reader, DecoderFactory = _decoder()
    from rangemesh.live import run, workers

    monkeypatch.setattr(workers, "cores", lambda: 2)
    got = {}
    for threads in ("1", "2"):
        monkeypatch.setenv("RANGEMESH_THREADS", threads)
        out = tmp_path / threads
        loops = 3
        s = run(shared_data / REALSENSE, kind=reader, pace="fast", loop=True,
                frames=2 * loops, outputs=[out / "live.mcap", out / "meshes"], quiet=True)
        assert (s["frames_in"], s["frames_out"], s["dropped"]) == (2 * loops, 2 * loops, 0)
        with open(out / "live.mcap", "rb") as fh:
            scenes = [d.entities[0] for _, _, _, d in make_reader(
                fh, decoder_factories=[DecoderFactory()]).iter_decoded_messages(
                topics=["/rangemesh/mesh"])]
        files = sorted((out / "meshes").glob("*.ply"))
        got[threads] = ([(e.timestamp.seconds * 10**9 + e.timestamp.nanos,
                          np.array([[p.x, p.y, p.z] for p in e.triangles[0].points]),
                          np.reshape(e.triangles[0].indices, (-1, 3))) for e in scenes],
                        {p.name: p.read_bytes() for p in files})
    want = _expected_meshes(shared_data)
    stamps = sorted(want)
    for threads, (scenes, files) in got.items():
        assert [s for s, _, _ in scenes] == stamps * loops, threads  # in the recording's order
        for stamp, vertices, faces in scenes:
            assert np.array_equal(vertices, want[stamp].vertices), threads
            assert np.array_equal(faces, want[stamp].faces), threads
        assert len(files) == 2 * loops
    assert got["1"][1] == got["2"][1]  # the same files, byte for byte


def test_the_status_line_gives_the_rates_drops_and_latency_unless_quiet(shared_data, tmp_path):
    import io

    from rangemesh.live import run

    said = io.StringIO()
    s = run(shared_data / REALSENSE, kind="ros", pace="fast", vertices=300,
            outputs=[tmp_path / "m"], status_stream=said)
    line = said.getvalue().splitlines()[-1]  # not a terminal: whole lines, the last one forced
    assert re.fullmatch(r"in \d+\.\d/s  out \d+\.\d/s  frames 2  dropped 0  "
                        r"latency \d+ ms \(p95 \d+ ms\)", line), line
    assert (s["frames_in"], s["frames_out"], s["dropped"]) == (2, 2, 0)
    assert s["csv"] == str(tmp_path / "m" / "rangemesh-live.csv")
    quiet = io.StringIO()
    run(shared_data / REALSENSE, kind="ros", pace="fast", vertices=300, quiet=True,
        status_stream=quiet)
    assert quiet.getvalue() == ""


def test_the_foxglove_address_is_host_and_port():
    from rangemesh.live.sinks import parse_address

    # parsing only: nothing binds these addresses (the server tests bind 127.0.0.1:0)
    assert parse_address("0") == ("127.0.0.1", 0)
    assert parse_address("0.0.0.0:8765") == ("0.0.0.0", 8765)
    assert parse_address("[::1]:9000") == ("::1", 9000)
    for bad in ("x", "70000", "host:", "-1"):
        with pytest.raises(ValueError, match="foxglove"):
            parse_address(bad)


def test_live_cli_refuses_a_camera_option_in_one_line(shared_data):
    r = _cli(shared_data / REALSENSE, "--intrinsics", "1,1,1,1")
    assert r.returncode == 2
    assert r.stderr.strip() == ("rangemesh: error: --intrinsics does not apply to live: the camera "
                                "comes from the source (its SDK, or the recording's CameraInfo)")


def test_live_cli_takes_the_mesh_options(shared_data):
    # an option of the other method is refused as `rangemesh mesh` refuses it: the same groups
    r = _cli(shared_data / REALSENSE, "--tiles", "4x4")
    assert r.returncode == 2 and "--tiles" in r.stderr and "--method paper" in r.stderr


def test_an_output_never_replaces_the_source_recording(shared_data, tmp_path):
    # `live x.bag -o x.bag` said only "x.bag: File exists"; `--csv x.bag` replaced the recording
    # with the CSV at the end of the run (issue 42)
    import shutil

    from rangemesh.live import run

    from .rosbag_writer import image_topic, info_topic, mcap_file, write_bag

    bag = tmp_path / "x.bag"
    shutil.copy(shared_data / REALSENSE, bag)
    folder = write_bag(tmp_path / "rec", [image_topic([np.full((48, 64), 900, np.uint16)] * 2,
                                                      "16UC1"),
                                          info_topic(size=(48, 64))], "mcap")
    (tmp_path / "notes.txt").write_text("mine")
    before = {p: p.read_bytes() for p in [bag, tmp_path / "notes.txt", *Path(folder).iterdir()]}
    cases = [
        ((bag, "-o", bag), f"-o {bag} is the source recording {bag}: writing there would "
                           f"replace the recording; write elsewhere"),
        ((bag, "--source", "ros", "-o", bag), f"-o {bag} is the source recording"),
        ((bag, "-o", tmp_path / "m.mcap", "--csv", bag), f"--csv {bag} is the source recording"),
        ((folder, "-o", Path(folder) / "m.mcap"),
         f"-o {Path(folder) / 'm.mcap'} is the source recording {folder} or lies inside it"),
        ((folder, "-o", mcap_file(folder)), f"-o {mcap_file(folder)} is the source recording"),
        ((bag, "-o", tmp_path / "notes.txt"),
         f"-o {tmp_path / 'notes.txt'} is a file: an output is NAME.mcap or a folder"),
        ((bag, "-o", tmp_path / "m.mcap", "--csv", tmp_path / "m.mcap"),
         "--csv " + str(tmp_path / "m.mcap") + " is the MCAP output too"),
    ]
    for argv, says in cases:
        r = _cli(*argv, "--pace", "fast", "--vertices", "300", "--overwrite", "--quiet")
        assert r.returncode == 2
        assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr, r.stderr
        assert r.stderr.startswith(f"rangemesh: error: {says}"), r.stderr
    assert {p: p.read_bytes() for p in [bag, tmp_path / "notes.txt", *Path(folder).iterdir()]} \
        == before
    assert not (tmp_path / "m.mcap").exists()
    with pytest.raises(ValueError, match=r"^csv .* is the source recording"):
        run(bag, csv=bag, pace="fast", quiet=True)


def test_live_cli_takes_the_deviation_targets(shared_data, tmp_path):
    # `live` lacked --max-deviation and --mean-deviation, which `mesh` takes (issue 42: every
    # mesh option of `mesh`); rangemesh.live refused them as unknown options
    r = _cli(shared_data / REALSENSE, "--source", "ros", "--pace", "fast", "--max-deviation",
             "0.02", "-o", tmp_path / "m", "--quiet")
    assert r.returncode == 0, r.stderr
    want = _expected_meshes(shared_data, max_deviation=0.02)
    for stamp, mesh in want.items():
        back = rangemesh.read_mesh(tmp_path / "m" / f"{stamp // 10**9}.{stamp % 10**9:09d}.ply")
        assert np.array_equal(back.faces, mesh.faces)
        assert np.allclose(back.vertices, mesh.vertices)
    got = [m for _, _, m in rangemesh.live(shared_data / REALSENSE, kind="ros", pace="fast",
                                           mean_deviation=0.005)]
    assert len(got) == 2 and all(m.stats.target.kind == "mean_deviation" for m in got)


def test_pacing_module_has_the_wall_clock():
    t0 = pacing.Clock.now()
    pacing.Clock.sleep(0.01)
    assert pacing.Clock.now() - t0 >= 0.009
