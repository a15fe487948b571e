// The two strips of one refine call (rangemesh/refine/strips.py's `strip_insert`, natively): the
// seam column and its vertices, each strip's first mesh, `strip_insert` on them, and the two
// meshes joined into one, the seam's edges flipped by the error when asked.
#pragma once

#include <vector>

#include "image.hpp"

namespace rangemesh {
class Worker;
}

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

// With `req.threads` of 2 or more, the strips and their join run on two threads: the calling one and
// `second` (the caller's, kept from call to call), or one started for the call when none is given.
Halves insert_halves(const Image& image, const HalvesRequest& req, Worker* second = nullptr);

struct StripMesh;

// The strips joined on column `m` into `out` (strips.py's `_join` and `_joined_halfedges`): B's
// vertices renumbered after A's, its seam vertices A's own, B's half-edges after A's, and A's
// half-edges down the seam paired with B's the other way; `sums` (when given) the strips'
// triangle sums, A's first. A's part is copied on `second` (or none) while B's is renumbered on
// the calling thread; the seam's pairs are then matched. Returns A's seam half-edges, in order.
std::vector<index_t> join_strips(const StripMesh& a, const StripMesh& b, index_t m, Worker* second, Halves& out,
                                 std::vector<double>* sums);

}  // namespace rangemesh::refine
