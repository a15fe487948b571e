"""The compiled core: C++17 kernels (``_ext``), built by scikit-build-core at ``pip install``.

The kernels trust their inputs: the public functions that call them check
shapes, dtypes and values. Nothing here imports the rest of rangemesh.
"""

from ._ext import (
    build_halfedges,
    count_edges,
    covered_error,
    delaunay_sweep,
    grid_pixels,
    legalize_all,
    mask_image,
    nearest_valid,
    neighbors_from_halfedges,
    prune_dangling,
    rasterize,
    valid_faces,
    valid_range,
)

__all__ = [
    "build_halfedges",
    "count_edges",
    "covered_error",
    "delaunay_sweep",
    "grid_pixels",
    "legalize_all",
    "mask_image",
    "nearest_valid",
    "neighbors_from_halfedges",
    "prune_dangling",
    "rasterize",
    "valid_faces",
    "valid_range",
]
