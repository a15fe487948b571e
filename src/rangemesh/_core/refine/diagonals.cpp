#include "diagonals.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#include "../geometry/halfedges.hpp"
#include "../geometry/ownership.hpp"
#include "../geometry/predicates.hpp"
#include "../geometry/raster.hpp"
#include "../interrupt.hpp"
#include "../simd.hpp"
#include "keys.hpp"

namespace rangemesh::refine {

namespace {

// Triangles of at most this many bounding-box pixels are summed by `box_error` (on TUM at 10 %,
// 91 % of the flips' triangles have at most 64; 128 measured best, all of them 1 % more).
constexpr index_t BOX_PIXELS = 128;

// The box walk's edge functions of counter-clockwise ABC: w = s col - t r + k for edge P -> Q
// (s = qr - pr, t = qc - pc), as plane_errors has them; a pixel is the triangle's when every
// w > 0, or w == 0 on an edge it owns: x = w - bias >= 0. y: x at the start of the box's first row.
struct BoxEdges {
    index_t s0, t0, s1, t1, s2, t2, bias0, bias1, bias2, r0, r1, c0, c1, y0, y1, y2;
};

BoxEdges box_edges(const Point& a, const Point& b, const Point& c, EdgeOwnership own) {
    BoxEdges e{};
    e.s0 = b.r - a.r, e.t0 = b.c - a.c, e.s1 = c.r - b.r, e.t1 = c.c - b.c, e.s2 = a.r - c.r, e.t2 = a.c - c.c;
    const index_t k0 = e.t0 * a.r - e.s0 * a.c, k1 = e.t1 * b.r - e.s1 * b.c, k2 = e.t2 * c.r - e.s2 * c.c;
    e.bias0 = own.ab ? 0 : 1, e.bias1 = own.bc ? 0 : 1, e.bias2 = own.ca ? 0 : 1;
    e.r0 = std::min(a.r, std::min(b.r, c.r)), e.r1 = std::max(a.r, std::max(b.r, c.r));
    e.c0 = std::min(a.c, std::min(b.c, c.c)), e.c1 = std::max(a.c, std::max(b.c, c.c));
    e.y0 = e.s0 * e.c0 - e.t0 * e.r0 + k0 - e.bias0;
    e.y1 = e.s1 * e.c0 - e.t1 * e.r0 + k1 - e.bias1;
    e.y2 = e.s2 * e.c0 - e.t2 * e.r0 + k2 - e.bias2;
    return e;
}

// Where a box row's pixels start when some x is negative at its left column: a row's pixels are
// one run (the triangle is convex), starting where the last edge whose x is negative there and
// grows to the right (s > 0) reaches 0; one whose x does not grow (s <= 0) leaves the row none.
// Moves col and the x's to the run's first pixel; false when the row has none.
inline bool run_start(index_t s0, index_t s1, index_t s2, index_t c1, index_t& x0, index_t& x1, index_t& x2,
                      index_t& col) {
    if ((x0 < 0 && s0 <= 0) || (x1 < 0 && s1 <= 0) || (x2 < 0 && s2 <= 0)) return false;
    index_t n = 0;
    if (x0 < 0) n = (s0 - 1 - x0) / s0;  // (ceil(-x / s), both positive)
    if (x1 < 0) n = std::max(n, (s1 - 1 - x1) / s1);
    if (x2 < 0) n = std::max(n, (s2 - 1 - x2) / s2);
    col += n;
    x0 += n * s0;
    x1 += n * s1;
    x2 += n * s2;
    return col <= c1 && (x0 | x1 | x2) >= 0;  // (an edge that shrinks to the right ends it first)
}

// `plane_errors`' sum over counter-clockwise ABC (area > 0) by a walk of its bounding box: each
// pixel tested by the three edge functions, exact integers, with no division an edge to set up
// (on a small triangle the setup costs more than its pixels). The same pixels in the same order
// with the same arithmetic (w as float64 of the same integers): the same sum. Left after a row
// once quantize(base + sum) >= stop, as `triangle_error`.
template <bool LongRows>
double box_error(const Image& image, const Point& a, const Point& b, const Point& c, EdgeOwnership own, index_t area,
                 double base, double stop, double cut) {
    const double inv = 1.0 / static_cast<double>(area);
    const double az = a.z, bz = b.z, cz = c.z;
    auto [s0, t0, s1, t1, s2, t2, bias0, bias1, bias2, r0, r1, c0, c1, y0, y1, y2] = box_edges(a, b, c, own);
    double total = 0.0;
    for (index_t r = r0; r <= r1; ++r, y0 -= t0, y1 -= t1, y2 -= t2) {
        index_t x0 = y0, x1 = y1, x2 = y2, col = c0;
        if ((x0 | x1 | x2) < 0 && !run_start(s0, s1, s2, c1, x0, x1, x2, col)) continue;
        const double* drow = image.depth.row(r);
        const bool* vrow = image.valid.row(r);
        if constexpr (LongRows) {
            // ... and ends where the first edge that shrinks to the right (s < 0) would fall
            // below 0; the pixels between in plane_errors' loop (w as float64, the same steps)
            index_t last = c1;
            if (s0 < 0) last = std::min(last, col + x0 / -s0);  // (floor(x / -s), both not negative)
            if (s1 < 0) last = std::min(last, col + x1 / -s1);
            if (s2 < 0) last = std::min(last, col + x2 / -s2);
            double w0 = static_cast<double>(x0 + bias0), w1 = static_cast<double>(x1 + bias1),
                   w2 = static_cast<double>(x2 + bias2);
            const double f0 = static_cast<double>(s0), f1 = static_cast<double>(s1), f2 = static_cast<double>(s2);
            for (; col <= last; ++col) {
                if (vrow[col]) total += std::abs(drow[col] - (w1 * az + w2 * bz + w0 * cz) * inv);
                w0 += f0;
                w1 += f1;
                w2 += f2;
            }
        } else {
            do {
                if (vrow[col]) {
                    const double w0 = static_cast<double>(x0 + bias0), w1 = static_cast<double>(x1 + bias1),
                                 w2 = static_cast<double>(x2 + bias2);
                    total += std::abs(drow[col] - (w1 * az + w2 * bz + w0 * cz) * inv);
                }
                ++col;
                x0 += s0;
                x1 += s1;
                x2 += s2;
            } while (col <= c1 && (x0 | x1 | x2) >= 0);
        }
        if (base + total >= cut && quantize(base + total, image.span) >= stop) break;
    }
    return total;
}

#if RANGEMESH_AVX
// `box_error<true>` four columns at once: each lane the IEEE operations of the scalar loop (the
// edge functions w + j f and w + 4 f are whole numbers below 2^53, exact), a lane counted when
// its three w pass the ownership test (w >= bias, exact in float64) and its pixel is valid, the
// counted errors added to the sum one at a time in row-major order (0 for the others: the sum
// starts at +0 and only grows, so adding +0 changes nothing). A row's first pixel is found as
// `box_error` finds it; its pixels are one run, so a group whose last lane is out ends the row
// (a group reads its four columns past the run's end, within the image row). Within 3 columns
// of the image's right side a column at a time. On NYU's default target (919 vertices) the
// flips took 0.83x the time of the scalar loop.
__attribute__((target("avx"))) double box_error_avx(const Image& image, const Point& a, const Point& b, const Point& c,
                                                    EdgeOwnership own, index_t area, double base, double stop,
                                                    double cut) {
    const double inv = 1.0 / static_cast<double>(area);
    const double az = a.z, bz = b.z, cz = c.z;
    auto [s0, t0, s1, t1, s2, t2, bias0, bias1, bias2, r0, r1, c0, c1, y0, y1, y2] = box_edges(a, b, c, own);
    const double f0 = static_cast<double>(s0), f1 = static_cast<double>(s1), f2 = static_cast<double>(s2);
    const double h0 = static_cast<double>(bias0), h1 = static_cast<double>(bias1), h2 = static_cast<double>(bias2);
    const index_t cols = image.cols();
    const __m256d za = _mm256_set1_pd(az), zb = _mm256_set1_pd(bz), zc = _mm256_set1_pd(cz),
                  scale = _mm256_set1_pd(inv);
    const __m256d magnitude = _mm256_castsi256_pd(_mm256_set1_epi64x(0x7fffffffffffffff));
    const __m256d lane = _mm256_set_pd(3.0, 2.0, 1.0, 0.0);
    const __m256d d0 = _mm256_mul_pd(lane, _mm256_set1_pd(f0)), d1 = _mm256_mul_pd(lane, _mm256_set1_pd(f1)),
                  d2 = _mm256_mul_pd(lane, _mm256_set1_pd(f2));
    const __m256d g0 = _mm256_set1_pd(4.0 * f0), g1 = _mm256_set1_pd(4.0 * f1), g2 = _mm256_set1_pd(4.0 * f2);
    const __m256d lo0 = _mm256_set1_pd(h0), lo1 = _mm256_set1_pd(h1), lo2 = _mm256_set1_pd(h2);
    double total = 0.0;
    for (index_t r = r0; r <= r1; ++r, y0 -= t0, y1 -= t1, y2 -= t2) {
        index_t x0 = y0, x1 = y1, x2 = y2, col = c0;
        if ((x0 | x1 | x2) < 0 && !run_start(s0, s1, s2, c1, x0, x1, x2, col)) continue;
        const double* drow = image.depth.row(r);
        const bool* vrow = image.valid.row(r);
        __m256d v0 = _mm256_add_pd(_mm256_set1_pd(static_cast<double>(x0 + bias0)), d0);
        __m256d v1 = _mm256_add_pd(_mm256_set1_pd(static_cast<double>(x1 + bias1)), d1);
        __m256d v2 = _mm256_add_pd(_mm256_set1_pd(static_cast<double>(x2 + bias2)), d2);
        bool ended = false;
        for (; col + 3 < cols; col += 4) {
            const __m256d plane = _mm256_mul_pd(
                _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(v1, za), _mm256_mul_pd(v2, zb)), _mm256_mul_pd(v0, zc)),
                scale);
            __m256d err = _mm256_and_pd(_mm256_sub_pd(_mm256_loadu_pd(drow + col), plane), magnitude);
            const unsigned in = static_cast<unsigned>(_mm256_movemask_pd(
                _mm256_and_pd(_mm256_and_pd(_mm256_cmp_pd(v0, lo0, _CMP_GE_OQ), _mm256_cmp_pd(v1, lo1, _CMP_GE_OQ)),
                              _mm256_cmp_pd(v2, lo2, _CMP_GE_OQ))));
            v0 = _mm256_add_pd(v0, g0);
            v1 = _mm256_add_pd(v1, g1);
            v2 = _mm256_add_pd(v2, g2);
            // the valid pixels' bytes (0 or 1) gathered into bits 0..3 by one product
            std::uint32_t four;
            std::memcpy(&four, vrow + col, sizeof four);
            const unsigned counted = ((four * 0x01020408u) >> 24) & in;
            if (counted != 0) {
                err = _mm256_and_pd(err, _mm256_load_pd(reinterpret_cast<const double*>(LANE_MASKS[counted])));
                const __m128d lo = _mm256_castpd256_pd128(err), hi = _mm256_extractf128_pd(err, 1);
                total += _mm_cvtsd_f64(lo);
                total += _mm_cvtsd_f64(_mm_unpackhi_pd(lo, lo));
                total += _mm_cvtsd_f64(hi);
                total += _mm_cvtsd_f64(_mm_unpackhi_pd(hi, hi));
            }
            if ((in & 8u) == 0 || col + 3 >= c1) {  // the run ended, or the box
                ended = true;
                break;
            }
        }
        if (!ended) {  // within 3 columns of the image's right side
            double w0 = _mm_cvtsd_f64(_mm256_castpd256_pd128(v0)), w1 = _mm_cvtsd_f64(_mm256_castpd256_pd128(v1)),
                   w2 = _mm_cvtsd_f64(_mm256_castpd256_pd128(v2));
            for (; col <= c1 && w0 >= h0 && w1 >= h1 && w2 >= h2; ++col) {
                if (vrow[col]) total += std::abs(drow[col] - (w1 * az + w2 * bz + w0 * cz) * inv);
                w0 += f0;
                w1 += f1;
                w2 += f2;
            }
        }
        if (base + total >= cut && quantize(base + total, image.span) >= stop) break;
    }
    return total;
}
#endif

