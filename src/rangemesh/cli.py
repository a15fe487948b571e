"""The ``rangemesh`` command: ``mesh``, ``info``, ``eval``, ``demo``, ``batch`` and ``live``.

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
from .memory import check_memory
from .metrics import evaluate
from .options import BOTH
from .paper.sampling import sampling_weights
from .params import OPTION_TABLE, OPTIONS_BY_NAME, MeshParams, misplaced_option
from .pipeline import prepare, run
from .prepare import NONPOSITIVE, guess_background, to_depth_and_mask
from .resolve import call_options, resolve_call

__all__ = ["main", "build_parser"]

_DEFAULTS = MeshParams()
_UNSET = object()  # an option flag not given (--flips none means None: not given needs a marker)


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


def _limits(text: str):
    """``NEAR,FAR`` (either side may be empty: no limit there) for --depth-limits."""
    parts = text.split(",")
    try:
        if len(parts) != 2:
            raise ValueError
        near, far = (float(t) if t.strip() else None for t in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected NEAR,FAR (one side may be empty), got "
                                         f"{text!r}") from None
    return near, far


def _add_cleanup_options(p):
    """--depth-limits and --min-region for `info` and `eval`, as the table declares them."""
    _add_option_flags({BOTH: p}, only=("depth_limits", "min_region"), unset=None)


def _add_cloud_options(c):
    from .clouds import SENSORS

    c.add_argument("--sensor", choices=sorted(SENSORS), default=None,
                   help="an unorganised LiDAR cloud (.bin, KITTI's x, y, z, intensity): the "
                        "Velodyne head whose beams are found from the cloud to make the range "
                        "image (rangemesh.project_scan); with --beams a cloud is projected on "
                        "the file's beams")


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
    _add_cloud_options(c)


def _default(name):
    """A MeshParams default as the command line writes it."""
    value = getattr(_DEFAULTS, name)
    if isinstance(value, tuple):
        return "x".join(str(v) for v in value)
    if isinstance(value, float) and value.is_integer():
        return str(int(value))
    return str(value).lower() if value is None else str(value)


# How the command line reads an option's text (`rangemesh.options.Flag.parse`).
_PARSE = {"int": int, "float": float, "pair": _pair, "limits": _limits, "flips": _flips}


def _add_option_flags(groups: dict, only=None, unset=_UNSET) -> None:
    """The flags of every option of the table (`rangemesh.params.OPTION_TABLE`), into `groups`.

    `groups` maps an option's methods to the argument group its flag goes in;
    `only` names the options to add (default all). A flag's destination is
    the option's name; not given, it holds `unset`.
    """
    for o in OPTION_TABLE:
        f = o.flag
        if f is None or (only is not None and o.name not in only):
            continue
        g = groups[o.methods]
        dashed = o.name.replace("_", "-")
        text = f.help.replace("{default}", _default(o.field)).replace("%", "%%")
        if f.parse == "off":
            g.add_argument(f"--no-{dashed}", dest=o.name, action="store_const", const=False,
                           default=unset, help=text)
        elif f.parse == "on_off":
            both = g.add_mutually_exclusive_group()
            both.add_argument(f"--{dashed}", dest=o.name, action="store_const", const=True,
                              default=unset, help=text)
            both.add_argument(f"--no-{dashed}", dest=o.name, action="store_const", const=False,
                              help=f"the opposite of --{dashed}")
        else:
            kwargs = {"choices": list(o.choices)} if f.parse == "choice" else \
                {"type": _PARSE[f.parse]}
            if f.metavar is not None:
                kwargs["metavar"] = f.metavar
            g.add_argument(f"--{dashed}", dest=o.name, default=unset, help=text, **kwargs)


def _add_mesh_options(p):
    p.add_argument("--method", choices=["refine", "paper", "greedy"], default="refine",
                   help="refine (the default): refine a coarse mesh at its worst pixels until "
                        "--vertices or --max-error is met, or without either the default "
                        "target: max error 0.5 %% with at most 2 %% of the valid pixels as "
                        "vertices; paper: Garcia & Sappa's pipeline with its options below; "
                        "greedy: deprecated name of refine. An option of the other method is "
                        "an error")
    t = p.add_argument_group("targets (both methods; --method paper: instead of --samples)")
    t.add_argument("--vertices", type=int, default=None,
                   help="this many vertices (refine: exactly; paper: within 2 %%, tiles and "
                        "samples chosen)")
    t.add_argument("--max-error", type=float, default=None,
                   help="smallest mesh whose relative error is at most this, percent")
    _add_option_flags({BOTH: p, ("refine",): p.add_argument_group("--method refine's options"),
                       ("paper",): p.add_argument_group(
                           "--method paper's options (defaults: rangemesh.MeshParams)")})
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


def _options(args) -> dict:
    """The options given on the command line, by their `triangulate` names.

    An option not given holds what `triangulate` takes for "not given" (None;
    ``flips``: ``'disparity'``).
    """
    return {o.name: o.unset if getattr(args, o.name, _UNSET) is _UNSET else getattr(args, o.name)
            for o in OPTION_TABLE}


def _flag(name: str) -> str:
    return OPTIONS_BY_NAME[name].cli


def _deviations(args) -> tuple:
    """``(max_deviation, mean_deviation)`` of a command that takes them (`mesh`), else Nones."""
    return getattr(args, "max_deviation", None), getattr(args, "mean_deviation", None)


def _deviation_line(ev, camera) -> str:
    """Evaluate's deviations, in metres with a metric camera, depth units otherwise."""
    unit = "depth units" if isinstance(camera, Orthographic) else "m"
    return (f"max deviation {ev.max_deviation:.6g} {unit}  "
            f"mean deviation {ev.mean_deviation:.6g} {unit}")


