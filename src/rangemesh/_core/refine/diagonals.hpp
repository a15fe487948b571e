// Each quad's diagonal chosen by the data (Dyn, Levin & Rippa 1990): an edge is flipped while
// the other diagonal lowers the sum of |depth - plane| over the two triangles' valid pixels.
//
// Both diagonals are measured on the same pixels (the ownership rules of `own_edge`: the outer
// edges keep their direction, the diagonal's pixels belong to one side either way). Sums are
// compared in key units (`quantize`), so near-ties flip alike in any depth unit and a quad that
// fits exactly either way is never flipped. Quads with a background vertex are left alone.
// Every flip lowers the total strictly; at most MAX_TESTS_PER_EDGE tests an edge bound the time.
#pragma once

#include <limits>

#include "image.hpp"
#include "scan.hpp"

namespace rangemesh::refine {

constexpr index_t MAX_TESTS_PER_EDGE = 8;

// Sum of |depth - plane| over the valid pixels of ABC (counter-clockwise) that `scan_triangle`
// visits, in its arithmetic and order (so cached and fresh sums compare). With a key `stop`
// the sum is left after a row once quantize(base + sum so far) >= stop: a flip test's answer
// is known then (sums only grow); the part returned is still at least `stop` in key units.
double triangle_error(const Image& image, const Point& a, const Point& b, const Point& c, EdgeOwnership own,
                      double base = 0.0, double stop = std::numeric_limits<double>::infinity());

// A mesh whose diagonals are flipped in place: vertex pixels, half-edge arrays, and each
// triangle's error sum over the pixels it owns.
struct FlipMesh {
    Span<const index_t> vr, vc;
    Span<index_t> triangles, halfedges;
    Span<double> sums;
};

struct FlipCount {
    index_t flips = 0, tests = 0;
};

// Flip every interior edge (no background corner) while a flip lowers the error. With
// `checked` false the caller vouches for the arrays (ids, twins, vertex pixels: an insertion's
// own), and only the vertices' depths and the background triangles' -1 sums are set first.
FlipCount flip_by_error(const Image& image, const FlipMesh& mesh, bool checked = true);

// The same, starting from the half-edges `first` only (and the edges flips touch), for a
// mesh whose other edges passed their tests: two strips joined along a seam. The sums of
// the triangles on those edges are computed afresh. With `checked` false the caller vouches for
// the arrays (ids, twins: each strip's made by its insertion, the seam's twins paired by the
// join), as `flip_by_error`'s.
FlipCount flip_from_edges(const Image& image, const FlipMesh& mesh, Span<const index_t> first, bool checked = true);

// Each triangle's error sum from scratch (0 for a triangle with a background corner).
void face_errors(const Image& image, const FlipMesh& mesh);

}  // namespace rangemesh::refine
