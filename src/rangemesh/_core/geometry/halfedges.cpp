#include "halfedges.hpp"

#include <algorithm>
#include <cstdint>

namespace rangemesh {

void flip_quad(Span<index_t> triangles, Span<index_t> halfedges, index_t e0) {
    const Quad q(Span<const index_t>{halfedges.data, halfedges.size}, e0);
    const index_t va = triangles[q.e0], vb = triangles[q.b0];
    const index_t vc = triangles[q.c0], vd = triangles[q.c1];
    const index_t tb0 = halfedges[q.b0], tc0 = halfedges[q.c0];
    const index_t tb1 = halfedges[q.b1], tc1 = halfedges[q.c1];
    triangles[q.e0] = vd;
    triangles[q.b0] = vc;
    triangles[q.c0] = va;
    triangles[q.e1] = vc;
    triangles[q.b1] = vd;
    triangles[q.c1] = vb;
    // the outer half-edges move: CA to next(e0), AD to prev(e0), DB to next(e1), BC to prev(e1)
    link(halfedges, q.b0, tc0);
    link(halfedges, q.c0, tb1);
    link(halfedges, q.b1, tc1);
    link(halfedges, q.c1, tb0);
}

void build_halfedges(Grid<const index_t> faces, index_t n_vertices, std::vector<index_t>& triangles,
                     std::vector<index_t>& halfedges) {
    const index_t n_he = 3 * faces.rows;
    triangles.assign(faces.data, faces.data + n_he);
    halfedges.assign(n_he, -1);
    // a CSR table of the half-edges by start vertex: O(F * degree), no sort
    std::vector<index_t> start(n_vertices + 1, 0);
    for (index_t e = 0; e < n_he; ++e) start[triangles[e] + 1] += 1;
    for (index_t v = 0; v < n_vertices; ++v) start[v + 1] += start[v];
    std::vector<index_t> fill(start.begin(), start.end() - 1);
    std::vector<index_t> leaving(n_he);
    for (index_t e = 0; e < n_he; ++e) leaving[fill[triangles[e]]++] = e;
    for (index_t e = 0; e < n_he; ++e) {
        const index_t a = triangles[e], b = triangles[nxt(e)];
        for (index_t j = start[b]; j < start[b + 1]; ++j) {
            const index_t f = leaving[j];
            if (triangles[nxt(f)] == a) {
                halfedges[e] = f;
                break;
            }
        }
    }
}

template <class Id>
index_t count_edges(Grid<const Id> faces, index_t n_vertices) {
    // each edge counted at its smaller endpoint, with a mark per vertex of who saw it last
    const index_t n_t = faces.rows;
    std::vector<index_t> start(n_vertices + 1, 0);
    for (index_t t = 0; t < n_t; ++t)
        for (int k = 0; k < 3; ++k) start[std::min<index_t>(faces(t, k), faces(t, (k + 1) % 3)) + 1] += 1;
    for (index_t v = 0; v < n_vertices; ++v) start[v + 1] += start[v];
    std::vector<index_t> fill(start.begin(), start.end() - 1);
    std::vector<index_t> other(3 * n_t);
    for (index_t t = 0; t < n_t; ++t) {
        for (int k = 0; k < 3; ++k) {
            const index_t a = faces(t, k), b = faces(t, (k + 1) % 3);
            other[fill[std::min(a, b)]++] = std::max(a, b);
        }
    }
    std::vector<index_t> mark(n_vertices, -1);
    index_t count = 0;
    for (index_t v = 0; v < n_vertices; ++v) {
        for (index_t j = start[v]; j < start[v + 1]; ++j) {
            const index_t u = other[j];
            if (mark[u] != v) {
                mark[u] = v;
                ++count;
            }
        }
    }
    return count;
}

template index_t count_edges(Grid<const index_t>, index_t);
template index_t count_edges(Grid<const std::int32_t>, index_t);

void neighbors_from_halfedges(Span<const index_t> halfedges, Grid<index_t> out) {
    const index_t n_t = halfedges.size / 3;
    for (index_t t = 0; t < n_t; ++t) {
        for (int k = 0; k < 3; ++k) {
            const index_t tw = halfedges[3 * t + (k + 1) % 3];  // the edge from corner k+1 to k+2
            out(t, k) = tw == -1 ? -1 : tw / 3;
        }
    }
}

}  // namespace rangemesh
