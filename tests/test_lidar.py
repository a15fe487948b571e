"""Spinning LiDAR: the spherical camera, the .bin reader, the 360-degree seam, jumps by ray angle."""

import json
import math

import numpy as np
import pytest

import rangemesh
from rangemesh import Orthographic, Rays, Spherical, backproject, triangulate
from rangemesh.cli import main
from rangemesh.geometry.seam import is_seam, seam_faces, seam_strip
from rangemesh.geometry.walls import wall_faces
from rangemesh.io import read_lidar_bin, read_mesh, write_mesh

from .helpers import assert_valid_mesh
from .images import lidar_scan

SCAN = "lidar/rellis3d_os1-64_000000"


@pytest.fixture(scope="module")
def scan(shared_data):
    rng = np.load(shared_data / f"{SCAN}.range.npy")
    beams = json.loads((shared_data / f"{SCAN}.beams.json").read_text())
    raw = np.fromfile(shared_data / f"{SCAN}.bin", dtype="<f4").reshape(-1, 4)
    cam = Spherical.from_beams(shared_data / f"{SCAN}.beams.json")
    return rng, beams, raw, cam


@pytest.fixture(scope="module")
def os1(tmp_path_factory):
    """A scan laid out as the shared OS1-64 scan (64 x 2048, the same files): tests/images.py."""
    return lidar_scan(tmp_path_factory.mktemp("os1"))


@pytest.fixture(scope="module")
def synthetic_scan(os1):
    """`scan`'s four items for the synthetic scan: for tests that need no particular scan."""
    return (np.load(os1["range"]), json.loads(os1["beams"].read_text()),
            np.fromfile(os1["bin"], dtype="<f4").reshape(-1, 4), Spherical.from_beams(os1["beams"]))


def _raw_point(raw, beams, r, c):
    """The .bin's point for destaggered pixel (r, c): README section 5 (index = step*64 + beam)."""
    step = (np.asarray(c) - np.asarray(beams["column_shift"])[r]) % beams["cols"]
    return raw[step * beams["rows"] + r, :3].astype(np.float64)


# --- the camera, by hand ---------------------------------------------------------------


def test_spherical_rays_by_hand():
    cam = Spherical([90.0, 0.0, -45.0], [0.0, 90.0, 180.0], row_azimuth=[0.0, 0.0, 90.0],
                    range_scale=2.0)
    pts = backproject([0, 1, 1, 2], [0, 0, 1, 0], [1.0, 1.0, 3.0, math.sqrt(2)], cam)
    # straight up; forward (x); left (y) at range 3 x 2; 45 deg down at azimuth 0 + 90
    expected = [[0, 0, 2], [2, 0, 0], [0, 6, 0], [0, 2 * 1, -2 * 1]]
    np.testing.assert_allclose(pts, expected, atol=1e-12)


def test_spherical_wraps_only_once_round():
    assert Spherical([0.0, -1.0], np.arange(0, 360, 10.0)).wraps
    assert Spherical([0.0, -1.0], -np.arange(0, 360, 10.0)).wraps  # Ouster's decreasing azimuths
    assert not Spherical([0.0, -1.0], np.arange(0, 180, 10.0)).wraps
    with pytest.raises(ValueError, match="go round more than once"):  # report E29
        Spherical([0.0, -1.0], np.arange(0, 720, 10.0))
    assert not Rays(np.ones((2, 3, 3))).wraps


def test_camera_of_another_shape_is_refused():
    cam = Spherical([0.0, -1.0, -2.0], np.arange(0, 360, 10.0))
    with pytest.raises(ValueError, match="rays for a 3x36 image"):
        triangulate(np.ones((4, 36)), camera=cam, vertices=10)


def test_from_beams_errors(tmp_path):
    with pytest.raises(ValueError, match="missing azimuth_step_deg"):
        Spherical.from_beams({"elevation_deg": [0.0], "azimuth0_deg": 0.0, "cols": 4})
    bad = tmp_path / "b.json"
    bad.write_text("[1, 2]")
    with pytest.raises(ValueError, match="JSON object"):
        Spherical.from_beams(bad)
    with pytest.raises(ValueError, match="cannot read"):
        Spherical.from_beams(tmp_path / "missing.json")


