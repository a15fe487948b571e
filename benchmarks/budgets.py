"""method="refine" against its targets: 1 %, 3 % and 10 % of the valid pixels as vertex counts.

Run ``python benchmarks/budgets.py`` (``--quick`` for three images, ``--help``).
For every image of ``../shared/data`` and every synthetic scene of the
package, at each budget it meshes with

* rangemesh ``method="refine"`` (greedy insertion), fitted vertex depths (the default), copied
  ones (``heights="pixel"``), and copied ones with greedy insertion's Delaunay diagonals
  (``heights="pixel", diagonals="delaunay"``: the fastest; a second table weighs what the
  default's fit and diagonals cost in time against the error they save);
* pydelatin (greedy insertion, Garland-Heckbert), asked for the count that
  puts as many vertices on valid pixels;
* fast-simplification (quadric decimation) of the full-resolution grid mesh;

and evaluates every mesh with `rangemesh.evaluate`. The LiDAR scan is meshed with its
beams' camera (`Spherical.from_beams`), as a user of that sensor would: its rows lie 3x
farther apart than its columns, and the Delaunay test weighs them so; the peers see the same
range image. It prints one row per
case and the medians over the cases of the issue's target ratios: mean
relative error against quadric decimation (target <= 1.0), error within 2 px
of jumps and creases against pydelatin (target <= 1.0), and whole-call time
against pydelatin (target <= 1.0). Times are medians of ``--repeat`` calls in
one process, measured side by side (the peers' hole filling, grid building
and count search are not timed, as in ``benchmarks/peers.py``).

The default's time is measured on one thread and on two (`thread_times`): its
calls and pydelatin's alternate, pinned to one core and timed in CPU seconds
(``time.process_time``: what another process's load takes from the wall clock
is not charged); then one-thread and two-thread calls, free on the process's
cores, timed on the wall clock. The other variants are timed as the one-thread
calls are. "time / pydelatin" is the one-thread ratio; a
third table gives two threads against one (target <= 0.6 on 640 x 480 frames).
The report starts with the commit and the machine's load: a two-thread time
is only meaningful when a second core is free.

With ``--diagonals delaunay`` rangemesh's meshes keep greedy insertion's Delaunay diagonals
instead of the default's error-chosen ones (`rangemesh.refine.diagonals`), in both variants
and in the bound checks.

A second table checks ``max_error=E`` (E = 1 % and 0.3 %) on every image:
whether the bound holds, and its time against one ``vertices=N`` call at the
count it landed on (target <= 2).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import peers  # noqa: E402  (the sibling script: images, peers and timing)

from rangemesh.camera import Spherical  # noqa: E402
from rangemesh.pipeline import triangulate  # noqa: E402
from rangemesh.threads import THREADS_VARIABLE  # noqa: E402

FRACTIONS = (0.01, 0.03, 0.10)
MIN_VERTICES = 50
MINE = "refine, fitted depths"
FASTEST = "refine, pixel depths, Delaunay diagonals"
VARIANTS = [(MINE, {}), ("refine, pixel depths", {"heights": "pixel"}),
            (FASTEST, {"heights": "pixel", "diagonals": "delaunay"})]


def sensor_camera(image, data):
    """The camera of the sensor where the data ships one (a LiDAR scan's ``.beams.json``), else None."""
    for rel, _, _ in peers.IMAGES if data is not None else ():
        if Path(rel).name == image.name and rel.endswith(".range.npy"):
            beams = data / rel.replace(".range.npy", ".beams.json")
            if beams.exists():
                return Spherical.from_beams(beams)
    return None


def vertex_budgets(valid):
    """``(fraction, vertex count)`` of each budget: FRACTIONS of the valid pixels, at least 50.

    Every benchmark that meshes at 1, 3 and 10 % takes its counts from here.
    """
    n_valid = int(valid.sum())
    return [(frac, max(int(frac * n_valid), MIN_VERTICES)) for frac in FRACTIONS]


def budget_cases(images, data):
    """Every image at every budget: ``(image, camera, masked depth, valid, fraction, count)``.

    The camera is the sensor's where the data ships one (`sensor_camera`); the
    masked depth and the valid pixels are `peers.to_depth_and_mask`'s.
    """
    for image in images:
        masked, valid = peers.to_depth_and_mask(image.depth, image.background)
        camera = sensor_camera(image, data)
        for frac, n in vertex_budgets(valid):
            yield image, camera, masked, valid, frac, n


def _on_threads(n, fn, pin=False):
    """`fn()` with ``RANGEMESH_THREADS=n``; `pin`: this thread (and those it starts) on one core."""
    cores = sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None
    before = os.environ.get(THREADS_VARIABLE)
    os.environ[THREADS_VARIABLE] = str(n)
    try:
        if cores is not None and pin:
            os.sched_setaffinity(0, cores[:1])
        return fn()
    finally:
        if cores is not None and pin:
            os.sched_setaffinity(0, cores)
        if before is None:
            del os.environ[THREADS_VARIABLE]
        else:
            os.environ[THREADS_VARIABLE] = before


def thread_times(call, delatin, repeat):
    """One thread against pydelatin, two threads against one: medians of alternating calls.

    Returns ``(mesh, {"cpu1": ms, "delatin": ms, "wall1": ms, "wall2": ms})``: `call`
    on one thread and pydelatin's `delatin`, each pinned to one core, in CPU time; `call`
    on one thread and on two, free on the process's cores alike, in wall time. The
    mesh is the one-thread call's (the two-thread mesh is the same: the golden tests).
    """
    two = _cores() >= 2
    times = {"cpu1": [], "delatin": [], "wall1": [], "wall2": []}
    mesh = _on_threads(1, call, pin=True)  # warm-up
    _on_threads(1, delatin, pin=True)
    for _ in range(repeat):
        c = time.process_time()
        mesh = _on_threads(1, call, pin=True)
        times["cpu1"].append(time.process_time() - c)
        c = time.process_time()
        _on_threads(1, delatin, pin=True)
        times["delatin"].append(time.process_time() - c)
        w = time.perf_counter()
        _on_threads(1, call)
        times["wall1"].append(time.perf_counter() - w)
        if two:
            w = time.perf_counter()
            _on_threads(2, call)
            times["wall2"].append(time.perf_counter() - w)
    return mesh, {k: 1000.0 * statistics.median(v) if v else float("nan") for k, v in times.items()}


def one_thread_ms(call, repeat):
    """``(mesh, ms)``: `call` on one thread pinned to one core, median CPU ms after a warm-up."""
    mesh = _on_threads(1, call, pin=True)
    times = []
    for _ in range(repeat):
        c = time.process_time()
        mesh = _on_threads(1, call, pin=True)
        times.append(time.process_time() - c)
    return mesh, 1000.0 * statistics.median(times)


def _cores():
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def run(images, repeat, data=None, log=print, extra=None):
    """One row of figures per image and budget; `extra` goes to every rangemesh call."""
    extra = extra or {}
    rows = []
    for image, camera, masked, valid, frac, n in budget_cases(images, data):
        got = {}
        calls = {}
        for label, opts in VARIANTS:
            calls[label] = (lambda opts=opts, image=image, n=n, camera=camera: triangulate(
                image.depth, background=image.background, vertices=n, method="refine",
                camera=camera, **opts, **extra))
            if label == MINE:
                continue  # timed below, against pydelatin and on two threads
            mesh, ms = one_thread_ms(calls[label], repeat)
            got[label] = peers._record(image, f"{frac:.0%}", label, mesh, ms, valid)
        mesh = calls[MINE]()
        n_mine = max(peers._valid_vertex_count(mesh, valid), 4)
        from pydelatin import Delatin

        arr, ask = peers.delatin_request(masked, valid, n_mine)
        mesh, t = thread_times(calls[MINE],
                               lambda arr=arr, ask=ask: Delatin(arr, max_error=0.0, max_points=ask),
                               repeat)
        got[MINE] = peers._record(image, f"{frac:.0%}", MINE, mesh, t["cpu1"], valid)
        got[MINE].update(wall1=t["wall1"], wall2=t["wall2"], shape=image.depth.shape[:2])
        tin = Delatin(arr, max_error=0.0, max_points=ask)
        got["pydelatin"] = peers._record(image, f"{frac:.0%}", "pydelatin",
                                         peers.delatin_mesh(tin, masked.shape), t["delatin"], valid)
        mesh, ms = peers.peer_quadric(masked, valid, n_mine, repeat)
        got["quadric decimation"] = peers._record(image, f"{frac:.0%}", "quadric decimation", mesh,
                                                  ms, valid)
        rows.append(got)
        m, d, q = got[MINE], got["pydelatin"], got["quadric decimation"]
        log(f"{image.name[:30]:30s} {frac:4.0%} {n_mine:7d} | err {m['relative_error']:.4f} "
            f"pix {got['refine, pixel depths']['relative_error']:.4f} "
            f"quadric {q['relative_error']:.4f} delatin {d['relative_error']:.4f} | band "
            f"{m['edge_band_error']:.3f} delatin {d['edge_band_error']:.3f} | ms "
            f"{m['ms']:.1f} delatin {d['ms']:.1f} | 2 threads / 1 {_ratio_text(m['wall2'], m['wall1'])} "
            f"| uncovered {m['uncovered']:.2f} %")
    return rows


def _ratio_text(a, b):
    return f"{a / b:.2f}" if a == a else "n/a"  # (NaN: one core, no two-thread call)


def thread_summary(rows):
    """Per budget, on 640 x 480 frames and on all images: median and max of two threads / one."""
    out = []
    for frac in (None, *FRACTIONS):
        sel = [g[MINE] for g in rows if frac is None or g[MINE]["budget"] == f"{frac:.0%}"]
        for which, pick in (("640 x 480", [m for m in sel if tuple(m["shape"]) == (480, 640)]),
                            ("every image", sel)):
            ratios = [m["wall2"] / m["wall1"] for m in pick]
            if ratios:
                out.append((frac, which, len(ratios), statistics.median(ratios), max(ratios)))
    return out


def header():
    """The commit measured and the machine's load, the first line of a report."""
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True, cwd=Path(__file__).resolve().parent).stdout.strip()
    except OSError:
        commit = ""
    load = " ".join(f"{x:.2f}" for x in os.getloadavg()) if hasattr(os, "getloadavg") else "?"
    return (f"commit {commit or '?'}, load average {load} on {os.cpu_count()} cores, "
            f"{_cores()} for this process")


