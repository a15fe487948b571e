#include "pixels.hpp"

#include <algorithm>
#include <cstring>

#include "../simd.hpp"

namespace rangemesh {

namespace {

// `valid_range` one pixel after another: its order, which decides the sign of a zero bound.
DepthRange valid_range_in_order(Grid<const double> depth, Grid<const bool> valid) {
    DepthRange out;
    double lo = INFINITY, hi = -INFINITY;
    for (index_t r = 0; r < depth.rows; ++r) {
        poll_interrupt();
        for (index_t c = 0; c < depth.cols; ++c) {
            if (!valid(r, c)) continue;
            const double x = depth(r, c);
            ++out.count;
            if (x < lo) lo = x;
            if (x > hi) hi = x;
        }
    }
    if (out.count > 0) {
        out.lo = lo;
        out.hi = hi;
    }
    return out;
}

#if RANGEMESH_AVX
// `valid_range`'s lanes in AVX: each lane keeps its bound as the scalar lanes do (an invalid
// pixel is +-inf there, which no bound passes; `min_pd(x, lo)` is `x < lo ? x : lo`, so NaN
// is never taken); a zero bound is found again in order by the caller.
__attribute__((target("avx"))) DepthRange valid_range_avx(Grid<const double> depth, Grid<const bool> valid, double& low,
                                                          double& high) {
    const __m256d inf = _mm256_set1_pd(INFINITY), minus_inf = _mm256_set1_pd(-INFINITY);
    __m256d lo = inf, hi = minus_inf;
    double lo_rest = INFINITY, hi_rest = -INFINITY;
    index_t count = 0;
    for (index_t r = 0; r < depth.rows; ++r) {
        poll_interrupt();
        const double* d = depth.row(r);
        const bool* v = valid.row(r);
        index_t c = 0;
        for (; c + 4 <= depth.cols; c += 4) {
            std::uint32_t four;
            std::memcpy(&four, v + c, sizeof four);
            // the valid flags (bytes 0 or 1) gathered into bits 0..3 by one product
            const unsigned bits = ((four * 0x01020408u) >> 24) & 15u;
            const __m256d ok = _mm256_load_pd(reinterpret_cast<const double*>(LANE_MASKS[bits]));
            const __m256d in = _mm256_and_pd(ok, _mm256_loadu_pd(d + c));  // x, or +0 where not valid
            lo = _mm256_min_pd(_mm256_or_pd(in, _mm256_andnot_pd(ok, inf)), lo);
            hi = _mm256_max_pd(_mm256_or_pd(in, _mm256_andnot_pd(ok, minus_inf)), hi);
            count += __builtin_popcount(bits);
        }
        for (; c < depth.cols; ++c) {
            if (!v[c]) continue;
            ++count;
            lo_rest = d[c] < lo_rest ? d[c] : lo_rest;
            hi_rest = d[c] > hi_rest ? d[c] : hi_rest;
        }
    }
    alignas(32) double l[4], h[4];
    _mm256_store_pd(l, lo);
    _mm256_store_pd(h, hi);
    low = lo_rest;
    high = hi_rest;
    for (int k = 0; k < 4; ++k) {
        if (l[k] < low) low = l[k];
        if (h[k] > high) high = h[k];
    }
    DepthRange out;
    out.count = count;
    return out;
}
#endif

}  // namespace

DepthRange valid_range(Grid<const double> depth, Grid<const bool> valid) {
#if RANGEMESH_AVX
    if (has_avx()) {
        double l = 0.0, h = 0.0;
        DepthRange out = valid_range_avx(depth, valid, l, h);
        if (out.count == 0) return DepthRange{};
        if (l == 0.0 || h == 0.0) return valid_range_in_order(depth, valid);
        out.lo = l;
        out.hi = h;
        return out;
    }
#endif
    // Four lanes with no branch: the one chain of compares and a branch mispredicted on scattered
    // holes took 3x mask_image's time (0.36 ms on a 640 x 480 frame). The bounds are the same
    // values whatever the order (NaN is never below or above, a hole is +-inf, which no bound
    // passes); only a zero's sign depends on it, so a zero bound is found again in order.
    constexpr int LANES = 4;
    double lo[LANES], hi[LANES];
    std::fill(lo, lo + LANES, INFINITY);
    std::fill(hi, hi + LANES, -INFINITY);
    index_t count = 0;
    const auto take = [&](int k, bool ok, double x) {
        count += ok ? 1 : 0;
        const double below = ok ? x : INFINITY, above = ok ? x : -INFINITY;
        lo[k] = below < lo[k] ? below : lo[k];
        hi[k] = above > hi[k] ? above : hi[k];
    };
    for (index_t r = 0; r < depth.rows; ++r) {
        poll_interrupt();
        const double* d = depth.row(r);
        const bool* v = valid.row(r);
        index_t c = 0;
        for (; c + LANES <= depth.cols; c += LANES)
            for (int k = 0; k < LANES; ++k) take(k, v[c + k], d[c + k]);
        for (; c < depth.cols; ++c) take(0, v[c], d[c]);
    }
    DepthRange out;
    if (count == 0) return out;
    double l = lo[0], h = hi[0];
    for (int k = 1; k < LANES; ++k) {
        if (lo[k] < l) l = lo[k];
        if (hi[k] > h) h = hi[k];
    }
    if (l == 0.0 || h == 0.0) return valid_range_in_order(depth, valid);
    out.count = count;
    out.lo = l;
    out.hi = h;
    return out;
}

CoveredError covered_error(Grid<const double> pred, Grid<const double> depth, Grid<const bool> valid) {
    CoveredError out;
    for (index_t r = 0; r < depth.rows; ++r) {
        poll_interrupt();
        for (index_t c = 0; c < depth.cols; ++c) {
            if (!valid(r, c)) continue;
            const double p = pred(r, c);
            if (std::isfinite(p)) {
                out.total += std::abs(p - depth(r, c));
                ++out.count;
            }
        }
    }
    return out;
}

ValidFaces valid_faces(Span<const index_t> vr, Span<const index_t> vc, Span<const index_t> tv, Grid<const bool> valid) {
    const index_t n_t = tv.size / 3, n_v = vr.size;
    require(vc.size == n_v, "valid_faces: vr and vc differ in length");
    std::vector<unsigned char> on_valid, keep, used;
    fill_polled(on_valid, n_v, static_cast<unsigned char>(0));
    fill_polled(keep, n_t, static_cast<unsigned char>(0));
    fill_polled(used, n_v, static_cast<unsigned char>(0));
    for (index_t v = 0; v < n_v; ++v) {
        poll_every(v);
        require(vr[v] >= 0 && vr[v] < valid.rows && vc[v] >= 0 && vc[v] < valid.cols,
                "valid_faces: a vertex outside the image");
        on_valid[v] = valid(vr[v], vc[v]);
    }
    index_t n_keep = 0;
    for (index_t t = 0; t < n_t; ++t) {
        poll_every(t);
        const index_t a = tv[3 * t], b = tv[3 * t + 1], c = tv[3 * t + 2];
        require(a >= 0 && a < n_v && b >= 0 && b < n_v && c >= 0 && c < n_v, "valid_faces: a vertex id out of range");
        if (on_valid[a] && on_valid[b] && on_valid[c]) {
            keep[t] = 1;
            used[a] = used[b] = used[c] = 1;
            ++n_keep;
        }
    }
    // the used vertices keep their order
    std::vector<index_t> new_id;
    fill_polled(new_id, n_v, index_t{-1});
    index_t n_used = 0;
    for (index_t v = 0; v < n_v; ++v) {
        poll_every(v);
        if (used[v]) new_id[v] = n_used++;
    }
    ValidFaces out;
    fill_polled(out.faces, 3 * n_keep, std::int32_t{0});
    fill_polled(out.pixels, 2 * n_used, std::int32_t{0});
    for (index_t t = 0, k = 0; t < n_t; ++t) {
        poll_every(t);
        if (!keep[t]) continue;
        for (int j = 0; j < 3; ++j) out.faces[k++] = static_cast<std::int32_t>(new_id[tv[3 * t + j]]);
    }
    for (index_t v = 0; v < n_v; ++v) {
        poll_every(v);
        if (new_id[v] < 0) continue;
        out.pixels[2 * new_id[v]] = static_cast<std::int32_t>(vr[v]);
        out.pixels[2 * new_id[v] + 1] = static_cast<std::int32_t>(vc[v]);
    }
    return out;
}

Pixel nearest_valid(Grid<const bool> valid, index_t r, index_t c) {
    // Square windows around (r, c), doubling until the nearest pixel found is nearer than
    // anything outside the window can be (its half-width): O(window), not a distance transform.
    // Visited row by row, only a strictly nearer pixel replaces the best: ties keep the first.
    const index_t h = valid.rows, w = valid.cols;
    for (index_t k = 8;; k *= 2) {
        poll_interrupt();
        const index_t r0 = std::max<index_t>(r - k + 1, 0), r1 = std::min(r + k - 1, h - 1);
        const index_t c0 = std::max<index_t>(c - k + 1, 0), c1 = std::min(c + k - 1, w - 1);
        index_t best = -1;
        Pixel found{-1, -1};
        for (index_t i = r0; i <= r1; ++i) {
            for (index_t j = c0; j <= c1; ++j) {
                if (!valid(i, j)) continue;
                const index_t d = (i - r) * (i - r) + (j - c) * (j - c);
                if (best < 0 || d < best) {
                    best = d;
                    found = {i, j};
                }
            }
        }
        const bool whole = r0 == 0 && c0 == 0 && r1 == h - 1 && c1 == w - 1;
        if ((best >= 0 && best < k * k) || whole) return found;
    }
}

namespace {

// The distinct values of lo + int((i + 0.5) * extent / n) for i < n, in order (non-decreasing,
// so equal values are neighbours).
std::vector<index_t> grid_centres(index_t lo, index_t extent, index_t n) {
    std::vector<index_t> out;
    for (index_t i = 0; i < n; ++i) {
        const index_t x = lo + static_cast<index_t>((static_cast<double>(i) + 0.5) * static_cast<double>(extent) /
                                                    static_cast<double>(n));
        if (out.empty() || x != out.back()) out.push_back(x);
    }
    return out;
}

}  // namespace

PixelList grid_pixels(Grid<const bool> valid, index_t n_rows, index_t n_cols, index_t c_lo, index_t c_hi, bool inner) {
    const index_t h = valid.rows;
    if (n_rows < 2 || n_cols < 2) n_rows = n_cols = 0;  // no grid, the corners alone
    // a grid finer than the pixels has every pixel for a centre, as one of exactly the pixels
    // does: the same centres, without a loop over a raw call's 2^62 rows
    n_rows = std::min(n_rows, h);
    n_cols = std::min(n_cols, c_hi - c_lo + 1);
    const std::vector<index_t> rows = grid_centres(0, h, n_rows);
    const std::vector<index_t> cols = grid_centres(c_lo, c_hi - c_lo + 1, n_cols);
    PixelList out;
    out.rows = {0, h - 1, h - 1, 0};
    out.cols = {c_lo, c_lo, c_hi, c_hi};
    for (const index_t r : rows) {
        for (const index_t c : cols) {
            if (!valid(r, c)) continue;
            const bool side = c == c_lo || c == c_hi;
            if ((r == 0 || r == h - 1) && side) continue;  // a corner, in already
            if (inner && side) continue;
            out.rows.push_back(r);
            out.cols.push_back(c);
        }
    }
    return out;
}

}  // namespace rangemesh