def test_rays_camera_matches_spherical():
    sph = Spherical([10.0, 0.0, -10.0], np.linspace(0.0, -350.0, 36))
    rays = Rays(sph.directions * 3.0)  # any length: normalised
    depth = 5.0 + np.random.default_rng(0).random((3, 36))
    a = triangulate(depth, camera=sph, vertices=40, heights="pixel", wrap=False)
    b = triangulate(depth, camera=rays, vertices=40, heights="pixel")
    np.testing.assert_array_equal(a.faces, b.faces)
    np.testing.assert_allclose(a.vertices, b.vertices, atol=1e-12)


# --- the shared scan ------------------------------------------------------------------


def test_read_lidar_bin_matches_the_range_image(shared_data, scan):
    rng, beams, _, _ = scan
    got, inten = read_lidar_bin(shared_data / f"{SCAN}.bin", 64, column_shift=beams["column_shift"])
    np.testing.assert_array_equal(got, rng)  # the data's own converter, not ours
    np.testing.assert_array_equal(inten, np.load(shared_data / f"{SCAN}.intensity.npy"))
    with pytest.raises(ValueError, match="whole number of 60-beam steps"):
        read_lidar_bin(shared_data / f"{SCAN}.bin", 60)


@pytest.mark.parametrize("method", ["refine", "paper"])
def test_vertices_are_the_raw_points(synthetic_scan, method):
    """Every vertex within 1 mm of the .bin's point for its pixel (depths copied from pixels).

    Single-pixel holes are left as they are (``fill_gaps=False``): a filled
    pixel has no point in the .bin.
    """
    rng, beams, raw, cam = synthetic_scan
    kw = {"vertices": 3000, "heights": "pixel"} if method == "refine" else {"tiles": (2, 16)}
    mesh = triangulate(rng, camera=cam, background=0, method=method, fill_gaps=False, **kw)
    assert (rng[mesh.pixels[:, 0], mesh.pixels[:, 1]] > 0).all()
    r, c = mesh.pixels[:, 0], mesh.pixels[:, 1]
    err = np.linalg.norm(mesh.vertices - _raw_point(raw, beams, r, c), axis=1)
    assert err.max() < 1e-3, err.max()


def test_fitted_vertices_stay_on_their_rays(synthetic_scan):
    rng, beams, raw, cam = synthetic_scan
    mesh = triangulate(rng, camera=cam, background=0, vertices=3000, fill_gaps=False)
    p = _raw_point(raw, beams, mesh.pixels[:, 0], mesh.pixels[:, 1])
    cos = np.sum(mesh.vertices * p, axis=1) / (np.linalg.norm(mesh.vertices, axis=1)
                                               * np.linalg.norm(p, axis=1))
    assert cos.min() > 1 - 1e-9


def _seam_gaps(mesh, valid):
    """Boundary edges on column 0 or W-1 with valid pixels on both sides of the seam all along."""
    f = mesh.faces
    w = mesh.image_shape[1]
    directed = {(a, b) for a, b in np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]).tolist()}
    gaps = 0
    for a, b in directed:
        if (b, a) in directed:
            continue
        (ra, ca), (rb, cb) = mesh.pixels[a], mesh.pixels[b]
        if ca == cb and ca in (0, w - 1):
            rows = np.arange(min(ra, rb), max(ra, rb) + 1)
            gaps += bool(valid[rows, 0].all() and valid[rows, w - 1].all())
    return gaps


