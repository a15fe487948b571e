"""The ``rangemesh`` command: ``mesh``, ``info``, ``eval`` and ``demo``.

User errors print one line on stderr (``rangemesh: error: ...``) and exit
with status 2; no traceback. Outputs are written atomically.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import signal
import sys
import threading
import time
from pathlib import Path

import numpy as np

from . import scenes
from ._version import __version__
from .camera import Orthographic, Pinhole, Spherical
from .io import (
    IMAGE_SUFFIXES,
    MESH_SUFFIXES,
    SCAN_SUFFIX,
    bin_layout,
    read_color_image,
    read_image_size,
    read_mesh,
    read_range_image,
    read_scan,
    write_mesh,
)
from .metrics import evaluate
from .paper.sampling import sampling_weights
from .params import MeshParams, misplaced_option
from .pipeline import OPTIONS, call_options, check_memory, prepare, resolve_call, run
from .prepare import NONPOSITIVE, guess_background, to_depth_and_mask

__all__ = ["main", "build_parser"]

_DEFAULTS = MeshParams()
_UNSET = object()  # --flips none means None, so 'not given' needs its own marker


class UserError(Exception):
    """A problem with the user's input, reported as one line."""


class _Parser(argparse.ArgumentParser):
    def __init__(self, *args, **kwargs):
        kwargs.setdefault("allow_abbrev", False)  # `--vertice` must not be taken as `--vertices`
        super().__init__(*args, **kwargs)

    def error(self, message):  # one line, not the usage block
        self.exit(2, f"{self.prog}: error: {message}\n")


def _pair(text: str) -> tuple[int, int]:
    parts = text.lower().replace("x", ",").split(",")
    try:
        vals = [int(p) for p in parts]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected N or NxM with whole numbers, got {text!r}") from None
    if len(vals) == 1:
        vals = vals * 2
    if len(vals) != 2 or min(vals) < 1:
        raise argparse.ArgumentTypeError(f"expected N or NxM with N, M >= 1, got {text!r}")
    return vals[0], vals[1]


def _floats(n):
    def parse(text):
        try:
            vals = [float(p) for p in text.split(",")]
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {n} comma-separated numbers, got {text!r}") from None
        if len(vals) != n:
            raise argparse.ArgumentTypeError(f"expected {n} comma-separated numbers, got {text!r}")
        return vals

    return parse


def _background(text: str):
    t = text.lower()
    if t in ("auto", "none", "nan", NONPOSITIVE):
        return t
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a number, 'auto', '{NONPOSITIVE}', 'none' or 'nan', got {text!r}"
        ) from None


def _flips(text):
    t = text.lower()
    if t in ("none", "off"):
        return None
    if t not in ("disparity", "error"):
        raise argparse.ArgumentTypeError(f"expected disparity, error or none, got {text!r}")
    return t


def _resolve_background(spec, image, camera=None):
    """What marks missing depth: `--background` as given, 'auto' by the camera (one rule with Python)."""
    if spec == "auto":
        return guess_background(image, camera)
    if spec in ("none", "nan"):
        return None
    return spec


def _add_image_options(p):
    p.add_argument("--background", type=_background, default="auto",
                   help=f"value that marks missing depth: a number, '{NONPOSITIVE}' (0 and "
                        f"below), 'none', or 'auto' (default: 0 and below with --intrinsics "
                        f"or --beams, else 0 for integer images and none for float; NaN/inf "
                        f"always)")


def _add_camera_options(p):
    c = p.add_argument_group("camera (how pixels become 3-D points)")
    c.add_argument("--scale", type=_floats(3), metavar="KX,KY,KZ", default=None,
                   help="orthographic, the paper's eq. 4: X=kx*r, Y=ky*c, Z=kz*value, r = row, "
                        "c = column (default 1,1,1)")
    c.add_argument("--intrinsics", type=_floats(4), metavar="FX,FY,CX,CY", default=None,
                   help="pinhole depth camera; vertices become camera-frame points "
                        "((c-cx)Z/fx, (r-cy)Z/fy, Z)")
    c.add_argument("--camera", metavar="FILE", default=None,
                   help="pinhole depth camera from a calibration file: ROS camera_info YAML, "
                        "OpenCV YAML/XML, Open3D intrinsics JSON; lens distortion (plumb_bob, "
                        "equidistant) gives exact per-pixel rays")
    c.add_argument("--depth-scale", type=float, default=None,
                   help="with --intrinsics or --camera: Z = stored value x this (0.001 for mm, "
                        "0.0002 for TUM; needed for integer images); with --beams: range = "
                        "stored value x this")
    c.add_argument("--beams", metavar="FILE.json", default=None,
                   help="spinning LiDAR: a spherical camera from a beams file (elevation per "
                        "row, azimuth per column; see docs/method.md); vertices = range x ray")


def _default(name):
    """A MeshParams default as the command line writes it."""
    value = getattr(_DEFAULTS, name)
    if isinstance(value, tuple):
        return "x".join(str(v) for v in value)
    if isinstance(value, float) and value.is_integer():
        return str(int(value))
    return str(value).lower() if value is None else str(value)


