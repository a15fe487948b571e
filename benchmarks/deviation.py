"""method="refine" under error bounds in metres: ``max_deviation=D`` on the LiDAR scan and depth frames.

Run ``python benchmarks/deviation.py`` (``--repeat K``, ``--help``). For the
RELLIS OS1-64 scan (`Spherical.from_beams`) and two 640 x 480 Kinect frames
(`Pinhole` with their intrinsics, metres), at a few bounds D, it prints the
vertices, the meshings the search ran, the largest deviation measured by
`rangemesh.evaluate` (metres, every covered valid pixel) and the CPU time of
the whole `triangulate` call (``time.process_time``, the median of
``--repeat`` calls interleaved over the cases), beside the default target's
figures. For a quiet measure pin the process to one core and one thread:
``RANGEMESH_THREADS=1 taskset -c 0 python benchmarks/deviation.py``; the load
(``os.getloadavg``) and the commit are printed.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import rangemesh
from rangemesh import Pinhole, Spherical, evaluate, triangulate
from rangemesh.io import read_range_image

DATA = Path(os.environ.get("RANGEMESH_DATA", Path(__file__).resolve().parents[1].parent / "shared" / "data"))
# (name, file, camera, bounds in metres); the TUM frames are in 1/5000 m (data README)
TUM = Pinhole(525.0, 525.0, 319.5, 239.5, depth_scale=1 / 5000)


def cases():
    scan = DATA / "lidar" / "rellis3d_os1-64_000000"
    yield ("RELLIS OS1-64 64x2048", np.load(f"{scan}.range.npy"),
           Spherical.from_beams(f"{scan}.beams.json"), (0.05, 0.02))
    for name in ("open3d_TUM_depth.png", "slambook2_ch7_1_depth.png"):
        yield (f"{name} 480x640", read_range_image(DATA / "rgbd" / name), TUM, (0.05, 0.02, 0.01))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--repeat", type=int, default=3, help="calls per case (median), default 3")
    args = p.parse_args(argv)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True, cwd=Path(__file__).parent).stdout.strip()
    print(f"rangemesh {rangemesh.__version__} at {commit or '?'}; load {os.getloadavg()[0]:.2f}; "
          f"RANGEMESH_THREADS={os.environ.get('RANGEMESH_THREADS', 'unset')}")
    runs = [(name, image, cam, d) for name, image, cam, bounds in cases()
            for d in (None, *bounds)]
    times = {i: [] for i in range(len(runs))}
    meshes = {}
    for _ in range(args.repeat):  # interleaved: each repeat visits every case once
        for i, (_name, image, cam, d) in enumerate(runs):
            kw = {} if d is None else {"max_deviation": d}
            t = time.process_time()
            meshes[i] = triangulate(image, camera=cam, **kw)
            times[i].append(time.process_time() - t)
    print(f"{'image':32s} {'target':>16s} {'vertices':>9s} {'valid':>7s} {'meshings':>8s} "
          f"{'max dev m':>10s} {'mean dev m':>10s} {'CPU s':>7s}")
    for i, (name, image, _cam, d) in enumerate(runs):
        m = meshes[i]
        ev = evaluate(m, image)
        target = "default" if d is None else f"max_dev {d:g} m"
        print(f"{name:32s} {target:>16s} {m.stats.vertices:9d} {ev.valid_pixels:7d} "
              f"{m.stats.target.meshings:8d} {ev.max_deviation:10.4f} {ev.mean_deviation:10.4f} "
              f"{statistics.median(times[i]):7.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
