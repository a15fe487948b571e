"""What fitted vertex depths gain over copied ones, per image and budget.

Run ``python benchmarks/heights.py`` (``--only NAME`` for some images,
``--floor F`` to try another `rangemesh.refine.heights.OUTLIER_FLOOR`, a
share of the vertices' value range below which the fit's outlier bound never
falls). For every image of ``../shared/data`` and every synthetic scene, at
1 %, 3 % and 10 % of its valid pixels as vertex counts, it meshes with
``heights="fit"`` (the default, `rangemesh.refine.heights.fit_heights`) and
``heights="pixel"`` (each vertex's depth copied from its pixel), everything
else at its default, the LiDAR scan with its beams' camera as in
``benchmarks/budgets.py``.

It prints per case the mean error and the error within 2 px of jumps
(`rangemesh.evaluate`) of the fitted depths as ratios of the copied
depths', then their medians per budget over the cases that the copied
depths do not mesh exactly. The triangulations are the same on both sides.
Quality only: nothing is timed.
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
from rangemesh.refine import heights  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    peers.add_image_options(ap)
    ap.add_argument("--floor", type=float, default=None,
                    help=f"OUTLIER_FLOOR to use (default {heights.OUTLIER_FLOOR:g})")
    args = ap.parse_args(argv)
    if args.floor is not None:
        heights.OUTLIER_FLOOR = args.floor
    data, images = peers.selected_images(args)
    ratios = {frac: {"error": [], "band": []} for frac in budgets.FRACTIONS}
    print(f"OUTLIER_FLOOR {heights.OUTLIER_FLOOR:g}, OUTLIER_MADS {heights.OUTLIER_MADS:g}\n")
    print("| image | budget | vertices | error, fitted / copied | edge band |")
    print("|---|---:|---:|---:|---:|")
    for image, camera, _, _, frac, n in budgets.budget_cases(images, data):
        meshes = {h: triangulate(image.depth, background=image.background, vertices=n,
                                 camera=camera, heights=h) for h in ("fit", "pixel")}
        if not (np.array_equal(meshes["fit"].pixels, meshes["pixel"].pixels)
                and np.array_equal(meshes["fit"].faces, meshes["pixel"].faces)):
            raise RuntimeError(f"{image.name}: the fit changed the triangulation")
        ev = {h: evaluate(m, image.depth, background=image.background)
              for h, m in meshes.items()}
        err = budgets._ratio(ev["fit"].relative_error, ev["pixel"].relative_error)
        band = budgets._ratio(np.nan_to_num(ev["fit"].edge_band_error),
                              np.nan_to_num(ev["pixel"].edge_band_error))
        print(f"| {image.name[:30]} | {frac:.0%} | {len(meshes['fit'].pixels)} | {err:.3f} "
              f"| {band:.3f} |", flush=True)
        # below a millionth of the depth range both count as exact (`budgets.EXACT`)
        if ev["pixel"].relative_error > budgets.EXACT:
            ratios[frac]["error"].append(err)
            ratios[frac]["band"].append(band)
    print("\n| budget | cases | error, fitted / copied | edge band |")
    print("|---|---:|---:|---:|")
    for frac, r in ratios.items():
        if r["error"]:
            print(f"| {frac:.0%} | {len(r['error'])} | {statistics.median(r['error']):.3f} "
                  f"| {statistics.median(r['band']):.3f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
