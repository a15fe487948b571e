"""Vertex-count and error-bound targets: what was asked, what came, what it cost.

    python benchmarks/targets.py [--data ../shared/data] [--repeat 5]

For each image: a plain meshing at the paper's grid (4x4 tiles, 10x10 samples)
as the time unit, then ``vertices=N`` and ``max_error=E`` targets with the
achieved figure, the number of full meshings the search used and its median
time as a multiple of the plain meshing, measured side by side in one process.
"""

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import rangemesh

IMAGES = [
    ("odetics/chair-range.npy", 0),
    ("middlebury/venus_disp2.npy", None),
    ("rgbd/pcl_grabber_frame_20121214T142255.814212_depth.tiff", 0),
    ("rgbd/open3d_TUM_depth.png", 0),
]


def load(path):
    if path.suffix == ".npy":
        return np.load(path)
    return rangemesh.io.read_range_image(path)


def timed(fn, repeat):
    fn()  # warm: compiled kernels, caches
    times, out = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    here = Path(__file__).resolve().parents[1]
    ap.add_argument("--data", type=Path, default=here.parent / "shared" / "data")
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    import rangemesh.io  # noqa: F401

    print("| image | target | achieved | vertices | meshings | median ms | one meshing of that grid, ms "
          "| ratio |")
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    for rel, bg in IMAGES:
        path = args.data / rel
        if not path.exists():
            print(f"skipping {rel}: not found", file=sys.stderr)
            continue
        img = load(path)
        plain, m = timed(lambda img=img, bg=bg: rangemesh.triangulate(img, background=bg,
                                                                      method="paper"), args.repeat)
        e = rangemesh.evaluate(m, img, background=bg).relative_error
        name = Path(rel).name[:28]
        print(f"| {name} | plain 4x4 tiles, 10x10 samples | {e:.3f} % | {m.stats.vertices} | 1 "
              f"| {1000 * plain:.1f} | {1000 * plain:.1f} | 1.0 |")
        targets = [{"vertices": n} for n in (1000, 5000, 20000)]
        targets += [{"max_error": x} for x in (1.0, 0.5)]
        for kw in targets:
            t, m = timed(lambda img=img, bg=bg, kw=kw: rangemesh.triangulate(
                img, background=bg, method="paper", **kw), args.repeat)
            s = m.stats.target
            ach = s.achieved
            ach = f"{ach:.3f} %" if isinstance(ach, float) else f"{ach}"
            (k, v), = kw.items()
            flag = "" if s.met else " (not met: " + s.note + ")"
            grid = {"tiles": tuple(s.tiles), "samples": tuple(s.samples)}
            if tuple(s.tiles) == (1, 1):
                grid["sampling"] = "uniform"  # full resolution
            one, _ = timed(lambda img=img, bg=bg, g=grid: rangemesh.triangulate(
                img, background=bg, method="paper", **g),
                           args.repeat)
            print(f"| {name} | {k}={v} | {ach}{flag} | {m.stats.vertices} | {s['meshings']} "
                  f"| {1000 * t:.1f} | {1000 * one:.1f} | {t / one:.1f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
