"""Shared geometry in Python, which both methods and the evaluation use.

* `seam`: the 360-degree seam of a spinning LiDAR's image and the strip
  that closes it (`seam.seam_faces`);
* `walls`: the triangles across a depth jump (``walls=False``);
* `curvature`: the multiresolution curvature (the paper's sampling weight,
  the evaluation's discontinuities).

The kernels every method builds on (half-edges, Delaunay, the row scan, the
heap, rasterising) are compiled C++ (`rangemesh._core`).
"""
