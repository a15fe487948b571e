"""The compiled half-edge kernels against plain-Python references written from their definitions."""

import math
import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import ConvexHull, Delaunay

import rangemesh
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


# --- pixels ------------------------------------------------------------------------------

@pytest.mark.parametrize("dtype", [np.int8, np.int16, np.int32, np.int64, np.uint8, np.uint16,
                                   np.uint32, np.uint64, np.float32, np.float64])
def test_mask_image_follows_numpys_rules_for_every_dtype(dtype):
    rng = np.random.default_rng(7)
    arr = rng.integers(0, 9, (13, 17)).astype(dtype)
    if np.dtype(dtype).kind == "f":
        arr[rng.random(arr.shape) < 0.2] = np.nan
        arr[0, 0], arr[0, 1] = np.inf, -np.inf
    else:  # the type's own ends, which a marker may name
        info = np.iinfo(dtype)
        arr[0, 0], arr[0, 1] = info.min, info.max
    ends = () if np.dtype(dtype).kind == "f" else (float(np.iinfo(dtype).min), float(np.iinfo(dtype).max))
    # markers no value of the type equals (3.5, -1 for unsigned, beyond the type) match nothing
    for bg in (None, 3, 2**64 - 1, 3.5, -1, 0.0, -0.0, 1e300, *ends):
        depth = np.full(arr.shape, -1.0)
        valid = np.zeros(arr.shape, bool)
        _core.mask_image(arr, bg is not None, 0.0 if bg is None else float(bg), depth, valid)
        want = np.isfinite(arr.astype(np.float64))
        if bg is not None:
            want &= arr.astype(np.float64) != float(bg)
        assert np.array_equal(valid, want)
        assert np.array_equal(depth, np.where(want, arr.astype(np.float64), 0.0))


@pytest.mark.parametrize("dtype", [np.int8, np.int16, np.int32, np.int64, np.uint8, np.uint16,
                                   np.uint32, np.uint64])
@pytest.mark.parametrize("shape", [(0, 0), (0, 3), (1, 1), (2, 2), (3, 70)])
def test_mask_image_markers_at_the_limits_of_integer_types(dtype, shape):
    # the marker compared as the image's own type must equal NumPy's float64 comparison, at the
    # type's limits, just past them, and for markers no value of the type equals
    info = np.iinfo(dtype)
    ends = [float(info.min), float(info.max)]
    values = np.array([info.min, info.max, info.min + 1, info.max - 1, 0], dtype)
    arr = np.random.default_rng(3).choice(values, size=shape)
    past = [e + d for e in ends for d in (-1.0, 1.0, -0.5, 0.5)]
    for bg in ends + past + [2.0**63, 2.0**64, np.nan, np.inf]:
        depth = np.full(shape, -1.0)
        valid = np.zeros(shape, bool)
        _core.mask_image(arr, True, bg, depth, valid)
        want = arr.astype(np.float64) != bg
        assert np.array_equal(valid, want), bg
        assert np.array_equal(depth, np.where(want, arr.astype(np.float64), 0.0)), bg


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 20), st.integers(1, 20), st.floats(0, 1))
def test_valid_range_and_covered_error_by_plain_loops(seed, h, w, share):
    rng = np.random.default_rng(seed)
    depth = rng.normal(0, 100, (h, w))
    valid = rng.random((h, w)) < share
    pred = depth + rng.normal(0, 1, (h, w))
    pred[rng.random((h, w)) < 0.3] = np.nan
    pred[0, 0] = np.inf
    inside = depth[valid].tolist()
    want = (min(inside), max(inside), len(inside)) if inside else (0.0, 0.0, 0)
    got = _core.valid_range(depth, valid)
    assert (got.lo, got.hi, got.count) == want
    # unpacked through __iter__: by __getitem__ it ended in an IndexError thrown in C++ (fixed44)
    assert "__iter__" in vars(type(got)) and tuple(got) == want
    total, n = 0.0, 0  # the same row-major order of additions
    for r in range(h):
        for c in range(w):
            if valid[r, c] and np.isfinite(pred[r, c]):
                total += abs(float(pred[r, c]) - float(depth[r, c]))
                n += 1
    got = _core.covered_error(pred, depth, valid)
    assert (got.total, got.count) == (total, n)


def _range_in_order(depth, valid):
    """valid_range by its definition: one pixel after another, strict compares (a zero's sign)."""
    lo, hi, n = math.inf, -math.inf, 0
    for x, ok in zip(depth.ravel().tolist(), valid.ravel().tolist(), strict=True):
        if ok:
            n += 1
            lo = x if x < lo else lo
            hi = x if x > hi else hi
    return (lo, hi, n) if n else (0.0, 0.0, 0)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 6), st.integers(1, 11))
