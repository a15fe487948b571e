"""The row scan of a triangle, for the Numba kernels that still walk it.

Raster lines and the edge error along them (``_core/geometry/lines.hpp``) and the depth render
(``_core/geometry/rasterize.hpp``) live in the core.
"""

from numba import njit

from .vectors import orient


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
