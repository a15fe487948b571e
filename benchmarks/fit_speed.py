"""What the least-squares depths (``heights="fit"``) cost, optionally against another tree.

    python benchmarks/fit_speed.py                    # this checkout
    git archive BASE src | tar -x -C /tmp/base        # then copy a core built from BASE into it
    python benchmarks/fit_speed.py /tmp/base/src [runs]

On the Odetics chair (128 x 128, 0 missing; ``../shared/data``) at 163, 491 and 1638 vertices it
prints the median of 300 calls of ``triangulate(z, vertices=N)`` with fitted and with copied
depths, and the fit's own time inside the fitted calls (``Stats.seconds["fit"]``); on a 16 x 16
image to 10 vertices, the median of 3000 calls of each and of `fit_heights` alone. With a base
tree each side runs in its own process, the sides alternating, and the medians of the runs'
medians are printed side by side (the base tree needs its own compiled core). Nothing here
asserts on time.
"""

import json
import statistics
import subprocess
import sys
from pathlib import Path

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"

sys.path.insert(0, str(Path(__file__).resolve().parent))
from call_cost_ab import TREE_PREAMBLE  # noqa: E402  (the sibling script: which tree to import)

CODE = TREE_PREAMBLE + r'''
import json, statistics, time
import numpy as np
from rangemesh import _core
from rangemesh.camera import Orthographic
from rangemesh.refine.heights import fit_heights


def median_us(fn, n):
    for _ in range(n // 10):
        fn()
    times = []
    for _ in range(n):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return 1e6 * statistics.median(times)


out = {}
r, c = np.mgrid[0:16, 0:16]
small = 100.0 + r + 0.5 * c + ((r - 8) ** 2 + (c - 8) ** 2) * 0.1
for h in ("fit", "pixel"):
    out[f"16x16, 10 vertices, heights={h}"] = median_us(
        lambda: rangemesh.triangulate(small, method="refine", vertices=10, heights=h), 3000)
m = rangemesh.triangulate(small, method="refine", vertices=10, heights="pixel")
valid = np.ones(small.shape, bool)
extent = _core.valid_range(small, valid)
camera = Orthographic()
out["16x16, fit_heights alone"] = median_us(
    lambda: fit_heights(m.pixels, m.faces, small, valid, camera, extent=extent), 3000)
z = np.load(sys.argv[2])
for n in (163, 491, 1638):
    fit = []
    out[f"chair, {n} vertices, heights=fit"] = median_us(
        lambda: fit.append(rangemesh.triangulate(z, vertices=n).stats.seconds["fit"]), 300)
    out[f"chair, {n} vertices, the fit inside"] = 1e6 * statistics.median(fit[30:])
    out[f"chair, {n} vertices, heights=pixel"] = median_us(
        lambda: rangemesh.triangulate(z, vertices=n, heights="pixel"), 300)
print(json.dumps(out))
'''


def run(tree: str) -> dict:
    out = subprocess.run([sys.executable, "-c", CODE, tree, str(DATA / "odetics" / "chair-range.npy")],
                         capture_output=True, text=True, cwd="/")
    if out.returncode:
        sys.exit(out.stderr[-1500:])
    return json.loads(out.stdout)


def main():
    base = sys.argv[1] if len(sys.argv) > 1 else None
    runs = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    sides = {"this checkout": "installed"} if base is None else {"base": base, "this checkout": "installed"}
    res = {name: [] for name in sides}
    for _ in range(runs if base else 1):
        for name, tree in sides.items():
            res[name].append(run(tree))
    print("| case, median us | " + " | ".join(sides) + " |")
    print("|---|" + "---:|" * len(sides))
    for key in res["this checkout"][0]:
        cells = [f"{statistics.median(r[key] for r in res[name]):.1f}" for name in sides]
        print(f"| {key} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
