#include "rasterize.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <type_traits>

#include "../interrupt.hpp"
#include "predicates.hpp"
#include "raster.hpp"

#include "../simd.hpp"

namespace rangemesh {

namespace {

// Triangles whose box holds more pixels than this are walked over their row spans when their
// corners are pixel centres: below it the walk's set-up costs more than the box's empty half.
constexpr index_t span_min_box = 64;

// One triangle: its index, corners, corner values, and the sign that makes its weights
// positive inside.
struct Triangle {
    index_t t;
    double r[3], c[3], f[3];
    double sign;
};

// Whether x is a pixel centre's coordinate on an axis of n pixels: whole and in [0, n - 1].
bool on_pixel(double x, index_t n) { return 0.0 <= x && x <= static_cast<double>(n - 1) && x == std::floor(x); }

// The first pixel index >= x on an axis of n pixels; n when there is none. (Only pixels of the
// image matter, and the bounds keep a far-off corner from overflowing the conversion.)
index_t first_from(double x, index_t n) {
    if (x <= 0.0) return 0;
    if (x > static_cast<double>(n - 1)) return n;
    return static_cast<index_t>(std::ceil(x));
}

// The last pixel index <= x on an axis of n pixels; -1 when there is none.
index_t last_to(double x, index_t n) {
    if (x < 0.0) return -1;
    if (x >= static_cast<double>(n - 1)) return n - 1;
    return static_cast<index_t>(std::floor(x));
}

// One row of the render: values, and which pixels a triangle has claimed (`Claims`).
template <class Claim>
struct RenderRow {
    double* value;
    Claim* claim;
};

// A render's claims: face ids (-1 free) or a mask (0 free, 1 claimed), for callers that need no ids.
template <class Claim>
struct Claims;
template <>
struct Claims<index_t> {
    static constexpr index_t free = -1;
    static index_t mark(index_t t) { return t; }
};
template <>
struct Claims<unsigned char> {
    static constexpr unsigned char free = 0;
    static unsigned char mark(index_t) { return 1; }
};

// Write column c from the weights w0, w1, w2 of corners 0, 1, 2, unless a triangle did. A
// corner's own pixel takes its value as it is: (s * f) / s rounds away from f for some s, and a
// mesh with every pixel a vertex must render exactly. Two weights are 0 only at a corner, so
// rows without one (`corners` false) skip those tests.
template <bool corners, class Claim>
void put(RenderRow<Claim> out, index_t c, const Triangle& k, double w0, double w1, double w2) {
    if (out.claim[c] != Claims<Claim>::free) return;
    if (corners && w1 == 0.0 && w2 == 0.0)
        out.value[c] = k.f[0];
    else if (corners && w0 == 0.0 && w2 == 0.0)
        out.value[c] = k.f[1];
    else if (corners && w0 == 0.0 && w1 == 0.0)
        out.value[c] = k.f[2];
    else
        out.value[c] = (w0 * k.f[0] + w1 * k.f[1] + w2 * k.f[2]) / (w0 + w1 + w2);
    out.claim[c] = Claims<Claim>::mark(k.t);
}

// The box loop: every pixel centre of [rmin, rmax] x [cmin, cmax] tested by its three weights.
template <class Claim>
void raster_box(const Triangle k, index_t rmin, index_t rmax, index_t cmin, index_t cmax, Grid<double> value,
                Grid<Claim> claim) {
    for (index_t r = rmin; r <= rmax; ++r) {
        const RenderRow<Claim> row{value.row(r), claim.row(r)};
        const double x = static_cast<double>(r);
        for (index_t c = cmin; c <= cmax; ++c) {
            if (row.claim[c] != Claims<Claim>::free) continue;
            const double y = static_cast<double>(c);
            const double w0 = k.sign * orient(k.r[1], k.c[1], k.r[2], k.c[2], x, y);
            const double w1 = k.sign * orient(k.r[2], k.c[2], k.r[0], k.c[0], x, y);
            const double w2 = k.sign * orient(k.r[0], k.c[0], k.r[1], k.c[1], x, y);
            if (w0 < 0 || w1 < 0 || w2 < 0) continue;
            put<true>(row, c, k, w0, w1, w2);
        }
    }
}

// One row of the span walk: columns s.first..s.last from weights w0, w1, w2 growing by d0, d1, d2.
template <bool corners, class Claim>
void raster_row(RenderRow<Claim> line, const Triangle& k, index_t first, index_t last, double w0, double w1, double w2,
                double d0, double d1, double d2) {
    for (index_t col = first; col <= last; ++col) {
        put<corners>(line, col, k, w0, w1, w2);
        w0 += d0;
        w1 += d1;
        w2 += d2;
    }
}

#if RANGEMESH_AVX
// `raster_row<false>` into a claims mask, four columns at once: each lane the IEEE operations of
// `put` (the weights w + j d and w + 4 d are whole numbers, exact), four free pixels written at
// once, any other group a pixel at a time; the last 0 to 3 columns by `put`.
__attribute__((target("avx"))) void raster_row_avx(RenderRow<unsigned char> line, const Triangle& k, index_t first,
                                                   index_t last, double w0, double w1, double w2, double d0, double d1,
                                                   double d2) {
    const __m256d lane = _mm256_set_pd(3.0, 2.0, 1.0, 0.0);
    __m256d v0 = _mm256_add_pd(_mm256_set1_pd(w0), _mm256_mul_pd(lane, _mm256_set1_pd(d0)));
    __m256d v1 = _mm256_add_pd(_mm256_set1_pd(w1), _mm256_mul_pd(lane, _mm256_set1_pd(d1)));
    __m256d v2 = _mm256_add_pd(_mm256_set1_pd(w2), _mm256_mul_pd(lane, _mm256_set1_pd(d2)));
    const __m256d g0 = _mm256_set1_pd(4.0 * d0), g1 = _mm256_set1_pd(4.0 * d1), g2 = _mm256_set1_pd(4.0 * d2);
    const __m256d f0 = _mm256_set1_pd(k.f[0]), f1 = _mm256_set1_pd(k.f[1]), f2 = _mm256_set1_pd(k.f[2]);
    index_t col = first;
    for (; col + 3 <= last; col += 4) {
        const __m256d num =
            _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(v0, f0), _mm256_mul_pd(v1, f1)), _mm256_mul_pd(v2, f2));
        const __m256d value = _mm256_div_pd(num, _mm256_add_pd(_mm256_add_pd(v0, v1), v2));
        v0 = _mm256_add_pd(v0, g0);
        v1 = _mm256_add_pd(v1, g1);
        v2 = _mm256_add_pd(v2, g2);
        std::uint32_t claims;
        std::memcpy(&claims, line.claim + col, sizeof claims);
        if (claims == 0) {  // (claims are 0 or 1)
            _mm256_storeu_pd(line.value + col, value);
            const std::uint32_t mine = 0x01010101u;
            std::memcpy(line.claim + col, &mine, sizeof mine);
            continue;
        }
        alignas(32) double v[4];
        _mm256_store_pd(v, value);
        for (index_t j = 0; j < 4; ++j)
            if (line.claim[col + j] == Claims<unsigned char>::free) {
                line.value[col + j] = v[j];
                line.claim[col + j] = Claims<unsigned char>::mark(k.t);
            }
    }
    if (col <= last)
        raster_row<false>(line, k, col, last, _mm_cvtsd_f64(_mm256_castpd256_pd128(v0)),
                          _mm_cvtsd_f64(_mm256_castpd256_pd128(v1)), _mm_cvtsd_f64(_mm256_castpd256_pd128(v2)), d0, d1,
                          d2);
}
#endif

