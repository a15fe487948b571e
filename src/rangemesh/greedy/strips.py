"""Greedy insertion on two vertical strips of the image at once: the same mesh on any machine.

The image is cut down one column, the seam. Its vertices are chosen first
(`seam_rows`, greedy insertion on that column's profile) and stay fixed; each
strip is then meshed by the kernel of `rangemesh.greedy.kernels`, on the
whole image but from a first mesh of its own columns, whose hull edges down
the seam own no pixel. No triangle crosses the seam, so the two strips'
insertions do not interact: inserting the worst triangle of the image, one
at a time, is the same as inserting each strip's worst, in the order of
their keys.

That order is kept without running the strips in lock step. Both advance
on two threads until their first key falls below a common threshold (a
*round*): whatever the threads' timing, the state they reach is the one the
one-at-a-time order passes through. Thresholds are predicted from each
strip's keys so far (a power law of the count) to reach a growing share of
the vertices asked; the last 3 % are inserted one at a time, from the strip
whose key is larger (`merge_tail`), landing exactly on the count. A round
whose prediction was far off stops a strip by count instead; the next round
(same threshold) brings it back to that order, unless it was the last. The
mesh depends only on the image and the request, never on the number of
threads. With ``diagonals='error'`` each strip's edges are then flipped on
its own thread, and after the join the seam's (`rangemesh.greedy.diagonals`).

Measured with ``benchmarks/strips.py`` against one strip (the README gives the
figures): on 640 x 480 frames a call takes 0.5-0.8x the time at the same
error. A round costs about 0.1 ms of hand-over between the threads, which is
why strips start at STRIP_MIN_VERTICES.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .._core import flip_by_error, flip_from_edges
from . import kernels as _k
from . import threads as _threads
from .start import first_mesh
from .threads import executor

__all__ = ["use_strips", "seam_column", "seam_rows", "strip_insert", "merge_tail"]

# Strips pay once the kernel's own time dwarfs a round's overhead and the seam's vertices
# are a small share: at least this many vertices and columns.
STRIP_MIN_VERTICES = 2000
STRIP_MIN_COLUMNS = 64
# ... on images of STRIP_MIN_PIXELS valid pixels or more, with a count or an error bound alike:
# max_error's count is not known beforehand, and on smaller images (the 160 x 200 scenes)
# strips cost it their set-up at small counts (2-3 ms at 67 vertices, 3x the call), while
# vertices=N gained little there (0.78-1.05x at 3200 vertices).
STRIP_MIN_PIXELS = 60_000
# Seam vertices: this times the vertices a column gets in a mesh of uniform density.
SEAM_DENSITY = 0.7
# ... and under an error bound, as many as bring the seam's summed error to this share of its
# column's part of the bound (1-D greedy insertion gets there with few; half of it cost the
# noisy pyramid at 1 % 128 vertices against one strip's 88).
SEAM_ERROR_SHARE = 1.0
# Each round aims at this share of the vertices still to insert; once at most TAIL_SHARE of
# the request (and at least TAIL_MIN vertices) is left, the rest go one at a time.
ROUND_SHARE = 0.6
ROUND_GROWTH = 2.0
TAIL_SHARE = 0.03
TAIL_MIN = 64
MAX_ROUNDS = 16
# The power law's exponent (vertices ~ key**-e) before a strip has two rounds to fit it on,
# and its bounds. A small exponent predicts a large step in key and overshoots: on the seven
# committed 96 x 128 crops at 100 to 3000 vertices, the last round stopped by count in 18 of 35
# cases with 0.25 as the lower bound, 10 with 0.5, 1 with 0.75 (7.2 rounds a call; 8.3 with 1).
EXPONENT = 1.0
EXPONENT_RANGE = (0.75, 4.0)


def use_strips(shape, vertices: int | None, max_error, n_valid: int) -> bool:
    """Whether `greedy_mesh` meshes the image as two strips.

    Images of STRIP_MIN_PIXELS valid pixels or more (and STRIP_MIN_COLUMNS
    columns): under an error bound always, with a vertex count from
    STRIP_MIN_VERTICES to half the valid pixels (the seam's pixels that are
    not its vertices can never be inserted, so strips cannot give every
    pixel). The choice depends on the request and the image only, so the
    mesh is the same on every machine (threads or not).
    """
    if shape[1] < STRIP_MIN_COLUMNS or n_valid < STRIP_MIN_PIXELS:
        return False
    if max_error is not None:
        return True
    return vertices is not None and STRIP_MIN_VERTICES <= vertices <= n_valid // 2


def seam_column(valid: np.ndarray) -> int:
    """The column that halves the valid pixels, kept within the middle half of the image."""
    w = valid.shape[1]
    per_col = valid.sum(axis=0)
    cum = np.cumsum(per_col)
    m = int(np.searchsorted(cum, cum[-1] / 2.0)) if cum[-1] > 0 else w // 2
    return int(np.clip(m, w // 4, (3 * w) // 4))


@njit(cache=True)
def _seam_kernel(z, ok, k, max_sum, span):
    """Rows of `k` valid pixels of a profile, by greedy insertion (see `seam_rows`).

    Errors are compared as the 2-D kernel's keys (units of 2**-32 of `span`), so a change of
    depth unit cannot reorder two pixels by rounding (SPEC P2).
    """
    h = z.size
    rows_ok = np.nonzero(ok)[0]
    n_ok = rows_ok.size
    chosen = np.zeros(h, np.bool_)
    if n_ok == 0:
        return rows_ok
    chosen[rows_ok[0]] = True
    chosen[rows_ok[-1]] = True
    n = 2 if n_ok > 1 else 1
    while n < min(k, n_ok):
        # the worst pixel against the linear profile between chosen neighbours; when every
        # pixel fits, the middle of the longest gap
        best_key, best_r = -1.0, -1
        long_gap, long_r = 0, -1
        total = 0.0
        a = rows_ok[0]
        for i in range(1, n_ok):
            r = rows_ok[i]
            if not chosen[r]:
                continue
            if r - a > 1:
                for j in range(a + 1, r):
                    if ok[j] and not chosen[j]:
                        zl = z[a] + (z[r] - z[a]) * (j - a) / (r - a)
                        e = abs(z[j] - zl)
                        total += e
                        key = _k._quantize(e, span)
                        if key > best_key:
                            best_key, best_r = key, j
                if r - a > long_gap:
                    mid = (a + r) // 2
                    for d in range(r - a):  # the valid pixel nearest the middle
                        if mid + d < r and ok[mid + d] and not chosen[mid + d]:
                            long_gap, long_r = r - a, mid + d
                            break
                        if mid - d > a and ok[mid - d] and not chosen[mid - d]:
                            long_gap, long_r = r - a, mid - d
                            break
            a = r
        if best_r < 0 or total <= max_sum:
            break
        chosen[best_r if best_key > 0.0 else long_r] = True
        n += 1
    return np.nonzero(chosen)[0]


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
    return _seam_kernel(z, ok, int(k), float(max_sum), float(span))


@njit(cache=True)
def merge_tail(depth, valid, a, b, n_target, max_sum, span, sr, sc):
    """Insert one vertex at a time into strip `a` or `b`, whichever's first key is larger.

    Stops once the two strips hold `n_target` valid vertices between them
    (counting the shared seam twice), once their summed error is at most
    `max_sum` (when it is not negative) with no pixel left to cover, or when
    nothing is left to insert. Ties go to `a`. Returns the two states.
    """
    while True:
        na = a[17][3]
        nb = b[17][3]
        if na + nb >= n_target:
            break
        ka = _k.top_key(a)
        kb = _k.top_key(b)
        if ka < 0.0 and kb < 0.0:
            break
        ta = a[18][0]
        tb = b[18][0]
        if max_sum >= 0.0 and ta + tb <= max_sum and max(ka, kb) <= _k.COVER_KEY:
            break
        rem = n_target - na - nb
        if ka >= kb:  # a goes on while its key is at least b's
            a = _k.advance(depth, valid, a, na + rem, max_sum - tb if max_sum >= 0.0 else -1.0,
                           kb, span, sr, sc)
        else:  # b while its key is above a's
            b = _k.advance(depth, valid, b, nb + rem, max_sum - ta if max_sum >= 0.0 else -1.0,
                           np.nextafter(ka, np.inf), span, sr, sc)
    return a, b


def _exponent(x0, y0, x1, y1):
    """The exponent e of y ~ x**-e through two points, within EXPONENT_RANGE.

    EXPONENT when the points do not fall that way (y not moving against x).
    """
    if min(x0, y0, x1, y1) > 0 and (y1 - y0) * (x1 - x0) < 0:
        e = math.log(y0 / y1) / math.log(x1 / x0)
        return min(max(e, EXPONENT_RANGE[0]), EXPONENT_RANGE[1])
    return EXPONENT


def _power_law(hist):
    """``(n, key, e)``: a strip's last count and first key, and the exponent of n ~ key**-e."""
    n1, k1 = hist[-1]
    e = _exponent(hist[-2][1], hist[-2][0], k1, n1) if len(hist) >= 2 else EXPONENT
    return n1, k1, e


