"""The cameras (rangemesh.camera) and calibration files (issue 41): `read_camera`, ``--camera FILE``."""

import math

import numpy as np
import pytest

import rangemesh
from rangemesh import Pinhole, Rays, Spherical, read_camera, read_mesh, triangulate
from rangemesh.cli import main

K = (52.09, 52.1, 32.51, 24.97)  # fx, fy, cx, cy: slambook2's Kinect at a tenth of its size
PLUMB = [0.2624, -0.9531, -0.0054, 0.0026, 1.1633]  # TUM fr1's depth camera, k1 k2 p1 p2 k3
RATIONAL = [0.1, -0.05, 0.001, -0.002, 0.01, 0.02, -0.01, 0.005]
FISHEYE = [-0.013, 0.02, -0.006, 0.001]
SHAPE = (48, 64)  # small images: the rays of every pixel are checked


def ros_yaml(path, d, model="plumb_bob", shape=SHAPE, k=K, drop=None):
    fx, fy, cx, cy = k
    lines = {
        "image_width": f"image_width: {shape[1]}",
        "image_height": f"image_height: {shape[0]}",
        "camera_name": "camera_name: depth_camera",
        "camera_matrix": "camera_matrix:\n  rows: 3\n  cols: 3\n"
                         f"  data: [{fx}, 0, {cx}, 0, {fy}, {cy}, 0, 0, 1]",
        "distortion_model": f"distortion_model: {model}",
        "distortion_coefficients": f"distortion_coefficients:\n  rows: 1\n  cols: {len(d)}\n"
                                   f"  data: [{', '.join(map(str, d))}]",
        "rectification_matrix": "rectification_matrix:\n  rows: 3\n  cols: 3\n"
                                "  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]",
        "projection_matrix": "projection_matrix:\n  rows: 3\n  cols: 4\n"
                             f"  data: [{fx}, 0, {cx}, 0, 0, {fy}, {cy}, 0, 0, 0, 1, 0]",
    }
    path.write_text("\n".join(v for key, v in lines.items() if key != drop) + "\n")
    return path


def opencv_yaml(path, d, shape=SHAPE):
    fx, fy, cx, cy = K
    # as cv::FileStorage writes it: a data list that wraps onto a second line
    path.write_text(
        "%YAML:1.0\n---\n"
        f"image_width: {shape[1]}\nimage_height: {shape[0]}\n"
        "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
        f"   data: [ {fx}, 0., {cx}, 0., {fy},\n       {cy}, 0., 0., 1. ]\n"
        f"distortion_coefficients: !!opencv-matrix\n   rows: {len(d)}\n   cols: 1\n   dt: d\n"
        f"   data: [ {', '.join(map(str, d))} ]\n"
        "avg_reprojection_error: 2.1e-01\n")
    return path


def opencv_xml(path, d, shape=SHAPE):
    fx, fy, cx, cy = K
    path.write_text(
        '<?xml version="1.0"?>\n<opencv_storage>\n'
        f"<image_width>{shape[1]}</image_width>\n<image_height>{shape[0]}</image_height>\n"
        '<K type_id="opencv-matrix">\n  <rows>3</rows>\n  <cols>3</cols>\n  <dt>d</dt>\n'
        f"  <data>\n    {fx} 0. {cx} 0. {fy} {cy}\n    0. 0. 1.</data></K>\n"
        f'<D type_id="opencv-matrix">\n  <rows>1</rows>\n  <cols>{len(d)}</cols>\n  <dt>d</dt>\n'
        f"  <data>\n    {' '.join(map(str, d))}</data></D>\n"
        "</opencv_storage>\n")
    return path


def brown_forward(x, y, d):
    """OpenCV's documented plumb_bob / rational model, written out independently."""
    k1, k2, p1, p2, k3, k4, k5, k6 = list(d) + [0.0] * (8 - len(d))
    r2 = x * x + y * y
    radial = (1 + k1 * r2 + k2 * r2 ** 2 + k3 * r2 ** 3) / (1 + k4 * r2 + k5 * r2 ** 2 + k6 * r2 ** 3)
    return (x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x),
            y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y)


def fisheye_forward(x, y, d):
    """OpenCV's fisheye (ROS equidistant) model: theta_d = theta (1 + k1 t^2 + ... + k4 t^8)."""
    r = np.hypot(x, y)
    t = np.arctan(r)
    td = t * (1 + d[0] * t ** 2 + d[1] * t ** 4 + d[2] * t ** 6 + d[3] * t ** 8)
    s = np.where(r > 0, td / np.where(r > 0, r, 1), 1.0)
    return x * s, y * s


