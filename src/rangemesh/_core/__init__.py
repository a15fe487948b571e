"""The compiled core: C++17 kernels (``_ext``), built by scikit-build-core at ``pip install``.

The kernels trust their inputs: the public functions that call them check
shapes, dtypes and values. Nothing here imports the rest of rangemesh.
"""

from ._ext import (
    FLIP_RULES,
    FLIP_VERDICTS,
    add_curvature,
    build_halfedges,
    count_edges,
    disparity_verdict,
    edge_error,
    fill_gaps_inplace,
    flip_loop,
    lift,
    line_pixel,
    neighbors_from_halfedges,
    sample_tiles,
)

__all__ = ["FLIP_RULES", "FLIP_VERDICTS", "add_curvature", "build_halfedges", "count_edges",
           "disparity_verdict", "edge_error", "fill_gaps_inplace", "flip_loop", "lift", "line_pixel",
           "neighbors_from_halfedges", "sample_tiles"]
