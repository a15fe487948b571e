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

}  // namespace

std::vector<index_t> join_strips(const StripMesh& a, const StripMesh& b, index_t m, Worker* second, Halves& out,
                                 std::vector<double>* sums) {
    const index_t n_av = static_cast<index_t>(a.vr.size()), n_bv = static_cast<index_t>(b.vr.size());
    const index_t n_a = static_cast<index_t>(a.triangles.size()), n_b = static_cast<index_t>(b.triangles.size());
    require(static_cast<index_t>(a.halfedges.size()) == n_a && static_cast<index_t>(b.halfedges.size()) == n_b,
            "strip_insert: one twin a half-edge");
    out.vr.resize(n_av + n_bv);  // (cut to the vertices B adds once counted)
    out.vc.resize(n_av + n_bv);
    out.triangles.resize(n_a + n_b);
    out.halfedges.resize(n_a + n_b);
    if (sums != nullptr) sums->resize(a.sums.size() + b.sums.size());
    // B's vertex ids in the joined mesh, written out when `write`; returns the joined vertex count.
    // Each part numbers them for itself: a step a vertex, against several a half-edge.
    const auto number_b = [&](std::vector<index_t>& new_id, bool write) {
        std::vector<std::pair<index_t, index_t>> seam_ids;  // (row, id) of A's seam vertices
        for (index_t i = 0; i < n_av; ++i)
            if (a.vc[i] == m) seam_ids.emplace_back(a.vr[i], i);
        std::sort(seam_ids.begin(), seam_ids.end());
        new_id.resize(n_bv);
        index_t next = n_av;
        for (index_t j = 0; j < n_bv; ++j) {
            poll_every(j);
            if (b.vc[j] != m) {
                if (write) {
                    out.vr[next] = b.vr[j];
                    out.vc[next] = b.vc[j];
                }
                new_id[j] = next++;
                continue;
            }
            const auto at =
                std::lower_bound(seam_ids.begin(), seam_ids.end(), std::pair<index_t, index_t>{b.vr[j], -1});
            require(at != seam_ids.end() && at->first == b.vr[j], "strip_insert: the strips' seams differ");
            new_id[j] = at->second;
        }
        return next;
    };
    // B's half-edges [begin, end) renumbered; (v * n_v + u, e) of those down the seam (u -> v) into `keys`
    const auto renumber_b = [&](const std::vector<index_t>& new_id, index_t n_v, index_t begin, index_t end,
                                std::vector<std::pair<index_t, index_t>>& keys) {
        for (index_t e = begin; e < end; ++e) {
            poll_every(e);
            const index_t u = b.triangles[e], g = b.halfedges[e];
            out.triangles[n_a + e] = new_id[u];
            out.halfedges[n_a + e] = g >= 0 ? g + n_a : -1;
            if (g < 0 && b.vc[u] == m && b.vc[b.triangles[nxt(e)]] == m)
                keys.emplace_back(new_id[b.triangles[nxt(e)]] * n_v + new_id[u], n_a + e);
        }
    };
    // A's copies and seam scan weigh about half of B's renumbering: A's part takes a third of B's half-edges
    const index_t cut = n_b / 3;
    std::vector<index_t> seam_a;                                 // A's half-edges down the seam, in order
    std::vector<std::pair<index_t, index_t>> keys_lo, keys_hi;  // B's, before and after `cut`
    index_t n_v = n_av;
    const auto part_a = [&] {
        std::copy(a.vr.begin(), a.vr.end(), out.vr.begin());
        std::copy(a.vc.begin(), a.vc.end(), out.vc.begin());
        std::copy(a.triangles.begin(), a.triangles.end(), out.triangles.begin());
        std::copy(a.halfedges.begin(), a.halfedges.end(), out.halfedges.begin());
        if (sums != nullptr) std::copy(a.sums.begin(), a.sums.end(), sums->begin());
        for (index_t e = 0; e < n_a; ++e) {
            poll_every(e);
            if (a.halfedges[e] < 0 && a.vc[a.triangles[e]] == m && a.vc[a.triangles[nxt(e)]] == m) seam_a.push_back(e);
        }
        std::vector<index_t> new_id;
        renumber_b(new_id, number_b(new_id, false), 0, cut, keys_lo);
    };
    const auto part_b = [&] {
        std::vector<index_t> new_id;
        n_v = number_b(new_id, true);
        renumber_b(new_id, n_v, cut, n_b, keys_hi);
        if (sums != nullptr)
            std::copy(b.sums.begin(), b.sums.end(), sums->begin() + static_cast<index_t>(a.sums.size()));
    };
    run_both(second, part_a, part_b);
    out.vr.resize(n_v);
    out.vc.resize(n_v);
    out.total = a.total + b.total;
    std::vector<std::pair<index_t, index_t>>& keys_b = keys_lo;
    keys_b.insert(keys_b.end(), keys_hi.begin(), keys_hi.end());
    std::sort(keys_b.begin(), keys_b.end());
    require(seam_a.size() == keys_b.size(), "strip_insert: the strips' edges down the seam differ");
    std::vector<index_t>& he = out.halfedges;
    for (const index_t e : seam_a) {
        const index_t key = out.triangles[e] * n_v + out.triangles[nxt(e)];
        const auto at = std::lower_bound(keys_b.begin(), keys_b.end(), std::pair<index_t, index_t>{key, -1});
        require(at != keys_b.end() && at->first == key, "strip_insert: the strips' edges down the seam differ");
        he[e] = at->second;
        he[at->second] = e;
    }
    return seam_a;
}

Halves insert_halves(const Image& image, const HalvesRequest& req, Worker* second) {
    // a second thread of its own when the caller has none, started first (its start overlaps the
    // seam's choice): the strips' first meshes run on both threads too
    std::optional<Worker> worker;
    if (req.threads < 2) {
        second = nullptr;
    } else if (second == nullptr) {
        worker.emplace();
        second = &*worker;
    }
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
    Halves out;
    std::vector<double> sums;  // (the seam's flips only)
    const std::vector<index_t> first = join_strips(s.left, s.right, m, second, out, req.flip ? &sums : nullptr);
    out.flips = s.left.flips + s.right.flips;
    out.total = out.total + seam;
    if (req.flip) {
        const FlipMesh mesh{view(out.vr),
                            view(out.vc),
                            {out.triangles.data(), static_cast<index_t>(out.triangles.size())},
                            {out.halfedges.data(), static_cast<index_t>(out.halfedges.size())},
                            {sums.data(), static_cast<index_t>(sums.size())}};
        out.flips += flip_from_edges(image, mesh, view(first), false).flips;  // (checked as made)
    }
    return out;
}

}  // namespace rangemesh::refine