def pixels_of(cam, forward, d):
    """Where the forward model sends each pixel's ray back onto the image."""
    fx, fy, cx, cy = K
    ray = cam.directions
    xd, yd = forward(ray[..., 0] / ray[..., 2], ray[..., 1] / ray[..., 2], d)
    return yd * fy + cy, xd * fx + cx


@pytest.mark.parametrize("write", [ros_yaml, opencv_yaml, opencv_xml])
def test_a_calibration_file_without_distortion_gives_its_pinhole(tmp_path, write):
    cam = read_camera(write(tmp_path / "cam.txt", [0.0] * 5), depth_scale=0.001)
    assert cam == Pinhole(52.09, 52.1, 32.51, 24.97, depth_scale=0.001)


def test_a_camera_info_yaml_in_flow_style_reads_as_in_block_style(tmp_path):
    # YAML's flow style ({rows: 3, ...}), as yaml.dump and hand-written files give it, is the same
    # mapping: the same camera as the block style of `ros_yaml`; expected values are K, PLUMB
    path = tmp_path / "flow.yaml"
    fx, fy, cx, cy = K
    path.write_text(
        f"{{image_width: {SHAPE[1]}, image_height: {SHAPE[0]}, distortion_model: plumb_bob,\n"
        f" camera_matrix: {{rows: 3, cols: 3, data: [{fx}, 0, {cx}, 0, {fy}, {cy}, 0, 0, 1]}},\n"
        f" distortion_coefficients: {{rows: 1, cols: 5, data: {PLUMB}}}}}\n")
    flow = read_camera(path, depth_scale=0.001)
    block = read_camera(ros_yaml(tmp_path / "block.yaml", PLUMB), depth_scale=0.001)
    assert isinstance(flow, Rays) and flow == block
    assert read_camera(ros_yaml(tmp_path / "k.yaml", [0.0] * 5)) == Pinhole(fx, fy, cx, cy)


def test_an_open3d_intrinsics_json_is_read_column_major(tmp_path):
    path = tmp_path / "intrinsic.json"
    # PinholeCameraIntrinsic(640, 480, fx=525, fy=526, cx=319.5, cy=239.5) as Open3D writes it
    path.write_text('{"width": 640, "height": 480, "intrinsic_matrix": '
                    '[525.0, 0.0, 0.0, 0.0, 526.0, 0.0, 319.5, 239.5, 1.0]}')
    assert read_camera(path) == Pinhole(525.0, 526.0, 319.5, 239.5)


@pytest.mark.parametrize("write,model,d,forward", [
    (ros_yaml, "plumb_bob", PLUMB, brown_forward),
    (ros_yaml, "rational_polynomial", RATIONAL, brown_forward),
    (ros_yaml, "equidistant", FISHEYE, fisheye_forward),
    (opencv_yaml, None, PLUMB, brown_forward),
    (opencv_xml, None, [0.1, -0.2, 0.001, -0.002], brown_forward),  # TUM's without k3 folds
])
def test_distorted_rays_go_back_to_their_pixel_through_the_forward_model(tmp_path, write, model,
                                                                         d, forward):
    path = write(tmp_path / "cam.txt", d, model) if model else write(tmp_path / "cam.txt", d)
    cam = read_camera(path, depth_scale=0.001)
    assert isinstance(cam, Rays) and cam.z_depth and cam.shape == SHAPE
    r, c = pixels_of(cam, forward, d)
    rows, cols = np.mgrid[0:SHAPE[0], 0:SHAPE[1]]
    assert np.abs(r - rows).max() < 1e-9 and np.abs(c - cols).max() < 1e-9
    # a depth Z lifts to a point at z = Z (metres), on the pixel's ray
    p = rangemesh.backproject([5], [7], [2000.0], cam)[0]
    assert p[2] == pytest.approx(2.0, rel=1e-12)
    np.testing.assert_allclose(p / np.linalg.norm(p), cam.directions[5, 7], atol=1e-12)


def test_a_zero_distortion_file_gives_exactly_the_pinhole_mesh(tmp_path, shared_data):
    img = rangemesh.read_range_image(shared_data / "rgbd" / "open3d_TUM_depth.png")
    path = ros_yaml(tmp_path / "cam.yaml", [0.0] * 5, shape=img.shape,
                    k=(525.0, 525.0, 319.5, 239.5))
    one = triangulate(img, camera=read_camera(path, depth_scale=0.0002), vertices=3000)
    two = triangulate(img, camera=Pinhole(525.0, 525.0, 319.5, 239.5, 0.0002), vertices=3000)
    assert np.array_equal(one.faces, two.faces) and np.array_equal(one.vertices, two.vertices)


