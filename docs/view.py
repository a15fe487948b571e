"""A 3-D picture of a mesh file, for the README: flat-shaded faces seen from a chosen direction.

    python docs/view.py scan.ply docs/lidar-3d.png --box -12,12,-12,12,-3,6 --elev 28 --azim 200
    python docs/view.py frame.ply docs/rgbd-color.png --colors --elev -80 --azim -90

Faces take the mean colour of their vertices (``--colors``, from ``rangemesh mesh --color``) or a
colour by height, times a Lambert shade. matplotlib draws the faces back to front (the painter's
algorithm), which is enough for a picture of a few tens of thousands of faces.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

import rangemesh


def _floats(text):
    return [float(x) for x in text.split(",")]


def main(argv=None) -> int:
    """Command line of the picture; returns the exit status."""
    ap = argparse.ArgumentParser(prog="python docs/view.py", description=__doc__.splitlines()[0])
    ap.add_argument("mesh", help="a mesh file rangemesh wrote (PLY keeps the colours)")
    ap.add_argument("png", help="picture to write")
    ap.add_argument("--box", type=_floats, default=None, metavar="X0,X1,Y0,Y1,Z0,Z1",
                    help="keep the faces inside this box (metres)")
    ap.add_argument("--elev", type=float, default=30.0, help="view elevation, degrees")
    ap.add_argument("--azim", type=float, default=200.0, help="view azimuth, degrees")
    ap.add_argument("--colors", action="store_true", help="use the file's vertex colours")
    ap.add_argument("--title", default="", help="title above the picture")
    ap.add_argument("--size", type=_floats, default=[12.0, 7.0], metavar="W,H", help="inches")
    args = ap.parse_args(argv)

    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import colormaps
    from matplotlib.figure import Figure
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    mesh = rangemesh.read_mesh(args.mesh)
    tri = mesh.vertices[mesh.faces]
    keep = np.ones(len(tri), bool)
    if args.box:
        x0, x1, y0, y1, z0, z1 = args.box
        lo, hi = np.array([x0, y0, z0]), np.array([x1, y1, z1])
        keep = ((tri >= lo) & (tri <= hi)).all(axis=(1, 2))
    tri, faces = tri[keep], mesh.faces[keep]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    tone = 0.35 + 0.65 * np.abs(n @ (np.array([0.4, 0.3, 0.87]) / np.linalg.norm([0.4, 0.3, 0.87])))
    if args.colors and mesh.colors is not None:
        rgb = mesh.colors[faces].mean(axis=1) / 255.0
    else:
        z = tri[:, :, 2].mean(axis=1)
        rgb = colormaps["viridis"]((z - z.min()) / max(np.ptp(z), 1e-9))[:, :3]
    fig = Figure(figsize=tuple(args.size), dpi=100, layout="constrained")
    ax = fig.add_subplot(projection="3d")
    ax.add_collection3d(Poly3DCollection(tri, facecolors=rgb * tone[:, None], edgecolors="none"))
    pts = tri.reshape(-1, 3)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(tuple(np.maximum(hi - lo, 1e-9)))
    ax.view_init(args.elev, args.azim)
    ax.set_axis_off()
    if args.title:
        ax.set_title(args.title)
    fig.savefig(args.png)
    print(f"{args.png}: {len(tri)} faces drawn", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
