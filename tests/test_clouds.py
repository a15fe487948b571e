"""Unorganised LiDAR clouds to range images (rangemesh.clouds): project_scan, --sensor, .bin info."""

import json

import numpy as np
import pytest

import rangemesh
from rangemesh.cli import main
from rangemesh.clouds import SENSORS, find_beams, project_scan, read_cloud

RELLIS = "lidar/rellis3d_os1-64_000000"


@pytest.fixture(scope="module")
def kitti(shared_data, tmp_path_factory):
    """The RELLIS scan as KITTI stores a cloud: its no-returns dropped, the rest shuffled."""
    pts = read_cloud(shared_data / f"{RELLIS}.bin")
    cloud = pts[(pts[:, :3] != 0).any(axis=1)]
    cloud = cloud[np.random.default_rng(7).permutation(len(cloud))]
    path = tmp_path_factory.mktemp("kitti") / "scan.bin"
    cloud.tofile(path)
    return path, cloud


def test_a_cloud_on_its_beams_file_gives_the_file_s_range_image(shared_data, kitti):
    _, cloud = kitti
    scan = project_scan(cloud, beams=shared_data / f"{RELLIS}.beams.json")
    want = np.load(shared_data / f"{RELLIS}.range.npy")  # the README's organised image
    assert scan.ranges.shape == (64, 2048) and scan.collisions == 0
    assert np.array_equal(scan.ranges > 0, want > 0)
    np.testing.assert_allclose(scan.ranges, want, rtol=1e-6)  # float32 sqrt in the .npy
    inten = np.load(shared_data / f"{RELLIS}.intensity.npy")
    assert np.array_equal(scan.intensity[want > 0], inten[want > 0])
    # every pixel holds its own point: the index maps back to the cloud
    r, c = np.nonzero(scan.index >= 0)
    np.testing.assert_allclose(np.linalg.norm(cloud[scan.index[r, c], :3].astype(float), axis=1),
                               scan.ranges[r, c], rtol=1e-12)


def test_beams_found_from_the_cloud_are_the_file_s(shared_data, kitti):
    _, cloud = kitti
    beams = json.loads((shared_data / f"{RELLIS}.beams.json").read_text())
    found = find_beams(cloud, 64)
    assert found["cols"] == 2048
    np.testing.assert_allclose(found["elevation_deg"], beams["elevation_deg"], atol=1e-3)
    # each beam's azimuth offset, up to a whole step (half a step either way is one offset)
    step = 360.0 / 2048
    off = np.asarray(found["azimuth_row_residual_deg"]) - (
        np.asarray(beams["azimuth_row_residual_deg"]) + beams["azimuth0_deg"])
    assert np.abs((off + step / 2) % step - step / 2).max() < 1e-3
    scan = project_scan(cloud, rows=64)
    want = np.load(shared_data / f"{RELLIS}.range.npy")
    for r in range(64):  # the same image, a row rolled by one column where its offset wrapped
        assert min(np.abs(np.roll(scan.ranges[r], k) - want[r]).max() for k in (-1, 0, 1)) < 1e-5


def test_two_points_in_one_pixel_keep_the_nearest():
    beams = {"rows": 1, "cols": 4, "elevation_deg": [0.0], "azimuth0_deg": 0.0,
             "azimuth_step_deg": -90.0}
    pts = np.array([[2.0, 0, 0], [1.0, 0, 0], [0, 3.0, 0], [0, 0, 0]])
    scan = project_scan(pts, beams=beams)
    # azimuth 0 -> column 0; azimuth 90 -> (90 - 0) / -90 = -1 -> column 3 (mod 4)
    assert scan.ranges.tolist() == [[1.0, 0.0, 0.0, 3.0]]
    assert scan.index.tolist() == [[1, -1, -1, 2]]
    assert scan.points == 3 and scan.collisions == 1  # the origin is no return, not a point
    assert scan.intensity is None


