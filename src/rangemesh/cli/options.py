"""The flags the commands share.

Image, camera and clean-up options, and the flags made from the option table
(`rangemesh.params.OPTION_TABLE`), read back into a call's parameters.
"""

from __future__ import annotations

import argparse
import sys

from ..options import BOTH
from ..params import OPTION_TABLE, OPTIONS_BY_NAME, MeshParams, misplaced_option
from ..prepare import NONPOSITIVE
from ..resolve import resolve_call
from .common import UserError, _one_line

_DEFAULTS = MeshParams()
_UNSET = object()  # an option flag not given (--flips none means None: not given needs a marker)


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
    from ..clouds import SENSORS

    def sensor(text):
        if text in SENSORS or text.lower().endswith(".json"):
            return text
        raise argparse.ArgumentTypeError(f"expected one of {', '.join(sorted(SENSORS))} or an "
                                         f"Ouster metadata FILE.json, got {text!r}")

    c.add_argument("--sensor", type=sensor, default=None,
                   metavar="{" + ",".join(sorted(SENSORS)) + "} or META.json",
                   help="an unorganised LiDAR cloud (.bin, KITTI's x, y, z, intensity; .pcd or "
                        ".ply, with a ring field where the driver gives one): the Velodyne head "
                        "whose beams are found from the cloud, or an Ouster head from its "
                        "metadata JSON, makes the range image (rangemesh.project_scan); with "
                        "--beams a .bin cloud is projected on the file's beams")


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
    """The meshing flags, the same for every command that meshes (mesh, demo, batch, live)."""
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
    dev = p.add_argument_group("deviation targets (--method refine; instead of --vertices or "
                               "--max-error)")
    dev.add_argument("--max-deviation", type=float, default=None, metavar="D",
                     help="every valid pixel within D of the mesh along its ray: metres with "
                          "--intrinsics, --camera or --beams (z-depth, or range), depth units "
                          "otherwise; fitted depths included")
    dev.add_argument("--mean-deviation", type=float, default=None, metavar="D",
                     help="the mean deviation of the valid pixels (as --max-deviation) at most D")


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
    """``(max_deviation, mean_deviation)`` as given (Nones when not)."""
    return args.max_deviation, args.mean_deviation


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
