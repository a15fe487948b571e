// NumPy's median of a float array, bit for bit.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <utility>

#include "../views.hpp"

namespace rangemesh::heights {

namespace median_detail {

// Below this many values std::nth_element is as fast as `select`.
constexpr index_t SELECT_MIN = 256;
// Rounds of partitioning before the rest is left to std::nth_element (a bound on bad pivots;
// ninthers of real errors halve the candidates or better every round).
constexpr int SELECT_ROUNDS = 48;
constexpr double NONE = -std::numeric_limits<double>::infinity();

inline double median3(double a, double b, double c) { return std::max(std::min(a, b), std::min(std::max(a, b), c)); }

// The median of three medians of three values spread over x[0..n) (n >= 9): one of them.
inline double ninther(const double* x, index_t n) {
    const index_t s = n / 9;
    return median3(median3(x[0], x[s], x[2 * s]), median3(x[3 * s], x[4 * s], x[5 * s]),
                   median3(x[6 * s], x[7 * s], x[8 * s]));
}

// The largest of x[0..n), NONE when n is 0 (four chains: max is exact in any order).
inline double largest(const double* x, index_t n) {
    double m[4] = {NONE, NONE, NONE, NONE};
    index_t i = 0;
    for (; i + 4 <= n; i += 4)
        for (int j = 0; j < 4; ++j) m[j] = std::max(m[j], x[i + j]);
    for (; i < n; ++i) m[0] = std::max(m[0], x[i]);
    return std::max(std::max(m[0], m[1]), std::max(m[2], m[3]));
}

struct Selected {
    double value;  // the k-th smallest
    double below;  // the (k-1)-th smallest (when asked for, k >= 1)
};

// The k-th smallest value (from 0) of x[0..n), which holds no NaN, and the one before it if
// `with_below`; overwrites x, and `room` (n values). Quickselect whose partition writes every
// value to both ends of the other buffer and counts where it belongs instead of branching on
// it: std::nth_element's branches on the data are mispredicted half the time.
inline Selected select(double* x, index_t n, index_t k, double* room, bool with_below) {
    double* const buffers[2] = {x, room};
    int in = 0;            // the buffer that holds the candidates src[0..n)
    double* src = x;
    double below = NONE;   // the largest value left behind below the candidates
    for (int round = 0; n > SELECT_MIN && round < SELECT_ROUNDS; ++round) {
        const double p = ninther(src, n);
        double* const out = buffers[1 - in];
        index_t less = 0, greater = 0;  // out[0..less) < p < out[n - greater..n)
        for (index_t i = 0; i < n; ++i) {
            const double v = src[i];
            out[less] = v;
            out[n - 1 - greater] = v;
            less += v < p;
            greater += v > p;
        }
        const index_t equal = n - less - greater;
        in = 1 - in;
        if (k < less) {
            src = out;
            n = less;
        } else if (k < less + equal) {
            return {p, !with_below ? NONE : k > less ? p : std::max(below, largest(out, less))};
        } else {
            below = p;  // every value left behind is at most p, and p is one of them
            src = out + (n - greater);
            k -= less + equal;
            n = greater;
        }
    }
    std::nth_element(src, src + k, src + n);
    return {src[k], with_below ? std::max(below, largest(src, k)) : NONE};
}

}  // namespace median_detail

// np.median(x) of a non-empty array, overwriting x: NaN when x holds one, else the middle
// value, or the mean (a + b) / 2 of the two middle values for an even count, as NumPy computes
// it. `room`: x.size doubles of any contents the selection may overwrite, or null (then it
// allocates them when it needs them).
inline double median_inplace(Span<double> x, double* room = nullptr) {
    require(x.size > 0, "median: an empty array has no median");
    bool nan = false;
    std::uint64_t bits = 0;  // the sign bits of all values, or-ed
    for (const double v : x) {
        nan |= std::isnan(v);
        std::uint64_t b;
        std::memcpy(&b, &v, sizeof b);
        bits |= b;
    }
    if (nan) return std::numeric_limits<double>::quiet_NaN();
    const index_t h = x.size / 2;
    // Without negative values (errors have none) equal values have equal bits, so any exact
    // selection returns NumPy's; -0.0 and 0.0 compare equal and keep std::nth_element's choice.
    if (x.size >= median_detail::SELECT_MIN && (bits >> 63) == 0) {
        std::unique_ptr<double[]> own;
        if (room == nullptr) {
            own.reset(new double[x.size]);
            room = own.get();
        }
        const bool even = x.size % 2 == 0;
        const median_detail::Selected s = median_detail::select(x.data, x.size, h, room, even);
        return even ? (s.below + s.value) / 2.0 : s.value;
    }
    std::nth_element(x.begin(), x.begin() + h, x.end());
    if (x.size % 2 == 1) return x[h];
    const double below = *std::max_element(x.begin(), x.begin() + h);  // the (h-1)-th smallest
    return (below + x[h]) / 2.0;
}

}  // namespace rangemesh::heights
