#include "regions.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "../interrupt.hpp"

namespace rangemesh {

namespace {

constexpr index_t DR[8] = {-1, -1, -1, 0, 0, 1, 1, 1};
constexpr index_t DC[8] = {-1, 0, 1, -1, 1, -1, 0, 1};

// Whether two valid neighbours' depths join them (the rule in regions.hpp); NaN never joins.
inline bool joined(double za, double zb, double step) {
    return std::abs(za - zb) <= step * std::min(std::abs(za), std::abs(zb));
}

}  // namespace

std::vector<std::int64_t> label_regions(Grid<const double> depth, Grid<const bool> valid, double share,
                                        Grid<std::int32_t> labels) {
    require(
        valid.rows == depth.rows && valid.cols == depth.cols && labels.rows == depth.rows && labels.cols == depth.cols,
        "label_regions: valid and labels must have depth's shape");
    const double diagonal = share * std::sqrt(2.0);
    std::vector<std::int64_t> sizes;
    std::vector<index_t> stack;
    for (index_t r = 0; r < depth.rows; ++r)
        for (index_t c = 0; c < depth.cols; ++c) labels(r, c) = -1;
    for (index_t r = 0; r < depth.rows; ++r) {
        poll_interrupt();
        for (index_t c = 0; c < depth.cols; ++c) {
            if (!valid(r, c) || labels(r, c) >= 0) continue;
            require(sizes.size() < static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()),
                    "label_regions: more regions than int32 ids");
            const auto id = static_cast<std::int32_t>(sizes.size());
            std::int64_t count = 0;
            labels(r, c) = id;
            stack.push_back(r * depth.cols + c);
            while (!stack.empty()) {  // depth-first flood: a region at most the image, no recursion
                const index_t p = stack.back();
                stack.pop_back();
                ++count;
                const index_t pr = p / depth.cols, pc = p % depth.cols;
                const double z = depth(pr, pc);
                for (int k = 0; k < 8; ++k) {
                    const index_t qr = pr + DR[k], qc = pc + DC[k];
                    if (qr < 0 || qr >= depth.rows || qc < 0 || qc >= depth.cols) continue;
                    if (!valid(qr, qc) || labels(qr, qc) >= 0) continue;
                    if (!joined(z, depth(qr, qc), (DR[k] != 0 && DC[k] != 0) ? diagonal : share)) continue;
                    labels(qr, qc) = id;
                    stack.push_back(qr * depth.cols + qc);
                }
            }
            sizes.push_back(count);
        }
    }
    return sizes;
}

}  // namespace rangemesh
