"""Slow, obviously-correct versions of the kernels, written independently of them."""

import math
from fractions import Fraction

import numpy as np

from rangemesh.camera import backproject


def bresenham(a, b):
    """Textbook incremental Bresenham (``if D > 0`` form), drawn from the smaller (r, c)."""
    (r0, c0), (r1, c1) = sorted([tuple(map(int, a)), tuple(map(int, b))])
    dr, dc = r1 - r0, c1 - c0
    if abs(dr) >= abs(dc):  # step along rows
        step_c = 1 if dc >= 0 else -1
        adc = abs(dc)
        D = 2 * adc - dr
        c = c0
        out = []
        for r in range(r0, r1 + 1):
            out.append((r, c))
            if D > 0:
                c += step_c
                D -= 2 * dr
            D += 2 * adc
        return out
    step_r = 1 if dr >= 0 else -1
    step_c = 1 if dc >= 0 else -1
    adr, adc = abs(dr), abs(dc)
    D = 2 * adr - adc
    r = r0
    out = []
    c = c0
    for _ in range(adc + 1):
        out.append((r, c))
        if D > 0:
            r += step_r
            D -= 2 * adc
        D += 2 * adr
        c += step_c
    return out


def edge_error(a, b, depth, valid, camera):
    """Sum of 3-D distances of the valid Bresenham pixels of AB to the 3-D segment AB."""
    A = backproject([a[0]], [a[1]], [depth[a]], camera)[0]
    B = backproject([b[0]], [b[1]], [depth[b]], camera)[0]
    total = 0.0
    for r, c in bresenham(a, b):
        if not valid[r, c]:
            continue
        X = backproject([r], [c], [depth[r, c]], camera)[0]
        ab = B - A
        L = float(ab @ ab)
        t = 0.0 if L == 0 else min(1.0, max(0.0, float((X - A) @ ab) / L))
        total += float(np.linalg.norm(X - (A + t * ab)))
    return total


def fill_gaps(depth, valid):
    d = np.where(valid, depth, 0.0).astype(float)
    v = valid.copy()
    h, w = depth.shape
    out = d.copy()
    for r in range(1, h - 1):
        for c in range(1, w - 1):
            if valid[r, c]:
                continue
            nb = [(r + i, c + j) for i in (-1, 0, 1) for j in (-1, 0, 1) if (i, j) != (0, 0)]
            if all(valid[p] for p in nb):
                out[r, c] = sum(d[p] for p in nb) / 8
                v[r, c] = True
    return out, v


def curvature_one_level(d, v, jump):
    h, w = d.shape
    K = np.zeros((h, w))
    for r in range(h):
        for c in range(w):
            for (p, q) in (((r - 1, c), (r + 1, c)), ((r, c - 1), (r, c + 1))):
                if min(p + q) < 0 or p[0] >= h or q[0] >= h or p[1] >= w or q[1] >= w:
                    continue
                n_valid = int(v[p]) + int(v[r, c]) + int(v[q])
                if n_valid == 3:
                    K[r, c] += abs(d[p] - 2 * d[r, c] + d[q])
                elif n_valid > 0:
                    K[r, c] += jump
    return K


def invert(weights, count):
    """Positions of `count` equally spaced targets of the cumulative weight (rounded half up)."""
    cum = [0.0]
    for x in weights[1:]:
        cum.append(cum[-1] + x)
    m = cum[-1]
    out = []
    for j in range(count):
        if j == 0:
            out.append(0)
            continue
        if j == count - 1:
            out.append(len(weights) - 1)
            continue
        y = j * m / (count - 1)
        k = next(i for i in range(len(cum) - 1) if cum[i + 1] >= y)
        x = k + (y - cum[k]) / (cum[k + 1] - cum[k])
        out.append(math.floor(x + 0.5))
    return out


def sample_grid(f, tiles, samples):
    """Per-tile, per-row plain-Python version of stage one's grid."""
    h, w = f.shape
    V, H = tiles
    Rs, Z = samples
    rb = [round_half_up(k * (h - 1), V) for k in range(V + 1)]
    cb = [round_half_up(k * (w - 1), H) for k in range(H + 1)]
    grid = np.zeros(((Rs - 1) * V + 1, (Z - 1) * H + 1, 2), int)
    for v in range(V):
        for hh in range(H):
            rows = range(rb[v], rb[v + 1] + 1)
            cols = list(range(cb[hh], cb[hh + 1] + 1))
            HS = {r: [cols[i] for i in invert([f[r, c] for c in cols], Z)] for r in rows}
            for j in range(Z):
                curve = [(r, HS[r][j]) for r in rows]
                idx = invert([f[p] for p in curve], Rs)
                for i, k in enumerate(idx):
                    grid[v * (Rs - 1) + i, hh * (Z - 1) + j] = curve[k]
    return grid


def round_half_up(num, den):
    return math.floor(Fraction(num, den) + Fraction(1, 2))


