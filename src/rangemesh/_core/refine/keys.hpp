// What the refine method's kernels share: the 2^-32 rounding rule of its keys. Which triangle
// owns the pixels on an edge is geometry/ownership.hpp's.
#pragma once

#include <cmath>

#include "../geometry/ownership.hpp"
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

}  // namespace rangemesh::refine
