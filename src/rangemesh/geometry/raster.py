"""Raster lines and rasterised triangles: Bresenham, the edge error along a line, depth rendering."""

import math

from numba import njit

from .vectors import lift, orient


@njit(cache=True)
def line_pixel(r0, c0, r1, c1, k):
    """Pixel k (0-based, from the first endpoint) of the raster line r0,c0 -> r1,c1.

    Bresenham's line written in closed form: one pixel per step along the major
    axis; on the minor axis the nearest pixel, halves rounded toward the first
    endpoint (what the textbook loop with ``if D > 0`` gives). The line has
    ``max(|dr|, |dc|) + 1`` pixels.
    """
    dr = r1 - r0
    dc = c1 - c0
    adr = abs(dr)
    adc = abs(dc)
    sr = 1 if dr >= 0 else -1
    sc = 1 if dc >= 0 else -1
    if adr >= adc:
        n = adr
        if n == 0:
            return r0, c0
        return r0 + sr * k, c0 + sc * ((2 * k * adc + n - 1) // (2 * n))
    n = adc
    return r0 + sr * ((2 * k * adr + n - 1) // (2 * n)), c0 + sc * k


@njit(cache=True)
def edge_error(va, vb, pixels, vertices, depth, valid, cam):
    """SPEC 3.1: sum of 3-D distances from the valid pixels of the raster line AB to segment AB.

    The line is always drawn from the endpoint with the smaller ``(r, c)``, so
    ``E(A, B) == E(B, A)`` exactly.
    """
    ra = pixels[va, 0]
    ca = pixels[va, 1]
    rb = pixels[vb, 0]
    cb = pixels[vb, 1]
    if rb < ra or (rb == ra and cb < ca):
        va, vb = vb, va
        ra, ca, rb, cb = rb, cb, ra, ca
    px = vertices[va, 0]
    py = vertices[va, 1]
    pz = vertices[va, 2]
    dx = vertices[vb, 0] - px
    dy = vertices[vb, 1] - py
    dz = vertices[vb, 2] - pz
    dd = dx * dx + dy * dy + dz * dz
    # Bresenham, incremental form (the same pixels as `line_pixel`, without a division
    # per pixel): one step along the major axis, a minor step when the error says so.
    dr = rb - ra
    dc = cb - ca
    adr = abs(dr)
    adc = abs(dc)
    sr = 1 if dr >= 0 else -1
    sc = 1 if dc >= 0 else -1
    if adr >= adc:
        n, dmin = adr, adc
    else:
        n, dmin = adc, adr
    # minor offset at step k is floor((2 k dmin + n - 1) / (2 n)); track its remainder
    acc = n - 1
    total = 0.0
    r = ra
    c = ca
    for k in range(n + 1):
        if k > 0:
            acc += 2 * dmin
            bump = acc >= 2 * n
            if bump:
                acc -= 2 * n
            if adr >= adc:
                r += sr
                if bump:
                    c += sc
            else:
                c += sc
                if bump:
                    r += sr
        if not valid[r, c]:
            continue
        x, y, z = lift(r, c, depth[r, c], cam)
        qx = x - px
        qy = y - py
        qz = z - pz
        t = 0.0
        if dd > 0.0:
            t = (qx * dx + qy * dy + qz * dz) / dd
            t = min(max(t, 0.0), 1.0)
        ex = qx - t * dx
        ey = qy - t * dy
        ez = qz - t * dz
        total += math.sqrt(ex * ex + ey * ey + ez * ez)
    return total


@njit(cache=True)
def rasterize(face_r, face_c, face_val, height, width, out_val, out_face):
    """Interpolate per-vertex values over each triangle's pixels in the image plane.

    `face_r`, `face_c`, `face_val` are (F, 3) float64. A pixel is covered when
    its centre (integer coordinates) lies inside or on the border of the
    triangle; the first triangle that covers a pixel sets it. Degenerate
    triangles cover nothing. `out_val` (NaN-filled) and `out_face` (-1-filled)
    are written in place.
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
