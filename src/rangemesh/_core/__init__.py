"""The compiled core: C++17 kernels (``_ext``), built by scikit-build-core at ``pip install``.

The kernels trust their inputs: the public functions that call them check
shapes, dtypes and values. Nothing here imports the rest of rangemesh.
"""

from ._ext import (  # noqa: F401  (the _strip_* names: the strips' power laws, for tests)
    FLIP_RULES,
    FLIP_VERDICTS,
    MAX_TESTS_PER_EDGE,
    _strip_error_target,
    _strip_exponent,
    _strip_power_law,
    add_curvature,
    build_halfedges,
    count_edges,
    disparity_verdict,
    edge_error,
    error_flips,
    fill_gaps_inplace,
    flip_by_error,
    flip_from_edges,
    flip_loop,
    greedy_insert,
    greedy_insert_sums,
    lift,
    line_pixel,
    neighbors_from_halfedges,
    sample_tiles,
    seam_rows,
    strip_insert,
    triangle_error,
)

__all__ = ["FLIP_RULES", "FLIP_VERDICTS", "MAX_TESTS_PER_EDGE", "add_curvature", "build_halfedges",
           "count_edges", "disparity_verdict", "edge_error", "error_flips", "fill_gaps_inplace",
           "flip_by_error", "flip_from_edges", "flip_loop", "greedy_insert", "greedy_insert_sums",
           "lift", "line_pixel", "neighbors_from_halfedges", "sample_tiles", "seam_rows",
           "strip_insert", "triangle_error"]