def test_valid_range_signed_zeros_infinities_and_nan_as_the_plain_loop(seed, h, w):
    # the range is taken in lanes: a zero bound's sign, infinities and NaN (which no compare
    # passes) must come out as one pass in order has them, on widths that are no multiple of 4
    rng = np.random.default_rng(seed)
    depth = rng.choice([0.0, -0.0, 1.5, -2.0, np.inf, -np.inf, np.nan], (h, w))
    valid = rng.random((h, w)) < 0.8
    got = _core.valid_range(depth, valid)
    want = _range_in_order(depth, valid)
    assert [(float(x), math.copysign(1.0, x)) for x in (got.lo, got.hi)] + [got.count] == \
        [(x, math.copysign(1.0, x)) for x in want[:2]] + [want[2]]


def test_valid_range_zero_sign_by_hand():
    # the first zero in scan order (column 1, -0.0) is the lower bound, not a later one (column 4,
    # 0.0, which a lane holding columns 0 and 4 would give); the same for the upper bound
    depth = np.array([[5.0, -0.0, 5.0, 5.0, 0.0]])
    got = _core.valid_range(depth, np.ones(depth.shape, bool))
    assert (math.copysign(1.0, got.lo), got.hi, got.count) == (-1.0, 5.0, 5)
    got = _core.valid_range(-depth, np.ones(depth.shape, bool))
    assert (got.lo, math.copysign(1.0, got.hi)) == (-5.0, 1.0)


# --- fans ------------------------------------------------------------------------------------

def test_prune_dangling_by_hand():
    # a bow tie at vertex 2: fan {0, 1} (triangles 0-1-2 and 1-3-2 share the edge 1-2) and
    # fan {2} (2-4-5), whose triangle shares edge 4-5 with triangle 3 (5-4-6). The smaller fan
    # goes; triangle 3, left with no neighbour, goes in the next round.
    simplices = np.array([[0, 1, 2], [1, 3, 2], [2, 4, 5], [5, 4, 6]], np.int64)
    neighbors = np.array([[1, -1, -1], [-1, 0, -1], [3, -1, -1], [-1, -1, 2]], np.int64)
    alive = np.ones(4, bool)
    assert _core.prune_dangling(simplices, neighbors, alive, 7) == 2
    assert alive.tolist() == [True, True, False, False]
    # a tie: two fans of one triangle each at vertex 0; the one holding corner slot 0 stays
    simplices = np.array([[0, 1, 2], [0, 3, 4], [1, 5, 2], [3, 6, 4]], np.int64)
    neighbors = np.array([[2, -1, -1], [3, -1, -1], [-1, 0, -1], [-1, 1, -1]], np.int64)
    alive = np.ones(4, bool)
    assert _core.prune_dangling(simplices, neighbors, alive, 7) == 2
    assert alive.tolist() == [True, False, True, False]


def _random_delaunay(draw, most, side):
    """``(rng, points, faces)``: Delaunay of 3 to `most` points of a `side` grid, or None (collinear)."""
    n = draw(st.integers(3, most))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    pts = np.unique(rng.integers(0, side, size=(n, 2)), axis=0)
    if len(pts) < 3 or np.linalg.matrix_rank(pts[1:] - pts[0]) < 2:
        return None
    return rng, pts, Delaunay(pts.astype(float)).simplices.astype(np.int64)


@st.composite
def live_meshes(draw):
    drawn = _random_delaunay(draw, 40, 9)
    if drawn is None:
        return None
    rng, pts, faces = drawn
    _, he = _core.build_halfedges(np.ascontiguousarray(faces), len(pts))
    alive = rng.random(len(faces)) > draw(st.floats(0, 0.7))
    return faces, _core.neighbors_from_halfedges(he), alive, len(pts)


@settings(max_examples=60, deadline=None)
@given(live_meshes())
def test_prune_dangling_equals_the_definition(mesh):
    from .reference import prune_dangling

    if mesh is None:
        return
    faces, neighbors, alive, n = mesh
    want, removed = prune_dangling(faces, neighbors, alive, n)
    got = alive.copy()
    assert _core.prune_dangling(faces, neighbors, got, n) == removed
    assert np.array_equal(got, want)


