"""rangemesh live's speed: frames/s in and out, drops, latency and frames per CPU second.

Run ``python benchmarks/live.py`` (``--pace fast,30,recorded``, ``--threads 1,2``,
``--frames N``, ``--repeat K``, ``--only realsense|ros|ouster``, ``--sink none|mcap``,
``--stages``, ``--per-thread``).
Each run plays a recording looped (the RealSense bag holds 2 depth frames, the
Ouster pcap 3 scans) through `rangemesh.live.run` at the default target until
``--frames`` meshes are published (to an MCAP file with ``--sink mcap``, the
Foxglove server's messages). A looped RealSense recording is decoded by
pyrealsense2 on its first pass only; later passes replay the decoded frames
from memory (`rangemesh.live.sources.REPLAY_BYTES`), so the ``realsense`` rows
measure the SDK's opening and first pass, not its decoding of every frame:
``--sdk-every-pass`` has the SDK play every pass (as a recording longer than
the replay's memory is played). The sources: ``realsense``, the shared RealSense
SDK bag played by pyrealsense2; ``ros``, the same bag read as a ROS bag (the
ROS reader, ``--source ros``); ``ouster``, the Ouster pcap with its metadata.

For each source, pace and thread count (``RANGEMESH_THREADS``, set in this
process before the run: `rangemesh.threads` reads it at each call) it
prints the medians over the runs of what the session records
(`rangemesh.live.stats.Stats.summary`): frames/s in and out, frames dropped,
the latency from a frame's release by the playback clock to its publication
(median and 95th percentile), and frames per CPU second (frames out over the
process's `time.process_time`, every thread counted, which a loaded machine
slows less than the wall clock), the median meshing time and the median time
to build and write a frame's messages (``publish_ms``). The machine's load
(1-minute average) is printed before and after each configuration. Under
``taskset -c 0`` the process may use one core, so two threads give one. A
thread count above one meshes that many frames at once (`rangemesh.live.workers`).

``--per-thread`` also prints each thread's CPU time a frame, its median over the runs
(`thread_cpu`): the caller's thread (publishing, and with one thread everything), the frame
workers, the read-ahead thread; a thread's share of the GIL-held Python shows there, which
the load slows less than the wall clock.

``--stages`` first measures each stage's CPU time a frame on one thread (`stages`:
read, mesh, build, write, and the process's CPU a frame), which the load slows
less than the wall clock, and the frames/s two workers on two cores could reach
from them: the process's CPU a frame spread over two cores, unless meshing on two
workers or the stages one thread does for every frame (read, build, write) take
longer.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import io
import os
import re
import resource
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path

from rangemesh.live import run

HERE = Path(__file__).resolve().parent
DATA = Path(os.environ.get("RANGEMESH_DATA", HERE.parent.parent / "shared" / "data"))
BAG = "librealsense_d435_single_depth_color_640x480.bag"


def _sources(data: Path) -> dict:
    bag = data / "rosbag" / BAG
    return {
        "realsense": (bag, {"kind": "realsense"}),
        "ros": (bag, {"kind": "ros"}),
        "ouster": (data / "lidar" / "OS-1-128_v2.3.0_1024x10_lb_n3.pcap",
                   {"meta": data / "lidar" / "OS-1-128_v2.3.0_1024x10.json"}),
    }


def _available(name: str) -> str | None:
    """Why a source cannot run here (its SDK is missing), or None."""
    module = {"realsense": "pyrealsense2", "ouster": "ouster.sdk", "ros": "rosbags"}[name]
    try:
        __import__(module)
    except ImportError as exc:
        return f"{module} is not installed ({exc})"
    return None


def _load() -> str:
    return f"{os.getloadavg()[0]:.1f}"


def _cpu(usage) -> float:
    return usage.ru_utime + usage.ru_stime


@contextlib.contextmanager
def thread_cpu(into: dict):
    """Each thread's CPU seconds within the block, by name (numbered names summed): ``into``.

    The caller's thread by `resource.getrusage` before and after; every thread
    started within, at its end (`threading.Thread.run` wrapped for the
    block). Threads the SDKs start themselves are not counted (the process's
    CPU, frames per CPU s, counts them).
    """
    run_thread = threading.Thread.run
    lock = threading.Lock()

    def counted(self):
        try:
            run_thread(self)
        finally:
            used = _cpu(resource.getrusage(resource.RUSAGE_THREAD))
            with lock:
                name = re.sub(r"_\d+$", "", self.name)
                into[name] = into.get(name, 0.0) + used

    threading.Thread.run = counted
    start = _cpu(resource.getrusage(resource.RUSAGE_THREAD))
    try:
        yield into
    finally:
        threading.Thread.run = run_thread
        into["caller"] = _cpu(resource.getrusage(resource.RUSAGE_THREAD)) - start


def one_run(path, kw, pace, frames, sink) -> dict:
    """One live run: its summary, frames per CPU second, the CSV's median times, each thread's CPU."""
    threads: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        out = [Path(tmp) / "live.mcap"] if sink == "mcap" else []
        table = Path(tmp) / "live.csv"
        c0 = time.process_time()
        with thread_cpu(threads):
            s = run(path, outputs=out, csv=table, quiet=True, pace=pace, loop=True,
                    frames=frames, status_stream=io.StringIO(), **kw)
        cpu = time.process_time() - c0
        rows = list(csv.DictReader(table.open()))
    s["thread_ms"] = {k: 1e3 * v / s["frames_out"] for k, v in threads.items()}
    s["cpu_fps"] = s["frames_out"] / cpu
    s["mesh_ms"] = statistics.median(float(r["mesh_ms"]) for r in rows)
    s["publish_ms"] = statistics.median(float(r["publish_ms"]) for r in rows)
    return s


def stages(path, kw, frames) -> dict:
    """CPU milliseconds a frame of each stage, on one thread, one after the other.

    ``read`` (the source's next frame: the SDK's playback or the ROS reader,
    decoding included), ``mesh`` (`triangulate` at the default target, one
    native thread), ``build`` (the SceneUpdate's bytes) and ``write`` (logging
    the frame's messages to an MCAP file, less ``build``) are this thread's
    `time.thread_time`; ``process`` is the process's `time.process_time` a
    frame, every thread (an SDK's own) counted. Medians over `frames` frames
    after 4 left out (warm-up).
    """
    from rangemesh.live.messages import scene_update_bytes
    from rangemesh.live.session import _open
    from rangemesh.live.sinks import FoxgloveChannels
    from rangemesh.pipeline import triangulate
    from rangemesh.prepare import NONPOSITIVE
    from rangemesh.recordings.ouster import with_offsets

    os.environ["RANGEMESH_THREADS"] = "1"
    call, _, src = _open(path, kw.get("kind"), kw.get("meta"), None, "fast", True, None, 1,
                         "refine", None, None, {})
    if getattr(src, "wraps", False):
        call = {**call, "wrap": True}
    clock = time.thread_time
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        fox = FoxgloveChannels(None, Path(tmp) / "stages.mcap")
        it = src.frames()
        try:
            for _ in range(frames + 4):
                p0, t0 = time.process_time(), clock()
                frame = next(it)
                t1 = clock()
                mesh = with_offsets(triangulate(frame.depth, background=NONPOSITIVE,
                                                camera=frame.camera, **call), frame.offsets)
                t2 = clock()
                scene_update_bytes(mesh.vertices, mesh.faces, frame.stamp, frame.frame_id,
                                   mesh.colors)
                t3 = clock()
                fox.publish(frame.stamp, frame.frame_id, mesh, frame.depth.shape)
                t4 = clock()
                rows.append((t1 - t0, t2 - t1, t3 - t2, (t4 - t3) - (t3 - t2),
                             time.process_time() - p0))
        finally:
            fox.close()
            src.close()
    rows = rows[4:]
    return {k: 1e3 * statistics.median(r[i] for r in rows)
            for i, k in enumerate(("read", "mesh", "build", "write", "process"))}


def _median(runs, key):
    return statistics.median(r[key] for r in runs)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DATA)
    ap.add_argument("--frames", type=int, default=60, help="meshes published a run")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", choices=["realsense", "ros", "ouster"], action="append",
                    default=None, help="a source (may be given again; default all)")
    ap.add_argument("--pace", default="fast", help="comma-separated: fast, recorded, N frames/s")
    ap.add_argument("--threads", default=None,
                    help="comma-separated RANGEMESH_THREADS values (default: as the "
                         "environment says)")
    ap.add_argument("--sink", choices=["none", "mcap"], default="mcap")
    ap.add_argument("--sdk-every-pass", action="store_true",
                    help="pyrealsense2 plays every pass of the looped RealSense bag (no replay "
                         "from memory): measures its decoding of every frame")
    ap.add_argument("--per-thread", action="store_true",
                    help="also each thread's CPU ms a frame (the caller's, the workers', the "
                         "read-ahead's), medians over the runs")
    ap.add_argument("--stages", action="store_true",
                    help="also each stage's CPU ms a frame on one thread (read, mesh, build, "
                         "write) and the frames/s two workers could reach from them")
    args = ap.parse_args(argv)
    if args.sdk_every_pass:
        from rangemesh.live import sources

        sources.REPLAY_BYTES = 0  # nothing kept: the SDK decodes every pass
    paces = [p.strip() for p in args.pace.split(",")]
    threads = args.threads.split(",") if args.threads else [os.environ.get("RANGEMESH_THREADS")]
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    print(f"{args.frames} meshes a run, medians of {args.repeat}, sink {args.sink}, "
          f"{cores} core(s) allowed, RealSense passes after the first "
          f"{'played by the SDK' if args.sdk_every_pass else 'replayed from memory'}, "
          f"load {_load()}")
    print("source     pace      thr  in/s   out/s  dropped  lat p50 ms  lat p95 ms  "
          "frames/CPU s  mesh ms  msg ms  load")
    for name, (path, kw) in _sources(args.data).items():
        if args.only and name not in args.only:
            continue
        why = _available(name)
        if why is not None:
            print(f"{name}: skipped, {why}")
            continue
        if args.stages:
            before = _load()
            st = [stages(path, kw, args.frames) for _ in range(args.repeat)]
            ms = {k: statistics.median(r[k] for r in st) for k in st[0]}
            serial = ms["read"] + ms["build"] + ms["write"]
            # two workers on two cores: the CPU a frame over both, or the longest one-thread stage
            bound = min(2e3 / ms["process"], 1e3 / max(ms["mesh"] / 2, serial))
            print(f"{name:<10} stages (CPU ms a frame, one thread): read {ms['read']:.2f}  "
                  f"mesh {ms['mesh']:.2f}  build {ms['build']:.2f}  write {ms['write']:.2f}  "
                  f"process {ms['process']:.2f}: one core {1e3 / ms['process']:.1f} frames/s, "
                  f"two workers at most {bound:.1f}  load {before}-{_load()}", flush=True)
        for pace in paces:
            for t in threads:
                if t is None:
                    os.environ.pop("RANGEMESH_THREADS", None)
                else:
                    os.environ["RANGEMESH_THREADS"] = t
                before = _load()
                runs = [one_run(path, kw, pace, args.frames, args.sink)
                        for _ in range(args.repeat)]
                lat50 = _median(runs, "latency_median_ms")
                lat95 = _median(runs, "latency_p95_ms")
                drops = [r["dropped"] for r in runs]
                outs = ", ".join(f"{r['fps_out']:.1f}" for r in runs)
                print(f"{name:<10} {pace:<9} {t or '-':>3} {_median(runs, 'fps_in'):6.1f} "
                      f"{_median(runs, 'fps_out'):6.1f}  {statistics.median(drops):7.0f}  "
                      f"{lat50:10.1f}  {lat95:10.1f}  {_median(runs, 'cpu_fps'):12.1f}  "
                      f"{_median(runs, 'mesh_ms'):7.1f}  {_median(runs, 'publish_ms'):6.2f}  "
                      f"{before}-{_load()}  (runs out/s: {outs}; dropped: "
                      f"{', '.join(map(str, drops))})", flush=True)
                if args.per_thread:
                    names = sorted({k for r in runs for k in r["thread_ms"]})
                    per = {k: statistics.median(r["thread_ms"].get(k, 0.0) for r in runs)
                           for k in names}
                    print("           CPU ms a frame by thread: " + ", ".join(
                        f"{k} {v:.2f}" for k, v in per.items()), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
