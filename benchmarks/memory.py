"""Peak memory of meshing a large image, as a multiple of the image's own size.

Each case runs in a fresh process (so peaks do not mix) on a synthetic scene
upscaled to N x N float32 with 2 % random holes, as in the hostile-input
report. The figure is the child's peak resident set size (``ru_maxrss``)
minus the same process's peak after importing everything and loading the
image, divided by the image's bytes.

    python benchmarks/memory.py [--size 4000]
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
path, case = sys.argv[1], sys.argv[2]
img = np.load(path)
rangemesh.triangulate(img[:64, :64], background=0)   # compile/load kernels on a small image
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
t0 = time.perf_counter()
if case == "triangulate":
    rangemesh.triangulate(img, background=0)
elif case == "evaluate":
    m = rangemesh.triangulate(img, background=0)
    rangemesh.evaluate(m, img, background=0)
else:
    out = str(path) + ".ply"
    argv = ["mesh", path, "-o", out, "--background", "0", "--quiet"]
    if case == "cli+preview":
        argv += ["--preview", str(path) + ".png"]
    assert rangemesh.cli.main(argv) == 0
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(json.dumps({"case": case, "seconds": time.perf_counter() - t0, "extra_bytes": peak - base,
                  "image_bytes": img.nbytes}))
"""


def make_image(n: int, path: Path):
    import numpy as np

    from rangemesh import scenes

    small = scenes.make("box", (n // 8, n // 8)).depth.astype(np.float32) + 100
    img = np.kron(small, np.ones((8, 8), np.float32))
    rng = np.random.default_rng(0)
    img[rng.random(img.shape) < 0.02] = 0
    np.save(path, img)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=4000)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "big.npy"
        make_image(args.size, path)
        print(f"{args.size}x{args.size} float32 image, {path.stat().st_size / 2**20:.0f} MiB")
        for case in ("triangulate", "evaluate", "cli", "cli+preview"):
            out = subprocess.run([sys.executable, "-c", CHILD, str(path), case], check=True,
                                 capture_output=True, text=True).stdout
            r = json.loads(out.strip().splitlines()[-1])
            print(f"{case:12s} {r['seconds']:6.1f} s  peak above baseline "
                  f"{r['extra_bytes'] / 2**20:7.0f} MiB = {r['extra_bytes'] / r['image_bytes']:4.1f}x "
                  f"the image")


if __name__ == "__main__":
    main()
