"""Command line: ``rangemesh demo`` and ``rangemesh mesh``.

User errors print one line on stderr and exit with status 2; no traceback.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

from . import __version__, scenes
from .camera import Orthographic, Pinhole
from .metrics import evaluate
from .params import MeshParams
from .pipeline import triangulate

__all__ = ["main"]


class UserError(Exception):
    """A problem with the user's input, reported as one line."""


def _pair(text: str) -> tuple[int, int]:
    parts = text.lower().replace("x", ",").split(",")
    try:
        vals = [int(p) for p in parts]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected N or NxM, got {text!r}") from None
    if len(vals) == 1:
        vals = vals * 2
    if len(vals) != 2:
        raise argparse.ArgumentTypeError(f"expected N or NxM, got {text!r}")
    return vals[0], vals[1]


def _floats(n):
    def parse(text):
        try:
            vals = [float(p) for p in text.split(",")]
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {n} comma-separated numbers") from None
        if len(vals) != n:
            raise argparse.ArgumentTypeError(f"expected {n} comma-separated numbers, got {text!r}")
        return vals

    return parse


def _flips(text):
    return None if text.lower() in ("none", "off") else text


def _add_mesh_options(p):
    g = p.add_argument_group("the paper's parameters")
    g.add_argument("--tiles", type=_pair, default=(4, 4),
                   help="tiles VxH (rows x columns); neighbours share one line (default 4x4)")
    g.add_argument("--samples", type=_pair, default=(10, 10),
                   help="samples per tile RxZ; grid is ((R-1)V+1) x ((Z-1)H+1) (default 10x10)")
    g.add_argument("--sampling", choices=["adaptive", "uniform"], default="adaptive",
                   help="curvature-driven sampling (paper) or the uniform baseline")
    g.add_argument("--flips", type=_flips, default="disparity",
                   choices=["disparity", "error", None],
                   help="flip rule: disparity (paper), error (gain > 0), or none")
    g.add_argument("--delta", type=float, default=20.0,
                   help="upper disparity threshold Delta, degrees (default 20)")
    g.add_argument("--epsilon", type=float, default=0.3,
                   help="test 2: minimum disparity change, degrees (default 0.3)")
    g.add_argument("--max-angle", type=float, default=160.0,
                   help="test 3: internal angle of a degenerate triangle, degrees (default 160)")
    g.add_argument("--min-bend", type=float, default=5.0,
                   help="test 4: minimum bend between the new triangles, degrees (default 5)")
    g.add_argument("--curvature-floor", type=float, default=20.0,
                   help="curvature floor on a 0..255 depth scale (default 20)")
    g.add_argument("--levels", type=int, default=2,
                   help="resolutions added into the curvature image (default 2)")
    c = p.add_argument_group("camera")
    c.add_argument("--scale", type=_floats(3), metavar="KX,KY,KZ", default=None,
                   help="orthographic mapping X=kx*r, Y=ky*c, Z=kz*depth (default 1,1,1)")
    c.add_argument("--intrinsics", type=_floats(4), metavar="FX,FY,CX,CY", default=None,
                   help="pinhole camera; vertices become metric camera-frame points")
    c.add_argument("--depth-scale", type=float, default=1.0,
                   help="with --intrinsics: stored value x this = Z (e.g. 0.001 for mm)")


def _params(args) -> MeshParams:
    return MeshParams(tiles=args.tiles, samples=args.samples, sampling=args.sampling,
                      flips=args.flips, delta=args.delta, epsilon=args.epsilon,
                      max_angle=args.max_angle, min_bend=args.min_bend,
                      curvature_floor=args.curvature_floor, levels=args.levels)


def _camera(args):
    if args.intrinsics is not None:
        return Pinhole(*args.intrinsics, depth_scale=args.depth_scale)
    if args.scale is not None:
        return Orthographic(*args.scale)
    return Orthographic()


def _read(path: Path) -> np.ndarray:
    if not path.exists():
        raise UserError(f"{path}: no such file")
    suffix = path.suffix.lower()
    try:
        if suffix == ".npy":
            return np.load(path, allow_pickle=False)
        if suffix in (".tif", ".tiff"):
            import tifffile

            return tifffile.imread(path)
        import imageio.v3 as iio

        return iio.imread(path)
    except Exception as exc:  # readers raise many types; the user needs one line
        raise UserError(f"{path}: cannot read it as an image ({exc})") from None


