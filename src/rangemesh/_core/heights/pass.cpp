#include "pass.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <type_traits>
#include <utility>
#include <vector>

#include "../geometry/ownership.hpp"
#include "../geometry/predicates.hpp"
#include "../geometry/raster.hpp"
#include "../interrupt.hpp"
#include "../parallel.hpp"
#include "../simd.hpp"

namespace rangemesh::heights {

void check_mesh(const FitMesh& mesh, const FitImage& image) {
    const index_t n = mesh.values.size;
    require(mesh.rows.size == n && mesh.cols.size == n, "fit: one row, column and value a vertex");
    require(mesh.faces.cols == 3, "fit: faces have three corners");
    // flags and-ed without a branch an entry: unsigned, a negative id is past n too
    const auto below = [](index_t x, index_t end) {
        return static_cast<std::uint64_t>(x) < static_cast<std::uint64_t>(end);
    };
    bool ids = true;
    for (index_t k = 0; k < 3 * mesh.faces.rows; ++k) ids &= below(mesh.faces.data[k], n);
    require(ids, "fit: a face's vertex id is out of range");
    require(image.values.rows == image.valid.rows && image.values.cols == image.valid.cols,
            "fit: the image and its mask differ in shape");
    bool inside = true;
    for (index_t i = 0; i < n; ++i)
        inside &= below(mesh.rows[i], image.values.rows) & below(mesh.cols[i], image.values.cols);
    if (!inside) throw std::invalid_argument("fit: a vertex lies outside the image");
}

namespace {

// A face's corners turned counter-clockwise in (row, column).
struct Corners {
    index_t a, b, c;
};

Corners ccw_corners(const FitMesh& mesh, index_t t) {
    const index_t a = mesh.faces(t, 0);
    index_t b = mesh.faces(t, 1), c = mesh.faces(t, 2);
    if (orient<index_t>(mesh.rows[a], mesh.cols[a], mesh.rows[b], mesh.cols[b], mesh.rows[c], mesh.cols[c]) < 0)
        std::swap(b, c);
    return {a, b, c};
}

// Faces fewer columns wide than this test each pixel of their bounding box (no walk set-up).
constexpr index_t BOX_MAX_WIDTH = 8;

// `visit_pixels` without a four-lane path.
struct NoWide {};

#if RANGEMESH_AVX
// One row of a wide face: columns first..last of row r, the edge functions w0, w1, w2 at first.
struct FitRun {
    index_t r, first, last, w0, w1, w2;
};

// A face's rows run four columns at once when they hold at least this many pixels on average.
constexpr index_t AVX_MIN_RUN = 6;

// What the four-lane loops read besides the image and a face's runs.
struct WideFace {
    index_t n = 0;  // runs
    double inv = 0.0, az = 0.0, bz = 0.0, cz = 0.0, f0 = 0.0, f1 = 0.0, f2 = 0.0;
};

// `visit_pixels`' four-lane path for a face of long rows (`on`): take(face, runs) instead of
// the visits, with the face's runs in `runs`; what it returns `visit_pixels` returns.
template <class Take>
struct Wide {
    bool on;
    Take take;
    std::vector<FitRun> runs;
};

// What a group of four columns reads besides its row.
struct FitLanes {
    __m256d inv, za, zb, zc, threshold, magnitude;
};

// acc += the columns of the 4 x 4 matrix whose rows are r0..r3, one column after the other:
// lane k of each row is pixel k's, so each sum takes its pixels' terms one at a time, in order.
__attribute__((target("avx"), always_inline)) inline void add_columns(__m256d& acc, __m256d r0, __m256d r1, __m256d r2,
                                                                      __m256d r3) {
    const __m256d t0 = _mm256_unpacklo_pd(r0, r1), t1 = _mm256_unpackhi_pd(r0, r1);
    const __m256d t2 = _mm256_unpacklo_pd(r2, r3), t3 = _mm256_unpackhi_pd(r2, r3);
    acc = _mm256_add_pd(acc, _mm256_permute2f128_pd(t0, t2, 0x20));
    acc = _mm256_add_pd(acc, _mm256_permute2f128_pd(t1, t3, 0x20));
    acc = _mm256_add_pd(acc, _mm256_permute2f128_pd(t0, t2, 0x31));
    acc = _mm256_add_pd(acc, _mm256_permute2f128_pd(t1, t3, 0x31));
}

// The four columns from `values` (edge functions e0, e1, e2; the pixels of `lanes` valid) added
// to the face's sums x = (m00, m11, m22, q0), y = (m01, m12, m02, q1) and q2, and counted in
// `used`: each lane the scalar loop's IEEE operations, a pixel left out (invalid, beyond the
// bound, or past the row) adding +0 to every sum (they start at +0 and never reach -0, so
// adding +0 changes nothing).
__attribute__((target("avx"), always_inline)) inline void fit_four(const double* values, unsigned lanes, __m256d e0,
                                                                   __m256d e1, __m256d e2, const FitLanes& k,
                                                                   __m256d& x, __m256d& y, double& q2, index_t& used) {
    const __m256d la = _mm256_mul_pd(e1, k.inv), lb = _mm256_mul_pd(e2, k.inv), lc = _mm256_mul_pd(e0, k.inv);
    const __m256d value = _mm256_loadu_pd(values);
    const __m256d mesh =
        _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(la, k.za), _mm256_mul_pd(lb, k.zb)), _mm256_mul_pd(lc, k.zc));
    const __m256d error = _mm256_and_pd(_mm256_sub_pd(value, mesh), k.magnitude);
    const __m256d keep = _mm256_and_pd(_mm256_cmp_pd(error, k.threshold, _CMP_LE_OQ),
                                       _mm256_load_pd(reinterpret_cast<const double*>(LANE_MASKS[lanes])));
    const int kept = _mm256_movemask_pd(keep);
    if (kept == 0) return;
    used += __builtin_popcount(static_cast<unsigned>(kept));
    const __m256d a = _mm256_and_pd(la, keep), b = _mm256_and_pd(lb, keep), c = _mm256_and_pd(lc, keep),
                  v = _mm256_and_pd(value, keep);
    add_columns(x, _mm256_mul_pd(a, a), _mm256_mul_pd(b, b), _mm256_mul_pd(c, c), _mm256_mul_pd(v, a));
    add_columns(y, _mm256_mul_pd(a, b), _mm256_mul_pd(b, c), _mm256_mul_pd(c, a), _mm256_mul_pd(v, b));
    const __m256d q = _mm256_mul_pd(c, v);
    const __m128d lo = _mm256_castpd256_pd128(q), hi = _mm256_extractf128_pd(q, 1);
    q2 += _mm_cvtsd_f64(lo);
    q2 += _mm_cvtsd_f64(_mm_unpackhi_pd(lo, lo));
    q2 += _mm_cvtsd_f64(hi);
    q2 += _mm_cvtsd_f64(_mm_unpackhi_pd(hi, hi));
}

