"""A call's fixed cost against another commit: triangulate of a 16 x 16 image to 10 vertices.

    git archive BASE src | tar -x -C /tmp/base   # then copy the built _core/_ext*.so into it
    python benchmarks/call_cost_ab.py /tmp/base/src [runs]

Each run is a new process per side, the sides alternating: 300 warm-up calls, then the median
of 3000 (``method="refine", vertices=10``). The base tree needs the same compiled core, so the
comparison holds for Python changes only. Prints, for each side, the median of the runs'
medians in microseconds. Nothing here asserts on time.
"""

import statistics
import subprocess
import sys

# The child's first lines: `sys.argv[1]` is "installed", or the src folder of a tree to import
# instead of the installed (editable) rangemesh (`benchmarks/fit_speed.py` starts the same way).
TREE_PREAMBLE = r'''
import sys
if sys.argv[1] != "installed":
    sys.meta_path = [f for f in sys.meta_path if "editable" not in repr(f).lower()
                     and "skbc" not in repr(f)]
    sys.path.insert(0, sys.argv[1])
import rangemesh
if sys.argv[1] != "installed":
    assert rangemesh.__file__.startswith(sys.argv[1]), rangemesh.__file__
'''

CODE = TREE_PREAMBLE + r'''
import statistics, time
import numpy as np
r, c = np.mgrid[0:16, 0:16]
d = 100.0 + r + 0.5 * c + ((r - 8) ** 2 + (c - 8) ** 2) * 0.1
for _ in range(300):
    rangemesh.triangulate(d, method="refine", vertices=10)
ts = []
for _ in range(3000):
    t = time.perf_counter()
    rangemesh.triangulate(d, method="refine", vertices=10)
    ts.append(time.perf_counter() - t)
print(1e6 * statistics.median(ts))
'''


def main():
    base = sys.argv[1]
    runs = int(sys.argv[2]) if len(sys.argv) > 2 else 4
    res = {"base": [], "this checkout": []}
    for _ in range(runs):
        for name, arg in (("base", base), ("this checkout", "installed")):
            out = subprocess.run([sys.executable, "-c", CODE, arg], capture_output=True, text=True,
                                 cwd="/")
            if out.returncode:
                sys.exit(out.stderr[-1500:])
            res[name].append(float(out.stdout))
    for name, v in res.items():
        print(f"{name}: {statistics.median(v):.1f} us (runs: {', '.join(f'{x:.1f}' for x in v)})")


if __name__ == "__main__":
    main()
