"""``rangemesh demo``: mesh a built-in synthetic scene (no input needed)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import scenes
from .common import _check_outputs, _refuse_unnamed
from .mesh import _run_mesh
from .options import _add_mesh_options, _add_output_options, _add_overwrite_option, _add_ply_options


def handle(args):
    """`rangemesh demo`: the built-in scene meshed, with its preview picture."""
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


NAME = "demo"
HELP = "mesh a built-in synthetic scene (no input needed)"
DESCRIPTION = "Mesh a built-in scene (a box and a pyramid) and write the mesh and a preview picture."


def add_arguments(d) -> None:
    """The ``demo`` subcommand's flags."""
    d.add_argument("-o", "--output", default=None, help="mesh file (default demo.ply)")
    d.add_argument("--preview", default=None, help="PNG picture (default demo-preview.png)")
    _add_ply_options(d)
    _add_overwrite_option(d)
    _add_mesh_options(d)
    _add_output_options(d)