def rendered_errors(mesh, depth, valid):
    """Brute force: per valid pixel, the first face containing it; linear depth in (r, c)."""
    p = mesh.pixels.astype(int)
    z = mesh.vertices[:, 2] / mesh.camera.kz
    errs = {}
    for a, b, c in mesh.faces.tolist():
        (ra, ca), (rb, cb), (rc, cc) = p[a], p[b], p[c]
        area = (rb - ra) * (cc - ca) - (cb - ca) * (rc - ra)
        for r in range(min(ra, rb, rc), max(ra, rb, rc) + 1):
            for col in range(min(ca, cb, cc), max(ca, cb, cc) + 1):
                if (r, col) in errs or not valid[r, col]:
                    continue
                wa = (rc - rb) * (col - cb) - (cc - cb) * (r - rb)
                wb = (ra - rc) * (col - cc) - (ca - cc) * (r - rc)
                wc = (rb - ra) * (col - ca) - (cb - ca) * (r - ra)
                if min(wa, wb, wc) < 0:
                    continue
                zz = (wa * z[a] + wb * z[b] + wc * z[c]) / area
                errs[(r, col)] = abs(zz - depth[r, col])
    return errs


# ---------------------------------------------------------------------------
# The NumPy versions of stage one's pixel work, as they were before the Numba
# kernels replaced them (issue 7): the kernels must agree with them bit for bit.


def fill_gaps_numpy(depth, valid):
    """`sampling.fill_gaps` as first written in NumPy."""
    h, w = depth.shape
    d = np.where(valid, depth, 0.0)
    out_d = d.copy()
    out_v = valid.copy()
    if h < 3 or w < 3:
        return out_d, out_v
    inner_valid = np.ones((h - 2, w - 2), bool)
    total = np.zeros((h - 2, w - 2))
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            if dr == 0 and dc == 0:
                continue
            sl = (slice(1 + dr, h - 1 + dr), slice(1 + dc, w - 1 + dc))
            inner_valid &= valid[sl]
            total += d[sl]
    hole = inner_valid & ~valid[1:-1, 1:-1]
    out_d[1:-1, 1:-1][hole] = total[hole] / 8.0
    out_v[1:-1, 1:-1] |= hole
    return out_d, out_v



def _second_difference(d, v, axis, jump):
    """The NumPy second difference along `axis` (SPEC rules at borders and jumps)."""
    out = np.zeros(d.shape)
    n = d.shape[axis]
    if n < 3:
        return out
    lo = [slice(None)] * 2
    mid = [slice(None)] * 2
    hi = [slice(None)] * 2
    lo[axis] = slice(0, n - 2)
    mid[axis] = slice(1, n - 1)
    hi[axis] = slice(2, n)
    lo, mid, hi = tuple(lo), tuple(mid), tuple(hi)
    dd = np.abs(d[lo] - 2.0 * d[mid] + d[hi])
    count = v[lo].astype(np.int8) + v[mid] + v[hi]
    inner = np.where(count == 3, dd, np.where(count == 0, 0.0, jump))
    out[mid] = inner
    return out


def curvature_numpy(depth, valid, levels=2):
    """`sampling.curvature` as first written in NumPy."""
    if valid.any():
        jump = float(depth[valid].max() - depth[valid].min())
    else:
        jump = 0.0
    d = np.where(valid, depth, 0.0)
    h, w = d.shape
    K = np.zeros((h, w))
    for level in range(levels):
        step = 1 << level
        ds = d[::step, ::step]
        vs = valid[::step, ::step]
        if ds.shape[0] < 3 and ds.shape[1] < 3:
            break
        k = _second_difference(ds, vs, 0, jump) + _second_difference(ds, vs, 1, jump)
        if step == 1:
            K += k
        else:
            rows = np.arange(h) >> level
            cols = np.arange(w) >> level
            K += k[rows[:, None], cols[None, :]]
    return K




def line_pixel_closed_form(r0, c0, r1, c1, k):
    """Pixel k of the raster line r0,c0 -> r1,c1 in closed form: one step a pixel on the major
    axis, on the minor axis the nearest pixel with halves rounded toward the first endpoint."""
    dr, dc = r1 - r0, c1 - c0
    n = max(abs(dr), abs(dc))
    if n == 0:
        return r0, c0
    sr, sc = (1 if dr >= 0 else -1), (1 if dc >= 0 else -1)
    minor = (2 * k * min(abs(dr), abs(dc)) + n - 1) // (2 * n)
    if abs(dr) >= abs(dc):
        return r0 + sr * k, c0 + sc * minor
    return r0 + sr * minor, c0 + sc * k


