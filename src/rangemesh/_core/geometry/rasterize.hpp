// Rendering a mesh in the image plane: per-vertex values interpolated over each triangle's pixels.
#pragma once

#include "../views.hpp"
#include "pixels.hpp"

namespace rangemesh {

// The triangles' corners in the image plane, (F, 3) each, and the values to interpolate.
struct FaceValues {
    Grid<const double> r, c, value;
};

// The render, filled in place: `value` NaN and `face` -1 where no triangle has written yet.
struct RenderTarget {
    Grid<double> value;
    Grid<index_t> face;
};

// Interpolate each triangle's corner values over the pixel centres it covers (closed triangles;
// degenerate ones cover nothing); the first triangle that covers a pixel sets it. A triangle
// with pixel-centre corners is walked over its exact row spans, any other over its bounding
// box; both give the same pixels and the same values, bit for bit.
void rasterize(FaceValues faces, RenderTarget out);

// The render without face ids: `claimed` 0 where no triangle has written yet, set to 1 where one
// does (an eighth of the ids' memory); the same values, bit for bit.
struct ValueTarget {
    Grid<double> value;
    Grid<unsigned char> claimed;
};

void rasterize(FaceValues faces, ValueTarget out);

// How a render's stored value reads as depth: as it is, 1 / value, or 1 / value / scale.
struct DepthMap {
    enum Kind { same, inverse, inverse_scaled } kind = same;
    double scale = 1.0;
};

// `covered_error(pred, claimed, depth, valid, map, range)`: |map(pred) - depth| summed over the
// valid pixels a render claimed where map(pred) is finite, and their number, and with `range`
// `valid_range(depth, valid)`; the same total, count and range bit for bit (four pixels at once
// where AVX runs, the sum still added in row-major order).
CoveredError claimed_error(Grid<const double> pred, Grid<const unsigned char> claimed, Grid<const double> depth,
                           Grid<const bool> valid, DepthMap map, DepthRange* range);

}  // namespace rangemesh
