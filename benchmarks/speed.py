"""Speed of rangemesh, stage by stage, against pydelatin where it is installed.

    python benchmarks/speed.py [--data ../shared/data] [--repeat 21] [--quick]

Prints (medians over --repeat runs in one warm process, milliseconds):

1. a 200x200 image, 4x4 tiles, 10x10 samples (the paper's example), every
   stage, next to pydelatin asked for the same number of vertices on the same
   image, measured side by side in the same run;
2. a 640x480 depth frame at about 5000 vertices (8x8 tiles, 10x10 samples);
3. 1280x720 and 2048x2048 images at about 5000 and 20000 vertices, with ns
   per pixel and us per vertex, to show how time grows;
4. stage one with workers=1 and workers=2;
5. start-up: ``rangemesh mesh`` on a 200x200 image as a new process with the
   Numba cache warm, and the first run with an empty cache (compilation);
6. peak memory of one meshing, in a fresh process, against the image's size.

Nothing here asserts on time: the machine is shared and noisy, so read the
ratios measured in the same run.
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import rangemesh
from rangemesh import scenes
from rangemesh.io import read_range_image

STAGES = ("prepare", "sampling", "triangulation", "flipping", "total")


def median_ms(fn, repeat):
    fn()
    fn()
    out = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t)
    return 1000 * statistics.median(out)


def stage_medians(img, repeat, **kw):
    runs = []
    rangemesh.triangulate(img, **kw)
    for _ in range(repeat):
        runs.append(rangemesh.triangulate(img, **kw))
    med = {k: 1000 * statistics.median(r.stats.seconds.get(k, 0.0) for r in runs) for k in STAGES}
    return med, runs[-1]


def row(name, med, mesh, extra=""):
    s = mesh.stats
    print(f"| {name} | {s.vertices} | " + " | ".join(f"{med[k]:.2f}" for k in STAGES) + f" | {extra} |")


def header():
    print("| case | vertices | " + " | ".join(STAGES) + " | note |")
    print("|---|---:|" + "---:|" * len(STAGES) + "---|")


def delatin_ms(img, n_points, repeat):
    try:
        from pydelatin import Delatin
    except ImportError:
        return None, "pydelatin not installed (pip install pydelatin)"
    arr = np.ascontiguousarray(img, dtype=np.float32)
    t = median_ms(lambda: Delatin(arr, max_error=0.0, max_points=n_points), repeat)
    got = len(Delatin(arr, max_error=0.0, max_points=n_points).vertices)
    return t, f"{got} vertices"


def image_200(data):
    path = data / "middlebury/venus_disp2.npy"
    if path.exists():
        return np.load(path)[100:300, 100:300].astype(np.float64), None, "venus crop 200x200"
    sc = scenes.pyramid((200, 200))
    return sc.depth, None, "synthetic pyramid 200x200"


def vga(data):
    path = data / "rgbd/pcl_grabber_frame_20121214T142255.814212_depth.tiff"
    if path.exists():
        return read_range_image(path), 0, "PCL boxes 480x640 (Kinect)"
    return scenes.box((480, 640), noise=0.5).depth, None, "synthetic box 480x640"


def big(shape):
    sc = scenes.box(shape, noise=0.3)
    return sc.depth


def startup(tmp, repeat):
    img = tmp / "s200.npy"
    np.save(img, scenes.pyramid((200, 200)).depth)
    cmd = [sys.executable, "-m", "rangemesh", "mesh", str(img), "-o", str(tmp / "s.ply"), "--quiet"]
    subprocess.run(cmd, check=True)  # warm the cache
    warm = []
    for _ in range(repeat):
        t = time.perf_counter()
        subprocess.run(cmd, check=True)
        warm.append(time.perf_counter() - t)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp / "empty-cache"))
    t = time.perf_counter()
    subprocess.run(cmd, check=True, env=env)
    cold = time.perf_counter() - t
    return statistics.median(warm), cold


_MEM_CHILD = """
import sys, numpy as np, rangemesh
from rangemesh import scenes


def kb(field):
    for line in open("/proc/self/status"):
        if line.startswith(field + ":"):
            return int(line.split()[1])


rangemesh.triangulate(scenes.box((64, 64)).depth)   # compile/load kernels first
h, w, n = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
img = scenes.box((h, w), noise=0.3).depth.astype(np.float32)
with open("/proc/self/clear_refs", "w") as fh:       # reset the peak (VmHWM) to now
    fh.write("5")
