"""Instructions of refine's default and of pydelatin on 640 x 480 frames, counted by callgrind.

Run ``python benchmarks/insertion_counts.py`` (``--help``). For the TUM and NYU Kinect frames of
``../shared/data`` at 1, 3 and 10 % of the valid pixels (`budgets.vertex_budgets`) it meshes
with ``method="refine"``'s default (``RANGEMESH_THREADS=1``) and with pydelatin
(``Delatin(z, max_error=0, max_points=N)``, asked for the count that puts as many vertices on
valid pixels, as ``benchmarks/budgets.py`` asks) under valgrind's callgrind, and prints the
instructions of each native call: ``refine_mesh`` for rangemesh, ``Triangulator::Run`` for
pydelatin (Python's argument checks and wrapping are not counted). The machine's load does not
change these counts, so an A/B of two builds needs no quiet machine.

With ``--ext PATH`` the rangemesh extension is loaded from PATH (a build kept with its symbols,
e.g. CMake's ``RelWithDebInfo`` with ``-O3 -DNDEBUG -g -fno-stack-protector``, the Release
build's code), and ``--functions`` adds each call's inclusive counts of the insertion's
functions (symbols needed). The requests (our valid vertex counts, pydelatin's ``max_points``)
are searched once, outside valgrind, and cached in ``--cache``.
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
FRAMES = [("rgbd/open3d_TUM_depth.png", 0, "TUM"), ("rgbd/open3d_NYU_depth.raw.npy", 2047, "NYU")]
OURS = "rangemesh::refine::refine_mesh(*"
THEIRS = "Triangulator::Run(*"
# the insertion's functions whose inclusive counts --functions prints (symbol prefixes)
FUNCTIONS = ["rangemesh::refine::Insertion::advance", "rangemesh::refine::Insertion::scan(",
             "rangemesh::refine::scan_triangle", "rangemesh::refine::Insertion::legalize",
             "rangemesh::refine::Insertion::insert(", "rangemesh::refine::Insertion::Insertion("]


def load_ext(path):
    """Put the extension at `path` in place of the installed one, before rangemesh is imported."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("rangemesh._core._ext", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules["rangemesh._core._ext"] = mod
    spec.loader.exec_module(mod)


def prepare(data, cache):
    """Each case's request: ``[{name, rel, bg, frac, n, n_mine, ask}]``, searched once and cached."""
    if cache.exists():
        return json.loads(cache.read_text())
    sys.path.insert(0, str(HERE))
    import budgets  # noqa: PLC0415
    import peers  # noqa: PLC0415

    from rangemesh.io import read_range_image
    from rangemesh.pipeline import triangulate
    from rangemesh.prepare import to_depth_and_mask

    os.environ["RANGEMESH_THREADS"] = "1"
    cases = []
    for rel, bg, name in FRAMES:
        img = read_range_image(data / rel)
        masked, valid = to_depth_and_mask(img, bg)
        for frac, n in budgets.vertex_budgets(valid):
            mesh = triangulate(img, background=bg, vertices=n, method="refine")
            n_mine = max(peers._valid_vertex_count(mesh, valid), 4)
            _, ask = peers.delatin_request(masked, valid, n_mine)
            cases.append(dict(name=name, rel=rel, bg=bg, frac=frac, n=n, n_mine=n_mine, ask=int(ask)))
    cache.write_text(json.dumps(cases, indent=1))
    return cases


DUMP_C = """#include <valgrind/callgrind.h>
void dump(void) { CALLGRIND_DUMP_STATS; }
"""


def dumper():
    """A function that makes callgrind write its counts so far (and zero them): a tiny C library."""
    lib = Path(tempfile.gettempdir()) / "insertion_counts_dump.so"
    if not lib.exists():
        src = lib.with_suffix(".c")
        src.write_text(DUMP_C)
        subprocess.run(["cc", "-O1", "-shared", "-fPIC", "-o", str(lib), str(src)], check=True)
    return str(lib)


def child(which, data, cases, ext):
    """The calls callgrind counts: every case, one call each, in order, each dumped apart."""
    import ctypes

    dump = ctypes.CDLL(dumper()).dump
    os.environ["RANGEMESH_THREADS"] = "1"
    if ext:
        load_ext(ext)
    import numpy as np  # noqa: F401

    from rangemesh.io import read_range_image
    from rangemesh.pipeline import triangulate
    from rangemesh.prepare import to_depth_and_mask

    sys.path.insert(0, str(HERE))
    import peers  # noqa: PLC0415

    for case in cases:
        img = read_range_image(data / case["rel"])
        if which == "ours":
            triangulate(img, background=case["bg"], vertices=case["n"], method="refine")
        else:
            from pydelatin import Delatin

            masked, valid = to_depth_and_mask(img, case["bg"])
            arr = peers._filled(masked, valid)
            Delatin(arr, max_error=0.0, max_points=case["ask"])
        dump()


