"""Fast kernels against the slow references of tests/reference.py."""

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from rangemesh import _core
from rangemesh.camera import Orthographic, Pinhole, Spherical, backproject

from . import reference as ref


def orient(ra, ca, rb, cb, rc, cc):
    """Twice the signed area of (a, b, c), from its definition."""
    return (rb - ra) * (cc - ca) - (cb - ca) * (rc - ra)

coord = st.integers(0, 40)


@given(coord, coord, coord, coord)
def test_line_pixels_match_textbook_bresenham(r0, c0, r1, c1):
    a, b = sorted([(r0, c0), (r1, c1)])
    n = max(abs(b[0] - a[0]), abs(b[1] - a[1]))
    got = [_core.line_pixel(a[0], a[1], b[0], b[1], k) for k in range(n + 1)]
    assert got == ref.bresenham(a, b)


@given(coord, coord, coord, coord)
def test_line_is_8_connected_and_hits_endpoints(r0, c0, r1, c1):
    line = ref.bresenham((r0, c0), (r1, c1))
    assert set(line[:1] + line[-1:]) == {(r0, c0), (r1, c1)}
    steps = np.abs(np.diff(np.array(line), axis=0))
    assert (steps.max(axis=1) == 1).all() if len(line) > 1 else True


def _walked_spans(a, b, c, owns):
    """Each row's (first, last) columns as the core's row scan (`TriangleRows`) walks them.

    Also checks the edge functions returned at each row's first column against `orient`.
    """
    spans = {}
    for r, lo, hi, w0, w1, w2 in _core._triangle_rows(np.array([a, b, c]), owns).tolist():
        assert (w0, w1, w2) == tuple(orient(*p, *q, r, lo) for p, q in ((a, b), (b, c), (c, a)))
        spans[r] = (lo, hi)
    return spans


@given(st.lists(st.tuples(coord, coord), min_size=3, max_size=3, unique=True),
       st.tuples(st.booleans(), st.booleans(), st.booleans()))
def test_walked_row_spans_hold_exactly_the_pixels_inside(pts, owns):
    # Independent reference: every pixel of the bounding box tested by its three edge
    # functions (w > 0, or w == 0 on an edge whose pixels the triangle owns).
    a, b, c = pts
    area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    if area == 0:
        return
    if area < 0:
        b, c = c, b

    def w(p, q, r, col):
        return (q[0] - p[0]) * (col - p[1]) - (q[1] - p[1]) * (r - p[0])

    spans = _walked_spans(a, b, c, owns)
    for r, (lo, hi) in spans.items():
        inside = [col for col in range(0, 41)
                  if all(w(p, q, r, col) > 0 or (w(p, q, r, col) == 0 and own)
                         for (p, q), own in zip(((a, b), (b, c), (c, a)), owns, strict=True))]
        assert list(range(lo, hi + 1)) == inside


@given(st.lists(st.tuples(coord, coord), min_size=3, max_size=3, unique=True),
       st.tuples(st.booleans(), st.booleans(), st.booleans()))
def test_span_walk_holds_exactly_the_pixels_inside(pts, owns):
    # refine's scans walk each row by one edge a side (`TriangleSpans`); against the same
    # independent reference as the row walk: every pixel of the bounding box tested by its
    # three edge functions (w > 0, or w == 0 on an edge whose pixels the triangle owns).
    a, b, c = pts
    if orient(*a, *b, *c) == 0:
        return
    if orient(*a, *b, *c) < 0:
        b, c = c, b

    def inside(r, col):
        return all(orient(*p, *q, r, col) > 0 or (orient(*p, *q, r, col) == 0 and own)
                   for (p, q), own in zip(((a, b), (b, c), (c, a)), owns, strict=True))

    got = _core._triangle_rows(np.array([a, b, c]), owns, spans=True).tolist()
    want = {}
    for r in range(0, 41):
        cols = [col for col in range(0, 41) if inside(r, col)]
        if cols:
            want[r] = cols
    assert [r for r, *_ in got] == sorted(want)
    for r, lo, hi, w0, w1, w2 in got:
        assert list(range(lo, hi + 1)) == want[r]
        assert (w0, w1, w2) == tuple(orient(*p, *q, r, lo) for p, q in ((a, b), (b, c), (c, a)))