// A row without a corner: `raster_row<false>`, four columns at once into a claims mask where AVX runs.
template <class Claim>
void raster_inner_row(RenderRow<Claim> line, const Triangle& k, index_t first, index_t last, double w0, double w1,
                      double w2, double d0, double d1, double d2) {
#if RANGEMESH_AVX
    if constexpr (std::is_same_v<Claim, unsigned char>) {
        if (last - first >= 3 && has_avx()) {
            raster_row_avx(line, k, first, last, w0, w1, w2, d0, d1, d2);
            return;
        }
    }
#endif
    raster_row<false>(line, k, first, last, w0, w1, w2, d0, d1, d2);
}

// The row-span walk of a triangle with pixel-centre corners. The weights are the box loop's
// (w0 of corner 0, ...), read from the walk's integer edge functions: the same floats.
template <class Claim>
void raster_spans(const Triangle k, Grid<double> value, Grid<Claim> claim) {
    index_t r[3], c[3];
    for (int i = 0; i < 3; ++i) {
        r[i] = static_cast<index_t>(k.r[i]);
        c[i] = static_cast<index_t>(k.c[i]);
    }
    // Walked counter-clockwise: as 0, 1, 2 (edges 0->1, 1->2, 2->0 weigh corners 2, 0, 1) or
    // as 0, 2, 1 (edges 0->2, 2->1, 1->0 weigh corners 1, 0, 2). w0, w1, w2 are the weights of
    // corners 0, 1, 2 and d0, d1, d2 their growth a column.
    const bool ccw = k.sign > 0;
    TriangleRows rows =
        ccw ? TriangleRows(r[0], c[0], r[1], c[1], r[2], c[2]) : TriangleRows(r[0], c[0], r[2], c[2], r[1], c[1]);
    const double d0 = static_cast<double>(ccw ? r[2] - r[1] : r[1] - r[2]);
    const double d1 = static_cast<double>(ccw ? r[0] - r[2] : r[2] - r[0]);
    const double d2 = static_cast<double>(ccw ? r[1] - r[0] : r[0] - r[1]);
    for (index_t row = rows.r0; row <= rows.r1; ++row) {
        if (row > rows.r0) rows.next_row();
        const RowSpan s = rows.columns(true, true, true);
        const RenderRow<Claim> line{value.row(row), claim.row(row)};
        // integers, exact in float64: the values the box loop computes
        const double w0 = static_cast<double>(s.w1);
        const double w1 = static_cast<double>(ccw ? s.w2 : s.w0);
        const double w2 = static_cast<double>(ccw ? s.w0 : s.w2);
        if (row == r[0] || row == r[1] || row == r[2])
            raster_row<true>(line, k, s.first, s.last, w0, w1, w2, d0, d1, d2);
        else
            raster_inner_row(line, k, s.first, s.last, w0, w1, w2, d0, d1, d2);
    }
}

