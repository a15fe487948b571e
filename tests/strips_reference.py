"""The strips' Python steps as they were (`rangemesh.refine.strips`, before 2026-11-27).

The native call (`rangemesh._core.refine_mesh`) chooses the seam, builds the strips' first
meshes, runs them and joins them; these steps, the library's own until it did, stay here as
the reference the tests hold it to (`refine_reference._greedy` calls `strip_insert`), and
call the strip kernels (`rangemesh._core.strip_insert`, `seam_rows`, `flip_from_edges`)
as the library did. Not the library's: nothing in `src/` imports it.
"""

from __future__ import annotations

import math

import numpy as np

from rangemesh import _core
from rangemesh import threads as _threads
from rangemesh.blocks import blocks, concat, take
from rangemesh.refine.start import first_mesh
from rangemesh.refine.strips import SEAM_DENSITY, SEAM_ERROR_SHARE

from .helpers import core_settings


def seam_column(valid: np.ndarray) -> int:
    """The column that halves the valid pixels, kept within the middle half of the image."""
    w = valid.shape[1]
    per_col = valid.sum(axis=0)
    cum = np.cumsum(per_col)
    m = int(np.searchsorted(cum, cum[-1] / 2.0)) if cum[-1] > 0 else w // 2
    return int(np.clip(m, w // 4, (3 * w) // 4))


def seam_rows(depth_col: np.ndarray, valid_col: np.ndarray, k: int,
              max_sum: float = -1.0, span: float | None = None) -> np.ndarray:
    """Rows of the seam's vertices: about `k` valid pixels of one column, its first and last.

    Greedy insertion in one dimension: the pixel farthest from the straight
    line between its chosen neighbours, until `k` are chosen (or, when
    `max_sum` is not negative, until the column's summed error is at most
    that); once every pixel lies on those lines, the middle of the longest
    gap. The first and last valid pixels are always chosen, so a strip's
    triangles with a background corner never hold valid pixels on the seam.
    Errors are ranked in units of 2**-32 of `span` (default: the column's own
    valid depth range), as the 2-D kernel ranks them.
    """
    z = np.ascontiguousarray(depth_col, dtype=np.float64)
    ok = np.ascontiguousarray(valid_col, dtype=np.bool_)
    if span is None:
        span = float(z[ok].max() - z[ok].min()) if ok.any() else 0.0
    return _core.seam_rows(z, ok, int(k), float(max_sum), float(span))


def strip_insert(depth, valid, vertices, span, scales, n_grid, *, max_sum=-1.0, threads=None,
                 rounds=True, info=None, diagonals="delaunay"):
    """Greedy insertion of `vertices` valid vertices, as two strips (see the module).

    Parameters
    ----------
    depth, valid : (H, W) ndarrays
        The prepared image.
    vertices : int
        Valid vertices wanted (all of them if the image has fewer); with
        `max_sum`, at most.
    span : float
        The valid depth range.
    scales : (int, int)
        Weights of rows and columns in the Delaunay test.
    n_grid : int
        Grid points of the first meshes, between them.
    max_sum : float, default -1
        When not negative, also stop once the summed error of the valid
        pixels is at most this (the seam's own pixels included), as
        `rangemesh._core.greedy_insert` does. Rounds then stop short
        of the count a power law of the error predicts, and the rest go one
        at a time; a round that passes the bound leaves a few more vertices
        than one at a time would.
    threads : int, optional
        1 runs the strips one after the other; default 2 where this process
        may use two cores and ``RANGEMESH_THREADS`` is not 1
        (`rangemesh.threads`). The mesh is the same either way.
    rounds : bool, default True
        False inserts every vertex one at a time (the tail's order): the
        same mesh, on one thread, unless the last round stopped a strip by
        count (``info['capped']``); for tests.
    info : dict, optional
        Receives ``rounds`` (how many ran), ``capped`` (whether the last
        one stopped a strip by count) and ``flips`` (edges flipped by the
        error, both strips and the seam).
    diagonals : {'delaunay', 'error'}, default 'delaunay'
        ``'error'``: each strip's edges are then flipped by the error
        (`rangemesh.refine.diagonals`), on both threads, and after
        the join the seam's edges and those their flips touch
        (`rangemesh._core.flip_from_edges`).

    Returns
    -------
    vr, vc, tv, n_valid_vertices, total
        As `rangemesh._core.greedy_insert`: one mesh, the seam's
        vertices once; `total` includes the seam's own pixels (the
        insertion's, before any flip).
    """
    h, w = depth.shape
    sr, sc = scales
    m = seam_column(valid)
    if max_sum >= 0.0:
        # the count is not known: the seam takes its column's share of the error bound
        col_share = valid[:, m].sum() / max(valid.sum(), 1)
        rows = seam_rows(depth[:, m], valid[:, m], h, SEAM_ERROR_SHARE * col_share * max_sum,
                         span)
    else:
        k = max(2, int(round(SEAM_DENSITY * math.sqrt(vertices * h * sr / (w * sc)))))
        rows = seam_rows(depth[:, m], valid[:, m], k, span=span)
    share = m / (w - 1)
    left = first_mesh(depth, valid, int(n_grid * share), scales, cols=(0, m), seam=(rows, m))
    right = first_mesh(depth, valid, int(n_grid * (1 - share)), scales, cols=(m, w - 1),
                       seam=(rows, m))
    on_seam = left[1] == m
    shared = int(valid[left[0][on_seam], m].sum())
    target = vertices + shared  # the two strips' counts add the seam twice
    n_threads = _threads.threads() if threads is None else threads
    size = vertices if max_sum < 0.0 else 0  # arrays for the count; grown under an error bound
    # the seam's pixels belong to neither strip: their error comes off the bound
    seam_error = _seam_error(depth[:, m], valid[:, m], rows)
    budget = max(max_sum - seam_error, 0.0) if max_sum >= 0.0 else -1.0
    # (the strips' summed errors stay the insertion's: the flips leave them alone)
    request = core_settings(_core.StripRequest, vertices=vertices, target=target, reserve=size, budget=budget,
                            sr=sr, sc=sc, threads=n_threads, rounds=rounds, flip=diagonals == "error")
    out = _core.strip_insert(depth, valid, left, right, span, request)
    a, b = out.left, out.right
    if info is not None:
        if rounds:
            info.update(rounds=out.rounds, capped=out.capped)
        info["flips"] = a.flips + b.flips
    vr, vc, tv, n, total = _join(a, b, m, shared)
    if diagonals == "error":
        he, seam = _joined_halfedges(a.he, b.he, tv, vc, m)
        tsum = concat([a.tsum, b.tsum])
        # (through `_core`: the contract tests' spies sit on its names)
        seam_flips = _core.flip_from_edges((vr, vc, tv, he, tsum), depth, valid, span, seam)[0]
        if info is not None:
            info["flips"] += seam_flips
    return vr, vc, tv, n, total + seam_error


def _seam_error(z, ok, rows):
    """Summed error of a column's valid pixels against the lines between its seam vertices."""
    r = np.nonzero(ok)[0]
    if len(rows) < 2 or len(r) == 0:
        return 0.0
    inside = (r > rows[0]) & (r < rows[-1])
    return float(np.abs(z[r[inside]] - np.interp(r[inside], rows, z[rows])).sum())


def _joined_halfedges(he_a, he_b, tv, vc, m):
    """Twin half-edges of the joined mesh (`_join`'s `tv`): the strips' own, and the seam's paired.

    Returns ``he, seam``: `seam` holds strip A's half-edges down the seam
    column `m`, each now the twin of B's half-edge the other way.
    """
    n_a = len(he_a)
    he = concat([he_a, he_b])  # (millions of half-edges: a block at a time, Ctrl-C seen between)
    for b in blocks(len(he_b)):
        he[n_a + b.start:n_a + b.stop] = np.where(he_b[b] >= 0, he_b[b] + n_a, -1)
    hull = np.nonzero(he < 0)[0]
    u, v = tv[hull], tv[hull - hull % 3 + (hull + 1) % 3]
    down = (vc[u] == m) & (vc[v] == m)
    hull, u, v = hull[down], u[down], v[down]
    in_a = hull < n_a
    n_v = len(vc)
    key_a = u[in_a] * n_v + v[in_a]  # u -> v in A is v -> u in B
    key_b = v[~in_a] * n_v + u[~in_a]
    order = np.argsort(key_b)
    pos = np.minimum(np.searchsorted(key_b[order], key_a), max(len(key_b) - 1, 0))
    if len(key_a) != len(key_b) or not np.array_equal(key_b[order][pos], key_a):
        raise RuntimeError("strip_insert: the strips' edges down the seam differ")
    seam_a = hull[in_a]
    seam_b = hull[~in_a][order][pos]
    he[seam_a] = seam_b
    he[seam_b] = seam_a
    return he, seam_a


def _join(ra, rb, m, shared):
    """One mesh from the two strips' results: B's seam vertices become A's.

    `ra`, `rb`: each strip's `rangemesh._core.StripMesh` (`rangemesh._core.strip_insert`).
    """
    vra, vca, tva, na, ta = ra.vr, ra.vc, ra.tv, ra.valid_vertices, ra.total
    vrb, vcb, tvb, nb, tb = rb.vr, rb.vc, rb.tv, rb.valid_vertices, rb.total
    seam_a = np.nonzero(vca == m)[0]
    order = np.argsort(vra[seam_a])
    seam_a = seam_a[order]
    on_b = vcb == m
    new_id = np.empty(len(vrb), np.int64)
    pos = np.searchsorted(vra[seam_a], vrb[on_b])
    if not np.array_equal(vra[seam_a][pos], vrb[on_b]):
        raise RuntimeError("strip_insert: the strips' seams differ")
    new_id[on_b] = seam_a[pos]
    own = np.nonzero(~on_b)[0]
    new_id[own] = len(vra) + np.arange(len(own))
    vr = concat([vra, take(vrb, own)])  # (a block at a time: Ctrl-C is seen between blocks)
    vc = concat([vca, take(vcb, own)])
    tv = concat([tva, take(new_id, tvb)])
    return vr, vc, tv, int(na + nb - shared), float(ta + tb)
