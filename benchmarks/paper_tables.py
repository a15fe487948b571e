"""Figures in the shape of the paper's Tables I-III, on real images of ../shared/data.

For each image and method: sampled points, vertices, edges, triangles, flipped
edges, median time per stage over several runs (warm process; Numba compiled
before timing) and the paper's relative error.

    python benchmarks/paper_tables.py [--data ../shared/data] [--repeat 7]

Prints a markdown table. Times are wall-clock medians; the machine is shared
and noisy, so compare rows measured in the same run only.
"""

import argparse
import statistics
import sys
from pathlib import Path

import numpy as np

import rangemesh

IMAGES = [
    # (file, background, note)
    ("odetics/chair-range.npy", 0, "laser range finder, 128x128"),
    ("middlebury/venus_disp2.npy", None, "piecewise planar, 383x434"),
    ("rgbd/pcl_grabber_frame_20121214T142255.814212_depth.tiff", 0, "boxes, Kinect, 480x640"),
]

METHODS = [
    ("adaptive + disparity flips", dict(sampling="adaptive", flips="disparity")),
    ("adaptive + error flips", dict(sampling="adaptive", flips="error")),
    ("uniform + error flips", dict(sampling="uniform", flips="error")),
    ("uniform, no flips", dict(sampling="uniform", flips=None)),
]


def load(path):
    if path.suffix == ".npy":
        return np.load(path)
    if path.suffix in (".tif", ".tiff"):
        import tifffile

        return tifffile.imread(path)
    import imageio.v3 as iio

    return iio.imread(path)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    here = Path(__file__).resolve().parents[1]
    ap.add_argument("--data", type=Path, default=here.parent / "shared" / "data")
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--tiles", default="4x4")
    ap.add_argument("--samples", default="10x10")
    args = ap.parse_args(argv)
    tiles = tuple(int(x) for x in args.tiles.split("x"))
    samples = tuple(int(x) for x in args.samples.split("x"))
    print(f"tiles {tiles}, samples {samples}; median of {args.repeat} runs, times in ms\n")
    print("| image | method | sampled | vertices | edges | triangles | flipped | sampling "
          "| triangulation | flipping | total | rel. error % | edge-band % |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for rel, bg, _note in IMAGES:
        path = args.data / rel
        if not path.exists():
            print(f"skipping {rel}: not found under {args.data}", file=sys.stderr)
            continue
        img = load(path)
        for name, kw in METHODS:
            rangemesh.triangulate(img, background=bg, method="paper", tiles=tiles,
                                  samples=samples, **kw)
            runs = [rangemesh.triangulate(img, background=bg, method="paper", tiles=tiles,
                                          samples=samples, **kw)
                    for _ in range(args.repeat)]
            m = runs[-1]
            med = {k: 1000 * statistics.median(r.stats.seconds[k] for r in runs)
                   for k in ("sampling", "triangulation", "flipping", "total")}
            e = rangemesh.evaluate(m, img, background=bg)
            s = m.stats
            print(f"| {Path(rel).name} | {name} | {s.sampled_points} | {s.vertices} | {s.edges} "
                  f"| {s.triangles} | {s.flipped_edges} | {med['sampling']:.2f} "
                  f"| {med['triangulation']:.2f} | {med['flipping']:.2f} | {med['total']:.2f} "
                  f"| {e.relative_error:.3f} | {e.edge_band_error:.3f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
