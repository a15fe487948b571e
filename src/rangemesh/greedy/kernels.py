"""Greedy insertion kernels: a Delaunay mesh refined at a worst pixel, one pixel at a time.

The mesh starts as the image rectangle cut in two. Every triangle knows its
worst pixel (largest vertical distance between the image and the triangle's
plane) and the sum of its pixels' distances; an indexed max-heap orders the
triangles. Each step inserts the worst pixel of the first triangle, splitting
it (or the two triangles of the edge it lies on), restores the Delaunay
property with Lawson flips, and rasterises only the triangles that changed.
This is Garland & Heckbert's "greedy insertion" (1995), the method of hmm and
delatin, written here for range images:

* triangles are ranked by ``sqrt(worst error * error sum)``, not by the worst
  error alone: Garland & Heckbert's order (hmm, delatin) spends vertices on a
  few pixels of large error, along jumps, long before broad areas of small
  error; the summed error alone leaves jumps for last. Measured with
  ``benchmarks/budgets.py`` (66 cases at 1, 3 and 10 % of the valid pixels,
  fitted depths): mean error against quadric decimation 1.00 -> 0.88 (0.94
  by the sum alone), error near jumps against pydelatin 0.97 -> 1.00 (1.27
  by the sum alone; worst^0.67 * sum^0.33 gave 0.90 and 1.00);
* background pixels never become vertices and never count in the error; a
  background image corner takes the depth of its nearest valid pixel so that a
  silhouette is not a jump to 0;
* a triangle with a background vertex (an image corner) must not keep valid
  pixels: its pixels to cover come first in the heap (keys above
  ``COVER_KEY``, above every error), the one farthest from the corner's
  opposite edge first (`_cover_pixel`), so the triangles dropped at the end
  cover only background;
* pixels on an edge shared by two triangles belong to one of them (the one
  on the edge's left when it is walked with rows, then columns, increasing),
  so the error sums count every pixel once;
* vertices asked beyond an exact mesh (every pixel on its triangle's plane)
  go to the largest exact triangles, at their centroids; what such a split
  makes inside one plane is keyed without a scan, and its flips never join
  two planes, so an exact mesh stays exact (`_spread_key`, `_flat_cavity`,
  `_legalize`).

Coordinates are integers (row, column) and every geometric predicate is exact
in int64 for images up to about 30,000 pixels a side.
"""

import math

import numpy as np
from numba import njit

from ..geometry.halfedges import link, nxt, prv
from ..geometry.heap import rekey, sift_up
from ..geometry.raster import next_row, row_columns, triangle_rows
from ..geometry.vectors import orient

# Errors are ranked in units of 2**-32 of the valid depth range, so that a change of depth
# unit (depth times s, kz divided by s) cannot reorder two pixels by rounding (SPEC P2), as
# the paper's flip gains are. Keys of pixels that must be covered lie above every error key.
KEY_STEPS = 4294967296.0
COVER_KEY = 1.25 * KEY_STEPS
# Keys below 1 (no error key is): a triangle whose pixels all fit its plane to within half a
# key step ranks below SMALL_KEY by its area (`_spread_key`); one with errors too small for
# a key of 1 at SMALL_KEY, above them.
SMALL_KEY = 0.5


@njit(cache=True)
def _quantize(err, span):
    if span > 0.0:
        return math.floor(err / span * KEY_STEPS + 0.5)
    return 0.0


@njit(cache=True)
def _incircle(ar, ac, br, bc, cr, cc, dr, dc):
    """> 0 when d lies strictly inside the circle through the counter-clockwise a, b, c."""
    adr = ar - dr
    adc = ac - dc
    bdr = br - dr
    bdc = bc - dc
    cdr = cr - dr
    cdc = cc - dc
    ad = adr * adr + adc * adc
    bd = bdr * bdr + bdc * bdc
    cd = cdr * cdr + cdc * cdc
    return (adr * (bdc * cd - bd * cdc) - adc * (bdr * cd - bd * cdr) + ad * (bdr * cdc - bdc * cdr))


