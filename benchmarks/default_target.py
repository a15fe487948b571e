"""Which target should method="refine" take when the caller gives none?

Meshes every shared image and scene with candidate rules and prints, for each,
the vertices (and their share of the valid pixels), the mean relative error,
the error near jumps and the share of valid pixels left uncovered, beside the
paper's pipeline with its defaults (what ``triangulate(depth)`` gave before).

    python benchmarks/default_target.py [--data ../shared/data] [--only NAME]
"""

import argparse
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import budgets  # noqa: E402
import peers  # noqa: E402

from rangemesh import evaluate  # noqa: E402
from rangemesh.pipeline import triangulate  # noqa: E402

RULES = {
    "paper defaults": {"method": "paper"},
    # what triangulate(depth) gives: rangemesh.params.DEFAULT_TARGET
    "default: max_error 0.5 %, at most 2 % of pixels": {},
    "max_error 0.25 %": {"method": "refine", "max_error": 0.25},
    "max_error 0.5 %": {"method": "refine", "max_error": 0.5},
    "max_error 1 %": {"method": "refine", "max_error": 1.0},
    "1 % of pixels": {"method": "refine", "share": 0.01},
    "2 % of pixels": {"method": "refine", "share": 0.02},
}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    peers.add_image_options(ap)
    ap.add_argument("--rules", nargs="*", default=list(RULES), help="rule names to run")
    args = ap.parse_args(argv)
    data, images = peers.selected_images(args)
    table = {r: [] for r in args.rules}
    print("| image | rule | vertices | share of valid % | error % | near jumps % | uncovered % |")
    print("|---|---|---:|---:|---:|---:|---:|")
    for image in images:
        masked, valid = peers.to_depth_and_mask(image.depth, image.background)
        camera = budgets.sensor_camera(image, data)
        n_valid = int(valid.sum())
        for name in args.rules:
            kw = dict(RULES[name])
            share = kw.pop("share", None)
            if share is not None:
                kw["vertices"] = max(int(share * n_valid), 50)
            mesh = triangulate(image.depth, background=image.background, camera=camera, **kw)
            ev = evaluate(mesh, image.depth, background=image.background,
                          discontinuities=image.discontinuities)
            row = (len(mesh.vertices), 100 * len(mesh.vertices) / n_valid, ev.relative_error,
                   ev.edge_band_error, ev.uncovered)
            table[name].append(row)
            print(f"| {image.name} | {name} | {row[0]} | {row[1]:.2f} | {row[2]:.3f} | {row[3]:.3f} "
                  f"| {row[4]:.2f} |", flush=True)
    print("\n| rule | median share % | median error % | worst error % | median near jumps % "
          "| worst uncovered % |")
    print("|---|---:|---:|---:|---:|---:|")
    for name, rows in table.items():
        print(f"| {name} | {statistics.median(r[1] for r in rows):.2f} "
              f"| {statistics.median(r[2] for r in rows):.3f} | {max(r[2] for r in rows):.3f} "
              f"| {statistics.median(r[3] for r in rows):.3f} | {max(r[4] for r in rows):.2f} |")


if __name__ == "__main__":
    main()
