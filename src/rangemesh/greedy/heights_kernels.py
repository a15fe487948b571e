"""Numba kernels of the least-squares vertex depths: a pass over each triangle's pixels, a solve.

Each pixel is visited once, by the triangle that owns it: interior pixels by
their triangle, a pixel on a shared edge by one side only (the rule of the
greedy kernel's `_owns`), a pixel on the mesh's border edge by its triangle
when that rule says so (otherwise it is simply not used by the fit). Rows are
walked over their exact integer spans, as the greedy kernel does.
"""

import math

import numpy as np
from numba import njit

from ..geometry.raster import next_row, row_columns, triangle_rows
from ..geometry.vectors import orient
from .kernels import _owns


@njit(cache=True)
def face_order(faces, pr, pc, h, w, tile):
    """The faces in the row-major order of the `tile` x `tile` pixel cells of their top-left.

    A counting sort, O(faces + cells). The faces of a mesh made by insertion
    come in the order they were made, scattered over the image; visited in
    this order instead, consecutive faces read the same image rows from the
    cache: a pass of `fit_pass` over the faces of teddy or TUM at 10 % of
    their pixels took 0.6-0.8x the time.
    """
    across = (w + tile - 1) // tile
    cells = ((h + tile - 1) // tile) * across
    start = np.zeros(cells + 1, np.int64)
    cell = np.empty(faces.shape[0], np.int64)
    for t in range(faces.shape[0]):
        a = faces[t, 0]
        b = faces[t, 1]
        c = faces[t, 2]
        r = min(pr[a], min(pr[b], pr[c]))
        col = min(pc[a], min(pc[b], pc[c]))
        if r < 0 or col < 0 or r >= h or col >= w:
            raise ValueError("face_order: a vertex lies outside the image")
        k = (r // tile) * across + col // tile
        cell[t] = k
        start[k + 1] += 1
    for k in range(cells):
        start[k + 1] += start[k]
    order = np.empty(faces.shape[0], np.int64)
    for t in range(faces.shape[0]):  # stable: by index within a cell
        k = cell[t]
        order[start[k]] = t
        start[k] += 1
    return order


@njit(cache=True, nogil=True)
def fit_pass(faces, order, pr, pc, h0, image, valid, thr, resid, ids, block, rhs, row_stride,
             face_stride):
    """Visit every owned valid pixel of every triangle, the triangles in `order`.

    With ``thr < 0`` (the first pass) writes each pixel's ``|image - mesh|``
    under the vertex values `h0` into `resid`, for the rows that are a
    multiple of `row_stride` of the triangles ``order[0], order[face_stride],
    order[2 * face_stride], ...`` only, and returns how many. Otherwise
    adds, for the pixels whose residual is at most `thr`, the products of
    their barycentric weights to ``block[i]`` (3x3) and weight times image
    value to ``rhs[i]`` (3), for the vertices ``ids[i]`` (the face's vertices,
    turned counter-clockwise) of face ``order[i]``, and returns how many pixels
    were used. (Written in visiting order: written at the faces' own indices,
    scattered over megabytes, they cost the spatial order its gain.)
    """
    k = 0
    h, w = image.shape
    step = face_stride if thr < 0.0 else 1
    for i in range(0, order.size, step):
        t = order[i]
        a = faces[t, 0]
        b = faces[t, 1]
        c = faces[t, 2]
        if orient(pr[a], pc[a], pr[b], pc[b], pr[c], pc[c]) < 0:
            b, c = c, b
        ids[i, 0] = a
        ids[i, 1] = b
        ids[i, 2] = c
        ar, ac, az = pr[a], pc[a], h0[a]
        br, bc, bz = pr[b], pc[b], h0[b]
        cr, cc, cz = pr[c], pc[c], h0[c]
        area = orient(ar, ac, br, bc, cr, cc)
        if area == 0:
            continue
        inv = 1.0 / area
        own0 = _owns(ar, ac, br, bc)
        own1 = _owns(br, bc, cr, cc)
        own2 = _owns(cr, cc, ar, ac)
        r0, r1, c0, c1, edges = triangle_rows(ar, ac, br, bc, cr, cc)
        if r0 < 0 or c0 < 0 or r1 >= h or c1 >= w:
            raise ValueError("fit_pass: a vertex lies outside the image")
        f0, f1, f2 = float(br - ar), float(cr - br), float(ar - cr)
        # sums of this triangle, kept in registers and written once
        m00 = m01 = m02 = m11 = m12 = m22 = 0.0
        q0 = q1 = q2 = 0.0
        for r in range(r0, r1 + 1):
            if r > r0:
                edges = next_row(edges)
            if thr < 0.0 and r % row_stride != 0:
                continue
            first, last, v0, v1, v2 = row_columns(edges, own0, own1, own2, c0, c1)
            if first > last:
                continue
            vrow = valid[r]
            irow = image[r]
            # float64 holds these integers exactly: no conversion per pixel
            w0, w1, w2 = float(v0), float(v1), float(v2)
            for col in range(first, last + 1):
                if vrow[col]:
                    la = w1 * inv  # weight of a
                    lb = w2 * inv
                    lc = w0 * inv
                    v = irow[col]
                    e = abs(v - (la * az + lb * bz + lc * cz))
                    if thr < 0.0:
                        if k < resid.size:  # overlapping faces could visit a pixel twice
                            resid[k] = e
                            k += 1
                    elif e <= thr:
                        k += 1
                        m00 += la * la
                        m01 += la * lb
                        m02 += la * lc
                        m11 += lb * lb
                        m12 += lb * lc
                        m22 += lc * lc
                        q0 += la * v
                        q1 += lb * v
                        q2 += lc * v
                w0 += f0
                w1 += f1
                w2 += f2
        block[i, 0, 0] = m00
        block[i, 0, 1] = block[i, 1, 0] = m01
        block[i, 0, 2] = block[i, 2, 0] = m02
        block[i, 1, 1] = m11
        block[i, 1, 2] = block[i, 2, 1] = m12
        block[i, 2, 2] = m22
        rhs[i, 0] = q0
        rhs[i, 1] = q1
        rhs[i, 2] = q2
    return k


@njit(cache=True)
def _dot(x, y):
    s = 0.0
    for i in range(x.size):
        s += x[i] * y[i]
    return s


@njit(cache=True)
def _block_product(ids, block, ridge, x, y):
    """``y = (sum of the faces' 3x3 blocks + diag(ridge)) @ x``, the matrix never formed."""
    for i in range(x.size):
        y[i] = ridge[i] * x[i]
    for t in range(ids.shape[0]):
        a = ids[t, 0]
        b = ids[t, 1]
        c = ids[t, 2]
        xa = x[a]
        xb = x[b]
        xc = x[c]
        y[a] += block[t, 0, 0] * xa + block[t, 0, 1] * xb + block[t, 0, 2] * xc
        y[b] += block[t, 1, 0] * xa + block[t, 1, 1] * xb + block[t, 1, 2] * xc
        y[c] += block[t, 2, 0] * xa + block[t, 2, 1] * xb + block[t, 2, 2] * xc


@njit(cache=True)
def gather_blocks(ids, block, rhs, h0, ridge_share):
    """The system `solve_blocks` solves, per vertex: its diagonal, right-hand side and ridge.

    ``ridge = ridge_share * max(diag(M), 1)``; the diagonal and the
    right-hand side returned include it (``diag(M) + ridge``, ``b + ridge * h0``).
    """
    n = h0.size
    diag = np.zeros(n)
    b = np.zeros(n)
    for t in range(ids.shape[0]):
        for k in range(3):
            diag[ids[t, k]] += block[t, k, k]
            b[ids[t, k]] += rhs[t, k]
    ridge = np.empty(n)
    for i in range(n):
        ridge[i] = ridge_share * max(diag[i], 1.0)
        b[i] += ridge[i] * h0[i]
        diag[i] += ridge[i]
    return diag, b, ridge


@njit(cache=True)
def solve_blocks(ids, block, rhs, h0, ridge_share, rtol, max_iter):
    """Least-squares vertex values from the faces' normal-equation blocks (`fit_pass`).

    Solves ``(M + diag(ridge)) x = b + ridge * h0``, where ``M`` and ``b``
    gather ``block[t]`` and ``rhs[t]`` onto the vertices ``ids[t]``, and
    ``ridge = ridge_share * max(diag(M), 1)`` pulls each vertex towards its
    copied value `h0`. Conjugate gradients from `h0`, preconditioned by the
    diagonal (Jacobi), until the residual is at most ``rtol`` times the
    right-hand side's norm.

    The matrix is never assembled: a product visits the faces' blocks (9
    multiply-adds a face). Assembling it with scipy.sparse and running
    scipy's `cg` cost about 2.6 ms at 940 faces (chair, 128x128) and 10 ms
    at 14800 (TUM, 640x480), against 0.2 and 2-2.5 ms here: the Python-level
    overhead of each CG step and the CSR sort were most of the time.

    Returns
    -------
    x : (V,) float64
    converged : bool
    """
    n = h0.size
    diag, b, ridge = gather_blocks(ids, block, rhs, h0, ridge_share)
    x = h0.copy()
    r = np.empty(n)
    _block_product(ids, block, ridge, x, r)
    bb = 0.0
    for i in range(n):
        r[i] = b[i] - r[i]
        bb += b[i] * b[i]
    stop = rtol * math.sqrt(bb)
    z = r / diag
    p = z.copy()
    q = np.empty(n)
    rz = _dot(r, z)
    for _ in range(max_iter):
        if math.sqrt(_dot(r, r)) <= stop:
            return x, True
        _block_product(ids, block, ridge, p, q)
        pq = _dot(p, q)
        if pq <= 0.0:  # not positive definite along p (cannot happen with the ridge): stop
            return x, False
        alpha = rz / pq
        for i in range(n):
            x[i] += alpha * p[i]
            r[i] -= alpha * q[i]
            z[i] = r[i] / diag[i]
        rz_new = _dot(r, z)
        beta = rz_new / rz
        rz = rz_new
        for i in range(n):
            p[i] = z[i] + beta * p[i]
    return x, math.sqrt(_dot(r, r)) <= stop


def empty_buffers(n_faces, n_pixels):
    """Zeroed outputs of `fit_pass` for `n_faces` faces and at most `n_pixels` pixels."""
    return (np.zeros(n_pixels), np.zeros((n_faces, 3), np.int64), np.zeros((n_faces, 3, 3)),
            np.zeros((n_faces, 3)))
