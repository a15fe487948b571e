"""The real images of ../shared/data: how to read each and what marks missing depth.

And what tests use without that folder: the committed crops of the real images, and synthetic
stand-ins (an RGB-D frame, a spinning-LiDAR scan) for tests that need some real-looking input.
"""

import json
from pathlib import Path

import numpy as np

# (relative path, background marker); the marker comes from shared/data/README.md.
REAL_IMAGES = [
    ("odetics/chair-range.npy", 0),
    ("middlebury/venus_disp2.npy", None),
    ("middlebury/cones_disp2.png", 0),
    ("middlebury/teddy_disp2.png", 0),
    ("middlebury/tsukuba_disp3.npy", 0),
    ("middlebury/aloeGT.png", 0),
    ("rgbd/open3d_TUM_depth.png", 0),
    ("rgbd/slambook2_ch7_1_depth.png", 0),
    ("rgbd/open3d_NYU_depth.raw.npy", 2047),
    ("rgbd/open3d_SUN_depth.mm.npy", 0),
    ("rgbd/slambook2_ch5_depth_1.npy", 0),
    ("rgbd/pcl_grabber_frame_20121214T142255.814212_depth.tiff", 0),
    ("rgbd/pcl_milk_cartoon_all_small_clorox.z.npy", None),
    ("rgbd/pcl_table_scene_mug_stereo_textured.z.npy", None),
]


def load(root, rel):
    path = root / rel
    if path.suffix == ".npy":
        return np.load(path)
    if path.suffix in (".tif", ".tiff"):
        import tifffile

        return tifffile.imread(path)
    import imageio.v3 as iio

    return iio.imread(path)


# ---------------------------------------------------------------- stand-ins made in the test
# For tests that need some real-looking input but no particular file: they run without the
# data folder. Each is deterministic (seeded) and built from rangemesh.scenes where one fits.

HERE = Path(__file__).resolve().parent


def crop_of(rel):
    """The committed crop of the real image `rel`, or None when there is none."""
    meta = json.loads((HERE / "data" / "crops.json").read_text())
    for name, m in meta.items():
        if m["source"] == rel:
            with np.load(HERE / "data" / "crops.npz") as z:
                return z[name]
    return None


def load_or_crop(root, rel):
    """The real image `rel` from the data folder `root`, or its committed crop when `root` is None.

    Without the folder and without a crop of that image the test skips, as ``shared_data`` does.
    """
    import pytest

    if root is not None:
        return load(root, rel)
    crop = crop_of(rel)
    if crop is None:
        pytest.skip(f"../shared/data not found (set RANGEMESH_DATA) and no committed crop of {rel}")
    return crop


