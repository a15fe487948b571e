#include "scan.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#include "../geometry/ownership.hpp"
#include "../geometry/predicates.hpp"
#include "../geometry/raster.hpp"
#include "keys.hpp"

#if defined(__SSE2__) || defined(_M_X64) || (defined(_M_IX86_FP) && _M_IX86_FP >= 2)
#include <emmintrin.h>
#define RANGEMESH_SCAN_SSE2 1
#else
#define RANGEMESH_SCAN_SSE2 0
#endif
#include "../simd.hpp"

namespace rangemesh::refine {

double spread_key(index_t area, index_t h, index_t w) {
    return SMALL_KEY * static_cast<double>(area) / (2.0 * static_cast<double>(h) * static_cast<double>(w) + 1.0);
}

Pixel centroid_pixel(index_t ar, index_t ac, index_t br, index_t bc, index_t cr, index_t cc, Grid<const bool> valid) {
    const index_t r = floor_div(ar + br + cr + 1, 3);
    const index_t c = floor_div(ac + bc + cc + 1, 3);
    if (orient(ar, ac, br, bc, r, c) > 0 && orient(br, bc, cr, cc, r, c) > 0 && orient(cr, cc, ar, ac, r, c) > 0 &&
        valid(r, c))
        return {r, c};
    return {-1, -1};
}

namespace {

bool is_corner(index_t r, index_t c, const Corner& a, const Corner& b, const Corner& cn) {
    return (r == a.r && c == a.c) || (r == b.r && c == b.c) || (r == cn.r && c == cn.c);
}

// The valid pixel that covers a background-corner triangle best, as QuickHull picks a point.
struct Cover {
    index_t weight = -1;  // -1: no pixel needs covering
    index_t r = -1, c = -1;
    bool seen = false;  // the triangle holds a valid pixel
};

// Among the valid pixels that need covering, the one with the largest barycentric weight of
// a background corner: the farthest from that corner's opposite edge. Inserting it leaves the
// corner two triangles that hold no valid pixel unless the valid region bends inwards there,
// so a straight silhouette costs one vertex, not one per pixel. The weight is an exact
// integer; ties go to the first pixel in row-major order. A valid pixel on an edge between
// two valid corners (`lost` false) competes by its error instead, in a full scan.
Cover cover_pixel(const Corner& a, const Corner& b, const Corner& cn, EdgeOwnership own, Grid<const bool> valid) {
    const bool lost0 = a.background || b.background;
    const bool lost1 = b.background || cn.background;
    const bool lost2 = cn.background || a.background;
    const index_t s0 = b.r - a.r;   // w0 = orient(A, B, p): the weight of C
    const index_t s1 = cn.r - b.r;  // w1: the weight of A
    const index_t s2 = a.r - cn.r;  // w2: the weight of B
    // the largest background corner's weight, from the three edge functions
    auto weight = [&](index_t w0, index_t w1, index_t w2) {
        index_t w = -1;
        if (a.background) w = std::max(w, w1);
        if (b.background) w = std::max(w, w2);
        if (cn.background) w = std::max(w, w0);
        return w;
    };
    Cover best;
    TriangleRows rows(a.r, a.c, b.r, b.c, cn.r, cn.c);
    owned_rows(rows, own, [&](index_t r, const RowSpan& span) {
        // the weights are linear along the row: no pixel of it can beat `best` when neither
        // end of the span does (once valid pixels were seen)
        if (best.seen && best.weight >= 0) {
            const index_t n = span.last - span.first;
            const index_t bound = std::max(weight(span.w0, span.w1, span.w2),
                                           weight(span.w0 + s0 * n, span.w1 + s1 * n, span.w2 + s2 * n));
            if (bound < best.weight) return true;
        }
        // The weight, a largest of linear functions, is convex along the row: over the row's
        // competing pixels it is largest at the first or the last, and where another competing
        // pixel equals that largest so does the first. So the row's winner (its first of the
        // largest weight) is the first unless the last weighs more; the pixels between are only
        // walked past from each end to the nearest competing one.
        const bool* vrow = valid.row(r);
        const auto competes = [&](index_t c, index_t& w) {
            const index_t k = c - span.first;
            const index_t w0 = span.w0 + s0 * k, w1 = span.w1 + s1 * k, w2 = span.w2 + s2 * k;
            if (is_corner(r, c, a, b, cn)) return false;
            if ((w0 == 0 && !lost0) || (w1 == 0 && !lost1) || (w2 == 0 && !lost2)) return false;
            w = weight(w0, w1, w2);
            return true;
        };
        index_t first = span.first, w_first = -1;
        for (; first <= span.last; ++first) {
            if (!vrow[first]) {
                // the invalid pixels after it passed eight at a time (a background region's)
                std::uint64_t eight = 0;
                while (first + 8 <= span.last && (std::memcpy(&eight, vrow + first + 1, 8), eight == 0)) first += 8;
                continue;
            }
            best.seen = true;
            if (competes(first, w_first)) break;
        }
        if (first > span.last) return true;  // no competing pixel in the row
        index_t last = span.last, w_last = -1;
        while (last > first && !(vrow[last] && competes(last, w_last))) --last;
        const bool last_wins = last > first && w_last > w_first;
        const index_t w = last_wins ? w_last : w_first;
        if (w > best.weight) {  // row-major visit: an equal weight never replaces the first
            best.weight = w;
            best.r = r;
            best.c = last_wins ? last : first;
        }
        return true;
    });
    return best;
}

// The pixel a full scan keys a triangle by: the first, in row-major order, of those whose error
// has the largest key (`quantize`). Keys rise with the error, so that pixel set a new largest
// error when it was met, and lies within a key step of the largest error. The scan keeps those
// records alone and quantises them once at the end: quantising each new largest error cost a
// division and a floor a pixel wherever the error grows along the rows.
class Records {
  public:
    struct Entry {
        double key, err;
        index_t r, c;
    };

