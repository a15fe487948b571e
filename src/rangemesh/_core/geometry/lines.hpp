// Raster lines between two pixels (Bresenham) and the edge error along them (SPEC 3.1).
#pragma once

#include <cstdlib>
#include <utility>

#include "../interrupt.hpp"
#include "../views.hpp"
#include "predicates.hpp"
#include "vectors.hpp"

namespace rangemesh {

struct Pixel {
    index_t r = 0, c = 0;
};

// Pixel k (0-based, from the first endpoint) of the raster line (r0, c0) -> (r1, c1): one pixel
// a step along the major axis; on the minor axis the nearest pixel, halves rounded toward the
// first endpoint (what the textbook loop with `if D > 0` gives). The line has
// max(|dr|, |dc|) + 1 pixels.
inline Pixel line_pixel(index_t r0, index_t c0, index_t r1, index_t c1, index_t k) {
    const index_t dr = r1 - r0, dc = c1 - c0;
    const index_t adr = std::llabs(dr), adc = std::llabs(dc);
    const index_t sr = dr >= 0 ? 1 : -1, sc = dc >= 0 ? 1 : -1;
    if (adr >= adc) {
        const index_t n = adr;
        if (n == 0) return {r0, c0};
        return {r0 + sr * k, c0 + sc * floor_div(2 * k * adc + n - 1, 2 * n)};
    }
    const index_t n = adc;
    return {r0 + sr * floor_div(2 * k * adr + n - 1, 2 * n), c0 + sc * k};
}

// A range image as the kernels read it: depths, which pixels are valid, and the camera
// (`Camera.as_array()`, see vectors.hpp).
struct RangeImage {
    Grid<const double> depth;
    Grid<const bool> valid;
    Span<const double> cam;

    Vec3 lift(index_t r, index_t c) const { return rangemesh::lift(cam, r, c, depth(r, c)); }

    bool contains(index_t r, index_t c) const { return 0 <= r && r < depth.rows && 0 <= c && c < depth.cols; }

    // Whether the views agree: valid has depth's shape and the camera's array its layout.
    bool consistent() const {
        if (valid.rows != depth.rows || valid.cols != depth.cols || cam.size < CAMERA_HEADER) return false;
        if (cam[0] != RAYS) return cam[0] == ORTHOGRAPHIC || cam[0] == PINHOLE;
        // compared as doubles: converting a NaN or huge H, W to an integer is undefined behaviour
        return cam[1] == static_cast<double>(depth.rows) && cam[2] == static_cast<double>(depth.cols) &&
               cam.size == CAMERA_HEADER + 3 * depth.rows * depth.cols;
    }
};

// A mesh's vertices as the kernels read them: (V, 2) pixels (row, column) and (V, 3) 3-D points.
struct MeshPoints {
    Grid<const index_t> pixels;
    Grid<const double> vertices;

    index_t size() const { return vertices.rows; }

    // Whether there is a pixel for each vertex and every pixel lies in `image`.
    bool fit(const RangeImage& image) const {
        if (pixels.rows != vertices.rows || pixels.cols != 2 || vertices.cols != 3) return false;
        for (index_t v = 0; v < pixels.rows; ++v) {
            poll_every(v);
            if (!image.contains(pixels(v, 0), pixels(v, 1))) return false;
        }
        return true;
    }
};

// E(A, B), SPEC 3.1: the sum of the 3-D distances from the valid pixels of the raster line AB to
// the 3-D segment AB. The line is drawn from the endpoint with the smaller (r, c), so
// E(A, B) == E(B, A) exactly.
double edge_error(index_t va, index_t vb, const MeshPoints& mesh, const RangeImage& image);

}  // namespace rangemesh
