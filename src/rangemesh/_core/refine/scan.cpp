#include "scan.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "../geometry/ownership.hpp"
#include "../geometry/predicates.hpp"
#include "../geometry/raster.hpp"
#include "keys.hpp"

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
        for (index_t c = span.first; c <= span.last; ++c) {
            if (!valid(r, c)) continue;
            const index_t k = c - span.first;
            const index_t w0 = span.w0 + s0 * k, w1 = span.w1 + s1 * k, w2 = span.w2 + s2 * k;
            best.seen = true;
            if (is_corner(r, c, a, b, cn)) continue;
            if ((w0 == 0 && !lost0) || (w1 == 0 && !lost1) || (w2 == 0 && !lost2)) continue;
            const index_t w = weight(w0, w1, w2);
            if (w > best.weight) {  // row-major visit: an equal weight never replaces the first
                best.weight = w;
                best.r = r;
                best.c = c;
            }
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
    plane_errors(
        image, {a.r, a.c, a.z}, {b.r, b.c, b.z}, {cn.r, cn.c, cn.z}, own,
        [&](index_t r, index_t c, double err) {
            total += err;
            if (err > records.largest() && !is_corner(r, c, a, b, cn)) records.add(r, c, err);
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