    // Records more than WINDOW key steps below the largest cannot share its key.
    explicit Records(double span)
        : span_(span), window_(span > 0.0 ? WINDOW * span / KEY_STEPS : std::numeric_limits<double>::infinity()) {}

    double largest() const { return top_; }

    // A pixel whose error exceeds every error so far.
    void add(index_t r, index_t c, double err) {
        // drop the records that fell out of the window (they sit first: errors rise along the list)
        const double low = err - window_;
        index_t keep = 0;
        while (keep < n_ && entries_[keep].err < low) ++keep;
        if (keep > 0) {
            for (index_t i = keep; i < n_; ++i) entries_[i - keep] = entries_[i];
            n_ -= keep;
        }
        if (n_ == CAPACITY) collapse();
        entries_[n_++] = Entry{-1.0, err, r, c};
        top_ = err;
    }

    Entry first_of_largest_key() const {
        if (n_ == 0) return {-1.0, -1.0, -1, -1};
        const double top = quantize(entries_[n_ - 1].err, span_);
        for (index_t i = 0; i < n_; ++i) {
            if (i == n_ - 1 || quantize(entries_[i].err, span_) == top) {  // (the last is the top)
                Entry e = entries_[i];
                e.key = top;
                return e;
            }
        }
        throw InvariantError("scan: the largest error's key belongs to a record");
    }

  private:
    static constexpr double WINDOW = 4.0;
    static constexpr index_t CAPACITY = 16;

    // Full of records within the window (errors that rise by less than a key step): keep the
    // first of each key, as only the first of a key can win.
    void collapse() {
        index_t out = 0;
        double last = -1.0;
        for (index_t i = 0; i < n_; ++i) {
            const double key = quantize(entries_[i].err, span_);
            if (out == 0 || key != last) entries_[out++] = entries_[i];
            last = key;
        }
        if (out == CAPACITY) throw InvariantError("scan: more keys within the window than records kept");
        n_ = out;
    }

