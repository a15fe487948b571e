// Greedy insertion on two vertical strips of the image, on two native threads: the same mesh
// as inserting each strip's worst pixel in the order of their keys, whatever the threads.
//
// The strips meet down one column, the seam, whose vertices are fixed beforehand (`seam_rows`);
// no triangle crosses it, so the strips' insertions do not interact. Both advance until their
// first key falls below a common threshold (a round): whatever the threads' timing, that state
// is one the one-at-a-time order passes through. Thresholds come from a power law of each
// strip's keys so far; the last few vertices go one at a time, from the strip whose key is
// larger (`merge_tail`), landing exactly on the count. A round whose prediction was far off
// stops a strip by count; the next round (same threshold) brings it back to that order.
#pragma once

#include <functional>
#include <utility>
#include <vector>

#include "insertion.hpp"

namespace rangemesh {
class Worker;
}

namespace rangemesh::refine {

// Rows of about `k` valid pixels of a column profile, by greedy insertion in one dimension:
// the pixel farthest from the line between its chosen neighbours (in key units of `span`),
// until `k` are chosen or (when `max_sum` is not negative) the summed error is at most it;
// once every pixel lies on those lines, the middle of the longest gap. The first and last
// valid pixels always.
std::vector<index_t> seam_rows(Span<const double> z, Span<const bool> ok, index_t k, double max_sum, double span);

// Insert one vertex at a time into strip `a` or `b`, whichever's first key is larger (ties to
// `a`), until they hold `n_target` valid vertices between them (the seam counted twice), their
// summed error is at most `max_sum` (when not negative) with no pixel left to cover, or
// nothing is left to insert (or neither strip goes on: keys or sums of NaN).
void merge_tail(Insertion& a, Insertion& b, index_t n_target, double max_sum);

// What the two strips are asked for.
struct StripRequest {
    index_t vertices;  // valid vertices wanted, the seam's once
    index_t target;    // ... the seam's counted twice (once a strip)
    index_t reserve;   // room for this many vertices a strip (0 under an error bound)
    double budget;     // the strips' summed error bound, or -1
    index_t sr, sc;    // weights of rows and columns in the Delaunay test
    int threads;       // 1: one strip after the other; 2: on two threads (the same mesh)
    bool rounds;       // false: every vertex one at a time (for tests)
    bool flip;         // then flip each strip's edges by the error (`flip_by_error`)
};

// One strip's mesh once inserted (and flipped): vertex pixels, triangles, twins, sums.
struct StripMesh {
    std::vector<index_t> vr, vc, triangles, halfedges;
    std::vector<double> sums;
    index_t valid_vertices;
    double total;  // the insertion's summed error (flips leave it alone)
    index_t flips = 0;  // edges flipped by the error on this strip
};

struct Strips {
    StripMesh left, right;
    index_t rounds = 0;
    bool capped = false;  // the last round stopped a strip by count, not by the threshold
};

// A strip's vertex count against its first key, n ~ key^-e, through its last two rounds.
struct PowerLaw {
    double n = 0.0, k = 0.0, e = 1.0;  // the last count and key, the exponent

    // The predicted count once the first key falls below `key`.
    double count_at(double key) const;
};

// The exponent e of y ~ x^-e through two points, within its bounds; the default exponent when
// the points do not fall that way.
double strip_exponent(double x0, double y0, double x1, double y1);
// The law of a history of (count, first key) after each round.
PowerLaw strip_power_law(const std::vector<std::pair<double, double>>& hist);
// The count at which the summed error is predicted to reach `budget`, from (count, error) pairs.
double strip_error_target(const std::vector<std::pair<double, double>>& hist, double budget);

// Both strips inserted (on two threads when asked), then each flipped when asked.
Strips strip_insert(const Image& image, const FirstMesh& left, const FirstMesh& right, const StripRequest& req);
// The same from the first meshes `starts(0)` (left) and `starts(1)` (right) makes, each on its
// strip's thread, with a second thread the caller started (or none: one strip after the other):
// the set-up runs on both threads too (`insert_halves`). The meshes `starts` returns are read
// before it returns.
Strips strip_insert(const Image& image, const std::function<FirstMesh(int)>& starts, const StripRequest& req,
                    Worker* worker);

}  // namespace rangemesh::refine
