"""The compiled half-edge kernels against plain-Python references written from their definitions."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import Delaunay

from rangemesh import _core


def _reference_halfedges(faces):
    """Twins by a dictionary of directed edges: a -> b pairs with b -> a."""
    tri = faces.reshape(-1)
    where = {(tri[e], tri[e - 2 if e % 3 == 2 else e + 1]): e for e in range(tri.size)}
    return np.array([where.get((b, a), -1) for (a, b) in
                     ((tri[e], tri[e - 2 if e % 3 == 2 else e + 1]) for e in range(tri.size))])


@st.composite
def meshes(draw):
    n = draw(st.integers(3, 60))
    seed = draw(st.integers(0, 2**32 - 1))
    pts = np.random.default_rng(seed).integers(0, 30, size=(n, 2)).astype(float)
    pts = np.unique(pts, axis=0)
    if len(pts) < 3 or np.linalg.matrix_rank(pts[1:] - pts[0]) < 2:
        return np.array([[0, 1, 2]], np.int64), 3
    return Delaunay(pts).simplices.astype(np.int64), len(pts)


@settings(max_examples=60, deadline=None)
@given(meshes())
def test_build_halfedges_pairs_each_edge_with_its_reverse(mesh):
    faces, n = mesh
    triangles, halfedges = _core.build_halfedges(faces, n)
    assert np.array_equal(triangles, faces.reshape(-1))
    assert np.array_equal(halfedges, _reference_halfedges(faces))


@settings(max_examples=60, deadline=None)
@given(meshes(), st.booleans())
def test_count_edges_counts_distinct_undirected_edges(mesh, flip_some):
    faces, n = mesh
    if flip_some:  # orientation must not matter
        faces = faces.copy()
        faces[::2] = faces[::2, ::-1]
    edges = {frozenset((int(f[k]), int(f[(k + 1) % 3]))) for f in faces for k in range(3)}
    assert _core.count_edges(faces, n) == len(edges)


@settings(max_examples=60, deadline=None)
@given(meshes())
def test_neighbors_name_the_triangle_across_the_opposite_edge(mesh):
    faces, n = mesh
    got = _core.neighbors_from_halfedges(_core.build_halfedges(faces, n)[1])
    for t, f in enumerate(faces):
        for k in range(3):
            edge = {f[(k + 1) % 3], f[(k + 2) % 3]}
            across = [u for u, g in enumerate(faces) if u != t and edge <= set(g)]
            assert got[t, k] == (across[0] if across else -1)


def test_two_triangles_by_hand():
    # 0-1-2 and 2-1-3 share the edge 1-2: half-edge 1 (1->2) twins half-edge 3 (2->1)
    faces = np.array([[0, 1, 2], [2, 1, 3]], np.int64)
    _, he = _core.build_halfedges(faces, 4)
    assert he.tolist() == [-1, 3, -1, 1, -1, -1]
    assert _core.count_edges(faces, 4) == 5
    assert _core.neighbors_from_halfedges(he).tolist() == [[1, -1, -1], [-1, -1, 0]]


def test_wrong_dtypes_are_converted_and_wrong_shapes_refused():
    faces = np.array([[0, 1, 2]], np.int32)
    assert _core.count_edges(faces, 3) == 3
    with pytest.raises(TypeError):
        _core.count_edges(np.array([0, 1, 2]), 3)
