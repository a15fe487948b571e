"""Peak memory of meshing a large image, as a multiple of the image's own size.

Each case runs in a fresh process (so peaks do not mix) on a synthetic scene
upscaled to N x N float32 with 2 % random holes, as in the hostile-input
report. The figure is the child's peak resident set size (``ru_maxrss``)
minus the same process's peak after importing everything and loading the
image, divided by the image's bytes.

``--refine`` measures ``method="refine"`` instead, at vertex counts and error
bounds, and fits the peak as bytes per pixel plus bytes per vertex of the mesh
(least squares over the cases): the figures of
`rangemesh.pipeline.REFINE_BYTES_PER_PIXEL` and ``REFINE_BYTES_PER_VERTEX``.

    python benchmarks/memory.py [--size 4000] [--method paper]
    python benchmarks/memory.py --refine [--size 2000] [--vertices 20000,200000,1000000]
                                [--max-error 0.01,0.001]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

CHILD = r"""
import json, resource, sys, time
import numpy as np
import rangemesh, rangemesh.cli, rangemesh.preview, matplotlib.figure, scipy.ndimage
path, case, method = sys.argv[1], sys.argv[2], sys.argv[3]
img = np.load(path)
rangemesh.triangulate(img[:64, :64], background=0)   # compile/load kernels on a small image
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
t0 = time.perf_counter()
vertices = None
if case.startswith("refine:"):
    key, value = case[len("refine:"):].split("=")
    target = {"vertices": int(value)} if key == "vertices" else {"max_error": float(value)}
    vertices = len(rangemesh.triangulate(img, background=0, **target).vertices)
elif case == "triangulate":
    rangemesh.triangulate(img, background=0, method=method)
elif case == "evaluate":
    m = rangemesh.triangulate(img, background=0, method=method)
    rangemesh.evaluate(m, img, background=0)
else:
    out = str(path) + ".ply"
    argv = ["mesh", path, "-o", out, "--background", "0", "--quiet", "--method", method]
    if case == "cli+preview":
        argv += ["--preview", str(path) + ".png"]
    assert rangemesh.cli.main(argv) == 0
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(json.dumps({"case": case, "seconds": time.perf_counter() - t0, "extra_bytes": peak - base,
                  "image_bytes": img.nbytes, "pixels": img.size, "vertices": vertices}))
"""


def make_image(n: int, path: Path):
    import numpy as np

    from rangemesh import scenes

    small = scenes.make("box", (n // 8, n // 8)).depth.astype(np.float32) + 100
    img = np.kron(small, np.ones((8, 8), np.float32))
    rng = np.random.default_rng(0)
    img[rng.random(img.shape) < 0.02] = 0
    np.save(path, img)


def _run(path, case, method="refine"):
    out = subprocess.run([sys.executable, "-c", CHILD, str(path), case, method], check=True,
                         capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def refine_cases(path, vertices, errors):
    """Peak of `method="refine"` per case, and its fit as bytes a pixel plus bytes a vertex."""
    import numpy as np

    rows = []
    cases = [f"refine:vertices={n}" for n in vertices] + [f"refine:max_error={e}" for e in errors]
    for case in cases:
        r = _run(path, case)
        rows.append((r["pixels"], r["vertices"], r["extra_bytes"]))
        print(f"{case:26s} {r['seconds']:6.1f} s  {r['vertices']:9d} vertices  peak above "
              f"baseline {r['extra_bytes'] / 2**20:7.0f} MiB = "
              f"{r['extra_bytes'] / r['pixels']:6.1f} B a pixel")
    px, nv, extra = (np.array(x, np.float64) for x in zip(*rows, strict=True))
    (per_px, per_v), *_ = np.linalg.lstsq(np.stack([px, nv], axis=1), extra, rcond=None)
    worst = (extra - per_v * nv) / px
    print(f"fit: {per_px:.1f} B a pixel + {per_v:.0f} B a vertex "
          f"(largest per-pixel rest {worst.max():.1f} B with {per_v:.0f} B a vertex)")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=None, help="side of the image (4000; --refine 2000)")
    ap.add_argument("--refine", action="store_true", help="measure method='refine' by budget")
    ap.add_argument("--vertices", default="20000,200000,1000000")
    ap.add_argument("--max-error", default="0.01,0.001")
    ap.add_argument("--method", choices=["refine", "paper"], default="refine",
                    help="the method of the whole-image cases, with its default target (refine)")
    args = ap.parse_args()
    size = args.size or (2000 if args.refine else 4000)
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "big.npy"
        make_image(size, path)
        print(f"{size}x{size} float32 image, {path.stat().st_size / 2**20:.0f} MiB")
        if args.refine:
            refine_cases(path, [int(x) for x in args.vertices.split(",") if x],
                         [float(x) for x in args.max_error.split(",") if x])
            return
        for case in ("triangulate", "evaluate", "cli", "cli+preview"):
            r = _run(path, case, args.method)
            print(f"{case:12s} {r['seconds']:6.1f} s  peak above baseline "
                  f"{r['extra_bytes'] / 2**20:7.0f} MiB = {r['extra_bytes'] / r['image_bytes']:4.1f}x "
                  f"the image")


if __name__ == "__main__":
    main()
