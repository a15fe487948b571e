"""walls=False: greedy insertion drops the triangles that bridge depth jumps."""

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import rangemesh
from rangemesh import Spherical, evaluate, scenes, triangulate
from rangemesh.geometry.walls import wall_faces
from rangemesh.io import read_lidar_bin

from .helpers import assert_valid_mesh


def test_the_jump_rule_by_hand():
    # one triangle per case; its edge 0-1 decides (vertex 2 sits far away at the same depth
    # as vertex 0, along a long edge that is never a jump)
    def is_wall(z0, z1, length):
        pixels = np.array([[0, 0], [0, length], [100, 0]])
        return bool(wall_faces(np.array([[0, 1, 2]]), pixels, np.array([z0, z1, z0]), 0.05)[0])

    assert not is_wall(1.0, 1.04, 1)   # 4 % a pixel
    assert is_wall(1.0, 1.06, 1)       # 6 % a pixel
    assert not is_wall(1.0, 1.08, 2)   # 8 % over 2 pixels: 4 % a pixel
    assert is_wall(0.5, 0.6, 1)        # 10 cm at 0.5 m: 20 % a pixel
    assert not is_wall(4.0, 4.1, 2)    # 10 cm at 4 m over 2 pixels: 1.25 % a pixel
    assert is_wall(1.04, 1.0, 1) == is_wall(1.0, 1.04, 1)  # symmetric


@pytest.mark.parametrize("name", ["box", "stairs"])
def test_no_kept_triangle_spans_a_labelled_jump(name):
    sc = scenes.make(name, (80, 100))
    valid = np.ones(sc.depth.shape, bool)
    both = triangulate(sc.depth, vertices=600, method="refine")
    open_ = triangulate(sc.depth, vertices=600, method="refine", walls=False)
    assert_valid_mesh(open_, valid)
    assert len(open_.vertices) == 600  # insertion went on until 600 vertices are in use

    def spans(mesh):
        lab = sc.labels[mesh.pixels[:, 0], mesh.pixels[:, 1]][mesh.faces]
        return (lab != lab[:, :1]).any(axis=1)

    assert spans(both).any()       # with walls, jumps are bridged (so the test can fail)
    assert not spans(open_).any()  # without, never
    assert open_.stats.target.walls_dropped > 0
    # what goes uncovered is at most the jumps' own pixels
    grown = evaluate(open_, sc.depth).uncovered - evaluate(both, sc.depth).uncovered
    assert grown <= 100.0 * sc.discontinuities.mean()


def test_the_rule_is_the_same_in_any_depth_unit():
    # a pinhole frame in millimetres and in metres: the same walls, the same mesh
    sc = scenes.make("box", (60, 80))
    mm = sc.depth * 10.0  # ~1-2 m, in mm
    cam_mm = rangemesh.Pinhole(fx=80.0, fy=80.0, cx=40.0, cy=30.0, depth_scale=0.001)
    cam_m = rangemesh.Pinhole(fx=80.0, fy=80.0, cx=40.0, cy=30.0)
    a = triangulate(mm, camera=cam_mm, vertices=300, method="refine", walls=False)
    b = triangulate(mm / 1000.0, camera=cam_m, vertices=300, method="refine", walls=False)
    assert np.array_equal(a.faces, b.faces) and np.array_equal(a.pixels, b.pixels)
    assert a.stats.target.walls_dropped == b.stats.target.walls_dropped > 0


def test_walls_belong_to_greedy_insertion():
    depth = scenes.make("box", (30, 40)).depth
    with pytest.raises(ValueError, match="walls is an option of method='refine'"):
        triangulate(depth, walls=False, method="paper")
    with pytest.raises(ValueError, match="jump is an option of method='refine'"):
        triangulate(depth, jump=0.1, method="paper")
    with pytest.raises(ValueError, match="jump must be a positive"):
        triangulate(depth, vertices=50, method="refine", walls=False, jump=0.0)
    with pytest.raises(TypeError, match="walls"):
        triangulate(depth, vertices=50, method="refine", walls="no")


def test_command_line_no_walls(tmp_path, capsys):
    from rangemesh.cli import main

    src = tmp_path / "box.npy"
    np.save(src, scenes.make("box", (60, 80)).depth)
    out = tmp_path / "b.ply"
    assert main(["mesh", str(src), "--method", "refine", "--vertices", "200", "--no-walls",
                 "--jump", "0.1", "-o", str(out), "--quiet"]) == 0
    m = rangemesh.read_mesh(out)
    assert len(m.vertices) == 200
    assert main(["mesh", str(src), "--method", "paper", "--no-walls", "-o", str(out)]) == 2
    assert "--no-walls is an option of --method refine" in capsys.readouterr().err