// `triangle_error` with its cheap bound `cut` given: below it no sum quantises to `stop`.
double error_until(const Image& image, const Point& a, const Point& b, const Point& c, EdgeOwnership own, double base,
                   double stop, double cut) {
    const index_t area = orient(a.r, a.c, b.r, b.c, c.r, c.c);
    const index_t box = (std::max(a.r, std::max(b.r, c.r)) - std::min(a.r, std::min(b.r, c.r)) + 1) *
                        (std::max(a.c, std::max(b.c, c.c)) - std::min(a.c, std::min(b.c, c.c)) + 1);
    if (area > 0) {
#if RANGEMESH_AVX
        if (box > BOX_PIXELS && has_avx()) return box_error_avx(image, a, b, c, own, area, base, stop, cut);
#endif
        return box <= BOX_PIXELS ? box_error<false>(image, a, b, c, own, area, base, stop, cut)
                                 : box_error<true>(image, a, b, c, own, area, base, stop, cut);
    }
    double total = 0.0;
    plane_errors(
        image, a, b, c, own, [&](index_t, index_t, double err) { total += err; },
        [&] { return !(base + total >= cut && quantize(base + total, image.span) >= stop); });
    return total;
}

}  // namespace

double triangle_error(const Image& image, const Point& a, const Point& b, const Point& c, EdgeOwnership own,
                      double base, double stop) {
    const bool stops = stop < std::numeric_limits<double>::infinity();
    // a cheap bound first: only a sum of at least (stop - 0.5) key steps can quantise to stop
    const double cut = stops ? (stop - 0.5) * image.span / KEY_STEPS : std::numeric_limits<double>::infinity();
    return error_until(image, a, b, c, own, base, stop, cut);
}