def rgbd_frame(shape=(480, 640), seed=0):
    """A Kinect-like RGB-D pair: depth in TUM units (1/5000 m, 0 = no depth) and 8-bit colour.

    A box on a tilted floor (`rangemesh.scenes.box`) 1.0 .. 3.2 m away with 3 mm of noise, an
    invalid margin on the left (as Kinect frames have), a round hole and 2 % speckle holes. The
    colour is a gradient with a checker on the box, so that each pixel's colour is its own.
    """
    from rangemesh import scenes

    sc = scenes.box(shape, noise=0.3, seed=seed)
    depth = np.round(sc.depth * 50.0).astype(np.uint16)  # scene units are cm: 1 cm = 50 units
    h, w = shape
    r, c = np.mgrid[0:h, 0:w]
    hole = (r - 0.8 * h) ** 2 + (c - 0.2 * w) ** 2 < (0.06 * min(h, w)) ** 2
    speckle = np.random.default_rng(seed + 1).random(shape) < 0.02
    depth[hole | speckle | (c < w // 40)] = 0
    color = np.stack([(c * 255 // max(w - 1, 1)), (r * 255 // max(h - 1, 1)),
                      np.where(sc.labels == 1, 60 + 120 * ((r // 8 + c // 8) % 2), 200)],
                     axis=-1).astype(np.uint8)
    return depth, color


def lidar_scan(folder, name="scan", rows=64, cols=2048, seed=0):
    """A spinning-LiDAR scan written as the shared data's OS1-64 scan is laid out (README section 5).

    Writes ``name.bin`` (KITTI float32 x y z intensity, staggered, index = step * rows + beam, no
    return = (0, 0, 0)), ``name.range.npy`` and ``name.intensity.npy`` (destaggered, 0 = no
    return) and ``name.beams.json``. The scene: the sensor 1.8 m above flat ground, a building
    front 25 m ahead, six posts and trunks; no return from the sky beyond 120 m and from a fifth
    of the rays that meet the ground beyond 40 m, at random.
    Returns {"bin", "range", "intensity", "beams"}: the paths.
    """
    folder = Path(folder)
    rng = np.random.default_rng(seed)
    el = np.linspace(17.0, -16.4, rows) + rng.uniform(-0.05, 0.05, rows)
    residual = rng.uniform(-0.08, 0.08, rows)
    shift = np.tile([17, 5, -7, -20], rows // 4 + 1)[:rows]
    step = -360.0 / cols
    beams = {"rows": rows, "cols": cols, "elevation_deg": el.round(3).tolist(),
             "azimuth0_deg": 0.01508, "azimuth_row_residual_deg": residual.round(6).tolist(),
             "azimuth_step_deg": step, "column_shift": shift.tolist()}
    e = np.radians(np.asarray(beams["elevation_deg"]))[:, None]
    a = np.radians(beams["azimuth0_deg"] + np.asarray(beams["azimuth_row_residual_deg"])[:, None]
                   + np.arange(cols)[None, :] * step)
    ray = np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e) + 0 * a], axis=-1)
    dist = np.full((rows, cols), np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        ground = np.where(ray[..., 2] < 0, -1.8 / ray[..., 2], np.inf)
        dist = np.minimum(dist, ground)
        front = 25.0 / ray[..., 0]  # the plane x = 25 between y = -20 and 15, up to 6 m high
        p = front[..., None] * ray
        ok = (ray[..., 0] > 0) & (np.abs(p[..., 1] + 2.5) < 17.5) & (p[..., 2] < 6.0)
        dist = np.where(ok, np.minimum(dist, front), dist)
        for cx, cy, rad, top in [(6, 3, 0.3, 1.0), (-8, -5, 0.5, 4.0), (10, -9, 0.4, 3.0),
                                 (-4, 12, 0.8, 6.0), (15, 14, 0.3, 1.2), (-18, 2, 1.0, 8.0)]:
            # a vertical cylinder: |t * (x, y) - (cx, cy)| = rad in the horizontal plane
            dx, dy = ray[..., 0], ray[..., 1]
            qa = dx * dx + dy * dy
            qb = -2 * (dx * cx + dy * cy)
            qc = cx * cx + cy * cy - rad * rad
            t = (-qb - np.sqrt(qb * qb - 4 * qa * qc)) / (2 * qa)
            ok = (t > 0) & (t * ray[..., 2] < top - 1.8)
            dist = np.where(ok, np.minimum(dist, t), dist)
    dist = dist + rng.normal(0.0, 0.01, dist.shape)
    # grazing returns from far ground are weak: 20 % of those beyond 40 m are lost
    hit = np.isfinite(dist) & (dist < 120.0) & ((dist < 40.0) | (rng.random(dist.shape) > 0.2))
    pts = np.where(hit[..., None], dist[..., None] * ray, 0.0).astype("<f4")
    inten = np.where(hit, rng.uniform(1.0, 200.0, hit.shape), 0.0).astype("<f4")
    # stagger: destaggered column c of beam b is the sensor's step (c - shift[b]) mod cols
    raw = np.zeros((cols, rows, 4), "<f4")
    for b in range(rows):
        steps = (np.arange(cols) - shift[b]) % cols
        raw[steps, b, :3] = pts[b]
        raw[steps, b, 3] = inten[b]
    out = {k: folder / f"{name}{s}" for k, s in
           (("bin", ".bin"), ("range", ".range.npy"), ("intensity", ".intensity.npy"),
            ("beams", ".beams.json"))}
    raw.tofile(out["bin"])
    # the range image from the stored float32 points: sqrt(x^2 + y^2 + z^2), README section 5
    np.save(out["range"], np.sqrt((pts.astype(np.float64) ** 2).sum(axis=-1)).astype(np.float32))
    np.save(out["intensity"], inten)
    out["beams"].write_text(json.dumps(beams))
    return out
