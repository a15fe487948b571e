"""``rangemesh batch``: many images (files, folders, globs) or one ROS recording, in parallel."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from ..io import MESH_SUFFIXES
from ..resolve import call_options
from ..timing import timed
from .common import (
    UserError,
    _camera,
    _check_depth_scale,
    _clean,
    _make_camera,
    _one_line,
    _read_image,
    _same_file,
)
from .options import _add_image_options, _add_mesh_options, _add_output_options, _resolve
from .ouster import add_ouster_options, check_no_camera


def handle(args):
    """`rangemesh batch INPUTS -o DIR`: every input meshed into DIR; 1 when some failed."""
    from ..batch import mesh_many, summarize

    params, method, _ = _resolve(args)
    colors = _colors(args)
    if args.sensor is not None:
        raise UserError("--sensor goes with mesh, eval and info (one cloud at a time); for a "
                        "batch, write its beams once (info CLOUD.bin --sensor NAME --write-beams "
                        "B.json) and give --beams B.json")
    camera = _camera(args)
    if _recording_input(args) is None and args.depth_scale is None \
            and (args.intrinsics is not None or args.camera is not None):
        from ..batch import expand_inputs

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
    clock = timed()
    report = Path(args.output_dir) / "rangemesh-batch.csv"
    recording = _recording_input(args)
    _check_output_dir(args, recording)
    try:
        if recording is not None:
            results, report = _mesh_recording(args, recording, params, method)
        else:
            results = mesh_many(args.inputs, args.output_dir, background=bg, camera=camera,
                                scheduler=args.scheduler, workers=args.workers,
                                overwrite=args.overwrite, fmt="." + args.format,
                                progress=not (args.quiet or args.json) and sys.stderr.isatty(),
                                method=method, vertices=args.vertices, max_error=args.max_error,
                                max_deviation=args.max_deviation,
                                mean_deviation=args.mean_deviation,
                                beams=args.beams, colors=colors, **call_options(params, method))
    except (ValueError, TypeError) as exc:
        raise UserError(_one_line(exc)) from None
    summary = summarize(results, clock.elapsed)
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


def _check_output_dir(args, recording) -> None:
    """Refuse an -o that is an input, lies inside the recording, or is a file for the meshes' folder."""
    out = Path(args.output_dir)
    if recording is not None:
        rec = Path(recording)
        if _same_file(out, rec) or (rec.is_dir() and rec.resolve() in out.resolve().parents):
            raise UserError(f"-o {out}: the output must not be the recording {rec} or lie "
                            f"inside it; write it elsewhere")
        if out.suffix.lower() == ".mcap":
            return  # a file of markers: an existing one is replaced with --overwrite only
    for i in args.inputs:
        if _same_file(out, Path(i)):
            raise UserError(f"-o {out} is the input {i}: the meshes go to a folder, and an "
                            f"output never replaces an input")
    if out.exists() and not out.is_dir():
        what = "a folder (or NAME.mcap for a recording)" if recording is not None else "a folder"
        raise UserError(f"-o {out} is a file: the meshes go to {what}")


def _recording_input(args):
    """The recording a batch meshes (a .bag, .db3, .mcap or ROS 2 bag folder), or None for files."""
    from ..recordings import is_recording
    from ..recordings.ouster import is_ouster

    hits = [i for i in args.inputs if is_recording(i) or is_ouster(i)]
    if not hits and args.meta is not None:
        raise UserError("--meta goes with an Ouster recording (.pcap or .osf)")
    if not hits:
        for opt in ("topic", "color_topic", "camera_info_topic"):
            if getattr(args, opt) is not None:
                raise UserError(f"--{opt.replace('_', '-')} goes with a recording (.bag, .db3, "
                                f".mcap or a ROS 2 bag folder)")
        return None
    if len(args.inputs) > 1:
        raise UserError(f"{hits[0]}: a recording is meshed alone, not with other inputs")
    if args.color_pattern is not None or args.associations is not None:
        raise UserError("--color-pattern and --associations go with image files; a ROS "
                        "recording's colour is --color-topic")
    if args.background != "auto":
        raise UserError("--background does not apply to a recording: 0 and below (and NaN in "
                        "32FC1 images) are missing depth there")
    return hits[0]


