#include "order.hpp"

#include <algorithm>
#include <stdexcept>
#include <vector>

#include "../geometry/predicates.hpp"
#include "../interrupt.hpp"

namespace rangemesh::heights {

void face_order(Grid<const index_t> faces, Span<const index_t> rows, Span<const index_t> cols,
                index_t h, index_t w, index_t tile, Span<index_t> order) {
    require(order.size == faces.rows && tile > 0, "face_order: one order entry a face");
    const index_t across = floor_div(w + tile - 1, tile);
    const index_t cells = floor_div(h + tile - 1, tile) * across;
    std::vector<index_t> start, cell;
    fill_polled(start, cells + 1, index_t{0});
    fill_polled(cell, faces.rows, index_t{0});
    for (index_t t = 0; t < faces.rows; ++t) {
        poll_every(t);
        const index_t a = faces(t, 0), b = faces(t, 1), c = faces(t, 2);
        require(std::min({a, b, c}) >= 0 && std::max({a, b, c}) < rows.size,
                "face_order: a face's vertex id is out of range");
        const index_t r = std::min({rows[a], rows[b], rows[c]});
        const index_t col = std::min({cols[a], cols[b], cols[c]});
        if (r < 0 || col < 0 || r >= h || col >= w)
            throw std::invalid_argument("face_order: a vertex lies outside the image");
        cell[t] = (r / tile) * across + col / tile;  // both >= 0: C++ division is Python's
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