@st.composite
def cut_triangulations(draw):
    """A Delaunay triangulation with some triangles cut away: its faces and twins (build_halfedges)."""
    drawn = _random_delaunay(draw, 60, 12)
    if drawn is None:
        return None
    rng, pts, faces = drawn
    faces = np.ascontiguousarray(faces[rng.random(len(faces)) > draw(st.floats(0, 0.8))])
    if len(faces) == 0:
        return None
    triangles, he = _core.build_halfedges(faces, len(pts))
    return faces, triangles, he, len(pts)


@settings(max_examples=150, deadline=None)
@given(cut_triangulations())
def test_prune_cut_fans_drops_what_prune_dangling_drops(mesh):
    # the border-walking pruning the assembly uses against the round-by-round definition
    if mesh is None:
        return
    faces, triangles, he, n = mesh
    want = np.ones(len(faces), bool)
    removed = _core.prune_dangling(faces, _core.neighbors_from_halfedges(he), want, n, drop_lone=False)
    got = np.zeros(len(faces), bool)
    assert _core.prune_cut_fans(triangles, he, got, n) == removed
    assert np.array_equal(got, want)


def test_prune_cut_fans_by_hand():
    # a bow tie at vertex 2 (fans {0, 1} and {2}, triangle 3 beside 2): the smaller fan goes, and
    # triangle 3, left alone, stays (lone triangles are kept); a tie of one-triangle fans at
    # vertex 0 keeps the one holding corner slot 0, and triangle 3 beside the dropped one stays
    faces = np.array([[0, 1, 2], [1, 3, 2], [2, 4, 5], [5, 4, 6]], np.int64)
    triangles, he = _core.build_halfedges(faces, 7)
    alive = np.zeros(4, bool)
    assert _core.prune_cut_fans(triangles, he, alive, 7) == 1
    assert alive.tolist() == [True, True, False, True]
    faces = np.array([[0, 1, 2], [0, 3, 4], [1, 5, 2], [3, 6, 4]], np.int64)
    triangles, he = _core.build_halfedges(faces, 7)
    alive = np.zeros(4, bool)
    assert _core.prune_cut_fans(triangles, he, alive, 7) == 1
    assert alive.tolist() == [True, False, True, True]
    with pytest.raises(ValueError, match="prune_cut_fans"):
        _core.prune_cut_fans(triangles, np.zeros_like(he), alive, 7)


# --- Delaunay -------------------------------------------------------------------------------

@settings(max_examples=80, deadline=None)
@given(st.lists(st.tuples(st.integers(-6, 6), st.integers(-6, 6)), min_size=3, max_size=40, unique=True))
def test_delaunay_sweep_is_delaunay_by_brute_force(pts):
    from .reference import delaunay_violations

    pr = np.array([p[0] for p in pts], np.int64)
    pc = np.array([p[1] for p in pts], np.int64)
    triangles, halfedges = _core.delaunay_sweep(pr, pc)
    if np.linalg.matrix_rank(np.c_[pr - pr[0], pc - pc[0]]) < 2:
        assert len(triangles) == 0 and len(halfedges) == 0
        return
    assert delaunay_violations(pr, pc, triangles) == []
    assert np.array_equal(halfedges, _reference_halfedges(triangles.reshape(-1, 3)))
    assert _core.legalize_all(triangles.copy(), halfedges.copy(), pr, pc) == 0