@njit(cache=True)
def _owns(ar, ac, br, bc):
    """Whether the triangle left of the directed edge a -> b owns the pixels on it."""
    return br > ar or (br == ar and bc > ac)


@njit(cache=True)
def _own_edge(twin, ar, ac, br, bc, w):
    """Whether a triangle owns the pixels on its edge a -> b, whose twin half-edge is `twin`.

    A shared edge's pixels belong to one side (`_owns`); a hull edge's to its
    only triangle, except on a seam: a hull edge down an inner column, where a
    mesh of a vertical strip of the image (`rangemesh.greedy.strips`) meets the
    next. The seam's vertices are fixed beforehand; its pixels are no
    candidates in either strip, and a vertex there would not be in the other.
    """
    if twin < 0:
        return not (ac == bc and 0 < ac < w - 1)
    return _owns(ar, ac, br, bc)


@njit(cache=True)
def _cover_pixel(ar, ac, br, bc, cr, cc, own0, own1, own2, lost0, lost1, lost2, bga, bgb, bgc,
                 valid, best):
    """The pixel that covers a background-corner triangle best, as QuickHull picks a point.

    Among the valid pixels that need covering, the one with the largest
    barycentric weight of a background corner: the farthest from the corner's
    opposite edge, towards the corner. Inserting it leaves the corner two
    triangles that hold no valid pixel unless the valid region bends inwards
    there, so a straight silhouette costs one vertex, not one per pixel (the
    nearest pixel to the corner, tried first, marched along such lines). The
    weight is an exact integer; ties go to the first pixel in row-major order.

    `best` receives ``(weight, row, col)`` (weight -1 when no pixel needs
    covering). Returns whether the triangle holds any valid pixel.
    """
    r0, r1, c0, c1, edges = triangle_rows(ar, ac, br, bc, cr, cc)
    s0 = br - ar  # w0 = orient(A, B, p): the weight of C
    s1 = cr - br  # w1: the weight of A
    s2 = ar - cr  # w2: the weight of B
    seen = False
    best[0] = -1
    best[1] = -1
    best[2] = -1
    for r in range(r0, r1 + 1):
        if r > r0:
            edges = next_row(edges)
        first, last, v0, v1, v2 = row_columns(edges, own0, own1, own2, c0, c1)
        if first > last:
            continue
        # the corners' weights are linear along the row: no pixel of it can beat `best`
        # when none of them does at either end of the span (and valid pixels were seen)
        if seen and best[0] >= 0:
            bound = -1
            for cb in (first, last):
                if bga:
                    bound = max(bound, v1 + s1 * (cb - first))
                if bgb:
                    bound = max(bound, v2 + s2 * (cb - first))
                if bgc:
                    bound = max(bound, v0 + s0 * (cb - first))
            if bound < best[0]:
                continue
        for c in range(first, last + 1):
            if not valid[r, c]:
                continue
            w0 = v0 + s0 * (c - first)
            w1 = v1 + s1 * (c - first)
            w2 = v2 + s2 * (c - first)
            seen = True
            if (r == ar and c == ac) or (r == br and c == bc) or (r == cr and c == cc):
                continue
            if (w0 == 0 and not lost0) or (w1 == 0 and not lost1) or (w2 == 0 and not lost2):
                continue  # on an edge that stays: competes by its error (full scan)
            w = -1
            if bga:
                w = max(w, w1)
            if bgb:
                w = max(w, w2)
            if bgc:
                w = max(w, w0)
            if w > best[0]:  # row-major visit: an equal weight never replaces the first
                best[0] = w
                best[1] = r
                best[2] = c
    return seen


