"""Each quad's diagonal chosen by the data: edge flips that lower the error over the pixels.

Greedy insertion keeps its mesh Delaunay: every diagonal is the one that
makes rounder triangles, whatever the depths. Along a crease or a jump edge
that is not where the pixels say it is, the round diagonal cuts a corner off
one surface and puts it on the other. Dyn, Levin & Rippa's data-dependent
triangulation (1990) picks each quad's diagonal by the data instead; here the
measure is the one the insertion already ranks by: the sum of |depth - plane|
over the valid pixels of the two triangles (vertex depths copied from their
pixels). An edge is flipped when the other diagonal's sum is smaller, and the
four outer edges of its quad are tested again, until no flip lowers the sum.

* Pixels on the quad's outer edges stay with the same side after a flip (the
  ownership rules of `rangemesh.greedy.kernels`: `_owns` depends on an edge's
  direction only, and the outer edges keep theirs), and the diagonal's pixels
  belong to one triangle either way: both diagonals are measured on the same
  pixels, and every valid pixel counts once.
* Sums are compared in the insertion's key units (2**-32 of the valid depth
  range, `_quantize`), so a near-tie does not flip one way in metres and the
  other in millimetres (SPEC P2), and a quad that fits exactly either way (a
  plane) is never flipped.
* A quad with a background vertex (an image corner) is never flipped: those
  triangles hold no valid pixel to be judged by and are dropped afterwards;
  flipping them could uncover valid pixels.
* Every flip lowers the total strictly, so the flips end; at most
  `MAX_TESTS_PER_EDGE` tests an edge bound the time all the same.

Measured with ``benchmarks/diagonals.py`` (69 cases: every shared image and
scene at 1, 3 and 10 % of its valid pixels, fitted depths after): medians of
0.93x the mean error and 0.87x the error within 2 px of jumps of the Delaunay
mesh, at 1.21x the whole call's time (the flips test most edges once, two
triangles rasterised a test). They are `method='refine'`'s default: with
them a call still takes less time than pydelatin's over those cases (median
0.96x; README, Results).
Two things keep them cheap: on strips (`rangemesh.greedy.strips`) each
strip flips on its own thread (`flip_state`), and only the seam's edges are
tested after the join (`flip_edges`); and a test stops scanning once the
other diagonal is known to be no better (`triangle_error`'s `stop`).
Testing only quads with more than the mean error per pixel saved 28 % of
the flips' time and gave back a quarter of the gain: not kept.
"""

import math

import numpy as np
from numba import njit

from ..geometry.halfedges import build_halfedges, flip_quad, nxt, prv, quad_halfedges
from ..geometry.raster import next_row, row_columns, triangle_rows
from ..geometry.vectors import orient
from .kernels import KEY_STEPS, _own_edge, _owns, _quantize

# The flips stop after this many tests per interior edge even if some would still lower the
# error (each flip lowers it strictly, so they end anyway; this bounds the worst case).
MAX_TESTS_PER_EDGE = 8


@njit(cache=True, nogil=True)
def triangle_error(ar, ac, az, br, bc, bz, cr, cc, cz, own0, own1, own2, depth, valid,
                   base=0.0, span=0.0, stop=math.inf):
    """Sum of |depth - plane| over the valid pixels of triangle ABC (counter-clockwise).

    The pixels are those `rangemesh.greedy.kernels._scan` visits: inside, or
    on an edge whose flag (`own0` for AB, `own1` for BC, `own2` for CA) is
    True; the plane goes through the corners' depths `az`, `bz`, `cz`.

    The row loop of `_scan` without its worst pixel, in the same arithmetic and
    order: its sums equal the kernel's `tsum` bit for bit (tested), so cached and
    fresh sums compare. (Calling `_scan` would track a worst pixel nobody reads.)

    With a key `stop`, the sum is left part-way, after a row, once
    ``_quantize(base + sum so far, span) >= stop``: a flip test's answer is
    known then (the rest can only add), and that saves scanning the rest.
    The sum returned is then the part, still at least `stop` in key units.
    """
    area = orient(ar, ac, br, bc, cr, cc)
    inv = 1.0 / area
    total = 0.0
    # a cheap bound first: only a sum of at least (stop - 0.5) key steps can quantise to stop
    cut = (stop - 0.5) * span / KEY_STEPS if stop < math.inf else math.inf
    r0, r1, c0, c1, edges = triangle_rows(ar, ac, br, bc, cr, cc)
    f0, f1, f2 = float(br - ar), float(cr - br), float(ar - cr)
    for r in range(r0, r1 + 1):
        if r > r0:
            edges = next_row(edges)
        first, last, v0, v1, v2 = row_columns(edges, own0, own1, own2, c0, c1)
        if first > last:
            continue
        drow = depth[r]
        vrow = valid[r]
        w0, w1, w2 = float(v0), float(v1), float(v2)
        for c in range(first, last + 1):
            if vrow[c]:
                total += abs(drow[c] - (w1 * az + w2 * bz + w0 * cz) * inv)
            w0 += f0
            w1 += f1
            w2 += f2
        if base + total >= cut and _quantize(base + total, span) >= stop:
            return total
    return total