template <class Claim>
void raster_all(FaceValues faces, Grid<double> value, Grid<Claim> claim) {
    const index_t height = value.rows, width = value.cols;
    require(claim.rows == height && claim.cols == width, "rasterize: render buffers differ in shape");
    require(faces.c.rows == faces.r.rows && faces.value.rows == faces.r.rows, "rasterize: face arrays differ");
    for (index_t t = 0; t < faces.r.rows; ++t) {
        poll_interrupt();
        Triangle k{t,
                   {faces.r(t, 0), faces.r(t, 1), faces.r(t, 2)},
                   {faces.c(t, 0), faces.c(t, 1), faces.c(t, 2)},
                   {faces.value(t, 0), faces.value(t, 1), faces.value(t, 2)},
                   0.0};
        const double area = orient(k.r[0], k.c[0], k.r[1], k.c[1], k.r[2], k.c[2]);
        if (area == 0.0 || !std::isfinite(area)) continue;  // also: every corner is finite
        k.sign = area > 0 ? 1.0 : -1.0;
        // the box's pixels inside the image
        const index_t rmin = first_from(std::min(k.r[0], std::min(k.r[1], k.r[2])), height);
        const index_t rmax = last_to(std::max(k.r[0], std::max(k.r[1], k.r[2])), height);
        const index_t cmin = first_from(std::min(k.c[0], std::min(k.c[1], k.c[2])), width);
        const index_t cmax = last_to(std::max(k.c[0], std::max(k.c[1], k.c[2])), width);
        const bool on_pixels = on_pixel(k.r[0], height) && on_pixel(k.r[1], height) && on_pixel(k.r[2], height) &&
                               on_pixel(k.c[0], width) && on_pixel(k.c[1], width) && on_pixel(k.c[2], width);
        if ((rmax - rmin + 1) * (cmax - cmin + 1) > span_min_box && on_pixels)
            raster_spans(k, value, claim);
        else
            raster_box(k, rmin, rmax, cmin, cmax, value, claim);
    }
}

