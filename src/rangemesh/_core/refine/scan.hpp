// What greedy insertion learns of one triangle by walking its pixels: the pixel to insert next,
// its key in the heap, and the triangle's summed error.
#pragma once

#include <cstdint>

#include "image.hpp"
#include "plane.hpp"

namespace rangemesh::refine {

// A triangle corner: its pixel, its depth, and whether the pixel is background (an image corner).
struct Corner {
    index_t r, c;
    double z;
    bool background;
};

// A triangle's standing in the heap. `key` is -1 when no pixel can be inserted; `sum` is
// sum |depth - plane| over the valid pixels it owns (0 for a triangle keyed without a full
// scan); `fits` says that it fits exactly and (r, c) is its centroid.
// 32 bytes, two to a cache line: the pixel in int32 (an image side is at most EXACT_SPAN).
struct alignas(32) TriangleKey {
    double key = -1.0;
    double sum = 0.0;
    std::int32_t r = -1, c = -1;
    bool fits = false;
};

// The key of a triangle that fits exactly: below every other, larger triangles first, so
// vertices asked beyond an exact mesh go to the largest triangles and spread over the image.
double spread_key(index_t area, index_t h, index_t w);

struct Pixel {
    index_t r, c;
};

// The pixel nearest the centroid of ABC when it is valid and strictly inside (on no edge, so
// inserting it splits ABC in three), else {-1, -1}.
Pixel centroid_pixel(index_t ar, index_t ac, index_t br, index_t bc, index_t cr, index_t cc, Grid<const bool> valid);

// Rasterise triangle ABC (counter-clockwise): the pixel to insert, its key, the error sum.
// A triangle with a background corner is keyed by the valid pixel that covers it best (above
// every error key); any other by sqrt(worst error * error sum / pixels) in key units.
TriangleKey scan_triangle(const Image& image, const Corner& a, const Corner& b, const Corner& c, EdgeOwnership own);

}  // namespace rangemesh::refine
