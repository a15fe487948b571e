"""depth_limits and min_region (rangemesh.cleanup): the same pixels missing at every entry point."""

import json
import warnings

import numpy as np
import pytest

import rangemesh
import rangemesh.cleanup
from rangemesh import triangulate
from rangemesh.cleanup import ZeroMarkerWarning, apply_depth_limits, zeros_like_a_marker
from rangemesh.cli import main

from .images import load


def same_mesh(a, b):
    assert np.array_equal(a.pixels, b.pixels)
    assert np.array_equal(a.faces, b.faces)
    assert np.array_equal(a.vertices, b.vertices)


MM = np.array([[400.0, 500.0, 1000.0, 4000.0, 4001.0]])


@pytest.mark.parametrize("camera, limits", [
    (rangemesh.Pinhole(1, 1, 0, 0, depth_scale=0.001), (0.5, 4.0)),  # metres: mm x 0.001
    (rangemesh.Orthographic(1, 1, 0.001), (500.0, 4000.0)),  # stored units, not kz
    (rangemesh.Spherical([0.0], [0, 1, 2, 3, 4], range_scale=0.001), (0.5, 4.0)),
])
def test_depth_limits_keep_depths_from_near_to_far_in_the_camera_s_units(camera, limits):
    d, v = MM.copy(), np.ones(MM.shape, bool)
    assert apply_depth_limits(d, v, limits, camera) == 2
    assert v.tolist() == [[False, True, True, True, False]]  # 500 and 4000 kept: inclusive
    assert d.tolist() == [[0.0, 500.0, 1000.0, 4000.0, 0.0]]


@pytest.mark.parametrize("limits, kept", [((None, 1.0), [True, True, True, False, False]),
                                          ((1.0, None), [False, False, True, True, True])])
def test_a_side_of_none_has_no_limit(limits, kept):
    p = rangemesh.MeshParams(depth_limits=limits)
    d, v = MM.copy(), np.ones(MM.shape, bool)
    apply_depth_limits(d, v, p.depth_limits, rangemesh.Pinhole(1, 1, 0, 0, depth_scale=0.001))
    assert v[0].tolist() == kept


@pytest.mark.parametrize("value, error", [((2.0, 1.0), ValueError), ((1.0, 1.0), ValueError),
                                          ((float("nan"), 1.0), ValueError), (3.0, TypeError),
                                          ("1,2", TypeError), ((1.0, 2.0, 3.0), TypeError),
                                          (("a", 2.0), TypeError)])
def test_bad_depth_limits_are_refused_naming_them(value, error):
    with pytest.raises(error, match="depth_limits"):
        triangulate(np.ones((4, 4)), depth_limits=value)


@pytest.mark.parametrize("value, error", [(0, ValueError), (2.5, ValueError), ("3", TypeError)])
def test_bad_min_region_is_refused_naming_it(value, error):
    with pytest.raises(error, match="min_region"):
        triangulate(np.ones((4, 4)), min_region=value)


def test_both_methods_mesh_no_pixel_outside_the_limits(shared_data):
    img = load(shared_data, "rgbd/pcl_grabber_frame_20121214T142255.814212_depth.tiff")
    cam = rangemesh.Pinhole(525.0, 525.0, 320.0, 240.0, depth_scale=0.001)
    for method in ("refine", "paper"):
        m = triangulate(img, camera=cam, method=method, depth_limits=(0.8, 1.2))
        z = img[m.pixels[:, 0], m.pixels[:, 1]] * 0.001
        assert z.min() >= 0.8 and z.max() <= 1.2, method
        np.testing.assert_allclose(m.vertices[:, 2], z, rtol=0.05) if method == "paper" else None
        # without the limits the mesh reaches the wall behind the boxes (up to 1.713 m)
        full = triangulate(img, camera=cam, method=method)
        assert (img[full.pixels[:, 0], full.pixels[:, 1]] * 0.001).max() > 1.2, method


