// Kernels on the pixel grid: a raw image's float depth and validity, the range of the valid
// depths, a rendering's error, the faces on valid pixels, the nearest valid pixel, a start grid.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <vector>

#include "../interrupt.hpp"
#include "../views.hpp"

namespace rangemesh {

// Float depth (0.0 on background, a value no later stage reads) and validity of a raw image:
// NaN, inf and `background` are invalid. Values are compared as float64, as NumPy compares
// integers with a float marker.
// A float marker as a value of the integer type T, when some T equals it (`exact`).
template <class T>
struct IntegerMarker {
    bool exact = false;
    T value{};
    explicit IntegerMarker(double marker) {
        if constexpr (std::is_integral_v<T> && sizeof(T) <= 4) {  // wider ones stay float64
            if (marker >= static_cast<double>(std::numeric_limits<T>::min()) &&
                marker <= static_cast<double>(std::numeric_limits<T>::max()) && std::trunc(marker) == marker) {
                value = static_cast<T>(marker);
                exact = static_cast<double>(value) == marker;
            }
        }
    }
};

template <class T>
void mask_image(Grid<const T> image, bool has_background, double background, Grid<double> depth, Grid<bool> valid) {
    // NaN as the marker when there is none: x != NaN holds for every x. Written without
    // branches, each loop over a row vectorises (a mixed bool and double store in one loop did
    // not, and mispredicted on scattered holes).
    const double bg = has_background ? background : std::numeric_limits<double>::quiet_NaN();
    constexpr double big = std::numeric_limits<double>::max();
    const IntegerMarker<T> marker(bg);
    for (index_t r = 0; r < image.rows; ++r) {
        poll_interrupt();
        const T* in = image.row(r);
        double* d = depth.row(r);
        bool* v = valid.row(r);
        for (index_t c = 0; c < image.cols; ++c) {
            const double x = static_cast<double>(in[c]);
            d[c] = (std::abs(x) <= big && x != bg) ? x : 0.0;  // |x| <= max: finite
        }
        if constexpr (std::is_integral_v<T> && sizeof(T) <= 4) {
            // exact in float64: compared as T, the loop vectorises
            for (index_t c = 0; c < image.cols; ++c) v[c] = !(marker.exact && in[c] == marker.value);
        } else {
            // `&`, not `&&`: both compares on every pixel, and the loop vectorises
            for (index_t c = 0; c < image.cols; ++c) {
                const double x = static_cast<double>(in[c]);
                v[c] = static_cast<bool>(static_cast<int>(std::abs(x) <= big) & static_cast<int>(x != bg));
            }
        }
    }
}

// The smallest and largest valid depth and the number of valid pixels; all 0 when none is.
struct DepthRange {
    double lo = 0.0, hi = 0.0;
    index_t count = 0;
};
DepthRange valid_range(Grid<const double> depth, Grid<const bool> valid);

// The summed |pred - depth| over the valid pixels where `pred` is finite, and their number.
struct CoveredError {
    double total = 0.0;
    index_t count = 0;
};
CoveredError covered_error(Grid<const double> pred, Grid<const double> depth, Grid<const bool> valid);

// The same over the pixels a render `claimed` (its other values unread, unset), each valid
// pixel's prediction read as map(pred) (a render's stored values in depth units), and with
// `range`, `valid_range(depth, valid)` in the same pass: one read of the image.
template <class Map>
CoveredError covered_error(Grid<const double> pred, Grid<const unsigned char> claimed, Grid<const double> depth,
                           Grid<const bool> valid, Map&& map, DepthRange* range) {
    CoveredError out;
    double lo = INFINITY, hi = -INFINITY;
    index_t n_valid = 0;
    for (index_t r = 0; r < depth.rows; ++r) {
        poll_interrupt();
        const double* prow = pred.row(r);
        const unsigned char* crow = claimed.row(r);
        const double* drow = depth.row(r);
        const bool* vrow = valid.row(r);
        for (index_t c = 0; c < depth.cols; ++c) {
            if (!vrow[c]) continue;
            const double x = drow[c];
            if (range != nullptr) {  // (valid_range's tests, in its order)
                ++n_valid;
                if (x < lo) lo = x;
                if (x > hi) hi = x;
            }
            if (!crow[c]) continue;  // (a NaN prediction: not finite)
            const double p = map(prow[c]);
            if (std::isfinite(p)) {
                out.total += std::abs(p - x);
                ++out.count;
            }
        }
    }
    if (range != nullptr) {
        *range = DepthRange{};
        range->count = n_valid;
        if (n_valid > 0) {
            range->lo = lo;
            range->hi = hi;
        }
    }
    return out;
}

// The triangles (vertex ids `tv`, three a triangle) whose corners are all valid pixels, renumbered
// over the vertices they use (in vertex order), and those vertices' (row, col).
struct ValidFaces {
    std::vector<std::int32_t> faces;   // 3 per kept triangle
    std::vector<std::int32_t> pixels;  // (row, col) per used vertex
};
ValidFaces valid_faces(Span<const index_t> vr, Span<const index_t> vc, Span<const index_t> tv, Grid<const bool> valid);

// Face t's corners as (row, col) doubles, and whether it is a wrap-around seam face (clockwise and
// wider than half the image's `width`), which covers no pixel centre: every render of ValidFaces skips it.
struct FaceCorners {
    double r[3], c[3];
    bool wraps(index_t width) const {
        const double area = (r[1] - r[0]) * (c[2] - c[0]) - (c[1] - c[0]) * (r[2] - r[0]);
        return area < 0 && std::max({c[0], c[1], c[2]}) - std::min({c[0], c[1], c[2]}) > 0.5 * width;
    }
};
inline FaceCorners face_corners(const ValidFaces& f, index_t t) {
    FaceCorners fc;
    for (int k = 0; k < 3; ++k) {
        const index_t v = f.faces[3 * t + k];
        fc.r[k] = static_cast<double>(f.pixels[2 * v]);
        fc.c[k] = static_cast<double>(f.pixels[2 * v + 1]);
    }
    return fc;
}

// The valid pixel nearest (r, c), ties to the smallest (row, col); (-1, -1) when there is none.
struct Pixel {
    index_t r, c;
};
Pixel nearest_valid(Grid<const bool> valid, index_t r, index_t c);

// The corners of columns c_lo..c_hi, then the valid centres of an n_rows x n_cols grid over them.
struct PixelList {
    std::vector<index_t> rows, cols;
};
PixelList grid_pixels(Grid<const bool> valid, index_t n_rows, index_t n_cols, index_t c_lo, index_t c_hi, bool inner);

}  // namespace rangemesh
