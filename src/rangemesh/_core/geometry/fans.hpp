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

}  // namespace rangemesh