base = kb("VmRSS")
m = rangemesh.triangulate(img, vertices=n, method="paper")
peak = kb("VmHWM")
print(img.nbytes, (peak - base) * 1024, m.stats.vertices)
"""


def memory(shape, n):
    out = subprocess.run([sys.executable, "-c", _MEM_CHILD, str(shape[0]), str(shape[1]), str(n)],
                         check=True, capture_output=True, text=True).stdout.split()
    return int(out[0]), int(out[1]), int(out[2])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    here = Path(__file__).resolve().parents[1]
    ap.add_argument("--data", type=Path, default=here.parent / "shared" / "data")
    ap.add_argument("--repeat", type=int, default=21)
    ap.add_argument("--quick", action="store_true", help="fewer repeats, skip 2048x2048")
    args = ap.parse_args(argv)
    rep = 5 if args.quick else args.repeat

    print("## 1. 200x200, 4x4 tiles, 10x10 samples (ms)\n")
    header()
    img, bg, name = image_200(args.data)
    med, m = stage_medians(img, rep, background=bg)
    d_ms, note = delatin_ms(img, m.stats.vertices, rep)
    ratio = f"pydelatin {d_ms:.2f} ms for {note}; rangemesh / pydelatin = {med['total'] / d_ms:.2f}" \
        if d_ms else note
    row(name, med, m, ratio)
    for fl in ("error", None):
        med2, m2 = stage_medians(img, rep, background=bg, flips=fl)
        row(f"{name}, flips={fl}", med2, m2)

    print("\n## 2. 640x480 frame, about 5000 vertices (ms)\n")
    header()
    img, bg, name = vga(args.data)
    med, m = stage_medians(img, rep, background=bg, tiles=(8, 8), samples=(10, 10))
    d_ms, note = delatin_ms(np.where(img == 0, np.median(img[img > 0]), img), m.stats.vertices, rep)
    ratio = f"pydelatin {d_ms:.2f} ms for {note} (holes filled with the median)" if d_ms else note
    row(name + ", 8x8 tiles", med, m, ratio)
    med, m = stage_medians(img, rep, background=bg, tiles=(8, 8), samples=(10, 10), workers=2)
    row(name + ", 8x8 tiles, workers=2", med, m)

    print("\n## 3. growth with image size (ms; ns per pixel, us per vertex)\n")
    header()
    sizes = [(480, 640), (720, 1280)] + ([] if args.quick else [(2048, 2048)])
    for shape in sizes:
        im = big(shape)
        for tiles in ((8, 8), (16, 16)):
            med, m = stage_medians(im, max(3, rep // 3), tiles=tiles, samples=(10, 10))
            px = shape[0] * shape[1]
            row(f"synthetic box {shape[0]}x{shape[1]}, tiles {tiles[0]}x{tiles[1]}", med, m,
                f"{1e6 * med['prepare'] / px:.1f} ns/px prepare, "
                f"{1e6 * med['sampling'] / px:.1f} ns/px sampling, "
                f"{1e3 * (med['triangulation'] + med['flipping']) / m.stats.vertices:.2f} us/vertex "
                f"stages 2-3")

    print("\n## 4. stage one alone, workers=1 vs 2 (ms)\n")
    print("| image | tiles, samples | workers=1 | workers=2 | speed-up |")
    print("|---|---|---:|---:|---:|")
    from rangemesh.paper.sampling import sample_grid, sampling_weights
    from rangemesh.pipeline import prepare

    for shape, p in (((480, 640), rangemesh.MeshParams(tiles=8)),
                     ((720, 1280), rangemesh.MeshParams(tiles=16, samples=20))):
        im = big(shape)
        d, v = prepare(im, p)
        w = sampling_weights(d, v, p)
        a = median_ms(lambda d=d, v=v, p=p, w=w: sample_grid(d, v, p, weights=w), rep)
        b = median_ms(lambda d=d, v=v, p=p, w=w: sample_grid(d, v, p, weights=w, workers=2), rep)
        print(f"| {shape[0]}x{shape[1]} | {p.tiles}, {p.samples} | {a:.3f} | {b:.3f} | {a / b:.2f} |")

    print("\n## 5. start-up of `python -m rangemesh mesh` on 200x200 (s)\n")
    with tempfile.TemporaryDirectory() as tmp:
        warm, cold = startup(Path(tmp), 3 if args.quick else 5)
    print(f"warm Numba cache: {warm:.2f} s (median); empty cache, compiling: {cold:.1f} s")

    print("\n## 6. peak memory of one meshing, fresh process\n")
    print("Peak resident memory while meshing (Linux VmHWM, reset just before) minus the resident")
    print("memory before; the image is float32 and the search for `vertices=n` is included.\n")
    print("| image | float32 bytes | peak RSS increase | ratio | vertices |")
    print("|---|---:|---:|---:|---:|")
    cases = (((480, 640), 5000), ((720, 1280), 20000)) + (() if args.quick else (((2048, 2048), 20000),))
    for shape, n in cases:
        nbytes, inc, nv = memory(shape, n)
        print(f"| {shape[0]}x{shape[1]} | {nbytes / 1e6:.1f} MB | {inc / 1e6:.1f} MB | "
              f"{inc / nbytes:.1f}x | {nv} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