// The valid flags (bytes 0 or 1) of four pixels gathered into bits 0..3 by one product.
inline unsigned valid_bits(const bool* valid) {
    std::uint32_t four;
    std::memcpy(&four, valid, sizeof four);
    return (four * 0x01020408u) >> 24 & 15u;
}

// The rows read ahead of the one summed: a face's rows lie a row of the image apart, where the
// processor's own prefetch did not follow (a load of its first pixels took a third of the time).
constexpr index_t PREFETCH_RUNS = 2;

// A face's block from its rows `runs`, four columns at once: the sums of `accumulate`'s scalar
// loop bit for bit (the edge functions w + j f are whole numbers below 2^53, exact). Within 3
// columns of the image's right side a row's last group reads copies of its pixels.
__attribute__((target("avx"))) index_t face_sums_avx(const FitImage& image, const FitRun* runs, index_t n_runs,
                                                     double inv, double az, double bz, double cz, double f0, double f1,
                                                     double f2, double threshold, double sums[9]) {
    const index_t cols = image.values.cols;
    const FitLanes k{_mm256_set1_pd(inv),       _mm256_set1_pd(az),
                     _mm256_set1_pd(bz),        _mm256_set1_pd(cz),
                     _mm256_set1_pd(threshold), _mm256_castsi256_pd(_mm256_set1_epi64x(0x7fffffffffffffff))};
    const __m256d lane = _mm256_set_pd(3.0, 2.0, 1.0, 0.0);
    const __m256d d0 = _mm256_mul_pd(lane, _mm256_set1_pd(f0)), d1 = _mm256_mul_pd(lane, _mm256_set1_pd(f1)),
                  d2 = _mm256_mul_pd(lane, _mm256_set1_pd(f2));
    const __m256d g0 = _mm256_set1_pd(4.0 * f0), g1 = _mm256_set1_pd(4.0 * f1), g2 = _mm256_set1_pd(4.0 * f2);
    // (in locals: a sum in a struct went through memory every group)
    __m256d x = _mm256_setzero_pd(), y = _mm256_setzero_pd();
    double q2 = 0.0;
    index_t used = 0;
    for (index_t i = 0; i < n_runs; ++i) {
        const FitRun& run = runs[i];
        const double* values = image.values.row(run.r);
        const bool* valid = image.valid.row(run.r);
        if (i + PREFETCH_RUNS < n_runs) {  // the pixels of a row further down asked for now
            const FitRun& ahead = runs[i + PREFETCH_RUNS];
            const double* row = image.values.row(ahead.r);
            for (index_t c = ahead.first; c < ahead.last; c += 8)
                _mm_prefetch(reinterpret_cast<const char*>(row + c), _MM_HINT_T0);
            _mm_prefetch(reinterpret_cast<const char*>(row + ahead.last), _MM_HINT_T0);
            _mm_prefetch(reinterpret_cast<const char*>(image.valid.row(ahead.r) + ahead.first), _MM_HINT_T0);
        }
        __m256d e0 = _mm256_add_pd(_mm256_set1_pd(static_cast<double>(run.w0)), d0);
        __m256d e1 = _mm256_add_pd(_mm256_set1_pd(static_cast<double>(run.w1)), d1);
        __m256d e2 = _mm256_add_pd(_mm256_set1_pd(static_cast<double>(run.w2)), d2);
        const index_t last = run.last, end = std::min(last, cols - 1) - 3;
        index_t col = run.first;
        for (; col <= end; col += 4) {
            fit_four(values + col, valid_bits(valid + col), e0, e1, e2, k, x, y, q2, used);
            e0 = _mm256_add_pd(e0, g0);
            e1 = _mm256_add_pd(e1, g1);
            e2 = _mm256_add_pd(e2, g2);
        }
        if (col > last) continue;
        const unsigned lanes = (1u << static_cast<unsigned>(last - col + 1)) - 1u;  // 1 to 3 pixels left
        if (col + 3 < cols) {
            fit_four(values + col, valid_bits(valid + col) & lanes, e0, e1, e2, k, x, y, q2, used);
        } else {
            alignas(32) double tail[4] = {0.0, 0.0, 0.0, 0.0};
            bool flags[4] = {false, false, false, false};
            for (index_t j = 0; col + j <= last; ++j) {
                tail[j] = values[col + j];
                flags[j] = valid[col + j];
            }
            fit_four(tail, valid_bits(flags), e0, e1, e2, k, x, y, q2, used);
        }
    }
    alignas(32) double xs[4], ys[4];
    _mm256_store_pd(xs, x);
    _mm256_store_pd(ys, y);
    // m00 m01 m02 m11 m12 m22 q0 q1 q2
    sums[0] = xs[0];
    sums[1] = ys[0];
    sums[2] = ys[2];
    sums[3] = xs[1];
    sums[4] = ys[1];
    sums[5] = xs[2];
    sums[6] = xs[3];
    sums[7] = ys[3];
    sums[8] = q2;
    return used;
}