def edge_error_closed_form(va, vb, pixels, vertices, depth, valid, camera):
    """The edge error as first written: a closed-form pixel a step, each lifted by `backproject`."""
    ra, ca = (int(x) for x in pixels[va])
    rb, cb = (int(x) for x in pixels[vb])
    if rb < ra or (rb == ra and cb < ca):
        va, vb = vb, va
        ra, ca, rb, cb = rb, cb, ra, ca
    px, py, pz = (float(x) for x in vertices[va])
    dx = float(vertices[vb, 0]) - px
    dy = float(vertices[vb, 1]) - py
    dz = float(vertices[vb, 2]) - pz
    dd = dx * dx + dy * dy + dz * dz
    n = max(abs(rb - ra), abs(cb - ca))
    total = 0.0
    for k in range(n + 1):
        r, c = line_pixel_closed_form(ra, ca, rb, cb, k)
        if not valid[r, c]:
            continue
        x, y, z = (float(v) for v in backproject([r], [c], [depth[r, c]], camera)[0])
        qx, qy, qz = x - px, y - py, z - pz
        t = 0.0
        if dd > 0.0:
            t = (qx * dx + qy * dy + qz * dz) / dd
            t = min(max(t, 0.0), 1.0)
        ex, ey, ez = qx - t * dx, qy - t * dy, qz - t * dz
        total += math.sqrt(ex * ex + ey * ey + ez * ez)
    return total


def prune_dangling(simplices, neighbors, alive, n_vertices):
    """Rounds of SPEC 2.3's pruning, from the definition; returns the new `alive` and the count.

    A round: one pass in triangle order dropping each live triangle with no live neighbour
    (a triangle dropped earlier in the pass counts as dead); then, at every vertex, the fans
    (its live triangles, joined when they share an edge through it) are found by a search,
    and every triangle outside its vertex's largest fan goes, ties kept by the fan holding
    the smallest corner slot ``3 t + k``. Rounds repeat until one drops nothing.
    """
    alive = [bool(a) for a in alive]
    tris = [tuple(int(x) for x in s) for s in simplices]
    removed = 0
    while True:
        dropped = 0
        for t in range(len(tris)):
            if alive[t] and not any(nb >= 0 and alive[nb] for nb in neighbors[t]):
                alive[t] = False
                dropped += 1
        best = {}  # vertex -> the triangles of its kept fan
        for v in range(n_vertices):
            mine = [t for t, tri in enumerate(tris) if alive[t] and v in tri]
            fans, seen = [], set()
            for t in mine:
                if t in seen:
                    continue
                fan, todo = [], [t]
                seen.add(t)
                while todo:
                    u = todo.pop()
                    fan.append(u)
                    for w in mine:
                        if w not in seen and len(set(tris[u]) & set(tris[w])) == 2:
                            seen.add(w)
                            todo.append(w)
                slot = min(3 * u + tris[u].index(v) for u in fan)
                fans.append((-len(fan), slot, set(fan)))
            if fans:
                best[v] = min(fans, key=lambda f: (f[0], f[1]))[2]
        for t, tri in enumerate(tris):
            if alive[t] and any(t not in best[v] for v in tri):
                alive[t] = False
                dropped += 1
        removed += dropped
        if dropped == 0:
            return np.array(alive), removed


def delaunay_violations(pr, pc, triangles):
    """Whether a triangle list is a Delaunay triangulation of all the points, by brute force.

    Returns a list of what is wrong (empty when nothing is): a triangle that is not
    counter-clockwise, a point strictly inside some triangle's circumcircle (exact integer
    in-circle test, all pairs), a point that is no vertex, or a total area that differs from
    the convex hull's (so the triangles tile the hull).
    """
    from scipy.spatial import ConvexHull

    pts = [(int(r), int(c)) for r, c in zip(pr, pc, strict=True)]
    faces = [tuple(int(x) for x in triangles[3 * t:3 * t + 3]) for t in range(len(triangles) // 3)]
    bad = []
    area2 = 0
    for a, b, c in faces:
        (ar, ac), (br, bc), (cr, cc) = pts[a], pts[b], pts[c]
        o = (br - ar) * (cc - ac) - (bc - ac) * (cr - ar)
        if o <= 0:
            bad.append(f"face {(a, b, c)} is not counter-clockwise")
        area2 += o
        for d, (dr, dc) in enumerate(pts):
            m = [[x - dr, y - dc, (x - dr) ** 2 + (y - dc) ** 2] for x, y in (pts[a], pts[b], pts[c])]
            det = (m[0][0] * (m[1][1] * m[2][2] - m[2][1] * m[1][2])
                   - m[0][1] * (m[1][0] * m[2][2] - m[2][0] * m[1][2])
                   + m[0][2] * (m[1][0] * m[2][1] - m[2][0] * m[1][1]))
            if det > 0:
                bad.append(f"point {d} inside the circle of {(a, b, c)}")
    if {v for f in faces for v in f} != set(range(len(pts))):
        bad.append("a point is no vertex")
    hull = ConvexHull(np.array(pts, float))
    if area2 != round(2 * hull.volume):
        bad.append(f"the faces' area {area2 / 2} is not the hull's {hull.volume}")
    return bad