def _add_mesh_options(p):
    d = _default
    g = p.add_argument_group("--method paper's options (defaults: rangemesh.MeshParams)")
    r = p.add_argument_group("--method refine's options")
    g.add_argument("--tiles", type=_pair, default=None, metavar="VxH",
                   help=f"tiles, rows x columns; neighbours share one line of pixels (default "
                        f"{d('tiles')}; chosen for the image with --vertices/--max-error)")
    g.add_argument("--samples", type=_pair, default=None, metavar="RxZ",
                   help=f"samples per tile; the grid is ((R-1)V+1) x ((Z-1)H+1) points "
                        f"(default {d('samples')})")
    p.add_argument("--method", choices=["refine", "paper", "greedy"], default="refine",
                   help="refine (the default): refine a coarse mesh at its worst pixels until "
                        "--vertices or --max-error is met, or without either the default "
                        "target: max error 0.5 %% with at most 2 %% of the valid pixels as "
                        "vertices; paper: Garcia & Sappa's pipeline with its options below; "
                        "greedy: deprecated name of refine. An option of the other method is "
                        "an error")
    r.add_argument("--heights", choices=["fit", "pixel"], default=None,
                   help="vertex depths: least squares over the pixels, jumps left out (fit, "
                        "the default) or copied from the vertex's pixel (pixel)")
    r.add_argument("--diagonals", choices=["error", "delaunay"], default=None,
                   help="each quad's diagonal is the one that fits its pixels better (error, "
                        "the default) or the Delaunay one (delaunay: a little faster, "
                        "higher error)")
    r.add_argument("--effort", choices=["fast", "best"], default=None,
                   help="fast (the default): greedy insertion's mesh; best: a lower error at "
                        "the same vertex count for several times the time (insertion to more "
                        "vertices, then the cheapest collapses down to the count)")
    r.add_argument("--no-walls", action="store_true",
                   help="drop the triangles across depth jumps, so separate surfaces stay "
                        "separate")
    r.add_argument("--jump", type=float, default=None,
                   help=f"with --no-walls: a depth change above this share of the local depth "
                        f"per pixel is a jump (default {d('jump')})")
    w = p.add_mutually_exclusive_group()
    w.add_argument("--wrap", dest="wrap", action="store_const", const=True, default=None,
                   help="column W-1 is beside column 0 (360 degrees): close the seam "
                        "(default: on for a --beams camera that goes once round)")
    w.add_argument("--no-wrap", dest="wrap", action="store_const", const=False,
                   help="leave the seam of a 360-degree scan open")
    t = p.add_argument_group("targets (both methods; --method paper: instead of --samples)")
    t.add_argument("--vertices", type=int, default=None,
                   help="this many vertices (refine: exactly; paper: within 2 %%, tiles and "
                        "samples chosen)")
    t.add_argument("--max-error", type=float, default=None,
                   help="smallest mesh whose relative error is at most this, percent")
    g.add_argument("--max-edge", type=float, default=None,
                   help="no triangle edge longer than this in the image, pixels")
    g.add_argument("--sampling", choices=["adaptive", "uniform"], default=None,
                   help=f"place samples by log-curvature (paper) or evenly (baseline) "
                        f"(default {d('sampling')})")
    g.add_argument("--flips", type=_flips, default=_UNSET, metavar="{disparity,error,none}",
                   help=f"edge flips: disparity tests (paper), error gain > 0, or none "
                        f"(default {d('flips')})")
    g.add_argument("--delta", type=float, default=None,
                   help=f"upper disparity threshold Delta: above it a triangle is off its "
                        f"surroundings, degrees (default {d('delta')})")
    g.add_argument("--epsilon", type=float, default=None,
                   help=f"test 2: smallest disparity change worth a flip, degrees "
                        f"(default {d('epsilon')})")
    g.add_argument("--max-angle", type=float, default=None,
                   help=f"test 3: a triangle with an angle above this is degenerate, degrees "
                        f"(default {d('max_angle')})")
    g.add_argument("--min-bend", type=float, default=None,
                   help=f"test 4: new triangles must bend more than this, degrees "
                        f"(default {d('min_bend')})")
    g.add_argument("--gain-threshold", type=float, default=None,
                   help="stop flipping when the best gain left is below this (default: none, "
                        "every edge with a finite gain is tried)")
    g.add_argument("--curvature-floor", type=float, default=None,
                   help=f"curvature floor on a 0..255 depth scale; flat areas still get points "
                        f"(default {d('curvature_floor')})")
    g.add_argument("--levels", type=int, default=None,
                   help=f"resolutions summed into the curvature image (default {d('levels')}: "
                        f"full + half)")
    p.add_argument("--no-fill-gaps", action="store_true",
                   help="keep single-pixel holes instead of filling them with the 8-neighbour "
                        "mean (both methods)")
    g.add_argument("--threads", type=int, default=None,
                   help=f"threads sharing stage one's tiles; the mesh is the same for any number "
                        f"(default {d('workers')})")
    _add_camera_options(p)


def _add_ply_options(p):
    p.add_argument("--ascii", action="store_true", help="PLY only: text instead of binary")
    p.add_argument("--pixels", action="store_true",
                   help="PLY only: keep each vertex's (row, col) as properties row, col")


def _add_overwrite_option(p):
    p.add_argument("--overwrite", action="store_true",
                   help="replace an existing file of a default output name (a file named with "
                        "-o or --preview is always replaced)")


def _add_output_options(p):
    p.add_argument("--quiet", action="store_true", help="print nothing on success")
    p.add_argument("--json", action="store_true", help="print the figures as JSON on stdout")


# option -> how the command line reads it from its arguments (None: not given)
_READ = {
    "fill_gaps": lambda a: False if a.no_fill_gaps else None,
    "wrap": lambda a: getattr(a, "wrap", None),
    "walls": lambda a: False if getattr(a, "no_walls", False) else None,
    "flips": lambda a: "disparity" if a.flips is _UNSET else a.flips,
}


