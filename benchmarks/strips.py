"""Two strips on two threads against one strip: method="refine"'s error, edge band and time.

Run ``python benchmarks/strips.py`` (``--only NAME`` for some images, ``--repeat K``).
For every image of ``../shared/data`` and every synthetic scene whose budget
(1 %, 3 % and 10 % of the valid pixels, as in ``budgets.py``) is large enough for
strips (`rangemesh.refine.strips.use_strips`), it meshes with
``triangulate(..., vertices=N, method="refine")`` twice: as it does by default
(two strips), and with strips switched off (one strip, the kernel of
``fa981af``). Calls alternate, ``--repeat`` times each; it prints one row per case
and the medians of the ratios (strips / one strip).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import budgets  # noqa: E402  (the sibling scripts: budgets, images, cameras)
import peers  # noqa: E402

from rangemesh import evaluate, triangulate  # noqa: E402
from rangemesh.refine import strips  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    peers.add_image_options(ap)
    ap.add_argument("--repeat", type=peers.positive_int, default=3)
    args = ap.parse_args(argv)
    data, images = peers.selected_images(args)
    on = strips.STRIP_MIN_VERTICES
    ratios = {"error": [], "band": [], "time": []}
    print("| image | budget | vertices | error | edge band | one strip ms | two strips ms | time |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for image, camera, _, valid, frac, n in budgets.budget_cases(images, data):
        if not strips.use_strips(image.depth.shape, n, None, int(valid.sum())):
            continue
        meshes, times = {}, {0: [], 1: []}
        for _ in range(args.repeat):
            for two in (0, 1):  # alternating: the machine's load hits both alike
                strips.STRIP_MIN_VERTICES = on if two else 1 << 62
                try:
                    t = time.perf_counter()
                    meshes[two] = triangulate(image.depth, background=image.background,
                                              vertices=n, method="refine", camera=camera)
                    times[two].append(time.perf_counter() - t)
                finally:
                    strips.STRIP_MIN_VERTICES = on
        ev = {k: evaluate(m, image.depth, background=image.background,
                          discontinuities=image.discontinuities) for k, m in meshes.items()}
        ms = {k: 1e3 * statistics.median(v) for k, v in times.items()}
        err = ev[1].relative_error / ev[0].relative_error if ev[0].relative_error else None
        band = ev[1].edge_band_error / ev[0].edge_band_error if ev[0].edge_band_error else None
        for key, r in (("error", err), ("band", band), ("time", ms[1] / ms[0])):
            if r is not None:
                ratios[key].append(r)
        fmt = lambda r: "-" if r is None else f"{r:.3f}"  # noqa: E731
        print(f"| {image.name[:30]} | {frac:.0%} | {n} | {fmt(err)} | {fmt(band)} | "
              f"{ms[0]:.1f} | {ms[1]:.1f} | {ms[1] / ms[0]:.2f} |", flush=True)
    print()
    for key, r in ratios.items():
        if r:
            print(f"{key}: median {statistics.median(r):.3f}, {min(r):.3f}-{max(r):.3f} "
                  f"over {len(r)} cases")


if __name__ == "__main__":
    main()
