#include "lines.hpp"

namespace rangemesh {

double edge_error(index_t va, index_t vb, const MeshPoints& mesh, const RangeImage& image) {
    index_t ra = mesh.pixels(va, 0), ca = mesh.pixels(va, 1);
    index_t rb = mesh.pixels(vb, 0), cb = mesh.pixels(vb, 1);
    if (rb < ra || (rb == ra && cb < ca)) {
        std::swap(va, vb);
        std::swap(ra, rb);
        std::swap(ca, cb);
    }
    const Vec3 p = row3(mesh.vertices, va);
    const Vec3 d = row3(mesh.vertices, vb) - p;
    const double dd = d.x * d.x + d.y * d.y + d.z * d.z;
    // Bresenham, incremental: the pixels of `line_pixel` without a division a pixel. The minor
    // offset at step k is floor((2 k dmin + n - 1) / (2 n)); `acc` is that fraction's numerator.
    const index_t dr = rb - ra, dc = cb - ca;
    const index_t adr = std::llabs(dr), adc = std::llabs(dc);
    const index_t sr = dr >= 0 ? 1 : -1, sc = dc >= 0 ? 1 : -1;
    const bool along_rows = adr >= adc;
    const index_t n = along_rows ? adr : adc;
    const index_t dmin = along_rows ? adc : adr;
    index_t acc = n - 1;
    double total = 0.0;
    index_t r = ra, c = ca;
    for (index_t k = 0; k <= n; ++k) {
        if (k > 0) {
            acc += 2 * dmin;
            const bool bump = acc >= 2 * n;
            if (bump) acc -= 2 * n;
            if (along_rows) {
                r += sr;
                if (bump) c += sc;
            } else {
                c += sc;
                if (bump) r += sr;
            }
        }
        if (!image.valid(r, c)) continue;
        const Vec3 q = image.lift(r, c) - p;
        double t = 0.0;
        if (dd > 0.0) {
            t = (q.x * d.x + q.y * d.y + q.z * d.z) / dd;
            t = py_min(py_max(t, 0.0), 1.0);
        }
        const double ex = q.x - t * d.x;
        const double ey = q.y - t * d.y;
        const double ez = q.z - t * d.z;
        total += std::sqrt(ex * ex + ey * ey + ez * ez);
    }
    return total;
}

}  // namespace rangemesh
