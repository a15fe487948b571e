"""How a two-thread refine call's work splits per part, in instructions, and its modelled critical path.

Run ``python benchmarks/work_split.py --ext BUILD/_ext...so`` (``--help``). For the TUM and NYU
Kinect frames (640 x 480) at 1, 3 and 10 % of the valid pixels (``budgets.vertex_budgets``), it
runs one ``triangulate(..., vertices=N, method="refine")`` call on two threads
(``RANGEMESH_THREADS=2``) under valgrind's callgrind with ``--separate-threads=yes`` and sums
each part's inclusive instructions per thread (`PARTS`, by function). ``--ext`` is a build of
the core with its symbols kept (the same flags otherwise), loaded in place of the installed one::

    cmake -S . -B /tmp/rwdi -DSKBUILD=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo \\
          -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O3 -DNDEBUG -g" && cmake --build /tmp/rwdi --target _ext

Counts do not move with the machine's load; wall-clock times do. So the table's two-thread
figures are modelled: the serial parts plus, for each part that runs on two threads, the larger
thread's count, against the sum over the threads (one thread's work). Beyond two threads only
the parts split "all" ways (the fit's) shrink further. ``docs/benchmarks.md`` ("How the work
splits beyond two cores") holds its output.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

ANON = "rangemesh::refine::(anonymous namespace)::"
# (part, threads it can use: "2" the strips, "all" the fit's ranges, "1" serial, functions whose
# inclusive count it is (by the start of their name; "~": a piece of a started thread's mangled
# name), parts whose count it leaves out). A function's count is taken on every thread it runs
# on (valgrind numbers a new thread as an ended one: one file may hold several threads' work).
# Parts come before the parts that hold them.
PARTS = [
    ("first scans", "2", ["rangemesh::refine::Insertion::Insertion("], []),
    ("tail, one vertex at a time", "1", ["rangemesh::refine::merge_tail("], []),
    ("insertion rounds", "2", ["rangemesh::refine::Insertion::advance("], ["tail, one vertex at a time"]),
    ("diagonals by the error", "2", ["rangemesh::refine::flip_by_error("], []),
    ("strips' copies out", "2", [ANON + "finish("], ["diagonals by the error"]),
    ("strip starts (grid, first Delaunay)", "2", [ANON + "strip_start("], []),
    ("seam's flips", "1", ["rangemesh::refine::flip_from_edges("], []),
    ("join (A copied beside B renumbered)", "2", ["~join_strips("], []),
    ("seam's choice, worker start", "1", ["rangemesh::refine::insert_halves("],
     ["first scans", "tail, one vertex at a time", "insertion rounds", "diagonals by the error",
      "strips' copies out", "strip starts (grid, first Delaunay)", "seam's flips",
      "join (A copied beside B renumbered)"]),
    ("assembly (valid faces on two threads, one fan a vertex)", "2",
     [ANON + "assemble(", "~_Function_handler<void (), " + ANON + "split_valid_faces("], []),
    ("fit: sample of errors", "all",
     ["rangemesh::heights::sample_errors_checked(", "~heights21sample_errors_checked"], []),
    ("fit: pass over the pixels", "all",
     ["rangemesh::heights::fit_blocks_checked(", "~heights18fit_blocks_checked"], []),
    ("fit: solve", "1", ["rangemesh::heights::solve_blocks("], []),
    ("fit: median, checks", "1", ["rangemesh::heights::fit_heights("],
     ["fit: sample of errors", "fit: pass over the pixels", "fit: solve"]),
    ("edges beside the fit's set-up", "2", ["~rangemesh::count_edges<int>(", ANON + "fitted_depths("],
     ["fit: sample of errors", "fit: pass over the pixels", "fit: solve", "fit: median, checks"]),
]
TOTAL = "rangemesh::refine::refine_mesh("
THREAD = "<the thread>"  # (the key of a thread's whole count)


def run_one(args):
    """The child: one call under callgrind, the image from the driver's .npz."""
    import importlib.util

    import numpy as np

    spec = importlib.util.spec_from_file_location("rangemesh._core._ext", args.ext)
    mod = importlib.util.module_from_spec(spec)
    sys.modules["rangemesh._core._ext"] = mod
    spec.loader.exec_module(mod)
    from rangemesh import triangulate

    case = np.load(args.one)
    depth, n = case["depth"], int(case["n"])
    bg = float(case["background"]) if case["has_background"] else "auto"
    triangulate(depth, background=bg, vertices=n, method="refine")


def inclusive(path):
    """{function: inclusive instructions} of one thread's callgrind file (its own lines' counts
    plus its calls'), read from the file itself: callgrind_annotate lists a function once per
    source file its inlined lines come from."""
    names, res = {}, {}
    fn, callee, after_call = None, None, False
    with open(path) as f:
        for line in f:
            if line[0] in "0123456789+-*":
                if fn is not None and not (after_call and callee == fn):  # (recursion: counted once)
                    parts = line.split()
                    if len(parts) >= 2:
                        res[fn] = res.get(fn, 0) + int(parts[1])
                after_call = False
                continue
            if line.startswith("fn="):
                fn = _name(names, line[3:].strip())
            elif line.startswith("cfn="):
                callee = _name(names, line[4:].strip())
            elif line.startswith("summary:"):
                res[THREAD] = int(line.split()[1])
            elif line.startswith("calls="):
                after_call = True
    return res


