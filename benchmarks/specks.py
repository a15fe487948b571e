"""How many specks do real depth frames have, and what do they cost a mesh? (min_region's default)

For each depth-camera frame of the shared data (Kinect v1 TUM/NYU, SUN, slambook, PCL's OpenNI
and stereo frames, the RealSense D435 bag), with its sensor's missing-depth marker and a pinhole
camera: the regions of valid pixels (split where depth jumps by more than 5 % a pixel,
`rangemesh.regions`) smaller than K pixels, the valid pixels they hold, and in the default mesh
(`triangulate(depth, camera=...)`) the triangles that touch one of their pixels and the share of
the mesh's 3-D area those triangles cover. Then the same figures for the issue's reproducer (a
lone valid pixel at (0, 0) in a 100-pixel invalid border of the TUM frame).

    python benchmarks/specks.py [--data ../shared/data]
"""

import argparse
from pathlib import Path

import numpy as np

import rangemesh
from rangemesh.prepare import to_depth_and_mask
from rangemesh.regions import label_regions

KS = (2, 5, 10, 20, 50, 100, 200)

# (file, background marker, depth scale to metres, fx, cx, cy): the README's figures
FRAMES = [
    ("rgbd/open3d_TUM_depth.png", 0, 1 / 5000, 525.0, 319.5, 239.5),
    ("rgbd/slambook2_ch7_1_depth.png", 0, 1 / 5000, 520.9, 325.1, 249.7),
    ("rgbd/open3d_NYU_depth.raw.npy", 2047, None, 518.9, 325.6, 253.7),  # raw: metres below
    ("rgbd/open3d_SUN_depth.mm.npy", 0, 0.001, 525.0, 319.5, 239.5),
    ("rgbd/slambook2_ch5_depth_1.npy", 0, 0.001, 518.0, 325.5, 253.5),
    ("rgbd/pcl_grabber_frame_20121214T142255.814212_depth.tiff", 0, 0.001, 525.0, 320.0, 240.0),
    ("rgbd/pcl_milk_cartoon_all_small_clorox.z.npy", None, 1.0, 525.0, 319.5, 239.5),
    ("rgbd/pcl_table_scene_mug_stereo_textured.z.npy", None, 1.0, 525.0, 319.5, 239.5),
]


def load(path: Path):
    if path.suffix == ".npy":
        return np.load(path)
    return rangemesh.read_range_image(path)


def realsense(data: Path):
    from rosbags.highlevel import AnyReader

    bag = data / "rosbag/librealsense_d435_single_depth_color_640x480.bag"
    with AnyReader([bag]) as reader:
        conn = [c for c in reader.connections if c.topic.endswith("Depth_0/image/data")]
        for c, _, raw in reader.messages(connections=conn):
            msg = reader.deserialize(raw, c.msgtype)
            return np.frombuffer(msg.data, "<u2").reshape(480, 640).copy()


def areas(mesh):
    p = mesh.vertices[mesh.faces]
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)


def figures(name, img, background, cam):
    depth, valid = to_depth_and_mask(img, background, camera=cam)
    labels, sizes = label_regions(depth, valid)
    mesh = rangemesh.triangulate(img, camera=cam, background=background)
    a = areas(mesh)
    vlab = labels[mesh.pixels[:, 0], mesh.pixels[:, 1]]
    n_valid = int(valid.sum())
    print(f"\n{name}: {n_valid} valid pixels, {len(sizes)} regions; default mesh "
          f"{mesh.stats.vertices} vertices, {len(mesh.faces)} triangles")
    print("   K  regions<K  pixels<K (% valid)  triangles touching  area share %")
    rows = {}
    for k in KS:
        small = sizes < k
        px = int(sizes[small].sum())
        # a vertex on a speck pixel (fill_gaps may fill a hole beside it: label -1, not a speck)
        on = np.zeros(len(mesh.vertices), bool)
        ok = vlab >= 0
        on[ok] = small[vlab[ok]]
        tri = on[mesh.faces].any(axis=1)
        share = 100.0 * a[tri].sum() / a.sum()
        rows[k] = (int(small.sum()), px, int(tri.sum()), share)
        print(f"{k:4d}  {small.sum():9d}  {px:8d} ({100.0 * px / n_valid:6.3f})  {tri.sum():18d}  "
              f"{share:12.3f}")
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default="../shared/data")
    data = Path(ap.parse_args().data)
    for rel, bg, scale, f, cx, cy in FRAMES:
        img = load(data / rel)
        if scale is None:  # NYU raw Kinect disparity: Open3D's conversion to metres
            valid = img != bg
            img = np.where(valid, 351.3 / (1092.5 - img.astype(np.float64)), 0.0)
            bg, scale = 0, 1.0
        cam = rangemesh.Pinhole(f, f, cx, cy, depth_scale=scale)
        figures(rel, img, "auto" if bg == 0 else bg, cam)
    try:
        img = realsense(data)
        cam = rangemesh.Pinhole(390.43, 390.43, 331.39, 242.19, depth_scale=0.001)
        figures("rosbag D435 frame 169", img, "auto", cam)
    except ImportError:
        print("\n(rosbags not installed: the RealSense frame is left out)")
    img = load(data / FRAMES[0][0]).copy()
    img[:100], img[-100:], img[:, :100], img[:, -100:] = 0, 0, 0, 0
    img[0, 0] = img[240, 320]
    figures("issue 41 reproducer (TUM, 100-pixel border, lone pixel at (0, 0))", img, "auto",
            rangemesh.Pinhole(525.0, 525.0, 319.5, 239.5, depth_scale=1 / 5000))


if __name__ == "__main__":
    main()
