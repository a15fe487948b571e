// What the least-squares depths of method="refine" work on: the mesh whose vertex values are
// fitted, the image they are fitted to, and each face's share of the normal equations.
#pragma once

#include "../views.hpp"

namespace rangemesh::heights {

// Triangles over vertices that stay at their pixels; `values` are the vertices' copied values
// (depth, or inverse depth before a pinhole), where the fit starts.
struct FitMesh {
    Grid<const index_t> faces;  // (F, 3) vertex ids, either orientation
    Span<const index_t> rows;   // each vertex's pixel row
    Span<const index_t> cols;   // and column
    Span<const double> values;
};

// The image the vertex values are fitted to, and which of its pixels are valid.
struct FitImage {
    Grid<const double> values;
    Grid<const bool> valid;
};

// One face's normal equations: over its kept pixels, the sums of w w^T (m) and of w times the
// pixel's value (rhs), w the barycentric weights of its corners `ids`, counter-clockwise.
struct FaceBlock {
    index_t ids[3] = {0, 0, 0};
    double m[3][3] = {{0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}};
    double rhs[3] = {0.0, 0.0, 0.0};
};

// Which pixels the first pass samples: the rows that are multiples of `row_stride` of the
// faces order[0], order[face_stride], order[2 * face_stride], ...
struct Sample {
    index_t row_stride = 1;
    index_t face_stride = 1;
};

// Sizes, ids and positions the kernels trust: faces over the vertices, an image and mask of one
// shape, every vertex in the image. The passes (`sample_errors`, `fit_blocks`) read pixels
// unchecked after it.
void check_mesh(const FitMesh& mesh, const FitImage& image);

}  // namespace rangemesh::heights