@pytest.mark.parametrize("method", ["refine", "paper"])
def test_seam_is_closed(synthetic_scan, method):
    rng, _, _, cam = synthetic_scan
    valid = rng > 0
    if method == "refine":  # it fills single-pixel gaps by default: vertices may stand on them
        valid = rangemesh.fill_gaps(*rangemesh.to_depth_and_mask(rng, 0))[1]
    kw = {"vertices": 1500} if method == "refine" else {"tiles": (2, 16), "fill_gaps": False}
    closed = triangulate(rng, camera=cam, background=0, method=method, **kw)
    cut = triangulate(rng, camera=cam, background=0, method=method, wrap=False, **kw)
    assert _seam_gaps(cut, valid) > 0  # the check can fail: the cut mesh has them
    assert _seam_gaps(closed, valid) == 0
    assert is_seam(closed.pixels, closed.faces).sum() > 0
    assert not is_seam(cut.pixels, cut.faces).any()
    assert_valid_mesh(closed, valid, wrap=True)
    # the strip covers no pixel: the error is that of the cut mesh
    ev_closed = rangemesh.evaluate(closed, rng, background=0)
    ev_cut = rangemesh.evaluate(cut, rng, background=0)
    assert ev_closed.relative_error == ev_cut.relative_error
    assert ev_closed.uncovered == ev_cut.uncovered
    if method == "refine":
        assert ev_closed.uncovered == 0.0


def test_seam_strip_of_a_full_mesh_by_hand():
    """Every pixel a vertex: the strip joins the H pixels of column W-1 to those of column 0."""
    h, w = 5, 12
    depth = 10.0 + np.random.default_rng(1).random((h, w))
    mesh = triangulate(depth, vertices=h * w, heights="pixel", wrap=True)
    seam = is_seam(mesh.pixels, mesh.faces)
    assert seam.sum() == 2 * (h - 1)  # one quad per pair of rows, two triangles each
    assert_valid_mesh(mesh, wrap=True)
    # no seam without wrap, and none from seam_strip on a mesh that touches neither column
    assert not is_seam(triangulate(depth, vertices=h * w).pixels,
                       triangulate(depth, vertices=h * w).faces).any()
    inner = mesh.pixels[:, 1] % (w - 1) != 0
    keep = inner[mesh.faces].all(axis=1)
    assert len(seam_strip(mesh.pixels, mesh.faces[keep], w)) == 0


def test_seam_faces_measure_the_jump_across_the_seam_by_hand():
    """2x4 image, depth 1 on column 0 and 2 on column 3: the strip's edges are 1 pixel long.

    Across the seam a straight edge is 1 pixel and a diagonal 1.41, so a step of 1 at depth 1
    is a jump for ``jump=0.5`` (0.5 * 1 * 1 < 1) and not for 1.5 (1.5 * 1 * 1 > 1); measured in
    the plain image (3 pixels from column 3 to column 0) 0.5 would let it pass (1.5 > 1).
    """
    depth = np.array([[1.0, 1.0, 2.0, 2.0], [1.0, 1.0, 2.0, 2.0]])
    mesh = triangulate(depth, vertices=8, heights="pixel", wrap=False)
    kept = seam_faces(mesh.pixels, mesh.faces, 4)
    assert len(kept) == 2  # one quad between the two rows, two triangles
    assert is_seam(mesh.pixels, kept).all()
    assert len(seam_faces(mesh.pixels, mesh.faces, 4, depth=depth, jump=1.5)) == 2
    assert len(seam_faces(mesh.pixels, mesh.faces, 4, depth=depth, jump=0.5)) == 0
    # through the pipeline: the same strip, walls or not
    assert is_seam(*_pf(triangulate(depth, vertices=8, heights="pixel", wrap=True))).sum() == 2
    no_walls = triangulate(depth, vertices=8, heights="pixel", wrap=True, walls=False, jump=0.5)
    assert not is_seam(*_pf(no_walls)).any()


def _pf(mesh):
    return mesh.pixels, mesh.faces


