// The whole refine call on one strip or two: first mesh, insertion, diagonals, assembly (walls
// kept or dropped), heights and the lift to 3-D, repeated by one small search until the target
// is met: a vertex count (`vertices=`) or an error bound (`max_error=`, with a vertex cap: the
// default target).
//
// The rules and their reasons are those of rangemesh/refine/insertion.py, which checks the
// arguments and wraps the result; every step is a kernel of its own family (Insertion,
// flip_by_error, valid_faces, prune_dangling, fit_heights, lift), in the arithmetic and order of the Python steps it
// stands for, so the mesh is the same bit for bit.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "../heights/fit.hpp"
#include "image.hpp"

namespace rangemesh::refine {

// The least-squares heights' rules (rangemesh/refine/heights.py holds the values and reasons).
struct HeightRule {
    double outlier_mads = 6.0, outlier_floor = 1e-9, ridge = 1e-3, rtol = 1e-6;
    index_t residual_stride = 4, residual_min = 500, residual_sample = 2000;
    index_t order_tile = 8, order_min_pixels = 150000;
    int threads = 1;  // for the pass over the pixels of meshes of SPLIT_MIN_FACES faces or more
};

// What one call asks for; the caller resolves the library's defaults into it.
struct MeshRequest {
    index_t vertices = 0;  // valid vertices wanted (at most n_valid); with an error bound, the cap
    double max_error = -1.0;  // percent of the reference's valid range, mean; < 0: none
    index_t n_valid = 0;   // the image's valid pixels
    double lo = 0.0, hi = 0.0;  // their smallest and largest depth
    index_t n_grid = 0;    // grid points of the first mesh
    index_t sr = 1, sc = 1;  // weights of rows and columns in the Delaunay test
    bool strips = false;   // insert as two strips (`insert_halves`) until a count search needs one
    double seam_density = 0.7, seam_error_share = 1.0;  // the seam's vertices (strips.py)
    int threads = 1;       // the strips' threads
    bool flip = true;      // each quad's diagonal by the error (`flip_by_error`)
    bool fit = true;       // heights by least squares, else copied from the pixels
    bool walls = true;     // keep the walls of jumps; false drops them
    double jump = 0.05;    // the jump rule's share of the local depth per pixel (walls.hpp)
    double pixel_angle = 0.0;  // a ray camera's angle of one pixel, the unit of its edge lengths
    index_t max_runs = 8, max_bisect_runs = 5;  // meshings at most, and once past the count
    double collapse = 0.0;  // effort="best" (> 1): mesh this many times the count, collapse to it (collapse.hpp)
    HeightRule heights;
    // The deviation targets (deviation.hpp), each negative for none; with either, `vertices` is
    // the cap (n_valid: none) and `max_error` none. A pixel's deviation is |predicted - measured| depth times
    // `deviation_scale`, the prediction interpolating inverse depth when `deviation_inverse`.
    double max_deviation = -1.0, mean_deviation = -1.0;
    double max_edge = 0.0;  // longest face edge in the image plane, pixels, with any target (0: none)
    double deviation_scale = 1.0;
    bool deviation_inverse = false;
    // Deviation targets: the first insertion stops at a summed error of this share of the largest
    // deviation a pixel (in depth units) times the valid pixels; the rounds then insert the rest.
    double max_deviation_share = 0.25;
    // max_error: the first insertion stops at a summed error of this many times the bound's
    // (max_error / 100 * span * n_valid): above 1 only with fitted heights, which err less.
    double max_error_stop = 1.0;
};

// The image an error bound is measured against (the one before gap filling).
struct Reference {
    Grid<const double> depth;
    Grid<const bool> valid;
};

// How the call ended. `declined`: a fit conjugate gradients did not converge on, with no
// `DirectSolve` given (a raw call: the library always gives one); nothing else of the result is
// set. A call that leaves no triangle, even from the valid pixels' hull, is `done` with no face
// (`walls_dropped` says whether walls took them: Python names the reason).
enum class MeshOutcome { done, declined };

// The direct solve of a fit's system that conjugate gradients did not converge on (the caller's
// sparse LU, refine/heights.py's `_direct_solve`): the visited faces' blocks and the vertices'
// copied values in, the solution out, neither clipped nor inverted.
using DirectSolve =
    std::function<std::vector<double>(const std::vector<heights::FaceBlock>&, const std::vector<double>&)>;

struct MeshResult {
    MeshOutcome outcome = MeshOutcome::declined;
    std::vector<std::int32_t> faces;   // 3 a triangle, counter-clockwise
    std::vector<std::int32_t> pixels;  // (row, col) a vertex
    std::vector<double> vertices;      // (x, y, z) a vertex, lifted by the camera
    index_t edges = 0;                 // distinct edges of the faces
    index_t insertions = 0;            // vertices of the last insertion, background corners included
    index_t flips = 0;                 // edges the last insertion's diagonals flipped
    index_t strips = 1;                // strips of the last insertion (1 or 2)
    index_t meshings = 0;
    index_t walls_dropped = 0;         // walls dropped from the mesh (walls false)
    index_t asked = 0;                 // the last meshing's request (max_error: its vertex count)
    double achieved = 0.0;             // max_error: the relative error reached (NaN: none covered)
    // After rounds (a deviation target or max_edge): the deviation reached and what it covers.
    double deviation_max = 0.0, deviation_mean = 0.0, longest_edge = 0.0;
    index_t uncovered = 0;             // valid reference pixels no face covers (not measured)
    index_t rounds = 0;                // rounds of insertion after the search's meshing
    bool fitted = true;                // heights fitted (false: copied, the request's or the fit's say)
    double fit_seconds = 0.0, seconds = 0.0;
};

// The mesh of `image` for `req`, lifted by `camera` (`Camera.as_array()`; vectors.hpp); an
// error bound is measured against `reference`.
// A fit that meets a vertex value that is not finite raises ValueError (as refine/heights.py's
// `fit_heights`), except under rounds (a deviation target, max_edge), where the call is made
// again with copied heights; one that does not converge is solved by `direct` (under rounds:
// copied heights again).
MeshResult refine_mesh(const Image& image, Span<const double> camera, const Reference& reference,
                       const MeshRequest& req, const DirectSolve& direct = {});

}  // namespace rangemesh::refine
