r"""Numba kernels of stage three (paper II.B.2-3, SPEC 3): the flip queue, the decision, the flip.

The stage is split as hmm's triangulator splits its work:

* `init_queue`: edge ids, triangle normals, edge errors, gains, and the heap;
* `decide`: the verdict on the edge at the head of the queue (T1 deadlock,
  the edge-length bound, then for the paper's rule T2-T5 and the final test);
* `apply_flip`: flip the edge, update normals, errors, gains and the heap;
* `flip_loop`: pop, decide, apply or reject, until the queue is exhausted.

Verdicts are the constants below, mirrored by `rangemesh.paper.flipping.Verdict`
(an IntEnum; a test checks that the two agree).

Quad before and after a flip of AB (e0 in t0 = ABC, e1 in t1 = BAD)::

          C                      C
        /   \                  / | \
       /  t0 \                /  |  \
      A ----- B      ->       A t0|t1 B
       \  t1 /                \  |  /
        \   /                  \ | /
          D                      D

t0 becomes DCA and t1 becomes CDB; the new diagonal keeps the half-edge
slots e0, e1 and the edge id of AB, the four outer edges keep their ids.

No ``fastmath``: predicates, angles and errors must be reproducible bit for bit.
"""

import math

import numpy as np
from numba import njit

from ..geometry.halfedges import flip_quad, nxt, prv, quad_halfedges
from ..geometry.heap import rekey, sift_up
from ..geometry.raster import edge_error
from ..geometry.vectors import angle, max_internal_angle, orient, unit_normal

NEG_INF = -np.inf
# Angles closer than this (radians) are equal: flat spans give angles of 0 up
# to rounding noise, and noise must not decide a test (SPEC P2, P6).
ANGLE_TOL = 1e-9

# Verdicts (indices of the `verdicts` counters); see flipping.Verdict.
T1_DEADLOCK = 0
T2_DISPARITY_CHANGE = 1
T3_DEGENERATE = 2
T4_BEND = 3
T5_CREASE = 4
FINAL_TEST = 5
FLIPPED = 6
MAX_EDGE = 7
N_VERDICTS = 8

# Flip rules
MODE_DISPARITY = 0
MODE_ERROR = 1


@njit(cache=True)
def _span_normal(triangles, halfedges, normals, start, t0, t1):
    """NS_V: sum of unit normals of the triangles around V = triangles[start], but t0, t1.

    `start` is a half-edge leaving V. The walk turns one way until it closes the
    fan or meets the border, then (at a border) the other way.
    """
    sx = 0.0
    sy = 0.0
    sz = 0.0
    cur = start
    open_fan = False
    while True:
        t = cur // 3
        if t != t0 and t != t1:
            sx += normals[t, 0]
            sy += normals[t, 1]
            sz += normals[t, 2]
        tw = halfedges[prv(cur)]
        if tw == -1:
            open_fan = True
            break
        cur = tw
        if cur == start:
            break
    if open_fan:
        cur = start
        while True:
            tw = halfedges[cur]
            if tw == -1:
                break
            cur = nxt(tw)
            t = cur // 3
            if t != t0 and t != t1:
                sx += normals[t, 0]
                sy += normals[t, 1]
                sz += normals[t, 2]
    return sx, sy, sz


@njit(cache=True)
def _disparity(ns, n, delta):
    """SPEC 3.4: angle(NS_V, N_T) if NS_V is non-zero and the angle is below delta, else pi."""
    if ns[0] == 0.0 and ns[1] == 0.0 and ns[2] == 0.0:
        return math.pi
    a = angle(ns[0], ns[1], ns[2], n[0], n[1], n[2])
    if a < delta:
        return a
    return math.pi


@njit(cache=True)
def _pair_key(a, b, n_vertices):
    if a > b:
        a, b = b, a
    return a * n_vertices + b


@njit(cache=True)
def _set_slot(keys, key):
    """Slot of `key` in an open-addressing table (linear probing), or of the empty slot."""
    mask = keys.size - 1
    i = (key ^ (key >> 17) ^ (key >> 31)) & mask
    while keys[i] != -1 and keys[i] != key:
        i = (i + 1) & mask
    return i