@njit(cache=True)
def _scan(t, tv, he, vr, vc, vz, vbg, depth, valid, span, out):
    """Rasterise triangle `t`: its worst pixel, that pixel's key, and its error sum.

    Writes ``out[0] = key`` (-1 when no pixel can be inserted), ``out[1], out[2]``
    = row, column of that pixel, ``out[3]`` = sum of |depth - plane| over the valid
    pixels the triangle owns, and ``out[4]`` = 1 when the triangle fits exactly and
    that pixel is its centroid (`_centroid_pixel`), else 0.
    """
    out[4] = 0.0
    ia = tv[3 * t]
    ib = tv[3 * t + 1]
    ic = tv[3 * t + 2]
    ar, ac, az = vr[ia], vc[ia], vz[ia]
    br, bc, bz = vr[ib], vc[ib], vz[ib]
    cr, cc, cz = vr[ic], vc[ic], vz[ic]
    bga, bgb, bgc = vbg[ia], vbg[ib], vbg[ic]
    area = orient(ar, ac, br, bc, cr, cc)
    cover = bga or bgb or bgc
    # pixels on an edge: the image border's always, a shared edge's by one side only
    w = depth.shape[1]
    own0 = _own_edge(he[3 * t], ar, ac, br, bc, w)
    own1 = _own_edge(he[3 * t + 1], br, bc, cr, cc, w)
    own2 = _own_edge(he[3 * t + 2], cr, cc, ar, ac, w)
    # A valid pixel on an edge of a background-corner triangle needs covering only
    # when the edge itself has a background end: both its triangles go. On an edge
    # between two valid vertices it competes by its error, and is covered once the
    # triangle across has no background corner, which the cover of that triangle's
    # own pixels brings about. (A cover key for every valid pixel on an edge put a
    # vertex on each pixel of a silhouette's straight edges: on tsukuba, 600 of 876
    # vertices; one for those whose triangle across also had a background corner
    # still marched along them pixel by pixel, leaving 10 % uncovered at 449.)
    lost0 = bga or bgb
    lost1 = bgb or bgc
    lost2 = bgc or bga
    if cover:
        # Cover first: the pixel to insert is found by `_cover_pixel`, mostly without
        # visiting the whole triangle. Its error sum is not needed
        # (left 0): a triangle with a cover key is split before any stop on the sum, and
        # `total` subtracts the same 0 when it goes. Only a triangle with valid pixels and
        # none to cover (they lie on edges that stay) is scanned in full, below.
        near = np.zeros(3, np.int64)
        seen = _cover_pixel(ar, ac, br, bc, cr, cc, own0, own1, own2, lost0, lost1, lost2,
                            bga, bgb, bgc, valid, near)
        if near[0] >= 0:
            out[0] = COVER_KEY * (1.0 + near[0] / area)
            out[1] = near[1]
            out[2] = near[2]
            out[3] = 0.0
            return
        if not seen:
            out[0] = -1.0
            out[1] = -1
            out[2] = -1
            out[3] = 0.0
            return
    best = -1.0
    best_err = -1.0
    best_r = -1
    best_c = -1
    total = 0.0
    inv = 1.0 / area
    # Each row is visited over its span inside the triangle only (exact integer bounds,
    # pixels on edges the triangle does not own left out), as delatin does: bounding-box
    # scans of long thin triangles cost 4x more. Edge functions are linear along a row.
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
        # float64 holds these integers exactly (|w| < 2**53): no int-to-float per pixel
        w0, w1, w2 = float(v0), float(v1), float(v2)
        for c in range(first, last + 1):
            if vrow[c]:
                z = (w1 * az + w2 * bz + w0 * cz) * inv
                err = abs(drow[c] - z)
                total += err
                # (a triangle with a pixel to cover never gets here: see above)
                if err > best_err and not ((r == ar and c == ac) or (r == br and c == bc)
                                           or (r == cr and c == cc)):
                    key = _quantize(err, span)  # only a larger error can have a larger key
                    if key > best:
                        best = key
                        best_err = err
                        best_r = r
                        best_c = c
            w0 += f0
            w1 += f1
            w2 += f2
    out[4] = 0.0
    if best == 0.0:  # every pixel fits the plane to within half a key step
        best = _spread_key(area, depth.shape[0], depth.shape[1])
        pr, pc = _centroid_pixel(ar, ac, br, bc, cr, cc, valid)
        if pr >= 0:
            best_r, best_c = pr, pc
            out[4] = 1.0
    elif 0.0 < best <= KEY_STEPS:  # an error key (not a cover key): rank by max and sum
        best = _quantize(math.sqrt(best_err * total / (depth.shape[0] * depth.shape[1])), span)
        if best == 0.0:
            best = SMALL_KEY
    out[0] = best  # -1 when no pixel can be inserted
    out[1] = best_r
    out[2] = best_c
    out[3] = total