def hdl64_cloud(seed=3, cols=2000):
    """An HDL-64E-like cloud: the nominal beams off by a calibration of up to 0.1 degree each,
    azimuths off a grid (firing times drift), a room 4-30 m away, a third of the returns lost."""
    rng = np.random.default_rng(seed)
    el = np.asarray(SENSORS["hdl64"]) + rng.uniform(-0.1, 0.1, 64)
    az = np.arange(cols) * 360.0 / cols + rng.uniform(-0.02, 0.02, (64, cols))
    e, a = np.radians(el)[:, None], np.radians(az)
    ray = np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e) + 0 * a], -1)
    d = 4.0 + 26.0 * rng.random((64, cols)) ** 2
    pts = (d[..., None] * ray).reshape(-1, 3)
    beam = np.repeat(np.arange(64), cols)
    keep = rng.random(len(pts)) > 1 / 3
    return pts[keep], beam[keep], el


def test_an_hdl64_s_beams_are_found_from_its_cloud():
    pts, beam, el = hdl64_cloud()
    scan = project_scan(pts, sensor="hdl64", cols=2000)
    np.testing.assert_allclose(scan.camera.elevation, el, atol=1e-6)  # (6 decimals kept)
    r, c = np.nonzero(scan.index >= 0)
    assert np.array_equal(beam[scan.index[r, c]], r)  # every point in its own beam's row
    assert scan.collisions < 0.01 * len(pts)  # the jitter puts few points in one pixel
    assert scan.camera.wraps


@pytest.mark.parametrize("kwargs, match", [({}, "one of beams"), ({"sensor": "hdl65"}, "sensor"),
                                            ({"rows": 4, "sensor": "vlp16"}, "one of beams"),
                                            ({"rows": 64}, "64 beams")])
def test_bad_calls_say_what_is_wrong(kwargs, match):
    with pytest.raises(ValueError, match=match):
        project_scan(np.ones((20, 4)), **kwargs)


def test_points_must_be_n_by_3():
    with pytest.raises(ValueError, match="points must be"):
        project_scan(np.ones(12), rows=2)


def test_the_command_line_meshes_a_cloud_with_sensor_or_beams(shared_data, kitti, tmp_path, capsys):
    path, cloud = kitti
    scan = project_scan(cloud, sensor="hdl64")
    want = rangemesh.triangulate(scan.ranges, camera=scan.camera, vertices=800, heights="pixel")
    assert main(["mesh", str(path), "--sensor", "hdl64", "--vertices", "800", "--heights",
                 "pixel", "-o", str(tmp_path / "a.ply"), "--quiet"]) == 0
    got = rangemesh.read_mesh(tmp_path / "a.ply")
    assert np.array_equal(got.faces, want.faces)
    # vertices are the cloud's own points: this scan's beams lie on a grid the cloud shows
    ids = scan.index[want.pixels[:, 0], want.pixels[:, 1]]
    assert (ids >= 0).mean() > 0.99  # (a corner on a no-return pixel takes its neighbour's range)
    own = cloud[ids[ids >= 0], :3]
    assert np.abs(got.vertices[ids >= 0] - own).max() < 1e-4  # metres (float32 points and PLY)
    # the beams written from the cloud mesh it as --sensor does
    assert main(["info", str(path), "--sensor", "hdl64", "--write-beams",
                 str(tmp_path / "b.json")]) == 0
    assert "wrote" in capsys.readouterr().out
    assert main(["mesh", str(path), "--beams", str(tmp_path / "b.json"), "--vertices", "800",
                 "--heights", "pixel", "-o", str(tmp_path / "b.ply"), "--quiet"]) == 0
    assert np.array_equal(rangemesh.read_mesh(tmp_path / "b.ply").faces, want.faces)
    # and a batch with that beams file meshes it too
    res = rangemesh.mesh_many([path], tmp_path / "many", beams=tmp_path / "b.json", vertices=800,
                              heights="pixel")
    assert res[0].status == "meshed", res[0].error


