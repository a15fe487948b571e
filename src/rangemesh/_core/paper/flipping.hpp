// Stage three of the paper's method (II.B.2-3, SPEC 3): discontinuity-preserving edge flips.
//
// Edges wait in a max-heap keyed by their gain G = E(A,B) - E(C,D); the head edge gets one
// verdict (T1 deadlock, the edge-length bound, then the paper's tests T2-T5 and its final test,
// or for the error rule a positive gain alone) and is flipped or dropped, until no gain is left.

/* Quad before and after a flip of AB (e0 in t0 = ABC, e1 in t1 = BAD):

             C                      C
           /   \                  / | \
          /  t0 \                /  |  \
         A ----- B      ->      A t0|t1 B
          \  t1 /                \  |  /
           \   /                  \ | /
             D                      D

   t0 becomes DCA and t1 CDB; the new diagonal keeps the half-edge slots e0, e1 and the edge id
   of AB, the four outer edges keep their ids. */
#pragma once

#include "../geometry/lines.hpp"
#include "../views.hpp"

namespace rangemesh::paper {

// What the stage decided for an edge popped from its queue; the indices of its counters and
// the values of Python's flipping.Verdict.
enum Verdict : index_t {
    T1_DEADLOCK = 0,          // C and D were neighbours before: flipping could cycle
    T2_DISPARITY_CHANGE = 1,  // |disp(AB) - disp(CD)| < epsilon
    T3_DEGENERATE = 2,        // a new triangle is degenerate on a smooth region
    T4_BEND = 3,              // the new triangles bend by no more than min_bend
    T5_CREASE = 4,            // a crease along AB would be lost
    FINAL_TEST = 5,           // disp(AB) <= disp(CD): the final test keeps AB
    FLIPPED = 6,              // the edge was flipped
    MAX_EDGE = 7,             // CD would be longer than max_edge
    N_VERDICTS = 8,
};

// The flip rule: the paper's tests, or flip while the gain is positive.
enum FlipRule : index_t { RULE_DISPARITY = 0, RULE_ERROR = 1 };

// The paper's tests' thresholds, in radians.
struct DisparityTests {
    double delta = 0.0;      // the largest angle between a span and a triangle that is smooth
    double epsilon = 0.0;    // T2: the least significant change of disparity
    double max_angle = 0.0;  // T3: an internal angle above this makes a triangle degenerate
    double min_bend = 0.0;   // T4: the least noticeable bend between the new triangles
};

struct FlipSettings {
    FlipRule rule = RULE_DISPARITY;
    DisparityTests tests;
    double threshold = 0.0;  // gains below this are not worth a decision
    double quantum = 0.0;    // gains are rounded to multiples of this power of two
    double max_edge2 = 0.0;  // the squared bound on CD's length in the image plane (pixels)
};

// The half-edge mesh the stage edits in place, and its vertices.
struct FlipMesh {
    Span<index_t> triangles;
    Span<index_t> halfedges;
    MeshPoints points;
};

// What the stage reports: `verdicts` (N_VERDICTS) counts each verdict given; the first
// log.rows decisions go to `log` as (smaller endpoint, larger endpoint, verdict).
struct FlipRecord {
    Span<index_t> verdicts;
    Grid<index_t> log;
};

// Stage three (SPEC 3.3-3.6) on `mesh`, in place; returns the number of flips taken.
index_t flip_loop(const FlipMesh& mesh, const RangeImage& image, const FlipSettings& settings,
                  const FlipRecord& record);

// The paper's tests T2-T5 and its final test on the edge of half-edge e0 (SPEC 3.3-3.5):
// FLIPPED when the final test accepts the flip, else the first test that rejects it.
// `normals` (F x 3) holds the triangles' unit normals.
Verdict disparity_verdict(Span<const index_t> triangles, Span<const index_t> halfedges, Grid<const double> normals,
                          Grid<const double> vertices, index_t e0, const DisparityTests& tests);

}  // namespace rangemesh::paper