// The errors |value - mesh value| of the valid pixels of a face's rows `runs` into `out`, in
// row-major order, four columns at once (each lane the scalar loop's IEEE operations); returns
// how many. `out` has room for the rows' pixels.
__attribute__((target("avx"))) index_t face_errors_avx(const FitImage& image, const FitRun* runs, index_t n_runs,
                                                       double inv, double az, double bz, double cz, double f0,
                                                       double f1, double f2, double* out) {
    const index_t cols = image.values.cols;
    const __m256d scale = _mm256_set1_pd(inv), za = _mm256_set1_pd(az), zb = _mm256_set1_pd(bz),
                  zc = _mm256_set1_pd(cz), magnitude = _mm256_castsi256_pd(_mm256_set1_epi64x(0x7fffffffffffffff));
    const __m256d lane = _mm256_set_pd(3.0, 2.0, 1.0, 0.0);
    const __m256d d0 = _mm256_mul_pd(lane, _mm256_set1_pd(f0)), d1 = _mm256_mul_pd(lane, _mm256_set1_pd(f1)),
                  d2 = _mm256_mul_pd(lane, _mm256_set1_pd(f2));
    const __m256d g0 = _mm256_set1_pd(4.0 * f0), g1 = _mm256_set1_pd(4.0 * f1), g2 = _mm256_set1_pd(4.0 * f2);
    index_t k = 0;
    for (index_t i = 0; i < n_runs; ++i) {
        const FitRun& run = runs[i];
        const double* values = image.values.row(run.r);
        const bool* valid = image.valid.row(run.r);
        __m256d e0 = _mm256_add_pd(_mm256_set1_pd(static_cast<double>(run.w0)), d0);
        __m256d e1 = _mm256_add_pd(_mm256_set1_pd(static_cast<double>(run.w1)), d1);
        __m256d e2 = _mm256_add_pd(_mm256_set1_pd(static_cast<double>(run.w2)), d2);
        const index_t last = run.last, end = std::min(last, cols - 1) - 3;
        alignas(32) double tail[4] = {0.0, 0.0, 0.0, 0.0};
        for (index_t col = run.first; col <= last; col += 4) {
            unsigned lanes;
            const double* four = values + col;
            if (col <= end) {
                lanes = valid_bits(valid + col);
            } else if (col + 3 < cols) {  // the row's last 1 to 3 pixels
                lanes = valid_bits(valid + col) & ((1u << static_cast<unsigned>(last - col + 1)) - 1u);
            } else {  // ... at the image's right side: copies of them
                bool flags[4] = {false, false, false, false};
                for (index_t j = 0; col + j <= last; ++j) {
                    tail[j] = values[col + j];
                    flags[j] = valid[col + j];
                }
                lanes = valid_bits(flags);
                four = tail;
            }
            if (lanes != 0) {
                const __m256d la = _mm256_mul_pd(e1, scale), lb = _mm256_mul_pd(e2, scale),
                              lc = _mm256_mul_pd(e0, scale);
                const __m256d mesh =
                    _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(la, za), _mm256_mul_pd(lb, zb)), _mm256_mul_pd(lc, zc));
                const __m256d error = _mm256_and_pd(_mm256_sub_pd(_mm256_loadu_pd(four), mesh), magnitude);
                if (lanes == 15u) {
                    _mm256_storeu_pd(out + k, error);
                    k += 4;
                } else {
                    alignas(32) double e[4];
                    _mm256_store_pd(e, error);
                    for (unsigned j = 0; j < 4; ++j)
                        if ((lanes >> j) & 1u) out[k++] = e[j];
                }
            }
            e0 = _mm256_add_pd(e0, g0);
            e1 = _mm256_add_pd(e1, g1);
            e2 = _mm256_add_pd(e2, g2);
        }
    }
    return k;
}
#endif

