"""``rangemesh info``: describe a range image, a LiDAR cloud or a recording's depth topics."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..io import SCAN_SUFFIX
from ..params import MeshParams
from ..prepare import NONPOSITIVE, to_depth_and_mask
from .common import UserError, _camera, _clean, _one_line, _read_image, _read_scan, _resolve_background
from .options import _add_camera_options, _add_cleanup_options, _add_image_options
from .ouster import add_ouster_options, info_ouster, is_ouster_input


def handle(args):
    """`rangemesh info FILE`: what the image, cloud or recording holds."""
    from ..recordings import is_recording

    if is_ouster_input(args, args.image):
        return info_ouster(args)
    if is_recording(args.image):
        return _info_recording(args)
    if _is_cloud(args.image) or args.sensor is not None:
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
    from ..cleanup import zeros_like_a_marker
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


def _is_cloud(path) -> bool:
    """A cloud file: a .bin or .ply, or a .pcd that is not organised (an organised one is an image)."""
    from ..cloud_files import pcd_height

    suffix = Path(path).suffix.lower()
    if suffix == ".pcd":
        try:
            return pcd_height(path) <= 1
        except (OSError, ValueError):
            return False  # the image reader says why in one line
    return suffix in (SCAN_SUFFIX, ".ply")


def _info_cloud(args):
    """`rangemesh info cloud.bin`: its points, returns and angles (no beams: no range image)."""
    from ..clouds import read_cloud

    try:
        pts, ring = read_cloud(args.image, ring=True)
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
            "elevation_max_deg": float(el.max()) if ok.any() else None,
            "ring_beams": None if ring is None else int(len(np.unique(ring)))}
    if args.json:
        print(json.dumps(_clean(info)))
        return 0
    print(f"{args.image}: a LiDAR cloud of {info['points']} points (x, y, z, intensity), "
          f"{info['returns']} with a return, {info['no_returns']} at the origin or not finite "
          f"(no return)" + ("" if ring is None else f"; a ring field of {info['ring_beams']} beams"))
    if ok.any():
        print(f"range {info['range_min']:g} .. {info['range_max']:g} m, elevation "
              f"{info['elevation_min_deg']:.2f} .. {info['elevation_max_deg']:.2f} degrees")
    print("as a range image: give --sensor NAME (the beams found from the cloud), --sensor "
          "META.json (an Ouster's metadata) or --beams FILE.json; --write-beams FILE.json keeps "
          "the beams found")
    return 0


def _write_beams(args):
    """--write-beams: the beams of the projected cloud, as --beams reads them."""
    from ..clouds import project_scan, read_cloud, write_beams

    if not _is_cloud(args.image) or args.sensor is None:
        raise UserError("--write-beams goes with a LiDAR cloud (.bin, .pcd, .ply) and --sensor")
    try:
        beams = getattr(args, "scan_beams", None)
        if beams is None:
            points, ring = read_cloud(args.image, ring=True)
            beams = project_scan(points, ring=ring, sensor=args.sensor).beams
        write_beams(args.write_beams, beams)
    except (ValueError, OSError) as exc:
        raise UserError(_one_line(exc)) from None
    if not args.json:
        print(f"wrote {args.write_beams} ({beams['rows']} beams, {beams['cols']} columns)")


def _cleaned(args, depth, valid, camera):
    """--depth-limits and --min-region applied to a masked image, in place; pixels each dropped."""
    from ..cleanup import clean_inplace

    try:
        params = MeshParams(depth_limits=args.depth_limits, min_region=args.min_region)
    except (ValueError, TypeError) as exc:
        raise UserError(_one_line(exc)) from None
    return clean_inplace(depth, valid, params, camera)


def _info_recording(args):
    """`rangemesh info recording`: its depth topics (size, encoding, count) and their cameras."""
    from ..recordings import Recording

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


NAME = "info"
HELP = "describe a range image or a recording's depth topics"
DESCRIPTION = """\
Size, dtype, valid share, depth range and what marks missing depth; for a ROS recording its
depth topics with size, encoding, count and camera; for an Ouster recording the sensor, its
scans and one scan's valid pixels.
"""


def add_arguments(i) -> None:
    """The ``info`` subcommand's flags."""
    i.add_argument("image")
    add_ouster_options(i)
    _add_image_options(i)
    _add_cleanup_options(i)
    _add_camera_options(i)  # the camera says what 'auto' marks as missing depth
    i.add_argument("--write-beams", metavar="FILE.json", default=None,
                   help="with a .bin cloud and --sensor: write the beams found, for --beams")
    i.add_argument("--json", action="store_true", help="print as JSON on stdout")