@njit(cache=True)
def _spread_key(area, h, w):
    """The key of a triangle that fits exactly: below every other, larger triangles first.

    Vertices asked beyond an exact mesh then go to the largest triangles, at
    their centroids, and spread over the image (inserting the first pixel of
    the smallest triangles crowded them into a corner).
    """
    return SMALL_KEY * area / (2.0 * h * w + 1.0)


@njit(cache=True)
def _on_plane(plane, span, r, c, z):
    """Whether depth `z` at pixel (r, c) lies on `plane` to within half a key step.

    `plane` holds a triangle's corners, (row, column, depth) each.
    """
    ar, ac, az = plane[0], plane[1], plane[2]
    br, bc, bz = plane[3], plane[4], plane[5]
    cr, cc, cz = plane[6], plane[7], plane[8]
    zp = (orient(br, bc, cr, cc, r, c) * az + orient(cr, cc, ar, ac, r, c) * bz
          + orient(ar, ac, br, bc, r, c) * cz) / orient(ar, ac, br, bc, cr, cc)
    return _quantize(abs(z - zp), span) == 0.0


@njit(cache=True)
def _flat_cavity(t, old_t, changed, n_changed, tv, vr, vc, terr, vz, plane, span):
    """Whether an exact split left only triangles that fit exactly: no scan needed.

    The triangles an insertion made (`changed`) tile what it replaced: the
    split triangle and the neighbours whose edges were flipped, which keep
    their ids (below `old_t`, their keys still theirs). When each of those
    fitted exactly (a key below SMALL_KEY) and every corner of the new
    triangles lies on the split triangle's plane (`_on_plane`), every new
    triangle's pixels fit its plane too.
    """
    for i in range(3, n_changed):
        s = changed[i]
        if s != t and s < old_t and not 0.0 < terr[s] < SMALL_KEY:
            return False
    for i in range(n_changed):
        for k in range(3):
            v = tv[3 * changed[i] + k]
            if not _on_plane(plane, span, vr[v], vc[v], vz[v]):
                return False
    return True


@njit(cache=True)
def _fit_child(t, tv, vr, vc, valid, h, w, out):
    """Key a child of an exactly fitting triangle split at its centroid, without a scan.

    Its pixels fit the parent's plane, which its new corner (an exact pixel)
    keeps: its key is `_spread_key` and its pixel to insert its centroid.
    Returns False, writing nothing, when that centroid is no valid inside
    pixel: the child must then be scanned.
    """
    ia, ib, ic = tv[3 * t], tv[3 * t + 1], tv[3 * t + 2]
    pr, pc = _centroid_pixel(vr[ia], vc[ia], vr[ib], vc[ib], vr[ic], vc[ic], valid)
    if pr < 0:
        return False
    out[0] = _spread_key(orient(vr[ia], vc[ia], vr[ib], vc[ib], vr[ic], vc[ic]), h, w)
    out[1] = pr
    out[2] = pc
    out[4] = 1.0
    return True