// Calls visit(la, lb, lc, value, error) for each valid pixel the face owns on the rows that are
// multiples of `row_stride`: la, lb, lc the barycentric weights of corners a, b, c, `value` the
// pixel's and `error` its distance to the mesh at the vertices' copied values. Returns how many
// calls returned true (counted here, in a register: a count behind a reference stayed in memory).
// The vertices lie in the image (`check_mesh`).
template <class Visit, class W = NoWide>
index_t visit_pixels(const FitMesh& mesh, const FitImage& image, Corners v, index_t row_stride, Visit&& visit,
                     [[maybe_unused]] W&& wide = NoWide{}) {
    const index_t ar = mesh.rows[v.a], ac = mesh.cols[v.a];
    const index_t br = mesh.rows[v.b], bc = mesh.cols[v.b];
    const index_t cr = mesh.rows[v.c], cc = mesh.cols[v.c];
    // the first row at or below the face's top that is a multiple of row_stride (rows are >= 0)
    const index_t top = std::min(ar, std::min(br, cr));
    const index_t first = (top + row_stride - 1) / row_stride * row_stride;
    const index_t bottom = std::max(ar, std::max(br, cr));
    if (first > bottom) return 0;  // no sampled row: not even the walk's set-up
    const index_t area = orient<index_t>(ar, ac, br, bc, cr, cc);
    if (area == 0) return 0;
    const double az = mesh.values[v.a], bz = mesh.values[v.b], cz = mesh.values[v.c];
    const double inv = 1.0 / static_cast<double>(area);
    const EdgeOwnership own{owns(ar, ac, br, bc), owns(br, bc, cr, cc), owns(cr, cc, ar, ac)};
    // the edge functions grow by these a column (integers, held exactly as float64 too: the
    // floats the weights are made of, without an int-to-float conversion a weight and pixel)
    const index_t d0 = br - ar, d1 = cr - br, d2 = ar - cr;
    const double f0 = static_cast<double>(d0), f1 = static_cast<double>(d1), f2 = static_cast<double>(d2);
    index_t count = 0;
    // the pixels first..last of row r, where the edge functions are w0, w1, w2 at `first`
    const auto row = [&](index_t r, index_t first, index_t last, index_t w0, index_t w1, index_t w2) {
        const bool* valid = image.valid.row(r);
        const double* values = image.values.row(r);
        double e0 = static_cast<double>(w0), e1 = static_cast<double>(w1), e2 = static_cast<double>(w2);
        for (index_t col = first; col <= last; ++col) {
            if (valid[col]) {
                const double la = e1 * inv;
                const double lb = e2 * inv;
                const double lc = e0 * inv;
                const double value = values[col];
                count += visit(la, lb, lc, value, std::fabs(value - (la * az + lb * bz + lc * cz)));
            }
            e0 += f0;
            e1 += f1;
            e2 += f2;
        }
    };
    if (row_stride == 1) {
        // the edge functions at (r, c) are orient(P, Q, (r, c)) = s c - t r + k, for edge P -> Q
        const index_t t0 = bc - ac, t1 = cc - bc, t2 = ac - cc;
        const index_t k0 = t0 * ar - d0 * ac, k1 = t1 * br - d1 * bc, k2 = t2 * cr - d2 * cc;
        const index_t left = std::min(ac, std::min(bc, cc));
        const index_t right = std::max(ac, std::max(bc, cc));
        if (right - left < BOX_MAX_WIDTH) {
            // a narrow face: each row's span found by stepping along its bounding box's row, no
            // set-up beyond the edge functions. A pixel is the face's where each edge function
            // is > 0, or 0 on an edge that owns it: the spans of TriangleRows, in the same order
            const index_t o0 = own.ab ? 0 : 1, o1 = own.bc ? 0 : 1, o2 = own.ca ? 0 : 1;
            // g = w - o at the box's left column: the pixel is the face's where no g is negative
            index_t g0 = d0 * left - t0 * top + k0 - o0, g1 = d1 * left - t1 * top + k1 - o1,
                    g2 = d2 * left - t2 * top + k2 - o2;
            for (index_t r = top; r <= bottom; ++r, g0 -= t0, g1 -= t1, g2 -= t2) {
                index_t h0 = g0, h1 = g1, h2 = g2, col = left;
                while (col < right && (h0 | h1 | h2) < 0) {  // to the span's first pixel
                    ++col;
                    h0 += d0;
                    h1 += d1;
                    h2 += d2;
                }
                if ((h0 | h1 | h2) < 0) continue;  // none on this row
                const index_t first = col, w0 = h0 + o0, w1 = h1 + o1, w2 = h2 + o2;
                // to its last (a triangle is convex: its pixels on a row are one run)
                while (col < right && ((h0 + d0) | (h1 + d1) | (h2 + d2)) >= 0) {
                    ++col;
                    h0 += d0;
                    h1 += d1;
                    h2 += d2;
                }
                row(r, first, col, w0, w1, w2);
            }
            return count;
        }
        // else TriangleSpans' walk, the same spans at two edge steps a row instead of
        // TriangleRows' three steps and three clips, and half its set-up's divisions
        TriangleSpans spans(ar, ac, br, bc, cr, cc, own.ab, own.bc, own.ca);
#if RANGEMESH_AVX
        if constexpr (!std::is_same_v<std::decay_t<W>, NoWide>) {
            // about area / 2 pixels on bottom - top + 1 rows: long ones run four columns at once
            if (wide.on && area >= 2 * AVX_MIN_RUN * (bottom - top + 1)) {
                const std::size_t rows = static_cast<std::size_t>(bottom - top + 1);
                if (wide.runs.size() < rows) wide.runs.resize(rows);
                FitRun* const out = wide.runs.data();
                index_t n = 0;
                spans.walk([&](index_t r, index_t first, index_t last) {
                    out[n++] = FitRun{
                        r, first, last, d0 * first - t0 * r + k0, d1 * first - t1 * r + k1, d2 * first - t2 * r + k2};
                    return true;
                });
                return wide.take(WideFace{n, inv, az, bz, cz, f0, f1, f2}, static_cast<const FitRun*>(out));
            }
        }
#endif
        spans.walk([&](index_t r, index_t first, index_t last) {
            row(r, first, last, d0 * first - t0 * r + k0, d1 * first - t1 * r + k1, d2 * first - t2 * r + k2);
            return true;
        });
        return count;
    }
    TriangleRows walk(ar, ac, br, bc, cr, cc, first, row_stride);
    owned_rows(walk, first, bottom, row_stride, own, [&](index_t r, const RowSpan& span) {
        row(r, span.first, span.last, span.w0, span.w1, span.w2);
        return true;
    });
    return count;
}

