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
            double length = lengths.rows > 0
                                ? lengths(t, k)
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

void ray_lengths(Span<const double> camera, Grid<const index_t> pixels, Span<const index_t> a, Span<const index_t> b,
                 double pixel_angle, Span<double> out) {
    const index_t w = static_cast<index_t>(camera[2]);
    const double* rays = camera.data + 6;
    for (index_t i = 0; i < a.size; ++i) {
        poll_every(i);
        const double* p = rays + 3 * (pixels(a[i], 0) * w + pixels(a[i], 1));
        const double* q = rays + 3 * (pixels(b[i], 0) * w + pixels(b[i], 1));
        // |p x q| and p . q summed in numpy's order (np.cross, np.linalg.norm, np.sum)
        const double c0 = p[1] * q[2] - p[2] * q[1], c1 = p[2] * q[0] - p[0] * q[2], c2 = p[0] * q[1] - p[1] * q[0];
        const double sine = std::sqrt(c0 * c0 + c1 * c1 + c2 * c2), cosine = p[0] * q[0] + p[1] * q[1] + p[2] * q[2];
        out[i] = std::atan2(sine, cosine) / pixel_angle;
    }
}

}  // namespace rangemesh::refine