namespace {

// The flips' working state: the mesh, its vertex depths, the stack of edges to test.
class Flipper {
  public:
    Flipper(const Image& image, const FlipMesh& mesh, bool checked = true) : image_(image), m_(mesh) {
        require(mesh.vc.size == mesh.vr.size && mesh.halfedges.size == mesh.triangles.size &&
                    mesh.triangles.size == 3 * mesh.sums.size,
                "flips: one column a vertex, one twin a half-edge, one sum a triangle");
        const FreeLater late(on_throw, vz_, ok_, queued_, stack_);  // (no destructor when stopped here)
        const index_t n_v = mesh.vr.size;
        if (!checked) {  // the caller's own arrays, checked when made: the depths and the -1 sums alone
            vertex_depths();
            mark_background();
            fill_polled(queued_, mesh.triangles.size, static_cast<unsigned char>(0));
            stack_.reserve(mesh.triangles.size);
            return;
        }
        for (index_t k = 0; k < mesh.triangles.size; ++k) {
            poll_every(k);
            check_input(0 <= mesh.triangles[k] && mesh.triangles[k] < n_v, "flips: a corner id out of range");
        }
        // a flip writes through the twins (`link`): a twin below -1 would write before the array
        const Span<const index_t> tri{mesh.triangles.data, mesh.triangles.size};
        const Span<const index_t> he{mesh.halfedges.data, mesh.halfedges.size};
        for (index_t k = 0; k < mesh.triangles.size; ++k) {
            poll_every(k);
            check_input(twin_ok(tri, he, k),
                        "flips: a twin below -1 or out of range, or twins that do not run back along one edge");
        }
        for (index_t v = 0; v < n_v; ++v) {
            poll_every(v);
            check_input(0 <= mesh.vr[v] && mesh.vr[v] < image.rows() && 0 <= mesh.vc[v] && mesh.vc[v] < image.cols(),
                        "flips: the vertices must be pixels of the image");
        }
        // the vertex depths; triangles with a background vertex get sum -1 (never flipped)
        vertex_depths();
        mark_background();
        fill_polled(queued_, mesh.triangles.size, static_cast<unsigned char>(0));
        stack_.reserve(mesh.triangles.size);
    }