def _options(args) -> dict:
    """The options given on the command line, by their `triangulate` names.

    None where not given (``flips``: ``'disparity'``, its default, as `triangulate` takes it).
    """
    return {name: _READ[name](args) if name in _READ else getattr(args, name, None)
            for name in OPTIONS}


def _flag(name: str) -> str:
    return {"walls": "--no-walls", "fill_gaps": "--no-fill-gaps"}.get(
        name, "--" + name.replace("_", "-"))


def _resolve(args):
    """``params, method, tiles_given`` of the options given, by `rangemesh.pipeline.resolve_call`.

    One rule with Python: an option of the other method is refused, named as a flag.
    """
    if args.method == "greedy":
        print("rangemesh: warning: --method greedy is the old name of --method refine; it goes "
              "in the next release", file=sys.stderr)
        args.method = "refine"
    options = _options(args)
    given = [k for k, v in options.items()
             if v is not None and not (k == "flips" and args.flips is _UNSET)]
    message = misplaced_option(args.method, given,
                               spell=lambda name, m: (_flag(name), f"--method {m}"))
    if message:
        raise UserError(message)
    if args.samples is not None and (args.vertices is not None or args.max_error is not None
                                     or args.max_edge is not None):
        given = next(k for k in ("vertices", "max_error", "max_edge") if getattr(args, k) is not None)
        raise UserError(f"--samples and --{given.replace('_', '-')} exclude each other: "
                        "the target chooses the samples")
    try:
        return resolve_call(None, args.method, args.vertices, args.max_error, options, {})
    except (ValueError, TypeError) as exc:
        raise UserError(_one_line(exc)) from None


def _camera(args, image_shape=None):
    try:
        return _make_camera(args, image_shape)
    except (ValueError, TypeError) as exc:
        raise UserError(str(exc)) from None


def _check_depth_scale(args, image) -> None:
    """A metric camera on an integer image needs the metres per stored value (issue 41)."""
    if args.depth_scale is None and image.dtype.kind in "iu":
        for opt in ("intrinsics", "camera"):
            if getattr(args, opt, None) is not None:
                raise UserError(f"--{opt} on an integer image needs --depth-scale (metres per "
                                f"stored value: 0.001 for millimetres, 0.0002 for TUM)")


def _make_camera(args, image_shape=None, depth_scale=None):
    if args.camera is not None:
        if any(getattr(args, o) is not None for o in ("beams", "intrinsics", "scale")):
            raise UserError("--camera, --beams, --intrinsics and --scale exclude each other")
        from .camera_files import read_camera

        scale = depth_scale or (1.0 if args.depth_scale is None else args.depth_scale)
        return read_camera(args.camera, depth_scale=scale, image_shape=image_shape)
    if args.beams is not None:
        if args.intrinsics is not None or args.scale is not None:
            raise UserError("--beams, --intrinsics and --scale exclude each other")
        scale = 1.0 if args.depth_scale is None else args.depth_scale
        return Spherical.from_beams(args.beams, range_scale=scale, image_shape=image_shape)
    if args.intrinsics is not None:
        if args.scale is not None:
            raise UserError("--scale and --intrinsics exclude each other")
        scale = depth_scale or (1.0 if args.depth_scale is None else args.depth_scale)
        return Pinhole(*args.intrinsics, depth_scale=scale)
    if args.depth_scale is not None:
        raise UserError("--depth-scale goes with --intrinsics or --camera (use --scale for "
                        "orthographic)")
    if args.scale is not None:
        return Orthographic(*args.scale)
    return Orthographic()


def _read_image(path) -> np.ndarray:
    shape = read_image_size(path)  # from the header: a huge image is refused before decoding
    if shape is not None:
        try:
            check_memory(shape)  # the paper's rule: the least any command here needs a pixel
        except MemoryError as exc:
            raise MemoryError(f"{path}: {_one_line(exc)}") from None
    try:
        return read_range_image(path)
    except (FileNotFoundError, ValueError) as exc:
        raise UserError(str(exc)) from None


