"""Ouster recordings (``.pcap``/``.osf`` with ``--meta``) in ``info``, ``mesh`` and ``batch``.

They are read by the one Ouster reader (`rangemesh.recordings.ouster`, which
``live`` uses too): a scan's range image with the SDK's per-pixel rays and
beam-origin offsets. `ouster-sdk` is not in ``rangemesh[all]`` (its pins
clash with ``[ros]``): without it the commands name ``rangemesh[ouster]``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .common import UserError, _clean, _one_line

# flags that give a camera: an Ouster recording's geometry is the SDK's
_CAMERA_FLAGS = ("scale", "intrinsics", "camera", "depth_scale", "beams", "sensor")


def add_ouster_options(p, frame: bool = True) -> None:
    """--meta (and --frame) for the commands that read an Ouster recording."""
    g = p.add_argument_group("Ouster recordings (.pcap, .osf; pip install \"rangemesh[ouster]\")")
    g.add_argument("--meta", metavar="FILE.json", default=None,
                   help="the recording's metadata JSON (as the SDK's tools spell it; optional "
                        "when the SDK finds it beside the recording); the SDK's per-pixel rays "
                        "and beam-origin offsets place the vertices")
    if frame:
        g.add_argument("--frame", type=int, metavar="K", default=None,
                       help="the scan to use, counted from 0 (default 0)")


def is_ouster_input(args, path) -> bool:
    """Whether `path` is an Ouster recording; --meta and --frame refused with anything else."""
    from ..recordings.ouster import is_ouster

    if is_ouster(path):
        return True
    for opt in ("meta", "frame"):
        if getattr(args, opt, None) is not None:
            raise UserError(f"--{opt} goes with an Ouster recording (.pcap or .osf)")
    return False


def check_no_camera(args) -> None:
    """The SDK gives an Ouster recording's geometry: a camera flag is an error."""
    for opt in _CAMERA_FLAGS:
        if getattr(args, opt, None) is not None:
            raise UserError(f"--{opt.replace('_', '-')} does not apply to an Ouster recording: "
                            f"ouster-sdk gives its per-pixel geometry (--meta FILE.json)")


def read_ouster_scan(args):
    """Scan --frame of the recording: its range image (mm); the camera, offsets and wrap set on `args`."""
    from ..recordings.ouster import read_one_scan

    check_no_camera(args)
    frame = getattr(args, "frame", None)
    try:
        scan, reader = read_one_scan(args.image, meta=getattr(args, "meta", None),
                                 frame=0 if frame is None else frame)
    except (ValueError, FileNotFoundError) as exc:
        raise UserError(_one_line(exc)) from None
    args.scan_camera, args.scan_offsets = reader.camera, reader.offsets
    args.ouster = {"product": str(reader.info.prod_line), "serial": str(reader.info.sn),
                   "mode": f"{reader.shape[1]}x{reader.fps:g}", "wraps": reader.wraps,
                   "stamp": scan.stamp}
    if reader.wraps and hasattr(args, "wrap") and not isinstance(args.wrap, bool):
        args.wrap = True  # the whole circle: the seam closed, as `live` does (--no-wrap opens it)
    return scan.ranges


def info_ouster(args) -> int:
    """`rangemesh info REC.pcap`: the sensor, the scans, and scan --frame's pixels and ranges."""
    from ..recordings.ouster import OusterReader

    check_no_camera(args)
    if args.background != "auto" or args.write_beams is not None:
        raise UserError("--background and --write-beams do not apply to an Ouster recording")
    frame = 0 if args.frame is None else args.frame
    if frame < 0:
        raise UserError(f"--frame must be a whole number >= 0, got {frame}")
    picked, count = None, 0
    try:
        with OusterReader(args.image, meta=args.meta) as reader:
            for scan in reader.scans():
                count += 1
                if scan.index == frame:
                    picked = scan
    except (ValueError, FileNotFoundError) as exc:
        raise UserError(_one_line(exc)) from None
    if picked is None:
        raise UserError(f"{args.image}: --frame {frame} is past the recording's end (it has "
                        f"{count} scans, counted from 0)")
    valid = picked.ranges > 0
    m = picked.ranges[valid] * 0.001
    i = reader.info
    info = {"file": args.image, "sensor": str(i.prod_line), "serial": str(i.sn),
            "firmware": str(i.fw_rev), "scans": count, "shape": list(reader.shape),
            "fps": reader.fps, "whole_circle": reader.wraps, "frame": frame,
            "stamp_ns": picked.stamp, "valid_pixels": int(valid.sum()),
            "valid_share_percent": 100.0 * float(valid.mean()),
            "range_min_m": float(m.min()) if m.size else None,
            "range_max_m": float(m.max()) if m.size else None}
    if args.json:
        print(json.dumps(_clean(info)))
        return 0
    h, w = reader.shape
    circle = "the whole circle" if reader.wraps else "part of the circle"
    print(f"{args.image}: an Ouster {info['sensor']} recording (serial {info['serial']}, firmware "
          f"{info['firmware']}), {count} scans of {h} rows x {w} columns at {reader.fps:g} Hz, "
          f"{circle}; range in mm, 0 for no return")
    line = f"scan {frame}: valid pixels {info['valid_pixels']} ({info['valid_share_percent']:.1f} %)"
    if m.size:
        line += f", range {info['range_min_m']:g} .. {info['range_max_m']:g} m"
    print(line)
    return 0


def default_ouster_output(args) -> Path:
    """``REC.frameK.ply`` beside the recording."""
    image = Path(args.image)
    return image.with_name(f"{image.stem}.frame{0 if args.frame is None else args.frame}.ply")


def without_scan_offsets(args, mesh, path):
    """A mesh file of an Ouster scan, its vertices moved back onto the rays (`evaluate`'s frame).

    The file's vertices carry the beam-origin offsets `mesh` added; its pixels (``--pixels``)
    say which, and are what a ray camera needs to compare the mesh with the scan.
    """
    offsets = getattr(args, "scan_offsets", None)
    if mesh.pixels is None or len(mesh.pixels) != len(mesh.vertices):
        raise UserError(f"{path}: an Ouster scan's mesh is compared pixel by pixel: write it with "
                        f"--pixels (rangemesh mesh REC.pcap --pixels ...)")
    if offsets is None:
        return mesh
    from ..recordings.ouster import with_offsets

    return with_offsets(mesh, -np.asarray(offsets))


def with_scan_offsets(args, mesh):
    """The mesh with the Ouster scan's beam-origin offsets added (the SDK's exact points)."""
    offsets = getattr(args, "scan_offsets", None)
    if offsets is None:
        return mesh
    from ..recordings.ouster import with_offsets

    return with_offsets(mesh, np.asarray(offsets))
