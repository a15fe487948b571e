// The walls of jumps (rangemesh/refine/walls.py holds the rule's reasons): a face is a wall when
// an edge between vertices of depths za and zb, L pixels long, has
//     |za - zb| > jump * min(|za|, |zb|) * max(L, 1).
#pragma once

#include "../views.hpp"

namespace rangemesh::refine {

// Which faces (F x 3 vertex ids) are walls, into `out` (F). Edge k runs from corner k to corner
// k + 1; its length is lengths(t, k) when `lengths` has rows (ray angles in pixels, computed by
// the caller), else the distance between its corners' pixels (V x 2, row and column).
void wall_faces(Grid<const index_t> faces, Grid<const index_t> pixels, Span<const double> z, double jump,
                Grid<const double> lengths, Span<bool> out);

// Lengths of edges a[i] -> b[i] between vertices' pixels (V x 2) by the angle of their rays, in
// units of `pixel_angle` (walls.py's `pixel_lengths` for a Spherical or Rays camera), into `out`.
// `camera` is a ray camera's Camera.as_array(): [2, H, W, range_scale, 0, 0, the rays].
void ray_lengths(Span<const double> camera, Grid<const index_t> pixels, Span<const index_t> a, Span<const index_t> b,
                 double pixel_angle, Span<double> out);

}  // namespace rangemesh::refine
