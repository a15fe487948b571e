#include "order.hpp"

#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "../geometry/predicates.hpp"
#include "../interrupt.hpp"

namespace rangemesh::heights {

namespace {

// The most cells the counting sort takes (a 65,536 x 65,536 image at tile 8; the library's
// images stop at 29,001 a side): a raw call's h and w of 2^40 would allocate terabytes.
constexpr index_t MAX_CELLS = index_t{1} << 26;

}  // namespace

void face_order(Grid<const index_t> faces, Span<const index_t> rows, Span<const index_t> cols, index_t h, index_t w,
                index_t tile, Span<index_t> order) {
    require(order.size == faces.rows && tile > 0 && h > 0 && w > 0, "face_order: one order entry a face");
    // ceil(w / tile) without w + tile - 1, which overflows for a raw call's tile of INT64_MAX
    const index_t across = (w - 1) / tile + 1, down = (h - 1) / tile + 1;
    check_input(down <= MAX_CELLS / across, "face_order: more than 2^26 cells of tile x tile pixels; a larger tile");
    const index_t cells = down * across;
    std::vector<index_t> start, cell;
    // before anything is read through them: flags and-ed without a branch an entry (a bad id
    // reads vertex 0 instead), then, if one failed, the entries again in order for its message
    const auto below = [](index_t x, index_t end) {
        return static_cast<std::uint64_t>(x) < static_cast<std::uint64_t>(end);
    };
    bool fine = rows.size > 0 || faces.rows == 0;
    for (index_t k = 0; fine && k < 3 * faces.rows; ++k) {
        poll_every(k);
        const index_t v = faces.data[k];
        const bool id = below(v, rows.size);
        const index_t u = id ? v : 0;
        fine &= id & below(rows[u], h) & below(cols[u], w);
    }
    for (index_t k = 0; !fine && k < 3 * faces.rows; ++k) {
        const index_t v = faces.data[k];
        check_input(0 <= v && v < rows.size, "face_order: a face's vertex id is out of range");
        check_input(0 <= rows[v] && rows[v] < h && 0 <= cols[v] && cols[v] < w,
                    "face_order: a vertex lies outside the image");
    }
    require(fine, "face_order: a failed check names its entry");
    int shift = -1;  // log2(tile), when the tile is a power of 2
    if ((tile & (tile - 1)) == 0) {
        shift = 0;
        while ((index_t{1} << shift) < tile) ++shift;
    }
    fill_polled(start, cells + 1, index_t{0});
    fill_polled(cell, faces.rows, index_t{0});
    for (index_t t = 0; t < faces.rows; ++t) {
        poll_every(t);
        const index_t a = faces(t, 0), b = faces(t, 1), c = faces(t, 2);
        const index_t r = std::min({rows[a], rows[b], rows[c]});
        const index_t col = std::min({cols[a], cols[b], cols[c]});
        // both >= 0: C++ division is Python's, and a shift when the tile is a power of 2 (the
        // library's 8): two integer divisions a face cost more cycles than the rest of the sort
        cell[t] = shift >= 0 ? (r >> shift) * across + (col >> shift) : (r / tile) * across + col / tile;
        start[cell[t] + 1] += 1;
    }
    for (index_t k = 0; k < cells; ++k) {
        poll_every(k);
        start[k + 1] += start[k];
    }
    for (index_t t = 0; t < faces.rows; ++t) {  // stable within a cell
        poll_every(t);
        order[start[cell[t]]++] = t;
    }
}

}  // namespace rangemesh::heights
