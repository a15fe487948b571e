"""The compiled core: C++17 kernels (``_ext``), built by scikit-build-core at ``pip install``.

The kernels trust their inputs: the public functions that call them check
shapes, dtypes and values. Nothing here imports the rest of rangemesh.
"""

from ._ext import (
    build_halfedges,
    count_edges,
    face_order,
    fit_blocks,
    fit_heights,
    fit_sample_errors,
    gather_blocks,
    median_inplace,
    neighbors_from_halfedges,
    solve_blocks,
)

__all__ = ["build_halfedges", "count_edges", "face_order", "fit_blocks", "fit_heights", "fit_sample_errors",
           "gather_blocks", "median_inplace", "neighbors_from_halfedges", "solve_blocks"]