@njit(cache=True)
def _centroid_pixel(ar, ac, br, bc, cr, cc, valid):
    """The pixel nearest the triangle's centroid when it is valid and strictly inside, else -1s.

    Strictly inside, it lies on no edge: inserting it splits the triangle in
    three, and no other vertex can be there (a mesh triangle holds none).
    """
    r = (ar + br + cr + 1) // 3
    c = (ac + bc + cc + 1) // 3
    if (orient(ar, ac, br, bc, r, c) > 0 and orient(br, bc, cr, cc, r, c) > 0
            and orient(cr, cc, ar, ac, r, c) > 0 and valid[r, c]):
        return r, c
    return -1, -1


@njit(cache=True)
def _legalize(e0, tv, he, vr, vc, changed, n_changed, stack, guard, terr, vz, plane, span, sr,
              sc):
    """Lawson flips from half-edge `e0`, whose opposite vertex is the new point.

    With `guard` (the split triangle fits exactly; its corners are in
    `plane`), its creases are kept: an edge whose far triangle fits exactly
    (or holds no pixel to insert) is flipped only when that triangle's far
    corner lies on the split triangle's plane (`_on_plane`). Flipping it
    would join two planes in one triangle: vertices asked beyond an exact
    mesh of a pyramid broke it, and left it inexact when the count ran out.

    Rows count `sr` and columns `sc` in the circle test (`delaunay_scales`):
    the mesh is Delaunay in the sensor's units, not in pixels.
    """
    top = 0
    stack[top] = e0
    top += 1
    while top > 0:
        top -= 1
        a = stack[top]
        b = he[a]
        if b < 0:
            continue
        al = nxt(a)
        ar = prv(a)
        bn = nxt(b)
        bp = prv(b)
        pa = tv[a]
        pb = tv[al]
        pc = tv[ar]
        pd = tv[bp]
        if _incircle(sr * vr[pa], sc * vc[pa], sr * vr[pb], sc * vc[pb], sr * vr[pc],
                     sc * vc[pc], sr * vr[pd], sc * vc[pd]) <= 0:
            continue
        if guard and terr[b // 3] < SMALL_KEY and not _on_plane(plane, span, vr[pd], vc[pd],
                                                                vz[pd]):
            continue
        # flip A-B to C-D: (A, B, C) + (B, A, D) -> (D, B, C) + (C, A, D)
        hbp = he[bp]
        har = he[ar]
        tv[a] = pd
        tv[b] = pc
        link(he, a, hbp)
        link(he, b, har)
        link(he, ar, bp)
        changed[n_changed] = a // 3
        changed[n_changed + 1] = b // 3
        n_changed += 2
        stack[top] = a  # (D, B, C): D -> B is opposite the new point C
        stack[top + 1] = bn  # (C, A, D): A -> D is opposite C
        top += 2
    return n_changed


@njit(cache=True)
def _new_tri(tv, he, t, a, b, c):
    tv[3 * t] = a
    tv[3 * t + 1] = b
    tv[3 * t + 2] = c
    he[3 * t] = -1
    he[3 * t + 1] = -1
    he[3 * t + 2] = -1


