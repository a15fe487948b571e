"""The compiled core: C++17 kernels (``_ext``), built by scikit-build-core at ``pip install``.

The kernels trust their inputs: the public functions that call them check
shapes, dtypes and values. Nothing here imports the rest of rangemesh.
"""

from ._ext import (  # noqa: F401  (the _strip_* names: the strips' power laws, for tests)
    MAX_TESTS_PER_EDGE,
    _strip_error_target,
    _strip_exponent,
    _strip_power_law,
    build_halfedges,
    count_edges,
    error_flips,
    flip_by_error,
    flip_from_edges,
    greedy_insert,
    greedy_insert_sums,
    neighbors_from_halfedges,
    seam_rows,
    strip_insert,
    triangle_error,
)

__all__ = ["MAX_TESTS_PER_EDGE", "build_halfedges", "count_edges", "error_flips", "flip_by_error",
           "flip_from_edges", "greedy_insert", "greedy_insert_sums", "neighbors_from_halfedges",
           "seam_rows", "strip_insert", "triangle_error"]
