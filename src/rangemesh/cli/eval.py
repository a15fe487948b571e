"""``rangemesh eval``: the paper's relative error (and the deviations) of any mesh file."""

from __future__ import annotations

import json

from ..io import MESH_SUFFIXES, read_mesh
from ..metrics import evaluate
from .common import (
    UserError,
    _camera,
    _check_depth_scale,
    _clean,
    _deviation_line,
    _read_scan,
    _resolve_background,
)
from .options import _add_camera_options, _add_cleanup_options, _add_image_options
from .ouster import add_ouster_options, without_scan_offsets


def handle(args):
    """`rangemesh eval IMAGE MESH`: the mesh's errors against the image."""
    image = _read_scan(args)  # an image file, or a LiDAR .bin with --beams, as `mesh` reads
    given = any(x is not None for x in (args.scale, args.intrinsics, args.depth_scale, args.beams,
                                         args.camera, args.sensor))
    _check_depth_scale(args, image)
    # an Ouster scan's camera is the SDK's rays; else None: the camera the file records
    ouster = getattr(args, "scan_camera", None)
    camera = ouster if ouster is not None else _camera(args, image.shape) if given else None
    try:
        mesh = read_mesh(args.mesh, camera=camera, image_shape=image.shape)
        if ouster is not None:
            mesh = without_scan_offsets(args, mesh, args.mesh)
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


NAME = "eval"
HELP = "the paper's relative error of any mesh file"
DESCRIPTION = """\
Compare a mesh file with its range image: relative error (mean |depth - mesh| / depth range),
RMS, max, edge band, uncovered share. PLY files written by rangemesh record their camera; for
other files give the camera the mesh was made with. An Ouster recording (.pcap, .osf) is read as
`mesh` reads it (--meta, --frame); its mesh file needs its vertices' pixels (mesh --pixels).
"""


def add_arguments(e) -> None:
    """The ``eval`` subcommand's flags."""
    e.add_argument("image")
    e.add_argument("mesh", help=f"mesh file ({' '.join(MESH_SUFFIXES)})")
    _add_image_options(e)
    _add_cleanup_options(e)
    _add_camera_options(e)
    add_ouster_options(e)
    e.add_argument("--json", action="store_true", help="print as JSON on stdout")