def _colors(args):
    """The colour pairing of a folder batch (--color-pattern, --associations), or None.

    With --associations and no inputs, its depth files are the inputs.
    """
    from ..pairing import check_pattern, read_associations

    if args.color_pattern is not None and args.associations is not None:
        raise UserError("--color-pattern and --associations exclude each other")
    if not args.inputs and args.associations is None:
        raise UserError("give the inputs: image files, folders, quoted glob patterns or one "
                        "recording (or --associations FILE)")
    try:
        if args.associations is not None:
            pairs = read_associations(args.associations)
            if not args.inputs:
                args.inputs = [str(d) for d, _ in pairs]
            return {str(d): str(c) for d, c in pairs}
        if args.color_pattern is not None:
            return check_pattern(args.color_pattern)
    except (ValueError, TypeError) as exc:
        raise UserError(f"--{'associations' if args.associations else 'color-pattern'}: "
                        f"{_one_line(exc)}") from None
    return None


def _mesh_recording(args, path, params, method):
    """`rangemesh batch recording -o out.mcap|folder`: the results and where the figures are."""
    import warnings

    from ..recordings import Recording, mesh_recording
    from ..recordings.ouster import is_ouster

    camera = None
    if is_ouster(path):
        check_no_camera(args)
    elif args.meta is not None:
        raise UserError("--meta goes with an Ouster recording (.pcap or .osf)")
    elif (args.intrinsics is not None or args.camera is not None) and args.depth_scale is None:
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
            progress=not (args.quiet or args.json) and sys.stderr.isatty(), meta=args.meta,
            method=method, vertices=args.vertices, max_error=args.max_error,
            max_deviation=args.max_deviation, mean_deviation=args.mean_deviation,
            **call_options(params, method))
    if not args.quiet:
        for w in said:
            print(f"rangemesh: warning: {_one_line(w.message)}", file=sys.stderr)
    report = out.with_name(out.stem + ".rangemesh-batch.csv") if out.suffix.lower() == ".mcap" \
        else out / "rangemesh-batch.csv"
    return results, report


NAME = "batch"
HELP = "mesh many images (files, folders, globs) in parallel"
DESCRIPTION = """\
Mesh many range images into a folder, in parallel through Dask: a local cluster of worker
processes, or an existing cluster (--scheduler). Bad files are reported and the rest go on;
outputs already there are skipped unless --overwrite.
"""


def add_arguments(b) -> None:
    """The ``batch`` subcommand's flags."""
    b.add_argument("inputs", nargs="*", help="image files, folders or quoted glob patterns "
                                             "(LiDAR .bin scans with --beams); or one ROS "
                                             "recording (.bag, .db3, .mcap, ROS 2 bag folder) "
                                             "or Ouster recording (.pcap, .osf, with --meta): "
                                             "every frame")
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
    col = b.add_argument_group("colour (image files; registered pixel to pixel with the depth)")
    col.add_argument("--color-pattern", metavar="PATTERN", default=None,
                     help="each depth file's colour image, named from it: {stem} (name without "
                          "suffix), {name}, {dir} (its folder), e.g. 'rgb/{stem}.png' for "
                          "depth/*.png: vertex colours; colour images among the inputs are "
                          "skipped, not failed")
    col.add_argument("--associations", metavar="FILE", default=None,
                     help="a TUM-style association list ('stamp depth stamp rgb' a line, paths "
                          "relative to it; the path under 'depth' is the depth): the pairs, "
                          "and the inputs when none are given")
    ros = b.add_argument_group("ROS recordings (pip install \"rangemesh[ros]\")")
    ros.add_argument("--topic", default=None,
                     help="depth topic (16UC1/mono16 mm, 32FC1 m, compressedDepth); default: "
                          "the recording's only one (rangemesh info lists them)")
    ros.add_argument("--color-topic", default=None,
                     help="colour topic registered with the depth (same size): vertex colours")
    ros.add_argument("--camera-info-topic", default=None,
                     help="CameraInfo topic (default: the one beside the depth topic, same "
                          "frame id, nearest stamp)")
    add_ouster_options(b, frame=False)
    _add_image_options(b)
    _add_mesh_options(b)
    _add_output_options(b)
