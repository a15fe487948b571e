"""The greedy insertion kernel alone against pydelatin, same images, same vertex counts.

    python benchmarks/refine_speed.py

Prints the median of 7 calls of `rangemesh._core.greedy_insert` (on
the prepared image, background filled) and of ``pydelatin.Delatin(max_points=N)``
(on the float32 image), measured side by side in one process.
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import numpy as np

from rangemesh import MeshParams, _core
from rangemesh._core import valid_range
from rangemesh.pipeline import prepare
from rangemesh.refine.insertion import first_mesh

sys.path.insert(0, str(Path(__file__).resolve().parent))
from peers import _filled  # noqa: E402  (the sibling script: background filled for pydelatin)

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
CASES = [("middlebury/venus_disp2.npy", None), ("odetics/chair-range.npy", 0)]


def median_ms(fn, repeat=7):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1000 * statistics.median(times)


def main() -> int:
    import pydelatin

    print("| image | vertices | kernel ms | pydelatin ms | ratio |")
    print("|---|---:|---:|---:|---:|")
    for rel, background in CASES:
        z = np.load(DATA / rel)
        depth, valid = prepare(z, MeshParams(), background)
        filled = _filled(depth, valid)  # pydelatin needs every pixel
        lo, hi, _ = valid_range(depth, valid)
        _core.greedy_insert(depth, valid, first_mesh(depth, valid, 0),
                            _core.InsertSettings(50, -1.0, hi - lo))
        z32 = filled.astype(np.float32)
        span = hi - lo
        for n in (1369, 5000):
            ours = median_ms(lambda n=n, d=depth, v=valid, s=span: _core.greedy_insert(
                d, v, first_mesh(d, v, min(256, n // 16)), _core.InsertSettings(n, -1.0, s)))
            theirs = median_ms(lambda n=n, z=z32: pydelatin.Delatin(z, max_points=n))
            print(f"| {Path(rel).name} | {n} | {ours:.1f} | {theirs:.1f} | {ours / theirs:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
