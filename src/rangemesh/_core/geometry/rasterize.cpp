#include "rasterize.hpp"

#include <algorithm>
#include <cmath>

#include "../interrupt.hpp"
#include "predicates.hpp"
#include "raster.hpp"

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
            raster_row<false>(line, k, s.first, s.last, w0, w1, w2, d0, d1, d2);
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

}  // namespace

void rasterize(FaceValues faces, RenderTarget out) { raster_all(faces, out.value, out.face); }

void rasterize(FaceValues faces, ValueTarget out) { raster_all(faces, out.value, out.claimed); }

}  // namespace rangemesh
