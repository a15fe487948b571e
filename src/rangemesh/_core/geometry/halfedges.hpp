// Flat half-edge meshes, as in hmm and delatin.
//
// `triangles` (3F) holds vertex ids and `halfedges` (3F) the twin half-edge or -1 on the
// border; triangle t owns half-edges 3t, 3t+1, 3t+2, and half-edge e runs from triangles[e]
// to triangles[nxt(e)].
#pragma once

#include <vector>

#include "../views.hpp"

namespace rangemesh {

// The half-edge after `e` in its triangle.
inline index_t nxt(index_t e) { return e % 3 == 2 ? e - 2 : e + 1; }

// The half-edge before `e` in its triangle.
inline index_t prv(index_t e) { return e % 3 == 0 ? e + 2 : e - 1; }

// Make half-edges a and b twins (b may be -1: a is then on the hull).
inline void link(Span<index_t> halfedges, index_t a, index_t b) {
    halfedges[a] = b;
    if (b != -1) halfedges[b] = a;
}

// Whether half-edge e's twin is well formed: -1 (a border), or a half-edge of another triangle
// that runs back along e's edge and has e for its twin. `triangles` holds ids already checked
// (or none read out of bounds: only ids at half-edges in range are read).
inline bool twin_ok(Span<const index_t> triangles, Span<const index_t> halfedges, index_t e) {
    const index_t g = halfedges[e];
    if (g == -1) return true;
    return 0 <= g && g < halfedges.size && halfedges[g] == e && g / 3 != e / 3 && triangles[g] == triangles[nxt(e)] &&
           triangles[nxt(g)] == triangles[e];
}

// The half-edges of the quad around e0's edge. With e0 = A->B in triangle ABC and its twin
// e1 = B->A in BAD: b0 = B->C, c0 = C->A, b1 = A->D, c1 = D->B.
struct Quad {
    index_t e0, e1, b0, c0, b1, c1;

    Quad(Span<const index_t> halfedges, index_t e)
        : e0(e), e1(halfedges[e]), b0(nxt(e)), c0(prv(e)), b1(nxt(e1)), c1(prv(e1)) {}
};

// Flip the edge of half-edge e0 (A->B in ABC, twin in BAD) to CD, in place. Afterwards e0's
// triangle is DCA and its twin's CDB; the diagonal keeps the slots e0 and its twin.
void flip_quad(Span<index_t> triangles, Span<index_t> halfedges, index_t e0);

// Twin half-edges of an oriented, edge-manifold face list (F x 3 of int32 or int64 ids in
// [0, n_vertices)): the triangles and halfedges arrays. The twin of a -> b is found among the
// half-edges leaving b.
template <class T>
void build_halfedges(Grid<const T> faces, index_t n_vertices, std::vector<index_t>& triangles,
                     std::vector<index_t>& halfedges);

// Distinct undirected edges of a face list (F x 3 of int32 or int64 ids in [0, n_vertices); any
// orientation, manifold or not).
template <class T>
index_t count_edges(Grid<const T> faces, index_t n_vertices);

// SciPy-style neighbours (F x 3): entry (t, k) is the triangle across the edge opposite corner k.
void neighbors_from_halfedges(Span<const index_t> halfedges, Grid<index_t> out);

}  // namespace rangemesh
