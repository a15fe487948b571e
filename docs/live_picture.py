"""The README's picture of rangemesh live: the SceneUpdate meshes read back from its MCAP file.

    python docs/live_picture.py [docs/live-meshes.png]

Runs ``rangemesh live`` on the RealSense bag
(``shared/data/rosbag/librealsense_d435_single_depth_color_640x480.bag``, through pyrealsense2
when it is installed, else the ROS reader; ``--pace fast``, the default target) into an MCAP
file, reads each ``/rangemesh/mesh`` message back with `mcap` and its protobuf decoder and the
camera from ``/rangemesh/calibration``, and draws each frame's triangles as the camera sees them
(coloured by depth, shaded), with its stamp, frame id and counts: what Foxglove's 3D panel shows
from the camera's viewpoint.
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

import numpy as np

from rangemesh.cli import main as rangemesh

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("RANGEMESH_DATA", ROOT.parent / "shared" / "data"))
BAG = DATA / "rosbag" / "librealsense_d435_single_depth_color_640x480.bag"


def read_back(path: Path) -> tuple[list, object]:
    """The decoded SceneUpdate messages and the first CameraCalibration of a live MCAP file."""
    from mcap.reader import make_reader
    from mcap_protobuf.decoder import DecoderFactory

    with open(path, "rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        scenes = [d for _, _, _, d in reader.iter_decoded_messages(topics=["/rangemesh/mesh"])]
    with open(path, "rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        calib = next(d for _, _, _, d in reader.iter_decoded_messages(
            topics=["/rangemesh/calibration"]))
    return scenes, calib


def draw(ax, scene, k) -> None:
    """A SceneUpdate's triangles projected with the calibration's K, flat-shaded, far ones first."""
    from matplotlib import colormaps
    from matplotlib.collections import PolyCollection

    entity = scene.entities[0]
    t = entity.triangles[0]
    pts = np.array([[p.x, p.y, p.z] for p in t.points])
    tri = pts[np.reshape(t.indices, (-1, 3))]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    light = np.array([-0.35, -0.35, 1.0]) / np.linalg.norm([-0.35, -0.35, 1.0])
    tone = 0.15 + 0.85 * np.abs(n @ light)
    fx, cx, fy, cy = k[0], k[2], k[4], k[5]
    uv = np.stack([tri[..., 0] / tri[..., 2] * fx + cx, tri[..., 1] / tri[..., 2] * fy + cy], -1)
    z = tri[..., 2].mean(axis=1)
    order = np.argsort(-z)
    rgb = colormaps["viridis"]((z - 0.3) / 2.9)[:, :3] * (0.55 + 0.45 * tone)[:, None]
    ax.add_collection(PolyCollection(uv[order], facecolors=rgb[order],
                                     edgecolors=(1, 1, 1, 0.3), linewidths=0.15))
    ax.set_xlim(0, 640)
    ax.set_ylim(480, 0)
    ax.set_aspect("equal")
    ax.set_facecolor("black")
    ax.set_xticks([])
    ax.set_yticks([])
    stamp = f"{entity.timestamp.seconds}.{entity.timestamp.nanos:09d}"
    ax.set_title(f"{entity.frame_id} at {stamp} s: {len(pts)} vertices, "
                 f"{len(t.indices) // 3} triangles", fontsize=10)


def picture(out: Path) -> None:
    """Run rangemesh live into a temporary MCAP file and draw its meshes into `out`."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    with tempfile.TemporaryDirectory() as tmp:
        mcap = Path(tmp) / "live.mcap"
        code = rangemesh(["live", str(BAG), "--pace", "fast", "-o", str(mcap), "--quiet"])
        if code != 0:
            raise SystemExit(code)
        scenes, calib = read_back(mcap)
    fig = Figure(figsize=(12, 4.9), dpi=80, layout="constrained")
    axes = fig.subplots(1, len(scenes))
    for ax, scene in zip(axes, scenes, strict=True):
        draw(ax, scene, list(calib.K))
    fig.suptitle("rangemesh live (RealSense bag) --pace fast -o live.mcap: "
                 "the SceneUpdate meshes read back", fontsize=11)
    fig.savefig(out, format="png")


if __name__ == "__main__":
    picture(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "live-meshes.png")