def _resolve(args):
    """``params, method, tiles_given`` of the options given, by `rangemesh.resolve.resolve_call`.

    One rule with Python: an option of the other method is refused, named as a flag.
    """
    if args.method == "greedy":
        print("rangemesh: warning: --method greedy is the old name of --method refine; it goes "
              "in the next release", file=sys.stderr)
        args.method = "refine"
    options = _options(args)
    given = [o.name for o in OPTION_TABLE if getattr(args, o.name, _UNSET) is not _UNSET]
    message = misplaced_option(args.method, given,
                               spell=lambda name, m: (_flag(name), f"--method {m}"))
    if message:
        raise UserError(message)
    targets = {"vertices": args.vertices, "max_error": args.max_error,
               "max_edge": options["max_edge"]}
    if "samples" in given and any(v is not None for v in targets.values()):
        target = next(k for k, v in targets.items() if v is not None)
        raise UserError(f"--samples and --{target.replace('_', '-')} exclude each other: "
                        "the target chooses the samples")
    try:
        return resolve_call(None, args.method, args.vertices, args.max_error, options, {},
                            deviations=_deviations(args))
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
    scanned = getattr(args, "scan_camera", None)
    if scanned is not None:  # a cloud projected with --sensor: its beams were found (_read_scan)
        return scanned
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
        lines.append(_deviation_line(ev, mesh.camera))
    lines += [f"wrote {o}" for o in outputs]
    return lines


def _run_mesh(args, image, name, bg, outputs_for):
    params, method, tiles_given = _resolve(args)
    _check_depth_scale(args, image)
    camera = _camera(args, image.shape)
    bg = _resolve_background(bg, image, camera)
    with _progress(args, 4, f"meshing {name}") as bar:
        import warnings

        from .cleanup import ZeroMarkerWarning

        try:
            max_deviation, mean_deviation = _deviations(args)
            with warnings.catch_warnings(record=True) as said:
                warnings.simplefilter("always", ZeroMarkerWarning)
                mesh = run(image, params, background=bg, camera=camera, vertices=args.vertices,
                           max_error=args.max_error, tiles_given=tiles_given, method=method,
                           max_deviation=max_deviation, mean_deviation=mean_deviation)
        except (ValueError, TypeError, MemoryError) as exc:
            raise UserError(f"{name}: {_one_line(exc)}") from None
        for w in said:  # (others pass on as they came)
            if issubclass(w.category, ZeroMarkerWarning):
                if not (args.quiet or args.json):
                    print(f"rangemesh: warning: {name}: {w.message}".replace(
                        "background=0", "--background 0"), file=sys.stderr)
            else:
                warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        bar.update(1)
        if mesh.is_empty:
            raise UserError(f"{name}: nothing to mesh: {mesh.stats.reason}")
        ev = evaluate(mesh, image, background=bg, depth_limits=params.depth_limits,
                      min_region=params.min_region)
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

            depth, valid = prepare(image, params, bg, camera=camera)  # gap-filled in place
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
        if getattr(args, "sensor", None) is not None:
            raise UserError(f"{args.image}: --sensor goes with a LiDAR cloud (.bin)")
        return _read_image(args.image)
    scan = _project(args)
    if scan is not None:
        return scan.ranges
    if args.beams is None:
        raise UserError(f"{args.image}: a .bin LiDAR scan needs --beams FILE.json (its rows and "
                        f"column shifts) or, for an unorganised cloud, --sensor NAME")
    try:
        layout = bin_layout(args.beams)
    except ValueError as exc:
        raise UserError(_one_line(exc)) from None
    try:
        return read_scan(args.image, layout)
    except (OSError, ValueError) as exc:
        raise UserError(_one_line(exc)) from None


