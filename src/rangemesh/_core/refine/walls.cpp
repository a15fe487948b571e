#include "walls.hpp"

#include <cmath>

#include "../interrupt.hpp"

namespace rangemesh::refine {

void wall_faces(Grid<const index_t> faces, Grid<const index_t> pixels, Span<const double> z, double jump,
                Grid<const double> lengths, Span<bool> out) {
    for (index_t t = 0; t < faces.rows; ++t) {
        poll_every(t);
        bool wall = false;
        for (int k = 0; k < 3; ++k) {
            const index_t a = faces(t, k), b = faces(t, (k + 1) % 3);
            double length = lengths.rows > 0 ? lengths(t, k)
                                             : std::hypot(static_cast<double>(pixels(a, 0)) - static_cast<double>(pixels(b, 0)),
                                                          static_cast<double>(pixels(a, 1)) - static_cast<double>(pixels(b, 1)));
            length = length < 1.0 ? 1.0 : length;  // np.maximum(length, 1.0) (a NaN stays)
            const double za = std::abs(z[a]), zb = std::abs(z[b]);
            // np.minimum: a NaN wins; a threshold beyond the float range is inf (no wall)
            const double low = std::isnan(za) || std::isnan(zb) ? za + zb : (zb < za ? zb : za);
            wall = wall || std::abs(za - zb) > jump * low * length;
        }
        out[t] = wall;
    }
}

}  // namespace rangemesh::refine
