// The two strips of one refine call (rangemesh/refine/strips.py's `strip_insert`, natively): the
// seam column and its vertices, each strip's first mesh, `strip_insert` on them, and the two
// meshes joined into one, the seam's edges flipped by the error when asked.
#pragma once

#include <vector>

#include "image.hpp"

namespace rangemesh::refine {

// What the strips are asked for; the rules' values live in strips.py.
struct HalvesRequest {
    index_t vertices = 0;  // valid vertices wanted (with max_sum, at most)
    double max_sum = -1.0;  // the summed error bound (not negative), or none
    index_t n_grid = 0;    // grid points of the two first meshes, between them
    index_t n_valid = 0;   // the image's valid pixels
    index_t sr = 1, sc = 1;
    double seam_density = 0.7, seam_error_share = 1.0;
    int threads = 1;
    bool flip = false;
};

// The joined mesh: vertex pixels, triangles (3 a triangle) and their twins, what the insertion ran.
struct Halves {
    std::vector<index_t> vr, vc, triangles, halfedges;
    index_t flips = 0;
    double total = 0.0;  // the strips' summed error, the seam's own pixels included
};

Halves insert_halves(const Image& image, const HalvesRequest& req);

}  // namespace rangemesh::refine
