"""What the commands share.

One-line user errors, the camera and the image from the flags, the outputs' checks, the
progress bar, and the signals that end a command as Ctrl-C does.
"""

from __future__ import annotations

import contextlib
import math
import signal
import sys
import threading
from pathlib import Path

import numpy as np

from ..camera import Orthographic, Pinhole, Spherical
from ..cloud_files import CLOUD_SUFFIXES
from ..io import MESH_SUFFIXES, SCAN_SUFFIX, bin_layout, read_image_size, read_range_image, read_scan
from ..memory import check_memory
from ..prepare import guess_background


class UserError(Exception):
    """A problem with the user's input, reported as one line."""


def _one_line(exc: BaseException) -> str:
    """An exception as one line: its first line, or its type when it says nothing."""
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def _os_message(exc: OSError) -> str:
    """``path: reason`` for a failed file operation (permission, full disk, a folder...)."""
    reason = exc.strerror or _one_line(exc)
    return f"{exc.filename}: {reason}" if exc.filename else reason


def _resolve_background(spec, image, camera=None):
    """What marks missing depth: `--background` as given, 'auto' by the camera (one rule with Python)."""
    if spec == "auto":
        return guess_background(image, camera)
    if spec in ("none", "nan"):
        return None
    return spec


def _deviation_line(ev, camera) -> str:
    """Evaluate's deviations, in metres with a metric camera, depth units otherwise."""
    unit = "depth units" if isinstance(camera, Orthographic) else "m"
    return (f"max deviation {ev.max_deviation:.6g} {unit}  "
            f"mean deviation {ev.mean_deviation:.6g} {unit}")


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
        from ..camera_files import read_camera

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


def _refuse_unnamed(args, path: Path, option: str) -> None:
    """An output the command named itself replaces no file unless --overwrite (the user never named it)."""
    if path.exists() and not args.overwrite:
        raise UserError(f"{path}: already there (the default output name); give {option} to "
                        f"write elsewhere, or --overwrite to replace it")


def _read_scan(args):
    """The range image of a mesh command: an image file, a LiDAR .bin read with --beams, an Ouster scan."""
    from .ouster import is_ouster_input, read_ouster_scan

    if is_ouster_input(args, args.image):
        return read_ouster_scan(args)
    suffix = Path(args.image).suffix.lower()
    if suffix != SCAN_SUFFIX and getattr(args, "sensor", None) is None:
        if suffix == ".ply":  # a mesh suffix, never an image: as a cloud it needs its head
            raise UserError(f"{args.image}: a .ply cloud needs --sensor (a Velodyne preset or "
                            f"an Ouster metadata .json) to become a range image")
        return _read_image(args.image)
    if suffix not in CLOUD_SUFFIXES:
        raise UserError(f"{args.image}: --sensor goes with a LiDAR cloud "
                        f"({', '.join(CLOUD_SUFFIXES)})")
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
    from ..clouds import project_scan, read_cloud

    sensor = getattr(args, "sensor", None)
    if sensor is None:
        return None
    if args.beams is not None:
        raise UserError("--sensor and --beams exclude each other (--sensor finds the beams)")
    try:
        points, ring = read_cloud(args.image, ring=True)  # the driver's ring field, if any
        scan = project_scan(points, ring=ring, sensor=sensor)
    except (ValueError, TypeError) as exc:
        raise UserError(_one_line(exc)) from None
    args.scan_camera, args.scan_beams = scan.camera, scan.beams
    return scan


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