def test_info_reads_a_cloud(kitti, capsys):
    path, cloud = kitti
    assert main(["info", str(path), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["points"] == len(cloud) == doc["returns"] and doc["no_returns"] == 0
    assert doc["range_max"] == pytest.approx(107.75, abs=0.01)  # the README's 0.82-107.8 m
    assert main(["info", str(path), "--sensor", "hdl64", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["shape"] == [64, 2048] and doc["valid_pixels"] == len(cloud)


def test_sensor_goes_with_a_cloud_only(shared_data, capsys):
    img = shared_data / "rgbd/open3d_TUM_depth.png"
    assert main(["mesh", str(img), "--sensor", "hdl64", "-o", "/tmp/x.ply"]) == 2
    assert "--sensor goes with a LiDAR cloud" in capsys.readouterr().err


def test_a_camera_over_part_of_the_circle_takes_the_points_in_its_columns(shared_data, kitti):
    _, cloud = kitti
    beams = json.loads((shared_data / f"{RELLIS}.beams.json").read_text())
    beams["cols"] = 1024  # the first half turn of the scan's 2048 steps
    scan = project_scan(cloud, beams=beams)
    want = np.load(shared_data / f"{RELLIS}.range.npy")[:, :1024]
    assert not scan.camera.wraps and scan.collisions == 0
    assert np.array_equal(scan.ranges > 0, want > 0)
    np.testing.assert_allclose(scan.ranges, want, rtol=1e-6)


# ------------------------------------------------------------------ cloud files with a ring field

# Two beams at +2 and -2 degrees, four columns a turn (azimuth 0, -90, 180, 90: clockwise), by hand:
# ranges [[1, 2, 3, 4], [5, 6, 7, 8]]; the driver's ring counts from the bottom beam (Velodyne's
# order). The top beam's second point is measured at -1.5 degrees, nearer the bottom beam's -2:
# its ring keeps it in the top row. A NaN point is a no-return, as drivers write them.
HAND_RANGES = np.array([[1.0, 2.0, 3.0, 4.0], [5.0, 6.0, 7.0, 8.0]])


def _hand_cloud():
    rows = []
    for b, (elev, ring) in enumerate(((2.0, 1), (-2.0, 0))):
        for c, az in enumerate((0.0, -90.0, 180.0, 90.0)):
            e = -1.5 if (b, c) == (0, 1) else elev
            r = HAND_RANGES[b, c]
            er, ar = np.radians(e), np.radians(az)
            rows.append((r * np.cos(er) * np.cos(ar), r * np.cos(er) * np.sin(ar), r * np.sin(er),
                         10.0 * r, ring))
    rows.append((np.nan, np.nan, np.nan, 0.0, 0))
    return rows


def _pcd_header(data: str, fields="x y z intensity ring", size="4 4 4 4 2", typ="F F F F U"):
    n = len(_hand_cloud())
    return (f"# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS {fields}\n"
            f"SIZE {size}\nTYPE {typ}\nCOUNT 1 1 1 1 1\nWIDTH {n}\nHEIGHT 1\n"
            f"VIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA {data}\n")


def _check_hand_scan(points, ring):
    assert ring is not None and list(ring) == [1, 1, 1, 1, 0, 0, 0, 0, 0]
    scan = project_scan(points, ring=ring)
    np.testing.assert_allclose(scan.ranges, HAND_RANGES, rtol=1e-6)
    np.testing.assert_allclose(scan.intensity, 10.0 * HAND_RANGES, rtol=1e-6)
    assert scan.index.tolist() == [[0, 1, 2, 3], [4, 5, 6, 7]] and scan.collisions == 0
    np.testing.assert_allclose(scan.camera.elevation, [2.0, -2.0], atol=1e-5)
    # without the ring the odd point goes to the nearer bottom row, where a nearer point wins
    plain = project_scan(points, rows=2, cols=4)
    assert plain.ranges[0, 1] == 0.0 and plain.collisions == 1


def test_an_ascii_pcd_cloud_with_a_ring_field_keeps_each_point_in_its_beam(tmp_path):
    path = tmp_path / "hand.pcd"
    lines = [" ".join(f"{v:.9g}" for v in row[:4]) + f" {row[4]}" for row in _hand_cloud()]
    path.write_text(_pcd_header("ascii") + "\n".join(lines) + "\n")
    points, ring = read_cloud(path, ring=True)
    assert points.shape == (9, 4) and np.isnan(points[8, :3]).all()
    _check_hand_scan(points, ring)


def test_a_binary_pcd_cloud_reads_as_its_ascii_twin(tmp_path):
    import struct

    path = tmp_path / "hand.pcd"
    body = b"".join(struct.pack("<ffffH", *row) for row in _hand_cloud())  # 18 bytes a point
    path.write_bytes(_pcd_header("binary").encode() + body)
    _check_hand_scan(*read_cloud(path, ring=True))


def test_a_ply_cloud_with_a_ring_field_keeps_each_point_in_its_beam(tmp_path):
    from plyfile import PlyData, PlyElement

    rows = np.array(_hand_cloud(), dtype=[("x", "f4"), ("y", "f4"), ("z", "f4"),
                                          ("intensity", "f4"), ("ring", "u2")])
    path = tmp_path / "hand.ply"
    PlyData([PlyElement.describe(rows, "vertex")]).write(str(path))
    _check_hand_scan(*read_cloud(path, ring=True))
    # a cloud file without a ring field gives None
    bare = np.array([r[:3] for r in _hand_cloud()], dtype=[("x", "f4"), ("y", "f4"), ("z", "f4")])
    PlyData([PlyElement.describe(bare, "vertex")]).write(str(tmp_path / "bare.ply"))
    pts, ring = read_cloud(tmp_path / "bare.ply", ring=True)
    assert ring is None and (pts[:8, 3] == 0).all()


def test_a_cloud_file_of_an_unknown_suffix_is_refused_naming_the_known_ones(tmp_path):
    # the readers are a table by suffix (cloud_files._READERS): a suffix outside it is refused
    path = tmp_path / "scan.xyz"
    path.write_bytes(bytes(16))
    with pytest.raises(ValueError, match=r"scan\.xyz: not a cloud file \(\.bin, \.pcd, \.ply\)"):
        read_cloud(path)
    # the suffix is read without its case, as the table's keys are lower case
    upper = tmp_path / "scan.BIN"
    np.array([[1.0, 2.0, 3.0, 0.5]], "<f4").tofile(upper)
    assert read_cloud(upper).tolist() == [[1.0, 2.0, 3.0, 0.5]]


def test_a_cloud_file_s_bad_ring_or_missing_axis_is_one_line(tmp_path):
    path = tmp_path / "bad.pcd"
    path.write_text(_pcd_header("ascii", "x y intensity ring", "4 4 4 2", "F F F U")
                    .replace("COUNT 1 1 1 1 1", "COUNT 1 1 1 1") + "1 2 3 0\n" * 9)
    with pytest.raises(ValueError, match="no z field"):
        read_cloud(path)
    pts = np.array([r[:4] for r in _hand_cloud()[:8]])
    with pytest.raises(ValueError, match="ring"):
        project_scan(pts, ring=np.arange(8.0) + 0.5)


def test_the_command_line_meshes_and_describes_a_pcd_cloud(tmp_path, capsys):
    path = tmp_path / "hand.pcd"
    lines = [" ".join(f"{v:.9g}" for v in row[:4]) + f" {row[4]}" for row in _hand_cloud()]
    path.write_text(_pcd_header("ascii") + "\n".join(lines) + "\n")
    assert main(["info", str(path), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert (doc["points"], doc["returns"], doc["no_returns"], doc["ring_beams"]) == (9, 8, 1, 2)
    assert main(["info", str(path), "--sensor", "vlp16", "--json"]) == 2  # 2 rings, 16 beams
    assert "16 beams" in capsys.readouterr().err
    ply = tmp_path / "hand.ply"
    assert main(["mesh", str(ply), "-o", str(tmp_path / "m.ply")]) == 2
    assert "a .ply cloud needs --sensor" in capsys.readouterr().err


# ------------------------------------------------------------------ Ouster heads from metadata

OUSTER_META = "lidar/OS-1-128_v2.3.0_1024x10.json"


def _ouster_cloud(meta: dict, ranges):
    """Points of every pixel by the formula of Ouster's manual ("Lidar Range to XYZ"), in metres,
    in the sensor frame (lidar_to_sensor_transform applied), as the SDK and ouster-ros give them."""
    alt = np.radians(np.asarray(meta["beam_altitude_angles"]))[:, None]
    azi = -np.radians(np.asarray(meta["beam_azimuth_angles"]))[:, None]
    w = int(meta["lidar_mode"].split("x")[0])
    enc = 2 * np.pi * (1 - np.arange(w) / w)[None, :]
    n = meta["lidar_origin_to_beam_origin_mm"] / 1000.0
    x = (ranges - n) * np.cos(enc + azi) * np.cos(alt) + n * np.cos(enc)
    y = (ranges - n) * np.sin(enc + azi) * np.cos(alt) + n * np.sin(enc)
    z = (ranges - n) * np.sin(alt)
    m = np.asarray(meta["lidar_to_sensor_transform"], float).reshape(4, 4)
    p = np.stack([x, y, z], -1) @ m[:3, :3].T + m[:3, 3] / 1000.0
    return p.reshape(-1, 3)


def test_an_ouster_head_from_its_metadata_puts_every_point_in_its_beam(shared_data):
    meta = json.loads((shared_data / OUSTER_META).read_text())
    h, w = len(meta["beam_altitude_angles"]), 1024
    # near and far: at 0.5-2 m the 36 mm and 16 mm offsets move a point's elevation by a beam
    ranges = np.random.default_rng(3).uniform(0.5, 40.0, (h, w))
    ranges[:, ::7] = np.random.default_rng(4).uniform(0.5, 2.0, (h, len(range(0, w, 7))))
    cloud = _ouster_cloud(meta, ranges)
    order = np.random.default_rng(5).permutation(len(cloud))
    scan = project_scan(cloud[order], sensor=shared_data / OUSTER_META)
    assert scan.ranges.shape == (h, w) and scan.camera.wraps and scan.collisions == 0
    pid = order[scan.index]  # each pixel's point, as the generator numbered it (row-major)
    assert (scan.index >= 0).all()
    rows, cols = np.divmod(pid, w)
    assert np.array_equal(rows, np.repeat(np.arange(h)[:, None], w, axis=1))  # each in its beam
    shift = (np.arange(w)[None, :] - cols) % w
    assert (shift == shift[0, 0]).all()  # the columns in the sensor's order, one turn of shift
    np.testing.assert_allclose(scan.camera.elevation, meta["beam_altitude_angles"])


def test_an_ouster_head_from_the_command_line(shared_data, tmp_path, capsys):
    from plyfile import PlyData, PlyElement

    meta = json.loads((shared_data / OUSTER_META).read_text())
    ranges = np.random.default_rng(6).uniform(2.0, 20.0, (128, 1024))
    pts = _ouster_cloud(meta, ranges).astype("f4")
    path = tmp_path / "os1.ply"
    PlyData([PlyElement.describe(np.rec.fromarrays(pts.T, names="x,y,z"), "vertex")]).write(str(path))
    assert main(["mesh", str(path), "--sensor", str(shared_data / OUSTER_META), "--vertices", "500",
                 "-o", str(tmp_path / "m.ply"), "--quiet"]) == 0
    assert main(["info", str(path), "--sensor", str(shared_data / OUSTER_META), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["shape"] == [128, 1024] and doc["valid_pixels"] == 128 * 1024
