"""Whole `triangulate` calls of this checkout against those of an earlier commit, side by side.

Run ``python benchmarks/against_commit.py --base COMMIT`` (``--only NAME`` for
some images, ``--repeat K``). The package as it was at COMMIT is taken from
git (``git archive``) into a temporary folder and imported under another name,
so both versions run in one process, call after call: on this shared, noisy
machine only alternating calls give ratios worth quoting. For every image of
``../shared/data`` and every synthetic scene, at 1 %, 3 % and 10 % of its valid
pixels as vertex counts (``method="refine"``, the LiDAR scan with its beams'
camera, as in ``budgets.py``; ``--diagonals`` to pass one; ``--default-target`` for
the default target alone, no ``vertices=``, each call ``--repeat`` times), it
prints both medians, their ratio (this checkout / COMMIT) and whether the
meshes are the same bit for bit; then the medians of the ratios over all
cases, the small images (at most 40,000 pixels) and the others.
"""

from __future__ import annotations

import argparse
import importlib
import io
import statistics
import subprocess
import sys
import tarfile
import tempfile
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import budgets  # noqa: E402  (the sibling scripts: images, cameras)
import peers  # noqa: E402

import rangemesh  # noqa: E402

SMALL_PIXELS = 40_000
NAME = "rangemesh_at_base"


def import_commit(commit: str, folder: Path):
    """The package as it was at `commit`, built (its compiled core too) and imported as `NAME`.

    The commit's tree is built into a wheel (``pip wheel``, about a minute, in a nanobind domain
    of its own) and unpacked under `folder`; its package folder is renamed. The extension keeps
    its file name, whose init symbol does not depend on the package's name, and
    the package imports itself relatively only: it runs as is beside this one.
    """
    tar = subprocess.run(["git", "-C", str(HERE.parent), "archive", commit],
                         check=True, capture_output=True).stdout
    src = folder / "src_tree"
    with tarfile.open(fileobj=io.BytesIO(tar)) as t:
        t.extractall(src, filter="data")
    wheels = folder / "wheels"
    print(f"building {commit} ...", file=sys.stderr, flush=True)
    # its own nanobind domain: two builds of one tree register the same types (nanobind aborts
    # on "refusing to add duplicate key") unless their domains differ
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(wheels),
                    "-C", f"cmake.define.CMAKE_CXX_FLAGS=-DNB_DOMAIN={NAME}", str(src)], check=True)
    (wheel,) = wheels.glob("rangemesh-*.whl")
    with zipfile.ZipFile(wheel) as z:
        z.extractall(folder / "site")
    (folder / "site" / "rangemesh").rename(folder / "site" / NAME)
    sys.path.insert(0, str(folder / "site"))
    return importlib.import_module(NAME)


def cameras(image, data, base):
    """The image's camera (its beams' for the LiDAR scan) in this checkout and in `base`."""
    cam = budgets.sensor_camera(image, data)
    if cam is None:
        return None, None
    for rel, _, _ in peers.IMAGES:
        if Path(rel).name == image.name:
            beams = data / rel.replace(".range.npy", ".beams.json")
            return cam, base.camera.Spherical.from_beams(beams)
    raise RuntimeError(f"no beams for {image.name}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", required=True, help="the commit to compare with")
    peers.add_image_options(ap)
    ap.add_argument("--repeat", type=peers.positive_int, default=21,
                    help="alternating calls on small images (a third on larger ones)")
    ap.add_argument("--diagonals", choices=("delaunay", "error"), default=None,
                    help="passed to both calls (COMMIT must know it); default: not passed")
    ap.add_argument("--default-target", action="store_true",
                    help="time the default target (no vertices=) instead of the 1/3/10 %% budgets")
    args = ap.parse_args(argv)
    data, images = peers.selected_images(args)
    rows = []
    extra = {} if args.diagonals is None else {"diagonals": args.diagonals}
    with tempfile.TemporaryDirectory() as tmp:
        base = import_commit(args.base, Path(tmp))
        print(f"| image | budget | vertices | {args.base} ms | now ms | ratio | same mesh |")
        print("|---|---:|---:|---:|---:|---:|---|")
        for image in images:
            cam_now, cam_base = cameras(image, data, base)
            _, valid = peers.to_depth_and_mask(image.depth, image.background)
            small = image.depth.size <= SMALL_PIXELS
            repeat = args.repeat if small or args.default_target else max(args.repeat // 3, 3)
            cases = [("default", None)] if args.default_target else budgets.vertex_budgets(valid)
            for frac, n in cases:
                # (the default target: no vertices=, as `rangemesh.triangulate(depth)` is called)
                asked = {} if n is None else {"vertices": n}

                def old(asked=asked, image=image, cam=cam_base):
                    return base.triangulate(image.depth, background=image.background,
                                            method="refine", camera=cam, **asked, **extra)

                def new(asked=asked, image=image, cam=cam_now):
                    return rangemesh.triangulate(image.depth, background=image.background,
                                                 method="refine", camera=cam, **asked, **extra)

                a, b = old(), new()
                same = (a.faces.shape == b.faces.shape and (a.faces == b.faces).all()
                        and a.vertices.shape == b.vertices.shape
                        and (a.vertices == b.vertices).all())
                _, (ms_old, ms_new) = peers.alternating_ms((old, new), repeat)
                rows.append((small, ms_new / ms_old))
                label = frac if n is None else f"{frac:.0%}"
                print(f"| {image.name[:30]} | {label} | {n or len(b.vertices)} | {ms_old:.2f} | "
                      f"{ms_new:.2f} | "
                      f"{ms_new / ms_old:.3f} | {'yes' if same else 'NO'} |", flush=True)
    for label, sel in (("all", rows), ("small images", [r for r in rows if r[0]]),
                       ("larger images", [r for r in rows if not r[0]])):
        if sel:
            ratios = [r for _, r in sel]
            print(f"{label}: {len(sel)} cases, time now / {args.base} median "
                  f"{statistics.median(ratios):.3f} ({min(ratios):.3f}-{max(ratios):.3f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