@njit(cache=True, nogil=True)
def _face_error(t, tri, he, vr, vc, vz, depth, valid):
    e = 3 * t
    a, b, c = tri[e], tri[e + 1], tri[e + 2]
    w = depth.shape[1]
    return triangle_error(vr[a], vc[a], vz[a], vr[b], vc[b], vz[b], vr[c], vc[c], vz[c],
                          _own_edge(he[e], vr[a], vc[a], vr[b], vc[b], w),
                          _own_edge(he[e + 1], vr[b], vc[b], vr[c], vc[c], w),
                          _own_edge(he[e + 2], vr[c], vc[c], vr[a], vc[a], w), depth, valid)


@njit(cache=True)
def error_flips(vr, vc, tv, depth, valid, span):
    """Flip the edges of a mesh while a flip lowers the error of its two triangles.

    Parameters
    ----------
    vr, vc : (V,) int64
        Vertex pixels (background vertices allowed: quads that touch one
        are left alone).
    tv : (3 * T,) int64
        Triangles, counter-clockwise in (row, column), an edge-manifold
        triangulation; not changed.
    depth : (H, W) float64
    valid : (H, W) bool
    span : float
        The valid depth range (the comparison's unit, as the insertion's).

    Returns
    -------
    tv : (3 * T,) int64
        The triangles after the flips (same vertices, same count).
    flips, tests : int
    """
    tri, he = build_halfedges(tv.reshape(-1, 3), vr.size)
    n_t = tri.size // 3
    vz = _vertex_depths(vr, vc, depth, valid)
    tsum = np.zeros(n_t)
    for t in range(n_t):
        e = 3 * t
        if valid[vr[tri[e]], vc[tri[e]]] and valid[vr[tri[e + 1]], vc[tri[e + 1]]] \
                and valid[vr[tri[e + 2]], vc[tri[e + 2]]]:
            tsum[t] = _face_error(t, tri, he, vr, vc, vz, depth, valid)
    flips, tests = flip_by_error(vr, vc, tri, he, tsum, depth, valid, span)
    return tri, flips, tests


@njit(cache=True, nogil=True)
def _vertex_depths(vr, vc, depth, valid):
    vz = np.zeros(vr.size)
    for v in range(vr.size):
        if valid[vr[v], vc[v]]:
            vz[v] = depth[vr[v], vc[v]]
    return vz


@njit(cache=True, nogil=True)
def flip_by_error(vr, vc, tri, he, tsum, depth, valid, span):
    """`error_flips` on a mesh whose half-edges and triangle sums are known; in place.

    `tri`, `he` are flat half-edge arrays (`rangemesh.geometry.halfedges`) and
    `tsum` each triangle's error sum over the pixels it owns (as
    `triangle_error` with the ownership rules; what greedy insertion keeps,
    `rangemesh.greedy.kernels.greedy_insert_sums`). Returns ``flips, tests``.
    Runs without the GIL.
    """
    vz, stack, top, queued = _first_stack(vr, vc, tri, he, tsum, depth, valid)
    return _flip_stack(vr, vc, vz, tri, he, tsum, depth, valid, span, stack, top, queued)