@njit(cache=True)
def _set_add(keys, key, count):
    """Insert `key`; returns the (possibly regrown) table. `count` is the size before."""
    if 2 * (count + 1) > keys.size:
        bigger = np.full(2 * keys.size, -1, np.int64)
        for k in keys:
            if k != -1:
                bigger[_set_slot(bigger, k)] = k
        keys = bigger
    keys[_set_slot(keys, key)] = key
    return keys


@njit(cache=True)
def _gain(x, edge_he, triangles, halfedges, pixels, vertices, depth, valid, cam, err, quantum):
    """G = E(A,B) - E(C,D) for an interior edge whose quad is strictly convex, else -inf.

    The gain is rounded to a multiple of `quantum` (a power of two far below
    the scene's size): gains equal up to rounding noise become exactly equal,
    so a change of depth unit (SPEC P2) cannot reorder ties or turn a zero
    gain positive.
    """
    e0 = edge_he[x]
    e1 = halfedges[e0]
    if e1 == -1:
        return NEG_INF
    a = triangles[e0]
    b = triangles[nxt(e0)]
    c = triangles[prv(e0)]
    d = triangles[prv(e1)]
    # Strictly convex quad A-D-B-C <=> both new triangles (D,B,C), (C,A,D) are CCW.
    if orient(pixels[d, 0], pixels[d, 1], pixels[b, 0], pixels[b, 1],
              pixels[c, 0], pixels[c, 1]) <= 0:
        return NEG_INF
    if orient(pixels[c, 0], pixels[c, 1], pixels[a, 0], pixels[a, 1],
              pixels[d, 0], pixels[d, 1]) <= 0:
        return NEG_INF
    g = err[x] - edge_error(c, d, pixels, vertices, depth, valid, cam)
    return np.round(g / quantum) * quantum


@njit(cache=True)
def init_queue(triangles, halfedges, pixels, vertices, depth, valid, cam, quantum):
    """Edge ids, unit normals, edge errors, gains and the max-heap of a half-edge mesh.

    Returns ``(he_edge, edge_he, normals, err, gain, keys, heap, slot)``: one
    id per undirected edge in half-edge order, ``he_edge[e]`` the id of
    half-edge ``e`` and ``edge_he[x]`` one half-edge of edge ``x``; the heap
    (`rangemesh.geometry.heap`) is keyed by the gains.
    """
    n_he = triangles.size
    n_t = n_he // 3
    he_edge = np.full(n_he, -1, np.int64)
    n_e = 0
    for e in range(n_he):
        tw = halfedges[e]
        if tw == -1 or e < tw:
            he_edge[e] = n_e
            if tw != -1:
                he_edge[tw] = n_e
            n_e += 1
    edge_he = np.zeros(n_e, np.int64)
    for e in range(n_he):
        tw = halfedges[e]
        if tw == -1 or e < tw:
            edge_he[he_edge[e]] = e
    normals = np.zeros((n_t, 3))
    for t in range(n_t):
        nx, ny, nz = unit_normal(vertices, triangles[3 * t], triangles[3 * t + 1],
                                 triangles[3 * t + 2])
        normals[t, 0] = nx
        normals[t, 1] = ny
        normals[t, 2] = nz
    err = np.zeros(n_e)
    for x in range(n_e):
        e = edge_he[x]
        err[x] = edge_error(triangles[e], triangles[nxt(e)], pixels, vertices, depth, valid, cam)
    gain = np.zeros(n_e)
    for x in range(n_e):
        gain[x] = _gain(x, edge_he, triangles, halfedges, pixels, vertices, depth, valid,
                        cam, err, quantum)
    keys = gain.copy()
    heap = np.arange(n_e)
    slot = np.arange(n_e)
    for i in range(n_e):
        sift_up(keys, heap, slot, i)
    return he_edge, edge_he, normals, err, gain, keys, heap, slot


