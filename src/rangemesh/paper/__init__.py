"""The method of Garcia & Sappa (IEEE SMC-B 34(5), 2004), as the paper gives it.

Three stages, one module each; their loops are compiled kernels (the
core's ``paper/`` and the shared geometry):

* `sampling` (II.A): gap filling, multiresolution curvature, the tiled
  inverse-CDF sample grid (`sample_grid`);
* `triangulation` (II.B.1): canonical 2-D Delaunay of the samples, pruning,
  lifting to 3-D (`delaunay_mesh`);
* `flipping` (II.B.2-3): discontinuity-preserving edge flips (`flip_edges`).

`stages.mesh_grid` runs the three in order; `targets` chooses the grid for a
vertex count, an error bound or an edge length.
"""

from .flipping import Verdict, flip_edges
from .sampling import curvature, fill_gaps, sample_grid, sampling_weights
from .stages import mesh_grid
from .triangulation import delaunay_mesh

__all__ = ["Verdict", "curvature", "delaunay_mesh", "fill_gaps", "flip_edges", "mesh_grid",
           "sample_grid", "sampling_weights"]