@njit(cache=True, nogil=True)
def _first_stack(vr, vc, tri, he, tsum, depth, valid):
    """Vertex depths, and a stack of every interior edge with no background corner.

    Triangles with a background vertex get sum -1 (`_background_out`). The
    stack holds one half-edge an edge, popped in order of e; ``queued[e]``: e
    is on it.
    """
    vz = _background_out(vr, vc, tri, tsum, depth, valid)
    queued = np.zeros(tri.size, np.bool_)
    stack = np.empty(tri.size, np.int64)
    top = 0
    for e in range(tri.size - 1, -1, -1):
        if he[e] > e and tsum[e // 3] >= 0.0 and tsum[he[e] // 3] >= 0.0:
            stack[top] = e
            top += 1
            queued[e] = True
    return vz, stack, top, queued


@njit(cache=True, nogil=True)
def flip_state(depth, valid, state, span):
    """`flip_by_error` on the mesh of a greedy insertion state (`kernels.advance`), in place.

    Afterwards the state holds the flipped mesh for `kernels.result`, its
    half-edges and sums; its keys and heap are stale (do not advance it).
    Returns ``flips, tests``. Runs without the GIL: two strips' states flip on
    two threads (`rangemesh.greedy.strips`).
    """
    counts = state[17]
    n_v, n_t = counts[0], counts[1]
    return flip_by_error(state[0][:n_v], state[1][:n_v], state[4][:3 * n_t], state[5][:3 * n_t],
                         state[9][:n_t], depth, valid, span)


@njit(cache=True, nogil=True)
def flip_edges(vr, vc, tri, he, tsum, depth, valid, span, first):
    """`flip_by_error` starting from the half-edges `first` only, and the edges flips touch.

    For a mesh whose other edges already passed their tests: two meshes
    joined along a seam (`rangemesh.greedy.strips`), `first` the seam's
    half-edges. The sums of the triangles on those edges are computed afresh
    (the seam's pixels, no triangle's before, now belong to one side); the
    other sums are taken as given. Returns ``flips, tests``.
    """
    vz = _background_out(vr, vc, tri, tsum, depth, valid)
    for i in range(first.size):
        for t in (first[i] // 3, he[first[i]] // 3):
            if t >= 0 and tsum[t] >= 0.0:
                tsum[t] = _face_error(t, tri, he, vr, vc, vz, depth, valid)
    queued = np.zeros(tri.size, np.bool_)
    stack = np.empty(tri.size, np.int64)
    top = 0
    for i in range(first.size - 1, -1, -1):  # popped in the order given
        e = first[i]
        g = he[e]
        if g >= 0 and not queued[e] and not queued[g]:
            stack[top] = e
            top += 1
            queued[e] = True
    return _flip_stack(vr, vc, vz, tri, he, tsum, depth, valid, span, stack, top, queued)


@njit(cache=True, nogil=True)
def _background_out(vr, vc, tri, tsum, depth, valid):
    """The vertex depths; triangles with a background vertex get sum -1 (never flipped)."""
    for t in range(tri.size // 3):
        e = 3 * t
        if not (valid[vr[tri[e]], vc[tri[e]]] and valid[vr[tri[e + 1]], vc[tri[e + 1]]]
                and valid[vr[tri[e + 2]], vc[tri[e + 2]]]):
            tsum[t] = -1.0
    return _vertex_depths(vr, vc, depth, valid)


@njit(cache=True, nogil=True)
def _flip_stack(vr, vc, vz, tri, he, tsum, depth, valid, span, stack, top, queued):
    """Test the edges on the stack (`top` of them), flipping those whose error drops."""
    w = depth.shape[1]
    flips = 0
    tests = 0
    max_tests = MAX_TESTS_PER_EDGE * top
    while top > 0 and tests < max_tests:
        top -= 1
        e0 = stack[top]
        e1, b0, c0, b1, c1 = quad_halfedges(he, e0)
        queued[e0] = False
        if e1 < 0:
            continue
        t0, t1 = e0 // 3, e1 // 3
        if tsum[t0] < 0.0 or tsum[t1] < 0.0:
            continue
        old = _quantize(tsum[t0] + tsum[t1], span)
        if old == 0.0:  # nothing to gain
            continue
        a, b, c, d = tri[e0], tri[b0], tri[c0], tri[c1]
        ar, ac, br, bc, cr, cc, dr, dc = vr[a], vc[a], vr[b], vc[b], vr[c], vc[c], vr[d], vc[d]
        # ABC + BAD -> DCA + CDB: both counter-clockwise only when the quad is convex
        if orient(dr, dc, cr, cc, ar, ac) <= 0 or orient(cr, cc, dr, dc, br, bc) <= 0:
            continue
        tests += 1
        own_dc = _owns(dr, dc, cr, cc)
        # each scan stops once the other diagonal is known to be no better (the sums only
        # grow): 70-80 % of the tests flip nothing, most of them with a far larger sum
        s0 = triangle_error(dr, dc, vz[d], cr, cc, vz[c], ar, ac, vz[a], own_dc,
                            _own_edge(he[c0], cr, cc, ar, ac, w),
                            _own_edge(he[b1], ar, ac, dr, dc, w), depth, valid, 0.0, span, old)
        if _quantize(s0, span) >= old:
            continue
        s1 = triangle_error(cr, cc, vz[c], dr, dc, vz[d], br, bc, vz[b], not own_dc,
                            _own_edge(he[c1], dr, dc, br, bc, w),
                            _own_edge(he[b0], br, bc, cr, cc, w), depth, valid, s0, span, old)
        if _quantize(s0 + s1, span) >= old:
            continue
        flip_quad(tri, he, e0)
        tsum[t0] = s0
        tsum[t1] = s1
        flips += 1
        # the quad's four outer edges: their other triangles now face new ones
        for f in (nxt(e0), prv(e0), nxt(e1), prv(e1)):
            g = he[f]
            if g >= 0 and not queued[f] and not queued[g]:
                stack[top] = f
                top += 1
                queued[f] = True
    return flips, tests
