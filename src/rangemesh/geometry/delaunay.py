"""Numba kernels of stage two: a canonical 2-D Delaunay triangulation of pixel positions.

Pixel grids are full of co-circular points, so "the" Delaunay triangulation
is not unique. We make it unique by Simulation of Simplicity: the lifted
heights ``r^2 + c^2`` get infinitesimal perturbations ``eps^i``, the lowest
vertex index the largest. The triangulation is then the regular
triangulation of the perturbed lifting, which exists, is unique, and is a
Delaunay triangulation of the unperturbed points. Two implementations must
agree on it: the sweep below and Qhull followed by `legalize_all`; the
tests check that they do.

All predicates run on int64 pixel coordinates and are exact: |incircle| stays
below 2**57 for images up to 16384 pixels on a side.

The sweep follows the idea of Delaunator (V. Agafonkin, after Sinclair's
s-hull): insert points by distance from a seed circumcentre, keep the convex
hull in a linked list with an angular hash, add a fan of triangles to the
visible hull edges, legalise by flips. Written here for exact predicates,
our counter-clockwise (r, c) convention and our half-edge layout.
"""

import math

import numpy as np
from numba import njit

from .halfedges import flip_quad, link, nxt, prv

# --------------------------------------------------------------------------
# exact predicates
# --------------------------------------------------------------------------


@njit(cache=True)
def orient_i(pr, pc, a, b, c):
    """Twice the signed area of (a, b, c) in (r, c); > 0 is counter-clockwise. Exact."""
    return (pr[b] - pr[a]) * (pc[c] - pc[a]) - (pc[b] - pc[a]) * (pr[c] - pr[a])


@njit(cache=True)
def incircle_i(pr, pc, a, b, c, d):
    """> 0 when d is strictly inside the circle through counter-clockwise (a, b, c). Exact."""
    adx = pr[a] - pr[d]
    ady = pc[a] - pc[d]
    bdx = pr[b] - pr[d]
    bdy = pc[b] - pc[d]
    cdx = pr[c] - pr[d]
    cdy = pc[c] - pc[d]
    alift = adx * adx + ady * ady
    blift = bdx * bdx + bdy * bdy
    clift = cdx * cdx + cdy * cdy
    return (adx * (bdy * clift - cdy * blift) - ady * (bdx * clift - cdx * blift)
            + alift * (bdx * cdy - cdx * bdy))


@njit(cache=True)
def illegal(pr, pc, u, v, w, x):
    """Edge uv of counter-clockwise (u, v, w), with x across it, must be flipped.

    Strictly inside -> flip. On the circle -> Simulation of Simplicity: with
    perturbations eps^i (smallest vertex id dominant), x is inside iff the
    barycentric weight of the dominant vertex among u, v, w is positive, and
    never when x itself dominates. Three distinct points of a circle are never
    collinear, so the orientations below are never 0.
    """
    det = incircle_i(pr, pc, u, v, w, x)
    if det != 0:
        return det > 0
    m = min(min(u, v), min(w, x))
    if m == x:
        return False
    if m == u:
        return orient_i(pr, pc, x, v, w) > 0
    if m == v:
        return orient_i(pr, pc, u, x, w) > 0
    return orient_i(pr, pc, u, v, x) > 0


# --------------------------------------------------------------------------
# half-edge helpers
# --------------------------------------------------------------------------


