#include "deviation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "../geometry/rasterize.hpp"
#include "../interrupt.hpp"

namespace rangemesh::refine {

Deviation measure_deviation(const Image& image, const Reference& ref, DeviationRule rule, const ValidFaces& f,
                            const std::vector<double>& z, DeviationBuffers* buffers) {
    const index_t h = image.rows(), w = image.cols(), n = h * w;
    const index_t n_f = static_cast<index_t>(f.faces.size() / 3), n_v = static_cast<index_t>(f.pixels.size() / 2);
    require(static_cast<index_t>(z.size()) == n_v, "measure_deviation: one depth a vertex");
    Deviation d;
    d.worst.assign(n_f, -1.0);
    d.pick.assign(n_f, -1);
    d.face_sum.assign(n_f, 0.0);
    d.edge.assign(n_f, 0.0);
    std::vector<double> fr, fc, fv, cr(n_f), cc(n_f);
    std::vector<index_t> kept;  // the rendered faces' ids (a wrap-around seam face covers no pixel)
    for (index_t t = 0; t < n_f; ++t) {
        poll_every(t);
        const FaceCorners corners = face_corners(f, t);
        const double* r = corners.r;
        const double* c = corners.c;
        for (int k = 0; k < 3; ++k) {
            const double dr = r[(k + 1) % 3] - r[k], dc = c[(k + 1) % 3] - c[k];
            d.edge[t] = std::max(d.edge[t], std::sqrt(dr * dr + dc * dc));
        }
        d.longest_edge = std::max(d.longest_edge, d.edge[t]);
        cr[t] = (r[0] + r[1] + r[2]) / 3.0;
        cc[t] = (c[0] + c[1] + c[2]) / 3.0;
        if (corners.wraps(w)) continue;
        kept.push_back(t);
        for (int k = 0; k < 3; ++k) {
            const index_t v = f.faces[3 * t + k];
            fr.push_back(r[k]);
            fc.push_back(c[k]);
            fv.push_back(rule.inverse ? 1.0 / z[v] : z[v]);
        }
    }
    DeviationBuffers own;
    DeviationBuffers& b = buffers != nullptr ? *buffers : own;
    if (b.size < n) {  // (the render's values are read only where it wrote a face: no NaN fill)
        b.pred.reset(new double[static_cast<std::size_t>(n)]);
        b.size = n;
    }
    fill_polled(b.vertex, static_cast<std::size_t>(n), index_t{-1});
    fill_polled(b.face, static_cast<std::size_t>(n), index_t{-1});
    const double* const pred = b.pred.get();
    const index_t* const face = b.face.data();
    index_t* const vertex = b.vertex.data();  // the vertex on each pixel
    const index_t n_kept = static_cast<index_t>(kept.size());
    rasterize({{fr.data(), n_kept, 3}, {fc.data(), n_kept, 3}, {fv.data(), n_kept, 3}},
              {{b.pred.get(), h, w}, {b.face.data(), h, w}});
    for (index_t i = 0; i < n_v; ++i) vertex[f.pixels[2 * i] * w + f.pixels[2 * i + 1]] = i;
    std::vector<double> near(n_f, std::numeric_limits<double>::infinity());  // the pick's distance to the centroid
    for (index_t r = 0; r < h; ++r) {
        poll_interrupt();
        for (index_t c = 0; c < w; ++c) {
            const index_t p = r * w + c;
            const index_t k = face[p];
            const bool measured = ref.valid(r, c);
            if (k < 0) {
                d.uncovered += measured;
                continue;
            }
            const index_t t = kept[k];
            double dev = 0.0;
            if (measured) {
                // at a vertex the mesh is the vertex's own depth (the inverse's rounding aside)
                const double predicted = vertex[p] >= 0 ? z[vertex[p]] : rule.inverse ? 1.0 / pred[p] : pred[p];
                dev = std::abs(predicted - ref.depth(r, c)) * rule.scale;
                if (std::isnan(dev)) dev = std::numeric_limits<double>::infinity();
                d.max = std::max(d.max, dev);
                d.sum += dev;
                ++d.covered;
                d.face_sum[t] += dev;
            }
            if (!image.valid(r, c) || vertex[p] >= 0) continue;
            const double dr = static_cast<double>(r) - cr[t], dc = static_cast<double>(c) - cc[t];
            const double dist = dr * dr + dc * dc;
            if (dev > d.worst[t] || (dev == d.worst[t] && dist < near[t])) {
                d.worst[t] = dev;
                d.pick[t] = p;
                near[t] = dist;
            }
        }
    }
    return d;
}

bool deviation_met(const Deviation& d, const RoundBounds& b) {
    if (b.max_deviation >= 0.0 && !(d.max <= b.max_deviation)) return false;
    if (b.mean_deviation >= 0.0 && !(d.mean() <= b.mean_deviation)) return false;
    return true;
}

namespace {

// The valid pixel nearest the middle of face t's longest edge that is no vertex, or -1.
index_t edge_middle(const Image& image, const ValidFaces& f, index_t t, const std::vector<unsigned char>& vertex) {
    index_t best = -1;
    double longest = -1.0;
    const index_t w = image.cols();
    for (int k = 0; k < 3; ++k) {
        const index_t a = f.faces[3 * t + k], b = f.faces[3 * t + (k + 1) % 3];
        const index_t ar = f.pixels[2 * a], ac = f.pixels[2 * a + 1], br = f.pixels[2 * b], bc = f.pixels[2 * b + 1];
        const double len = std::hypot(static_cast<double>(br - ar), static_cast<double>(bc - ac));
        if (len <= longest) continue;
        longest = len;
        const index_t r = static_cast<index_t>(std::floor((ar + br) / 2.0)),
                      c = static_cast<index_t>(std::floor((ac + bc) / 2.0));
        best = image.valid(r, c) && !vertex[r * w + c] ? r * w + c : -1;
    }
    return best;
}

}  // namespace

std::vector<index_t> round_additions(const Image& image, const ValidFaces& f, const Deviation& d,
                                     const RoundBounds& b) {
    const index_t n_f = static_cast<index_t>(f.faces.size() / 3), w = image.cols();
    std::vector<unsigned char> vertex(static_cast<std::size_t>(image.rows() * w), 0), added(vertex.size(), 0);
    for (std::size_t i = 0; i < f.pixels.size() / 2; ++i) vertex[f.pixels[2 * i] * w + f.pixels[2 * i + 1]] = 1;
    std::vector<index_t> out;
    const auto add = [&](index_t p) {
        if (p >= 0 && !added[p]) {
            added[p] = 1;
            out.push_back(p);
        }
    };
    for (index_t t = 0; t < n_f; ++t) {
        poll_every(t);
        if (b.max_deviation >= 0.0 && d.worst[t] > b.max_deviation) add(d.pick[t]);
        if (b.max_edge > 0.0 && d.edge[t] > b.max_edge)
            add(d.pick[t] >= 0 ? d.pick[t] : edge_middle(image, f, t, vertex));
    }
    if (b.mean_deviation >= 0.0 && d.mean() > b.mean_deviation) {
        // the faces of the largest summed deviation first, until they hold twice the excess
        std::vector<index_t> order(n_f);
        std::iota(order.begin(), order.end(), index_t{0});
        std::stable_sort(order.begin(), order.end(),
                         [&](index_t x, index_t y) { return d.face_sum[x] > d.face_sum[y]; });
        const double excess = (d.mean() - b.mean_deviation) * static_cast<double>(d.covered);
        double held = 0.0;
        for (const index_t t : order) {
            if (held >= 2.0 * excess || d.face_sum[t] <= 0.0) break;
            if (d.worst[t] > 0.0) {
                add(d.pick[t]);
                held += d.face_sum[t];
            }
        }
    }
    return out;
}

}  // namespace rangemesh::refine
