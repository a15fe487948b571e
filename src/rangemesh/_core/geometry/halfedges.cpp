#include "halfedges.hpp"

#include <algorithm>
#include <cstdint>

#include "../interrupt.hpp"

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

template <class T>
void build_halfedges(Grid<const T> faces, index_t n_vertices, std::vector<index_t>& triangles,
                     std::vector<index_t>& halfedges) {
    const index_t n_he = 3 * faces.rows;
    const FreeLater late_out(on_throw, triangles, halfedges);
    // each half-edge's end vertex beside it in the table: the twin search reads one place, not
    // a triangle a candidate (each a cache miss on a large mesh)
    struct Leaving {
        index_t end, e;
    };
    std::vector<index_t> start, fill;
    std::vector<Leaving> leaving;
    const FreeLater late(start, fill, leaving);
    triangles.clear();
    triangles.reserve(n_he);
    index_t used = 0;  // the ids in use: a raw call's n_vertices of INT64_MAX would size the table
    for (index_t e = 0; e < n_he; ++e) {
        poll_every(e);
        check_input(0 <= faces.data[e] && faces.data[e] < n_vertices, "build_halfedges: a vertex id is out of range");
        triangles.push_back(faces.data[e]);
        used = std::max<index_t>(used, faces.data[e] + 1);
    }
    n_vertices = used;
    fill_polled(halfedges, n_he, index_t{-1});
    // a CSR table of the half-edges by start vertex: O(F * degree), no sort
    fill_polled(start, n_vertices + 1, index_t{0});
    for (index_t e = 0; e < n_he; ++e) {
        poll_every(e);
        start[triangles[e] + 1] += 1;
    }
    for (index_t v = 0; v < n_vertices; ++v) {
        poll_every(v);
        start[v + 1] += start[v];
    }
    fill = copy_polled(Span<const index_t>{start.data(), n_vertices});
    fill_polled(leaving, n_he, Leaving{0, 0});
    for (index_t e = 0; e < n_he; ++e) {
        poll_every(e);
        leaving[fill[triangles[e]]++] = Leaving{triangles[nxt(e)], e};
    }
    for (index_t e = 0; e < n_he; ++e) {
        poll_every(e);
        const index_t a = triangles[e], b = triangles[nxt(e)];
        for (index_t j = start[b]; j < start[b + 1]; ++j) {
            if (leaving[j].end == a) {  // the first in half-edge order, as before
                halfedges[e] = leaving[j].e;
                break;
            }
        }
    }
}

template void build_halfedges(Grid<const std::int32_t>, index_t, std::vector<index_t>&, std::vector<index_t>&);
template void build_halfedges(Grid<const index_t>, index_t, std::vector<index_t>&, std::vector<index_t>&);

template <class T>
index_t count_edges(Grid<const T> faces, index_t n_vertices) {
    // each edge counted at its smaller endpoint, with a mark per vertex of who saw it last
    const index_t n_t = faces.rows;
    std::vector<index_t> start, fill, other, mark;
    const FreeLater late(start, fill, other, mark);
    index_t used = 0;  // the ids in use: a raw call's n_vertices of INT64_MAX would size the tables
    for (index_t k = 0; k < 3 * n_t; ++k) {
        poll_every(k);
        check_input(0 <= faces.data[k] && faces.data[k] < n_vertices, "count_edges: a vertex id is out of range");
        used = std::max<index_t>(used, faces.data[k] + 1);
    }
    n_vertices = used;
    fill_polled(start, n_vertices + 1, index_t{0});
    for (index_t t = 0; t < n_t; ++t) {
        poll_every(t);
        for (int k = 0; k < 3; ++k) start[std::min(faces(t, k), faces(t, (k + 1) % 3)) + 1] += 1;
    }
    for (index_t v = 0; v < n_vertices; ++v) {
        poll_every(v);
        start[v + 1] += start[v];
    }
    fill = copy_polled(Span<const index_t>{start.data(), n_vertices});
    fill_polled(other, 3 * n_t, index_t{0});
    for (index_t t = 0; t < n_t; ++t) {
        poll_every(t);
        for (int k = 0; k < 3; ++k) {
            const index_t a = faces(t, k), b = faces(t, (k + 1) % 3);
            other[fill[std::min(a, b)]++] = std::max(a, b);
        }
    }
    fill_polled(mark, n_vertices, index_t{-1});
    index_t count = 0;
    for (index_t v = 0; v < n_vertices; ++v) {
        poll_every(v);
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

template index_t count_edges(Grid<const std::int32_t>, index_t);
template index_t count_edges(Grid<const index_t>, index_t);

void neighbors_from_halfedges(Span<const index_t> halfedges, Grid<index_t> out) {
    const index_t n_t = halfedges.size / 3;
    for (index_t t = 0; t < n_t; ++t) {
        poll_every(t);
        for (int k = 0; k < 3; ++k) {
            const index_t tw = halfedges[3 * t + (k + 1) % 3];  // the edge from corner k+1 to k+2
            out(t, k) = tw == -1 ? -1 : tw / 3;
        }
    }
}

}  // namespace rangemesh
