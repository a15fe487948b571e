"""Where should an error-bounded refine call stop its first insertion?

Under ``max_error=E`` the native search stops the first insertion once its summed
|depth - plane| (copied depths) is ``MAX_ERROR_STOP`` times E's (``E / 100 * span *
n_valid``), fits the heights and renders; a miss meshes again. This meshes every shared
image and scene at each stop factor, for the default target and explicit bounds, and
prints the vertices, the rendered error and the meshings; ``--time`` also times the
default on the 640 x 480 frames (``time.process_time``, factors interleaved, median).

    RANGEMESH_THREADS=1 taskset -c 0 python benchmarks/error_stop.py [--time] [--only NAME]
"""

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import budgets  # noqa: E402
import peers  # noqa: E402

from rangemesh.pipeline import triangulate  # noqa: E402
from rangemesh.refine import insertion  # noqa: E402

FACTORS = (1.0, 1.15, 1.25, 1.35, 1.5)
TARGETS = {"default": {}, "0.3": {"method": "refine", "max_error": 0.3},
           "1.0": {"method": "refine", "max_error": 1.0}}
TIMED = ("open3d_TUM", "open3d_NYU", "slambook2")  # the shared 640 x 480 Kinect frames


def mesh_at(image, camera, factor, kw):
    """The mesh of `image` with the first stop at `factor` times the bound's sum."""
    insertion.MAX_ERROR_STOP = factor
    return triangulate(image.depth, background=image.background, camera=camera, **kw)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    peers.add_image_options(ap)
    ap.add_argument("--factors", nargs="*", type=float, default=list(FACTORS))
    ap.add_argument("--targets", nargs="*", default=list(TARGETS), choices=list(TARGETS))
    ap.add_argument("--time", action="store_true", help="time the default on the VGA frames")
    ap.add_argument("--repeats", type=int, default=9)
    ap.add_argument("--golden", action="store_true",
                    help="only tests/golden_refine.py's max_error cases: vertices, error, ms")
    args = ap.parse_args(argv)
    data, images = peers.selected_images(args)
    kept = insertion.MAX_ERROR_STOP
    try:
        golden(args, data) if args.golden else run(args, data, images)
    finally:
        insertion.MAX_ERROR_STOP = kept


def run(args, data, images):
    """Print the tables of `main`."""
    head = " | ".join(f"x{f:g}" for f in args.factors)
    print(f"vertices / rendered error % / meshings per stop factor\n\n| image | target | {head} |")
    print("|---|---|" + "---:|" * len(args.factors))
    missed = {f: [] for f in args.factors}
    for image in images:
        camera = budgets.sensor_camera(image, data)
        for tname in args.targets:
            cells = []
            for f in args.factors:
                t = mesh_at(image, camera, f, TARGETS[tname]).stats.target
                if not t.met or t.meshings > 1:
                    missed[f].append(f"{image.name} {tname}: {t.meshings} meshings, "
                                     f"{t.achieved:.3f} %{'' if t.met else ' (not met)'}")
                cells.append(f"{t.vertices} / {t.achieved:.3f} / {t.meshings}")
            print(f"| {image.name} | {tname} | " + " | ".join(cells) + " |", flush=True)
    for f, rows in missed.items():
        print(f"\nx{f:g}: more than one meshing or not met: " + ("; ".join(rows) or "none"))
    if not args.time:
        return
    print(f"\ndefault target, ms (process time, median of {args.repeats}, factors interleaved)\n")
    print(f"| image | {head} |\n|---|" + "---:|" * len(args.factors))
    for image in images:
        if not any(n in image.name for n in TIMED):
            continue
        camera = budgets.sensor_camera(image, data)
        runs = {f: [] for f in args.factors}
        for _ in range(args.repeats):
            for f in args.factors:
                t0 = time.process_time()
                mesh_at(image, camera, f, {})
                runs[f].append(time.process_time() - t0)
        print(f"| {image.name} | " + " | ".join(f"{1e3 * statistics.median(runs[f]):.1f}"
                                                for f in args.factors) + " |", flush=True)


def golden(args, data):
    """The error-bounded cases of tests/data/golden_refine.json at each factor."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from tests import golden_refine

    inputs = {f"crop:{k}": v for k, v in golden_refine.crop_inputs().items()}
    inputs.update({f"scene:{k}": v for k, v in golden_refine.scene_inputs().items()})
    if data is not None:
        inputs.update({f"full:{k}": v for k, v in golden_refine.full_inputs(data).items()})
    head = " | ".join(f"x{f:g}" for f in args.factors)
    print(f"vertices / rendered error % / ms (process time, median of {args.repeats})\n")
    for cname, config in golden_refine.CONFIGS:
        if "max_error" not in config:
            continue
        print(f"| {cname} | {head} |\n|---|" + "---:|" * len(args.factors))
        for name, inp in inputs.items():
            if not golden_refine.applies(inp, config):
                continue
            runs, last = {f: [] for f in args.factors}, {}
            for _ in range(args.repeats):
                for f in args.factors:
                    insertion.MAX_ERROR_STOP = f
                    t0 = time.process_time()
                    last[f] = golden_refine.mesh(inp, config, 1)[0].stats.target
                    runs[f].append(time.process_time() - t0)
            print(f"| {name} | " + " | ".join(
                f"{last[f].vertices} / {last[f].achieved:.3f} / {1e3 * statistics.median(runs[f]):.1f}"
                for f in args.factors) + " |", flush=True)


if __name__ == "__main__":
    main()
