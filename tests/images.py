"""The real images of ../shared/data: how to read each and what marks missing depth."""

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
