// What the refine method's kernels share: the 2^-32 rounding rule of its keys, and which
// triangle owns the pixels on an edge.
#pragma once

#include <cmath>

#include "../views.hpp"

namespace rangemesh::refine {

// Errors are ranked in units of 2^-32 of the valid depth range, so a change of depth unit
// (depth times s, the camera's kz divided by s) cannot reorder two pixels by rounding (SPEC P2).
constexpr double KEY_STEPS = 4294967296.0;
// Keys of pixels that must be covered lie above every error key.
constexpr double COVER_KEY = 1.25 * KEY_STEPS;
// Keys below 1 (no error key is): triangles that fit their pixels exactly rank by area below it.
constexpr double SMALL_KEY = 0.5;

// An error as a key: a whole number of 2^-32 steps of the valid range `span`.
inline double quantize(double err, double span) {
    if (span > 0.0) return std::floor(err / span * KEY_STEPS + 0.5);
    return 0.0;
}

// Whether the triangle left of the directed edge a -> b owns the pixels on it: of the two
// triangles of a shared edge, the one on its left when it is walked with rows, then columns,
// increasing.
inline bool owns(index_t ar, index_t ac, index_t br, index_t bc) {
    return br > ar || (br == ar && bc > ac);
}

// Whether a triangle owns the pixels on its edge a -> b, whose twin half-edge is `twin`. A hull
// edge's pixels are its only triangle's, except on a seam: a hull edge down an inner column of
// an image of width `w`, where one strip's mesh meets the next (each strip fixes the seam's
// vertices beforehand, so its pixels are candidates in neither).
inline bool own_edge(index_t twin, index_t ar, index_t ac, index_t br, index_t bc, index_t w) {
    if (twin < 0) return !(ac == bc && 0 < ac && ac < w - 1);
    return owns(ar, ac, br, bc);
}

}  // namespace rangemesh::refine