// Two doubles multiplied and added lane by lane: one SSE2 (or NEON) instruction each where the
// compiler has vector types, two scalar ones elsewhere; the same IEEE operations either way.
#if defined(__GNUC__)
using Pair = double __attribute__((vector_size(16)));
#else
struct Pair {
    double x[2];
    double operator[](int k) const { return x[k]; }
    friend Pair operator*(const Pair& a, const Pair& b) { return {{a.x[0] * b.x[0], a.x[1] * b.x[1]}}; }
    Pair& operator+=(const Pair& b) {
        x[0] += b.x[0];
        x[1] += b.x[1];
        return *this;
    }
};
#endif

// The blocks of the faces order[first..last) (blocks[i] for face order[i]); returns the pixels used.
index_t accumulate(const FitMesh& mesh, const FitImage& image, Span<const index_t> order, double threshold,
                   Span<FaceBlock> blocks, index_t first, index_t last) {
    index_t used = 0;
#if RANGEMESH_AVX
    double m[9];         // a face of long rows: its sums, m00 m01 m02 m11 m12 m22 q0 q1 q2
    bool taken = false;  // (this face's)
    const auto take = [&](const WideFace& f, const FitRun* runs) {
        taken = true;
        return face_sums_avx(image, runs, f.n, f.inv, f.az, f.bz, f.cz, f.f0, f.f1, f.f2, threshold, m);
    };
    Wide<decltype(take)> wide{has_avx(), take, {}};
#else
    const NoWide wide;
#endif
    for (index_t i = first; i < last; ++i) {
        // once a face: polling within faces slows the pass, and even a face as large as the
        // image ends well within Ctrl-C's 0.2 s
        poll_interrupt();
        const Corners v = ccw_corners(mesh, order[i]);
        // the sums of this face, two a register, written to its block once (nine scalar sums
        // and the weights did not fit the sixteen registers: each sum went to memory a pixel)
        Pair s0{0.0, 0.0}, s1{0.0, 0.0}, s2{0.0, 0.0}, s3{0.0, 0.0};  // m00 m01, m02 m11, m12 m22, q0 q1
        double q2 = 0.0;
        used += visit_pixels(
            mesh, image, v, 1,
            [&](double la, double lb, double lc, double value, double error) {
                if (!(error <= threshold)) return false;
                const Pair ab{la, lb};
                s0 += Pair{la, la} * ab;
                s1 += ab * Pair{lc, lb};
                s2 += Pair{lb, lc} * Pair{lc, lc};
                s3 += ab * Pair{value, value};
                q2 += lc * value;
                return true;
            },
            wide);
#if RANGEMESH_AVX
        if (taken) {
            taken = false;
            blocks[i] = FaceBlock{
                {v.a, v.b, v.c}, {{m[0], m[1], m[2]}, {m[1], m[3], m[4]}, {m[2], m[4], m[5]}}, {m[6], m[7], m[8]}};
            continue;
        }
#endif
        const double m00 = s0[0], m01 = s0[1], m02 = s1[0], m11 = s1[1], m12 = s2[0], m22 = s2[1];
        blocks[i] = FaceBlock{{v.a, v.b, v.c}, {{m00, m01, m02}, {m01, m11, m12}, {m02, m12, m22}}, {s3[0], s3[1], q2}};
    }
    return used;
}