    ~Flipper() { free_later(vz_, ok_, queued_, stack_); }
    Flipper(const Flipper&) = delete;
    Flipper& operator=(const Flipper&) = delete;

    bool valid(index_t v) const { return image_.valid(m_.vr[v], m_.vc[v]); }
    bool all_valid(index_t t) const {
        return (ok_[m_.triangles[3 * t]] & ok_[m_.triangles[3 * t + 1]] & ok_[m_.triangles[3 * t + 2]]) != 0;
    }

    // Each vertex's depth and whether its pixel is valid, read from the image once: a triangle's
    // corners then cost a byte each, not a vertex's pixel and the image's validity.
    void vertex_depths() {
        const index_t n_v = m_.vr.size;
        fill_polled(vz_, n_v, 0.0);
        fill_polled(ok_, n_v, static_cast<unsigned char>(0));
        for (index_t v = 0; v < n_v; ++v) {
            poll_every(v);
            if (valid(v)) {
                ok_[v] = 1;
                vz_[v] = image_.depth(m_.vr[v], m_.vc[v]);
            }
        }
    }

    // Sum -1 for the triangles with a background vertex: never flipped.
    void mark_background() {
        for (index_t t = 0; t < m_.sums.size; ++t) {
            poll_every(t);
            if (!all_valid(t)) m_.sums[t] = -1.0;
        }
    }

