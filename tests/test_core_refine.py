"""The compiled greedy insertion (`rangemesh._core.greedy_insert`) against plain-Python references.

The references are written from the method's definition, not from the kernel:
a triangle's pixels are those inside it or on an edge it owns (a hull edge,
or a shared edge whose end is later in row-then-column order); its error sum
is sum |depth - plane| over them, the plane solved by NumPy; its key is
``quantize(sqrt(worst error * sum / pixels))`` in units of 2**-32 of the
depth range, its worst pixel the first in row-major order with the largest
quantized error; each step inserts the pixel of the triangle with the
largest key, and the mesh stays Delaunay (no vertex inside the circle of a
triangle across an edge). Small noisy images keep every triangle inexact, so
none of the exact-fit shortcuts apply and keys do not tie.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rangemesh import _core, threads
from rangemesh._core import InsertSettings, valid_range
from rangemesh.refine import insertion

STEPS = 2.0**32


def _orient(ar, ac, br, bc, pr, pc):
    return (br - ar) * (pc - ac) - (bc - ac) * (pr - ar)


def _owned_pixels(tri, he, t, vr, vc):
    """The pixels of triangle t by the ownership rule, from its bounding box."""
    corners = [(int(vr[v]), int(vc[v])) for v in tri[3 * t: 3 * t + 3]]
    own = []
    for k in range(3):
        (ar, ac), (br, bc) = corners[k], corners[(k + 1) % 3]
        own.append(he[3 * t + k] < 0 or br > ar or (br == ar and bc > ac))
    rows = [p[0] for p in corners]
    cols = [p[1] for p in corners]
    out = []
    for r in range(min(rows), max(rows) + 1):
        for c in range(min(cols), max(cols) + 1):
            ok = True
            for k in range(3):
                (ar, ac), (br, bc) = corners[k], corners[(k + 1) % 3]
                w = _orient(ar, ac, br, bc, r, c)
                ok &= w > 0 or (w == 0 and own[k])
            if ok:
                out.append((r, c))
    return corners, out


def _plane_errors(corners, depth, pixels):
    """|depth - plane| at each pixel, the plane through the corners' depths (NumPy's solve)."""
    a = np.array([[r, c, 1.0] for r, c in corners])
    coef = np.linalg.solve(a, np.array([depth[r, c] for r, c in corners]))
    return [abs(depth[r, c] - (coef[0] * r + coef[1] * c + coef[2])) for r, c in pixels]


def _reference_key(corners, errors, pixels, span, n_pixels):
    """The key of a triangle and its pixel to insert, from its pixels' errors."""
    best, best_err, best_px = -1.0, 0.0, None
    for (r, c), e in zip(pixels, errors, strict=True):
        if (r, c) in corners:
            continue
        q = math.floor(e / span * STEPS + 0.5)
        if q > best:  # the first pixel in row-major order with the largest key
            best, best_err, best_px = q, e, (r, c)
    if best <= 0:
        return best, best_px
    key = math.floor(math.sqrt(best_err * sum(errors) / n_pixels) / span * STEPS + 0.5)
    return max(key, 0.5), best_px


