"""How soon Ctrl-C stops a call on a large image (issue 35: within 0.2 s, even 8000 x 8000).

    python benchmarks/interrupt.py [--size 8000] [--delays 0.1 0.5 1 2 4] [--across N]
                                   [--methods refine refine-error default paper]

The calls: ``refine`` with ``vertices=size**2 // 100``, ``refine-error`` with
``max_error=0.05``, ``default`` (``triangulate(image)`` alone: refine's default
target, whose meshes are rendered to measure their error; not run unless
named), ``paper`` with 40 x 40 tiles of ``size // 80`` samples a side.

For each method and each delay, a new process makes a ``size x size`` image
and starts `rangemesh.triangulate`; this process sends it SIGINT ``delay``
seconds into the call (from outside, as a terminal's Ctrl-C comes: a signal
sent from a thread of the child itself could only leave once NumPy gave the
GIL back, and would then miss the very stretches this measures). The child
prints the seconds from the signal to the KeyboardInterrupt caught around the
call (or that the call finished first) and the stage it was stopped in: the
innermost line of rangemesh in the traceback, the kernel or NumPy step that
was running. It then meshes a small image again to show the process is sound.

``--across N`` replaces the delays by N spread evenly over the whole call (one
uninterrupted call per method measures its length first): every stage gets
its turn, not only the first seconds.

Nothing here asserts on time: read the figures of one run.
"""

from __future__ import annotations

import argparse
import os
import signal
import statistics
import subprocess
import sys
import textwrap
import time

CHILD = textwrap.dedent("""
    import linecache, os, signal, sys, time
    import numpy as np
    import rangemesh

    # a process started in the background inherits SIGINT ignored: Ctrl-C's behaviour, restored
    signal.signal(signal.SIGINT, signal.default_int_handler)
    n, method = int(sys.argv[1]), sys.argv[2]
    r, c = np.ogrid[0:n, 0:n]
    depth = 100.0 + 10.0 * np.sin(r / 37.0) * np.cos(c / 23.0) + (r * c) % 7
    kw = {"refine": dict(vertices=n * n // 100), "refine-error": dict(max_error=0.05),
          "default": dict(), "paper": dict(method="paper", tiles=(40, 40),
                                           samples=(max(2, n // 80),) * 2)}[method]
    package = os.path.dirname(rangemesh.__file__) + os.sep
    rangemesh.triangulate(depth[:50, :50], vertices=20)  # the lazy imports, before the clock

    def stage(tb):
        # the innermost line of rangemesh: the kernel call or the NumPy step that was running
        where = "?"
        while tb is not None:
            code = tb.tb_frame.f_code
            if code.co_filename.startswith(package):
                text = linecache.getline(code.co_filename, tb.tb_lineno).strip()
                where = (f"{code.co_filename[len(package):]}:{tb.tb_lineno} {code.co_name}: "
                         f"{text[:60]}")
            tb = tb.tb_next
        return where.replace("|", "/")

    print("go", time.monotonic(), flush=True)
    start = time.perf_counter()
    try:
        rangemesh.triangulate(depth, **kw)
        print("finished", time.perf_counter() - start, flush=True)
    except KeyboardInterrupt as exc:
        print("interrupted", time.monotonic(), stage(exc.__traceback__), flush=True)
    m = rangemesh.triangulate(depth[:50, :50], vertices=20)
    print("again", len(m.vertices), flush=True)
""")

# "default": triangulate(image) alone, refine's default target (max_error 0.5 with a vertex cap:
# its meshes are rendered to measure their error)
METHODS = ("refine", "refine-error", "default", "paper")


def one(size: int, method: str, delay: float | None) -> tuple[str, float, str]:
    """``('interrupted', seconds to KeyboardInterrupt, stage)`` or ``('finished', call seconds, '')``.

    `delay` None: no signal, the call runs to its end.
    """
    p = subprocess.Popen([sys.executable, "-c", CHILD, str(size), method], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    sent = None
    try:
        go = p.stdout.readline().split()
        if go[:1] != ["go"]:
            raise RuntimeError(f"{method}: the child did not start: {go}\n{p.stderr.read()[-2000:]}")
        if delay is not None:
            time.sleep(max(float(go[1]) + delay - time.monotonic(), 0.0))
            sent = time.monotonic()
            os.kill(p.pid, signal.SIGINT)
        out, err = p.communicate(timeout=3600)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    lines = out.splitlines()
    if p.returncode != 0 or len(lines) < 2 or lines[-1] != "again 20":
        raise RuntimeError(f"{method} at {delay} s: exit {p.returncode}\n{out}\n{err[-2000:]}")
    what, value, *where = lines[0].split(maxsplit=2)
    if what == "interrupted":
        return what, float(value) - sent, where[0] if where else "?"
    return what, float(value), ""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=8000, help="image side in pixels (8000)")
    ap.add_argument("--delays", type=float, nargs="+", default=[0.1, 0.5, 1.0, 2.0, 4.0],
                    help="seconds into the call when SIGINT is sent")
    ap.add_argument("--across", type=int, default=0, metavar="N",
                    help="instead, N delays spread evenly over each method's whole call")
    ap.add_argument("--methods", nargs="+", choices=METHODS, default=["refine", "refine-error", "paper"])
    args = ap.parse_args(argv)
    if args.size < 50:
        ap.error("--size must be at least 50")
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}", flush=True)
    print("| method | SIGINT after | outcome | seconds to KeyboardInterrupt | stopped in |\n"
          "|---|---:|---|---:|---|", flush=True)
    latencies = []
    for method in args.methods:
        delays = args.delays
        if args.across > 0:
            _, length, _ = one(args.size, method, None)
            print(f"| {method} | (none) | finished ({length:.1f} s) | | |", flush=True)
            delays = [round((i + 0.5) * length / args.across, 2) for i in range(args.across)]
        for delay in delays:
            what, seconds, where = one(args.size, method, delay)
            if what == "interrupted":
                latencies.append((seconds, method, delay, where))
                print(f"| {method} | {delay:g} s | stopped | {seconds:.3f} | {where} |", flush=True)
            else:
                print(f"| {method} | {delay:g} s | finished first ({seconds:.1f} s) | | |", flush=True)
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    if latencies:
        worst = max(latencies)
        print(f"\n{args.size} x {args.size}: {len(latencies)} calls stopped, median "
              f"{statistics.median(x[0] for x in latencies):.3f} s, worst {worst[0]:.3f} s after "
              f"SIGINT ({worst[1]} at {worst[2]:g} s, in {worst[3]})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