    Point point(index_t v) const { return {m_.vr[v], m_.vc[v], vz_[v]}; }

    bool owns(index_t e, const Point& p, const Point& q) const {
        return own_edge(m_.halfedges[e], p.r, p.c, q.r, q.c, image_.cols());
    }

    // The error sum of triangle t over the pixels it owns.
    double face_error(index_t t) const {
        const index_t e = 3 * t;
        const Point a = point(m_.triangles[e]), b = point(m_.triangles[e + 1]), c = point(m_.triangles[e + 2]);
        return triangle_error(image_, a, b, c, {owns(e, a, b), owns(e + 1, b, c), owns(e + 2, c, a)});
    }

    // Put e on the stack unless its edge is there already.
    void push(index_t e) {
        const index_t g = m_.halfedges[e];
        if (g >= 0 && !queued_[e] && !queued_[g]) {
            stack_.push_back(e);
            queued_[e] = 1;
        }
    }

    // Every interior edge between two triangles that may flip, popped in order of e.
    void push_all() {
        for (index_t e = m_.triangles.size - 1; e >= 0; --e) {
            poll_every(e);
            const index_t g = m_.halfedges[e];
            if (g > e && m_.sums[e / 3] >= 0.0 && m_.sums[g / 3] >= 0.0) {
                stack_.push_back(e);
                queued_[e] = 1;
            }
        }
    }

    // The half-edges `first`, popped in the order given, their triangles' sums afresh.
    void push_first(Span<const index_t> first) {
        for (const index_t e : first) {
            poll_interrupt();
            check_input(0 <= e && e < m_.triangles.size, "flips: a first half-edge out of range");
            for (const index_t g : {e, m_.halfedges[e]})
                if (g >= 0 && m_.sums[g / 3] >= 0.0) m_.sums[g / 3] = face_error(g / 3);
        }
        for (index_t i = first.size - 1; i >= 0; --i) push(first[i]);
    }

