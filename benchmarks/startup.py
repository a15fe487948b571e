"""What a user meets first: the first mesh, the import, a whole command, a call's fixed cost.

    python benchmarks/startup.py [--data ../shared/data] [--repeat 7]

Prints medians (new processes for the first three, one warm process for the last):

1. the first mesh in a new process: ``rangemesh mesh chair-range.npy --vertices 1000``,
   run first with empty caches in a fresh temporary HOME (what a new install meets),
   then again;
2. ``import rangemesh`` alone, and with ``rangemesh.triangulate`` resolved;
3. a whole ``rangemesh mesh`` process on the chair, wall clock;
4. a call's fixed cost: ``triangulate`` of a 16 x 16 image to 10 vertices, beside
   pydelatin's on the same heights (alternating calls in one process).

Nothing here asserts on time: the machine is shared and noisy; read the figures of one run.
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402
import peers  # noqa: E402


def _wall(cmd, env=None, cwd=None) -> float:
    t = time.perf_counter()
    subprocess.run(cmd, check=True, env=env, cwd=cwd, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)
    return time.perf_counter() - t


def first_mesh(chair: Path, repeat: int) -> tuple[float, float]:
    """Seconds of the first `rangemesh mesh` with empty caches (a new HOME), and warm."""
    exe = [sys.executable, "-m", "rangemesh", "mesh", str(chair), "--vertices", "1000",
           "--background", "0", "--quiet"]
    cold = []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(repeat):
            home = Path(tmp) / f"home{i}"
            home.mkdir()
            env = dict(os.environ, HOME=str(home), XDG_CACHE_HOME=str(home / ".cache"),
                       NUMBA_CACHE_DIR=str(home / "numba"))
            cold.append(_wall(exe + ["-o", str(home / "c.ply")], env=env, cwd=home))
        warm = [_wall(exe + ["-o", str(Path(tmp) / "w.ply")]) for _ in range(repeat)]
    return statistics.median(cold), statistics.median(warm)


def imports(repeat: int) -> tuple[float, float]:
    one = "import time; t = time.perf_counter(); import rangemesh{}; print(time.perf_counter() - t)"
    out = []
    for extra in ("", "; rangemesh.triangulate"):
        runs = [float(subprocess.run([sys.executable, "-c", one.format(extra)], check=True,
                                     capture_output=True, text=True).stdout) for _ in range(repeat)]
        out.append(statistics.median(runs))
    return out[0], out[1]


def fixed_cost(calls: int = 2000) -> tuple[float, float | None]:
    """Microseconds per call on a 16 x 16 image to 10 vertices: rangemesh, pydelatin."""
    from rangemesh import triangulate

    r, c = np.mgrid[0:16, 0:16]
    img = (100.0 + 3.0 * r + 2.0 * c + 5.0 * np.sin(r * c / 7.0))
    fns = {"rangemesh": lambda: triangulate(img, method="refine", vertices=10)}
    try:
        from pydelatin import Delatin

        h32 = img.astype(np.float32)
        # max_error 8 gives 13 vertices on these heights, the nearest to 10 it can be asked for
        fns["pydelatin"] = lambda: Delatin(h32, width=16, height=16, max_error=8.0).vertices
    except ImportError:
        pass
    for f in fns.values():
        f()
    times = {k: [] for k in fns}
    for _ in range(calls):
        for k, f in fns.items():
            t = time.perf_counter_ns()
            f()
            times[k].append(time.perf_counter_ns() - t)
    med = {k: statistics.median(v) / 1000 for k, v in times.items()}
    return med["rangemesh"], med.get("pydelatin")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=None)
    ap.add_argument("--repeat", type=peers.positive_int, default=7)
    args = ap.parse_args(argv)
    data = peers.find_data(args.data)
    if data is None:
        raise SystemExit("the shared data folder was not found (--data)")
    chair = data.resolve() / "odetics" / "chair-range.npy"  # the commands run in a temporary HOME
    cold, warm = first_mesh(chair, args.repeat)
    imp, imp_tri = imports(args.repeat)
    ours, delatin = fixed_cost()
    print("| what | median |")
    print("|---|---:|")
    print(f"| first `rangemesh mesh` on the chair, new HOME (empty caches) | {cold:.3f} s |")
    print(f"| the same command again (warm) | {warm:.3f} s |")
    print(f"| `import rangemesh` | {1000 * imp:.1f} ms |")
    print(f"| `import rangemesh` + `rangemesh.triangulate` | {1000 * imp_tri:.1f} ms |")
    print(f"| fixed cost of a call, 16 x 16 image, 10 vertices | {ours:.1f} us |")
    if delatin is not None:
        print(f"| pydelatin on the same heights (alternating calls) | {delatin:.1f} us |")


if __name__ == "__main__":
    main()