class _NoBar:
    """A progress bar that shows nothing: tqdm is not imported when no bar is shown."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def update(self, n=1):
        pass


def _progress(args, total, desc):
    if args.quiet or args.json or not sys.stderr.isatty():
        return _NoBar()
    from tqdm import tqdm

    # Shown only when the work takes longer than a second (tqdm's delay).
    return tqdm(total=total, desc=desc, file=sys.stderr, delay=1.0, leave=False, unit="step")


def _clean(obj):
    """JSON has no NaN: write null instead."""
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, dict):
        return {k: _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    return obj


def _say(args, lines):
    if not (args.quiet or args.json):
        for line in lines:
            print(line, file=sys.stderr)


def _did(s) -> str:
    """What the method did, in a few words (the summary line and the preview)."""
    if s.method == "refine":
        strips = " on 2 strips" if s.strips == 2 else ""
        return (f"refine: {s.insertions} insertions{strips}, {s.flipped_edges} flips by the error, "
                f"heights {s.heights}")
    if s.grid_shape is None or 0 in s.grid_shape:
        return f"paper: {s.flipped_edges} flips"
    gr, gc = s.grid_shape
    points = (f"refined to {s.sampled_points} points for max_edge" if s.sampled_points > gr * gc
              else f"{s.sampled_points} valid samples")
    return f"paper: grid {gr}x{gc} ({points}), {s.flipped_edges} flips"


def _mesh_lines(mesh, ev, outputs):
    s = mesh.stats
    lines = [f"vertices {s.vertices}  edges {s.edges}  triangles {s.triangles}  ({_did(s)})",
             "time " + "  ".join(f"{k} {1000 * v:.1f} ms" for k, v in s.seconds.items())]
    q = s.target
    if q is not None:
        ach = f"{q.achieved:.4f}" if isinstance(q.achieved, float) else q.achieved
        grid = (f" with tiles {q.tiles[0]}x{q.tiles[1]}, samples {q.samples[0]}x{q.samples[1]}"
                if q.tiles is not None else "")  # the paper's search only
        what = "default target max_error" if q.default else f"target {q.kind}"
        cap = f" (at most {q.max_vertices} vertices)" if q.max_vertices is not None else ""
        lines.append(f"{what} {q.requested}{cap}: achieved {ach}{grid} "
                     f"({q.meshings} meshing(s)){'' if q.met else ' -- not met: ' + q.note}")
    if ev is not None:
        lines.append(f"relative error {ev.relative_error:.4f} %  rms {ev.rms_error:.4f} %  "
                     f"max {ev.max_error:.3f} %  edge band {ev.edge_band_error:.4f} %  "
                     f"uncovered {ev.uncovered:.2f} %")
    lines += [f"wrote {o}" for o in outputs]
    return lines


def _run_mesh(args, image, name, bg, outputs_for):
    params, method, tiles_given = _resolve(args)
    _check_depth_scale(args, image)
    camera = _camera(args, image.shape)
    bg = _resolve_background(bg, image, camera)
    with _progress(args, 4, f"meshing {name}") as bar:
        try:
            mesh = run(image, params, background=bg, camera=camera, vertices=args.vertices,
                       max_error=args.max_error, tiles_given=tiles_given, method=method)
        except (ValueError, TypeError, MemoryError) as exc:
            raise UserError(f"{name}: {_one_line(exc)}") from None
        bar.update(1)
        if mesh.is_empty:
            raise UserError(f"{name}: nothing to mesh: {mesh.stats.reason}")
        ev = evaluate(mesh, image, background=bg)
        bar.update(1)
        written = []
        out, preview = outputs_for
        mesh = _with_colors(args, mesh, name)
        if out:
            # a ray table cannot map vertices back to pixels: the file keeps them (--camera)
            write_mesh(mesh, out, ascii=args.ascii,
                       pixels=args.pixels or getattr(camera, "z_depth", False))
            written.append(out)
        bar.update(1)
        if preview:
            from .preview import save_preview

            depth, valid = prepare(image, params, bg)  # gap-filled in place: no second copy
            weights = sampling_weights(depth, valid, params) if method == "paper" else None
            save_preview(mesh, depth, valid, preview, evaluation=ev, title=Path(name).name,
                         weights=weights)
            written.append(preview)
        bar.update(1)
    if args.json:
        print(json.dumps(_clean({"input": name, "background": bg, "stats": mesh.stats.to_dict(),
                                 "evaluation": ev.to_dict(),
                                 "outputs": [str(w) for w in written]})))
    lines = _mesh_lines(mesh, ev, written)
    if getattr(args, "output_defaulted", False):
        lines = [f"{line} (no -o given: beside the input)" if line == f"wrote {out}" else line
                 for line in lines]
    _say(args, lines)
    return 0


def _same_file(a: Path, b: Path) -> bool:
    try:
        return a.resolve() == b.resolve() or (a.exists() and b.exists() and a.samefile(b))
    except OSError:
        return False


def _check_outputs(args, inputs=()):
    """Refuse outputs that cannot be written, or that would replace an input or each other."""
    outputs = [Path(p) for p in (args.output, getattr(args, "preview", None)) if p]
    coloured = getattr(args, "color", None) or getattr(args, "intensity", None)
    if args.output and Path(args.output).suffix.lower() == ".obj" and coloured:
        outputs += [Path(args.output).with_suffix(".mtl"),  # the texture's files (io.write_mesh)
                    Path(args.output).with_name(Path(args.output).stem + ".texture.png")]
    for p in outputs:
        if p.is_dir():
            raise UserError(f"{p}: is a folder, not a file to write")
        if not p.resolve().parent.is_dir():
            raise UserError(f"{p}: folder {p.parent} does not exist")
        for i in inputs:
            if _same_file(p, Path(i)):
                raise UserError(f"{p}: is the input {i}; an output never replaces an input")
    for i, p in enumerate(outputs):
        for q in outputs[i + 1:]:
            if _same_file(p, q):
                raise UserError(f"{q}: two outputs would be the same file ({p} and {q}); "
                                f"name them apart")
    if args.output and Path(args.output).suffix.lower() not in MESH_SUFFIXES:
        raise UserError(f"{args.output}: unknown mesh format; use one of {', '.join(MESH_SUFFIXES)}")
    if args.output and Path(args.output).suffix.lower() != ".ply" and (args.ascii or args.pixels):
        raise UserError("--ascii and --pixels apply to .ply output only")
    if getattr(args, "preview", None) and Path(args.preview).suffix.lower() != ".png":
        raise UserError(f"{args.preview}: the preview is a PNG file")


def _with_colors(args, mesh, name):
    """The mesh with the colours (--color) and intensity (--intensity) asked for."""
    how = "mean" if getattr(args, "color_mean", False) else "pixel"
    for opt, path in (("--color", getattr(args, "color", None)),
                      ("--intensity", getattr(args, "intensity", None))):
        if path is None:
            continue
        try:
            img = read_color_image(path)
            if opt == "--intensity":
                if img.ndim != 2:
                    raise ValueError(f"{path}: an intensity image has one channel")
                mesh = mesh.with_attribute("intensity", img, how=how)
                if args.color is None:  # grey colours too, so viewers show it
                    mesh = mesh.with_colors(img, how=how)
            else:
                mesh = mesh.with_colors(img, how=how)
        except (FileNotFoundError, ValueError) as exc:
            raise UserError(f"{name}: {opt}: {_one_line(exc)}") from None
    return mesh


def _read_scan(args):
    """The range image of a mesh command: an image file, or a LiDAR .bin read with --beams."""
    if Path(args.image).suffix.lower() != SCAN_SUFFIX:
        return _read_image(args.image)
    if args.beams is None:
        raise UserError(f"{args.image}: a .bin LiDAR scan needs --beams FILE.json (its rows and "
                        f"column shifts)")
    try:
        layout = bin_layout(args.beams)
    except ValueError as exc:
        raise UserError(_one_line(exc)) from None
    try:
        return read_scan(args.image, layout)
    except (OSError, ValueError) as exc:
        raise UserError(_one_line(exc)) from None


def _default_output(args) -> None:
    """Without -o or --preview: the mesh goes beside the input as ``<stem>.ply``, never over it."""
    if args.output or args.preview:
        return
    image = Path(args.image)
    out = image.with_suffix(".ply")
    if _same_file(out, image):
        raise UserError(f"{image}: is a .ply file; give -o FILE to choose where the mesh goes")
    _refuse_unnamed(args, out, "-o FILE")
    args.output = str(out)
    args.output_defaulted = True


def _refuse_unnamed(args, path: Path, option: str) -> None:
    """An output the command named itself replaces no file unless --overwrite (the user never named it)."""
    if path.exists() and not args.overwrite:
        raise UserError(f"{path}: already there (the default output name); give {option} to "
                        f"write elsewhere, or --overwrite to replace it")


def _cmd_mesh(args):
    _default_output(args)
    _check_outputs(args, [a for a in (args.image, args.color, args.intensity) if a])
    image = _read_scan(args)
    return _run_mesh(args, image, args.image, args.background, (args.output, args.preview))


def _cmd_demo(args):
    for opt, name, option in (("output", "demo.ply", "-o FILE"),
                              ("preview", "demo-preview.png", "--preview FILE")):
        if getattr(args, opt) is None:
            _refuse_unnamed(args, Path(name), option)
            setattr(args, opt, name)
    _check_outputs(args)
    # A box standing on a plane in front of a four-sided pyramid: jump and crease edges.
    shape = (160, 200)
    pyr = scenes.pyramid(shape, height=70.0)
    box = scenes.box(shape, height=40.0)
    depth = np.where(box.labels == 1, box.depth + 50.0, pyr.depth)
    return _run_mesh(args, depth, "demo scene", None, (args.output, args.preview))


def _cmd_info(args):
    from .recordings import is_recording

    if is_recording(args.image):
        return _info_recording(args)
    image = _read_image(args.image)
    given = any(x is not None for x in (args.scale, args.intrinsics, args.depth_scale, args.beams,
                                         args.camera))
    bg = _resolve_background(args.background, image, _camera(args, image.shape) if given else None)
    depth, valid = to_depth_and_mask(image, bg)
    info = {
        "file": args.image,
        "shape": list(image.shape),
        "dtype": str(image.dtype),
        "background": "0 or below" if bg == NONPOSITIVE else bg if bg is not None
        else "NaN/inf only",
        "background_guessed": args.background == "auto",
        "valid_pixels": int(valid.sum()),
        "valid_share_percent": 100.0 * float(valid.mean()),
        "nan_or_inf_pixels": int((~np.isfinite(image)).sum()) if image.dtype.kind == "f" else 0,
        "depth_min": float(depth[valid].min()) if valid.any() else None,
        "depth_max": float(depth[valid].max()) if valid.any() else None,
        "distinct_values": int(np.unique(depth[valid]).size) if valid.any() else 0,
        # exact zeros kept as data: a no-return marker meshed at depth 0 if they are one
        "zero_pixels_valid": int(np.count_nonzero(valid & (depth == 0.0))),
    }
    if args.json:
        print(json.dumps(_clean(info)))
        return 0
    how = "guessed" if info["background_guessed"] else "given"
    print(f"{args.image}: {image.shape[0]} rows x {image.shape[1]} cols, {image.dtype}")
    print(f"background ({how}): {info['background']}; valid pixels {info['valid_pixels']} "
          f"({info['valid_share_percent']:.1f} %)")
    if info["zero_pixels_valid"]:
        print(f"{info['zero_pixels_valid']} valid pixels are exactly 0: if 0 marks no return, "
              f"give the camera (--intrinsics, --beams) or --background 0")
    if valid.any():
        print(f"depth range {info['depth_min']:g} .. {info['depth_max']:g} "
              f"({info['distinct_values']} distinct values)")
    return 0


def _cmd_eval(args):
    image = _read_scan(args)  # an image file, or a LiDAR .bin with --beams, as `mesh` reads
    given = any(x is not None for x in (args.scale, args.intrinsics, args.depth_scale, args.beams,
                                         args.camera))
    _check_depth_scale(args, image)
    camera = _camera(args, image.shape) if given else None  # None: the camera the file records
    try:
        mesh = read_mesh(args.mesh, camera=camera, image_shape=image.shape)
        # 'auto' by the mesh's camera, as `mesh` took it
        ev = evaluate(mesh, image, background=_resolve_background(args.background, image,
                                                                   mesh.camera))
    except (FileNotFoundError, ValueError) as exc:
        raise UserError(str(exc)) from None
    if args.json:
        print(json.dumps(_clean({"image": args.image, "mesh": args.mesh, "vertices": len(mesh.vertices),
                                 "triangles": len(mesh.faces), **ev.to_dict()})))
        return 0
    print(f"{args.mesh}: {len(mesh.vertices)} vertices, {len(mesh.faces)} triangles "
          f"against {args.image}")
    print(f"relative error {ev.relative_error:.4f} %  rms {ev.rms_error:.4f} %  "
          f"max {ev.max_error:.3f} %  edge band {ev.edge_band_error:.4f} %  "
          f"uncovered {ev.uncovered:.2f} %")
    return 0


def _cmd_batch(args):
    from .batch import mesh_many, summarize

    params, method, _ = _resolve(args)
    camera = _camera(args)
    if _recording_input(args) is None and args.depth_scale is None \
            and (args.intrinsics is not None or args.camera is not None):
        from .batch import expand_inputs

        try:  # the first image stands for the batch: its files are one sensor's
            first = expand_inputs(args.inputs)[:1]
        except (OSError, ValueError):
            first = []  # mesh_many reports unreadable inputs one by one
        try:
            image = _read_image(first[0]) if first else None
        except (UserError, MemoryError):
            image = None  # mesh_many reports it as that input's failure
        if image is not None:
            _check_depth_scale(args, image)
    bg = args.background
    bg = None if bg in ("none", "nan") else bg  # 'auto' is resolved image by image, by the camera
    t0 = time.perf_counter()
    report = Path(args.output_dir) / "rangemesh-batch.csv"
    recording = _recording_input(args)
    try:
        if recording is not None:
            results, report = _mesh_recording(args, recording, params, method)
        else:
            results = mesh_many(args.inputs, args.output_dir, background=bg, camera=camera,
                                scheduler=args.scheduler, workers=args.workers,
                                overwrite=args.overwrite, fmt="." + args.format,
                                progress=not (args.quiet or args.json) and sys.stderr.isatty(),
                                method=method, vertices=args.vertices, max_error=args.max_error,
                                beams=args.beams, **call_options(params, method))
    except (ValueError, TypeError) as exc:
        raise UserError(_one_line(exc)) from None
    summary = summarize(results, time.perf_counter() - t0)
    failed = [r for r in results if r.status == "failed"]
    if args.json:
        from dataclasses import asdict

        print(json.dumps(_clean({"summary": summary, "results": [asdict(r) for r in results]})))
    elif not args.quiet:
        for r in failed:
            print(f"failed: {r.input}: {r.error}", file=sys.stderr)
        med = summary["median_seconds_per_image"]
        other = summary.get("skipped_not_depth", 0)  # a recording's summary has none
        why = "already there" if not other else (
            f"{summary['skipped'] - other} already there, {other} not depth images: colour "
            f"images or previews")
        print(f"meshed {summary['meshed']}, skipped {summary['skipped']} ({why}), failed "
              f"{summary['failed']} of {summary['inputs']} in {summary['wall_seconds']:.1f} s "
              f"({summary['images_per_second']:.2f} images/s"
              + (f", median {med:.3f} s per image" if med is not None else "") + ")", file=sys.stderr)
        print(f"per-image figures: {report}", file=sys.stderr)
    return 1 if failed else 0


def _recording_input(args):
    """The recording a batch meshes (a .bag, .db3, .mcap or ROS 2 bag folder), or None for files."""
    from .recordings import is_recording

    hits = [i for i in args.inputs if is_recording(i)]
    if not hits:
        for opt in ("topic", "color_topic", "camera_info_topic"):
            if getattr(args, opt) is not None:
                raise UserError(f"--{opt.replace('_', '-')} goes with a recording (.bag, .db3, "
                                f".mcap or a ROS 2 bag folder)")
        return None
    if len(args.inputs) > 1:
        raise UserError(f"{hits[0]}: a recording is meshed alone, not with other inputs")
    if args.background != "auto":
        raise UserError("--background does not apply to a recording: 0 and below (and NaN in "
                        "32FC1 images) are missing depth there")
    return hits[0]


def _mesh_recording(args, path, params, method):
    """`rangemesh batch recording -o out.mcap|folder`: the results and where the figures are."""
    import warnings

    from .recordings import Recording, mesh_recording

    camera = None
    if (args.intrinsics is not None or args.camera is not None) and args.depth_scale is None:
        with Recording(path) as rec:  # metres per value from the encoding, as with a CameraInfo
            scale = rec.depth_topic(args.topic).depth_scale
        try:
            camera = _make_camera(args, depth_scale=scale)
        except (ValueError, TypeError) as exc:
            raise UserError(str(exc)) from None
    elif any(x is not None for x in (args.intrinsics, args.scale, args.beams, args.depth_scale,
                                     args.camera)):
        camera = _camera(args)
    out = Path(args.output_dir)
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always", UserWarning)
        results = mesh_recording(
            path, out, args.topic, color_topic=args.color_topic, camera=camera,
            camera_info_topic=args.camera_info_topic, scheduler=args.scheduler,
            workers=args.workers, overwrite=args.overwrite, fmt="." + args.format,
            progress=not (args.quiet or args.json) and sys.stderr.isatty(),
            method=method, vertices=args.vertices, max_error=args.max_error,
            **call_options(params, method))
    if not args.quiet:
        for w in said:
            print(f"rangemesh: warning: {_one_line(w.message)}", file=sys.stderr)
    report = out.with_name(out.stem + ".rangemesh-batch.csv") if out.suffix.lower() == ".mcap" \
        else out / "rangemesh-batch.csv"
    return results, report


def _info_recording(args):
    """`rangemesh info recording`: its depth topics (size, encoding, count) and their cameras."""
    from .recordings import Recording

    if args.background != "auto":
        raise UserError("--background does not apply to a recording")
    with Recording(args.image) as rec:
        topics = rec.image_topics()
        cams = {}
        for t in topics:
            if t.depth and not t.problem:
                try:
                    cams[t.topic] = rec.camera_info(t.topic, "", 0, (t.height, t.width))
                except ValueError as exc:
                    cams[t.topic] = _one_line(exc)
    depth = [t for t in topics if t.depth]
    other = [t for t in topics if not t.depth]

    def camera(t):
        c = cams.get(t.topic)
        if c is None or isinstance(c, str):
            note = t.problem or c or "no CameraInfo: give --intrinsics"
            return {"camera_info": None, "note": note}
        return {"camera_info": c.topic, "fx": c.k[0], "fy": c.k[4], "cx": c.k[2], "cy": c.k[5],
                "distortion_model": c.distortion_model, "distorted": any(v != 0 for v in c.d)}

    if args.json:
        print(json.dumps(_clean({"file": args.image,
                                 "depth_topics": [{**t.to_dict(), **camera(t)} for t in depth],
                                 "other_image_topics": [t.to_dict() for t in other]})))
        return 0
    print(f"{args.image}: {len(depth)} depth topic(s)")
    for t in depth:
        if t.problem:  # no message of it is an image: no size to print
            print(f"  {t.topic}: {t.encoding}, {t.count} messages; {t.problem}")
            continue
        c = camera(t)
        cam = (f"camera {c['camera_info']} (fx {c['fx']:g}, fy {c['fy']:g}, cx {c['cx']:g}, "
               f"cy {c['cy']:g})" if c["camera_info"] else c["note"])
        print(f"  {t.topic}: {t.width}x{t.height} {t.encoding}, {t.count} messages; {cam}")
    for t in other:
        print(f"  (not depth) {t.topic}: {t.width}x{t.height} {t.encoding}, {t.count} messages")
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``rangemesh`` command."""
    p = _Parser(
        prog="rangemesh",
        description="Discontinuity-preserving adaptive triangle meshes from range images "
                    "(Garcia & Sappa, IEEE SMC-B 2004).",
    )
    p.add_argument("--version", action="version", version=f"rangemesh {__version__}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    m = sub.add_parser("mesh", help="mesh one range image",
                       description="Mesh one range image; print the figures on stderr.")
    m.add_argument("image", help=f"range image ({' '.join(IMAGE_SUFFIXES)}), or a KITTI-style "
                                 f"LiDAR .bin with --beams")
    m.add_argument("-o", "--output", help=f"mesh file to write ({' '.join(MESH_SUFFIXES)}); "
                                          f"default: the image's name with .ply, beside it "
                                          f"(unless --preview is given)")
    m.add_argument("--preview", help="PNG picture: wireframe, samples, shaded mesh")
    col = m.add_argument_group("colour (images registered pixel to pixel with the range image)")
    col.add_argument("--color", metavar="FILE",
                     help="colour image: vertex colours (PLY, OBJ, GLB) and the texture of "
                          "OBJ (+ .mtl, .texture.png) and GLB files")
    col.add_argument("--intensity", metavar="FILE",
                     help="scalar image (a LiDAR's intensity, .npy): a vertex property "
                          "'intensity', and grey colours without --color")
    col.add_argument("--color-mean", action="store_true",
                     help="a vertex takes the mean over the pixels it stands for, not its "
                          "own pixel's value")
    _add_ply_options(m)
    _add_overwrite_option(m)
    _add_image_options(m)
    _add_mesh_options(m)
    _add_output_options(m)

    d = sub.add_parser("demo", help="mesh a built-in synthetic scene (no input needed)",
                       description="Mesh a built-in scene (a box and a pyramid) and write the "
                                   "mesh and a preview picture.")
    d.add_argument("-o", "--output", default=None, help="mesh file (default demo.ply)")
    d.add_argument("--preview", default=None, help="PNG picture (default demo-preview.png)")
    _add_ply_options(d)
    _add_overwrite_option(d)
    _add_mesh_options(d)
    _add_output_options(d)

    b = sub.add_parser("batch", help="mesh many images (files, folders, globs) in parallel",
                       description="Mesh many range images into a folder, in parallel through Dask: "
                                   "a local cluster of worker processes, or an existing cluster "
                                   "(--scheduler). Bad files are reported and the rest go on; "
                                   "outputs already there are skipped unless --overwrite.")
    b.add_argument("inputs", nargs="+", help="image files, folders or quoted glob patterns "
                                             "(LiDAR .bin scans with --beams); or one ROS "
                                             "recording (.bag, .db3, .mcap, ROS 2 bag folder)")
    b.add_argument("-o", "--output-dir", required=True,
                   help="folder for the meshes and the report; for a recording also NAME.mcap: "
                        "one mesh marker per frame, in step with the recording")
    b.add_argument("--format", default="ply", choices=[s[1:] for s in MESH_SUFFIXES],
                   help="mesh format (default ply)")
    b.add_argument("--workers", type=int, default=None,
                   help="worker processes of the local cluster (default: all cores)")
    b.add_argument("--scheduler", default=None,
                   help="address of a running Dask scheduler, e.g. tcp://head:8786")
    b.add_argument("--overwrite", action="store_true", help="mesh again images already meshed")
    ros = b.add_argument_group("ROS recordings (pip install \"rangemesh[ros]\")")
    ros.add_argument("--topic", default=None,
                     help="depth topic (16UC1/mono16 mm, 32FC1 m, compressedDepth); default: "
                          "the recording's only one (rangemesh info lists them)")
    ros.add_argument("--color-topic", default=None,
                     help="colour topic registered with the depth (same size): vertex colours")
    ros.add_argument("--camera-info-topic", default=None,
                     help="CameraInfo topic (default: the one beside the depth topic, same "
                          "frame id, nearest stamp)")
    _add_image_options(b)
    _add_mesh_options(b)
    _add_output_options(b)

    i = sub.add_parser("info", help="describe a range image or a recording's depth topics",
                       description="Size, dtype, valid share, depth range and what marks "
                                   "missing depth; for a ROS recording its depth topics with "
                                   "size, encoding, count and camera.")
    i.add_argument("image")
    _add_image_options(i)
    _add_camera_options(i)  # the camera says what 'auto' marks as missing depth
    i.add_argument("--json", action="store_true", help="print as JSON on stdout")

    e = sub.add_parser("eval", help="the paper's relative error of any mesh file",
                       description="Compare a mesh file with its range image: relative error "
                                   "(mean |depth - mesh| / depth range), RMS, max, edge band, "
                                   "uncovered share. PLY files written by rangemesh record "
                                   "their camera; for other files give the camera the mesh was "
                                   "made with.")
    e.add_argument("image")
    e.add_argument("mesh", help=f"mesh file ({' '.join(MESH_SUFFIXES)})")
    _add_image_options(e)
    _add_camera_options(e)
    e.add_argument("--json", action="store_true", help="print as JSON on stdout")
    return p


