"""The compiled core: C++17 kernels (``_ext``), built by scikit-build-core at ``pip install``.

The kernels trust their inputs: the public functions that call them check
shapes, dtypes and values. Nothing here imports the rest of rangemesh.
"""

from ._ext import (
    MAX_TESTS_PER_EDGE,
    build_halfedges,
    count_edges,
    error_flips,
    flip_by_error,
    flip_from_edges,
    greedy_insert,
    greedy_insert_sums,
    neighbors_from_halfedges,
    triangle_error,
)

__all__ = ["MAX_TESTS_PER_EDGE", "build_halfedges", "count_edges", "error_flips", "flip_by_error",
           "flip_from_edges", "greedy_insert", "greedy_insert_sums", "neighbors_from_halfedges",
           "triangle_error"]