def test_span_walk_by_hand():
    # (0,0) (4,0) (0,4) as in test_walked_row_spans_by_hand, and (0,2) (4,0) (4,4) (row 4 along
    # B -> C): a row along an edge the triangle does not own holds none of its pixels.
    def cols(a, b, c, owns):
        return {r: list(range(lo, hi + 1))
                for r, lo, hi, *_ in _core._triangle_rows(np.array([a, b, c]), owns, spans=True).tolist()}

    assert cols((0, 0), (4, 0), (0, 4), (True, True, False)) == {r: list(range(5 - r)) for r in range(1, 5)}
    assert cols((0, 2), (4, 0), (4, 4), (True, True, True)) == {0: [2], 1: [2], 2: [1, 2, 3], 3: [1, 2, 3],
                                                               4: [0, 1, 2, 3, 4]}
    assert cols((0, 2), (4, 0), (4, 4), (True, False, True)) == {0: [2], 1: [2], 2: [1, 2, 3], 3: [1, 2, 3]}
    assert cols((0, 2), (4, 0), (4, 4), (False, True, False)) == {1: [2], 2: [2], 3: [1, 2, 3], 4: [1, 2, 3]}


@given(st.lists(st.tuples(coord, coord), min_size=3, max_size=3, unique=True),
       st.tuples(st.booleans(), st.booleans(), st.booleans()), st.integers(1, 5), st.integers(0, 4))
def test_a_walk_by_steps_of_rows_visits_those_rows_of_the_full_walk(pts, owns, step, skip):
    # From any row on, every step-th row: the spans and edge functions of the row-by-row walk
    # (itself checked against the pixels inside above), nothing else.
    a, b, c = pts
    if orient(*a, *b, *c) == 0:
        return
    if orient(*a, *b, *c) < 0:
        b, c = c, b
    full = {r[0]: r for r in _core._triangle_rows(np.array([a, b, c]), owns).tolist()}
    first = min(full) + skip
    got = _core._triangle_rows(np.array([a, b, c]), owns, first=first, step=step).tolist()
    assert got == [full[r] for r in range(first, max(full) + 1, step)]


def test_walked_row_spans_by_hand():
    # (0,0) (4,0) (0,4), counter-clockwise in (row, col). A -> B is the column c == 0,
    # B -> C the hypotenuse r + c == 4, C -> A the row r == 0. With every edge owned, row r
    # holds columns 0..4-r; each edge not owned loses its own pixels.
    a, b, c = (0, 0), (4, 0), (0, 4)

    def cols(owns):
        return {r: list(range(lo, hi + 1)) for r, (lo, hi) in _walked_spans(a, b, c, owns).items()}

    assert cols((True, True, True)) == {r: list(range(0, 5 - r)) for r in range(5)}
    assert cols((True, False, True)) == {r: list(range(0, 4 - r)) for r in range(5)}
    assert cols((False, True, True)) == {r: list(range(1, 5 - r)) for r in range(5)}
    assert cols((True, True, False)) == {0: [], **{r: list(range(0, 5 - r)) for r in range(1, 5)}}


def _box_raster(tris, vals, h, w):
    """Brute force: every pixel of each triangle's box, first triangle wins, the same float ops.

    A corner's own pixel (two weights 0) takes the corner's value as it is.
    """
    out = np.full((h, w), np.nan)
    face = np.full((h, w), -1)
    for t, ((r0, c0), (r1, c1), (r2, c2)) in enumerate(tris):
        area = (r1 - r0) * (c2 - c0) - (c1 - c0) * (r2 - r0)
        if area == 0:
            continue
        sgn = 1 if area > 0 else -1
        for r in range(h):
            for c in range(w):
                ws = [sgn * ((qr - pr) * (c - pc) - (qc - pc) * (r - pr))
                      for (pr, pc), (qr, qc) in (((r1, c1), (r2, c2)), ((r2, c2), (r0, c0)),
                                                 ((r0, c0), (r1, c1)))]
                if face[r, c] != -1 or min(ws) < 0:
                    continue
                w0, w1, w2 = (float(x) for x in ws)
                if [w0, w1, w2].count(0.0) == 2:
                    out[r, c] = vals[t][[w0, w1, w2].index(max(w0, w1, w2))]
                else:
                    out[r, c] = (w0 * vals[t][0] + w1 * vals[t][1] + w2 * vals[t][2]) / (w0 + w1 + w2)
                face[r, c] = t
    return out, face