    // Test the edges on the stack, flipping those whose error drops.
    FlipCount run() {
        FlipCount count;
        const index_t max_tests = MAX_TESTS_PER_EDGE * static_cast<index_t>(stack_.size());
        const double span = image_.span;
        const Span<index_t> tri = m_.triangles, he = m_.halfedges;
        const index_t *vr = m_.vr.data, *vc = m_.vc.data;
        double* const sums = m_.sums.data;
        while (!stack_.empty() && count.tests < max_tests) {
            if (count.tests % 256 == 0) poll_interrupt();
            const index_t e0 = stack_.back();
            stack_.pop_back();
            queued_[e0] = 0;
            const index_t e1 = he[e0];
            if (e1 < 0) continue;
            const index_t t0 = e0 / 3, t1 = e1 / 3;
            const double u0 = sums[t0], u1 = sums[t1];
            if (u0 < 0.0 || u1 < 0.0) continue;
            // ABC + BAD -> DCA + CDB (A->B is e0, B->A its twin e1)
            const index_t k0 = e0 - 3 * t0, k1 = e1 - 3 * t1;  // (nxt and prv without a second % 3)
            const index_t b0 = k0 == 2 ? e0 - 2 : e0 + 1, c0 = k0 == 0 ? e0 + 2 : e0 - 1;
            const index_t b1 = k1 == 2 ? e1 - 2 : e1 + 1, c1 = k1 == 0 ? e1 + 2 : e1 - 1;
            const index_t ia = tri[e0], ib = tri[b0], ic = tri[c0], id = tri[c1];
            const index_t ar = vr[ia], ac = vc[ia], br = vr[ib], bc = vc[ib];
            const index_t cr = vr[ic], cc = vc[ic], dr = vr[id], dc = vc[id];
            // both counter-clockwise only when the quad is convex
            const index_t area0 = orient(dr, dc, cr, cc, ar, ac), area1 = orient(cr, cc, dr, dc, br, bc);
            if (area0 <= 0 || area1 <= 0) continue;
            const double old = quantize(u0 + u1, span);
            if (old == 0.0) continue;  // nothing to gain
            ++count.tests;
            const Point a{ar, ac, vz_[ia]}, b{br, bc, vz_[ib]}, c{cr, cc, vz_[ic]}, d{dr, dc, vz_[id]};
            const bool own_dc = rangemesh::owns(dr, dc, cr, cc);
            const EdgeOwnership own0{own_dc, owns(c0, c, a), owns(b1, a, d)};
            const EdgeOwnership own1{!own_dc, owns(c1, d, b), owns(b0, b, c)};
            // each scan stops once the other diagonal is known to be no better; the larger
            // triangle first, the likelier to stop the test alone (s0 + s1 is the same sum)
            const double cut = (old - 0.5) * span / KEY_STEPS;
            const bool first0 = area0 >= area1;
            const double s_first = first0 ? error_until(image_, d, c, a, own0, 0.0, old, cut)
                                          : error_until(image_, c, d, b, own1, 0.0, old, cut);
            if (quantize(s_first, span) >= old) continue;
            const double s_second = first0 ? error_until(image_, c, d, b, own1, s_first, old, cut)
                                           : error_until(image_, d, c, a, own0, s_first, old, cut);
            const double s0 = first0 ? s_first : s_second, s1 = first0 ? s_second : s_first;
            if (quantize(s0 + s1, span) >= old) continue;
            flip_quad(tri, he, e0);
            sums[t0] = s0;
            sums[t1] = s1;
            ++count.flips;
            // the quad's four outer edges: their other triangles now face new ones
            for (const index_t f : {b0, c0, b1, c1}) push(f);
        }
        return count;
    }

  private:
    const Image& image_;
    FlipMesh m_;
    std::vector<double> vz_;
    std::vector<unsigned char> ok_;  // 1 where the vertex's pixel is valid
    std::vector<unsigned char> queued_;
    std::vector<index_t> stack_;
};

}  // namespace

FlipCount flip_by_error(const Image& image, const FlipMesh& mesh, bool checked) {
    Flipper f(image, mesh, checked);
    f.push_all();
    return f.run();
}

FlipCount flip_from_edges(const Image& image, const FlipMesh& mesh, Span<const index_t> first, bool checked) {
    Flipper f(image, mesh, checked);
    f.push_first(first);
    return f.run();
}

void face_errors(const Image& image, const FlipMesh& mesh) {
    Flipper f(image, mesh);  // sums -1 where a corner is background
    for (index_t t = 0; t < mesh.sums.size; ++t) {
        poll_interrupt();  // a scan a triangle: a poll is nothing beside it
        mesh.sums[t] = f.all_valid(t) ? f.face_error(t) : 0.0;
    }
}

}  // namespace rangemesh::refine
