"""What ``diagonals="error"`` gains over the Delaunay diagonals of method="refine", and costs.

Run ``python benchmarks/diagonals.py`` (``--only NAME`` for some images,
``--repeat K`` for the timed calls of each side, default 5). For every image
of ``../shared/data`` and every synthetic scene, at 1 %, 3 % and 10 % of its
valid pixels as vertex counts, it meshes with ``diagonals="delaunay"`` (the
insertion's own mesh) and ``diagonals="error"`` (the default,
`rangemesh.refine.diagonals`: edges flipped while the two triangles fit
their pixels better), calls alternating
in one process, everything else at its default (fitted depths), and the
LiDAR scan with its beams' camera as in ``benchmarks/budgets.py``.

It prints per case the mean error and the error within 2 px of jumps
(`rangemesh.evaluate`) with the flips as ratios of those without, and the
ratio of the median whole-call times; then the medians of the three ratios
over all cases. The vertices are the same on both sides.
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import budgets  # noqa: E402  (the sibling scripts: images, cameras)
import peers  # noqa: E402

from rangemesh import evaluate, triangulate  # noqa: E402

SIDES = ("delaunay", "error")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    peers.add_image_options(ap)
    ap.add_argument("--repeat", type=peers.positive_int, default=5, help="timed calls a side (default 5)")
    args = ap.parse_args(argv)
    data, images = peers.selected_images(args)
    ratios = {"error": [], "band": [], "time": []}
    print("| image | budget | vertices | error, flips / none | edge band | time | ms without |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for image, camera, _, _, frac, n in budgets.budget_cases(images, data):
        outs, ms = peers.alternating_ms(
            [lambda side=side, image=image, n=n, camera=camera: triangulate(
                image.depth, background=image.background, vertices=n, camera=camera,
                diagonals=side) for side in SIDES], args.repeat)
        meshes, ms = dict(zip(SIDES, outs, strict=True)), dict(zip(SIDES, ms, strict=True))
        if not np.array_equal(meshes["delaunay"].pixels, meshes["error"].pixels):
            raise RuntimeError(f"{image.name}: the flips changed the vertices")
        ev = {side: evaluate(meshes[side], image.depth, background=image.background)
              for side in SIDES}
        # below a millionth of the depth range both count as exact (`budgets.EXACT`)
        err = budgets._ratio(ev["error"].relative_error, ev["delaunay"].relative_error)
        band = budgets._ratio(np.nan_to_num(ev["error"].edge_band_error),
                              np.nan_to_num(ev["delaunay"].edge_band_error))
        ratios["error"].append(err)
        ratios["band"].append(band)
        ratios["time"].append(ms["error"] / ms["delaunay"])
        print(f"| {image.name[:30]} | {frac:.0%} | {len(meshes['error'].pixels)} | {err:.3f} "
              f"| {band:.3f} | {ms['error'] / ms['delaunay']:.2f} | {ms['delaunay']:.1f} |",
              flush=True)
    print(f"\nmedians over {len(ratios['error'])} cases: error {statistics.median(ratios['error']):.3f}, "
          f"edge band {statistics.median(ratios['band']):.3f}, "
          f"time {statistics.median(ratios['time']):.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