def count(which, data, cases, ext, functions, keep=None):
    """Per case: the call's instructions, and with `functions` each function's inclusive count.

    `keep`: a folder to copy the callgrind dumps to (``<which>.<case>``, for callgrind_annotate).
    """
    fn = OURS if which == "ours" else THEIRS
    dumper()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "cg.out"
        cmd = ["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", "--collect-atstart=no",
               f"--toggle-collect={fn}", sys.executable, __file__, "--child", which,
               "--data", str(data), "--cases", json.dumps(cases)] + (["--ext", ext] if ext else [])
        res = subprocess.run(cmd, capture_output=True, text=True)
        if res.returncode != 0:
            raise RuntimeError(res.stderr[-3000:])
        dumps = sorted(glob.glob(f"{out}.*"), key=lambda p: int(p.rsplit(".", 1)[1]))
        dumps = [d for d in dumps if _total(d) > 0]
        if len(dumps) != len(cases):
            raise RuntimeError(f"{len(dumps)} dumps for {len(cases)} cases")
        rows = []
        if keep:
            keep.mkdir(parents=True, exist_ok=True)
            for i, d in enumerate(dumps):
                shutil.copy(d, keep / f"{which}.{i}")
        for d in dumps:
            row = {"total": _total(d)}
            if functions:
                row.update(_inclusive(d))
            rows.append(row)
        return rows


def _total(path):
    for line in Path(path).read_text(errors="replace").splitlines():
        if line.startswith("totals:") or line.startswith("summary:"):
            return int(line.split()[1])
    return 0


def _inclusive(path):
    """Inclusive instructions and calls of FUNCTIONS in one dump (callgrind_annotate's)."""
    res = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=100", path],
                         capture_output=True, text=True)
    got = {}
    for line in res.stdout.splitlines():
        m = re.match(r"\s*([\d,]+) \([^)]*\)\s+(.*)", line)
        if not m:
            continue
        for f in FUNCTIONS:
            if f not in got and f in m.group(2):
                got[f] = int(m.group(1).replace(",", ""))
    return got


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    data = os.environ.get("RANGEMESH_DATA", HERE.parent.parent / "shared/data")
    ap.add_argument("--data", type=Path, default=Path(data))
    ap.add_argument("--ext", help="the rangemesh extension to load (a build with symbols)")
    ap.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "insertion_counts_cases.json")
    ap.add_argument("--which", choices=["ours", "theirs", "both"], default="both")
    ap.add_argument("--functions", action="store_true", help="the insertion's functions too (needs --ext)")
    ap.add_argument("--json", type=Path, help="write the counts here")
    ap.add_argument("--keep", type=Path, help="copy the callgrind dumps to this folder")
    ap.add_argument("--only", help="the cases whose 'NAME FRACTION' (e.g. 'TUM 0.1') contains this")
    ap.add_argument("--child", choices=["ours", "theirs"], help=argparse.SUPPRESS)
    ap.add_argument("--cases", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        child(args.child, args.data, json.loads(args.cases), args.ext)
        return
    cases = prepare(args.data, args.cache)
    whiches = ["ours", "theirs"] if args.which == "both" else [args.which]
    if args.only:
        cases = [c for c in cases if args.only in f"{c['name']} {c['frac']}"]
    counts = {w: count(w, args.data, cases, args.ext, args.functions, args.keep) for w in whiches}
    head = " ".join(f"{w + ' Minstr':>14s}" for w in whiches)
    print(f"{'frame':5s} {'budget':>6s} {'vertices':>8s} " + head
          + ("  ours/theirs" if len(whiches) == 2 else ""))
    for i, c in enumerate(cases):
        vals = [counts[w][i]["total"] for w in whiches]
        line = f"{c['name']:5s} {c['frac']:6.0%} {c['n_mine']:8d} " + " ".join(f"{v / 1e6:14.2f}"
                                                                                for v in vals)
        if len(whiches) == 2:
            line += f"  {vals[0] / vals[1]:11.3f}"
        print(line)
        if args.functions and "ours" in counts:
            for f in FUNCTIONS:
                if f in counts["ours"][i]:
                    print(f"      {f:50s} {counts['ours'][i][f] / 1e6:10.2f} M")
    if args.json:
        args.json.write_text(json.dumps({"cases": cases, "counts": counts}, indent=1))


if __name__ == "__main__":
    main()
