// The deviation targets of the refine call (`max_deviation=`, `mean_deviation=`, `max_edge=`): a
// mesh's per-pixel deviation from the reference, measured on its render, and the pixels a round
// of insertion adds where a bound is still missed.
//
// A pixel's deviation is |predicted - measured| * scale: the depth the mesh predicts at the pixel
// centre (render.py's `render_depth`: depth interpolated linearly, or its inverse before a pinhole
// or a z-depth Rays camera), against the reference's, in metres (the camera's depth or range
// scale) or, with an orthographic camera, depth units (scale 1).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "../geometry/pixels.hpp"
#include "image.hpp"
#include "mesh.hpp"

namespace rangemesh::refine {

// How a pixel's deviation is measured.
struct DeviationRule {
    double scale = 1.0;    // metres of one stored depth unit (1: depth units)
    bool inverse = false;  // the render interpolates inverse depth (a pinhole, z-depth rays)
};

// A mesh's deviation over the reference's valid pixels it covers, and per face the pixel a round
// would insert there: the worst valid pixel that is no vertex, nearest the centroid among equals.
struct Deviation {
    double max = 0.0, sum = 0.0;  // over covered valid pixels of the reference
    index_t covered = 0, uncovered = 0;
    double longest_edge = 0.0;    // the longest face edge in the image plane, pixels
    std::vector<double> worst;    // per face: the deviation of its pixel to insert (-1: none)
    std::vector<index_t> pick;    // per face: that pixel, r * W + c (-1: none)
    std::vector<double> face_sum; // per face: summed deviation of its covered valid pixels
    std::vector<double> edge;     // per face: its longest edge, pixels

    double mean() const { return covered ? sum / static_cast<double>(covered) : 0.0; }
};

// The per-pixel buffers `measure_deviation` renders into, kept by a caller that measures again
// (the rounds): a 640 x 480 image's 7.4 MB are then not made and faulted in again each round.
struct DeviationBuffers {
    std::unique_ptr<double[]> pred;  // the render's values, set where `face` holds a face
    std::vector<index_t> face;       // the render's faces
    std::vector<index_t> vertex;     // the vertex on each pixel
    index_t size = 0;                // the pixels `pred` holds
};

// The deviation of mesh `f` whose vertices have stored depths `z` (one a vertex); `buffers`, when
// given, are rendered into (else the call's own).
Deviation measure_deviation(const Image& image, const Reference& ref, DeviationRule rule, const ValidFaces& f,
                            const std::vector<double>& z, DeviationBuffers* buffers = nullptr);

// What a round must still reach: a largest deviation (`max_deviation`), a mean one
// (`mean_deviation`), each negative for none; faces with a longer edge than `max_edge` pixels (0:
// none).
struct RoundBounds {
    double max_deviation = -1.0, mean_deviation = -1.0, max_edge = 0.0;
};

// Whether `d` meets the deviation bounds (the edge bound aside).
bool deviation_met(const Deviation& d, const RoundBounds& b);

// The pixels (r * W + c, distinct, valid, no vertex) a round inserts: the pick of each face beyond
// `max_deviation` or with an edge longer than `max_edge` (or, when such a face has no pick, the
// pixel nearest the middle of its longest edge); under a mean bound missed, the picks of the faces
// of the largest summed deviation until they hold twice the excess.
std::vector<index_t> round_additions(const Image& image, const ValidFaces& f, const Deviation& d, const RoundBounds& b);

}  // namespace rangemesh::refine
