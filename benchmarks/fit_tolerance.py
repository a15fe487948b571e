"""What conjugate gradients' stopping tolerance costs and changes: iterations, error, fitted depths.

Run ``python benchmarks/fit_tolerance.py`` (``--only NAME`` for some images,
``--rtol A --rtol B`` for the tolerances to compare; default 1e-8 and 1e-6). For
every image of ``../shared/data`` (the LiDAR scan with its beams' camera, as in
``benchmarks/budgets.py``) at 1 %, 3 % and 10 % of its valid pixels and at the
default target, it meshes with each tolerance
(`rangemesh.refine.heights.CG_RTOL`) and prints per case the conjugate-gradient
steps the fit takes (the fewest `max_iter` at which it converges), the mean error
with uncovered pixels charged (`peers.filled_error`, % of the depth range) and
the largest change of a vertex depth against the first tolerance, in % of the
depth range. The triangulation does not depend on the tolerance. Nothing is timed.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import budgets  # noqa: E402  (the sibling scripts: images, cameras, budgets)
import peers  # noqa: E402

from rangemesh import _core, triangulate  # noqa: E402
from rangemesh.camera import Pinhole  # noqa: E402
from rangemesh.refine import heights  # noqa: E402


def cg_steps(mesh, masked, valid, camera) -> int:
    """The fewest conjugate-gradient steps after which the fit of `mesh`'s depths converges."""
    ortho = not isinstance(camera, Pinhole)
    with np.errstate(divide="ignore"):
        image = masked if ortho else 1.0 / masked
    image = np.ascontiguousarray(np.where(valid, image, 0.0), dtype=np.float64)
    pixels = np.ascontiguousarray(mesh.pixels, dtype=np.int64)
    faces = np.ascontiguousarray(mesh.faces, dtype=np.int64)
    span = _core.valid_range(image, valid)
    order = _core.face_order(faces, np.ascontiguousarray(pixels[:, 0]), np.ascontiguousarray(pixels[:, 1]),
                             *image.shape, heights.ORDER_TILE)
    for steps in range(0, 10 * len(pixels) + 1):
        s = heights.fit_settings(span.lo, span.hi, len(faces), len(pixels), span.count, 1)
        s.max_iter = steps
        if _core.fit_heights(faces, pixels, image, valid, order, s).outcome != _core.FitOutcome.NOT_CONVERGED:
            return steps
    return -1


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    peers.add_image_options(ap)
    ap.add_argument("--rtol", type=float, action="append", default=[],
                    help="a tolerance to compare (repeatable; default 1e-8 and 1e-6)")
    args = ap.parse_args(argv)
    rtols = args.rtol or [1e-8, 1e-6]
    data, images = peers.selected_images(args)
    images = [im for im in images if not im.name.startswith("synthetic")]
    head = " | ".join(f"steps, error at {r:g}" for r in rtols)
    print(f"| image | budget | vertices | {head} | largest depth change |")
    print("|---|---:|---:|" + "---:|" * len(rtols) + "---:|")
    cases = []
    for image in images:
        masked, valid = peers.to_depth_and_mask(image.depth, image.background)
        camera = budgets.sensor_camera(image, data)
        cases += [(image, camera, masked, valid, f"{frac:.0%}", {"vertices": n})
                  for frac, n in budgets.vertex_budgets(valid)]
        cases.append((image, camera, masked, valid, "default", {}))
    keep = heights.CG_RTOL
    try:
        for image, camera, masked, valid, budget, kw in cases:
            cells, depths = [], []
            for rtol in rtols:
                heights.CG_RTOL = rtol
                mesh = triangulate(image.depth, background=image.background, camera=camera, **kw)
                steps = cg_steps(mesh, masked, valid, camera)
                cells.append(f"{steps}, {peers.filled_error(mesh, masked, valid):.5f}")
                xyz = mesh.vertices
                depths.append(xyz[:, 2] if camera is None else np.linalg.norm(xyz, axis=1))
            d = masked[valid]
            change = max(float(np.abs(z - depths[0]).max()) for z in depths) / float(d.max() - d.min())
            print(f"| {image.name} | {budget} | {mesh.stats.vertices} | {' | '.join(cells)} "
                  f"| {100 * change:.4f} |", flush=True)
    finally:
        heights.CG_RTOL = keep
    return 0


if __name__ == "__main__":
    sys.exit(main())
