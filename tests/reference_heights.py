"""Plain-Python references for the least-squares depths (`rangemesh._core` heights kernels).

Written from the definitions, pixel by pixel: a face owns a pixel when the
pixel lies inside it or on one of its edges that it owns (of the two faces of
an edge, the one on its left when the edge is walked with rows, then columns,
increasing); the mesh's value there is the barycentric mix of its corners'.
"""

import numpy as np


def _orient(ar, ac, br, bc, cr, cc):
    return (br - ar) * (cc - ac) - (bc - ac) * (cr - ar)


def _owns(ar, ac, br, bc):
    return br > ar or (br == ar and bc > ac)


def ccw(face, rows, cols):
    """The face's corners turned counter-clockwise in (row, column)."""
    a, b, c = (int(v) for v in face)
    if _orient(rows[a], cols[a], rows[b], cols[b], rows[c], cols[c]) < 0:
        b, c = c, b
    return a, b, c


def owned_pixels(face, rows, cols, row_stride=1):
    """``(r, c, la, lb, lc)`` of each pixel the face owns, row by row, on rows % row_stride == 0."""
    a, b, c = ccw(face, rows, cols)
    pa, pb, pc = ((int(rows[v]), int(cols[v])) for v in (a, b, c))
    area = _orient(*pa, *pb, *pc)
    if area == 0:
        return []
    out = []
    for r in range(min(pa[0], pb[0], pc[0]), max(pa[0], pb[0], pc[0]) + 1):
        if r % row_stride:
            continue
        for col in range(min(pa[1], pb[1], pc[1]), max(pa[1], pb[1], pc[1]) + 1):
            w = []
            for p, q in ((pa, pb), (pb, pc), (pc, pa)):
                wk = _orient(*p, *q, r, col)
                if wk < 0 or (wk == 0 and not _owns(*p, *q)):
                    break
                w.append(wk)
            else:
                out.append((r, col, w[1] / area, w[2] / area, w[0] / area))
    return out


def errors(faces, order, rows, cols, values, image, valid, row_stride=1, face_stride=1):
    """``|image - mesh|`` at the owned valid pixels sampled as `fit_sample_errors` samples them."""
    out = []
    for t in order[::face_stride]:
        a, b, c = ccw(faces[t], rows, cols)
        for r, col, la, lb, lc in owned_pixels(faces[t], rows, cols, row_stride):
            if valid[r, col]:
                out.append(abs(image[r, col] - (la * values[a] + lb * values[b] + lc * values[c])))
    return np.array(out)


def blocks(faces, order, rows, cols, values, image, valid, threshold):
    """``(ids, block, rhs, used)`` of `fit_blocks`: each face's sums of w w^T and w * value."""
    n = len(order)
    ids = np.zeros((n, 3), np.int64)
    block = np.zeros((n, 3, 3))
    rhs = np.zeros((n, 3))
    used = 0
    for i, t in enumerate(order):
        ids[i] = ccw(faces[t], rows, cols)
        for r, col, la, lb, lc in owned_pixels(faces[t], rows, cols):
            if not valid[r, col]:
                continue
            w = np.array([la, lb, lc])
            v = image[r, col]
            if abs(v - w @ values[ids[i]]) <= threshold:
                used += 1
                block[i] += np.outer(w, w)
                rhs[i] += w * v
    return ids, block, rhs, used


def solve(ids, block, rhs, h0, ridge_share):
    """The fit's normal equations assembled densely and solved by NumPy."""
    n = len(h0)
    m = np.zeros((n, n))
    b = np.zeros(n)
    for t in range(len(ids)):
        m[np.ix_(ids[t], ids[t])] += block[t]
        b[ids[t]] += rhs[t]
    ridge = ridge_share * np.maximum(np.diag(m), 1.0)
    return np.linalg.solve(m + np.diag(ridge), b + ridge * h0)