@njit(cache=True)
def _insert(t, p, tv, he, vr, vc, n_t, changed, stack, outer, guard, terr, vz, plane, span, sr,
            sc):
    """Insert vertex `p` (inside or on an edge of triangle `t`); returns (n_t, n_changed)."""
    e = 3 * t
    pr, pc = vr[p], vc[p]
    on = -1
    for k in range(3):
        a = tv[e + k]
        b = tv[e + (k + 1) % 3]
        if orient(vr[a], vc[a], vr[b], vc[b], pr, pc) == 0:
            on = k
    n_changed = 0
    if on < 0:
        a, b, c = tv[e], tv[e + 1], tv[e + 2]
        h_ab, h_bc, h_ca = he[e], he[e + 1], he[e + 2]
        t1 = n_t
        t2 = n_t + 1
        _new_tri(tv, he, t, a, b, p)
        _new_tri(tv, he, t1, b, c, p)
        _new_tri(tv, he, t2, c, a, p)
        link(he, 3 * t, h_ab)
        link(he, 3 * t1, h_bc)
        link(he, 3 * t2, h_ca)
        link(he, 3 * t + 1, 3 * t1 + 2)
        link(he, 3 * t1 + 1, 3 * t2 + 2)
        link(he, 3 * t2 + 1, 3 * t + 2)
        changed[0] = t
        changed[1] = t1
        changed[2] = t2
        n_changed = 3
        for s in (3 * t, 3 * t1, 3 * t2):
            n_changed = _legalize(s, tv, he, vr, vc, changed, n_changed, stack, guard, terr, vz,
                                  plane, span, sr, sc)
        return n_t + 2, n_changed
    # on the edge A -> B of t, opposite C
    ea = e + on
    a = tv[ea]
    b = tv[e + (on + 1) % 3]
    c = tv[e + (on + 2) % 3]
    h_bc = he[e + (on + 1) % 3]
    h_ca = he[e + (on + 2) % 3]
    tw = he[ea]
    t1 = n_t
    _new_tri(tv, he, t, a, p, c)  # A -> P, P -> C, C -> A
    _new_tri(tv, he, t1, p, b, c)  # P -> B, B -> C, C -> P
    link(he, 3 * t + 2, h_ca)
    link(he, 3 * t1 + 1, h_bc)
    link(he, 3 * t + 1, 3 * t1 + 2)
    changed[0] = t
    changed[1] = t1
    n_changed = 2
    n_new = 1
    outer[0] = 3 * t + 2
    outer[1] = 3 * t1 + 1
    n_outer = 2
    if tw >= 0:
        u = tw // 3
        d = tv[prv(tw)]  # (B, A, D)
        h_ad = he[nxt(tw)]
        h_db = he[prv(tw)]
        t3 = n_t + 1
        _new_tri(tv, he, u, b, p, d)  # B -> P, P -> D, D -> B
        _new_tri(tv, he, t3, p, a, d)  # P -> A, A -> D, D -> P
        link(he, 3 * u + 2, h_db)
        link(he, 3 * t3 + 1, h_ad)
        link(he, 3 * u + 1, 3 * t3 + 2)
        link(he, 3 * u, 3 * t1)  # B -> P with P -> B
        link(he, 3 * t3, 3 * t)  # P -> A with A -> P
        changed[2] = u
        changed[3] = t3
        n_changed = 4
        n_new = 2
        outer[2] = 3 * u + 2
        outer[3] = 3 * t3 + 1
        n_outer = 4
    for i in range(n_outer):
        n_changed = _legalize(outer[i], tv, he, vr, vc, changed, n_changed, stack, guard, terr,
                              vz, plane, span, sr, sc)
    return n_t + n_new, n_changed


@njit(cache=True)
def _grow_f(x, n):
    y = np.empty(n, x.dtype)
    y[: x.size] = x
    return y