// A face's set-up beside its pixels, in units of twice a pixel's area (the weights of `weighted_bounds`).
constexpr double FACE_SETUP = 40.0;

// Where `parts` contiguous ranges of the faces visited in `order` start (and the last ends),
// each about an equal share of the faces' summed weight: twice the area plus a face's set-up.
std::vector<index_t> weighted_bounds(const FitMesh& mesh, Span<const index_t> order, index_t parts) {
    const index_t n = order.size;
    std::vector<double> cum(static_cast<std::size_t>(n) + 1, 0.0);
    for (index_t i = 0; i < n; ++i) {
        poll_every(i);
        const index_t t = order[i];
        const index_t a = mesh.faces(t, 0), b = mesh.faces(t, 1), c = mesh.faces(t, 2);
        const index_t area =
            orient<index_t>(mesh.rows[a], mesh.cols[a], mesh.rows[b], mesh.cols[b], mesh.rows[c], mesh.cols[c]);
        cum[i + 1] = cum[i] + static_cast<double>(area < 0 ? -area : area) + FACE_SETUP;
    }
    std::vector<index_t> bounds(static_cast<std::size_t>(parts) + 1, n);
    bounds[0] = 0;
    for (index_t k = 1; k < parts; ++k) {
        const double share = cum[n] * static_cast<double>(k) / static_cast<double>(parts);
        const index_t at = static_cast<index_t>(std::lower_bound(cum.begin(), cum.end(), share) - cum.begin());
        bounds[k] = std::max(bounds[k - 1], std::min(at, n));
    }
    return bounds;
}

}  // namespace