@njit(cache=True)
def legalize_all(triangles, halfedges, pr, pc):
    """Lawson flips until every edge is legal under `illegal`; returns the flips made.

    On a Delaunay triangulation only co-circular quads can be illegal, and
    four distinct co-circular points always form a strictly convex quad, so
    every flip is possible; the perturbed lifted surface falls with each flip,
    so the loop ends, at the unique canonical triangulation.
    """
    n = triangles.size
    stack = np.zeros(max(n, 16), np.int64)
    top = 0
    for e in range(n):
        if halfedges[e] > e:
            stack[top] = e
            top += 1
    flips = 0
    while top > 0:
        top -= 1
        e = stack[top]
        t = halfedges[e]
        if t == -1:
            continue
        u = triangles[e]
        v = triangles[nxt(e)]
        w = triangles[prv(e)]
        x = triangles[prv(t)]
        if not illegal(pr, pc, u, v, w, x):
            continue
        flip_quad(triangles, halfedges, e)
        flips += 1
        if top + 4 > stack.size:
            bigger = np.zeros(2 * stack.size, np.int64)
            for k in range(top):  # a loop, not a slice copy: Numba compiles that ~2 s slower
                bigger[k] = stack[k]
            stack = bigger
        for s in (nxt(e), prv(e), nxt(t), prv(t)):
            stack[top] = s
            top += 1
    return flips


# --------------------------------------------------------------------------
# the sweep
# --------------------------------------------------------------------------


@njit(cache=True)
def _pseudo_angle(dx, dy):
    p = dx / (abs(dx) + abs(dy))
    return (3.0 - p if dy > 0 else 1.0 + p) / 4.0  # in [0, 1)


@njit(cache=True)
def _hash_key(r, c, cr, cc, size):
    dx = r - cr
    dy = c - cc
    if dx == 0.0 and dy == 0.0:
        return 0
    return int(math.floor(_pseudo_angle(dx, dy) * size)) % size


@njit(cache=True)
def _add_triangle(triangles, halfedges, n_t, i0, i1, i2, a, b, c):
    t = 3 * n_t
    triangles[t] = i0
    triangles[t + 1] = i1
    triangles[t + 2] = i2
    link(halfedges, t, a)
    link(halfedges, t + 1, b)
    link(halfedges, t + 2, c)
    return t


@njit(cache=True)
def _legalize(triangles, halfedges, pr, pc, hull_tri, a, stack):
    """Flip edges opposite the new point until legal; keep hull_tri pointing at hull edges."""
    top = 0
    while True:
        b = halfedges[a]
        flipped = False
        if b != -1:
            u = triangles[a]
            v = triangles[nxt(a)]
            w = triangles[prv(a)]
            x = triangles[prv(b)]
            if illegal(pr, pc, u, v, w, x):
                flip_quad(triangles, halfedges, a)
                # hull edges among the moved outer half-edges: re-point hull_tri
                for s in (nxt(a), prv(a), nxt(b), prv(b)):
                    if halfedges[s] == -1:
                        hull_tri[triangles[s]] = s
                # w is the new point; the edges now opposite it are prev(a) (u->x)
                # and next(b) (x->v)
                if top + 1 >= stack.size:
                    # the stack is sized to the triangle count: overflowing it means a bug
                    raise RuntimeError("delaunay _legalize: flip stack overflow")
                stack[top] = nxt(b)
                top += 1
                a = prv(a)
                flipped = True
        if not flipped:
            if top == 0:
                return 0
            top -= 1
            a = stack[top]


def delaunay_sweep(pr, pc):
    """Delaunay triangulation of distinct integer points (pr, pc).

    Returns ``(triangles, halfedges, n_triangles)``; ``n_triangles == 0``
    when the points are all collinear (or fewer than 3). Triangles are
    counter-clockwise in (r, c); every point is a vertex.

    Three steps: `sweep_seed` picks the first triangle, NumPy orders the
    points by distance from its circumcentre (a stable sort, so ties keep
    index order), and `sweep_insert` adds them. The sort runs in NumPy
    because Numba's own argsort costs ~1.5 s of compile time on a first run.
    """
    pr = np.ascontiguousarray(pr, dtype=np.int64)
    pc = np.ascontiguousarray(pc, dtype=np.int64)
    i0, i1, i2, cr, cc = sweep_seed(pr, pc)
    if i2 == -1:  # fewer than 3 points, or all collinear
        empty = np.zeros(0, np.int64)
        return empty, empty.copy(), 0
    fr = pr.astype(np.float64)
    fc = pc.astype(np.float64)
    # the same operations, in the same order, as the kernel did: the order is bit for bit the same
    dist = (fr - cr) ** 2 + (fc - cc) ** 2
    order = np.argsort(dist, kind="stable")
    return sweep_insert(pr, pc, order, i0, i1, i2, cr, cc)


