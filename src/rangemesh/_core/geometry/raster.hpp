// The row scan of a triangle with integer corners: which pixels of each row are its own.
//
// An edge P -> Q has the linear edge function w(r, c) = orient(P, Q, (r, c)): w = v + s (c - c0)
// on a row, and v grows by dv a row. The columns where w >= 0 start at c0 - floor(v / s)
// (s > 0) or end at c0 + floor(v / -s) (s < 0). `EdgeWalk` keeps that quotient and its
// remainder and moves them down a row (or `step` rows) with integer adds: one division per
// edge, none per row.
#pragma once

#include <algorithm>
#include <cstdlib>

#include "../views.hpp"
#include "predicates.hpp"

namespace rangemesh {

struct EdgeWalk {
    index_t s, v, q, m, dv, dq, dm, d;

    static EdgeWalk start(index_t pr, index_t pc, index_t qr, index_t qc, index_t r0, index_t c0, index_t step = 1) {
        EdgeWalk e;
        e.s = qr - pr;
        e.dv = (pc - qc) * step;
        e.v = orient<index_t>(pr, pc, qr, qc, r0, c0);
        e.d = std::max<index_t>(std::llabs(e.s), 1);  // an edge along a row (s == 0) uses v alone
        floor_divmod(e.v, e.d, e.q, e.m);
        floor_divmod(e.dv, e.d, e.dq, e.dm);
        return e;
    }

    // q = floor(a / d) and m = a - q d for d >= 1, exactly. Six a triangle: a float64 quotient,
    // corrected by a step, costs a fraction of an int64 division's latency.
    static void floor_divmod(index_t a, index_t d, index_t& q, index_t& m) {
        constexpr index_t EXACT = index_t{1} << 52;  // |a| below it: the quotient is off by 1 at most
        if (a >= EXACT || a <= -EXACT) {
            q = floor_div(a, d);
            m = a - q * d;
            return;
        }
        q = static_cast<index_t>(static_cast<double>(a) / static_cast<double>(d));  // (truncated)
        m = a - q * d;
        if (m < 0) {
            --q;
            m += d;
        } else if (m >= d) {
            ++q;
            m -= d;
        }
    }

    // One row (or step) down.
    void next() {
        q += dq;
        m += dm;
        // the carry without a branch: it follows the slope's pattern, which mispredicted
        const index_t carry = static_cast<index_t>(m >= d);
        m -= carry * d;
        q += carry;
        v += dv;
    }

    // Narrow [lo, hi] of this row to where w >= 0 (w > 0 when the edge's pixels are not `own`).
    void clip(bool own, index_t c0, index_t& lo, index_t& hi) const {
        // w == 0 on the bounding column exactly when v / s is whole: that pixel is left out
        // unless the edge owns it
        const index_t tie = static_cast<index_t>((m == 0) & !own);
        // selects, not branches: the edges' signs change from one small triangle to the next
        const index_t left = c0 - q + tie, right = c0 + q - tie;
        lo = std::max(lo, s > 0 ? left : lo);
        hi = std::min(hi, s < 0 ? right : hi);
        if (s == 0 && (v < 0 || (v == 0 && !own))) lo = hi + 1;  // along the row: all of it or none
    }

    // The edge function at column `c` of this row.
    index_t at(index_t c, index_t c0) const { return v + s * (c - c0); }
};

// One row's pixels of a triangle: columns first..last (none when first > last), and the edge
// functions orient(A, B, p), orient(B, C, p), orient(C, A, p) at p = (row, first); along the
// row they grow by rB - rA, rC - rB and rA - rC a column.
struct RowSpan {
    index_t first, last;
    index_t w0, w1, w2;
};

// Walks the rows of triangle ABC (counter-clockwise in (row, column)) top to bottom.
struct TriangleRows {
    index_t r0, r1, c0, c1;  // the bounding box
    EdgeWalk ab, bc, ca;

    TriangleRows(index_t ar, index_t ac, index_t br, index_t bc_, index_t cr, index_t cc)
        : TriangleRows(ar, ac, br, bc_, cr, cc, std::min(ar, std::min(br, cr)), 1) {}

    // The rows first, first + step, first + 2 step, ... only: next_row() moves `step` rows down.
    TriangleRows(index_t ar, index_t ac, index_t br, index_t bc_, index_t cr, index_t cc, index_t first, index_t step)
        : r0(std::min(ar, std::min(br, cr))),
          r1(std::max(ar, std::max(br, cr))),
          c0(std::min(ac, std::min(bc_, cc))),
          c1(std::max(ac, std::max(bc_, cc))),
          ab(EdgeWalk::start(ar, ac, br, bc_, first, c0, step)),
          bc(EdgeWalk::start(br, bc_, cr, cc, first, c0, step)),
          ca(EdgeWalk::start(cr, cc, ar, ac, first, c0, step)) {}

    void next_row() {
        ab.next();
        bc.next();
        ca.next();
    }

    // The current row's pixels; an edge whose flag is false leaves its own pixels out, so two
    // triangles that share an edge can split them.
    RowSpan columns(bool own_ab, bool own_bc, bool own_ca) const {
        RowSpan s{c0, c1, 0, 0, 0};
        ab.clip(own_ab, c0, s.first, s.last);
        bc.clip(own_bc, c0, s.first, s.last);
        ca.clip(own_ca, c0, s.first, s.last);
        s.w0 = ab.at(s.first, c0);
        s.w1 = bc.at(s.first, c0);
        s.w2 = ca.at(s.first, c0);
        return s;
    }
};

}  // namespace rangemesh