void check_order(const FitMesh& mesh, Span<const index_t> order) {
    bool faces = true;
    for (const index_t t : order) faces &= static_cast<std::uint64_t>(t) < static_cast<std::uint64_t>(mesh.faces.rows);
    check_input(faces, "fit: an order entry is not a face");
}

index_t sample_errors(const FitMesh& mesh, const FitImage& image, Span<const index_t> order, Sample sample,
                      Span<double> errors, int threads) {
    check_order(mesh, order);
    return sample_errors_checked(mesh, image, order, sample, errors, threads);
}

index_t sample_errors_checked(const FitMesh& mesh, const FitImage& image, Span<const index_t> order, Sample sample,
                              Span<double> errors, int threads) {
    check_input(sample.row_stride > 0 && sample.face_stride > 0, "fit: strides are positive");
    // a stride beyond the rows (faces) samples row (face) 0 alone, as the rows (faces) do: the
    // same rows, and no sum past int64 in the walk (a raw call's stride of 2^62)
    const index_t row_stride = std::min(sample.row_stride, std::max<index_t>(image.values.rows, 1));
    const index_t face_stride = std::min(sample.face_stride, std::max<index_t>(order.size, 1));
    const index_t n = order.size == 0 ? 0 : (order.size - 1) / face_stride + 1;  // the faces sampled
    // the errors of sampled faces [begin, end), in order, to `put` while it takes them
    const auto visit = [&](index_t begin, index_t end, auto&& put) {
#if RANGEMESH_AVX
        std::vector<double> face;  // a face of long rows: its errors
        const auto take = [&](const WideFace& f, const FitRun* runs) {
            index_t pixels = 0;
            for (index_t i = 0; i < f.n; ++i) pixels += runs[i].last - runs[i].first + 1;
            if (face.size() < static_cast<std::size_t>(pixels)) face.resize(static_cast<std::size_t>(pixels));
            const index_t k = face_errors_avx(image, runs, f.n, f.inv, f.az, f.bz, f.cz, f.f0, f.f1, f.f2, face.data());
            for (index_t i = 0; i < k; ++i) put(face[static_cast<std::size_t>(i)]);
            return index_t{0};
        };
        Wide<decltype(take)> wide{has_avx(), take, {}};
#else
        const NoWide wide;
#endif
        for (index_t j = begin; j < end; ++j) {
            poll_interrupt();
            visit_pixels(
                mesh, image, ccw_corners(mesh, order[j * face_stride]), row_stride,
                [&](double, double, double, double, double error) {
                    put(error);  // overlapping faces could visit a pixel twice
                    return false;
                },
                wide);
        }
    };
    if (threads < 2 || n < SAMPLE_SPLIT_MIN_FACES) {
        index_t k = 0;
        visit(0, n, [&](double error) {
            if (k < errors.size) errors[k++] = error;
        });
        return k;
    }
    // contiguous ranges of the sampled faces, one a thread, each into its own list; then joined
    // in order as far as `errors` holds them: the serial walk's errors, in its order
    const index_t parts = std::min<index_t>(threads, std::max<index_t>(2, n / (SAMPLE_SPLIT_MIN_FACES / 2)));
    std::vector<std::vector<double>> lists(static_cast<std::size_t>(parts));
    split_run(parts, n, [&](index_t p, index_t begin, index_t end) {
        std::vector<double>& list = lists[static_cast<std::size_t>(p)];
        visit(begin, end, [&](double error) {
            if (static_cast<index_t>(list.size()) < errors.size) list.push_back(error);
        });
    });
    index_t k = 0;
    for (const std::vector<double>& list : lists) {
        const index_t take = std::min(static_cast<index_t>(list.size()), errors.size - k);
        std::copy(list.begin(), list.begin() + take, errors.data + k);
        k += take;
    }
    return k;
}

