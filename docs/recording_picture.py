"""The README's picture of a recording's meshes: the RealSense bag meshed frame by frame.

    python docs/recording_picture.py [docs/recording-meshes.png]

Meshes the two depth frames of
``shared/data/rosbag/librealsense_d435_single_depth_color_640x480.bag`` (``rangemesh batch`` into
an MCAP file of markers, 1 % of the valid pixels as vertices), reads the markers back from the
MCAP file with `rosbags`, and draws each frame's triangles as seen from the camera (coloured by
depth, shaded like `rangemesh.preview.shade`) with its stamp, frame id and counts: what RViz or
Foxglove show when they play the file.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

from rangemesh.cli import main as rangemesh

ROOT = Path(__file__).resolve().parents[1]
BAG = ROOT.parent / "shared" / "data" / "rosbag" / "librealsense_d435_single_depth_color_640x480.bag"


def markers(path: Path) -> list:
    """Every message of an MCAP file, deserialised by `rosbags`."""
    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as r:
        return [r.deserialize(raw, c.msgtype) for c, _, raw in r.messages()]


def draw(ax, msg, fx, cx, cy):
    """A marker's triangles projected into the camera, flat-shaded, far ones first."""
    from matplotlib import colormaps
    from matplotlib.collections import PolyCollection

    tri = np.array([[p.x, p.y, p.z] for p in msg.points]).reshape(-1, 3, 3)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    light = np.array([-0.35, -0.35, 1.0]) / np.linalg.norm([-0.35, -0.35, 1.0])
    tone = 0.15 + 0.85 * np.abs(n @ light)
    uv = np.stack([tri[..., 0] / tri[..., 2] * fx + cx, tri[..., 1] / tri[..., 2] * fx + cy], -1)
    z = tri[..., 2].mean(axis=1)
    order = np.argsort(-z)
    # colour by depth (0.3 .. 3.2 m, the valid range), shaded lightly: the scene reads at a glance
    rgb = colormaps["viridis"]((z - 0.3) / 2.9)[:, :3] * (0.55 + 0.45 * tone)[:, None]
    ax.add_collection(PolyCollection(uv[order], facecolors=rgb[order],
                                     edgecolors=(1, 1, 1, 0.25), linewidths=0.1))
    ax.set_xlim(0, 640)
    ax.set_ylim(480, 0)
    ax.set_aspect("equal")
    ax.set_facecolor("black")
    ax.set_xticks([])
    ax.set_yticks([])
    stamp = f"{msg.header.stamp.sec}.{msg.header.stamp.nanosec:09d}"
    ax.set_title(f"stamp {stamp} s, frame '{msg.header.frame_id}': "
                 f"{len(msg.points) // 3} triangles", fontsize=10)


def picture(out: Path) -> None:
    """Mesh the bag into a temporary MCAP file and draw its markers into `out`."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    with tempfile.TemporaryDirectory() as tmp:
        mcap = Path(tmp) / "meshes.mcap"
        # 1 % of the 286 000 valid pixels of a frame
        code = rangemesh(["batch", str(BAG), "-o", str(mcap), "--vertices", "2860",
                          "--workers", "1", "--quiet"])
        if code != 0:
            raise SystemExit(code)
        msgs = markers(mcap)
    # the depth camera's K (the bag's CameraInfo): fx = fy
    fx, cx, cy = 390.43145751953125, 331.38787841796875, 242.18734741210938
    fig = Figure(figsize=(12, 4.9), dpi=80, layout="constrained")
    axes = fig.subplots(1, len(msgs))
    for ax, msg in zip(axes, msgs, strict=True):
        draw(ax, msg, fx, cx, cy)
    fig.suptitle("rangemesh batch librealsense_d435_single_depth_color_640x480.bag -o meshes.mcap "
                 "--vertices 2860: the TRIANGLE_LIST markers read back from the MCAP file",
                 fontsize=11)
    fig.savefig(out, format="png")


if __name__ == "__main__":
    picture(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "recording-meshes.png")
