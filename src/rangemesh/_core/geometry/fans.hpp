// One fan per vertex (SPEC P4): pruning the triangles that dangle after others were removed.
#pragma once

#include "../views.hpp"

namespace rangemesh {

// A triangle list with SciPy-style neighbours and the triangles still alive.
struct LiveTriangles {
    Grid<const index_t> simplices;  // (F, 3) vertex ids
    Grid<const index_t> neighbors;  // (F, 3): across the edge opposite corner k, or -1
    Span<bool> alive;               // (F,), edited in place
};

// Drop dangling triangles until none is left; returns how many were dropped. A triangle dangles
// when it shares no edge with a live triangle, or when it lies in a fan of one of its vertices
// that is not that vertex's largest (ties: the fan whose smallest corner slot 3t + k is smallest
// stays). Fans are the edge-connected groups of a vertex's triangles.
// With `drop_lone` false, a triangle that shares no edge is kept: only second fans go.
index_t prune_dangling(LiveTriangles mesh, index_t n_vertices, bool drop_lone = true);

// The same as `prune_dangling(mesh, n, false)` with every triangle alive to start, for triangles
// cut from a triangulation (each vertex's whole star a disc, or a half-disc on its hull) given as
// flat `triangles` (3F ids) and `halfedges` (3F twins, -1 on a border): only the vertices at a
// border, then those of the triangles each round drops, are visited (walking their stars by the
// twins), not every triangle each round. `alive` (F) is set; returns how many were dropped.
index_t prune_cut_fans(Span<const index_t> triangles, Span<const index_t> halfedges, Span<bool> alive);

}  // namespace rangemesh
