// The image every refine kernel reads: depth and its valid mask, and the unit of its keys.
#pragma once

#include "../views.hpp"

namespace rangemesh::refine {

struct Image {
    Grid<const double> depth;  // read on valid pixels only
    Grid<const bool> valid;
    double span;  // the valid depth range: errors are ranked in units of span / 2^32

    index_t rows() const { return depth.rows; }
    index_t cols() const { return depth.cols; }
};

}  // namespace rangemesh::refine
