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
    covered_error,
    delaunay_sweep,
    disparity_verdict,
    edge_error,
    fill_gaps_inplace,
    flip_loop,
    grid_pixels,
    legalize_all,
    lift,
    line_pixel,
    mask_image,
    nearest_valid,
    neighbors_from_halfedges,
    prune_dangling,
    rasterize,
    sample_tiles,
    valid_faces,
    valid_range,
)

__all__ = ["FLIP_RULES", "FLIP_VERDICTS", "add_curvature", "build_halfedges", "count_edges",
           "covered_error", "delaunay_sweep", "disparity_verdict", "edge_error", "fill_gaps_inplace",
           "flip_loop", "grid_pixels", "legalize_all", "lift", "line_pixel", "mask_image",
           "nearest_valid", "neighbors_from_halfedges", "prune_dangling", "rasterize", "sample_tiles",
           "valid_faces", "valid_range"]