@njit(cache=True, nogil=True)
def start_insertion(depth, valid, vr0, vc0, vz0, tv0, he0, span, max_vertices):
    """The state of greedy insertion on a first mesh, every triangle scanned and in the heap.

    Takes the first mesh as `greedy_insert` does; `max_vertices` sizes the
    arrays (they grow when more are inserted). Returns the state tuple that
    `advance` takes and gives back: ``(vr, vc, vz, vbg, tv, he, terr, tcr,
    tcc, tsum, tfit, heap, keys, slot, stamp, counts, total)``, with
    ``counts = [vertices, triangles, heap entries, vertices on valid pixels,
    steps]`` and ``total[0]`` the summed error of the valid pixels.
    """
    n_v = vr0.size
    n_t = tv0.size // 3
    cap_v = max(1024, 2 * n_v, n_v + max_vertices + 8)
    cap_t = 2 * cap_v + 8
    vr = np.zeros(cap_v, np.int64)
    vc = np.zeros(cap_v, np.int64)
    vz = np.zeros(cap_v, np.float64)
    vbg = np.zeros(cap_v, np.bool_)
    tv = np.zeros(3 * cap_t, np.int64)
    he = np.full(3 * cap_t, -1, np.int64)
    terr = np.full(cap_t, -1.0)
    tcr = np.zeros(cap_t, np.int64)
    tcc = np.zeros(cap_t, np.int64)
    tsum = np.zeros(cap_t)
    tfit = np.zeros(cap_t, np.bool_)  # fits exactly, its centroid to insert (out[4])
    heap = np.zeros(cap_t, np.int64)
    keys = np.zeros(cap_t)  # terr of heap[i], kept at heap positions (`geometry.heap`)
    slot = np.zeros(cap_t, np.int64)
    stamp = np.zeros(cap_t, np.int64)
    # an insertion flips each triangle at most once: 2 entries a triangle is enough
    changed = np.empty(2 * cap_t + 16, np.int64)
    stack = np.empty(2 * cap_t + 16, np.int64)
    out = np.zeros(5)
    n_valid_v = 0
    for i in range(n_v):
        r, c = vr0[i], vc0[i]
        vr[i], vc[i], vz[i] = r, c, vz0[i]
        vbg[i] = not valid[r, c]
        if vbg[i] and i >= 4:
            raise ValueError("greedy_insert: only the first four vertices may be background")
        if not vbg[i]:
            n_valid_v += 1
    for k in range(3 * n_t):
        tv[k] = tv0[k]
        he[k] = he0[k]
    n_heap = 0
    total = 0.0
    for t in range(n_t):
        _scan(t, tv, he, vr, vc, vz, vbg, depth, valid, span, out)
        terr[t], tcr[t], tcc[t], tsum[t] = out[0], out[1], out[2], out[3]
        tfit[t] = out[4] > 0.0
        total += out[3]
        heap[n_heap] = t
        keys[n_heap] = terr[t]
        slot[t] = n_heap
        sift_up(keys, heap, slot, n_heap)
        n_heap += 1
    counts = np.array([n_v, n_t, n_heap, n_valid_v, 0], np.int64)
    return (vr, vc, vz, vbg, tv, he, terr, tcr, tcc, tsum, tfit, heap, keys, slot, stamp, changed,
            stack, counts, np.array([total]))


@njit(cache=True)
def top_key(state):
    """The key of the triangle `advance` would split next (-1 when none is left)."""
    heap, counts = state[11], state[17]
    return state[6][heap[0]] if counts[2] > 0 else -1.0