@settings(deadline=None)
@given(st.integers(0, 2**31), st.sampled_from(sorted(scenes.SCENES)), st.floats(0, 0.5),
       st.integers(3, 400), st.floats(0.005, 0.5))
def test_meshes_without_walls_are_valid(seed, name, holes, n, jump):
    # random scenes with random holes and thresholds: what is left is a valid mesh (one fan
    # per vertex, no lone triangle), with no wall left in it
    rng = np.random.default_rng(seed)
    depth = scenes.make(name, (int(rng.integers(12, 60)), int(rng.integers(12, 60))),
                        noise=0.2).depth
    depth[rng.random(depth.shape) < holes] = np.nan
    m = triangulate(depth, vertices=n, method="refine", fill_gaps=False, walls=False, jump=jump,
                    heights="pixel")
    assert_valid_mesh(m, np.isfinite(depth))
    if not m.is_empty:
        z = depth[m.pixels[:, 0], m.pixels[:, 1]]
        assert not wall_faces(m.faces, m.pixels, z, jump).any()


@pytest.mark.parametrize("name", ["box", "stairs"])
@pytest.mark.parametrize("n", [150, 600])
def test_walls_are_at_most_a_pixel_wide_and_no_triangle_crosses_a_jump(name, n):
    # Noiseless jumps with known labels: greedy insertion puts vertices on both sides of each
    # jump, so a wall triangle (vertices on two surfaces) covers only pixels within 1 px of
    # a jump pixel, and no triangle covers a pixel of a surface none of its vertices is on.
    from scipy import ndimage

    from rangemesh.render import render_depth

    sc = scenes.make(name, (80, 100))
    m = triangulate(sc.depth, vertices=n)
    _, face = render_depth(m)
    covered = face >= 0
    vertex_labels = sc.labels[m.pixels[:, 0], m.pixels[:, 1]][m.faces][face[covered]]
    wall = (vertex_labels != vertex_labels[:, :1]).any(axis=1)
    assert wall.any()
    to_jump = ndimage.distance_transform_edt(~sc.discontinuities)[covered]
    assert to_jump[wall].max() <= 1.0
    assert (vertex_labels == sc.labels[covered][:, None]).any(axis=1).all()


@pytest.mark.parametrize(("name", "n"), [("crease", 40), ("pyramid", 80)])
def test_creases_get_vertices_on_the_crease_line(name, n):
    # planes meeting at creases (one line; a pyramid's four edges and its base outline): a few
    # dozen vertices on the crease lines make the mesh exact
    sc = scenes.make(name, (80, 100))
    m = triangulate(sc.depth, vertices=n)
    assert evaluate(m, sc.depth).max_error < 1e-9


@pytest.mark.parametrize("name", ["crease", "pyramid", "box"])
def test_vertices_beyond_an_exact_mesh_keep_it_exact(name):
    # Once a few dozen vertices make a piecewise-planar scene exact, more vertices go inside
    # the planes: they must never join two planes in one triangle (an unguarded Delaunay flip
    # across a crease did, on the pyramid at 69-79 vertices)
    sc = scenes.make(name, (80, 100))
    for n in range(70, 130):
        m = triangulate(sc.depth, vertices=n)
        assert len(m.vertices) == n
        assert evaluate(m, sc.depth).max_error < 1e-9, n


@pytest.mark.parametrize("n", [1000, 3000])
def test_depth_frame_without_walls(data_or_crops, n):
    # A Kinect frame in metres: no wall left, every vertex valid, one fan each; the count is N,
    # or a few short of it with a note when some vertices had only walls (flying pixels
    # between surfaces), never above (without the data folder: the frame's committed crop)
    from .images import load_or_crop

    z = load_or_crop(data_or_crops, "rgbd/open3d_TUM_depth.png")
    cam = rangemesh.Pinhole(525.0, 525.0, 319.5, 239.5, depth_scale=0.0002)
    m = triangulate(z, background=0, vertices=n, walls=False, camera=cam)
    valid = rangemesh.pipeline.prepare(z, rangemesh.MeshParams(), 0)[1]  # holes of 1 px filled
    assert_valid_mesh(m, valid, check_overlap=False)
    filled = rangemesh.pipeline.prepare(z, rangemesh.MeshParams(), 0)[0]
    depth = filled[m.pixels[:, 0], m.pixels[:, 1]] * 0.0002
    assert not wall_faces(m.faces, m.pixels, depth, 0.05).any()
    got = len(m.vertices)
    assert got == n or (0.99 * n <= got < n and "walls" in m.stats.target.note)
    assert m.stats.target.meshings <= 5


