"""rangemesh live's throughput: frames/s meshed and published from the real recordings at --pace fast.

Run ``RANGEMESH_THREADS=1 taskset -c 0 python benchmarks/live.py`` (``--frames N``,
``--repeat K``, ``--only realsense|ouster``, ``--sink none|mcap``). Each run
plays a recording looped (the RealSense bag holds 2 depth frames, the Ouster
pcap 3 scans) through `rangemesh.live.run` at the default target, every
frame meshed and, with ``--sink mcap``, published to an MCAP file (the
Foxglove server's messages). It prints frames/s by the wall clock and per CPU second
(`time.process_time`, which a loaded machine does not slow; medians of the runs),
the median meshing time and the median time to build and write a
frame's messages (``publish_ms``), as a share of the frame's time.
"""

from __future__ import annotations

import argparse
import csv
import io
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from rangemesh.live import run

HERE = Path(__file__).resolve().parent
DATA = Path(os.environ.get("RANGEMESH_DATA", HERE.parent.parent / "shared" / "data"))


def _sources(data: Path) -> dict:
    return {
        "realsense": (data / "rosbag" / "librealsense_d435_single_depth_color_640x480.bag", {}),
        "ouster": (data / "lidar" / "OS-1-128_v2.3.0_1024x10_lb_n3.pcap",
                   {"meta": data / "lidar" / "OS-1-128_v2.3.0_1024x10.json"}),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DATA)
    ap.add_argument("--frames", type=int, default=60)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", choices=["realsense", "ouster"], default=None)
    ap.add_argument("--sink", choices=["none", "mcap"], default="mcap")
    args = ap.parse_args(argv)
    for name, (path, kw) in _sources(args.data).items():
        if args.only and name != args.only:
            continue
        fps, cpu_fps, mesh_ms, pub_ms = [], [], [], []
        for _ in range(args.repeat):
            with tempfile.TemporaryDirectory() as tmp:
                out = [Path(tmp) / "live.mcap"] if args.sink == "mcap" else []
                table = Path(tmp) / "live.csv"
                c0 = time.process_time()
                s = run(path, outputs=out, csv=table, quiet=True, pace="fast", loop=True,
                        frames=args.frames, status_stream=io.StringIO(), **kw)
                cpu = time.process_time() - c0
                rows = list(csv.DictReader(table.open()))
            fps.append(s["fps_out"])
            cpu_fps.append(s["frames_out"] / cpu)
            mesh_ms.append(statistics.median(float(r["mesh_ms"]) for r in rows))
            pub_ms.append(statistics.median(float(r["publish_ms"]) for r in rows))
        m, p = statistics.median(mesh_ms), statistics.median(pub_ms)
        print(f"{name}: {statistics.median(fps):.1f} frames/s (runs: "
              f"{', '.join(f'{x:.1f}' for x in fps)}; per CPU second "
              f"{statistics.median(cpu_fps):.1f}), mesh {m:.1f} ms, messages {p:.2f} ms "
              f"({100 * p / (m + p):.1f} % of a frame), {args.frames} frames a run, sink "
              f"{args.sink}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
