"""Rasterised triangles: depth rendering and the row scan of a triangle.

Raster lines and the edge error along them live in the core (``_core/geometry/lines.hpp``).
"""

import math

from numba import njit

from .vectors import orient

# Triangles whose box holds more pixels than this are walked over their row spans when their
# corners are pixel centres: below it the walk's set-up costs more than the box's empty half
# (a render of a 16,000-vertex mesh of teddy: 1.1-1.9x slower with every triangle walked;
# with this bound 0.95-1.0x, and 0.6-0.8x on meshes of 1,000-2,000 vertices).
SPAN_MIN_BOX = 64


@njit(cache=True)
def _on_pixels(r0, c0, r1, c1, r2, c2, height, width):
    """Whether the triangle's corners are all pixel centres of the image (integer, inside)."""
    for x, n in ((r0, height), (r1, height), (r2, height), (c0, width), (c1, width), (c2, width)):
        if not (0.0 <= x <= n - 1 and x == math.floor(x)):
            return False
    return True


@njit(cache=True)
def rasterize(face_r, face_c, face_val, height, width, out_val, out_face):
    """Interpolate per-vertex values over each triangle's pixels in the image plane.

    `face_r`, `face_c`, `face_val` are (F, 3) float64. A pixel is covered when
    its centre (integer coordinates) lies inside or on the border of the
    triangle; the first triangle that covers a pixel sets it. Degenerate
    triangles cover nothing. `out_val` (NaN-filled) and `out_face` (-1-filled)
    are written in place.

    A triangle whose corners are pixel centres (every mesh made from an image)
    is walked over its exact row spans (`triangle_rows`), any other over its
    bounding box; both give the same pixels and the same values, bit for bit.
    The spans skip the box's empty half.
    """
    for t in range(face_r.shape[0]):
        r0, r1, r2 = face_r[t, 0], face_r[t, 1], face_r[t, 2]
        c0, c1, c2 = face_c[t, 0], face_c[t, 1], face_c[t, 2]
        area = orient(r0, c0, r1, c1, r2, c2)
        if area == 0.0 or not math.isfinite(area):
            continue
        sgn = 1.0 if area > 0 else -1.0
        rmin = max(int(math.ceil(min(r0, min(r1, r2)))), 0)
        rmax = min(int(math.floor(max(r0, max(r1, r2)))), height - 1)
        cmin = max(int(math.ceil(min(c0, min(c1, c2)))), 0)
        cmax = min(int(math.floor(max(c0, max(c1, c2)))), width - 1)
        if ((rmax - rmin + 1) * (cmax - cmin + 1) > SPAN_MIN_BOX
                and _on_pixels(r0, c0, r1, c1, r2, c2, height, width)):
            _raster_spans(t, int(r0), int(c0), int(r1), int(c1), int(r2), int(c2), sgn,
                          face_val, out_val, out_face)
            continue
        for r in range(rmin, rmax + 1):
            for c in range(cmin, cmax + 1):
                if out_face[r, c] != -1:
                    continue
                w0 = sgn * orient(r1, c1, r2, c2, r, c)
                w1 = sgn * orient(r2, c2, r0, c0, r, c)
                w2 = sgn * orient(r0, c0, r1, c1, r, c)
                if w0 < 0 or w1 < 0 or w2 < 0:
                    continue
                s = w0 + w1 + w2
                out_val[r, c] = (w0 * face_val[t, 0] + w1 * face_val[t, 1]
                                 + w2 * face_val[t, 2]) / s
                out_face[r, c] = t


@njit(cache=True)
def _raster_spans(t, r0, c0, r1, c1, r2, c2, sgn, face_val, out_val, out_face):
    """`rasterize` of one triangle with integer corners, row span by row span.

    The weights are the box loop's (``w0`` of corner 0, ...), read from the
    walk's integer edge functions: the same floats, so the same values.
    """
    if sgn > 0:  # counter-clockwise 0, 1, 2: edges 0->1, 1->2, 2->0 weigh corners 2, 0, 1
        rmin, rmax, cmin, cmax, edges = triangle_rows(r0, c0, r1, c1, r2, c2)
        k0, k1, k2 = 1, 2, 0  # the walk's edge that gives w0, w1, w2
        slopes = (r1 - r0, r2 - r1, r0 - r2)  # each edge's growth a column
    else:  # walked as 0, 2, 1: edges 0->2, 2->1, 1->0 weigh corners 1, 0, 2
        rmin, rmax, cmin, cmax, edges = triangle_rows(r0, c0, r2, c2, r1, c1)
        k0, k1, k2 = 1, 0, 2
        slopes = (r2 - r0, r1 - r2, r0 - r1)
    f0, f1, f2 = face_val[t, 0], face_val[t, 1], face_val[t, 2]
    d0, d1, d2 = float(slopes[k0]), float(slopes[k1]), float(slopes[k2])
    for r in range(rmin, rmax + 1):
        if r > rmin:
            edges = next_row(edges)
        first, last, e0, e1, e2 = row_columns(edges, True, True, True, cmin, cmax)
        e = (e0, e1, e2)
        # integers, exact in float64: the values the box loop computes
        w0, w1, w2 = float(e[k0]), float(e[k1]), float(e[k2])
        for c in range(first, last + 1):
            if out_face[r, c] == -1:
                s = w0 + w1 + w2
                out_val[r, c] = (w0 * f0 + w1 * f1 + w2 * f2) / s
                out_face[r, c] = t
            w0 += d0
            w1 += d1
            w2 += d2


