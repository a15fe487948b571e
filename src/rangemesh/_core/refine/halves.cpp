#include "halves.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <utility>

#include "../geometry/delaunay.hpp"
#include "../geometry/halfedges.hpp"
#include "../geometry/pixels.hpp"
#include "../parallel.hpp"
#include "diagonals.hpp"
#include "insertion.hpp"
#include "start.hpp"
#include "strips.hpp"

namespace rangemesh::refine {

namespace {

// Each column's valid pixels: byte sums over blocks of 255 rows (a bool is one byte, 0 or 1), a
// loop the compiler vectorises: it visits every pixel of the image before the threads start.
std::vector<index_t> count_columns(Grid<const bool> valid) {
    const index_t w = valid.cols;
    std::vector<index_t> into(w, 0);
    std::vector<std::uint8_t> sums(w);
    std::uint8_t* const s = sums.data();
    for (index_t r = 0; r < valid.rows;) {
        const index_t end = std::min(valid.rows, r + 255);
        std::fill(sums.begin(), sums.end(), 0);
        for (; r < end; ++r) {
            const auto* const row = reinterpret_cast<const std::uint8_t*>(valid.row(r));
            for (index_t c = 0; c < w; ++c) s[c] = static_cast<std::uint8_t>(s[c] + row[c]);
        }
        for (index_t c = 0; c < w; ++c) into[c] += s[c];
    }
    return into;
}

// The column that halves the valid pixels, kept within the middle half (strips.py's `seam_column`).
index_t seam_column(Grid<const bool> valid) {
    const index_t w = valid.cols;
    std::vector<index_t> cum = count_columns(valid);
    for (index_t c = 1; c < w; ++c) cum[c] += cum[c - 1];
    index_t m = w / 2;
    if (cum[w - 1] > 0) {  // np.searchsorted(cum, cum[-1] / 2.0): the first column reaching half
        const double half = static_cast<double>(cum[w - 1]) / 2.0;
        m = 0;
        while (m < w && static_cast<double>(cum[m]) < half) ++m;
    }
    return std::min(std::max(m, w / 4), (3 * w) / 4);
}

// A first mesh (start.py's `first_mesh` with `cols` and `seam`): the strip's corners, about
// `n_grid` valid grid pixels strictly inside its columns, the seam's rows on column `seam_col`.
// A strip corner's depth: its own, or that of the nearest valid pixel of the strip.
double strip_corner(const Image& image, index_t r, index_t c, index_t c_lo, index_t c_hi) {
    if (image.valid(r, c)) return image.depth(r, c);
    const index_t h = image.rows(), w = c_hi - c_lo + 1;
    const std::unique_ptr<bool[]> own(new bool[h * w]);
    for (index_t i = 0; i < h; ++i)
        for (index_t j = 0; j < w; ++j) own[i * w + j] = image.valid(i, c_lo + j);
    const auto p = nearest_valid(Grid<const bool>{own.get(), h, w}, r, c - c_lo);
    check_input(p.r >= 0, "corner_depths: the image has no valid pixel");
    return image.depth(p.r, c_lo + p.c);
}

StartArrays strip_start(const Image& image, index_t n_grid, const HalvesRequest& req, index_t c_lo, index_t c_hi,
                        const std::vector<index_t>& seam, index_t seam_col) {
    const index_t h = image.rows(), w = c_hi - c_lo + 1, sr = req.sr, sc = req.sc;
    StartArrays s;
    s.vz = {strip_corner(image, 0, c_lo, c_lo, c_hi), strip_corner(image, h - 1, c_lo, c_lo, c_hi),
            strip_corner(image, h - 1, c_hi, c_lo, c_hi), strip_corner(image, 0, c_hi, c_lo, c_hi)};
    const index_t gr = n_grid >= 4 ? grid_side(n_grid * h * sr, w * sc) : 0;
    const index_t gc = n_grid >= 4 ? grid_side(n_grid * w * sc, h * sr) : 0;
    PixelList grid = grid_pixels(image.valid, gr, gc, c_lo, c_hi, true);
    s.vr = std::move(grid.rows);
    s.vc = std::move(grid.cols);
    for (const index_t r : seam)
        if (r > 0 && r < h - 1) {  // the corners are in already
            s.vr.push_back(r);
            s.vc.push_back(seam_col);
        }
    s.triangulate(image, sr, sc);
    return s;
}

// NumPy's sum of a contiguous float64 array: pairwise, eight accumulators in blocks of 128.
double numpy_sum(const double* a, index_t n) {
    if (n < 8) {
        double res = 0.0;
        for (index_t i = 0; i < n; ++i) res += a[i];
        return res;
    }
    if (n <= 128) {
        double r[8];
        for (int j = 0; j < 8; ++j) r[j] = a[j];
        index_t i = 8;
        for (; i < n - (n % 8); i += 8)
            for (int j = 0; j < 8; ++j) r[j] += a[i + j];
        double res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        for (; i < n; ++i) res += a[i];
        return res;
    }
    index_t n2 = n / 2;
    n2 -= n2 % 8;
    return numpy_sum(a, n2) + numpy_sum(a + n2, n - n2);
}

// The summed error of a column's valid pixels against the lines between its seam vertices
// (strips.py's `_seam_error`: np.interp's arithmetic, NumPy's sum).
double seam_error(const std::vector<double>& z, const bool* ok, const std::vector<index_t>& rows) {
    if (rows.size() < 2) return 0.0;
    std::vector<double> err;
    std::size_t j = 0;
    for (index_t r = rows.front() + 1; r < rows.back(); ++r) {
        if (!ok[r]) continue;
        while (rows[j + 1] <= r) ++j;  // rows[j] <= r < rows[j + 1]
        const double x = static_cast<double>(r), x0 = static_cast<double>(rows[j]);
        const double y0 = z[rows[j]], y1 = z[rows[j + 1]];
        const double line = x0 == x ? y0 : (y1 - y0) / (static_cast<double>(rows[j + 1]) - x0) * (x - x0) + y0;
        err.push_back(std::abs(z[r] - line));
    }
    return numpy_sum(err.data(), static_cast<index_t>(err.size()));
}

// Strip B's vertices renumbered after A's, its seam vertices A's own (strips.py's `_join`).
Halves join(const StripMesh& a, const StripMesh& b, index_t m) {
    std::vector<std::pair<index_t, index_t>> seam_a;  // (row, id) of A's seam vertices
    for (std::size_t i = 0; i < a.vr.size(); ++i)
        if (a.vc[i] == m) seam_a.emplace_back(a.vr[i], static_cast<index_t>(i));
    std::sort(seam_a.begin(), seam_a.end());
    Halves out;
    out.vr = a.vr;
    out.vc = a.vc;
    std::vector<index_t> new_id(b.vr.size());
    for (std::size_t j = 0; j < b.vr.size(); ++j) {
        if (b.vc[j] != m) {
            new_id[j] = static_cast<index_t>(out.vr.size());
            out.vr.push_back(b.vr[j]);
            out.vc.push_back(b.vc[j]);
            continue;
        }
        const auto at = std::lower_bound(seam_a.begin(), seam_a.end(), std::pair<index_t, index_t>{b.vr[j], -1});
        require(at != seam_a.end() && at->first == b.vr[j], "strip_insert: the strips' seams differ");
        new_id[j] = at->second;
    }
    out.triangles = a.triangles;
    for (const index_t v : b.triangles) out.triangles.push_back(new_id[v]);
    out.total = a.total + b.total;
    return out;
}

// The joined mesh's twins, A's half-edges down the seam paired with B's the other way
// (strips.py's `_joined_halfedges`); returns A's seam half-edges, in order.
std::vector<index_t> join_halfedges(const StripMesh& a, const StripMesh& b, const Halves& j, index_t m,
                                    std::vector<index_t>& he) {
    const index_t n_a = static_cast<index_t>(a.halfedges.size()), n_v = static_cast<index_t>(j.vc.size());
    he = a.halfedges;
    for (const index_t e : b.halfedges) he.push_back(e >= 0 ? e + n_a : -1);
    std::vector<index_t> seam_a;
    std::vector<std::pair<index_t, index_t>> keys_b;  // (v * n_v + u, e) of B's u -> v
    for (index_t e = 0; e < static_cast<index_t>(he.size()); ++e) {
        const index_t u = j.triangles[e], v = j.triangles[nxt(e)];
        if (he[e] >= 0 || j.vc[u] != m || j.vc[v] != m) continue;
        if (e < n_a)
            seam_a.push_back(e);
        else
            keys_b.emplace_back(v * n_v + u, e);
    }
    require(seam_a.size() == keys_b.size(), "strip_insert: the strips' edges down the seam differ");
    std::sort(keys_b.begin(), keys_b.end());
    for (const index_t e : seam_a) {
        const index_t key = j.triangles[e] * n_v + j.triangles[nxt(e)];
        const auto at = std::lower_bound(keys_b.begin(), keys_b.end(), std::pair<index_t, index_t>{key, -1});
        require(at != keys_b.end() && at->first == key, "strip_insert: the strips' edges down the seam differ");
        he[e] = at->second;
        he[at->second] = e;
    }
    return seam_a;
}

}  // namespace

Halves insert_halves(const Image& image, const HalvesRequest& req) {
    // the second thread started first (its start overlaps the seam's choice): the strips' first
    // meshes run on both threads too
    std::optional<Worker> worker;
    if (req.threads >= 2) worker.emplace();
    Worker* const second = worker ? &*worker : nullptr;
    const index_t h = image.rows(), w = image.cols(), m = seam_column(image.valid);
    std::vector<double> z(h);
    const std::unique_ptr<bool[]> ok(new bool[h]);
    index_t n_m = 0;
    for (index_t r = 0; r < h; ++r) {
        z[r] = image.depth(r, m);
        ok[r] = image.valid(r, m);
        n_m += ok[r];
    }
    const Span<const double> zs{z.data(), h};
    const Span<const bool> oks{ok.get(), h};
    std::vector<index_t> rows;
    if (req.max_sum >= 0.0) {  // the count is not known: the seam takes its column's share of the bound
        const double col_share = static_cast<double>(n_m) / static_cast<double>(std::max<index_t>(req.n_valid, 1));
        rows = seam_rows(zs, oks, h, req.seam_error_share * col_share * req.max_sum, image.span);
    } else {
        const double n = static_cast<double>(req.vertices * h * req.sr) / static_cast<double>(w * req.sc);
        rows = seam_rows(zs, oks, std::max<index_t>(2, round_even(req.seam_density * std::sqrt(n))), -1.0, image.span);
    }
    const double share = static_cast<double>(m) / static_cast<double>(w - 1);
    // each strip's first mesh made on its own thread, in `strip_insert`'s first phase
    StartArrays left, right;
    const auto starts = [&](int i) {
        if (i == 0)
            left =
                strip_start(image, static_cast<index_t>(static_cast<double>(req.n_grid) * share), req, 0, m, rows, m);
        else
            right = strip_start(image, static_cast<index_t>(static_cast<double>(req.n_grid) * (1 - share)), req, m,
                                w - 1, rows, m);
        return i == 0 ? left.view() : right.view();
    };
    // the seam's valid vertices, in both strips: the corners on its column and its rows between
    index_t shared = image.valid(0, m) + image.valid(h - 1, m);
    for (const index_t r : rows) shared += r > 0 && r < h - 1;  // (seam_rows chooses valid pixels)
    const double seam = seam_error(z, ok.get(), rows);
    const double budget = req.max_sum >= 0.0 ? std::max(req.max_sum - seam, 0.0) : -1.0;
    const StripRequest sreq{req.vertices,
                            req.vertices + shared,
                            req.max_sum < 0.0 ? req.vertices : 0,
                            budget,
                            req.sr,
                            req.sc,
                            req.threads,
                            true,
                            req.flip};
    const Strips s = strip_insert(image, starts, sreq, second);
    index_t on_seam = 0;
    for (std::size_t i = 0; i < left.vr.size(); ++i) on_seam += left.vc[i] == m && image.valid(left.vr[i], m);
    require(on_seam == shared, "insert_halves: the seam's vertices are the left strip's on its column");
    Halves out = join(s.left, s.right, m);
    out.flips = s.left.flips + s.right.flips;
    out.total = out.total + seam;
    std::vector<index_t>& he = out.halfedges;  // (the assembly walks the stars by them)
    const std::vector<index_t> first = join_halfedges(s.left, s.right, out, m, he);
    if (req.flip) {
        std::vector<double> sums = s.left.sums;
        sums.insert(sums.end(), s.right.sums.begin(), s.right.sums.end());
        const FlipMesh mesh{view(out.vr),
                            view(out.vc),
                            {out.triangles.data(), static_cast<index_t>(out.triangles.size())},
                            {he.data(), static_cast<index_t>(he.size())},
                            {sums.data(), static_cast<index_t>(sums.size())}};
        out.flips += flip_from_edges(image, mesh, view(first), false).flips;  // (checked as made)
    }
    return out;
}

}  // namespace rangemesh::refine