@njit(cache=True)
def disparity_verdict(triangles, halfedges, normals, vertices, e0, delta, epsilon, max_angle,
                      min_bend):
    """The paper's tests T2-T5 and its final test on the edge of half-edge `e0` (SPEC 3.3-3.5).

    Returns `FLIPPED` when the final test accepts the flip, else the verdict
    of the first test that rejects it. Spans and normals are computed as late
    as the tests allow: a value a test does not need is never computed (the
    verdict is the same as computing all).
    """
    e1, b0, c0, b1, c1 = quad_halfedges(halfedges, e0)
    t0 = e0 // 3
    t1 = e1 // 3
    va = triangles[e0]
    vb = triangles[b0]
    vc = triangles[c0]
    vd = triangles[c1]
    ns_c = _span_normal(triangles, halfedges, normals, c0, t0, t1)  # C -> A leaves C
    ns_d = _span_normal(triangles, halfedges, normals, c1, t0, t1)  # D -> B leaves D
    n_abc = (normals[t0, 0], normals[t0, 1], normals[t0, 2])
    n_bad = (normals[t1, 0], normals[t1, 1], normals[t1, 2])
    n_dca = unit_normal(vertices, vd, vc, va)
    n_cdb = unit_normal(vertices, vc, vd, vb)
    disp_ab = max(_disparity(ns_c, n_abc, delta), _disparity(ns_d, n_bad, delta))
    ns_a = _span_normal(triangles, halfedges, normals, b1, t0, t1)  # A -> D leaves A
    disp_cd = _disparity(ns_a, n_dca, delta)
    ns_b = (0.0, 0.0, 0.0)
    have_b = False
    if disp_cd < math.pi:  # else max(...) is pi whatever NS_B is
        ns_b = _span_normal(triangles, halfedges, normals, b0, t0, t1)  # B -> C leaves B
        have_b = True
        disp_cd = max(disp_cd, _disparity(ns_b, n_cdb, delta))
    bend = angle(n_dca[0], n_dca[1], n_dca[2], n_cdb[0], n_cdb[1], n_cdb[2])
    if abs(disp_ab - disp_cd) < epsilon:  # T2: no significant disparity change
        return T2_DISPARITY_CHANGE
    if bend < delta and (max_internal_angle(vertices, vd, vc, va) > max_angle
                         or max_internal_angle(vertices, vc, vd, vb) > max_angle):
        return T3_DEGENERATE  # T3: degenerate triangle on a smooth region
    if not bend > min_bend:  # T4: no noticeable change of shape
        return T4_BEND
    if not have_b:
        ns_b = _span_normal(triangles, halfedges, normals, b0, t0, t1)
    if (angle(ns_c[0], ns_c[1], ns_c[2], ns_d[0], ns_d[1], ns_d[2])
            > 2.0 * angle(ns_a[0], ns_a[1], ns_a[2], ns_b[0], ns_b[1], ns_b[2]) + ANGLE_TOL):
        return T5_CREASE  # T5: a crease along AB would be lost
    if disp_ab > disp_cd:  # final test
        return FLIPPED
    return FINAL_TEST


@njit(cache=True)
def decide(x, edge_he, triangles, halfedges, pixels, vertices, normals, former, mode,
           delta, epsilon, max_angle, min_bend, max_edge2):
    """Verdict on edge `x`: T1 (deadlock), the edge-length bound, then the flip rule."""
    e0 = edge_he[x]
    e1 = halfedges[e0]
    vc = triangles[prv(e0)]
    vd = triangles[prv(e1)]
    key_cd = _pair_key(vc, vd, vertices.shape[0])
    deadlock = former[_set_slot(former, key_cd)] == key_cd  # C, D were neighbours before
    dr_cd = pixels[vc, 0] - pixels[vd, 0]
    dc_cd = pixels[vc, 1] - pixels[vd, 1]
    if dr_cd * dr_cd + dc_cd * dc_cd > max_edge2:  # the user's edge-length bound
        return MAX_EDGE
    if deadlock:
        return T1_DEADLOCK
    if mode == MODE_ERROR:
        return FLIPPED
    return disparity_verdict(triangles, halfedges, normals, vertices, e0, delta, epsilon,
                             max_angle, min_bend)


