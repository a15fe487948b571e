"""Numba kernel pruning triangles so that every vertex keeps one fan (SPEC P4).

Used by the paper's stage two (II.B.1, SPEC 2.3: dangling triangles after
removing background ones) and by greedy insertion when it drops the walls of
jumps: in both, removing triangles can leave a vertex with two separate fans.
"""

import numpy as np
from numba import njit


@njit(cache=True)
def _find(parent, i):
    root = i
    while parent[root] != root:
        root = parent[root]
    while parent[i] != root:  # path compression
        nxt = parent[i]
        parent[i] = root
        i = nxt
    return root


@njit(cache=True)
def _union(parent, a, b):
    ra = _find(parent, a)
    rb = _find(parent, b)
    if ra != rb:
        # the smaller root wins, so the result does not depend on call order
        if ra < rb:
            parent[rb] = ra
        else:
            parent[ra] = rb


@njit(cache=True)
def prune_dangling(simplices, neighbors, alive, n_vertices):
    """Drop dangling triangles until none is left (SPEC 2.3); edits `alive` in place.

    A triangle is dangling when it shares no edge with a live triangle, or when
    it belongs to a fan of one of its vertices that is not that vertex's
    largest (ties: the fan whose lowest corner id is smallest is kept). Fans are
    the edge-connected groups of a vertex's triangles, found with a union-find
    over triangle corners ``3t + k``.

    Returns the number of triangles removed.
    """
    n_t = simplices.shape[0]
    removed = 0
    parent = np.zeros(3 * n_t, np.int64)
    size = np.zeros(3 * n_t, np.int64)
    best_root = np.zeros(n_vertices, np.int64)
    best_size = np.zeros(n_vertices, np.int64)
    changed = True
    while changed:
        changed = False
        for t in range(n_t):
            if not alive[t]:
                continue
            lonely = True
            for k in range(3):
                nb = neighbors[t, k]
                if nb >= 0 and alive[nb]:
                    lonely = False
            if lonely:
                alive[t] = False
                removed += 1
                changed = True
        for i in range(3 * n_t):
            parent[i] = i
            size[i] = 0
        for t in range(n_t):
            if not alive[t]:
                continue
            for k in range(3):
                nb = neighbors[t, k]
                if nb <= t or not alive[nb]:
                    continue
                # the shared edge is the one opposite corner k of t
                for m in (1, 2):
                    kk = (k + m) % 3
                    vtx = simplices[t, kk]
                    for q in range(3):
                        if simplices[nb, q] == vtx:
                            _union(parent, 3 * t + kk, 3 * nb + q)
        for v in range(n_vertices):
            best_root[v] = -1
            best_size[v] = 0
        for t in range(n_t):
            if alive[t]:
                for k in range(3):
                    size[_find(parent, 3 * t + k)] += 1
        for t in range(n_t):
            if not alive[t]:
                continue
            for k in range(3):
                i = 3 * t + k
                if parent[i] != i:
                    continue
                v = simplices[t, k]
                s = size[i]
                if s > best_size[v] or (s == best_size[v] and i < best_root[v]):
                    best_size[v] = s
                    best_root[v] = i
        for t in range(n_t):
            if not alive[t]:
                continue
            for k in range(3):
                if _find(parent, 3 * t + k) != best_root[simplices[t, k]]:
                    alive[t] = False
                    removed += 1
                    changed = True
                    break
    return removed