#if RANGEMESH_AVX
// `claimed_error` one pixel at a time.
template <class Map>
void claimed_row(const double* prow, const unsigned char* crow, const double* drow, const bool* vrow, index_t c,
                 index_t end, Map&& map, CoveredError& out) {
    for (; c < end; ++c) {
        if (!vrow[c] || !crow[c]) continue;
        const double p = map(prow[c]);
        if (std::isfinite(p)) {
            out.total += std::abs(p - drow[c]);
            ++out.count;
        }
    }
}

// `claimed_error`'s rows, four pixels at once: map(pred) and |map(pred) - depth| lane by lane
// (the scalar loop's IEEE operations), 0 where a pixel is not counted (invalid, unclaimed, not
// finite: the sum starts at +0 and only grows, so adding +0 changes nothing), the four added in
// column order. With `range`, the valid depths' bounds in four lanes as `valid_range` keeps them
// (the same values whatever the order; a zero bound, whose sign the order decides, is found
// again by `valid_range`).
template <DepthMap::Kind kind>
__attribute__((target("avx"))) void claimed_error_avx(Grid<const double> pred, Grid<const unsigned char> claimed,
                                                      Grid<const double> depth, Grid<const bool> valid, double scale,
                                                      CoveredError& out, DepthRange* range) {
    const __m256d magnitude = _mm256_castsi256_pd(_mm256_set1_epi64x(0x7fffffffffffffff));
    const __m256d inf = _mm256_set1_pd(INFINITY), one = _mm256_set1_pd(1.0), by = _mm256_set1_pd(scale);
    constexpr unsigned char COUNT[16] = {0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4};
    double total = out.total;
    index_t count = out.count, n_valid = 0;
    const __m256d minus_inf = _mm256_set1_pd(-INFINITY);
    __m256d lo = inf, hi = minus_inf;
    double lo_rest = INFINITY, hi_rest = -INFINITY;
    for (index_t r = 0; r < depth.rows; ++r) {
        poll_interrupt();
        const double* prow = pred.row(r);
        const unsigned char* crow = claimed.row(r);
        const double* drow = depth.row(r);
        const bool* vrow = valid.row(r);
        index_t c = 0;
        for (; c + 4 <= depth.cols; c += 4) {
            std::uint32_t v4, c4;
            std::memcpy(&v4, vrow + c, sizeof v4);
            std::memcpy(&c4, crow + c, sizeof c4);
            if (range != nullptr) {  // (bytes 0 or 1: gathered into bits 0..3 by one product)
                const unsigned bits = ((v4 * 0x01020408u) >> 24) & 15u;  // (& 15: a table row even for bool bytes > 1)
                const __m256d ok = _mm256_load_pd(reinterpret_cast<const double*>(LANE_MASKS[bits]));
                const __m256d x = _mm256_loadu_pd(drow + c);
                const __m256d in = _mm256_and_pd(ok, x);  // x, or +0 where not valid
                lo = _mm256_min_pd(_mm256_or_pd(in, _mm256_andnot_pd(ok, inf)), lo);  // (below < lo ? below : lo)
                hi = _mm256_max_pd(_mm256_or_pd(in, _mm256_andnot_pd(ok, minus_inf)), hi);
                n_valid += COUNT[bits];
            }
            const std::uint32_t both = v4 & c4;
            if (both == 0) continue;
            __m256d p = _mm256_loadu_pd(prow + c);
            if (kind != DepthMap::same) p = _mm256_div_pd(one, p);
            if (kind == DepthMap::inverse_scaled) p = _mm256_div_pd(p, by);
            const __m256d finite = _mm256_cmp_pd(_mm256_and_pd(p, magnitude), inf, _CMP_LT_OQ);
            const __m256d counted = _mm256_and_pd(
                finite,
                _mm256_load_pd(reinterpret_cast<const double*>(LANE_MASKS[((both * 0x01020408u) >> 24) & 15u])));
            const __m256d err =
                _mm256_and_pd(_mm256_and_pd(_mm256_sub_pd(p, _mm256_loadu_pd(drow + c)), magnitude), counted);
            const __m128d lo = _mm256_castpd256_pd128(err), hi = _mm256_extractf128_pd(err, 1);
            total += _mm_cvtsd_f64(lo);
            total += _mm_cvtsd_f64(_mm_unpackhi_pd(lo, lo));
            total += _mm_cvtsd_f64(hi);
            total += _mm_cvtsd_f64(_mm_unpackhi_pd(hi, hi));
            count += COUNT[_mm256_movemask_pd(counted)];
        }
        if (range != nullptr)
            for (index_t k = c; k < depth.cols; ++k) {
                if (!vrow[k]) continue;
                ++n_valid;
                lo_rest = drow[k] < lo_rest ? drow[k] : lo_rest;
                hi_rest = drow[k] > hi_rest ? drow[k] : hi_rest;
            }
        CoveredError rest{total, count};
        if (kind == DepthMap::same)
            claimed_row(prow, crow, drow, vrow, c, depth.cols, [](double x) { return x; }, rest);
        else if (kind == DepthMap::inverse)
            claimed_row(prow, crow, drow, vrow, c, depth.cols, [](double x) { return 1.0 / x; }, rest);
        else
            claimed_row(prow, crow, drow, vrow, c, depth.cols, [scale](double x) { return 1.0 / x / scale; }, rest);
        total = rest.total;
        count = rest.count;
    }
    out.total = total;
    out.count = count;
    if (range == nullptr) return;
    *range = DepthRange{};
    if (n_valid == 0) return;
    alignas(32) double l[4], h[4];
    _mm256_store_pd(l, lo);
    _mm256_store_pd(h, hi);
    double low = lo_rest, high = hi_rest;
    for (int k = 0; k < 4; ++k) {
        if (l[k] < low) low = l[k];
        if (h[k] > high) high = h[k];
    }
    if (low == 0.0 || high == 0.0) {
        *range = valid_range(depth, valid);
        return;
    }
    *range = DepthRange{low, high, n_valid};
}
#endif

}  // namespace

