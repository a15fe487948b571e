// The fit's passes over the pixels: each valid pixel visited once, by the face that owns it.
//
// An interior pixel belongs to its face; a pixel on a shared edge to one side only (`owns`,
// geometry/ownership.hpp); a pixel on the mesh's border to its face when that rule says so (else
// the fit does not use it). Rows are walked over their exact integer spans (`owned_rows`).
#pragma once

#include "../views.hpp"
#include "system.hpp"

namespace rangemesh::heights {

// A full pass of this many faces or more is shared by the threads it is given: each face's
// sums land in its own block, so the result is the same bit for bit.
constexpr index_t SPLIT_MIN_FACES = 4000;
// ... and a sample of this many faces or more (a sample visits every face, or every row of some).
constexpr index_t SAMPLE_SPLIT_MIN_FACES = 1000;

// Each sampled pixel's |value - mesh value| (the mesh at the vertices' copied values) into
// `errors`, at most errors.size of them, in the order of the faces; returns how many. On up to
// `threads` threads (from SAMPLE_SPLIT_MIN_FACES sampled faces), the same errors in the same order.
index_t sample_errors(const FitMesh& mesh, const FitImage& image, Span<const index_t> order, Sample sample,
                      Span<double> errors, int threads = 1);

// The normal equations of every face, visited in `order`: blocks[i] gathers the pixels of face
// order[i] whose error is at most `threshold`. On up to `threads` threads; returns the number
// of pixels used.
index_t fit_blocks(const FitMesh& mesh, const FitImage& image, Span<const index_t> order, double threshold, int threads,
                   Span<FaceBlock> blocks);

// That every order entry is a face (ValueError).
void check_order(const FitMesh& mesh, Span<const index_t> order);

// `sample_errors` and `fit_blocks` of an order `check_order` has passed: a fit checks it once.
index_t sample_errors_checked(const FitMesh& mesh, const FitImage& image, Span<const index_t> order, Sample sample,
                              Span<double> errors, int threads);
index_t fit_blocks_checked(const FitMesh& mesh, const FitImage& image, Span<const index_t> order, double threshold,
                           int threads, Span<FaceBlock> blocks);

}  // namespace rangemesh::heights