def _count_at(law, key):
    """A strip's predicted vertex count once its first key falls below `key`."""
    n1, k1, e = law
    if key >= k1 or k1 <= 0:
        return float(n1)
    return n1 * (k1 / key) ** e


def _threshold(laws, target):
    """The key at which the strips' predicted counts add up to `target` (bisection in log)."""
    hi = max(law[1] for law in laws)
    if hi <= 0:
        return -1.0
    lo = hi * 1e-12
    for _ in range(50):
        mid = math.sqrt(lo * hi)
        if sum(_count_at(law, mid) for law in laws) > target:
            lo = mid
        else:
            hi = mid
    return hi


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
        may use two cores and ``NUMBA_NUM_THREADS`` (Numba's own setting) is
        not 1. The mesh is the same either way.
    rounds : bool, default True
        False inserts every vertex one at a time (`merge_tail`): the same
        mesh, on one thread, unless the last round stopped a strip by count
        (see `_rounds`); for tests.
    info : dict, optional
        Receives ``rounds`` (how many ran) and ``capped`` (whether the last
        one stopped a strip by count).
    diagonals : {'delaunay', 'error'}, default 'delaunay'
        ``'error'``: each strip's edges are then flipped by the error
        (`rangemesh.greedy.diagonals`), on both threads, and after
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
    if n_threads >= 2:  # the first scans visit every pixel: half each
        fut = executor().submit(_k.start_insertion, depth, valid, *left, span, size)
        b = _k.start_insertion(depth, valid, *right, span, size)
        a = fut.result()
    else:
        a = _k.start_insertion(depth, valid, *left, span, size)
        b = _k.start_insertion(depth, valid, *right, span, size)
    # the seam's pixels belong to neither strip: their error comes off the bound
    seam_error = _seam_error(depth[:, m], valid[:, m], rows)
    budget = max(max_sum - seam_error, 0.0) if max_sum >= 0.0 else -1.0
    if rounds:
        a, b, n_rounds, capped = _rounds(depth, valid, a, b, vertices, target, budget, span, sr,
                                         sc, n_threads)
        if info is not None:
            info.update(rounds=n_rounds, capped=capped)
    a, b = merge_tail(depth, valid, a, b, target, budget, span, sr, sc)
    if diagonals == "error":  # (the states' summed errors stay the insertion's)
        if n_threads >= 2:
            fut = executor().submit(_flip_state, depth, valid, a, span)
            _flip_state(depth, valid, b, span)
            fut.result()
        else:
            _flip_state(depth, valid, a, span)
            _flip_state(depth, valid, b, span)
    vr, vc, tv, n, total = _join(_result(a), _result(b), m, shared)
    if diagonals == "error":
        he, seam = _joined_halfedges(a, b, tv, vc, m)
        tsum = np.concatenate([a[9][: int(a[17][1])], b[9][: int(b[17][1])]])
        flip_from_edges(vr, vc, tv, he, tsum, depth, valid, span, seam)
    return vr, vc, tv, n, total + seam_error


def _flip_state(depth, valid, state, span):
    """`rangemesh._core.flip_by_error` on the mesh of an insertion state, in place.

    Afterwards the state holds the flipped mesh, its half-edges and sums; its
    keys and heap are stale (do not advance it). Runs without the GIL.
    """
    n_v, n_t = int(state[17][0]), int(state[17][1])
    return flip_by_error(state[0][:n_v], state[1][:n_v], state[4][:3 * n_t], state[5][:3 * n_t],
                         state[9][:n_t], depth, valid, span)


def _result(state):
    """``vr, vc, tv, n_valid_vertices, total`` of a state (`rangemesh.greedy.kernels.result`).

    In NumPy: Numba's `result`, called from Python once `greedy_insert` had
    loaded it from the cache as its callee, failed to box its arrays
    ("'descr' is NULL", numba 0.68).
    """
    counts = state[17]
    n_v, n_t = int(counts[0]), int(counts[1])
    return state[0][:n_v].copy(), state[1][:n_v].copy(), state[4][: 3 * n_t].copy(), \
        int(counts[3]), float(state[18][0])


def _advance_both(depth, valid, a, b, caps, key, span, sr, sc, n_threads):
    if n_threads >= 2:
        fut = executor().submit(_k.advance, depth, valid, a, caps[0], -1.0, key, span, sr, sc)
        b = _k.advance(depth, valid, b, caps[1], -1.0, key, span, sr, sc)
        return fut.result(), b
    a = _k.advance(depth, valid, a, caps[0], -1.0, key, span, sr, sc)
    b = _k.advance(depth, valid, b, caps[1], -1.0, key, span, sr, sc)
    return a, b


def _seam_error(z, ok, rows):
    """Summed error of a column's valid pixels against the lines between its seam vertices."""
    r = np.nonzero(ok)[0]
    if len(rows) < 2 or len(r) == 0:
        return 0.0
    inside = (r > rows[0]) & (r < rows[-1])
    return float(np.abs(z[r[inside]] - np.interp(r[inside], rows, z[rows])).sum())


def _error_target(hist, budget):
    """The count at which the summed error is predicted to reach `budget` (a power law)."""
    n1, t1 = hist[-1]
    e = _exponent(hist[-2][0], hist[-2][1], n1, t1) if len(hist) >= 2 else EXPONENT
    if t1 <= budget or t1 <= 0:
        return n1
    return n1 * (t1 / max(budget, 1e-300)) ** (1.0 / e)


def _rounds(depth, valid, a, b, vertices, target, budget, span, sr, sc, n_threads):
    """Advance both strips to common key thresholds until the tail is left (see the module).

    Returns the two states, the number of rounds, and whether the last round
    stopped a strip by its cap rather than by the threshold. Only then is the
    state not one that the one-at-a-time order passes through, and the mesh
    may differ from it (a strip a few vertices short); it is still the same
    on any number of threads.
    """
    hists = [[], []]
    errors = []  # (count, summed error) after each round, with an error bound
    key = _k.COVER_KEY  # first, every pixel to cover (keys above COVER_KEY)
    n_rounds, capped = 0, False
    for _ in range(MAX_ROUNDS):
        counts = [int(a[17][3]), int(b[17][3])]
        stop = target
        if budget >= 0.0:
            total = float(a[18][0] + b[18][0])
            errors.append((float(sum(counts)), total))
            if total <= budget:
                break
            stop = min(target, int(_error_target(errors, budget)))
        rem = stop - sum(counts)
        if rem <= max(TAIL_MIN, int(TAIL_SHARE * stop)):
            break
        laws = [_power_law(hist) for hist in hists] if hists[0] and hists[1] else None
        if key is None:
            # at most twice the count a round: the power law is fitted on the last two rounds,
            # and early on (large triangles) its exponent changes fast
            want = min(sum(counts) + ROUND_SHARE * rem, ROUND_GROWTH * sum(counts))
            key = _threshold(laws, want)
            if key <= 0:
                break
        # Caps that add up to what is left, shared as the predicted growth: a strip whose
        # count the power law misjudged by more than that stops by count. The state is then
        # not one the one-at-a-time order passes through, but the next round's is: each
        # strip's state at a threshold does not depend on how it got there.
        grow = [max(_count_at(laws[i], key) - counts[i], 0.0) if laws else 1.0
                for i in range(2)]
        f = grow[0] / (grow[0] + grow[1]) if grow[0] + grow[1] > 0 else 0.5
        cap_a = counts[0] + int(round(f * rem))
        caps = (cap_a, counts[1] + rem - (cap_a - counts[0]))
        a, b = _advance_both(depth, valid, a, b, caps, key, span, sr, sc, n_threads)
        n_rounds += 1
        capped = any(int(s[17][3]) >= c and _k.top_key(s) >= key
                     for s, c in zip((a, b), caps, strict=True))
        for i, s in enumerate((a, b)):
            top = _k.top_key(s)
            if top > 0:
                hists[i].append((float(s[17][3]), top))
        if not hists[0] or not hists[1]:  # a strip has nothing left: the tail finishes
            break
        if not capped:
            key = None
        # else the same threshold again: the strip stopped by count goes on to it, the other
        # is there already, and all that is left is the first's to take
    return a, b, n_rounds, capped


def _joined_halfedges(a, b, tv, vc, m):
    """Twin half-edges of the joined mesh (`_join`'s `tv`): the strips' own, and the seam's paired.

    Returns ``he, seam``: `seam` holds strip A's half-edges down the seam
    column `m`, each now the twin of B's half-edge the other way.
    """
    n_a = 3 * int(a[17][1])
    he_b = b[5][: 3 * int(b[17][1])]
    he = np.concatenate([a[5][:n_a], np.where(he_b >= 0, he_b + n_a, -1)])
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
    """One mesh from the two strips' results: B's seam vertices become A's."""
    vra, vca, tva, na, ta = ra
    vrb, vcb, tvb, nb, tb = rb
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
    vr = np.concatenate([vra, vrb[own]])
    vc = np.concatenate([vca, vcb[own]])
    tv = np.concatenate([tva, new_id[tvb]])
    return vr, vc, tv, int(na + nb - shared), float(ta + tb)