def _one_line(exc: BaseException) -> str:
    """An exception as one line: its first line, or its type when it says nothing."""
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def _os_message(exc: OSError) -> str:
    """``path: reason`` for a failed file operation (permission, full disk, a folder...)."""
    reason = exc.strerror or _one_line(exc)
    return f"{exc.filename}: {reason}" if exc.filename else reason


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP, raised like Ctrl-C so that ``finally`` blocks run and clean up."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


def _terminate(signum, frame):
    raise Terminated(signum)


@contextlib.contextmanager
def _signals_raise():
    """SIGTERM and SIGHUP raise `Terminated` inside the block (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    names = [n for n in ("SIGTERM", "SIGHUP") if hasattr(signal, n)]
    old = {n: signal.signal(getattr(signal, n), _terminate) for n in names}
    try:
        yield
    finally:
        for n, handler in old.items():
            signal.signal(getattr(signal, n), handler)


def main(argv=None) -> int:
    """Entry point of the ``rangemesh`` command; returns the exit status.

    Every expected failure ends here as one line on stderr: bad input, bad
    options, unreadable or unwritable files, a missing optional extra, not
    enough memory for what was asked: exit status 2. ``batch`` returns 1
    when some inputs failed. Ctrl-C, SIGTERM and SIGHUP end the command with
    128 + the signal number (130, 143, 129) after temporary files are removed.
    """
    parser = build_parser()
    argv = sys.argv[1:] if argv is None else list(argv)
    if not argv:  # `rangemesh` alone: the usage, then argparse's missing-command error (status 2)
        parser.print_usage(sys.stderr)
        parser.error("give a command: mesh, demo, batch, info or eval (rangemesh -h says more)")
    args = parser.parse_args(argv)
    commands = {"mesh": _cmd_mesh, "demo": _cmd_demo, "info": _cmd_info, "eval": _cmd_eval,
                "batch": _cmd_batch}
    t0 = time.perf_counter()
    try:
        with _signals_raise():
            return commands[args.command](args)
    except BrokenPipeError:  # the reader went away (`rangemesh ... --json | head`): stop quietly
        sys.stdout = open(os.devnull, "w")  # noqa: SIM115 - Python flushes stdout at exit
        return 128 + 13  # SIGPIPE's status, as a shell reports a killed writer
    except KeyboardInterrupt as exc:
        signum = getattr(exc, "signum", signal.SIGINT)
        print(f"rangemesh: interrupted ({signal.Signals(signum).name}) after "
              f"{time.perf_counter() - t0:.1f} s", file=sys.stderr)
        return 128 + int(signum)
    except (UserError, ImportError) as exc:  # ImportError: an optional extra is missing
        message = _one_line(exc)
    except OSError as exc:
        message = _os_message(exc)
    except MemoryError as exc:
        message = _one_line(exc)
        if not message.startswith("not enough memory"):
            message = f"not enough memory ({message})"
    except (ValueError, TypeError) as exc:
        message = _one_line(exc)
    print(f"rangemesh: error: {message}", file=sys.stderr)
    return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