@njit(cache=True)
def apply_flip(x, he_edge, edge_he, triangles, halfedges, pixels, vertices, depth, valid, cam,
               normals, err, gain, keys, heap, slot, quantum):
    """Flip edge `x` (AB -> CD) and re-key CD and the four outer edges of its quad."""
    n_e = edge_he.size
    e0 = edge_he[x]
    e1, b0, c0, b1, c1 = quad_halfedges(halfedges, e0)
    t0 = e0 // 3
    t1 = e1 // 3
    va = triangles[e0]
    vb = triangles[b0]
    vc = triangles[c0]
    vd = triangles[c1]
    eb0 = he_edge[b0]  # BC
    ec0 = he_edge[c0]  # CA
    eb1 = he_edge[b1]  # AD
    ec1 = he_edge[c1]  # DB
    # outer half-edges move: CA -> b0, AD -> c0, DB -> b1, BC -> c1
    flip_quad(triangles, halfedges, e0)
    he_edge[b0] = ec0
    he_edge[c0] = eb1
    he_edge[b1] = ec1
    he_edge[c1] = eb0
    edge_he[ec0] = b0
    edge_he[eb1] = c0
    edge_he[ec1] = b1
    edge_he[eb0] = c1
    edge_he[x] = e0
    s = unit_normal(vertices, vd, vc, va)
    normals[t0, 0], normals[t0, 1], normals[t0, 2] = s
    s = unit_normal(vertices, vc, vd, vb)
    normals[t1, 0], normals[t1, 1], normals[t1, 2] = s
    err[x] = edge_error(vc, vd, pixels, vertices, depth, valid, cam)
    for y in (x, eb0, ec0, eb1, ec1):
        gain[y] = _gain(y, edge_he, triangles, halfedges, pixels, vertices, depth, valid,
                        cam, err, quantum)
        rekey(keys, heap, slot, y, gain[y], n_e)


@njit(cache=True)
def flip_loop(triangles, halfedges, pixels, vertices, depth, valid, cam, mode, threshold,
              delta, epsilon, max_angle, min_bend, quantum, max_edge2, verdicts, log):
    """Stage three (SPEC 3.3-3.6); edits `triangles` and `halfedges` in place.

    `mode` is `MODE_DISPARITY` (the paper's tests) or `MODE_ERROR` (flip
    while the gain is positive). Angles in radians. Returns the number of
    flips taken; `verdicts` (int64[N_VERDICTS]) counts, in place, each
    verdict given. The edge-length bound (``sqrt(max_edge2)`` pixels in the
    image plane) is checked before T1. The first ``len(log)`` decisions are
    written to `log` (int64, (n, 3)): the edge's endpoints (smaller first) and
    the verdict; pass a (0, 3) array to keep no log.
    """
    he_edge, edge_he, normals, err, gain, keys, heap, slot = init_queue(
        triangles, halfedges, pixels, vertices, depth, valid, cam, quantum)
    n_e = edge_he.size
    n_v = vertices.shape[0]
    # former neighbours: an open-addressing set of vertex-pair keys (faster than a typed dict)
    former = np.full(1024, -1, np.int64)
    n_former = np.int64(0)  # not a literal 0: Numba would compile _set_add twice
    flips = 0
    n_logged = 0
    while n_e > 0:
        x = heap[0]
        g = gain[x]
        if g == NEG_INF or g < threshold or (mode == MODE_ERROR and g <= 0.0):
            break
        verdict = decide(x, edge_he, triangles, halfedges, pixels, vertices, normals, former,
                         mode, delta, epsilon, max_angle, min_bend, max_edge2)
        if n_logged < log.shape[0]:
            e0 = edge_he[x]
            a = triangles[e0]
            b = triangles[nxt(e0)]
            log[n_logged, 0] = min(a, b)
            log[n_logged, 1] = max(a, b)
            log[n_logged, 2] = verdict
            n_logged += 1
        verdicts[verdict] += 1
        if verdict != FLIPPED:
            gain[x] = NEG_INF
            rekey(keys, heap, slot, x, NEG_INF, n_e)
            continue
        e0 = edge_he[x]
        former = _set_add(former, _pair_key(triangles[e0], triangles[nxt(e0)], n_v), n_former)
        n_former += 1
        apply_flip(x, he_edge, edge_he, triangles, halfedges, pixels, vertices, depth, valid,
                   cam, normals, err, gain, keys, heap, slot, quantum)
        flips += 1
    return flips