    double span_, window_;
    double top_ = -1.0;
    Entry entries_[CAPACITY];  // the first n_ are set
    index_t n_ = 0;
};

// A pixel's error against the records: the scan's rule, one pixel at a time in row-major order.
inline void note(Records& records, index_t r, index_t c, double err, const Corner& a, const Corner& b,
                 const Corner& cn) {
    if (err > records.largest() && !is_corner(r, c, a, b, cn)) records.add(r, c, err);
}

// One row's pixels of a triangle: columns first..last of row r, and the edge functions at `first`.
struct RowRun {
    index_t r, first, last;
    double w0, w1, w2;
};

// The scalar loop over columns col..last of row r from edge functions w0, w1, w2.
inline void row_sum(const Image& image, const PlaneRows& p, index_t r, index_t col, index_t last, double w0, double w1,
                    double w2, double& total, Records& records, const Corner& a, const Corner& b, const Corner& cn) {
    const double* drow = image.depth.row(r);
    const bool* vrow = image.valid.row(r);
    for (; col <= last; ++col) {
        if (vrow[col]) {
            const double err = p.error(drow[col], w0, w1, w2);
            total += err;
            note(records, r, col, err, a, b, cn);
        }
        w0 += p.f0;
        w1 += p.f1;
        w2 += p.f2;
    }
}

#if RANGEMESH_AVX
// What a group of four columns reads besides its row: the plane's lanes.
struct FourLanes {
    __m256d za, zb, zc, scale, magnitude, g0, g1, g2;
};

// The errors of the four columns from `col` (edge functions v0, v1, v2, moved on four columns),
// those of the lanes in `lanes` that are valid added to `total` one at a time, in order.
__attribute__((target("avx"), always_inline)) inline void sum_four(const double* drow, const bool* vrow, index_t r,
                                                                   index_t col, unsigned lanes, const FourLanes& k,
                                                                   __m256d& v0, __m256d& v1, __m256d& v2, __m256d& top,
                                                                   double& total, Records& records, const Corner& a,
                                                                   const Corner& b, const Corner& cn) {
    const __m256d plane = _mm256_mul_pd(
        _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(v1, k.za), _mm256_mul_pd(v2, k.zb)), _mm256_mul_pd(v0, k.zc)),
        k.scale);
    __m256d err = _mm256_and_pd(_mm256_sub_pd(_mm256_loadu_pd(drow + col), plane), k.magnitude);
    v0 = _mm256_add_pd(v0, k.g0);
    v1 = _mm256_add_pd(v1, k.g1);
    v2 = _mm256_add_pd(v2, k.g2);
    // the valid pixels' bytes (0 or 1) gathered into bits 0..3 by one product
    std::uint32_t four;
    std::memcpy(&four, vrow + col, sizeof four);
    const unsigned counted = ((four * 0x01020408u) >> 24) & lanes;
    err = _mm256_and_pd(err, _mm256_load_pd(reinterpret_cast<const double*>(LANE_MASKS[counted])));
    if (_mm256_movemask_pd(_mm256_cmp_pd(err, top, _CMP_GT_OQ)) == 0) {  // no record
        const __m128d lo = _mm256_castpd256_pd128(err), hi = _mm256_extractf128_pd(err, 1);
        total += _mm_cvtsd_f64(lo);
        total += _mm_cvtsd_f64(_mm_unpackhi_pd(lo, lo));
        total += _mm_cvtsd_f64(hi);
        total += _mm_cvtsd_f64(_mm_unpackhi_pd(hi, hi));
        return;
    }
    alignas(32) double e[4];
    _mm256_store_pd(e, err);
    for (index_t j = 0; j < 4; ++j)
        if ((counted >> j) & 1u) {
            total += e[j];
            note(records, r, col + j, e[j], a, b, cn);
        }
    top = _mm256_set1_pd(records.largest());
}

// The rows' sum, four columns at once: each lane the IEEE operation of the scalar loop (the
// edge functions w + j f and w + 4 f are whole numbers below 2^53, exact), the errors added to
// the sum one at a time in row-major order, 0 for a pixel not counted (invalid, or past the
// row's last: the sum starts at +0 and only grows, so adding +0 changes nothing), and four
// errors that all stay at or below the largest so far checked against the records once. A
// row's last group reads its four columns even past its last, within the image row; within 3
// columns of the image's right side the scalar loop goes on.
__attribute__((target("avx"))) double runs_sum_avx(const Image& image, const PlaneRows& p, const RowRun* runs,
                                                   index_t n_runs, Records& records, const Corner& a, const Corner& b,
                                                   const Corner& cn) {
    const index_t cols = image.cols();
    const FourLanes k{_mm256_set1_pd(p.az),
                      _mm256_set1_pd(p.bz),
                      _mm256_set1_pd(p.cz),
                      _mm256_set1_pd(p.inv),
                      _mm256_castsi256_pd(_mm256_set1_epi64x(0x7fffffffffffffff)),
                      _mm256_set1_pd(4.0 * p.f0),
                      _mm256_set1_pd(4.0 * p.f1),
                      _mm256_set1_pd(4.0 * p.f2)};
    const __m256d lane = _mm256_set_pd(3.0, 2.0, 1.0, 0.0);
    const __m256d d0 = _mm256_mul_pd(lane, _mm256_set1_pd(p.f0)), d1 = _mm256_mul_pd(lane, _mm256_set1_pd(p.f1)),
                  d2 = _mm256_mul_pd(lane, _mm256_set1_pd(p.f2));
    double total = 0.0;
    __m256d top = _mm256_set1_pd(records.largest());
    for (index_t i = 0; i < n_runs; ++i) {
        const RowRun& run = runs[i];
        const index_t r = run.r, last = run.last;
        // (the image row's last four columns start at `cols - 4`)
        const index_t end = std::min(last, cols - 1) - 3;
        index_t col = run.first;
        const double* drow = image.depth.row(r);
        const bool* vrow = image.valid.row(r);
        __m256d v0 = _mm256_add_pd(_mm256_set1_pd(run.w0), d0);
        __m256d v1 = _mm256_add_pd(_mm256_set1_pd(run.w1), d1);
        __m256d v2 = _mm256_add_pd(_mm256_set1_pd(run.w2), d2);
        for (; col <= end; col += 4) sum_four(drow, vrow, r, col, 15u, k, v0, v1, v2, top, total, records, a, b, cn);
        if (col <= last && col + 3 < cols) {  // the row's last pixels, 1 to 3
            sum_four(drow, vrow, r, col, (1u << static_cast<unsigned>(last - col + 1)) - 1u, k, v0, v1, v2, top, total,
                     records, a, b, cn);
            col += 4;
        }
        if (col <= last) {
            row_sum(image, p, r, col, last, _mm_cvtsd_f64(_mm256_castpd256_pd128(v0)),
                    _mm_cvtsd_f64(_mm256_castpd256_pd128(v1)), _mm_cvtsd_f64(_mm256_castpd256_pd128(v2)), total,
                    records, a, b, cn);
            top = _mm256_set1_pd(records.largest());
        }
    }
    return total;
}
#endif

