// The order in which the fit visits the faces: by the pixel cell of their top-left corner.
#pragma once

#include "../views.hpp"

namespace rangemesh::heights {

// The faces (F x 3, over vertices at pixels rows/cols of an h x w image) in the row-major order
// of the `tile` x `tile` cells holding their smallest row and column, by index within a cell;
// a counting sort. Visited so, consecutive faces read the same image rows from the cache.
void face_order(Grid<const index_t> faces, Span<const index_t> rows, Span<const index_t> cols, index_t h, index_t w,
                index_t tile, Span<index_t> order);

}  // namespace rangemesh::heights
