// effort="best": a denser refine mesh brought down to the vertices asked by half-edge collapses
// (issue 44, lever (a) of the quality-levers study of 2026-11-27).
//
// A vertex v is collapsed onto a neighbour u when the link condition holds and every new
// triangle of v's star polygon is positively oriented, so the region the mesh covers never
// changes: an inner v onto any neighbour, a border v only onto a border neighbour and only when
// it lies straight between its two border neighbours (an image side, a straight hole edge).
// Collapses are taken cheapest first by the exact increase of sum |value - mesh| over the pixels
// of v's star (each pixel owned by one triangle, `owns`). After each collapse u's value is
// refitted by 1-D least squares over its star, and u and its neighbours, whose stars changed,
// are ranked again at once (re-ranking them lazily, when popped, was measured worse:
// docs/decisions.md). At the end each convex quad takes the diagonal with the smaller summed
// error (data-dependent flips).
#pragma once

#include <vector>

#include "../geometry/pixels.hpp"
#include "image.hpp"

namespace rangemesh::refine {

// What a collapse did.
struct CollapseCount {
    index_t collapses = 0, evaluations = 0, flips = 0;
};

// The mesh to collapse: faces and pixels (counter-clockwise, each vertex with one fan, as
// `valid_faces` gives them), one value a vertex in the units of `Image::depth`.
struct CollapseInput {
    const ValidFaces& mesh;
    const std::vector<double>& z;
    index_t target;  // vertices to leave
    bool refit;      // refit the survivor's value after each collapse (heights='fit')
};

// The mesh of `in` with `target` vertices (renumbered in their order), or false, when the
// collapses cannot reach it (too few vertices may go): `out` is then untouched.
bool collapse_mesh(const Image& values, const CollapseInput& in, ValidFaces& out, CollapseCount& count);

}  // namespace rangemesh::refine
