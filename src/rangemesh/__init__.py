"""rangemesh: discontinuity-preserving adaptive triangle meshes from range images.

Two methods behind one call, `triangulate`: ``method='refine'`` (the
default) refines a coarse mesh where it fits worst, until a vertex count, an
error bound or the default target is met; ``method='paper'`` is Garcia &
Sappa (IEEE SMC-B 2004): curvature-based adaptive sampling, 2.5-D Delaunay
triangulation and discontinuity-preserving edge flips.

>>> import numpy as np, rangemesh
>>> mesh = rangemesh.triangulate(np.add.outer(np.arange(30.0), np.arange(40.0)))
>>> mesh.stats.method, mesh.vertices.shape[1], mesh.faces.shape[1]
('refine', 3, 3)

The library is layered (docs/method.md, "Where the code is"): applications
(`cli`, `batch`, `preview`, `calibrate`) -> `pipeline` -> methods (`paper`)
-> shared geometry kernels -> the compiled core. Every name here is imported
lazily, on first use, so that ``import rangemesh`` loads nothing it does not need.
"""

from ._version import __version__

# name -> module, imported on first use (PEP 562): `import rangemesh` stays cheap, and the
# command line can answer Ctrl-C during its start-up
_LAZY = {
    "Orthographic": "camera",
    "Pinhole": "camera",
    "Rays": "camera",
    "Spherical": "camera",
    "backproject": "camera",
    "read_camera": "camera_files",
    "project_scan": "clouds",
    "read_mesh": "io",
    "read_range_image": "io",
    "write_mesh": "io",
    "Mesh": "mesh",
    "Stats": "mesh",
    "Target": "mesh",
    "Evaluation": "metrics",
    "discontinuity_mask": "metrics",
    "evaluate": "metrics",
    "curvature": "geometry.curvature",
    "delaunay_mesh": "paper",
    "fill_gaps": "prepare",
    "flip_edges": "paper",
    "sample_grid": "paper",
    "sampling_weights": "paper",
    "MeshParams": "params",
    "triangulate": "pipeline",
    "to_depth_and_mask": "prepare",
    "render_depth": "render",
    "mesh_many": "batch",
    "mesh_stream": "batch",
    "mesh_bag": "recordings",
    "live": "live",
    "calibrate_delta": "calibrate",
    "triangle_disparities": "calibrate",
}

__all__ = [
    "__version__",
    "Evaluation",
    "Mesh",
    "MeshParams",
    "Orthographic",
    "Pinhole",
    "Rays",
    "Spherical",
    "Stats",
    "Target",
    "backproject",
    "calibrate_delta",
    "curvature",
    "delaunay_mesh",
    "discontinuity_mask",
    "evaluate",
    "fill_gaps",
    "flip_edges",
    "live",
    "mesh_bag",
    "mesh_many",
    "mesh_stream",
    "project_scan",
    "read_camera",
    "read_range_image",
    "render_depth",
    "sample_grid",
    "sampling_weights",
    "to_depth_and_mask",
    "triangle_disparities",
    "triangulate",
    "write_mesh",
    "read_mesh",
]


def __getattr__(name):
    import importlib

    if name in _LAZY:
        value = getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
        globals()[name] = value
        return value
    try:  # a submodule not imported yet (rangemesh.scenes, rangemesh.io, ...)
        return importlib.import_module(f".{name}", __name__)
    except ModuleNotFoundError as exc:
        if exc.name != f"{__name__}.{name}":
            raise
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