@njit(cache=True)
def sweep_seed(pr, pc):
    """The sweep's first triangle ``(i0, i1, i2)``, counter-clockwise, and its circumcentre.

    i0 is the point nearest the bounding-box centre, i1 its nearest neighbour,
    i2 the point making the smallest circumcircle with them. ``i2 == -1``
    when there are fewer than 3 points or all are collinear.
    """
    n = pr.size
    if n < 3:
        return -1, -1, -1, 0.0, 0.0
    fr = pr.astype(np.float64)
    fc = pc.astype(np.float64)
    # min and max by hand: Numba's np.min/np.max add ~0.5 s of first-run compile
    lo_r = hi_r = fr[0]
    lo_c = hi_c = fc[0]
    for i in range(1, n):
        lo_r = min(lo_r, fr[i])
        hi_r = max(hi_r, fr[i])
        lo_c = min(lo_c, fc[i])
        hi_c = max(hi_c, fc[i])
    mr = 0.5 * (lo_r + hi_r)
    mc = 0.5 * (lo_c + hi_c)
    i0 = np.int64(0)  # not literals: see `none` in sweep_insert
    best = np.inf
    for i in range(n):
        d = (fr[i] - mr) ** 2 + (fc[i] - mc) ** 2
        if d < best:
            best = d
            i0 = i
    i1 = np.int64(-1)
    best = np.inf
    for i in range(n):
        if i == i0:
            continue
        d = (fr[i] - fr[i0]) ** 2 + (fc[i] - fc[i0]) ** 2
        if d < best:
            best = d
            i1 = i
    i2 = np.int64(-1)
    best = np.inf
    for i in range(n):
        if i == i0 or i == i1:
            continue
        o = orient_i(pr, pc, i0, i1, i)
        if o == 0:
            continue
        # circumradius^2 of (i0, i1, i)
        ar = fr[i1] - fr[i0]
        ac = fc[i1] - fc[i0]
        br = fr[i] - fr[i0]
        bc = fc[i] - fc[i0]
        bl = ar * ar + ac * ac
        cl = br * br + bc * bc
        den = 0.5 / (ar * bc - ac * br)
        x = (bc * bl - ac * cl) * den
        y = (ar * cl - br * bl) * den
        rr = x * x + y * y
        if rr < best:
            best = rr
            i2 = i
    if i2 == -1:
        return i0, i1, -1, 0.0, 0.0  # all collinear
    if orient_i(pr, pc, i0, i1, i2) < 0:
        i1, i2 = i2, i1
    # circumcentre of the seed
    ar = fr[i1] - fr[i0]
    ac = fc[i1] - fc[i0]
    br = fr[i2] - fr[i0]
    bc = fc[i2] - fc[i0]
    bl = ar * ar + ac * ac
    cl = br * br + bc * bc
    den = 0.5 / (ar * bc - ac * br)
    cr = fr[i0] + (bc * bl - ac * cl) * den
    cc = fc[i0] + (ar * cl - br * bl) * den
    return i0, i1, i2, cr, cc