@given(st.lists(st.tuples(st.tuples(st.integers(0, 11), st.integers(0, 13)),
                          st.tuples(st.integers(0, 11), st.integers(0, 13)),
                          st.tuples(st.integers(0, 11), st.integers(0, 13)),
                          st.tuples(*[st.floats(-5, 5)] * 3)), min_size=1, max_size=4),
       st.booleans())
def test_rasterize_matches_a_box_loop(tris, shift):
    # Integer corners take the span walk, shifted ones (by 0.5 column) the box loop: both
    # must give what a plain loop over every pixel gives, value for value.
    h, w = 12, 14
    corners = [t[:3] for t in tris]
    if shift:
        corners = [tuple((r, c + 0.5) for r, c in tri) for tri in corners]
    vals = np.array([t[3] for t in tris])
    out = np.full((h, w), np.nan)
    face = np.full((h, w), -1, np.int64)
    fr = np.array([[p[0] for p in tri] for tri in corners], np.float64)
    fc = np.array([[p[1] for p in tri] for tri in corners], np.float64)
    _core.rasterize(fr, fc, vals, out, face)
    want, want_face = _box_raster(corners, vals, h, w)
    np.testing.assert_array_equal(face, want_face)
    np.testing.assert_array_equal(out, want)


def test_bresenham_by_hand():
    # (0,0)->(2,5): column-major, exact rows 0, .4, .8, 1.2, 1.6, 2 -> 0 0 1 1 2 2
    assert ref.bresenham((0, 0), (2, 5)) == [(0, 0), (0, 1), (1, 2), (1, 3), (2, 4), (2, 5)]
    # (0,0)->(1,2): the middle pixel is a tie (row 0.5) and goes toward the start
    assert ref.bresenham((0, 0), (1, 2)) == [(0, 0), (0, 1), (1, 2)]


@given(st.integers(0, 100), st.data())
def test_edge_error_matches_reference(seed, data):
    rng = np.random.default_rng(seed)
    depth = rng.uniform(0, 50, (30, 30))
    valid = rng.random((30, 30)) > 0.2
    cam = data.draw(st.sampled_from([Orthographic(1, 1, 1), Orthographic(0.5, 2.0, -1.5),
                                     Pinhole(25.0, 30.0, 14.0, 15.0, 0.01)]))
    a = tuple(rng.integers(0, 30, 2))
    b = tuple(rng.integers(0, 30, 2))
    pixels = np.array([a, b], np.int64)
    verts = backproject(pixels[:, 0], pixels[:, 1], depth[pixels[:, 0], pixels[:, 1]], cam)
    got = _core.edge_error(0, 1, pixels, verts, depth, valid, cam.as_array())
    back = _core.edge_error(1, 0, pixels, verts, depth, valid, cam.as_array())
    want = ref.edge_error(a, b, depth, valid, cam)
    assert got == back  # symmetric, bit for bit
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9)


def test_edge_error_by_hand():
    # Step of height 3 at column 2; segment from (0,0) z=0 to (0,4) z=3.
    depth = np.array([[0.0, 0.0, 3.0, 3.0, 3.0]])
    valid = np.ones_like(depth, bool)
    pixels = np.array([[0, 0], [0, 4]], np.int64)
    verts = np.array([[0.0, 0.0, 0.0], [0.0, 4.0, 3.0]])
    got = _core.edge_error(0, 1, pixels, verts, depth, valid, Orthographic().as_array())
    # distance of (0,c,z) to the line z = 3c/4 in the (c, z) plane is |3c - 4z| / 5
    want = sum(abs(3 * c - 4 * z) / 5 for c, z in zip(range(5), depth[0], strict=True))
    assert np.isclose(got, want)


