#include "sampling.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "../geometry/predicates.hpp"
#include "../interrupt.hpp"
#include "../parallel.hpp"

namespace rangemesh::paper {

namespace {

// Whether the 8 neighbours of (r, c) are all valid.
bool all_neighbours_valid(Grid<bool> valid, index_t r, index_t c) {
    for (index_t dr = -1; dr <= 1; ++dr)
        for (index_t dc = -1; dc <= 1; ++dc)
            if ((dr != 0 || dc != 0) && !valid(r + dr, c + dc)) return false;
    return true;
}

}  // namespace

index_t fill_gaps_inplace(Grid<double> depth, Grid<bool> valid) {
    require(valid.rows == depth.rows && valid.cols == depth.cols, "fill_gaps_inplace: valid must have depth's shape");
    struct Fill {
        index_t r, c;
        double value;
    };
    std::vector<Fill> fills;
    for (index_t r = 1; r < depth.rows - 1; ++r) {
        poll_interrupt();
        const bool* row = valid.row(r);
        for (index_t c = 1; c < depth.cols - 1; ++c) {
            if (row[c]) {  // jump to the row's next background pixel (a false bool is a zero byte)
                const void* hole = std::memchr(row + c, 0, static_cast<std::size_t>(depth.cols - 1 - c));
                if (hole == nullptr) break;
                c = static_cast<const bool*>(hole) - row;
            }
            if (!all_neighbours_valid(valid, r, c)) continue;
            double total = 0.0;
            for (index_t dr = -1; dr <= 1; ++dr)
                for (index_t dc = -1; dc <= 1; ++dc)
                    if (dr != 0 || dc != 0) total += depth(r + dr, c + dc);
            fills.push_back({r, c, total / 8.0});
        }
    }
    for (const Fill& f : fills) {
        depth(f.r, f.c) = f.value;
        valid(f.r, f.c) = true;
    }
    return static_cast<index_t>(fills.size());
}

namespace {

// |a - 2b + c| over three valid pixels, 0 over three background ones, `jump` across a border.
inline double second_diff(double a, double b, double c, bool va, bool vb, bool vc, double jump) {
    const int n_valid = int(va) + int(vb) + int(vc);
    if (n_valid == 3) return std::fabs(a - 2.0 * b + c);
    if (n_valid == 0) return 0.0;
    return jump;
}

// Adds level `level`'s second differences (hs x ws samples, one pixel in `step`) to `k`.
void add_second_diffs(Grid<const double> d, Grid<const bool> v, double jump, index_t step, Grid<double> k) {
    const index_t hs = k.rows, ws = k.cols;
    for (index_t i = 1; i < hs - 1; ++i) {  // along rows (axis 0)
        poll_interrupt();
        const index_t r0 = (i - 1) * step, r1 = i * step, r2 = (i + 1) * step;
        for (index_t j = 0; j < ws; ++j) {
            const index_t c = j * step;
            k(i, j) += second_diff(d(r0, c), d(r1, c), d(r2, c), v(r0, c), v(r1, c), v(r2, c), jump);
        }
    }
    for (index_t i = 0; i < hs; ++i) {  // along columns (axis 1)
        poll_interrupt();
        const index_t r = i * step;
        for (index_t j = 1; j < ws - 1; ++j) {
            const index_t c0 = (j - 1) * step, c1 = j * step, c2 = (j + 1) * step;
            k(i, j) += second_diff(d(r, c0), d(r, c1), d(r, c2), v(r, c0), v(r, c1), v(r, c2), jump);
        }
    }
}

}  // namespace

void add_curvature(Grid<const double> depth, Grid<const bool> valid, double jump, index_t levels,
                   Grid<double> curvature) {
    const index_t h = depth.rows, w = depth.cols;
    require(valid.rows == h && valid.cols == w && curvature.rows == h && curvature.cols == w,
            "add_curvature: valid and the curvature must have depth's shape");
    std::vector<double> coarse;
    for (index_t level = 0; level < std::min<index_t>(levels, 62); ++level) {  // 2^62 exceeds any image
        const index_t step = index_t{1} << level;
        const index_t hs = floor_div(h + step - 1, step), ws = floor_div(w + step - 1, step);
        if (hs < 3 && ws < 3) break;
        if (level == 0) {  // straight into K: 0.0 + x == x, so the sums are the same
            add_second_diffs(depth, valid, jump, step, curvature);
            continue;
        }
        fill_polled(coarse, hs * ws, 0.0);
        add_second_diffs(depth, valid, jump, step, Grid<double>{coarse.data(), hs, ws});
        for (index_t r = 0; r < h; ++r) {
            poll_interrupt();
            const double* kr = coarse.data() + (r >> level) * ws;
            for (index_t c = 0; c < w; ++c) curvature(r, c) += kr[c >> level];
        }
    }
}

namespace {

// Inverts a cumulative weight cum[0..n-1] (cum[0] = 0, strictly increasing to M) at `count`
// equally spaced targets j M / (count - 1): each target's position interpolated linearly between
// the two pixels that bracket it, rounded half up. The first and last are pinned to 0 and n - 1
// so that neighbouring tiles meet exactly.
void invert_cdf(const std::vector<double>& cum, index_t n, index_t count, std::vector<index_t>& out) {
    const double m = cum[n - 1];
    out[0] = 0;
    out[count - 1] = n - 1;
    index_t k = 0;
    for (index_t j = 1; j < count - 1; ++j) {
        const double y = static_cast<double>(j) * m / static_cast<double>(count - 1);
        while (k < n - 2 && cum[k + 1] < y) ++k;
        const double lo = cum[k], hi = cum[k + 1];
        const double x = static_cast<double>(k) + (y - lo) / (hi - lo);
        // (weights that are not positive can put x anywhere, past the row's end)
        check_input(x >= 0.0 && x <= static_cast<double>(n - 1),
                    "sample_tiles: the weights must be positive and finite");
        out[j] = static_cast<index_t>(x + 0.5);  // floor(x + 0.5): x >= 0, so truncation (no libm call)
    }
}

// One tile's scratch: a cumulative weight, the positions found, the columns of its curves.
struct TileScratch {
    std::vector<double> cum;
    std::vector<index_t> pos_c, pos_r;
    std::vector<index_t> curve_cols;  // nr x zs: row i's column of curve j
};

// Tile (v, h): its pixel rows sampled at zs columns, then the zs curves at rs rows. A tile writes
// its last row and column of samples only at the grid's edge: inside, its neighbour writes them
// (the same samples: the same pixels and weights give the same positions).
void sample_tile(Grid<const double> f, const Tiling& t, index_t v, index_t h, const SampleGrid& grid, TileScratch& s) {
    const index_t r0 = t.row_bounds[v], nr = t.row_bounds[v + 1] - r0 + 1;
    const index_t c0 = t.col_bounds[h], nc = t.col_bounds[h + 1] - c0 + 1;
    const index_t rs = t.rs, zs = t.zs;
    s.cum.resize(std::max(nr, nc));
    s.pos_c.resize(zs);
    s.pos_r.resize(rs);
    s.curve_cols.resize(nr * zs);
    for (index_t i = 0; i < nr; ++i) {  // each pixel row at zs columns
        const double* row = f.row(r0 + i);
        double sum = 0.0;  // cum[k - 1] kept in a register: the same sums, no reload per pixel
        s.cum[0] = sum;
        for (index_t k = 1; k < nc; ++k) s.cum[k] = sum = sum + row[c0 + k];
        invert_cdf(s.cum, nc, zs, s.pos_c);
        for (index_t j = 0; j < zs; ++j) s.curve_cols[i * zs + j] = c0 + s.pos_c[j];
    }
    const index_t last_i = v == t.n_rows() - 1 ? rs : rs - 1;
    const index_t last_j = h == t.n_cols() - 1 ? zs : zs - 1;
    for (index_t j = 0; j < last_j; ++j) {  // each curve (r, curve_cols(r, j)) at rs rows
        double sum = 0.0;
        s.cum[0] = sum;
        for (index_t k = 1; k < nr; ++k) s.cum[k] = sum = sum + f(r0 + k, s.curve_cols[k * zs + j]);
        invert_cdf(s.cum, nr, rs, s.pos_r);
        for (index_t i = 0; i < last_i; ++i)
            grid.set(v * (rs - 1) + i, h * (zs - 1) + j, r0 + s.pos_r[i], s.curve_cols[s.pos_r[i] * zs + j]);
    }
}

// Tiles first..last-1 in row-major order.
void sample_tile_range(Grid<const double> f, const Tiling& t, const SampleGrid& grid, index_t first, index_t last) {
    TileScratch scratch;
    for (index_t tile = first; tile < last; ++tile) {
        poll_interrupt();
        sample_tile(f, t, tile / t.n_cols(), tile % t.n_cols(), grid, scratch);
    }
}

}  // namespace

void sample_tiles(Grid<const double> f, const Tiling& tiling, const SampleGrid& grid, index_t workers) {
    require(tiling.n_rows() >= 1 && tiling.n_cols() >= 1 && tiling.rs >= 2 && tiling.zs >= 2,
            "sample_tiles: at least one tile and two samples a tile each way");
    // (by division: (rs - 1) * tiles overflows for a raw call's rs of 2^62)
    require(grid.rows >= 1 && grid.cols >= 1 && (grid.rows - 1) % tiling.n_rows() == 0 &&
                (grid.rows - 1) / tiling.n_rows() == tiling.rs - 1 && (grid.cols - 1) % tiling.n_cols() == 0 &&
                (grid.cols - 1) / tiling.n_cols() == tiling.zs - 1,
            "sample_tiles: the grid's shape must match the tiles and samples");
    for (index_t v = 0; v < tiling.n_rows(); ++v)
        require(0 <= tiling.row_bounds[v] && tiling.row_bounds[v] < tiling.row_bounds[v + 1] &&
                    tiling.row_bounds[v + 1] < f.rows,
                "sample_tiles: row borders must increase inside the image");
    for (index_t h = 0; h < tiling.n_cols(); ++h)
        require(0 <= tiling.col_bounds[h] && tiling.col_bounds[h] < tiling.col_bounds[h + 1] &&
                    tiling.col_bounds[h + 1] < f.cols,
                "sample_tiles: column borders must increase inside the image");
    const index_t n_tiles = tiling.n_rows() * tiling.n_cols();
    const index_t n_threads = std::clamp<index_t>(workers, 1, n_tiles);
    // a fixed split: thread k takes tiles [k T / n, (k + 1) T / n); each sample has one writer
    split_run(n_threads, n_tiles,
              [&](index_t, index_t begin, index_t end) { sample_tile_range(f, tiling, grid, begin, end); });
}

}  // namespace rangemesh::paper