// Triangles at least this many columns wide are summed by `plane_sum`, narrower ones by
// `plane_errors` a pixel at a time.
constexpr index_t WIDE_COLUMNS = 16;

// `plane_errors`' sum over counter-clockwise ABC (area > 0) with its visit inlined; with SSE2
// the errors (w1 zA + w2 zB + w0 zC) / area of two columns at once (each lane the IEEE operation
// of the scalar loop, so the same errors bit for bit), added to the sum one at a time in
// row-major order, and a pair of valid pixels whose errors both stay at or below the largest
// so far checked against the records once.
double plane_sum(const Image& image, const Corner& a, const Corner& b, const Corner& cn, EdgeOwnership own,
                 Records& records) {
#if RANGEMESH_AVX
    if (has_avx()) {  // the rows first, then their pixels in one function of AVX code
        thread_local std::vector<RowRun> kept;  // room for a run a row, kept for the thread's next scan
        TriangleSpans spans(a.r, a.c, b.r, b.c, cn.r, cn.c, own.ab, own.bc, own.ca);
        std::vector<RowRun>& runs = kept;
        const std::size_t rows = static_cast<std::size_t>(spans.bottom() - spans.top() + 1);
        if (runs.size() < rows) runs.resize(rows);
        RowRun* const out = runs.data();
        index_t n = 0;
        const PlaneRows p(a, b, cn);
        spans.walk([&](index_t r, index_t first, index_t last) {
            RowRun& run = out[n++];
            run.r = r;
            run.first = first;
            run.last = last;
            p.edges_at(r, first, run.w0, run.w1, run.w2);
            return true;
        });
        return runs_sum_avx(image, p, out, n, records, a, b, cn);
    }
#endif
    const PlaneRows p(a, b, cn);
    // in locals: read through a struct, the compiler reloads them every pixel
    const double inv = p.inv, az = p.az, bz = p.bz, cz = p.cz, f0 = p.f0, f1 = p.f1, f2 = p.f2;
    double total = 0.0;
#if RANGEMESH_SCAN_SSE2
    const __m128d za = _mm_set1_pd(az), zb = _mm_set1_pd(bz), zc = _mm_set1_pd(cz), scale = _mm_set1_pd(inv);
    const __m128d magnitude = _mm_castsi128_pd(_mm_set1_epi64x(0x7fffffffffffffff));
    // (the edge functions are whole numbers below 2^53: w + 2 f is (w + f) + f exactly)
    const __m128d g0 = _mm_set1_pd(2.0 * f0), g1 = _mm_set1_pd(2.0 * f1), g2 = _mm_set1_pd(2.0 * f2);
#endif
    TriangleSpans spans(a.r, a.c, b.r, b.c, cn.r, cn.c, own.ab, own.bc, own.ca);
    spans.walk([&](index_t r, index_t first, index_t last) {
        const double* drow = image.depth.row(r);
        const bool* vrow = image.valid.row(r);
        double w0, w1, w2;
        p.edges_at(r, first, w0, w1, w2);
        index_t col = first;
#if RANGEMESH_SCAN_SSE2
        if (col < last) {
            __m128d v0 = _mm_set_pd(w0 + f0, w0), v1 = _mm_set_pd(w1 + f1, w1), v2 = _mm_set_pd(w2 + f2, w2);
            __m128d top = _mm_set1_pd(records.largest());
            for (; col < last; col += 2) {
                const __m128d plane = _mm_mul_pd(
                    _mm_add_pd(_mm_add_pd(_mm_mul_pd(v1, za), _mm_mul_pd(v2, zb)), _mm_mul_pd(v0, zc)), scale);
                const __m128d err = _mm_and_pd(_mm_sub_pd(_mm_loadu_pd(drow + col), plane), magnitude);
                v0 = _mm_add_pd(v0, g0);
                v1 = _mm_add_pd(v1, g1);
                v2 = _mm_add_pd(v2, g2);
                const double e0 = _mm_cvtsd_f64(err), e1 = _mm_cvtsd_f64(_mm_unpackhi_pd(err, err));
                std::uint16_t both;
                std::memcpy(&both, vrow + col, sizeof both);
                if (both == 0x0101 && _mm_movemask_pd(_mm_cmpgt_pd(err, top)) == 0) {  // valid, no record
                    total += e0;
                    total += e1;
                    continue;
                }
                if (vrow[col]) {
                    total += e0;
                    note(records, r, col, e0, a, b, cn);
                }
                if (vrow[col + 1]) {
                    total += e1;
                    note(records, r, col + 1, e1, a, b, cn);
                }
                top = _mm_set1_pd(records.largest());
            }
            w0 = _mm_cvtsd_f64(v0);
            w1 = _mm_cvtsd_f64(v1);
            w2 = _mm_cvtsd_f64(v2);
        }
#endif
        for (; col <= last; ++col) {
            if (vrow[col]) {
                const double err = std::abs(drow[col] - (w1 * az + w2 * bz + w0 * cz) * inv);
                total += err;
                note(records, r, col, err, a, b, cn);
            }
            w0 += f0;
            w1 += f1;
            w2 += f2;
        }
        return true;
    });
    return total;
}

}  // namespace