def test_the_command_line_camera_meshes_as_the_api_does(tmp_path, capsys, shared_data):
    img = rangemesh.read_range_image(shared_data / "rgbd" / "open3d_TUM_depth.png")
    path = ros_yaml(tmp_path / "cam.yaml", PLUMB, shape=img.shape, k=(525.0, 525.0, 319.5, 239.5))
    api = triangulate(img, camera=read_camera(path, depth_scale=0.0002), vertices=2000)
    out = tmp_path / "m.ply"
    assert main(["mesh", str(shared_data / "rgbd" / "open3d_TUM_depth.png"), "--camera", str(path),
                 "--depth-scale", "0.0002", "--vertices", "2000", "-o", str(out), "--quiet"]) == 0
    m = read_mesh(out, camera=read_camera(path, depth_scale=0.0002))
    assert np.array_equal(m.faces, api.faces)
    np.testing.assert_allclose(m.vertices, api.vertices, rtol=1e-6)  # PLY keeps float32
    assert main(["eval", str(shared_data / "rgbd" / "open3d_TUM_depth.png"), str(out), "--camera",
                 str(path), "--depth-scale", "0.0002", "--json"]) == 0
    assert '"relative_error"' in capsys.readouterr().out


@pytest.mark.parametrize("option", [["--intrinsics", "525,525,319.5,239.5"], ["--camera", None]])
def test_a_metric_camera_on_an_integer_image_needs_a_depth_scale(tmp_path, capsys, option,
                                                                shared_data):
    if option[1] is None:
        option = ["--camera", str(ros_yaml(tmp_path / "c.yaml", [0.0] * 5, shape=(480, 640)))]
    src = str(shared_data / "rgbd" / "open3d_TUM_depth.png")
    assert main(["mesh", src, *option, "-o", str(tmp_path / "m.ply"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "--depth-scale" in err and "0.001 for millimetres" in err and len(err.splitlines()) == 1
    assert main(["batch", src, *option, "-o", str(tmp_path / "out"), "--quiet"]) == 2
    assert "--depth-scale" in capsys.readouterr().err


def test_the_calibration_must_be_for_the_images_size(tmp_path):
    path = ros_yaml(tmp_path / "cam.yaml", PLUMB)
    with pytest.raises(ValueError, match=r"cam.yaml: the calibration is for a 64x48 image"):
        read_camera(path, image_shape=(480, 640))


@pytest.mark.parametrize("make,field", [
    (lambda p: ros_yaml(p, PLUMB, drop="camera_matrix"), "camera_matrix"),
    (lambda p: ros_yaml(p, PLUMB, drop="image_width"), "image_width"),
    (lambda p: ros_yaml(p, PLUMB, model="kannala_brandt_8"), "distortion_model"),
    (lambda p: ros_yaml(p, PLUMB[:3]), "distortion_coefficients"),
    (lambda p: ros_yaml(p, FISHEYE + [0.1], model="equidistant"), "distortion_coefficients"),
    (lambda p: p.write_text(p.read_text().replace("cols: 3\n  data: [52.09, 0,",
                                                  "cols: 3\n  data: [0,")) and p, "camera_matrix"),
    (lambda p: p.write_text("%YAML:1.0\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 4\n"
                            "   dt: d\n   data: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0]\n") and p,
     "camera_matrix"),
    (lambda p: p.write_text('{"width": 640, "height": 480, "intrinsic_matrix": [1, 2]}') and p,
     "intrinsic_matrix"),
    (lambda p: p.write_text('<opencv_storage><image_width>6x</image_width></opencv_storage>')
     and p, "camera_matrix"),
])
def test_a_bad_calibration_file_is_refused_in_one_line_naming_the_field(tmp_path, make, field):
    path = tmp_path / "bad.yaml"
    ros_yaml(path, PLUMB)
    path = make(path)
    with pytest.raises(ValueError) as exc:
        read_camera(path)
    text = str(exc.value)
    assert str(path) in text and field in text and "\n" not in text


def test_undistortion_inverts_a_strong_lens_at_the_corners():
    # a wide lens: the corners move by tens of pixels, still inverted to 1e-9 px
    from rangemesh.camera_files import distortion_rays

    k = [[60.0, 0.0, 32.0], [0.0, 60.0, 24.0], [0.0, 0.0, 1.0]]
    d = [-0.35, 0.12, 0.0, 0.0, -0.02]
    cam = distortion_rays(k, d, "plumb_bob", SHAPE)
    ray = cam.directions
    xd, yd = brown_forward(ray[..., 0] / ray[..., 2], ray[..., 1] / ray[..., 2], d)
    rows, cols = np.mgrid[0:SHAPE[0], 0:SHAPE[1]]
    assert np.abs(yd * 60 + 24 - rows).max() < 1e-9 and np.abs(xd * 60 + 32 - cols).max() < 1e-9
    corner = math.hypot(ray[0, 0, 0] / ray[0, 0, 2] * 60, ray[0, 0, 1] / ray[0, 0, 2] * 60)
    # barrel distortion: the corner's ray lies further out, by 1/radial (0.866 at r = 2/3)
    assert corner > 45.0


def test_depth_rays_lift_a_stored_depth_to_that_z(shared_data):
    # z_depth: the kernels lift a stored depth to z = depth x scale, not to a range along a unit ray
    img = rangemesh.read_range_image(shared_data / "rgbd" / "open3d_TUM_depth.png")
    r, c = np.mgrid[0:img.shape[0], 0:img.shape[1]].astype(np.float64)
    rays = np.stack([(c - 319.5) / 525.0, (r - 239.5) / 525.0, np.ones_like(r)], axis=-1)
    mesh = triangulate(img, camera=Rays(rays, 0.0002, z_depth=True), vertices=1000,
                       heights="pixel")  # each vertex at its pixel's own depth
    p = mesh.pixels
    z = img[p[:, 0], p[:, 1]] * 0.0002
    np.testing.assert_allclose(mesh.vertices[:, 2], z, rtol=1e-12)
    np.testing.assert_allclose(mesh.vertices[:, 0], (p[:, 1] - 319.5) / 525.0 * z, rtol=1e-12,
                               atol=1e-15)
    # and the rendering the error is measured on predicts stored depths, not ranges
    depth, _ = rangemesh.render_depth(mesh)
    np.testing.assert_allclose(depth[p[:, 0], p[:, 1]], img[p[:, 0], p[:, 1]], rtol=1e-9)


# ---------------------------------------------------------------- from the hostile-input reports


# D11 of the 2026-11-21 hostile-input report
def test_an_overflowing_camera_is_refused(chair):
    with pytest.raises(ValueError, match="camera"):
        rangemesh.triangulate(chair, background=0,
                              camera=rangemesh.Pinhole(1e-300, 1e-300, 0, 0, 1e300), method="paper")
    with pytest.raises(ValueError, match="camera"):
        rangemesh.triangulate(np.full((20, 20), 1e300), camera=(1, 1, 1e10), method="paper")


# E5 of the 2026-11-25 hostile-input report
@pytest.mark.parametrize("scale", [1e155, 1e300, 1e-160, 1e-300])
def test_long_and_short_rays_keep_their_direction(scale):
    d = np.zeros((4, 5, 3))
    d[..., 0] = 1
    d[..., 1] = np.arange(5) * 0.1
    d[..., 2] = np.arange(4)[:, None] * 0.1
    # by hand: ray (1, 0.1 c, 0.1 r) over its length
    expected = d / np.sqrt(1 + (0.1 * np.arange(5)) ** 2 + (0.1 * np.arange(4)[:, None]) ** 2)[..., None]
    with np.errstate(all="raise"):
        cam = Rays(d * scale)
    np.testing.assert_allclose(cam.directions, expected, rtol=1e-15, atol=0)
    m = rangemesh.triangulate(np.full((4, 5), 10.0), camera=cam, method="refine", vertices=10)
    assert not (m.vertices == 0).all(axis=1).any()


# E29 of the 2026-11-25 hostile-input report
@pytest.mark.parametrize("el, az, what", [
    ([0.0, -1.0], np.zeros(8), "azimuth must change strictly"),
    ([0.0, 0.0], np.arange(8.0), "elevation must change strictly"),
    ([1e300, 0.0], np.arange(8.0), "within -90 .. 90"),
    ([0.0, -1.0], np.arange(0, 720, 10.0), "more than once"),
])
def test_degenerate_spherical_cameras_are_refused(el, az, what):
    with pytest.raises(ValueError, match=what):
        Spherical(el, az)


# E20 of the 2026-11-25 hostile-input report
def test_depth_zero_before_a_pinhole_says_what_to_do():
    zz = np.full((20, 20), 1000.0)
    zz[10, 10] = 0.0  # a float image: 0 is depth unless background says otherwise
    cam = rangemesh.Pinhole(525, 525, 10, 10, 0.001)
    with pytest.raises(ValueError, match=r"depth 0 at pixel \(10, 10\).*background=0"):
        rangemesh.triangulate(zz, camera=cam, vertices=50, background=None)
    assert len(rangemesh.triangulate(zz, camera=cam, vertices=50, background=0).vertices) == 50


# E23 of the 2026-11-25 hostile-input report
def test_complex_rays_are_refused():
    with pytest.raises(TypeError, match="not complex"):
        Rays(np.ones((2, 3, 3), complex))
