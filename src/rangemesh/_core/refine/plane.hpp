// The one loop that measures a triangle against its pixels: |depth - plane| for every valid
// pixel the triangle owns. Greedy insertion keys triangles with it (`scan_triangle`) and the
// flips compare diagonals with it (`triangle_error`); both must give the same sums, so they
// share this arithmetic and this order.
#pragma once

#include <cmath>

#include "../geometry/ownership.hpp"
#include "../geometry/predicates.hpp"
#include "../geometry/raster.hpp"
#include "image.hpp"

namespace rangemesh::refine {

// A corner of a triangle whose plane is measured: pixel and depth.
struct Point {
    index_t r, c;
    double z;
};

// A triangle's plane, the one arithmetic every compared sum uses: its corners' depths, 1 / area,
// and the edge functions w = s col - t r + k (for edge P -> Q, s = qr - pr, t = qc - pc), which
// grow by f = s a column. The plane's depth at a pixel is (w1 zA + w2 zB + w0 zC) / area, the w
// as float64 (integers, held exactly).
struct PlaneRows {
    double az, bz, cz, inv;
    index_t s0, t0, k0, s1, t1, k1, s2, t2, k2;
    double f0, f1, f2;

    template <class P>
    PlaneRows(const P& a, const P& b, const P& c) : PlaneRows(a, b, c, orient(a.r, a.c, b.r, b.c, c.r, c.c)) {}

    // (`area`: orient(A, B, C), when the caller has it)
    template <class P>
    PlaneRows(const P& a, const P& b, const P& c, index_t area)
        : az(a.z),
          bz(b.z),
          cz(c.z),
          inv(1.0 / static_cast<double>(area)),
          s0(b.r - a.r),
          t0(b.c - a.c),
          k0(t0 * a.r - s0 * a.c),
          s1(c.r - b.r),
          t1(c.c - b.c),
          k1(t1 * b.r - s1 * b.c),
          s2(a.r - c.r),
          t2(a.c - c.c),
          k2(t2 * c.r - s2 * c.c),
          f0(static_cast<double>(s0)),
          f1(static_cast<double>(s1)),
          f2(static_cast<double>(s2)) {}

    // The edge functions at (r, col).
    void edges_at(index_t r, index_t col, double& w0, double& w1, double& w2) const {
        w0 = static_cast<double>(s0 * col - t0 * r + k0);
        w1 = static_cast<double>(s1 * col - t1 * r + k1);
        w2 = static_cast<double>(s2 * col - t2 * r + k2);
    }

    // |depth - plane| at a column whose edge functions are w0, w1, w2: the one formula.
    double error(double depth, double w0, double w1, double w2) const {
        return std::abs(depth - (w1 * az + w2 * bz + w0 * cz) * inv);
    }
};

// Calls visit(r, c, err) for each valid pixel of ABC (counter-clockwise, area > 0) that `own`
// gives it, in row-major order, err = |depth - plane through A, B, C|. After each row that had
// pixels, `row_done()` returning false ends the scan.
//
// The plane's depth at a pixel is (w1 zA + w2 zB + w0 zC) / area, its edge functions w as
// float64 (integers, held exactly): the one formula every sum that is compared uses.
template <class Visit, class RowDone>
void plane_errors(const Image& image, const Point& a, const Point& b, const Point& c, EdgeOwnership own, Visit&& visit,
                  RowDone&& row_done) {
    const index_t area = orient(a.r, a.c, b.r, b.c, c.r, c.c);
    const double inv = 1.0 / static_cast<double>(area);
    // in locals: read through the references, the compiler reloads them every pixel
    const double az = a.z, bz = b.z, cz = c.z;
    const double f0 = static_cast<double>(b.r - a.r);
    const double f1 = static_cast<double>(c.r - b.r);
    const double f2 = static_cast<double>(a.r - c.r);
    if (area <= 0) {  // (a raw call's triangle turned the wrong way or flat: the walk that clips by all edges)
        TriangleRows rows(a.r, a.c, b.r, b.c, c.r, c.c);
        owned_rows(rows, own, [&](index_t r, const RowSpan& span) {
            const double* drow = image.depth.row(r);
            const bool* vrow = image.valid.row(r);
            double w0 = static_cast<double>(span.w0), w1 = static_cast<double>(span.w1),
                   w2 = static_cast<double>(span.w2);
            for (index_t col = span.first; col <= span.last; ++col) {
                if (vrow[col]) visit(r, col, std::abs(drow[col] - (w1 * az + w2 * bz + w0 * cz) * inv));
                w0 += f0;
                w1 += f1;
                w2 += f2;
            }
            return row_done();
        });
        return;
    }
    const PlaneRows p(a, b, c, area);
    TriangleSpans spans(a.r, a.c, b.r, b.c, c.r, c.c, own.ab, own.bc, own.ca);
    spans.walk([&](index_t r, index_t first, index_t last) {
        const double* drow = image.depth.row(r);
        const bool* vrow = image.valid.row(r);
        double w0, w1, w2;
        p.edges_at(r, first, w0, w1, w2);
        for (index_t col = first; col <= last; ++col) {
            if (vrow[col]) visit(r, col, std::abs(drow[col] - (w1 * az + w2 * bz + w0 * cz) * inv));
            w0 += f0;
            w1 += f1;
            w2 += f2;
        }
        return row_done();
    });
}

}  // namespace rangemesh::refine
