// Which triangle owns the pixels on an edge, and the row loop over the pixels a triangle owns:
// refine's keys, cover pixels and diagonals and the heights' fit all walk triangles this way.
#pragma once

#include <utility>

#include "../views.hpp"
#include "raster.hpp"

namespace rangemesh {

// Whether the triangle left of the directed edge a -> b owns the pixels on it: of the two
// triangles of a shared edge, the one on its left when it is walked with rows, then columns,
// increasing.
inline bool owns(index_t ar, index_t ac, index_t br, index_t bc) { return br > ar || (br == ar && bc > ac); }

// Whether a triangle owns the pixels on its edge a -> b, whose twin half-edge is `twin`. A hull
// edge's pixels are its only triangle's, except on a seam: a hull edge down an inner column of
// an image of width `w`, where one strip's mesh meets the next (each strip fixes the seam's
// vertices beforehand, so its pixels are candidates in neither).
inline bool own_edge(index_t twin, index_t ar, index_t ac, index_t br, index_t bc, index_t w) {
    if (twin < 0) return !(ac == bc && 0 < ac && ac < w - 1);
    return owns(ar, ac, br, bc);
}

// Which of a triangle's edges AB, BC, CA own the pixels on them (`owns`, `own_edge`).
struct EdgeOwnership {
    bool ab, bc, ca;
};

// The row loop: calls row(r, span) for the rows first, first + step, ... up to `last` of the
// walk `rows` (started at `first` with that step) whose pixels owned under `own` are not
// none, top to bottom; row(...) returning false ends the loop.
template <class Row>
void owned_rows(TriangleRows& rows, index_t first, index_t last, index_t step, EdgeOwnership own, Row&& row) {
    for (index_t r = first; r <= last; r += step) {
        if (r > first) rows.next_row();
        const RowSpan span = rows.columns(own.ab, own.bc, own.ca);
        if (span.first > span.last) continue;
        if (!row(r, span)) return;
    }
}

// The same over every row of the walk (started at its top row, step 1).
template <class Row>
void owned_rows(TriangleRows& rows, EdgeOwnership own, Row&& row) {
    owned_rows(rows, rows.r0, rows.r1, 1, own, std::forward<Row>(row));
}

}  // namespace rangemesh