def _write(mesh, path: Path):
    """Write through trimesh into a temporary file, then rename: never a half-written file."""
    known = (".ply", ".obj", ".off", ".stl", ".glb")
    if path.suffix.lower() not in known:
        raise UserError(f"{path}: unknown mesh format; use one of {', '.join(known)}")
    if not path.parent.exists():
        raise UserError(f"{path.parent}: folder does not exist")
    data = mesh.to_trimesh().export(file_type=path.suffix.lower()[1:])
    if isinstance(data, str):
        data = data.encode()
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _report(mesh, ev, args, out):
    s = mesh.stats
    if args.json:
        print(json.dumps({"stats": s.to_dict(), "evaluation": ev.to_dict() if ev else None}))
        return
    if args.quiet:
        return
    t = s.seconds
    print(f"vertices {s.vertices}  edges {s.edges}  triangles {s.triangles}  "
          f"flipped {s.flipped_edges}", file=sys.stderr)
    print("time " + "  ".join(f"{k} {1000 * v:.1f} ms" for k, v in t.items()), file=sys.stderr)
    if ev is not None:
        print(f"relative error {ev.relative_error:.3f} %  rms {ev.rms_error:.3f} %  "
              f"max {ev.max_error:.2f} %  uncovered {ev.uncovered:.2f} %", file=sys.stderr)
    if s.reason:
        print(f"empty mesh: {s.reason}", file=sys.stderr)
    if out:
        print(f"wrote {out}", file=sys.stderr)


def _cmd_mesh(args):
    img = _read(Path(args.image))
    bg = args.background
    try:
        mesh = triangulate(img, _params(args), background=bg, camera=_camera(args))
    except (ValueError, TypeError) as exc:
        raise UserError(f"{args.image}: {exc}") from None
    if mesh.is_empty:
        raise UserError(f"{args.image}: nothing to mesh: {mesh.stats.reason}")
    ev = evaluate(mesh, img, background=bg)
    if args.output:
        _write(mesh, Path(args.output))
    _report(mesh, ev, args, args.output)
    return 0


def _cmd_demo(args):
    sc = scenes.pyramid((160, 200), noise=0.0)
    box = scenes.box((160, 200))
    depth = np.where(box.labels == 1, box.depth, sc.depth)
    mesh = triangulate(depth, _params(args), camera=_camera(args))
    ev = evaluate(mesh, depth)
    out = Path(args.output)
    _write(mesh, out)
    _report(mesh, ev, args, out)
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``rangemesh`` command."""
    p = argparse.ArgumentParser(
        prog="rangemesh",
        description="Discontinuity-preserving adaptive triangle meshes from range images "
                    "(Garcia & Sappa 2004).",
    )
    p.add_argument("--version", action="version", version=f"rangemesh {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    m = sub.add_parser("mesh", help="mesh one range image")
    m.add_argument("image", help="range image: .npy, .png, .pgm/.ppm, .tif")
    m.add_argument("-o", "--output", help="mesh file to write: .ply .obj .off .stl .glb")
    m.add_argument("--background", type=float, default=None,
                   help="value that marks missing depth (NaN always does)")
    _add_mesh_options(m)
    d = sub.add_parser("demo", help="mesh a built-in synthetic scene (no input needed)")
    d.add_argument("-o", "--output", default="demo.ply", help="mesh file to write")
    _add_mesh_options(d)
    for q in (m, d):
        q.add_argument("--quiet", action="store_true", help="print nothing on success")
        q.add_argument("--json", action="store_true", help="print statistics as JSON on stdout")
    return p


def main(argv=None) -> int:
    """Entry point of the ``rangemesh`` command; returns the exit status."""
    args = build_parser().parse_args(argv)
    try:
        if args.command == "mesh":
            return _cmd_mesh(args)
        return _cmd_demo(args)
    except UserError as exc:
        print(f"rangemesh: error: {exc}", file=sys.stderr)
        return 2
    except (ValueError, TypeError) as exc:
        print(f"rangemesh: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