@st.composite
def noisy_images(draw):
    h = draw(st.integers(3, 11))
    w = draw(st.integers(3, 11))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    r, c = np.mgrid[:h, :w]
    depth = 0.3 * r - 0.2 * c + rng.normal(size=(h, w)) + 5.0 * (c > w // 2)
    return depth, np.ones((h, w), bool)


def _insert(depth, valid, n, sums=False, scales=(1, 1)):
    lo, hi, _ = valid_range(depth, valid)
    start = insertion.first_mesh(depth, valid, 0, scales)
    request = InsertSettings(n, -1.0, float(hi - lo), *scales, sums=sums)
    return _core.greedy_insert(depth, valid, start, request), float(hi - lo)


@settings(max_examples=40, deadline=None)
@given(noisy_images(), st.integers(0, 30))
def test_each_step_inserts_the_pixel_of_the_largest_key(image, extra):
    depth, valid = image
    n = min(4 + extra, depth.size - 1)
    out, span = _insert(depth, valid, n, sums=True)
    vr, vc, tri, he, tsum = out.vr, out.vc, out.tv, out.he, out.tsum
    ranked = []
    for t in range(len(tri) // 3):
        corners, pixels = _owned_pixels(tri, he, t, vr, vc)
        errors = _plane_errors(corners, depth, pixels)
        # the kernel's running sums are the sums over each triangle's own pixels
        assert tsum[t] == pytest.approx(sum(errors), rel=1e-9, abs=1e-9)
        key, px = _reference_key(corners, errors, pixels, span, depth.size)
        ranked.append((key, px))
    # every pixel but the vertices belongs to exactly one triangle (a vertex on the border
    # between two hull edges is on owned edges of both its triangles; its error is ~0)
    corners = set(zip(vr.tolist(), vc.tolist(), strict=True))
    owned = [p for t in range(len(tri) // 3) for p in _owned_pixels(tri, he, t, vr, vc)[1]
             if p not in corners]
    assert sorted(owned) == [(r, c) for r in range(depth.shape[0]) for c in range(depth.shape[1])
                             if (r, c) not in corners]
    keys = sorted(k for k, _ in ranked)
    if keys[-1] <= 0 or (len(keys) > 1 and keys[-1] == keys[-2]):
        return  # nothing to insert, or a tie the definition leaves to the triangles' ids
    best = max(ranked, key=lambda kp: kp[0])[1]
    more = _insert(depth, valid, n + 1)[0]
    vr2, vc2 = more.vr, more.vc
    assert len(vr2) == len(vr) + 1
    assert (vr2[-1], vc2[-1]) == best


@settings(max_examples=40, deadline=None)
@given(noisy_images(), st.integers(0, 40), st.sampled_from([(1, 1), (2, 1), (1, 3)]))
def test_the_mesh_is_delaunay_in_the_scaled_units(image, extra, scales):
    depth, valid = image
    out = _insert(depth, valid, 4 + extra, sums=True, scales=scales)[0]
    vr, vc, tri, he = out.vr, out.vc, out.tv, out.he
    sr, sc = scales
    for e in range(len(tri)):
        f = he[e]
        if f < 0:
            continue
        a, b, c = tri[e], tri[e - 2 if e % 3 == 2 else e + 1], tri[e + 2 if e % 3 == 0 else e - 1]
        d = tri[f + 2 if f % 3 == 0 else f - 1]  # the far corner across a -> b
        # the far corner is not strictly inside the circle through a, b, c (exact integers)
        m = [[sr * vr[v] - sr * vr[d], sc * vc[v] - sc * vc[d]] for v in (a, b, c)]
        det = sum(m[i][0] * (m[(i + 1) % 3][1] * (m[(i + 2) % 3][0] ** 2 + m[(i + 2) % 3][1] ** 2)
                             - m[(i + 2) % 3][1] * (m[(i + 1) % 3][0] ** 2 + m[(i + 1) % 3][1] ** 2))
                  for i in range(3))
        assert int(det) <= 0, (e, scales)


def test_a_spike_is_inserted_first():
    """A plane with one pixel raised: the corners fit the rest exactly, the spike goes first."""
    r, c = np.mgrid[:7, :9]
    depth = 0.5 * r + 0.25 * c
    depth[2, 6] += 3.0
    valid = np.ones_like(depth, bool)
    out, span = _insert(depth, valid, 5)
    vr, vc, tv, n_valid, total = out.vr, out.vc, out.tv, out.valid_vertices, out.total
    assert (vr[-1], vc[-1]) == (2, 6) and n_valid == 5
    assert len(tv) == 3 * 4  # the spike inside a triangle: 2 -> 4 triangles
    # the summed error is that of the planes through the new triangles, over their own pixels
    out = _insert(depth, valid, 5, sums=True)[0]
    vr, vc, tri, he = out.vr, out.vc, out.tv, out.he
    expected = 0.0
    for t in range(4):
        corners, pixels = _owned_pixels(tri, he, t, vr, vc)
        expected += sum(_plane_errors(corners, depth, pixels))
    assert expected > 1.0 and total == pytest.approx(expected)


@settings(max_examples=80, deadline=None)
@given(st.integers(5, 14), st.integers(5, 14), st.integers(0, 2**32 - 1),
       st.sampled_from([0.1, 0.4, 0.8]))
def test_a_background_corner_is_covered_by_the_valid_pixel_farthest_from_its_opposite_edge(
        h, w, seed, density):
    # Missing depth at the image's corners and in specks: each of the two first triangles, every
    # corner background, is keyed by its valid pixel of the largest background-corner weight
    # (barycentric, exact integers; the first in row-major order among equals), and the first
    # insertion takes that of the triangle whose key, 1 + weight / area cover keys, is larger.
    rng = np.random.default_rng(seed)
    valid = rng.random((h, w)) < density
    for r, c in ((0, 0), (h - 1, 0), (h - 1, w - 1), (0, w - 1)):
        valid[r, c] = False
    depth = 1.0 + rng.random((h, w))
    vr = np.array([0, h - 1, h - 1, 0], np.int64)
    vc = np.array([0, 0, w - 1, w - 1], np.int64)
    tv = np.array([0, 1, 2, 0, 2, 3], np.int64)
    he = np.array([-1, -1, 3, 2, -1, -1], np.int64)
    ranked = []
    for t in range(2):
        corners, pixels = _owned_pixels(tv, he, t, vr, vc)
        (ar, ac), (br, bc), (cr, cc) = corners
        best, best_px = -1, None
        for r, c in pixels:  # row-major
            if not valid[r, c]:
                continue
            weight = max(_orient(br, bc, cr, cc, r, c), _orient(cr, cc, ar, ac, r, c),
                         _orient(ar, ac, br, bc, r, c))
            if weight > best:
                best, best_px = weight, (r, c)
        if best_px is not None:
            ranked.append((best / _orient(ar, ac, br, bc, cr, cc), best_px))
    if not ranked or (len(ranked) == 2 and ranked[0][0] == ranked[1][0]):
        return  # no valid pixel, or a tie the definition leaves to the triangles' ids
    out = _core.greedy_insert(depth, valid, (vr, vc, np.ones(4), tv, he), InsertSettings(1, -1.0, 1.0))
    assert (out.vr[4], out.vc[4]) == max(ranked)[1]


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([0.05, 0.3, 0.9, 3.0]))
def test_the_first_pixel_of_the_largest_key_wins_near_ties(seed, step):
    """Errors a fraction of a key step apart: the first pixel in row-major order of the top key.

    The corners' depths are 0, so the plane is 0 exactly and each pixel's error is its depth;
    its key, floor(depth / span * 2**32 + 0.5), is then computed here in the same IEEE
    arithmetic as in the kernel. Only the first triangle's pixels are raised, by steps of
    `step` key steps drawn at random (mostly rising, sometimes falling), so that many pixels
    share a key or lie within one of the largest.
    """
    rng = np.random.default_rng(seed)
    h, w = 6, 31
    depth = np.zeros((h, w))
    valid = np.ones((h, w), bool)
    start = insertion.first_mesh(depth, valid, 0)
    vr0, vc0, _, tri0, he0 = start
    corners, pixels = _owned_pixels(tri0, he0, 0, vr0, vc0)
    inner = [p for p in pixels if p not in corners]
    base = 1.0
    unit = base / STEPS  # about a key step: the span is about `base`
    moves = rng.normal(loc=0.6, scale=1.0, size=len(inner)) * step * unit
    for (r, c), z in zip(inner, base + np.cumsum(moves), strict=True):
        depth[r, c] = z
    span = float(depth.max() - depth.min())
    keys = {p: math.floor(depth[p] / span * STEPS + 0.5) for p in inner}
    top = max(keys.values())
    expected = min(p for p in inner if keys[p] == top)  # tuples sort row-major
    out = _insert(depth, valid, 5)[0]
    vr, vc = out.vr, out.vc
    assert (int(vr[-1]), int(vc[-1])) == expected


def test_an_error_bound_stops_at_the_first_mesh_under_it():
    rng = np.random.default_rng(7)
    depth = rng.normal(size=(12, 14)).cumsum(0)
    valid = np.ones_like(depth, bool)
    lo, hi, n = valid_range(depth, valid)
    start = insertion.first_mesh(depth, valid, 0)
    bound = 0.02 * (hi - lo) * n
    out = _core.greedy_insert(depth, valid, start, InsertSettings(n, bound, hi - lo))
    n_valid, total = out.valid_vertices, out.total
    assert total <= bound
    # one vertex fewer (a count, no bound): its summed error is still above the bound
    before = _core.greedy_insert(depth, valid, start, InsertSettings(n_valid - 1, -1.0, hi - lo)).total
    assert before > bound


@pytest.mark.parametrize("stop", [1.0, insertion.MAX_ERROR_STOP])
def test_an_error_bounded_call_stops_its_first_insertion_at_max_error_stop_times_the_bound(stop):
    # max_error=E: the first insertion is the kernel's own, stopped at a summed error of
    # stop * E / 100 * span * n_valid; E = 1 % is met by that first meshing at each stop here
    rng = np.random.default_rng(7)
    depth = 20 + rng.normal(size=(24, 28)).cumsum(0).cumsum(1) / 10
    valid = np.ones_like(depth, bool)
    lo, hi, n = valid_range(depth, valid)
    req = _refine_request(vertices=n, n_valid=n, lo=lo, hi=hi, n_grid=0, max_error=1.0,
                          max_error_stop=stop)
    res = _core.refine_mesh(depth, valid, np.array([0.0, 1, 1, 1, 0, 0]), req)
    start = insertion.first_mesh(depth, valid, 0)
    bound = stop * 1.0 / 100 * (hi - lo) * n
    out = _core.greedy_insert(depth, valid, start, InsertSettings(n, bound, hi - lo))
    assert res.meshings == 1 and res.achieved <= 1.0
    assert len(res.pixels) == len(out.vr)


def test_background_beyond_the_corners_is_refused():
    depth = np.ones((4, 4))
    valid = np.ones((4, 4), bool)
    valid[1, 1] = False
    vr = np.array([0, 3, 3, 0, 1], np.int64)
    vc = np.array([0, 0, 3, 3, 1], np.int64)
    tv = np.array([0, 1, 2, 0, 2, 3], np.int64)
    he = np.array([-1, -1, 3, 2, -1, -1], np.int64)
    with pytest.raises(ValueError, match="first four"):
        _core.greedy_insert(depth, valid, (vr, vc, np.ones(5), tv, he), InsertSettings(10, -1.0, 1.0))


def test_an_insertion_refused_half_way_leaves_the_next_one_unchanged():
    # A thread keeps a small insertion's arrays for its next one (insertion.cpp `Kept`); one that
    # throws after taking them must leave none stale behind: the same mesh before and after.
    from rangemesh import triangulate

    r, c = np.mgrid[0:16, 0:16]
    d = 100.0 + r + 0.5 * c + ((r - 8) ** 2 + (c - 8) ** 2) * 0.1
    before = triangulate(d, method="refine", vertices=10)
    depth = np.ones((4, 4))
    valid = np.ones((4, 4), bool)
    valid[1, 1] = False
    first = (np.array([0, 3, 3, 0, 1], np.int64), np.array([0, 0, 3, 3, 1], np.int64), np.ones(5),
             np.array([0, 1, 2, 0, 2, 3], np.int64), np.array([-1, -1, 3, 2, -1, -1], np.int64))
    with pytest.raises(ValueError, match="first four"):
        _core.greedy_insert(depth, valid, first, InsertSettings(10, -1.0, 1.0))
    after = triangulate(d, method="refine", vertices=10)
    np.testing.assert_array_equal(after.faces, before.faces)
    np.testing.assert_array_equal(after.vertices, before.vertices)


def test_threads_setting(monkeypatch):
    monkeypatch.setattr(threads.os, "sched_getaffinity", lambda _: {0, 1, 2}, raising=False)
    monkeypatch.delenv("RANGEMESH_THREADS", raising=False)
    assert threads.threads() == 2
    monkeypatch.setenv("NUMBA_NUM_THREADS", "1")  # Numba's setting is not ours
    assert threads.threads() == 2
    monkeypatch.setenv("RANGEMESH_THREADS", "2")
    assert threads.threads() == 2
    monkeypatch.setenv("RANGEMESH_THREADS", "1")
    assert threads.threads() == 1
    monkeypatch.setattr(threads.os, "sched_getaffinity", lambda _: {0}, raising=False)
    monkeypatch.setenv("RANGEMESH_THREADS", "2")
    assert threads.threads() == 1  # one core: one thread


def _refine_request(**fields):
    req = _core.RefineRequest()
    req.vertices, req.n_valid, req.lo, req.hi = 5, 16, 0.0, 1.0
    for name, value in fields.items():
        setattr(req, name, value)
    return req


@pytest.mark.parametrize("call, match", [
    (lambda d, v, cam: _core.refine_mesh(d, v[:3], cam, _refine_request()), "one shape"),
    (lambda d, v, cam: _core.refine_mesh(d, v, cam, _refine_request(vertices=17)), "vertices"),
    (lambda d, v, cam: _core.refine_mesh(d, v, cam, _refine_request(n_valid=17, vertices=17)),
     "vertices"),
    (lambda d, v, cam: _core.refine_mesh(d, v, cam, _refine_request(sr=0)), "sr"),
    (lambda d, v, cam: _core.refine_mesh(d, v, cam, _refine_request(max_error=float("nan"))),
     "max_error"),
    (lambda d, v, cam: _core.refine_mesh(d, v, cam[:5], _refine_request()), "camera"),
    (lambda d, v, cam: _core.refine_mesh(d, v, np.array([2.0, 4, 4, 1, 0, 0]), _refine_request()),
     "camera"),
    (lambda d, v, cam: _core.refine_mesh(d, v, cam, _refine_request(), d[:2], v), "ref_depth"),
    (lambda d, v, cam: _core.refine_mesh(d[:1], v[:1], cam, _refine_request()), "2x2"),
    (lambda d, v, cam: _core.refine_mesh(d, v, cam, _refine_request(collapse=0.5)), "collapse"),
    (lambda d, v, cam: _core.refine_mesh(d, v, cam, _refine_request(max_error_stop=0.0)),
     "max_error_stop"),
    (lambda d, v, cam: _core.refine_mesh(d, v, cam, _refine_request(max_error_stop=float("inf"))),
     "max_error_stop"),
    (lambda d, v, cam: _core.refine_mesh(d, v, cam, _refine_request(collapse=float("nan"))),
     "collapse"),
    (lambda d, v, cam: _core.refine_mesh(d, v,
                                         np.concatenate([[2.0, 4, 4, 1, 0, 0], np.tile([0, 0, 1.0], 16)]),
                                         _refine_request(walls=False)), "pixel_angle"),
    (lambda d, v, cam: _core.refine_mesh(d, v, cam, _refine_request(strips=True, threads=0)),
     "threads"),
    (lambda d, v, cam: _core.refine_mesh(d[:, :3], v[:, :3], cam,
                                         _refine_request(strips=True, n_valid=12)), "strips"),
])
def test_the_native_refine_call_refuses_malformed_requests(call, match):
    depth = np.arange(16.0).reshape(4, 4) / 15.0
    valid = np.ones((4, 4), bool)
    with pytest.raises(ValueError, match=match):
        call(depth, valid, np.array([0.0, 1, 1, 1, 0, 0]))


def test_the_native_refine_call_meshes_a_count_and_names_its_parts():
    # a 4 x 4 image of one plane: 5 vertices are the corners and one pixel; its result's named
    # parts agree with each other
    depth = np.add.outer(np.arange(4.0), 2 * np.arange(4.0))
    res = _core.refine_mesh(depth, np.ones((4, 4), bool), np.array([0.0, 1, 1, 1, 0, 0]),
                            _refine_request(lo=0.0, hi=9.0))
    assert res.done and res.meshings == 1 and len(res.pixels) == 5
    assert res.faces.shape == (4, 3) and res.edges == 8  # a fan of 4 around the inner vertex
    np.testing.assert_array_equal(res.vertices[:, 2], depth[res.pixels[:, 0], res.pixels[:, 1]])


@pytest.mark.parametrize("args, match", [
    ((np.zeros((1, 2), np.int64), np.zeros((3, 2), np.int64), np.ones(3), 0.05), "faces"),
    ((np.array([[0, 1, 3]]), np.zeros((3, 2), np.int64), np.ones(3), 0.05), "out of range"),
    ((np.array([[0, 1, -1]]), np.zeros((3, 2), np.int64), np.ones(3), 0.05), "out of range"),
    ((np.array([[0, 1, 2]]), np.zeros((3, 2), np.int64), np.ones(2), 0.05), "one depth a vertex"),
    ((np.array([[0, 1, 2]]), np.zeros((3, 2), np.int64), np.ones(3), 0.05, np.ones((2, 3))), "lengths"),
])
def test_the_wall_rule_refuses_malformed_meshes(args, match):
    with pytest.raises(ValueError, match=match):
        _core.wall_faces(*args)


def test_the_wall_rule_by_hand():
    # one edge 0 -> 1 two pixels long from depth 10 to 11: a step of 1 against
    # 0.05 * 10 * 2 = 1.0 is no wall; to 11.5 it is (0.05 is the default jump)
    faces = np.array([[0, 1, 2]])
    pixels = np.array([[0, 0], [0, 2], [5, 0]])
    assert not _core.wall_faces(faces, pixels, np.array([10.0, 11.0, 10.0]), 0.05)[0]
    assert _core.wall_faces(faces, pixels, np.array([10.0, 11.5, 10.0]), 0.05)[0]
    # given lengths replace the image plane's: 4 pixels (and 5 on the edges to corner 2) leave
    # the larger step no wall
    lengths = np.array([[4.0, 5.0, 5.0]])
    assert not _core.wall_faces(faces, pixels, np.array([10.0, 11.5, 10.0]), 0.05, lengths)[0]
