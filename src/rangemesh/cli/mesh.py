"""``rangemesh mesh``: one range image (or LiDAR scan) to a mesh file, with its figures."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from ..io import IMAGE_SUFFIXES, MESH_SUFFIXES, read_color_image, write_mesh
from ..metrics import evaluate
from ..paper.sampling import sampling_weights
from ..pipeline import prepare, run
from .common import (
    UserError,
    _camera,
    _check_depth_scale,
    _check_outputs,
    _clean,
    _deviation_line,
    _one_line,
    _progress,
    _read_scan,
    _refuse_unnamed,
    _resolve_background,
    _same_file,
    _say,
)
from .options import (
    _add_image_options,
    _add_mesh_options,
    _add_output_options,
    _add_overwrite_option,
    _add_ply_options,
    _deviations,
    _resolve,
)
from .ouster import add_ouster_options, default_ouster_output, is_ouster_input, with_scan_offsets


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

        from ..cleanup import ZeroMarkerWarning

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
        mesh = with_scan_offsets(args, mesh)  # an Ouster scan: the SDK's exact points
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
            from ..preview import save_preview

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


def _default_output(args) -> None:
    """Without -o or --preview: the mesh goes beside the input as ``<stem>.ply``, never over it.

    An Ouster recording's scan K goes to ``<stem>.frameK.ply``.
    """
    if args.output or args.preview:
        return
    image = Path(args.image)
    out = default_ouster_output(args) if is_ouster_input(args, image) else image.with_suffix(".ply")
    if _same_file(out, image):
        raise UserError(f"{image}: is a .ply file; give -o FILE to choose where the mesh goes")
    _refuse_unnamed(args, out, "-o FILE")
    args.output = str(out)
    args.output_defaulted = True


def handle(args):
    """`rangemesh mesh IMAGE`: the image meshed into one file, its figures on stderr."""
    _default_output(args)
    _check_outputs(args, [a for a in (args.image, args.color, args.intensity) if a])
    image = _read_scan(args)
    return _run_mesh(args, image, args.image, args.background, (args.output, args.preview))


NAME = "mesh"
HELP = "mesh one range image"
DESCRIPTION = "Mesh one range image; print the figures on stderr."


def add_arguments(m) -> None:
    """The ``mesh`` subcommand's flags."""
    m.add_argument("image", help=f"range image ({' '.join(IMAGE_SUFFIXES)}), a KITTI-style "
                                 f"LiDAR .bin with --beams or --sensor, or an Ouster .pcap/.osf "
                                 f"with --meta (one scan: --frame)")
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
    add_ouster_options(m)
    _add_ply_options(m)
    _add_overwrite_option(m)
    _add_image_options(m)
    _add_mesh_options(m)
    _add_output_options(m)
