"""``rangemesh live``: mesh a sensor or a paced recording as it gives frames."""

from __future__ import annotations

import sys

from ..io import MESH_SUFFIXES
from ..resolve import call_options
from .common import UserError, _one_line
from .options import _add_mesh_options, _resolve


def handle(args):
    """`rangemesh live SOURCE`: meshes as the sensor (or a paced recording) gives frames."""
    from ..live import run
    from ..live.session import check_apart

    params, method, _ = _resolve(args)
    given = [o for o in ("scale", "intrinsics", "camera", "depth_scale", "beams")
             if getattr(args, o) is not None]
    if given:
        raise UserError(f"--{given[0].replace('_', '-')} does not apply to live: the camera comes "
                        f"from the source (its SDK, or the recording's CameraInfo)")
    try:
        check_apart(args.source, args.output or (), args.csv, names=("-o", "--csv"))
        s = run(args.source, foxglove=args.foxglove, outputs=args.output or (), csv=args.csv,
                fmt="." + args.format, overwrite=args.overwrite, quiet=args.quiet,
                kind=args.source_kind, meta=args.meta, topic=args.topic, pace=args.pace,
                loop=args.loop, frames=args.frames, queue=args.queue, method=method,
                vertices=args.vertices, max_error=args.max_error,
                max_deviation=args.max_deviation, mean_deviation=args.mean_deviation,
                **call_options(params, method))
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


NAME = "live"
HELP = "mesh a depth camera, a LiDAR or a paced recording as it runs"
DESCRIPTION = """\
Mesh frames as a sensor gives them (a RealSense, an Ouster) or as a recording plays; publish
each mesh to a Foxglove server, an MCAP file or a folder. When meshing falls behind, the newest
frame wins. Ctrl-C ends the run.
"""


def add_arguments(lv) -> None:
    """The ``live`` subcommand's flags."""
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
