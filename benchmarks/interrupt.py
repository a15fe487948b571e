"""How soon Ctrl-C stops a call on a large image (issue 35: within 0.2 s, even 8000 x 8000).

    python benchmarks/interrupt.py [--size 8000] [--delays 0.1 0.5 1 2 4]

For each method and each delay, a new process makes a ``size x size`` image,
starts `rangemesh.triangulate` and sends itself SIGINT ``delay`` seconds into
the call; it prints the seconds from the signal to the KeyboardInterrupt caught
around the call (or that the call finished first), then meshes a small image
again to show the process is sound. The delays land the signal in different
stages: preparing the image, the first mesh, insertion, the fit; the paper's
sampling, triangulation and flips.

Nothing here asserts on time: read the figures of one run.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import textwrap

CHILD = textwrap.dedent("""
    import os, signal, sys, threading, time
    import numpy as np
    import rangemesh

    # a process started in the background inherits SIGINT ignored: Ctrl-C's behaviour, restored
    signal.signal(signal.SIGINT, signal.default_int_handler)
    n, method, delay = int(sys.argv[1]), sys.argv[2], float(sys.argv[3])
    r, c = np.ogrid[0:n, 0:n]
    depth = 100.0 + 10.0 * np.sin(r / 37.0) * np.cos(c / 23.0) + (r * c) % 7
    kw = {"refine": dict(vertices=n * n // 100), "refine-error": dict(max_error=0.05),
          "paper": dict(method="paper", tiles=(40, 40), samples=(max(2, n // 80),) * 2)}[method]
    sent = []
    threading.Timer(delay, lambda: (sent.append(time.perf_counter()),
                                    os.kill(os.getpid(), signal.SIGINT))).start()
    start = time.perf_counter()
    try:
        rangemesh.triangulate(depth, **kw)
        print(f"finished {time.perf_counter() - start:.3f}", flush=True)
    except KeyboardInterrupt:
        print(f"interrupted {time.perf_counter() - sent[0]:.4f}", flush=True)
    m = rangemesh.triangulate(depth[:50, :50], vertices=20)
    print("again", len(m.vertices), flush=True)
""")

METHODS = ("refine", "refine-error", "paper")


def one(size: int, method: str, delay: float) -> tuple[str, float]:
    """('interrupted' or 'finished', seconds) of one child process."""
    p = subprocess.run([sys.executable, "-c", CHILD, str(size), method, str(delay)],
                       capture_output=True, text=True, timeout=3600)
    lines = p.stdout.split()
    if p.returncode != 0 or len(lines) < 4 or lines[2:4] != ["again", "20"]:
        raise RuntimeError(f"{method} at {delay} s: exit {p.returncode}\n{p.stdout}\n"
                           f"{p.stderr[-2000:]}")
    return lines[0], float(lines[1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=8000, help="image side in pixels (8000)")
    ap.add_argument("--delays", type=float, nargs="+", default=[0.1, 0.5, 1.0, 2.0, 4.0],
                    help="seconds into the call when SIGINT is sent")
    ap.add_argument("--methods", nargs="+", choices=METHODS, default=list(METHODS))
    args = ap.parse_args(argv)
    if args.size < 50:
        ap.error("--size must be at least 50")
    print("| method | SIGINT after | outcome | seconds to KeyboardInterrupt |\n|---|---:|---|---:|")
    latencies = []
    for method in args.methods:
        for delay in args.delays:
            what, seconds = one(args.size, method, delay)
            if what == "interrupted":
                latencies.append(seconds)
                print(f"| {method} | {delay:g} s | stopped | {seconds:.3f} |", flush=True)
            else:
                print(f"| {method} | {delay:g} s | finished first ({seconds:.1f} s) | |", flush=True)
    if latencies:
        print(f"\n{args.size} x {args.size}: {len(latencies)} calls stopped, median "
              f"{statistics.median(latencies):.3f} s, worst {max(latencies):.3f} s after SIGINT")
    return 0


if __name__ == "__main__":
    sys.exit(main())
