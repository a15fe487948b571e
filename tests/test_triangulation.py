import numpy as np

from rangemesh import Orthographic, Pinhole, delaunay_mesh

from .helpers import assert_valid_mesh


def _grid_of(points):
    return np.array(points, np.int32).reshape(-1, 1, 2)


def test_square_of_four_points():
    depth = np.arange(100.0).reshape(10, 10)
    valid = np.ones_like(depth, bool)
    m = delaunay_mesh(_grid_of([(0, 0), (0, 9), (9, 0), (9, 9)]), depth, valid)
    assert_valid_mesh(m, valid)
    assert len(m.faces) == 2 and m.stats.edges == 5
    # vertices ordered by r*W + c, depth from the image, orthographic (1,1,1)
    assert m.pixels.tolist() == [[0, 0], [0, 9], [9, 0], [9, 9]]
    assert np.array_equal(m.vertices[:, 2], [0.0, 9.0, 90.0, 99.0])


def test_too_few_and_collinear_give_empty_meshes():
    depth = np.zeros((10, 10))
    valid = np.ones_like(depth, bool)
    m = delaunay_mesh(_grid_of([(0, 0), (5, 5)]), depth, valid)
    assert m.is_empty and "3" in m.stats.reason
    m = delaunay_mesh(_grid_of([(0, 0), (1, 1), (2, 2), (7, 7)]), depth, valid)
    assert m.is_empty and "collinear" in m.stats.reason
    assert_valid_mesh(m)


def test_background_barycentre_drops_triangle():
    depth = np.ones((11, 11))
    valid = np.ones_like(depth, bool)
    pts = [(0, 0), (0, 10), (10, 0), (10, 10), (5, 5)]
    full = delaunay_mesh(_grid_of(pts), depth, valid)
    assert len(full.faces) == 4
    # barycentre of (0,0),(0,10),(5,5) is (5/3, 5) -> pixel (2, 5)
    valid[2, 5] = False
    m = delaunay_mesh(_grid_of(pts), depth, valid)
    assert len(m.faces) == 3
    assert_valid_mesh(m, valid)


def test_bowtie_keeps_the_larger_fan():
    # Two fans meet only at the centre (5,5): three triangles on the left, two on the right.
    depth = np.ones((11, 11))
    valid = np.zeros_like(depth, bool)
    left = [(0, 0), (4, 0), (7, 0), (10, 0)]
    right = [(2, 10), (5, 10), (8, 10)]
    pts = [(5, 5)] + left + right
    for p in pts:
        valid[p] = True
    valid[2:8, 0:3] = True  # barycentres of the left fan: (3,2), (5,2), (7,2)
    valid[4:7, 8:11] = True  # barycentres of the right fan: (4,8), (6,8)
    m = delaunay_mesh(_grid_of(pts), depth, valid)
    assert_valid_mesh(m, valid)
    assert len(m.faces) == 3
    assert sorted(map(tuple, m.pixels.tolist())) == sorted([(5, 5)] + left)


def test_lonely_triangle_is_dropped():
    depth = np.ones((20, 20))
    valid = np.zeros_like(depth, bool)
    valid[0:4, 0:4] = True  # a small island
    valid[10:20, 10:20] = True
    pts = [(0, 0), (0, 3), (3, 0), (10, 10), (10, 19), (19, 10), (19, 19)]
    m = delaunay_mesh(_grid_of(pts), depth, valid)
    assert_valid_mesh(m, valid)
    assert m.pixels.min() >= 10  # the island's single triangle is gone


def test_cameras_lift_vertices():
    depth = np.full((5, 5), 2.0)
    valid = np.ones_like(depth, bool)
    g = _grid_of([(0, 0), (0, 4), (4, 0), (4, 4)])
    m = delaunay_mesh(g, depth, valid, Orthographic(2.0, 3.0, 5.0))
    assert m.vertices[3].tolist() == [8.0, 12.0, 10.0]
    m = delaunay_mesh(g, depth, valid, Pinhole(2.0, 4.0, 2.0, 2.0, 0.5))
    # Z = 1; X = (4-2)*1/2 = 1; Y = (4-2)*1/4 = 0.5
    assert m.vertices[3].tolist() == [1.0, 0.5, 1.0]