@given(st.integers(0, 2**31), st.sampled_from([0, 1, 2]))
def test_lift_is_backproject(seed, cam_kind):
    """The core's camera lift gives `camera.backproject`'s points, bit for bit."""
    rng = np.random.default_rng(seed)
    cam = [Orthographic(0.5, 2.0, -1.5), Pinhole(525.0, 520.0, 14.5, 15.0, 0.001),
           Spherical(np.linspace(15, -15, 30), np.linspace(0, 348, 30), range_scale=0.25)][cam_kind]
    r, c = rng.integers(0, 30, 20), rng.integers(0, 30, 20)
    d = rng.uniform(0.1, 5000.0, 20)
    want = backproject(r, c, d, cam)
    got = np.array([_core.lift(int(r[i]), int(c[i]), d[i], cam.as_array()) for i in range(20)])
    assert np.array_equal(got.view(np.int64), want.view(np.int64))


def test_lift_by_hand():
    # pinhole: x = (c - cx) z / fx, y = (r - cy) z / fy, z = depth * scale
    pinhole = np.array([1.0, 500, 500, 320, 240, 0.001])
    assert _core.lift(240, 420, 2000.0, pinhole).tolist() == [0.4, 0.0, 2.0]
    # orthographic: (kx r, ky c, kz d)
    assert _core.lift(2, 3, 10.0, np.array([0.0, 0.5, 0.5, 2.0, 0, 0])).tolist() == [1.0, 1.5, 20.0]


def test_heap_pops_in_gain_order_with_id_ties():
    gain = np.array([1.0, 5.0, 5.0, -np.inf, 2.0, 0.5])
    n = gain.size
    keys = gain.copy()
    heap = np.arange(n)
    slot = np.arange(n)
    for i in range(n):
        _core._heap_sift_up(keys, heap, slot, i)
    order = []
    for _ in range(5):
        x = heap[0]
        order.append(int(x))
        _core._heap_rekey(keys, heap, slot, x, -np.inf, n)  # retire it
    assert order == [1, 2, 4, 0, 5]  # 1 and 2 tie at 5.0: smaller id first
    assert np.array_equal(heap[slot], np.arange(n))


def _check_heap(keys, heap, slot, gain):
    """Every parent above its children, keys at their ids' positions, slots inverse to heap."""
    n = len(heap)
    assert np.array_equal(keys, gain[heap])
    for i in range(1, n):
        p = (i - 1) // 2
        assert keys[p] > keys[i] or (keys[p] == keys[i] and heap[p] < heap[i])
    assert np.array_equal(heap[slot], np.arange(n))


def test_heap_rekey_keeps_invariant(rng):
    n = 200
    gain = rng.normal(size=n)
    keys = gain.copy()
    heap = np.arange(n)
    slot = np.arange(n)
    for i in range(n):
        _core._heap_sift_up(keys, heap, slot, i)
    _check_heap(keys, heap, slot, gain)
    for _ in range(500):
        x = int(rng.integers(n))
        # ties on purpose: a few repeated values, and retired ids
        gain[x] = rng.choice([rng.normal(), 0.25, -np.inf])
        _core._heap_rekey(keys, heap, slot, x, gain[x], n)
        _check_heap(keys, heap, slot, gain)


@given(st.lists(st.tuples(st.integers(0, 7), st.integers(0, 7), st.integers(0, 7)), min_size=1,
                max_size=30))
def test_count_edges_matches_a_set_of_vertex_pairs(faces):
    from rangemesh.mesh import count_edges

    # any face list: repeated faces, either orientation, degenerate corners
    expected = {frozenset((a, b)) for f in faces for a, b in ((f[0], f[1]), (f[1], f[2]),
                                                             (f[2], f[0]))}
    assert count_edges(np.array(faces)) == len(expected)


