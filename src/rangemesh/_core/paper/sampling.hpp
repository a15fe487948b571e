// Stage one of the paper's method (II.A, SPEC 1): gap filling, the multiresolution curvature
// and the sample grid, tile by tile, by inverting cumulative weights.
#pragma once

#include <cstdint>

#include "../views.hpp"

namespace rangemesh::paper {

// SPEC 1.1 in one pass, in place: a background pixel whose 8 neighbours are all valid gets their
// mean (added in row-major order) and becomes valid. Holes are found before any is filled, so a
// pixel filled now never counts as a neighbour. Returns the number filled.
index_t fill_gaps_inplace(Grid<double> depth, Grid<bool> valid);

// SPEC 1.2-1.3: K(r, c) += K_l(r >> l, c >> l) for each of `levels` levels, K_l the second
// differences (row term, then column term) of the image read one pixel in 2^l. A stencil leaving
// the image adds 0, one that mixes valid and background pixels adds `jump`.
void add_curvature(Grid<const double> depth, Grid<const bool> valid, double jump, index_t levels,
                   Grid<double> curvature);

// The tiles of stage one: V + 1 row borders and H + 1 column borders (a tile spans its two
// borders, inclusive), and the samples a tile takes along rows (rs) and columns (zs).
struct Tiling {
    Span<const index_t> row_bounds;
    Span<const index_t> col_bounds;
    index_t rs = 0;
    index_t zs = 0;

    index_t n_rows() const { return row_bounds.size - 1; }
    index_t n_cols() const { return col_bounds.size - 1; }
};

// The sample grid: Gr x Gc samples, each a (row, column) pair of int32.
struct SampleGrid {
    std::int32_t* data = nullptr;
    index_t rows = 0;
    index_t cols = 0;

    void set(index_t i, index_t j, index_t r, index_t c) const {
        data[2 * (i * cols + j)] = static_cast<std::int32_t>(r);
        data[2 * (i * cols + j) + 1] = static_cast<std::int32_t>(c);
    }
};

// The sample grid (paper II.A.3, SPEC 1.6-1.8), Gr = (rs-1)V+1 by Gc = (zs-1)H+1, from the
// weights `f`. `workers` threads share the tiles in a fixed split; the
// grid is the same for any number of them.
void sample_tiles(Grid<const double> f, const Tiling& tiling, const SampleGrid& grid, index_t workers);

}  // namespace rangemesh::paper