# Errors below a millionth of the depth range (in percent: 1e-4) count as exact: ratios
# of two rounding residues would say nothing.
EXACT = 1e-4


def error_bounds(images, repeat, data=None, log=print, extra=None):
    """max_error=E on every image: bound held, meshings, time against vertices=N at its count."""
    from rangemesh.metrics import evaluate

    extra = extra or {}
    rows = []
    for image in images:
        camera = sensor_camera(image, data)
        for bound in (1.0, 0.3):
            mesh, ms = peers._timed(lambda image=image, bound=bound, camera=camera: triangulate(
                image.depth, background=image.background, max_error=bound, camera=camera,
                **extra),
                repeat)
            n = len(mesh.vertices)
            _, ms_n = peers._timed(lambda image=image, n=n, camera=camera: triangulate(
                image.depth, background=image.background, vertices=n, camera=camera, **extra),
                repeat)
            err = evaluate(mesh, image.depth, background=image.background).relative_error
            rows.append((image.name, bound, n, err, mesh.stats.target.meshings, ms, ms_n))
            log(f"{image.name[:30]:30s} max_error {bound}: {n} vertices, error {err:.3f} % "
                f"({'held' if err <= bound else 'MISSED'}), {ms:.1f} ms against {ms_n:.1f} ms")
    return rows