def test_evaluate_leaves_out_the_pixels_the_options_drop(shared_data):
    img = load(shared_data, "rgbd/open3d_TUM_depth.png")
    cam = rangemesh.Pinhole(525.0, 525.0, 319.5, 239.5, depth_scale=0.0002)
    opts = dict(depth_limits=(1.0, 3.0), min_region=20)
    m = triangulate(img, camera=cam, **opts)
    ev = rangemesh.evaluate(m, img, **opts)
    z = img * 0.0002
    inside = (z >= 1.0) & (z <= 3.0)
    speck_pixels = int(inside.sum()) - ev.valid_pixels  # min_region's: a few, never negative
    assert 0 <= speck_pixels < 0.01 * inside.sum()
    # with the options left out, the pixels beyond the limits count (the mesh spans some)
    assert rangemesh.evaluate(m, img).valid_pixels == int((img > 0).sum())


def test_api_cli_stream_batch_eval_and_info_drop_the_same_pixels(shared_data, tmp_path, capsys):
    src = shared_data / "rgbd/open3d_TUM_depth.png"
    img = load(shared_data, "rgbd/open3d_TUM_depth.png")
    cam = rangemesh.Pinhole(525.0, 525.0, 319.5, 239.5, depth_scale=0.0002)
    opts = dict(depth_limits=(1.0, 3.0), min_region=20, vertices=800)
    one = triangulate(img, camera=cam, **opts)
    (streamed,) = list(rangemesh.mesh_stream([img], camera=cam, **opts))
    same_mesh(one, streamed)
    res = rangemesh.mesh_many([src], tmp_path / "many", camera=cam, **opts)
    assert res[0].status == "meshed", res[0].error
    flags = ["--intrinsics", "525,525,319.5,239.5", "--depth-scale", "0.0002",
             "--depth-limits", "1,3", "--min-region", "20"]
    assert main(["mesh", str(src), "-o", str(tmp_path / "cli.ply"), "--vertices", "800",
                 "--quiet", *flags]) == 0
    for path in (tmp_path / "many" / "open3d_TUM_depth.ply", tmp_path / "cli.ply"):
        m = rangemesh.read_mesh(path)
        assert np.array_equal(m.faces, one.faces)
        np.testing.assert_allclose(m.vertices, one.vertices, rtol=1e-6)  # PLY keeps float32
    ev = rangemesh.evaluate(one, img, depth_limits=(1.0, 3.0), min_region=20)
    assert res[0].relative_error == pytest.approx(ev.relative_error, rel=1e-9)
    assert main(["eval", str(src), str(tmp_path / "cli.ply"), "--json", *flags]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["valid_pixels"] == ev.valid_pixels
    assert doc["relative_error"] == pytest.approx(ev.relative_error, rel=1e-4)
    assert main(["info", str(src), "--json", *flags]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["valid_pixels"] == ev.valid_pixels
    z = img * 0.0002
    outside = (img > 0) & ((z < 1.0) | (z > 3.0))
    assert doc["dropped_by_depth_limits"] == int(outside.sum())


def test_a_recording_drops_the_pixels_triangulate_drops(shared_data):
    rosbags = pytest.importorskip("rosbags.highlevel")
    bag = shared_data / "rosbag/librealsense_d435_single_depth_color_640x480.bag"
    with rosbags.AnyReader([bag]) as reader:
        conn = [c for c in reader.connections if c.topic == "/device_0/sensor_0/Depth_0/image/data"]
        frames = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(connections=conn)]
    depth = np.frombuffer(frames[0].data, "<u2").reshape(480, 640)
    cam = rangemesh.Pinhole(390.43145751953125, 390.43145751953125, 331.38787841796875,
                            242.18734741210938, depth_scale=0.001)  # the bag's K (README)
    opts = dict(depth_limits=(0.5, 2.0), min_region=20, vertices=500)
    got = [m for _, _, m in rangemesh.mesh_bag(bag, **opts)][0]
    want = triangulate(depth, camera=cam, **opts)
    assert np.array_equal(got.faces, want.faces) and np.array_equal(got.pixels, want.pixels)
    z = depth[got.pixels[:, 0], got.pixels[:, 1]] * 0.001
    assert z.min() >= 0.5 and z.max() <= 2.0


# ------------------------------------------------------------ exact zeros with Orthographic


def test_zeros_cut_off_from_the_data_look_like_a_marker_by_hand():
    # zeros beside 5.0-5.2: steps of 5 at the border, 0.1 inside (90th percentile) -> 3 zeros
    d = np.array([[0.0, 0.0, 5.0, 5.1], [0.0, 5.0, 5.1, 5.2]])
    assert zeros_like_a_marker(d, np.ones(d.shape, bool)) == 3
    # a ramp through 0: steps of 0.1 off the zeros as everywhere: data
    ramp = np.array([[0.0, 0.1, 0.2, 0.3], [0.0, 0.1, 0.2, 0.3]])
    assert zeros_like_a_marker(ramp, np.ones(ramp.shape, bool)) == 0
    # data on both sides of 0 (heights): 0 is a height like any other
    signed = np.array([[0.0, 0.0, 5.0, -5.0]])
    assert zeros_like_a_marker(signed, np.ones(signed.shape, bool)) == 0
    # no zero touches the data: the gap from 0 to the smallest value decides
    apart = np.array([[0.0, np.nan, 5.0, 5.1]])
    assert zeros_like_a_marker(np.nan_to_num(apart), ~np.isnan(apart)) == 1


@pytest.mark.parametrize("rel, scale, zeros", [
    ("lidar/rellis3d_os1-64_000000.range.npy", 1.0, 52414),  # README: 40.0 % no return
    ("middlebury/cones_disp2.png", 0.25, 5429),  # 0 = unknown, 3.2 % (README)
    ("rgbd/open3d_SUN_depth.mm.npy", 0.001, 56012),  # 18.2 %
])
def test_real_no_return_markers_look_like_one_and_a_terrain_does_not(shared_data, rel, scale,
                                                                      zeros):
    img = load(shared_data, rel).astype(np.float64) * scale  # float: 0 is data under 'auto'
    d, v = rangemesh.to_depth_and_mask(img)
    assert zeros_like_a_marker(d, v) == zeros == int((img == 0).sum())
    rr, cc = np.mgrid[0:50, 0:60]
    terrain = np.maximum(0.0, 3.0 * np.sin(cc / 9.0) + 0.01 * rr)  # a lake at level 0
    assert (terrain == 0).sum() > 1000
    assert zeros_like_a_marker(terrain, np.ones(terrain.shape, bool)) == 0


def test_the_api_warns_once_naming_the_count(shared_data):
    img = load(shared_data, "lidar/rellis3d_os1-64_000000.range.npy")
    with pytest.warns(ZeroMarkerWarning, match=r"^52414 valid pixels are exactly 0 and look like "
                                               r"a no-return marker"):
        triangulate(img, vertices=100)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        triangulate(img, vertices=100)  # said once
        triangulate(img, vertices=100, background=0)  # no zero is data here
    rangemesh.cleanup._warned.clear()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        cam = rangemesh.Spherical.from_beams(shared_data / "lidar/rellis3d_os1-64_000000.beams.json")
        triangulate(img, vertices=100, camera=cam)  # a ray camera: 0 is no return, no warning


def test_info_says_whether_the_zeros_look_like_a_marker(shared_data, tmp_path, capsys):
    assert main(["info", str(shared_data / "lidar/rellis3d_os1-64_000000.range.npy"),
                 "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["zero_pixels_valid"] == 52414 and doc["zeros_look_like_no_return"] is True
    rr, cc = np.mgrid[0:50, 0:60]
    np.save(tmp_path / "terrain.npy", np.maximum(0.0, 3.0 * np.sin(cc / 9.0) + 0.01 * rr))
    assert main(["info", str(tmp_path / "terrain.npy")]) == 0
    assert "data by the look of them" in capsys.readouterr().out
