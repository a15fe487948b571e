"""effort="best" against effort="fast" on the quality-levers study's six cases (issue 44).

Run ``taskset -c 0 env RANGEMESH_THREADS=1 python benchmarks/effort.py`` (``--repeat`` timed
rounds, default 3; ``--factors 3,4`` tries collapse factors, `COLLAPSE_BEST` by default). Per
case: the vertex count (a share of the valid pixels), each effort's relative error (`evaluate`,
% of the valid depth range, mean over valid pixels; refine leaves none uncovered here) and its
CPU time (`time.process_time`, median of interleaved rounds: fast, best, fast, best, ...), and
the best peer's error from the study (MeshLab, Open3D, fast-simplification, pydelatin at
the same count within 5 %). Prints the commit and the load.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from rangemesh import evaluate, triangulate
from rangemesh.io import read_range_image
from rangemesh.prepare import to_depth_and_mask
from rangemesh.refine import insertion

# (image under shared/data, background, share of the valid pixels, the study's best peer's error)
CASES = [
    ("middlebury/tsukuba_disp3.npy", 0, 0.01, 0.408),
    ("middlebury/tsukuba_disp3.npy", 0, 0.03, 0.00279),
    ("middlebury/venus_disp2.npy", None, 0.03, 0.0720),
    ("odetics/chair-range.npy", 0, 0.01, 0.825),
    ("middlebury/teddy_disp2.png", 0, 0.03, 0.271),
    ("rgbd/open3d_TUM_depth.png", 0, 0.01, 0.162),
]


def _commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                              cwd=Path(__file__).parent, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def _timed(call, rounds):
    """Interleaved rounds of each call: (each one's last mesh, its median CPU seconds)."""
    meshes, times = [None] * len(call), [[] for _ in call]
    for _ in range(rounds):
        for i, fn in enumerate(call):
            t = time.process_time()
            meshes[i] = fn()
            times[i].append(time.process_time() - t)
    return meshes, [statistics.median(t) for t in times]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python benchmarks/effort.py", description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, default=Path(os.environ.get("RANGEMESH_DATA", "../shared/data")))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--factors", default=None,
                    help="collapse factors to try, e.g. 3,4 (default: COLLAPSE_BEST)")
    args = ap.parse_args(argv)
    factors = [float(x) for x in args.factors.split(",")] if args.factors else [insertion.COLLAPSE_BEST]
    print(f"commit {_commit()}, load {os.getloadavg()[0]:.2f}, RANGEMESH_THREADS="
          f"{os.environ.get('RANGEMESH_THREADS', '')}, affinity {sorted(os.sched_getaffinity(0))}")
    head = " | ".join(f"best k={k:g} % | ms | / peer" for k in factors)
    print(f"| case | N | fast % | ms | {head} | best peer % |")
    print("|---|---:|---:|---:|" + "---:|---:|---:|" * len(factors) + "---:|")
    for rel, background, share, peer in CASES:
        image = read_range_image(args.data / rel)
        valid = to_depth_and_mask(image, background)[1]
        n = max(50, round(share * int(valid.sum())))
        cells = []
        fast_ms = None
        for k in factors:
            insertion.COLLAPSE_BEST = k
            (fast, best), (tf, tb) = _timed([
                lambda image=image, background=background, n=n:
                    triangulate(image, background=background, vertices=n),
                lambda image=image, background=background, n=n:
                    triangulate(image, background=background, vertices=n, effort="best")],
                args.repeat)
            ef = evaluate(fast, image, background=background)
            eb = evaluate(best, image, background=background)
            assert best.stats.vertices == fast.stats.vertices == n and eb.uncovered == 0
            fast_ms = fast_ms or (ef.relative_error, 1000 * tf)
            cells.append(f"{eb.relative_error:.4g} | {1000 * tb:.0f} | {eb.relative_error / peer:.2f}")
        print(f"| {Path(rel).stem} {share:.0%} | {n} | {fast_ms[0]:.4g} | {fast_ms[1]:.0f} | "
              + " | ".join(cells) + f" | {peer:g} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