def _ratio(a, b):
    return max(a, EXACT) / max(b, EXACT)


def summary(rows):
    """Medians over the cases of the target ratios, overall and per budget."""
    out = []
    for frac in (None, *FRACTIONS):
        sel = [g for g in rows if frac is None or g[MINE]["budget"] == f"{frac:.0%}"]
        if not sel:
            continue
        err = statistics.median(_ratio(g[MINE]["relative_error"],
                                       g["quadric decimation"]["relative_error"]) for g in sel)
        fit = statistics.median(_ratio(g[MINE]["relative_error"],
                                       g["refine, pixel depths"]["relative_error"]) for g in sel)
        band = statistics.median(_ratio(g[MINE]["edge_band_error"],
                                        g["pydelatin"]["edge_band_error"]) for g in sel)
        ms = statistics.median(_ratio(g[MINE]["ms"], g["pydelatin"]["ms"]) for g in sel)
        worst = max(g[MINE]["uncovered"] for g in sel)
        fast_ms = statistics.median(_ratio(g[FASTEST]["ms"], g["pydelatin"]["ms"]) for g in sel)
        fast_err = statistics.median(_ratio(g[FASTEST]["relative_error"],
                                            g["pydelatin"]["relative_error"]) for g in sel)
        mine_err = statistics.median(_ratio(g[MINE]["relative_error"],
                                            g["pydelatin"]["relative_error"]) for g in sel)
        ms_max = max(_ratio(g[MINE]["ms"], g["pydelatin"]["ms"]) for g in sel)
        fast_max = max(_ratio(g[FASTEST]["ms"], g["pydelatin"]["ms"]) for g in sel)
        out.append((frac, len(sel), err, fit, band, ms, worst, mine_err, fast_ms, fast_err,
                    ms_max, fast_max))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python benchmarks/budgets.py", description=__doc__.split("\n")[0])
    ap.add_argument("--data", type=Path, default=None, help="the shared data folder")
    ap.add_argument("--quick", action="store_true", help="three real images, two scenes")
    ap.add_argument("--repeat", type=peers.positive_int, default=3, help="timed calls per case (default 3)")
    ap.add_argument("--only", default=None, metavar="TEXT",
                    help="only the inputs whose name contains TEXT (e.g. rellis3d)")
    ap.add_argument("--diagonals", choices=["delaunay", "error"], default=None,
                    help="rangemesh's diagonals (default: the library's, error)")
    args = ap.parse_args(argv)
    extra = {} if args.diagonals is None else {"diagonals": args.diagonals}
    data = peers.find_data(args.data)
    images, missing = peers.load_images(data, args.quick, args.only)
    for m in missing:
        print(f"skipped: {m}", file=sys.stderr)
    print(header())
    rows = run(images, args.repeat, data, extra=extra)
    print("\n| budget | cases | error / quadric | fitted / pixel depths | edge band / pydelatin "
          "| time / pydelatin | worst uncovered % |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    table = summary(rows)
    for frac, n, err, fit, band, ms, worst, *_ in table:
        name = "all" if frac is None else f"{frac:.0%} of valid pixels"
        print(f"| {name} | {n} | {err:.2f} | {fit:.2f} | {band:.2f} | {ms:.2f} | {worst:.2f} |")
    # what the default's fitted depths and error-chosen diagonals cost in time, and buy
    print(f"\n| budget | cases | default: error / pydelatin | time / pydelatin (max) "
          f"| {FASTEST}: error / pydelatin | time / pydelatin (max) |")
    print("|---|---:|---:|---:|---:|---:|")
    for frac, n, _, _, _, ms, _, mine_err, fast_ms, fast_err, ms_max, fast_max in table:
        name = "all" if frac is None else f"{frac:.0%} of valid pixels"
        print(f"| {name} | {n} | {mine_err:.2f} | {ms:.2f} ({ms_max:.2f}) | {fast_err:.2f} "
              f"| {fast_ms:.2f} ({fast_max:.2f}) |")
    # two threads against one (wall clock; "n/a": this process has one core)
    print("\n| budget | images | 2 threads / 1 thread: median | max |")
    print("|---|---|---:|---:|")
    for frac, which, n, med, worst in thread_summary(rows):
        name = "all budgets" if frac is None else f"{frac:.0%} of valid pixels"
        fig = (f"{med:.2f} | {worst:.2f}" if med == med else "n/a | n/a")
        print(f"| {name} | {which} ({n}) | {fig} |")
    bounds = error_bounds(images, args.repeat, data, extra=extra)
    held = sum(err <= bound for _, bound, _, err, *_ in bounds)
    times = [ms / ms_n for *_, ms, ms_n in bounds]
    print(f"\nmax_error: the bound held on {held} of {len(bounds)} cases; meshings at most "
          f"{max(b[4] for b in bounds)}; time against vertices=N at the same count: median "
          f"{statistics.median(times):.2f}, max {max(times):.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