def test_valid_faces_by_hand():
    from rangemesh._core import valid_faces

    # 5 vertices on a 3x3 image whose pixel (0, 2) is background; vertex 3 sits there.
    # Triangles (0, 1, 2) and (2, 1, 4) keep; (1, 3, 4) has the background vertex.
    valid = np.ones((3, 3), bool)
    valid[0, 2] = False
    vr = np.array([0, 2, 1, 0, 2])
    vc = np.array([0, 0, 1, 2, 2])
    tv = np.array([0, 1, 2, 1, 3, 4, 2, 1, 4])
    faces, pixels = valid_faces(vr, vc, tv, valid)
    # vertex 3 is used by the dropped triangle only: 0, 1, 2, 4 become 0, 1, 2, 3
    assert faces.tolist() == [[0, 1, 2], [2, 1, 3]]
    assert pixels.tolist() == [[0, 0], [2, 0], [1, 1], [2, 2]]
    assert faces.dtype == np.int32 and pixels.dtype == np.int32


@given(st.integers(0, 2**31), st.integers(1, 40), st.integers(1, 40), st.floats(0.0, 1.0))
def test_nearest_valid_is_the_brute_force_nearest(seed, h, w, share):
    # any pixel, not only a corner: nearest by squared distance, then smallest (row, col);
    # None on an image with no valid pixel (issue 43: no sentinel; it returned (-1, -1))
    from rangemesh._core import nearest_valid

    rng = np.random.default_rng(seed)
    valid = rng.random((h, w)) < share
    r, c = int(rng.integers(h)), int(rng.integers(w))
    rr, cc = np.nonzero(valid)
    if len(rr) == 0:
        assert nearest_valid(valid, r, c) is None
        return
    d = (rr - r) ** 2 + (cc - c) ** 2
    j = min(range(len(d)), key=lambda k: (d[k], rr[k], cc[k]))
    assert nearest_valid(valid, r, c) == (rr[j], cc[j])


def test_grid_pixels_by_hand():
    from rangemesh._core import grid_pixels as core_grid_pixels

    def grid_pixels(*args):
        got = core_grid_pixels(*args)
        return got.rows, got.cols

    # 10x10, a 2x2 grid: rows and columns int(0.5 * 10 / 2) = 2 and int(1.5 * 10 / 2) = 7,
    # the corners first; the background pixel (7, 2) is left out
    valid = np.ones((10, 10), bool)
    valid[7, 2] = False
    vr, vc = grid_pixels(valid, 2, 2, 0, 9, False)
    assert vr.tolist() == [0, 9, 9, 0, 2, 2, 7]
    assert vc.tolist() == [0, 0, 9, 9, 2, 7, 7]
    # 3 rows, 4 grid rows: int(k * 3 / 4) for k = 0.5, 1.5, 2.5, 3.5 gives 0, 1, 1, 2, so
    # rows 0, 1, 2 once each; columns 1..2 of a 3x4 image, 2 grid columns: 1 + int(0.5) = 1
    # and 1 + int(1.5) = 2. Corners (0, 1), (2, 1), (2, 2), (0, 2) are not repeated.
    valid = np.ones((3, 4), bool)
    vr, vc = grid_pixels(valid, 4, 2, 1, 2, False)
    assert vr.tolist() == [0, 2, 2, 0, 1, 1]
    assert vc.tolist() == [1, 1, 2, 2, 1, 2]
    # a strip's inner grid leaves its first and last columns to the seam: nothing is left
    vr, vc = grid_pixels(valid, 4, 2, 1, 2, True)
    assert vr.tolist() == [0, 2, 2, 0] and vc.tolist() == [1, 1, 2, 2]
    # no grid below 2 rows or columns
    vr, vc = grid_pixels(valid, 1, 5, 0, 3, False)
    assert vr.tolist() == [0, 2, 2, 0] and vc.tolist() == [0, 0, 3, 3]