def test_walls_across_the_seam_are_dropped():
    """A jump right at the seam (near on column 0, far on column W-1): no seam face without walls."""
    h, w = 6, 36
    cam = Spherical(np.linspace(5.0, -5.0, h), np.arange(w) * -10.0)
    depth = np.full((h, w), 20.0)
    depth[:, : w // 2] = 5.0  # near half: jumps at columns 17/18 and at the seam 35/0
    with_walls = triangulate(depth, camera=cam, vertices=h * w, heights="pixel")
    without = triangulate(depth, camera=cam, vertices=h * w, heights="pixel", walls=False)
    assert is_seam(with_walls.pixels, with_walls.faces).sum() == 2 * (h - 1)
    assert not is_seam(without.pixels, without.faces).any()
    assert_valid_mesh(without, wrap=True)
    depth[:] = 20.0  # no jump: the seam closes without walls too
    flat = triangulate(depth, camera=cam, vertices=h * w, heights="pixel", walls=False)
    assert is_seam(flat.pixels, flat.faces).sum() == 2 * (h - 1)


def test_jump_by_ray_angle_by_hand():
    """Beams 0.6 deg apart, columns 0.2 deg: a vertical edge is 3 pixels long."""
    cam = Spherical([0.6, 0.0], [0.0, -0.2, -0.4])
    pixels = np.array([[0, 0], [1, 0], [1, 1]])
    faces = np.array([[0, 1, 2]])

    def is_jump(z0, z1):
        # edge 0-1 (3 px) changes z0 -> z1; edge 1-2 (1 px) none; edge 2-0 (3.16 px) as 0-1
        return bool(wall_faces(faces, pixels, np.array([z0, z1, z1]), 0.05, cam)[0])

    assert not is_jump(10.0, 11.4)  # 14 % over 3 px: 4.7 % a pixel
    assert is_jump(10.0, 11.6)  # 16 %: 5.3 % a pixel
    # in the image plane the same edge is 1 pixel long: 14 % would be a jump
    assert bool(wall_faces(faces, pixels, np.array([10.0, 11.4, 11.4]), 0.05)[0])


def test_walls_dropped_on_the_scan_keep_the_ground(scan):
    rng, _, _, cam = scan
    valid = rng > 0
    low = valid.copy()
    low[:44] = False  # beams under -6 deg: mostly ground, with people's legs and tree trunks
    mesh = triangulate(rng, camera=cam, background=0, vertices=8000, walls=False)
    ev = rangemesh.evaluate(mesh, rng, background=0)
    assert ev.uncovered < 15.0, ev.uncovered  # what is lost: edges of trees, people, posts
    assert np.isfinite(rangemesh.render_depth(mesh)[0][low]).mean() > 0.95
    assert_valid_mesh(mesh, wrap=True, check_overlap=False)  # (vertices on filled gaps too)
    # the rule by ray angle calls far fewer low faces walls than one in the image plane, which
    # counts a step between beams 0.55 deg apart as one over 1 pixel (0.18 deg). Both rules are
    # judged on one fixed mesh, every low pixel a vertex (two triangles a pixel square), so that
    # the comparison does not move with how the mesher shapes its triangles: 3.8 % against
    # 33.8 % when written (on the 8000-vertex mesh above, 35 % against 54 %)
    h, w = rng.shape
    rows, cols = np.mgrid[44:h, 0:w]
    idx = np.arange(rows.size).reshape(rows.shape)
    a, b, c, d = idx[:-1, :-1], idx[:-1, 1:], idx[1:, :-1], idx[1:, 1:]
    faces = np.concatenate([np.stack([a, c, b], -1).reshape(-1, 3),
                            np.stack([b, c, d], -1).reshape(-1, 3)])
    faces = faces[valid[44:].ravel()[faces].all(axis=1)]
    pixels = np.stack([rows.ravel(), cols.ravel()], axis=1)
    z = rng[pixels[:, 0], pixels[:, 1]]
    by_angle = wall_faces(faces, pixels, z, 0.05, cam).mean()
    in_plane = wall_faces(faces, pixels, z, 0.05).mean()
    assert by_angle < 0.25 * in_plane, (by_angle, in_plane)


def test_spherical_camera_round_trips_through_ply(tmp_path, synthetic_scan):
    rng, _, _, cam = synthetic_scan
    mesh = triangulate(rng, camera=cam, background=0, vertices=500)
    write_mesh(mesh, tmp_path / "s.ply")
    back = read_mesh(tmp_path / "s.ply")
    assert back.camera == cam and back.image_shape == rng.shape
    # without pixels, evaluation projects the vertices through the spherical camera
    ev = rangemesh.evaluate(back, rng, background=0)
    assert ev.relative_error == pytest.approx(
        rangemesh.evaluate(mesh, rng, background=0).relative_error, rel=1e-6)


def test_orthographic_wrap_on_request():
    """wrap=True closes the seam with any camera (a panorama in an orthographic frame)."""
    depth = 10.0 + np.random.default_rng(2).random((4, 9))
    mesh = triangulate(depth, camera=Orthographic(), vertices=36, wrap=True)
    assert is_seam(mesh.pixels, mesh.faces).sum() == 6
    assert_valid_mesh(mesh, wrap=True)


# --- the command line ----------------------------------------------------------------------


def test_no_return_is_no_vertex_in_the_api_and_the_cli_alike(tmp_path, shared_data, scan, capsys):
    # F16, issue 41: through the API (background='auto') a float scan's no-return 0 put 3250 of
    # 20000 vertices at the sensor origin; the CLI with --beams put none there
    from rangemesh.cli import main

    rng, _, _, cam = scan
    assert rng.dtype == np.float32 and (rng == 0).mean() > 0.3  # README: 0 = no return, 40 %
    mesh = triangulate(rng, camera=cam, vertices=5000)
    assert len(mesh.vertices) == 5000
    assert np.linalg.norm(mesh.vertices, axis=1).min() >= 0.8  # README: ranges 0.82 .. 107.8 m
    out = tmp_path / "scan.ply"
    assert main(["mesh", str(shared_data / f"{SCAN}.range.npy"), "--beams",
                 str(shared_data / f"{SCAN}.beams.json"), "--vertices", "5000", "-o", str(out),
                 "--quiet"]) == 0
    back = read_mesh(out)
    np.testing.assert_array_equal(back.faces, mesh.faces)
    np.testing.assert_allclose(back.vertices, mesh.vertices, rtol=1e-6)  # PLY keeps float32
    ev = rangemesh.evaluate(mesh, rng)
    assert ev.valid_pixels == int((rng > 0).sum())
    assert main(["info", str(shared_data / f"{SCAN}.range.npy"), "--beams",
                 str(shared_data / f"{SCAN}.beams.json"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["valid_pixels"] == int((rng > 0).sum())


def test_cli_meshes_the_scan_from_npy_and_bin(tmp_path, os1, capsys):
    from rangemesh.cli import main

    beams = os1["beams"]
    a, b = tmp_path / "a.ply", tmp_path / "b.ply"
    assert main(["mesh", str(os1["range"]), "--beams", str(beams),
                 "--vertices", "2000", "-o", str(a), "--quiet"]) == 0
    assert main(["mesh", str(os1["bin"]), "--beams", str(beams), "--vertices",
                 "2000", "-o", str(b), "--quiet",
                 "--intensity", str(os1["intensity"])]) == 0
    ma, mb = read_mesh(a), read_mesh(b)
    assert ma.camera == Spherical.from_beams(beams)
    np.testing.assert_array_equal(ma.vertices, mb.vertices)  # the same scan, the same mesh
    assert is_seam(*_pixels_faces(tmp_path, os1, beams)).any()  # wrap is on by default
    from plyfile import PlyData

    v = PlyData.read(str(b))["vertex"].data
    assert {"red", "green", "blue", "intensity", "nx", "ny", "nz"} <= set(v.dtype.names)
    capsys.readouterr()
    assert main(["mesh", str(os1["bin"]), "-o", str(b)]) == 2
    assert "needs --beams" in capsys.readouterr().err
    assert main(["mesh", str(os1["range"]), "--beams", str(beams),
                 "--intrinsics", "1,1,1,1", "-o", str(b)]) == 2
    assert "exclude each other" in capsys.readouterr().err
    # the OBJ's texture of an --intensity run never replaces that input
    taken = tmp_path / "o.texture.png"
    taken.write_bytes(os1["intensity"].read_bytes())
    assert main(["mesh", str(os1["range"]), "--beams", str(beams),
                 "--vertices", "300", "--intensity", str(taken), "-o", str(tmp_path / "o.obj")]) == 2
    assert "never replaces an input" in capsys.readouterr().err
    notes = tmp_path / "README.md"  # a text file that is no beams file
    notes.write_text("# Real range / depth images\n\n| file | kind |\n")
    assert main(["mesh", str(os1["bin"]), "--beams", str(notes), "-o", str(b)]) == 2
    assert "cannot read it as a beams file" in capsys.readouterr().err


def _pixels_faces(tmp_path, os1, beams):
    from rangemesh.cli import main

    out = tmp_path / "p.ply"
    main(["mesh", str(os1["range"]), "--beams", str(beams), "--vertices",
          "1000", "-o", str(out), "--pixels", "--quiet"])
    m = read_mesh(out)
    return m.pixels, m.faces


def test_cli_no_wrap_leaves_the_seam_open(tmp_path, os1):
    from rangemesh.cli import main

    beams = os1["beams"]
    out = tmp_path / "p.ply"
    assert main(["mesh", str(os1["range"]), "--beams", str(beams),
                 "--vertices", "1000", "-o", str(out), "--pixels", "--quiet", "--no-wrap"]) == 0
    m = read_mesh(out)
    assert not is_seam(m.pixels, m.faces).any()


def test_preview_of_the_scan_is_legible(tmp_path, synthetic_scan):
    """64 x 2048: panels stacked at the picture's full width, rows stretched, seam not drawn."""
    import imageio.v3 as iio

    from rangemesh.preview import save_preview

    rng, _, _, cam = synthetic_scan
    mesh = triangulate(rng, camera=cam, background=0, vertices=2000)
    save_preview(mesh, rng, rng > 0, tmp_path / "p.png")
    img = iio.imread(tmp_path / "p.png")
    assert img.shape[1] >= 1500  # each panel the full width: 1 shown pixel for 2 columns at most
    assert img.shape[0] > 0.3 * img.shape[1]  # three panels of legible height, not 3 slivers


# ---------------------------------------------------------------- from the hostile-input reports


# E6 of the 2026-11-25 hostile-input report
def test_beams_cols_for_another_image_are_refused_before_rays(beams_file, tmp_path):
    beams = json.loads(beams_file.read_text())
    beams["cols"] = 200_000_000
    with pytest.raises(ValueError, match="64x200000000 image, not this 64x2048 one"):
        Spherical.from_beams(beams, image_shape=(64, 2048))
    with pytest.raises(ValueError, match="more than the"):  # no image to compare with: a bound
        Spherical.from_beams(beams)


# E6 of the 2026-11-25 hostile-input report
def test_a_bin_size_is_checked_against_the_beams_file(tmp_path):
    big = tmp_path / "big.bin"
    with open(big, "wb") as f:
        f.truncate(16 * 64 * 500_000)  # 512 MB of zeros: 500,000 steps, not 2,048
    with pytest.raises(ValueError, match="500000 steps of 64 beams, not the 2048"):
        read_lidar_bin(big, 64, steps=2048)


# E6 of the 2026-11-25 hostile-input report
def test_a_beams_file_must_be_a_small_regular_file(tmp_path):
    with pytest.raises(ValueError, match="not a regular file"):
        Spherical.from_beams("/dev/zero")
    huge = tmp_path / "huge.json"
    with open(huge, "wb") as f:
        f.truncate((1 << 24) + 1)
    with pytest.raises(ValueError, match="a beams file has at most"):
        Spherical.from_beams(huge)


# E7 of the 2026-11-25 hostile-input report
def test_eval_with_beams_uses_the_beams_camera_and_zero_as_no_return(scan_file, beams_file,
                                                                    tmp_path, capsys):
    out = tmp_path / "g.glb"
    pytest.importorskip("trimesh")
    assert main(["mesh", str(scan_file), "--beams", str(beams_file), "--vertices", "2000",
                 "-o", str(out), "--json"]) == 0
    made = json.loads(capsys.readouterr().out)
    assert main(["eval", str(scan_file), str(out), "--beams", str(beams_file), "--json"]) == 0
    got = json.loads(capsys.readouterr().out)
    # eval of the file mesh wrote prints the figures mesh printed (GLB keeps float32 vertices)
    assert got["uncovered"] == pytest.approx(made["evaluation"]["uncovered"], abs=0.05)
    assert got["relative_error"] == pytest.approx(made["evaluation"]["relative_error"], rel=0.02)


# E12 of the 2026-11-25 hostile-input report
@pytest.mark.parametrize("mutation", [
    {"column_shift": [9223372036854775808] * 64},
    {"column_shift": [1e30] * 64},
    {"rows": float("inf")},
    {"cols": 1e400},
])
def test_overflowing_beams_values_are_one_line(os1, beams_file, tmp_path, capsys, mutation):
    beams = json.loads(beams_file.read_text())
    beams.update(mutation)
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(beams))
    assert main(["mesh", str(os1["bin"]), "--beams", str(bad), "--vertices", "200",
                 "-o", str(tmp_path / "x.ply")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err


# E12 of the 2026-11-25 hostile-input report
def test_deeply_nested_beams_json_is_one_line(scan_file, tmp_path, capsys):
    bad = tmp_path / "deep.json"
    bad.write_text("[" * 100_000 + "]" * 100_000)
    assert main(["mesh", str(scan_file), "--beams", str(bad), "--vertices", "200",
                 "-o", str(tmp_path / "x.ply")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot read it as a beams file" in err[0]


# E25 of the 2026-11-25 hostile-input report
@pytest.mark.parametrize("mutation, key", [
    ({"cols": "2048"}, "cols"),
    ({"cols": 2048.9}, "cols"),
    ({"azimuth_step_deg": "-0.17578125"}, "azimuth_step_deg"),
    ({"elevation_deg": ["1.0"] * 64}, "elevation_deg"),
    ({"rows": True}, "rows"),
    ({"rows": 63}, "rows"),
])
def test_beams_values_are_read_strictly(beams_file, mutation, key):
    beams = json.loads(beams_file.read_text())
    beams.update(mutation)
    with pytest.raises(ValueError, match=key):
        Spherical.from_beams(beams)


# E25 of the 2026-11-25 hostile-input report
@pytest.mark.parametrize("shift", [[1.5] * 64, [float("nan")] * 64, ["3"] * 64])
def test_column_shifts_are_whole_numbers(os1, beams_file, tmp_path, capsys, shift):
    beams = json.loads(beams_file.read_text())
    beams["column_shift"] = shift
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(beams))
    assert main(["mesh", str(os1["bin"]), "--beams", str(bad), "--vertices", "200",
                 "-o", str(tmp_path / "x.ply")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "column_shift" in err[0]


# E28 of the 2026-11-25 hostile-input report
def test_eval_reads_the_bin_scan_that_mesh_reads(os1, beams_file, tmp_path, capsys):
    scan = os1["bin"]
    out = tmp_path / "s.ply"
    assert main(["mesh", str(scan), "--beams", str(beams_file), "--vertices", "1000", "-o", str(out),
                 "--json"]) == 0
    made = json.loads(capsys.readouterr().out)
    assert main(["eval", str(scan), str(out), "--beams", str(beams_file), "--json"]) == 0
    got = json.loads(capsys.readouterr().out)
    assert got["relative_error"] == pytest.approx(made["evaluation"]["relative_error"], rel=1e-3)
    assert got["uncovered"] == pytest.approx(made["evaluation"]["uncovered"], abs=1e-6)


# E23 of the 2026-11-25 hostile-input report
def test_a_bin_of_huge_values_reads_quietly_as_no_return(tmp_path):
    path = tmp_path / "huge.bin"
    pts = np.full((2 * 64, 4), 3e38, "<f4")  # x, y, z at float32's top: the range overflows
    pts.tofile(path)
    with np.errstate(all="raise"):
        rng, _ = read_lidar_bin(path, 64, steps=2)
    assert rng.shape == (64, 2) and np.isinf(rng).all()
