// The canonical Delaunay triangulation of distinct integer points (see PointSet: Simulation of
// Simplicity makes it unique), by a sweep and by Lawson flips.
#pragma once

#include <vector>

#include "../views.hpp"
#include "predicates.hpp"

namespace rangemesh {

// A flat half-edge mesh (halfedges.hpp) that owns its arrays.
struct Triangulation {
    std::vector<index_t> triangles, halfedges;
};

// The sweep's Delaunay triangulation of the points: counter-clockwise in (r, c), every point a
// vertex; no triangle when there are fewer than 3 points or all are collinear.
//
// After Delaunator (V. Agafonkin, from Sinclair's s-hull): a seed triangle near the points'
// centre, the rest inserted by distance from its circumcentre, the convex hull kept as a linked
// list with an angular hash, a fan of triangles added to the hull edges a point sees, legalised
// by flips. Written for exact predicates and our counter-clockwise (r, c) half-edge layout.
Triangulation delaunay_sweep(const PointSet& points);

// Lawson flips until every edge is legal under PointSet::illegal; returns the flips made. On a
// Delaunay triangulation only co-circular quads can be illegal, and four distinct co-circular
// points always form a strictly convex quad, so every flip is possible; the perturbed lifted
// surface falls with each flip, so the loop ends, at the unique canonical triangulation.
index_t legalize_all(Span<index_t> triangles, Span<index_t> halfedges, const PointSet& points);

// The faces (3F vertex ids in, F x 3 out) in the canonical order: each starts at its smallest
// corner, keeping its turn, and the faces are sorted by their first, second and third corner,
// ties in their order (NumPy's argmin, take_along_axis and lexsort). Corners lie in
// [0, n_vertices).
std::vector<index_t> canonical_faces(Span<const index_t> triangles, index_t n_vertices);

}  // namespace rangemesh