@njit(cache=True, nogil=True)
def advance(depth, valid, state, max_vertices, max_sum, stop_key, span, sr=1, sc=1):
    """Insert worst pixels while the first triangle's key is at least `stop_key`.

    Also stops once `max_vertices` vertices stand on valid pixels, when no
    pixel is left to insert, or (not while valid pixels wait to be covered)
    once the summed error is at most `max_sum`. Returns the state, whose
    arrays may have grown. Runs without the GIL: two states on the same image
    can advance on two threads.
    """
    (vr, vc, vz, vbg, tv, he, terr, tcr, tcc, tsum, tfit, heap, keys, slot, stamp, changed, stack,
     counts, totals) = state
    h, w = depth.shape
    n_v, n_t, n_heap, n_valid_v, step = counts[0], counts[1], counts[2], counts[3], counts[4]
    total = totals[0]
    cap_v = vr.size
    cap_t = terr.size
    out = np.zeros(5)
    plane = np.zeros(9)  # the split triangle's corners, (r, c, z) each (`_on_plane`)
    outer = np.zeros(4, np.int64)
    while True:
        if n_heap == 0 or n_valid_v >= max_vertices:
            break
        t = heap[0]
        key = terr[t]
        if key < 0.0 or key < stop_key or (key <= COVER_KEY and total <= max_sum):
            break
        pr, pc = tcr[t], tcc[t]
        # room for the new vertex and up to two new triangles
        if n_v + 1 > cap_v:
            cap_v *= 2
            vr = _grow_f(vr, cap_v)
            vc = _grow_f(vc, cap_v)
            vz = _grow_f(vz, cap_v)
            vbg = _grow_f(vbg, cap_v)
        if n_t + 2 > cap_t:
            cap_t = 2 * cap_t
            tv = _grow_f(tv, 3 * cap_t)
            he2 = np.full(3 * cap_t, -1, np.int64)
            he2[: he.size] = he
            he = he2
            terr = _grow_f(terr, cap_t)
            tcr = _grow_f(tcr, cap_t)
            tcc = _grow_f(tcc, cap_t)
            tsum = _grow_f(tsum, cap_t)
            tfit = _grow_f(tfit, cap_t)
            heap = _grow_f(heap, cap_t)
            keys = _grow_f(keys, cap_t)
            slot = _grow_f(slot, cap_t)
            stamp2 = np.zeros(cap_t, np.int64)
            stamp2[: stamp.size] = stamp
            stamp = stamp2
        p = n_v
        vr[p], vc[p], vz[p] = pr, pc, depth[pr, pc]
        vbg[p] = False
        n_v += 1
        n_valid_v += 1
        if changed.size < 2 * n_t + 16:  # (sized in `start_insertion`; grown with the triangles)
            changed = np.empty(4 * n_t + 16, np.int64)
            stack = np.empty(4 * n_t + 16, np.int64)
        old_t = n_t
        # the centroid of a triangle that fits exactly: its three children fit too
        split_fit = tfit[t]
        guard = 0.0 < key < SMALL_KEY  # an exact split: keep it exact (`_legalize`)
        if guard:
            for k in range(3):
                v = tv[3 * t + k]
                plane[3 * k], plane[3 * k + 1], plane[3 * k + 2] = vr[v], vc[v], vz[v]
        n_t, n_changed = _insert(t, p, tv, he, vr, vc, n_t, changed, stack, outer, guard, terr,
                                 vz, plane, span, sr, sc)
        # ... and so does every triangle the flips made, when each triangle they replaced
        # fitted exactly and every corner lies on the split triangle's plane
        flat = split_fit and _flat_cavity(t, old_t, changed, n_changed, tv, vr, vc, terr, vz,
                                          plane, span)
        for s in range(old_t, n_t):  # new triangles join the heap
            terr[s] = -1.0
            tsum[s] = 0.0
            heap[n_heap] = s
            keys[n_heap] = -1.0
            slot[s] = n_heap
            n_heap += 1
        step += 1
        for j in range(n_changed):
            # Children of an exact split are keyed without a scan unless a flip changed
            # them: the flipped triangles (listed after the three) are scanned first.
            i = n_changed - 1 - j if split_fit else j
            s = changed[i]
            if stamp[s] == step:  # flipped twice in this step: one scan is enough
                continue
            stamp[s] = step
            if (flat or (split_fit and i < 3)) and _fit_child(s, tv, vr, vc, valid, h, w, out):
                out[3] = 0.0
            else:
                _scan(s, tv, he, vr, vc, vz, vbg, depth, valid, span, out)
            total += out[3] - tsum[s]
            terr[s], tcr[s], tcc[s], tsum[s] = out[0], out[1], out[2], out[3]
            tfit[s] = out[4] > 0.0
            rekey(keys, heap, slot, s, terr[s], n_heap)
    counts[0], counts[1], counts[2], counts[3], counts[4] = n_v, n_t, n_heap, n_valid_v, step
    totals[0] = total
    return (vr, vc, vz, vbg, tv, he, terr, tcr, tcc, tsum, tfit, heap, keys, slot, stamp, changed,
            stack, counts, totals)
