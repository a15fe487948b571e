// Orientation and in-circle determinants in the image plane (row, column).
//
// Integer coordinates make both exact in int64 while no two points lie more than EXACT_SPAN
// apart along an axis;
// the floating-point forms are the same expressions, evaluated in the order written (no
// contraction), so they round exactly as the Python references do.
#pragma once

#include <algorithm>
#include <cstdint>

#include "../views.hpp"

namespace rangemesh {

// With coordinate differences of at most D, |incircle| <= 12 D^4, below 2^63 for D <= 29,609:
// the largest span along an axis (pixels, times the Delaunay scales) the predicates take.
constexpr index_t EXACT_SPAN = 29'000;

// Whether coordinates from lo to hi along an axis stay within EXACT_SPAN of each other. The
// difference is taken unsigned: hi - lo of far coordinates (INT64_MIN) overflows int64.
inline bool exact_span(index_t lo, index_t hi) {
    return hi <= lo || static_cast<std::uint64_t>(hi) - static_cast<std::uint64_t>(lo) <= EXACT_SPAN;
}

// The largest coordinate magnitude the Delaunay sweep takes: it orders points by float64
// distances, which stay exact to well below a pixel this close to the origin.
constexpr index_t EXACT_COORDINATE = index_t{1} << 31;

// Twice the signed area of (a, b, c); > 0 when counter-clockwise in (row, column).
template <class T>
inline T orient(T ra, T ca, T rb, T cb, T rc, T cc) {
    return (rb - ra) * (cc - ca) - (cb - ca) * (rc - ra);
}

// > 0 when d lies strictly inside the circle through the counter-clockwise a, b, c.
template <class T>
inline T incircle(T ar, T ac, T br, T bc, T cr, T cc, T dr, T dc) {
    const T adr = ar - dr, adc = ac - dc;
    const T bdr = br - dr, bdc = bc - dc;
    const T cdr = cr - dr, cdc = cc - dc;
    const T ad = adr * adr + adc * adc;
    const T bd = bdr * bdr + bdc * bdc;
    const T cd = cdr * cdr + cdc * cdc;
    return adr * (bdc * cd - bd * cdc) - adc * (bdr * cd - bd * cdr) + ad * (bdr * cdc - bdc * cdr);
}

// Python's floor division and modulo for a positive divisor (C++ truncates toward zero).
inline long long floor_div(long long a, long long d) {
    long long q = a / d;
    return (a % d != 0 && a < 0) ? q - 1 : q;
}

inline long long floor_mod(long long a, long long d) { return a - floor_div(a, d) * d; }

// Integer points by id, as the Delaunay triangulation sees them.
//
// Pixel grids are full of co-circular points, so "the" Delaunay triangulation is not unique.
// Simulation of Simplicity makes it unique: the lifted heights r^2 + c^2 get infinitesimal
// perturbations eps^i, the smallest id the largest. The triangulation is then the regular
// triangulation of the perturbed lifting, which exists, is unique, and is a Delaunay
// triangulation of the unperturbed points. Exact in int64 within EXACT_SPAN (`checked_span`).
struct PointSet {
    Span<const index_t> r, c;

    index_t size() const { return r.size; }

    // Raises ValueError (check_input: a raw call's points) unless the points lie within
    // EXACT_SPAN along each axis (and within EXACT_COORDINATE of the origin).
    void check_span() const {
        if (size() == 0) return;
        const auto [r0, r1] = std::minmax_element(r.begin(), r.end());
        const auto [c0, c1] = std::minmax_element(c.begin(), c.end());
        check_input(exact_span(*r0, *r1) && exact_span(*c0, *c1) && -EXACT_COORDINATE <= std::min(*r0, *c0) &&
                        std::max(*r1, *c1) <= EXACT_COORDINATE,
                    "Delaunay: points span more than EXACT_SPAN (or lie beyond 2^31), where the int64 predicates "
                    "overflow");
    }

    // Twice the signed area of points a, b, c; > 0 counter-clockwise.
    index_t orient(index_t a, index_t b, index_t p) const {
        return rangemesh::orient<index_t>(r[a], c[a], r[b], c[b], r[p], c[p]);
    }

    // > 0 when point d is strictly inside the circle through counter-clockwise a, b, c.
    index_t incircle(index_t a, index_t b, index_t p, index_t d) const {
        return rangemesh::incircle<index_t>(r[a], c[a], r[b], c[b], r[p], c[p], r[d], c[d]);
    }

    // Whether edge uv of counter-clockwise (u, v, w), with x across it, must be flipped: x
    // inside the circle, or on it and inside under the perturbation. With perturbations eps^i
    // x is inside iff the barycentric weight of the dominant (smallest) id among u, v, w is
    // positive, and never when x itself dominates. Three distinct points of a circle are never
    // collinear, so the orientations below are never 0.
    bool illegal(index_t u, index_t v, index_t w, index_t x) const {
        const index_t det = incircle(u, v, w, x);
        if (det != 0) return det > 0;
        const index_t m = std::min(std::min(u, v), std::min(w, x));
        if (m == x) return false;
        if (m == u) return orient(x, v, w) > 0;
        if (m == v) return orient(u, x, w) > 0;
        return orient(u, v, x) > 0;
    }
};

}  // namespace rangemesh