def _project(args):
    """A .bin cloud made a range image with --sensor (`rangemesh.project_scan`), else None.

    (With --beams, `rangemesh.io.read_scan` projects a cloud that is not the file's organised scan.)
    """
    from .clouds import project_scan, read_cloud

    sensor = getattr(args, "sensor", None)
    if sensor is None:
        return None
    if args.beams is not None:
        raise UserError("--sensor and --beams exclude each other (--sensor finds the beams)")
    try:
        scan = project_scan(read_cloud(args.image), sensor=sensor)
    except (ValueError, TypeError) as exc:
        raise UserError(_one_line(exc)) from None
    args.scan_camera, args.scan_beams = scan.camera, scan.beams
    return scan


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
    if Path(args.image).suffix.lower() == SCAN_SUFFIX:
        if args.beams is None and args.sensor is None:
            return _info_cloud(args)
        image = _read_scan(args)
    else:
        image = _read_image(args.image)
    if args.write_beams is not None:
        _write_beams(args)
    given = any(x is not None for x in (args.scale, args.intrinsics, args.depth_scale, args.beams,
                                         args.camera, args.sensor))
    camera = _camera(args, image.shape) if given else None
    bg = _resolve_background(args.background, image, camera)
    depth, valid = to_depth_and_mask(image, bg)
    dropped = _cleaned(args, depth, valid, camera)  # as `mesh` would see the pixels
    from .cleanup import zeros_like_a_marker
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
        # ... and whether they look like one (rangemesh.cleanup.zeros_like_a_marker)
        "zeros_look_like_no_return": bool(zeros_like_a_marker(depth, valid)),
        **{f"dropped_by_{k}": n for k, n in dropped.items()},
    }
    if args.json:
        print(json.dumps(_clean(info)))
        return 0
    how = "guessed" if info["background_guessed"] else "given"
    print(f"{args.image}: {image.shape[0]} rows x {image.shape[1]} cols, {image.dtype}")
    print(f"background ({how}): {info['background']}; valid pixels {info['valid_pixels']} "
          f"({info['valid_share_percent']:.1f} %)")
    for k, n in dropped.items():
        print(f"--{k.replace('_', '-')} made {n} more pixels missing depth")
    if info["zeros_look_like_no_return"]:
        print(f"{info['zero_pixels_valid']} valid pixels are exactly 0 and look like a no-return "
              f"marker (cut off from the data): if 0 marks no return, give the camera "
              f"(--intrinsics, --beams) or --background 0")
    elif info["zero_pixels_valid"]:
        print(f"{info['zero_pixels_valid']} valid pixels are exactly 0, data by the look of them "
              f"(they continue their neighbours)")
    if valid.any():
        print(f"depth range {info['depth_min']:g} .. {info['depth_max']:g} "
              f"({info['distinct_values']} distinct values)")
    return 0


