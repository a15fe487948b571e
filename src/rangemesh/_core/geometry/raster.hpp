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

// Quotient `q` and remainder `m` (0 <= m < d) of a / d moved to those of (a + dq d + dm) / d, for
// 0 <= dm < d. The carry without a branch: it follows the slope's pattern, which mispredicted.
inline void add_steps(index_t& q, index_t& m, index_t dq, index_t dm, index_t d) {
    q += dq;
    m += dm;
    const index_t carry = static_cast<index_t>(m >= d);
    m -= carry * d;
    q += carry;
}

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
        add_steps(q, m, dq, dm, d);
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

// The same spans by another walk, for loops that visit a triangle's rows once: each row is
// bounded by one edge on the left (an edge running down the rows, s > 0) and one on the right
// (running up, s < 0), both at the row of the corner where two edges of a side meet, and an
// edge along a row only on its own row. A triangle is convex, so the edges TriangleRows also
// clips by bound no row more tightly, and the spans are the same; each row costs two edge steps
// instead of three steps and three clips. Only for a counter-clockwise triangle of area > 0
// (each side then has an edge, and every span lies within the bounding box).
class TriangleSpans {
  public:
    TriangleSpans(index_t ar, index_t ac, index_t br, index_t bc, index_t cr, index_t cc, bool own_ab, bool own_bc,
                  bool own_ca)
        : r0_(std::min(ar, std::min(br, cr))),
          r1_(std::max(ar, std::max(br, cr))),
          c0_(std::min(ac, std::min(bc, cc))) {
        add(ar, ac, br, bc, own_ab);
        add(br, bc, cr, cc, own_bc);
        add(cr, cc, ar, ac, own_ca);
        left_.order();
        right_.order();
    }

    index_t top() const { return r0_; }
    index_t bottom() const { return r1_; }

    // Calls row(r, first, last) for every row whose span is not empty, top to bottom, with the
    // columns TriangleRows::columns gives; row(...) returning false ends the walk.
    template <class Row>
    void walk(Row&& row) {
        Walk l = left_.edge[0], rt = right_.edge[0];
        index_t lk = left_.keep[0], rk = right_.keep[0];
        // at most one row is special: a side's turn (only one side has two edges, and none has
        // with an edge along a row), or the row of an edge along it that owns none of its pixels
        const index_t turn = left_.turn >= 0 ? left_.turn : right_.turn;
        const index_t special = turn >= 0 ? turn : (flat_own_ ? -1 : flat_row_);
        for (index_t r = r0_; r <= r1_; ++r) {
            index_t lo = c0_ - l.q + (static_cast<index_t>(l.m == 0) & lk);
            index_t hi = c0_ + rt.q - (static_cast<index_t>(rt.m == 0) & rk);
            if (r == special) {
                if (r == left_.turn) {  // the second left edge takes over from this row on
                    l = left_.edge[1];
                    lk = left_.keep[1];
                    lo = std::max(lo, c0_ - l.q + (static_cast<index_t>(l.m == 0) & lk));
                } else if (r == right_.turn) {
                    rt = right_.edge[1];
                    rk = right_.keep[1];
                    hi = std::min(hi, c0_ + rt.q - (static_cast<index_t>(rt.m == 0) & rk));
                } else {
                    lo = hi + 1;  // (the row along an edge that does not own its pixels)
                }
            }
            l.step();
            rt.step();
            if (lo > hi) continue;
            if (!row(r, lo, hi)) return;
        }
    }

  private:
    // Quotient and remainder of one edge, as EdgeWalk keeps them, and their steps a row.
    struct Walk {
        index_t q, m, dq, dm, d;

        void step() { add_steps(q, m, dq, dm, d); }
    };

    // One side's edges (one or two), the upper first; `turn` the row where the second starts.
    struct Side {
        Walk edge[2];
        index_t keep[2] = {0, 0};  // 1: the edge's own pixels left out
        index_t top[2] = {0, 0};
        index_t turn = -1;
        int n = 0;

        void order() {
            if (n < 2) return;
            if (top[1] < top[0]) {
                std::swap(edge[0], edge[1]);
                std::swap(keep[0], keep[1]);
                std::swap(top[0], top[1]);
            }
            turn = top[1];
        }
    };

    // Edge P -> Q started at its upper row: w(r, c) = orient(P, Q, (r, c)), w >= 0 inside.
    void add(index_t pr, index_t pc, index_t qr, index_t qc, bool own) {
        const index_t s = qr - pr;
        if (s == 0) {  // along a row: that row's pixels are all in (owned) or all out
            flat_row_ = pr;
            flat_own_ = own;
            return;
        }
        Side& side = s > 0 ? left_ : right_;
        const index_t top = std::min(pr, qr);
        // on its upper row the edge passes through its upper corner: w = s (c - that corner's
        // column) there, so q is a whole number (m = 0) and only the step needs a division
        Walk& w = side.edge[side.n];
        w.d = s > 0 ? s : -s;
        w.q = s > 0 ? c0_ - pc : qc - c0_;
        w.m = 0;
        EdgeWalk::floor_divmod(pc - qc, w.d, w.dq, w.dm);
        side.keep[side.n] = own ? 0 : 1;
        side.top[side.n] = top;
        ++side.n;
    }

    index_t r0_, r1_, c0_;
    Side left_, right_;
    index_t flat_row_ = -1;
    bool flat_own_ = true;
};

}  // namespace rangemesh