def _name(names, text):
    """A compressed name "(id) name" or "(id)": the name, remembered by its id."""
    m = re.match(r"\((\d+)\)\s*(.*)$", text)
    if not m:
        return text
    if m.group(2):
        names[m.group(1)] = m.group(2)
    return names.get(m.group(1), text)


def counts_of(files):
    """Per part, [count on each thread] (threads with none left out), and the call's total."""
    threads = [inclusive(f) for f in files]
    total_main = sum(v for k, v in threads[0].items() if k.startswith(TOTAL))
    # the threads the call started: everything they ran
    others = sum(t.get(THREAD, 0) for t in threads[1:]  # (not numpy's BLAS threads)
                 if any(k.startswith("rangemesh::") for k in t))
    parts = {}
    for name, _, fns, minus in PARTS:
        per = []
        for i, t in enumerate(threads):
            # the outermost of each function's entries (its lambdas are inside it, or on
            # threads of their own)
            c = sum(max((v for k, v in t.items() if _matches(k, f)), default=0) for f in fns)
            if c:
                for m in minus:
                    c -= parts[m][i]
            per.append(c)
        parts[name] = per
    return parts, total_main + others


def _matches(name, pattern):
    return pattern[1:] in name if pattern.startswith("~") else name.startswith(pattern)


def model(parts, total, n_threads):
    """The modelled critical path of the call on `n_threads`, against one thread's work."""
    path = total
    for name, kind, _, _ in PARTS:
        per = [c for c in parts[name] if c > 0]
        s = sum(per)
        if kind == "2" and n_threads >= 2:
            path -= s - max(per, default=0)
        elif kind == "all" and n_threads >= 2:
            path -= s - s / n_threads if n_threads > 2 else s - max(per, default=0)
    return path / total


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ext", required=True, help="the core built with its symbols (_ext...so)")
    ap.add_argument("--data", type=Path, default=None, help="the shared data folder")
    ap.add_argument("--out", type=Path, default=Path(tempfile.gettempdir()) / "work_split")
    ap.add_argument("--only", default=None, help="TUM or NYU")
    ap.add_argument("--one", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.one:
        return run_one(args)

    import budgets
    import numpy as np
    import peers

    data = peers.find_data(args.data)
    args.out.mkdir(parents=True, exist_ok=True)
    cols, results = [], {}
    for key, rel in (("TUM", "open3d_TUM"), ("NYU", "open3d_NYU")):
        if args.only and args.only != key:
            continue
        images, _ = peers.load_images(data, False, only=rel)
        image = images[0]
        _, valid = peers.to_depth_and_mask(image.depth, image.background)
        for frac, n in budgets.vertex_budgets(valid):
            tag = f"{key}_{round(frac * 100)}"
            npz = args.out / f"{tag}.npz"
            np.savez(npz, depth=image.depth, n=n, has_background=image.background is not None,
                     background=image.background if image.background is not None else 0)
            cg = args.out / f"{tag}.cg"
            for old in args.out.glob(f"{tag}.cg*"):
                old.unlink()
            env = dict(os.environ, RANGEMESH_THREADS="2")
            subprocess.run(["valgrind", "--tool=callgrind", "--separate-threads=yes",
                            f"--callgrind-out-file={cg}", sys.executable, __file__, "--ext", args.ext,
                            "--one", str(npz)], env=env, check=True, capture_output=True)
            files = sorted(args.out.glob(f"{tag}.cg-*"))
            parts, total = counts_of(files)
            results[f"{key} {round(frac * 100)} %"] = {"parts": parts, "total": total}
            cols.append(f"{key} {round(frac * 100)} %")
            print(f"{tag}: {total / 1e6:.0f}M instructions", file=sys.stderr, flush=True)
    (args.out / "work_split.json").write_text(json.dumps(results, indent=1))
    print("| part | threads | " + " | ".join(cols) + " |")
    print("|---|---|" + "---:|" * len(cols))
    for name, kind, _, _ in PARTS:
        cells = []
        for c in cols:
            per = [x for x in results[c]["parts"][name] if x > 0]
            tot = results[c]["total"]
            share = 100.0 * sum(per) / tot
            inside = " / ".join(f"{x / 1e6:.0f}" for x in per) if kind != "1" else f"{sum(per) / 1e6:.1f}"
            cells.append(f"{share:.1f} ({inside})")
        print(f"| {name} | {kind} | " + " | ".join(cells) + " |")
    rest = []
    for c in cols:
        accounted = sum(sum(results[c]["parts"][p]) for p, *_ in PARTS)
        tot = results[c]["total"]
        rest.append(f"{100.0 * (tot - accounted) / tot:.1f} ({(tot - accounted) / 1e6:.1f})")
    print("| lift, count search, rest | 1 | " + " | ".join(rest) + " |")
    print("| **1-thread total, M instructions** | | "
          + " | ".join(f"{results[c]['total'] / 1e6:.0f}" for c in cols) + " |")
    serial = []
    for c in cols:
        par = sum(sum(results[c]["parts"][p]) for p, k, *_ in PARTS if k != "1")
        serial.append(f"{100.0 * (1 - par / results[c]['total']):.1f} %")
    print("| serial share | | " + " | ".join(serial) + " |")
    for t in (2, 4, 8):
        print(f"| **critical path / 1 thread, {t} threads** | | "
              + " | ".join(f"{model(results[c]['parts'], results[c]['total'], t):.3f}" for c in cols) + " |")


if __name__ == "__main__":
    main()