def _info_cloud(args):
    """`rangemesh info cloud.bin`: its points, returns and angles (no beams: no range image)."""
    from .clouds import read_cloud

    try:
        pts = read_cloud(args.image)
    except ValueError as exc:
        raise UserError(_one_line(exc)) from None
    xyz = pts[:, :3].astype(np.float64)
    with np.errstate(over="ignore", invalid="ignore"):
        r = np.sqrt(np.sum(xyz * xyz, axis=1))
    ok = np.isfinite(r) & (r > 0)
    el = np.degrees(np.arcsin(xyz[ok, 2] / r[ok])) if ok.any() else np.zeros(0)
    info = {"file": args.image, "points": len(pts), "returns": int(ok.sum()),
            "no_returns": int((~ok).sum()),
            "range_min": float(r[ok].min()) if ok.any() else None,
            "range_max": float(r[ok].max()) if ok.any() else None,
            "elevation_min_deg": float(el.min()) if ok.any() else None,
            "elevation_max_deg": float(el.max()) if ok.any() else None}
    if args.json:
        print(json.dumps(_clean(info)))
        return 0
    print(f"{args.image}: a LiDAR cloud of {info['points']} points (float32 x, y, z, "
          f"intensity), {info['returns']} with a return, {info['no_returns']} at the origin "
          f"(no return)")
    if ok.any():
        print(f"range {info['range_min']:g} .. {info['range_max']:g} m, elevation "
              f"{info['elevation_min_deg']:.2f} .. {info['elevation_max_deg']:.2f} degrees")
    print("as a range image: give --sensor NAME (the beams found from the cloud) or --beams "
          "FILE.json; --write-beams FILE.json keeps the beams found")
    return 0


def _write_beams(args):
    """--write-beams: the beams of the projected cloud, as --beams reads them."""
    from .clouds import project_scan, read_cloud, write_beams

    if Path(args.image).suffix.lower() != SCAN_SUFFIX or args.sensor is None:
        raise UserError("--write-beams goes with a LiDAR cloud (.bin) and --sensor")
    try:
        beams = getattr(args, "scan_beams", None) or project_scan(read_cloud(args.image),
                                                                  sensor=args.sensor).beams
        write_beams(args.write_beams, beams)
    except (ValueError, OSError) as exc:
        raise UserError(_one_line(exc)) from None
    if not args.json:
        print(f"wrote {args.write_beams} ({beams['rows']} beams, {beams['cols']} columns)")


def _cleaned(args, depth, valid, camera):
    """--depth-limits and --min-region applied to a masked image, in place; pixels each dropped."""
    from .cleanup import clean_inplace

    try:
        params = MeshParams(depth_limits=args.depth_limits, min_region=args.min_region)
    except (ValueError, TypeError) as exc:
        raise UserError(_one_line(exc)) from None
    return clean_inplace(depth, valid, params, camera)


def _cmd_eval(args):
    image = _read_scan(args)  # an image file, or a LiDAR .bin with --beams, as `mesh` reads
    given = any(x is not None for x in (args.scale, args.intrinsics, args.depth_scale, args.beams,
                                         args.camera, args.sensor))
    _check_depth_scale(args, image)
    camera = _camera(args, image.shape) if given else None  # None: the camera the file records
    try:
        mesh = read_mesh(args.mesh, camera=camera, image_shape=image.shape)
        # 'auto' by the mesh's camera, as `mesh` took it
        ev = evaluate(mesh, image, background=_resolve_background(args.background, image,
                                                                   mesh.camera),
                      depth_limits=args.depth_limits, min_region=args.min_region)
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
    print(_deviation_line(ev, mesh.camera))
    return 0


def _cmd_batch(args):
    from .batch import mesh_many, summarize

    params, method, _ = _resolve(args)
    if args.sensor is not None:
        raise UserError("--sensor goes with mesh, eval and info (one cloud at a time); for a "
                        "batch, write its beams once (info CLOUD.bin --sensor NAME --write-beams "
                        "B.json) and give --beams B.json")
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


