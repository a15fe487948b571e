"""What data-dependent edge flips after `method="refine"` would gain: error, edge band, cost.

Run ``python benchmarks/flips_after_refine.py`` (``--only NAME`` for some images,
``--bend K`` for the pre-filter below). An experiment, not a method of the
library: for every image of ``../shared/data`` and every synthetic scene, at 1 %,
3 % and 10 % of its valid pixels as vertex counts, it takes the refined mesh,
flips every interior edge whose two triangles cover their pixels with a smaller
summed absolute error (copied vertex depths) after the flip than before
(Dyn, Levin & Rippa's data-dependent triangulation; passes over all edges until
none flips, at most 4), fits the vertex depths again (`fit_heights`) and
evaluates both meshes with `rangemesh.evaluate`. With ``--bend K`` an edge is
tested only when the far corner of one triangle lies more than K times the
mesh's mean error off the other's plane (a nearly flat quad gains little).

It prints, per case, the mean error and edge band after the flips as ratios of
the refined mesh's, the flips made and the edges tested, and the flips' time
next to the call's. The triangle errors are summed over each triangle's box
with edge functions, not with the kernel's row spans: the time is an upper
bound of what the library would pay.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from numba import njit

sys.path.insert(0, str(Path(__file__).resolve().parent))

import budgets  # noqa: E402  (the sibling scripts: images, cameras)
import peers  # noqa: E402

from rangemesh import MeshParams, evaluate, triangulate  # noqa: E402
from rangemesh.camera import backproject  # noqa: E402
from rangemesh.geometry.halfedges import build_halfedges, flip_quad, quad_halfedges  # noqa: E402
from rangemesh.geometry.vectors import orient  # noqa: E402
from rangemesh.greedy.heights import fit_heights  # noqa: E402
from rangemesh.mesh import Mesh  # noqa: E402
from rangemesh.pipeline import prepare  # noqa: E402

FRACTIONS = (0.01, 0.03, 0.10)
MAX_PASSES = 4


@njit(cache=True)
def triangle_error(ar, ac, az, br, bc, bz, cr, cc, cz, depth, valid):
    """Sum of |depth - plane| over the valid pixels inside or on triangle ABC (inf if not CCW)."""
    area = orient(ar, ac, br, bc, cr, cc)
    if area <= 0:
        return np.inf
    total = 0.0
    for r in range(min(ar, br, cr), max(ar, br, cr) + 1):
        for c in range(min(ac, bc, cc), max(ac, bc, cc) + 1):
            w0 = orient(br, bc, cr, cc, r, c)
            w1 = orient(cr, cc, ar, ac, r, c)
            w2 = orient(ar, ac, br, bc, r, c)
            if w0 >= 0 and w1 >= 0 and w2 >= 0 and valid[r, c]:
                total += abs(depth[r, c] - (w0 * az + w1 * bz + w2 * cz) / area)
    return total


@njit(cache=True)
def error_flips(tri, he, pr, pc, z, depth, valid, bend):
    """Flip edges while that lowers the two triangles' summed error; returns (flips, tests)."""
    flips = 0
    tests = 0
    for _ in range(MAX_PASSES):
        flipped = 0
        for e0 in range(tri.size):
            if he[e0] < e0:  # each interior edge once (hull edges have -1)
                continue
            _, b0, c0, _, c1 = quad_halfedges(he, e0)
            a, b, c, d = tri[e0], tri[b0], tri[c0], tri[c1]
            # ABC + BAD -> DCA + CDB, both counter-clockwise (the quad is convex)
            if (orient(pr[d], pc[d], pr[c], pc[c], pr[a], pc[a]) <= 0
                    or orient(pr[c], pc[c], pr[d], pc[d], pr[b], pc[b]) <= 0):
                continue
            area = orient(pr[a], pc[a], pr[b], pc[b], pr[c], pc[c])
            zd = (orient(pr[b], pc[b], pr[c], pc[c], pr[d], pc[d]) * z[a]
                  + orient(pr[c], pc[c], pr[a], pc[a], pr[d], pc[d]) * z[b]
                  + orient(pr[a], pc[a], pr[b], pc[b], pr[d], pc[d]) * z[c]) / area
            if abs(zd - z[d]) <= bend:
                continue
            tests += 1
            old = (triangle_error(pr[a], pc[a], z[a], pr[b], pc[b], z[b], pr[c], pc[c], z[c],
                                  depth, valid)
                   + triangle_error(pr[b], pc[b], z[b], pr[a], pc[a], z[a], pr[d], pc[d], z[d],
                                    depth, valid))
            new = (triangle_error(pr[d], pc[d], z[d], pr[c], pc[c], z[c], pr[a], pc[a], z[a],
                                  depth, valid)
                   + triangle_error(pr[c], pc[c], z[c], pr[d], pc[d], z[d], pr[b], pc[b], z[b],
                                    depth, valid))
            if new < old * (1.0 - 1e-9):
                flip_quad(tri, he, e0)
                flipped += 1
        flips += flipped
        if flipped == 0:
            break
    return flips, tests


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    peers.add_image_options(ap)
    ap.add_argument("--bend", type=float, default=0.0,
                    help="test an edge only when its quad bends by more than this many mean errors")
    args = ap.parse_args(argv)
    data, images = peers.selected_images(args)
    ratios = {"error": [], "band": [], "time": []}
    print("| image | budget | vertices | error after / before | edge band | flips | tested | "
          "flips ms | call ms |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for image in images:
        camera = budgets.sensor_camera(image, data)
        depth, valid = prepare(image.depth, MeshParams(), image.background)
        n_valid = int(valid.sum())
        lo, hi = float(depth[valid].min()), float(depth[valid].max())
        for frac in FRACTIONS:
            n = max(int(frac * n_valid), 50)
            t = time.perf_counter()
            mesh = triangulate(image.depth, background=image.background, vertices=n,
                               camera=camera)
            call_ms = 1000.0 * (time.perf_counter() - t)
            before = evaluate(mesh, image.depth, background=image.background)
            pr = mesh.pixels[:, 0].astype(np.int64)
            pc = mesh.pixels[:, 1].astype(np.int64)
            tri, he = build_halfedges(np.ascontiguousarray(mesh.faces, np.int64), len(pr))
            bend = args.bend * before.relative_error / 100.0 * (hi - lo)
            t = time.perf_counter()
            flips, tests = error_flips(tri, he, pr, pc, depth[pr, pc].copy(), depth, valid, bend)
            flip_ms = 1000.0 * (time.perf_counter() - t)
            faces = tri.reshape(-1, 3).astype(np.int32)
            z = fit_heights(mesh.pixels, faces, depth, valid, mesh.camera)
            after = evaluate(Mesh(backproject(pr, pc, z, mesh.camera), faces, mesh.pixels,
                                  mesh.camera, mesh.image_shape), image.depth,
                             background=image.background)
            # below a millionth of the depth range both count as exact (`budgets.EXACT`)
            err = budgets._ratio(after.relative_error, before.relative_error)
            band = budgets._ratio(np.nan_to_num(after.edge_band_error),
                                  np.nan_to_num(before.edge_band_error))
            ratios["error"].append(err)
            ratios["band"].append(band)
            ratios["time"].append(flip_ms / call_ms)
            print(f"| {image.name[:30]} | {frac:.0%} | {n} | {err:.3f} | {band:.3f} | {flips} | "
                  f"{tests} | {flip_ms:.1f} | {call_ms:.1f} |", flush=True)
    print(f"medians over {len(ratios['error'])} cases: error {statistics.median(ratios['error']):.3f}, "
          f"edge band {statistics.median(ratios['band']):.3f}, flips' time / call "
          f"{statistics.median(ratios['time']):.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