CoveredError claimed_error(Grid<const double> pred, Grid<const unsigned char> claimed, Grid<const double> depth,
                           Grid<const bool> valid, DepthMap map, DepthRange* range) {
    require(pred.rows == depth.rows && pred.cols == depth.cols && claimed.rows == depth.rows &&
                claimed.cols == depth.cols && valid.rows == depth.rows && valid.cols == depth.cols,
            "claimed_error: the render, its claims, the depth and the mask differ in shape");
    CoveredError out;
#if RANGEMESH_AVX
    if (has_avx()) {
        if (map.kind == DepthMap::same)
            claimed_error_avx<DepthMap::same>(pred, claimed, depth, valid, map.scale, out, range);
        else if (map.kind == DepthMap::inverse)
            claimed_error_avx<DepthMap::inverse>(pred, claimed, depth, valid, map.scale, out, range);
        else
            claimed_error_avx<DepthMap::inverse_scaled>(pred, claimed, depth, valid, map.scale, out, range);
        return out;
    }
#endif
    const double scale = map.scale;
    if (map.kind == DepthMap::same)
        return covered_error(pred, claimed, depth, valid, [](double p) { return p; }, range);
    if (map.kind == DepthMap::inverse)
        return covered_error(pred, claimed, depth, valid, [](double p) { return 1.0 / p; }, range);
    return covered_error(pred, claimed, depth, valid, [scale](double p) { return 1.0 / p / scale; }, range);
}

void rasterize(FaceValues faces, RenderTarget out) { raster_all(faces, out.value, out.face); }

void rasterize(FaceValues faces, ValueTarget out) { raster_all(faces, out.value, out.claimed); }

}  // namespace rangemesh