index_t fit_blocks(const FitMesh& mesh, const FitImage& image, Span<const index_t> order, double threshold, int threads,
                   Span<FaceBlock> blocks) {
    check_order(mesh, order);
    return fit_blocks_checked(mesh, image, order, threshold, threads, blocks);
}

index_t fit_blocks_checked(const FitMesh& mesh, const FitImage& image, Span<const index_t> order, double threshold,
                           int threads, Span<FaceBlock> blocks) {
    require(blocks.size == order.size, "fit: one block a visited face");
    const index_t n = order.size;
    if (threads < 2 || n < SPLIT_MIN_FACES) return accumulate(mesh, image, order, threshold, blocks, 0, n);
    // contiguous ranges, one a thread (at most one a SPLIT_MIN_FACES / 2 faces), of about equal
    // pixels: each face's weight its area plus a row walk's set-up; each face writes its own block
    const index_t parts = std::min<index_t>(threads, std::max<index_t>(2, n / (SPLIT_MIN_FACES / 2)));
    std::vector<index_t> bounds = weighted_bounds(mesh, order, parts);
    std::vector<index_t> used(static_cast<std::size_t>(parts), 0);
    split_run(parts, parts, [&](index_t k, index_t, index_t) {
        const std::size_t p = static_cast<std::size_t>(k);
        used[p] = accumulate(mesh, image, order, threshold, blocks, bounds[p], bounds[p + 1]);
    });
    index_t total = 0;
    for (const index_t u : used) total += u;
    return total;
}

}  // namespace rangemesh::heights