def _cmd_live(args):
    """`rangemesh live SOURCE`: meshes as the sensor (or a paced recording) gives frames."""
    from .live import run

    params, method, _ = _resolve(args)
    given = [o for o in ("scale", "intrinsics", "camera", "depth_scale", "beams")
             if getattr(args, o) is not None]
    if given:
        raise UserError(f"--{given[0].replace('_', '-')} does not apply to live: the camera comes "
                        f"from the source (its SDK, or the recording's CameraInfo)")
    try:
        s = run(args.source, foxglove=args.foxglove, outputs=args.output or (), csv=args.csv,
                fmt="." + args.format, overwrite=args.overwrite, quiet=args.quiet,
                kind=args.source_kind, meta=args.meta, topic=args.topic, pace=args.pace,
                loop=args.loop, frames=args.frames, queue=args.queue, method=method,
                vertices=args.vertices, max_error=args.max_error, **call_options(params, method))
    except (ValueError, TypeError) as exc:
        raise UserError(_one_line(exc)) from None
    if not args.quiet:
        lat = "" if s["latency_p95_ms"] is None else \
            f", latency median {s['latency_median_ms']:.0f} ms, p95 {s['latency_p95_ms']:.0f} ms"
        print(f"meshed {s['frames_out']} of {s['frames_in']} frames in {s['seconds']:.1f} s "
              f"({s['fps_out']:.1f} frames/s), dropped {s['dropped']}{lat}", file=sys.stderr)
        if s["csv"]:
            print(f"per-frame figures: {s['csv']}", file=sys.stderr)
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
    dev = m.add_argument_group("deviation targets (--method refine; instead of --vertices or "
                               "--max-error)")
    dev.add_argument("--max-deviation", type=float, default=None, metavar="D",
                     help="every valid pixel within D of the mesh along its ray: metres with "
                          "--intrinsics, --camera or --beams (z-depth, or range), depth units "
                          "otherwise; fitted depths included")
    dev.add_argument("--mean-deviation", type=float, default=None, metavar="D",
                     help="the mean deviation of the valid pixels (as --max-deviation) at most D")
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
    _add_cleanup_options(i)
    _add_camera_options(i)  # the camera says what 'auto' marks as missing depth
    i.add_argument("--write-beams", metavar="FILE.json", default=None,
                   help="with a .bin cloud and --sensor: write the beams found, for --beams")
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
    _add_cleanup_options(e)
    _add_camera_options(e)
    e.add_argument("--json", action="store_true", help="print as JSON on stdout")
    lv = sub.add_parser("live", help="mesh a depth camera, a LiDAR or a paced recording as it runs",
                        description="Mesh frames as a sensor gives them (a RealSense, an Ouster) "
                                    "or as a recording plays; publish each mesh to a Foxglove "
                                    "server, an MCAP file or a folder. When meshing falls "
                                    "behind, the newest frame wins. Ctrl-C ends the run.")
    lv.add_argument("source", help="realsense or realsense:SERIAL (a camera), a RealSense .bag, an "
                                   "Ouster .pcap/.osf (with --meta) or hostname, or a ROS "
                                   "recording (.bag, .db3, .mcap)")
    lv.add_argument("--source", dest="source_kind", choices=["realsense", "ouster", "ros"],
                    default=None, help="the reader, when the name does not say (a RealSense "
                                       "SDK .bag goes to pyrealsense2, another .bag to ROS)")
    lv.add_argument("--meta", metavar="FILE.json", default=None,
                    help="an Ouster recording's metadata")
    lv.add_argument("--topic", default=None, help="a ROS recording's depth topic")
    lv.add_argument("--pace", default="recorded", metavar="{recorded,N,fast}",
                    help="a recording's playback: its stamps (default), N frames/s, or as fast "
                         "as meshing goes (nothing dropped)")
    lv.add_argument("--loop", action="store_true", help="replay a recording without end")
    lv.add_argument("--frames", type=int, default=None, help="stop after N meshes")
    lv.add_argument("--queue", type=int, default=1,
                    help="frames kept waiting while one is meshed; older ones are dropped "
                         "(default 1: the newest wins)")
    lv.add_argument("--foxglove", metavar="[HOST:]PORT", default=None,
                    help="serve the meshes to Foxglove over WebSocket (port 0: a free one; "
                         "host 127.0.0.1 unless given); the URL is printed on stdout")
    lv.add_argument("-o", "--output", action="append", default=None,
                    help="NAME.mcap (what the server publishes, with the figures) or a folder "
                         "(one mesh file per frame); may be given twice")
    lv.add_argument("--format", default="ply", choices=[s[1:] for s in MESH_SUFFIXES],
                    help="mesh files' format in a folder output (default ply)")
    lv.add_argument("--csv", default=None,
                    help="per-frame figures (default: NAME.rangemesh-live.csv beside the MCAP, "
                         "or in the folder)")
    lv.add_argument("--overwrite", action="store_true", help="replace existing outputs")
    lv.add_argument("--quiet", action="store_true", help="no status line, no summary")
    _add_mesh_options(lv)
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
        parser.error("give a command: mesh, demo, batch, live, info or eval (rangemesh -h says more)")
    args = parser.parse_args(argv)
    commands = {"mesh": _cmd_mesh, "demo": _cmd_demo, "info": _cmd_info, "eval": _cmd_eval,
                "batch": _cmd_batch, "live": _cmd_live}
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
