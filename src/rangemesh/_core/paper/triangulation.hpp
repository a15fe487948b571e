// Stage two of the paper's method (II.B.1, SPEC 2) around the Delaunay triangulation: the valid
// samples, the faces to keep, the mesh renumbered over the vertices it uses. Whole-mesh steps
// of millions of elements, polling Ctrl-C every POLL_STRIDE.
#pragma once

#include <cstdint>
#include <vector>

#include "../views.hpp"

namespace rangemesh::paper {

// The distinct samples (N x 2, (row, column)) that are valid pixels of the image, in row-major
// order, as (row, column) pairs; samples outside the image are left out.
template <class T>
std::vector<index_t> valid_samples(Grid<const T> samples, Grid<const bool> valid);

// Writes to `alive` whether each face (F x 3 ids of `points`, M x 2 pixels) stays: the pixel at
// its rounded barycentre ((r0 + r1 + r2 + 1) // 3, and so for columns) is valid, and no edge is
// longer than sqrt(max_edge2) pixels (every edge passes when max_edge2 is infinite).
void keep_faces(Grid<const index_t> faces, Grid<const index_t> points, Grid<const bool> valid, double max_edge2,
                Span<bool> alive);

// The faces `alive`, renumbered over the points they use (in point order), and those points.
struct CompactMesh {
    std::vector<std::int32_t> faces;   // 3 a kept face
    std::vector<std::int32_t> pixels;  // (row, column) a used point
};
CompactMesh compact_faces(Grid<const index_t> faces, Span<const bool> alive, Grid<const index_t> points);

}  // namespace rangemesh::paper
