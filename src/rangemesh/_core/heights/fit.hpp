// Least-squares vertex values for a mesh with fixed image positions, jumps left out.
//
// A pixel's predicted value is la * ha + lb * hb + lc * hc, its barycentric weights in the face
// that owns it; every vertex value is chosen to minimise the squared error over the pixels its
// faces own. Pixels whose error under the copied values exceeds `outlier_mads` robust standard
// deviations (1.4826 x the median error of a sample) lie across a jump and are left out.
#pragma once

#include <limits>
#include <vector>

#include "../views.hpp"
#include "system.hpp"

namespace rangemesh::heights {

// The caller's choices; refine/heights.py holds the library's values and the reasons for them.
struct FitSettings {
    Sample sample;                // the pixels whose errors' median sets the outlier bound
    index_t capacity = 0;         // at most this many sampled errors: the image's valid pixels
    double outlier_mads = 0.0;    // the bound, in robust standard deviations
    double outlier_floor = 0.0;   // the share of the vertices' value range at or below which the
                                  // bound keeps the copied values as they are
    double ridge = 0.0;           // the pull towards the copied values (`solve_blocks`)
    double rtol = 0.0;            // conjugate gradients' relative residual
    index_t max_iter = 0;         // and most steps
    int threads = 1;              // for the pass over the pixels
    double lo = -std::numeric_limits<double>::infinity();  // a fitted value below lo is lo,
    double hi = std::numeric_limits<double>::infinity();   // one above hi is hi
};

enum class FitOutcome {
    no_pixels,      // the faces own no valid pixel: keep the copied values
    copied,         // the bound sits at its floor: the copied values are the solution
    fitted,         // `values` holds the solution, within [lo, hi]
    not_converged,  // `values` holds conjugate gradients' last iterate; `blocks` the system
};

struct FitResult {
    FitOutcome outcome = FitOutcome::no_pixels;
    double threshold = 0.0;          // the outlier bound used
    index_t used = 0;                // pixels in the system
    std::vector<double> values;      // one a vertex (fitted, not_converged)
    std::vector<FaceBlock> blocks;   // one a visited face (not_converged)
};

// The fit of mesh.values to the image, the faces visited in `order` (a permutation of them).
FitResult fit_heights(const FitMesh& mesh, const FitImage& image, Span<const index_t> order,
                      const FitSettings& settings);

}  // namespace rangemesh::heights