@pytest.mark.parametrize("kw", [{}, {"walls": False}, {"heights": "pixel"}])
def test_greedy_meshes_are_the_same_bit_for_bit_run_after_run(kw):
    # SPEC P6 for greedy insertion, the fit and the walls included
    sc = scenes.make("box", (60, 80), noise=0.5)
    a = triangulate(sc.depth, vertices=300, **kw)
    b = triangulate(sc.depth.copy(), vertices=300, **kw)
    assert np.array_equal(a.faces, b.faces) and np.array_equal(a.pixels, b.pixels)
    assert a.vertices.tobytes() == b.vertices.tobytes()


# ---------------------------------------------------------------- from the hostile-input reports


SCAN = "lidar/rellis3d_os1-64_000000"


def _os1_scan(shared_data):
    beams = shared_data / f"{SCAN}.beams.json"
    shift = json.loads(beams.read_text())["column_shift"]
    img, _ = read_lidar_bin(shared_data / f"{SCAN}.bin", 64, column_shift=shift)
    return img, Spherical.from_beams(beams)


# E23 of the 2026-11-25 hostile-input report
def test_a_huge_jump_is_quiet_and_drops_no_wall():
    z = np.ones((20, 30)) * 1e10
    z[:, 15:] = 2e10  # a jump of 1e10: a wall for any sensible jump rule
    with np.errstate(all="raise"):
        m = rangemesh.triangulate(z, vertices=60, walls=False, jump=1e308)
    assert m.stats.target.walls_dropped == 0


# E2 of the 2026-11-25 hostile-input report
@pytest.mark.parametrize("jump, vertices", [(0.01, 4000), (0.005, 800), (0.01, 800),
                                            (0.02, 800), (0.02, 4000), (0.02, 15000),
                                            (0.05, 4000)])
def test_walls_dropped_on_a_360_degree_scan_give_each_vertex_one_fan(shared_data, jump,
                                                                         vertices):
    from .helpers import assert_valid_mesh, canonical_faces

    img, cam = _os1_scan(shared_data)
    kw = {"background": 0, "camera": cam, "vertices": vertices, "walls": False, "jump": jump}
    mesh = rangemesh.triangulate(img, **kw)
    # before the fix (0.01, 4000): the vertex at pixel (63, 0) had two fans
    assert_valid_mesh(mesh, wrap=True, check_overlap=vertices <= 800)
    # the seam only adds faces: the open mesh's vertices and faces all stay
    open_ = rangemesh.triangulate(img, wrap=False, **kw)
    assert np.array_equal(mesh.pixels, open_.pixels)
    both = {tuple(t) for t in canonical_faces(mesh).tolist()}
    assert {tuple(t) for t in canonical_faces(open_).tolist()} <= both


# E2 of the 2026-11-25 hostile-input report
def test_seam_strips_keep_every_mesh_a_surface():
    from hypothesis import given, settings
    from hypothesis import strategies as st

    from .helpers import assert_valid_mesh

    # narrow images: faces across the whole width are common, and walls and holes at the seam
    @settings(max_examples=400, deadline=None)
    @given(st.integers(3, 14), st.integers(3, 12), st.integers(0, 2**32 - 1), st.booleans(),
           st.floats(0.0, 0.4), st.sampled_from([0.005, 0.01, 0.05, 0.2]),
           st.one_of(st.integers(3, 200).map(lambda n: {"vertices": n}),
                     st.sampled_from([0.1, 1.0, 5.0]).map(lambda e: {"max_error": e})))
    def check(h, w, seed, walls, holes, jump, target):
        rng = np.random.default_rng(seed)
        z = rng.uniform(10.0, 12.0, (h, w))
        for _ in range(rng.integers(0, 4)):  # blocks nearer or farther: walls at their edges
            r0, c0 = rng.integers(0, h), rng.integers(0, w)
            z[r0:r0 + rng.integers(1, h), c0:c0 + rng.integers(1, w)] *= rng.choice([0.5, 2.0])
        z[rng.random((h, w)) < holes] = 0.0
        if (z > 0).sum() < 3:
            return
        opts = {} if walls else {"walls": False, "jump": jump}
        mesh = rangemesh.triangulate(z, background=0, wrap=True, **opts, **target)
        assert_valid_mesh(mesh, wrap=True)

    check()