def test_delaunay_sweep_of_more_points_than_one_sorted_run():
    # 65536 points make one run of the distance sort; 3 runs and a short one are merged here.
    # Checked from the definition in exact integers: counter-clockwise triangles that use every
    # point, twins that pair reversed edges, areas that sum to the convex hull's (SciPy), and
    # no point strictly inside the circle of the triangle across an edge. Many points of a
    # pixel grid are co-circular, so SciPy's own triangulation may differ on such ties.
    side = 16384  # the predicates' exact range
    rng = np.random.default_rng(11)
    idx = rng.choice(side * side, size=3 * 65536 + 5, replace=False)
    pr, pc = idx // side, idx % side
    triangles, halfedges = _core.delaunay_sweep(pr, pc)
    t = triangles.reshape(-1, 3)
    r, c = pr[t], pc[t]
    area2 = (r[:, 1] - r[:, 0]) * (c[:, 2] - c[:, 0]) - (c[:, 1] - c[:, 0]) * (r[:, 2] - r[:, 0])
    assert (area2 > 0).all()
    assert np.array_equal(np.unique(triangles), np.arange(len(pr)))
    hull = ConvexHull(np.c_[pr, pc].astype(float)).vertices
    hr, hc = pr[hull], pc[hull]
    assert area2.sum() == abs(int((hr * np.roll(hc, -1) - np.roll(hr, -1) * hc).sum()))
    e = np.flatnonzero(halfedges >= 0)
    twin = halfedges[e]
    nxt = e - e % 3 + (e + 1) % 3
    assert np.array_equal(halfedges[twin], e)
    assert np.array_equal(triangles[twin], triangles[nxt])
    far = triangles[twin - twin % 3 + (twin + 2) % 3]  # the twin's corner off the edge
    dr, dc = pr[far], pc[far]
    a = t[e // 3]
    adr, adc = pr[a] - dr[:, None], pc[a] - dc[:, None]
    lift = adr * adr + adc * adc
    det = (adr[:, 0] * (adc[:, 1] * lift[:, 2] - lift[:, 1] * adc[:, 2])
           - adc[:, 0] * (adr[:, 1] * lift[:, 2] - lift[:, 1] * adr[:, 2])
           + lift[:, 0] * (adr[:, 1] * adc[:, 2] - adc[:, 1] * adr[:, 2]))
    assert (det <= 0).all()


def test_the_exact_span_keeps_incircle_within_int64():
    # |incircle| <= 12 D^4 for coordinate differences up to D (three terms of D * 4 D^3)
    assert 12 * _core.EXACT_SPAN**4 < 2**63
    assert 12 * 29_609**4 < 2**63 <= 12 * 29_610**4


def test_delaunay_sweep_is_exact_at_the_full_span():
    # Points near one circle as wide as the span (in-circle determinants near their largest and
    # near 0), the span's corners and random points: the empty-circle property holds, checked
    # in Python's unbounded integers.
    side = _core.EXACT_SPAN
    rng = np.random.default_rng(5)
    angles = np.sort(rng.random(3000)) * 2 * np.pi
    ring = np.c_[np.rint(side / 2 + side / 2 * np.cos(angles)), np.rint(side / 2 + side / 2 * np.sin(angles))]
    pts = np.unique(np.r_[ring, [[0, 0], [0, side], [side, 0], [side, side]],
                          rng.integers(0, side + 1, (2000, 2))].astype(np.int64), axis=0)
    pr, pc = pts[:, 0].copy(), pts[:, 1].copy()
    triangles, halfedges = _core.delaunay_sweep(pr, pc)
    assert len(np.unique(triangles)) == len(pr)
    P = [(int(a), int(b)) for a, b in zip(pr, pc, strict=True)]

    def incircle(a, b, c, d):
        (ar, ac), (br, bc), (cr, cc), (dr, dc) = P[a], P[b], P[c], P[d]
        adr, adc, bdr, bdc, cdr, cdc = ar - dr, ac - dc, br - dr, bc - dc, cr - dr, cc - dc
        ad, bd, cd = adr * adr + adc * adc, bdr * bdr + bdc * bdc, cdr * cdr + cdc * cdc
        return adr * (bdc * cd - bd * cdc) - adc * (bdr * cd - bd * cdr) + ad * (bdr * cdc - bdc * cdr)

    for e in np.flatnonzero(halfedges >= 0):
        t = int(halfedges[e])
        f = e - e % 3
        far = int(triangles[t - t % 3 + (t + 2) % 3])
        assert incircle(*(int(x) for x in triangles[f:f + 3]), far) <= 0


def test_points_beyond_the_exact_span_are_refused():
    side = _core.EXACT_SPAN + 1
    with pytest.raises(ValueError, match="EXACT_SPAN"):
        _core.delaunay_sweep(np.array([0, 0, side]), np.array([0, 5, 0]))
    with pytest.raises(ValueError, match="tiles"):
        rangemesh.triangulate(np.ones((2, side + 1)), vertices=4)
    with pytest.raises(ValueError, match="tiles"):
        rangemesh.triangulate(np.ones((side + 1, 2)), method="paper")
    assert len(rangemesh.triangulate(np.ones((2, side)), vertices=4).vertices) == 4


def test_cocircular_ties_go_by_simulation_of_simplicity():
    # The unit square's corners are co-circular. Perturbed lifting with eps^i, the smallest id
    # highest: point 0 lifts above the others' plane, so the lower hull is the triangle of the
    # other three plus one through 0, and the diagonal avoids point 0.
    for order in ([(0, 0), (0, 1), (1, 0), (1, 1)], [(0, 1), (0, 0), (1, 1), (1, 0)]):
        pr = np.array([p[0] for p in order], np.int64)
        pc = np.array([p[1] for p in order], np.int64)
        triangles, _ = _core.delaunay_sweep(pr, pc)
        faces = [set(f) for f in triangles.reshape(-1, 3)]
        assert len(faces) == 2 and faces[0] & faces[1] == {1, 2}  # in both orders, ids 1 and 2


def test_legalize_all_flips_a_bad_diagonal_by_hand():
    # A kite (0, 0), (2, -1), (4, 0), (2, 1) cut along its long diagonal 0-2: the circle
    # through 0, 1, 2 (centre (2, 1.5), radius^2 6.25) holds point 3, so one flip gives 1-3.
    pr = np.array([0, 2, 4, 2], np.int64)
    pc = np.array([0, -1, 0, 1], np.int64)
    faces = np.array([[0, 1, 2], [0, 2, 3]], np.int64)
    assert [np.sign((pr[b] - pr[a]) * (pc[c] - pc[a]) - (pc[b] - pc[a]) * (pr[c] - pr[a]))
            for a, b, c in faces] == [1, 1]
    triangles, halfedges = _core.build_halfedges(faces, 4)
    assert _core.legalize_all(triangles, halfedges, pr, pc) == 1
    assert sorted(sorted(triangles[3 * t:3 * t + 3].tolist()) for t in range(2)) == [[0, 1, 3], [1, 2, 3]]
    assert _core.legalize_all(triangles, halfedges, pr, pc) == 0


# --- the canonical face order ---------------------------------------------------------------

@settings(max_examples=60, deadline=None)
@given(meshes(), st.integers(0, 2**32 - 1))
def test_canonical_faces_are_numpys_rotation_and_lexsort(mesh, seed):
    # the definition in NumPy: each face from its smallest corner (argmin, turn kept), then the
    # faces in lexicographic order (a stable lexsort); faces shuffled, and some repeated
    faces, n = mesh
    rng = np.random.default_rng(seed)
    faces = np.concatenate([faces, faces[rng.integers(0, len(faces), size=len(faces) // 3)]])
    faces = faces[rng.permutation(len(faces))]
    k = np.argmin(faces, axis=1)
    rotated = np.take_along_axis(faces, (k[:, None] + np.arange(3)) % 3, axis=1)
    want = rotated[np.lexsort((rotated[:, 2], rotated[:, 1], rotated[:, 0]))]
    got = _core.canonical_faces(np.ascontiguousarray(faces).reshape(-1), n)
    assert got.dtype == np.int64 and np.array_equal(got, want)


def test_canonical_faces_by_hand():
    # (5, 2, 7) starts at 2: (2, 7, 5); (3, 1, 4) at 1: (1, 4, 3); (9, 2, 0) at 0: (0, 9, 2)
    got = _core.canonical_faces(np.array([5, 2, 7, 3, 1, 4, 9, 2, 0], np.int64), 10)
    assert got.tolist() == [[0, 9, 2], [1, 4, 3], [2, 7, 5]]


@settings(max_examples=40, deadline=None)
@given(meshes())
def test_int32_faces_give_what_int64_faces_give(mesh):
    faces, n = mesh
    faces32 = faces.astype(np.int32)
    for a, b in zip(_core.build_halfedges(faces, n), _core.build_halfedges(faces32, n), strict=True):
        assert np.array_equal(a, b)
    assert _core.count_edges(faces32, n) == _core.count_edges(faces, n)


# ---------------------------------------------------------------- from the hostile-input reports


E19_CHILD = """
import resource
import numpy as np
from rangemesh import _core
faces = np.zeros((4_000_000, 3), np.int64)  # 96 MB, allocated before the limit
with open("/proc/self/status") as f:
    vm = next(int(line.split()[1]) for line in f if line.startswith("VmSize:")) * 1024
# 48 MB more address space: the kernel's 96 MB of half-edge ids cannot be had
resource.setrlimit(resource.RLIMIT_AS, (vm + (48 << 20), resource.RLIM_INFINITY))
try:
    _core.build_halfedges(faces, 1)
except MemoryError as e:
    print(e)
"""


# E19 of the 2026-11-25 hostile-input report
@pytest.mark.skipif("libasan" in os.environ.get("LD_PRELOAD", ""),
                    reason="ASan maps terabytes of shadow memory: no address-space limit fits it")
def test_an_allocation_failure_in_the_core_says_not_enough_memory():
    # A real allocation failure, in a child held to a little more address space than it has.
    # (Raw counts beyond the image no longer reach an allocation: greedy_insert's room for
    # 2**61 vertices, the trigger this test had, is clamped to the pixels; issue 40, F6.)
    done = subprocess.run([sys.executable, "-c", E19_CHILD], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.startswith("not enough memory: the compiled core could not"), done.stdout