@njit(cache=True)
def edge_start(pr, pc, qr, qc, r0, c0):
    """Where the edge function of P -> Q turns non-negative on row `r0`, to follow down the rows.

    The edge function ``w(r, c) = orient(P, Q, (r, c))`` is linear:
    ``w = v + s * (c - c0)`` on row r, and ``v`` grows by ``dv`` a row. The
    columns where ``w >= 0`` start at ``c0 - floor(v / s)`` (``s > 0``) or end
    at ``c0 + floor(v / -s)`` (``s < 0``). The state keeps that quotient and
    its remainder, which `edge_next` moves to the next row with integer adds:
    one division per edge, none per row (three divisions a row cost 10-15 %
    of greedy insertion's time; the bounds are the same integers).

    Returns
    -------
    tuple of int
        ``(s, v, quotient, remainder, dv, quotient step, remainder step,
        divisor)``; pass it to `edge_next` and `edge_clip`.
    """
    s = qr - pr
    dv = pc - qc
    v = orient(pr, pc, qr, qc, r0, c0)
    d = max(abs(s), 1)  # an edge along a row (s == 0) uses v alone
    q = v // d
    dq = dv // d
    return s, v, q, v - q * d, dv, dq, dv - dq * d, d


@njit(cache=True)
def edge_next(e):
    """The `edge_start` state of the next row."""
    s, v, q, m, dv, dq, dm, d = e
    q += dq
    m += dm
    if m >= d:
        m -= d
        q += 1
    return s, v + dv, q, m, dv, dq, dm, d


@njit(cache=True)
def edge_clip(e, own, c0, lo, hi):
    """Narrow the columns [lo, hi] of the state's row to where the edge function is >= 0.

    With ``own`` False the pixels on the edge itself (``w == 0``) are left
    out too, so two triangles that share an edge can split its pixels. The
    result is empty when ``lo > hi``.
    """
    s, v, q, m = e[0], e[1], e[2], e[3]
    if s > 0:
        b = c0 - q
        if m == 0 and not own:  # w == 0 on column b exactly when v / s leaves no remainder
            b += 1
        return max(lo, b), hi
    if s < 0:
        b = c0 + q
        if m == 0 and not own:
            b -= 1
        return lo, min(hi, b)
    if v < 0 or (v == 0 and not own):  # along the row: all of it or none
        return hi + 1, hi
    return lo, hi


@njit(cache=True)
def triangle_rows(ar, ac, br, bc, cr, cc):
    """Start walking the rows of triangle ABC (counter-clockwise in (row, column)).

    Returns
    -------
    r0, r1, c0, c1 : int
        Its bounding box.
    edges : tuple
        The `edge_start` states of AB, BC and CA on row `r0`; `next_row`
        moves them down a row, `row_columns` reads a row's pixels.
    """
    r0 = min(ar, min(br, cr))
    r1 = max(ar, max(br, cr))
    c0 = min(ac, min(bc, cc))
    c1 = max(ac, max(bc, cc))
    edges = (edge_start(ar, ac, br, bc, r0, c0), edge_start(br, bc, cr, cc, r0, c0),
             edge_start(cr, cc, ar, ac, r0, c0))
    return r0, r1, c0, c1, edges


@njit(cache=True)
def next_row(edges):
    """The `triangle_rows` edge states one row down."""
    return edge_next(edges[0]), edge_next(edges[1]), edge_next(edges[2])


@njit(cache=True)
def row_columns(edges, own0, own1, own2, c0, c1):
    """The columns of the triangle on the edges' row, and its edge functions at the first.

    A pixel is the triangle's when its three edge functions are >= 0, except
    on an edge whose flag (`own0` for AB, `own1` for BC, `own2` for CA) is
    False: so two triangles that share an edge can split its pixels.

    Returns
    -------
    first, last : int
        The columns (none when ``first > last``).
    w0, w1, w2 : int
        ``orient(A, B, p)``, ``orient(B, C, p)`` and ``orient(C, A, p)`` at
        ``p = (row, first)``; along the row they grow by ``rB - rA``,
        ``rC - rB`` and ``rA - rC`` a column.
    """
    e0, e1, e2 = edges
    first, last = edge_clip(e0, own0, c0, c0, c1)
    first, last = edge_clip(e1, own1, c0, first, last)
    first, last = edge_clip(e2, own2, c0, first, last)
    return (first, last, e0[1] + e0[0] * (first - c0), e1[1] + e1[0] * (first - c0),
            e2[1] + e2[0] * (first - c0))
