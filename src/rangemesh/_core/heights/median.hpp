// NumPy's median of a float array, bit for bit, found in place.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

#include "../views.hpp"

namespace rangemesh::heights {

// np.median(x) of a non-empty array, reordering x: NaN when x holds one, else the middle value,
// or the mean (a + b) / 2 of the two middle values for an even count, as NumPy computes it.
inline double median_inplace(Span<double> x) {
    require(x.size > 0, "median: an empty array has no median");
    for (const double v : x)
        if (std::isnan(v)) return std::numeric_limits<double>::quiet_NaN();
    const index_t h = x.size / 2;
    std::nth_element(x.begin(), x.begin() + h, x.end());
    if (x.size % 2 == 1) return x[h];
    const double below = *std::max_element(x.begin(), x.begin() + h);  // the (h-1)-th smallest
    return (below + x[h]) / 2.0;
}

}  // namespace rangemesh::heights
