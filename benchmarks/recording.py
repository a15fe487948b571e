"""Frames per second of meshing a ROS recording, against the time to decode its frames alone.

    python benchmarks/recording.py [--frames 60] [--share 0.01] [--compressed]

Writes a ROS 2 recording (MCAP storage, `rosbags`' writer) of --frames 640x480
16UC1 depth frames in millimetres, with a CameraInfo: the shared RGB-D frames
(slambook2 ch7 and Open3D's TUM frame, both 1/5000 m; slambook2 ch5 and the
PCL grabber frame in mm; the two RealSense frames), in turn, each with a
little noise (+-4 mm), so that no two frames are the same; with --compressed as
image_transport's compressedDepth (PNG) messages. Then it times:

* decoding: reading every frame (header, CameraInfo match) and decoding its
  depth, nothing else;
* one process: ``mesh_recording(..., workers=1)``, frames meshed at --share of
  the valid pixels (``vertices=``: the mean valid count of the frames times the
  share), evaluated, and written as markers into an MCAP file; with refine's
  two strip threads (the default) and with one (``RANGEMESH_THREADS=1``, as a
  Dask worker runs);
* a local Dask cluster of 2 workers, started (and warmed on a few frames)
  before the clock starts, the same batch through ``scheduler=``.

Prints a Markdown table; the decode share is decoding's time over one
process's whole time (target: at most 10 %).
"""

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from rosbag_writer import T0, compressed_depth, image_topic, info_topic, write_bag  # noqa: E402

from rangemesh.recordings import Recording, mesh_recording  # noqa: E402
from rangemesh.recordings.decode import depth_image  # noqa: E402

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def sources() -> list[np.ndarray]:
    """The shared 640x480 depth frames, in millimetres (uint16, 0 = missing)."""
    import imageio.v3 as iio
    import tifffile

    tum = [np.asarray(iio.imread(DATA / "rgbd" / n)) for n in
           ("slambook2_ch7_1_depth.png", "open3d_TUM_depth.png")]
    out = [np.where(t > 0, np.maximum(np.round(t / 5.0), 1), 0).astype(np.uint16) for t in tum]
    out.append(np.load(DATA / "rgbd" / "slambook2_ch5_depth_1.npy").astype(np.uint16))
    out.append(tifffile.imread(DATA / "rgbd" / "pcl_grabber_frame_20121214T142255.814212_depth.tiff")
               .astype(np.uint16))
    from rosbags.highlevel import AnyReader

    with AnyReader([DATA / "rosbag" / "librealsense_d435_single_depth_color_640x480.bag"]) as r:
        conns = [c for c in r.connections if c.topic.endswith("Depth_0/image/data")]
        for c, _, raw in r.messages(connections=conns):
            m = r.deserialize(raw, c.msgtype)
            out.append(np.frombuffer(m.data.tobytes(), "<u2").reshape(480, 640).copy())
    return out


def make_recording(path: Path, n: int, compressed: bool = False) -> tuple[Path, int]:
    """The recording and the vertex count per frame (the share of the mean valid pixels)."""
    rng = np.random.default_rng(0)
    base = sources()
    frames = []
    for i in range(n):
        d = base[i % len(base)].astype(np.int32)
        noisy = np.clip(d + rng.integers(-4, 5, d.shape), 1, 65535)
        frames.append(np.where(d > 0, noisy, 0).astype(np.uint16))
    valid = float(np.mean([(f > 0).sum() for f in frames]))
    if compressed:  # image_transport's compressedDepth: 12-byte header + 16-bit PNG
        payloads = [compressed_depth(f, "16UC1") for f in frames]
        topic = image_topic([p[1] for p in payloads], payloads[0][0], "/camera/depth/compressedDepth")
        topic.kind = "compressed"
    else:
        topic = image_topic(frames, "16UC1")
    # one K for all: which camera is right for each source does not change the timing
    write_bag(path, [topic, info_topic(stamps=[T0])], "mcap")
    return path, valid


def decode_all(path: Path) -> tuple[float, int]:
    t0 = time.perf_counter()
    n = 0
    with Recording(path) as rec:
        for f in rec.frames():
            depth_image(f.depth)
            n += 1
    return time.perf_counter() - t0, n


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=60)
    ap.add_argument("--share", type=float, default=0.01)
    ap.add_argument("--compressed", action="store_true",
                    help="the depth as compressedDepth (PNG) messages instead of raw 16UC1")
    args = ap.parse_args(argv)
    from dask.distributed import LocalCluster

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        bag, valid = make_recording(tmp / "in", args.frames, args.compressed)
        vertices = int(round(args.share * valid))
        decode_all(bag)  # warm the imports and the file cache
        decode_s, n = decode_all(bag)
        rows = []
        t0 = time.perf_counter()
        res = mesh_recording(bag, tmp / "one.mcap", workers=1, vertices=vertices)
        one_s = time.perf_counter() - t0
        rows.append(("1 process (refine's 2 strip threads)", one_s, res))
        os.environ["RANGEMESH_THREADS"] = "1"  # one core, as each Dask worker has
        t0 = time.perf_counter()
        res = mesh_recording(bag, tmp / "one-thread.mcap", workers=1, vertices=vertices)
        rows.append(("1 process, 1 thread", time.perf_counter() - t0, res))
        del os.environ["RANGEMESH_THREADS"]
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                          dashboard_address=None, silence_logs=40,
                          env={"RANGEMESH_THREADS": "1"}) as cluster:
            warm = tmp / "warm"
            mesh_recording(bag, warm, scheduler=cluster.scheduler_address, vertices=vertices)
            t0 = time.perf_counter()
            res = mesh_recording(bag, tmp / "two.mcap", scheduler=cluster.scheduler_address,
                                 vertices=vertices)
            rows.append(("Dask, 2 workers", time.perf_counter() - t0, res))
        kind = "compressedDepth (PNG)" if args.compressed else "16UC1"
        print(f"{n} frames 640x480 {kind} (MCAP), {vertices} vertices per frame "
              f"({100 * args.share:g} % of the mean {valid:.0f} valid pixels)\n")
        print("| run | wall s | frames/s | median s per frame in the task | failed |")
        print("|---|---:|---:|---:|---:|")
        print(f"| decode only | {decode_s:.2f} | {n / decode_s:.1f} | | |")
        for name, wall, res in rows:
            done = [r for r in res if r.status == "meshed"]
            med = float(np.median([r.seconds for r in done])) if done else float("nan")
            print(f"| {name} | {wall:.2f} | {len(done) / wall:.2f} | {med:.3f} | "
                  f"{len(res) - len(done)} |")
        print(f"\ndecoding: {100 * decode_s / one_s:.1f} % of the one-process time, "
              f"{100 * decode_s / rows[-1][1]:.1f} % of the 2-worker time (target: at most 10 %)")


if __name__ == "__main__":
    main()