TriangleKey scan_triangle(const Image& image, const Corner& a, const Corner& b, const Corner& cn, EdgeOwnership own) {
    const index_t area = orient(a.r, a.c, b.r, b.c, cn.r, cn.c);
    TriangleKey out;
    if (a.background || b.background || cn.background) {
        // Cover first: the pixel is found mostly without visiting the whole triangle. Its sum
        // is left 0: a triangle with a cover key is split before any stop on the sum. Only a
        // triangle whose valid pixels lie on edges that stay is scanned in full, below.
        const Cover near = cover_pixel(a, b, cn, own, image.valid);
        if (near.weight >= 0) {
            out.key = COVER_KEY * (1.0 + static_cast<double>(near.weight) / static_cast<double>(area));
            out.r = static_cast<std::int32_t>(near.r);
            out.c = static_cast<std::int32_t>(near.c);
            return out;
        }
        if (!near.seen) return out;
    }
    const index_t h = image.rows(), w = image.cols();
    Records records(image.span);
    double total = 0.0;
    // a narrow triangle's rows are too short to pay for the wide loops' set-up (and a raw call's
    // triangle may be turned the wrong way or flat)
    if (area > 0 && std::max({a.c, b.c, cn.c}) - std::min({a.c, b.c, cn.c}) + 1 >= WIDE_COLUMNS)
        total = plane_sum(image, a, b, cn, own, records);
    else
        plane_errors(
            image, {a.r, a.c, a.z}, {b.r, b.c, b.z}, {cn.r, cn.c, cn.z}, own,
            [&](index_t r, index_t c, double err) {
                total += err;
                note(records, r, c, err, a, b, cn);
            },
            [] { return true; });
    const Records::Entry first = records.first_of_largest_key();
    double best = first.key, best_err = first.err;
    index_t best_r = first.r, best_c = first.c;
    if (best == 0.0) {  // every pixel fits the plane to within half a key step
        best = spread_key(area, h, w);
        const Pixel p = centroid_pixel(a.r, a.c, b.r, b.c, cn.r, cn.c, image.valid);
        if (p.r >= 0) {
            best_r = p.r;
            best_c = p.c;
            out.fits = true;
        }
    } else if (0.0 < best && best <= KEY_STEPS) {  // an error key: rank by worst and sum
        best = quantize(std::sqrt(best_err * total / static_cast<double>(h * w)), image.span);
        if (best == 0.0) best = SMALL_KEY;
    }
    out.key = best;
    out.r = static_cast<std::int32_t>(best_r);
    out.c = static_cast<std::int32_t>(best_c);
    out.sum = total;
    return out;
}

}  // namespace rangemesh::refine