@njit(cache=True)
def sweep_insert(pr, pc, order, i0, i1, i2, cr, cc):
    """Insert the points in `order` around the seed triangle; see `delaunay_sweep`."""
    n = pr.size
    max_t = max(2 * n - 5, 1)
    triangles = np.full(3 * max_t, -1, np.int64)
    halfedges = np.full(3 * max_t, -1, np.int64)
    fr = pr.astype(np.float64)
    fc = pc.astype(np.float64)
    hash_size = max(int(math.ceil(math.sqrt(n))), 1)
    hull_hash = np.full(hash_size, -1, np.int64)
    hull_next = np.full(n, -1, np.int64)
    hull_prev = np.full(n, -1, np.int64)
    hull_tri = np.full(n, -1, np.int64)
    stack = np.zeros(3 * max_t + 16, np.int64)
    # hull, counter-clockwise: i0 -> i1 -> i2 -> i0
    hull_next[i0] = i1
    hull_next[i1] = i2
    hull_next[i2] = i0
    hull_prev[i0] = i2
    hull_prev[i1] = i0
    hull_prev[i2] = i1
    # np.int64(-1), not a bare -1: a literal argument would make Numba compile
    # _add_triangle and link once more, for that constant (first-run time)
    none = np.int64(-1)
    n_t = np.int64(0)
    t = _add_triangle(triangles, halfedges, n_t, i0, i1, i2, none, none, none)
    n_t += 1
    hull_tri[i0] = t
    hull_tri[i1] = t + 1
    hull_tri[i2] = t + 2
    hull_hash[_hash_key(fr[i0], fc[i0], cr, cc, hash_size)] = i0
    hull_hash[_hash_key(fr[i1], fc[i1], cr, cc, hash_size)] = i1
    hull_hash[_hash_key(fr[i2], fc[i2], cr, cc, hash_size)] = i2
    for k in range(n):
        p = order[k]
        if p == i0 or p == i1 or p == i2:
            continue
        # a hull vertex near p's angle to start the search from
        key = _hash_key(fr[p], fc[p], cr, cc, hash_size)
        start = -1
        for j in range(hash_size):
            s = hull_hash[(key + j) % hash_size]
            if s != -1 and hull_next[s] != s:
                start = s
                break
        start = hull_prev[start]
        e = start
        # edge e -> next(e) is visible when p is strictly on its right (outside)
        while orient_i(pr, pc, e, hull_next[e], p) >= 0:
            e = hull_next[e]
            if e == start:
                e = -1
                break
        if e == -1:
            # distinct points swept in distance order always see a hull edge
            raise RuntimeError("delaunay_sweep: a point sees no hull edge (duplicate points?)")
        after = hull_next[e]
        # first triangle on the visible edge e -> after: (after, e, p)
        t = _add_triangle(triangles, halfedges, n_t, after, e, p, hull_tri[e], none, none)
        n_t += 1
        hull_tri[e] = t + 1   # e -> p
        hull_tri[p] = t + 2   # p -> after
        _legalize(triangles, halfedges, pr, pc, hull_tri, t, stack)
        # walk forward: after -> q visible too?
        while True:
            q = hull_next[after]
            if orient_i(pr, pc, after, q, p) >= 0:
                break
            # triangle (q, after, p): q->after twins the hull edge after->q; after->p twins p->after
            t = _add_triangle(triangles, halfedges, n_t, q, after, p, hull_tri[after], hull_tri[p], none)
            n_t += 1
            hull_tri[p] = t + 2   # p -> q
            _legalize(triangles, halfedges, pr, pc, hull_tri, t, stack)
            hull_next[after] = after  # off the hull
            after = q
        # walk backward: q -> e visible?
        if e == start:
            while True:
                q = hull_prev[e]
                if orient_i(pr, pc, q, e, p) >= 0:
                    break
                # triangle (e, q, p): e->q twins q->e; p->e twins e->p
                t = _add_triangle(triangles, halfedges, n_t, e, q, p, hull_tri[q], none, hull_tri[e])
                n_t += 1
                hull_tri[q] = t + 1   # q -> p
                _legalize(triangles, halfedges, pr, pc, hull_tri, t, stack)
                hull_next[e] = e
                e = q
        hull_prev[p] = e
        hull_next[e] = p
        hull_prev[after] = p
        hull_next[p] = after
        hull_hash[_hash_key(fr[p], fc[p], cr, cc, hash_size)] = p
        hull_hash[_hash_key(fr[e], fc[e], cr, cc, hash_size)] = e
    return triangles[: 3 * n_t], halfedges[: 3 * n_t], n_t


