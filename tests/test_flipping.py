import numpy as np

from rangemesh import MeshParams, Orthographic, delaunay_mesh, flip_edges
from rangemesh.mesh import Mesh, Stats, count_edges

from .helpers import assert_valid_mesh


def _quad_mesh(depth, pixels, faces):
    pixels = np.array(pixels, np.int32)
    verts = np.c_[pixels.astype(float), depth[pixels[:, 0], pixels[:, 1]]]
    return Mesh(verts, np.array(faces, np.int32), pixels, Orthographic(), depth.shape,
                Stats(vertices=len(pixels), triangles=len(faces), edges=count_edges(faces)))


def test_error_flip_on_a_single_quad_by_hand():
    # A roof along the anti-diagonal r + c = 4: depth = -|r + c - 4| * 3 on a 5x5 image.
    r, c = np.mgrid[0:5, 0:5]
    depth = -3.0 * np.abs(r + c - 4.0)
    valid = np.ones_like(depth, bool)
    # Quad (0,0), (0,4), (4,4), (4,0) split along the main diagonal (0,0)-(4,4),
    # which crosses the ridge; the other diagonal (0,4)-(4,0) lies on the ridge.
    pix = [(0, 0), (0, 4), (4, 0), (4, 4)]
    mesh = _quad_mesh(depth, pix, [[0, 3, 1], [0, 2, 3]])
    out = flip_edges(mesh, depth, valid, MeshParams(flips="error"))
    assert out.stats.flipped_edges == 1
    assert sorted(map(sorted, out.faces.tolist())) == [[0, 1, 2], [1, 2, 3]]
    assert_valid_mesh(out, valid)
    # The ridge diagonal has error 0: the gain of the original was E(main diagonal) > 0.
    # A flip never comes back (T1): running again changes nothing.
    again = flip_edges(out, depth, valid, MeshParams(flips="error"))
    assert again.stats.flipped_edges == 0


def test_disparity_flips_need_spans():
    # With only two triangles every span is empty: disparities are pi on both sides,
    # so test 2 rejects the flip.
    r, c = np.mgrid[0:5, 0:5]
    depth = -3.0 * np.abs(r + c - 4.0)
    valid = np.ones_like(depth, bool)
    mesh = _quad_mesh(depth, [(0, 0), (0, 4), (4, 0), (4, 4)], [[0, 3, 1], [0, 2, 3]])
    out = flip_edges(mesh, depth, valid, MeshParams(flips="disparity"))
    assert out.stats.flipped_edges == 0
    assert out.stats.flip_tests["t2_disparity_change"] == 1


def test_disparity_flip_aligns_with_a_ridge():
    # Two planes meet along the ridge r + c = 8 on a 9x9 image; a uniform 3x3 grid of
    # samples every 4 px. Delaunay diagonals that cross the ridge get flipped onto it.
    r, c = np.mgrid[0:9, 0:9]
    depth = 20.0 - 2.0 * np.abs(r + c - 8.0)
    valid = np.ones_like(depth, bool)
    grid = np.stack(np.meshgrid([0, 4, 8], [0, 4, 8], indexing="ij"), axis=-1)
    mesh = delaunay_mesh(grid, depth, valid)
    # every ridge pixel pair (0,8),(4,4),(8,0) must become edges
    out = flip_edges(mesh, depth, valid, MeshParams(flips="disparity"))
    assert_valid_mesh(out, valid)
    lin = {tuple(p): i for i, p in enumerate(out.pixels.tolist())}
    edges = {frozenset(e) for f in out.faces.tolist() for e in ((f[0], f[1]), (f[1], f[2]),
                                                                 (f[2], f[0]))}
    ridge = [(0, 8), (4, 4), (8, 0)]
    for a, b in zip(ridge, ridge[1:], strict=False):
        assert frozenset((lin[a], lin[b])) in edges
    from rangemesh import evaluate

    assert evaluate(out, depth).max_error < 1e-9  # the ridge is now exact


def test_flips_none_returns_input():
    r, c = np.mgrid[0:5, 0:5]
    depth = (r + c).astype(float)
    mesh = _quad_mesh(depth, [(0, 0), (0, 4), (4, 0), (4, 4)], [[0, 3, 1], [0, 2, 3]])
    assert flip_edges(mesh, depth, np.ones_like(depth, bool), MeshParams(flips=None)) is mesh
