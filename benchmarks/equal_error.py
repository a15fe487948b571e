"""Time at equal error: rangemesh against pydelatin asked for as little error, not as many vertices.

Run ``python benchmarks/equal_error.py`` (``--only NAME`` for some images,
``--repeat K``). The issue's time target compares the two at the same vertex
count; this asks the other question a user asks, what it costs to reach the
same mesh quality. For every image of ``../shared/data`` and every synthetic
scene, at 1 %, 3 % and 10 % of its valid pixels (`budgets.vertex_budgets`),
it meshes with rangemesh's default (``vertices=N``), measures its mean
relative error E (`rangemesh.evaluate`), then searches the fewest vertices
on valid pixels at which pydelatin's mean error is at most E (it grows the
count until the error is reached, then bisects to 1 % of the count; its error
falls with the count, if not strictly, so the count found is within a few %
of the fewest). Both are then timed, alternating, ``--repeat`` calls each,
the peer's hole filling and count search not timed (as in
``benchmarks/peers.py``).

Where rangemesh's mesh is exact (E below a millionth of the depth range:
the piecewise-planar scenes), pydelatin is asked for that millionth. If it
gets there with fewer vertices than N, the case is reported and left out of
the medians: rangemesh was asked for more vertices than exactness needs, and
spends them (at the largest exact triangles' centroids). Cases where
pydelatin does not reach E with every pixel of the image are reported and left
out too.
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import budgets  # noqa: E402  (the sibling scripts: images, cameras, budgets, peers)
import peers  # noqa: E402
from pydelatin import Delatin  # noqa: E402

from rangemesh import evaluate, triangulate  # noqa: E402


def delatin_error(image, masked, valid, n):
    """The mean relative error of pydelatin's mesh with n vertices on valid pixels."""
    arr, ask = peers.delatin_request(masked, valid, n)
    mesh = peers.delatin_mesh(Delatin(arr, max_error=0.0, max_points=ask), masked.shape)
    return evaluate(mesh, image.depth, background=image.background).relative_error


def fewest_for(image, masked, valid, n, target):
    """The fewest vertices (to 1 %) at which pydelatin's error is at most `target`, or None."""
    limit = int(valid.sum())
    lo, hi = 0, max(int(n), 4)
    while delatin_error(image, masked, valid, hi) > target:
        if hi >= limit:
            return None
        lo, hi = hi, min(2 * hi, limit)
    while hi - lo > max(1, hi // 100):
        mid = (lo + hi) // 2
        if delatin_error(image, masked, valid, mid) > target:
            lo = mid
        else:
            hi = mid
    return hi


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python benchmarks/equal_error.py",
                                 description=__doc__.splitlines()[0])
    peers.add_image_options(ap)
    ap.add_argument("--repeat", type=peers.positive_int, default=7, help="timed calls of each (default 7)")
    args = ap.parse_args(argv)
    data, images = peers.selected_images(args)
    print("| image | budget | vertices | error % | pydelatin's vertices at that error | ratio "
          "| ms | pydelatin ms | time / pydelatin |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    ratios = {frac: [] for frac in budgets.FRACTIONS}
    for image, camera, masked, valid, frac, n in budgets.budget_cases(images, data):
        mesh = triangulate(image.depth, background=image.background, vertices=n, camera=camera)
        err = evaluate(mesh, image.depth, background=image.background).relative_error
        head = f"| {image.name[:30]} | {frac:.0%} | {n} | {err:.4f} |"
        # an exact mesh: pydelatin is asked to be exact too (to a millionth of the depth range)
        m = fewest_for(image, masked, valid, n, max(err, budgets.EXACT))
        if m is None:
            print(f"{head} not reached with every pixel | | | | |")
            continue
        if err < budgets.EXACT and m < n:
            print(f"{head} {m} | {m / n:.2f} | both exact: left out | | |")
            continue
        arr, ask = peers.delatin_request(masked, valid, m)
        _, (ours, theirs) = peers.alternating_ms([
            lambda image=image, n=n, camera=camera: triangulate(
                image.depth, background=image.background, vertices=n, camera=camera),
            lambda arr=arr, ask=ask: Delatin(arr, max_error=0.0, max_points=ask)], args.repeat)
        ratios[frac].append(ours / theirs)
        print(f"{head} {m} | {m / n:.2f} | {ours:.2f} | {theirs:.2f} | "
              f"{ours / theirs:.2f} |", flush=True)
    print("\n| budget | cases | time / pydelatin at equal error (median) | max |")
    print("|---|---:|---:|---:|")
    for frac, r in ratios.items():
        if r:
            print(f"| {frac:.0%} | {len(r)} | {statistics.median(r):.2f} | {max(r):.2f} |")
    every = [x for r in ratios.values() for x in r]
    if every:
        print(f"| all | {len(every)} | {statistics.median(every):.2f} | {max(every):.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
