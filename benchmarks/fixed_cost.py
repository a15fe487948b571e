"""A call's fixed cost, against pydelatin in the same process and, optionally, another tree.

    RANGEMESH_THREADS=1 taskset -c 0 python benchmarks/fixed_cost.py [--base SRC] [--runs N]

`triangulate` of a 16 x 16 image to 10 vertices (``method="refine"``) and pydelatin's
``Delatin(z, max_error=0, max_points=10)`` on the same heights, in rounds of 1000 calls
alternating between the two, CPU time (`time.process_time`) per call; each run is a new process
and prints the medians of its rounds. With ``--base SRC`` (the ``src`` folder of another tree,
``git archive BASE src | tar -x -C /tmp/base``, with this build's ``_core/_ext*.so`` copied into
it) the runs alternate between that tree and this checkout, so both see the same load. Prints,
per tree, the median over the runs of rangemesh's and pydelatin's microseconds and of their
ratio. With ``--callgrind`` it counts instructions instead (valgrind's callgrind, the
difference between runs of 2000 and 0 calls after 200 warm-up calls): a figure the machine's
load does not change. Nothing here asserts on time.
"""

import argparse
import os
import statistics
import subprocess
import sys

CHILD = r'''
import sys
if sys.argv[1] != "installed":
    sys.meta_path = [f for f in sys.meta_path if "editable" not in repr(f).lower()
                     and "skbc" not in repr(f)]
    sys.path.insert(0, sys.argv[1])
import statistics, time
import numpy as np
import rangemesh
if sys.argv[1] != "installed":
    assert rangemesh.__file__.startswith(sys.argv[1]), rangemesh.__file__
from pydelatin import Delatin
r, c = np.mgrid[0:16, 0:16]
d = 100.0 + r + 0.5 * c + ((r - 8) ** 2 + (c - 8) ** 2) * 0.1
z = d.astype(np.float32)
ours = lambda: rangemesh.triangulate(d, method="refine", vertices=10)
theirs = lambda: Delatin(z, max_error=0, max_points=10)
assert ours().stats.vertices == 10 and len(theirs().vertices) == 10
times = {"ours": [], "theirs": []}
for f in (ours, theirs):
    for _ in range(300):
        f()
for _ in range(int(sys.argv[2])):
    for k, f in (("ours", ours), ("theirs", theirs)):
        t = time.process_time()
        for _ in range(1000):
            f()
        times[k].append((time.process_time() - t) * 1e3)
print(statistics.median(times["ours"]), statistics.median(times["theirs"]),
      statistics.median(a / b for a, b in zip(times["ours"], times["theirs"])))
'''


COUNT = CHILD.split("times = {")[0] + r'''
f = {"ours": ours, "theirs": theirs}[sys.argv[3]]
for _ in range(200):
    f()
for _ in range(int(sys.argv[2])):
    f()
'''


# string hashes and BLAS threads drift a run's count by about +-10K a call; fixed, runs repeat it
STEADY = {**os.environ, "PYTHONHASHSEED": "0", "OPENBLAS_NUM_THREADS": "1"}


def instructions(arg: str, which: str, calls: int = 2000) -> float:
    """Instructions a call of `which` ('ours' or 'theirs') in the tree `arg`, by callgrind."""
    counts = []
    for n in (0, calls):
        out = subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null",
                              sys.executable, "-c", COUNT, arg, str(n), which],
                             capture_output=True, text=True, cwd="/", env=STEADY)
        line = next(x for x in out.stderr.splitlines() if "Collected" in x)
        counts.append(int(line.split()[-1]))
    return (counts[1] - counts[0]) / calls


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", help="src folder of another tree to compare with")
    ap.add_argument("--runs", type=int, default=5, help="processes per tree (default 5)")
    ap.add_argument("--rounds", type=int, default=7, help="rounds of 1000 calls a process")
    ap.add_argument("--callgrind", action="store_true", help="count instructions (valgrind)")
    args = ap.parse_args(argv)
    trees = {"this checkout": "installed"}
    if args.base:
        trees = {"base": os.path.abspath(args.base), **trees}
    if args.callgrind:
        for name, arg in trees.items():
            ours, theirs = instructions(arg, "ours"), instructions(arg, "theirs")
            print(f"{name}: rangemesh {ours / 1000:.0f}K instructions a call, pydelatin "
                  f"{theirs / 1000:.0f}K, ratio {ours / theirs:.2f}")
        return
    res = {name: [] for name in trees}
    for _ in range(args.runs):
        for name, arg in trees.items():
            out = subprocess.run([sys.executable, "-c", CHILD, arg, str(args.rounds)],
                                 capture_output=True, text=True, cwd="/")
            if out.returncode:
                sys.exit(out.stderr[-1500:])
            res[name].append([float(x) for x in out.stdout.split()])
    print(f"load (1, 5, 15 min): {', '.join(f'{x:.1f}' for x in os.getloadavg())}")
    for name, runs in res.items():
        ours, theirs, ratio = (statistics.median(r[i] for r in runs) for i in range(3))
        print(f"{name}: rangemesh {ours:.1f} us, pydelatin {theirs:.1f} us, ratio {ratio:.2f} "
              f"(runs: {', '.join(f'{r[2]:.2f}' for r in runs)})")


if __name__ == "__main__":
    main()
