"""rangemesh: discontinuity-preserving adaptive triangle meshes from range images.

A fast implementation of Garcia & Sappa (IEEE SMC-B 2004): curvature-based
adaptive sampling, 2.5-D Delaunay triangulation and discontinuity-preserving
edge flips.

>>> import numpy as np, rangemesh
>>> mesh = rangemesh.triangulate(np.add.outer(np.arange(30.0), np.arange(40.0)))
>>> mesh.vertices.shape[1], mesh.faces.shape[1]
(3, 3)

The library is layered (see the README's Development section): applications
(`cli`, `batch`, `preview`, `calibrate`) -> `pipeline` -> methods (`paper`)
-> shared geometry kernels. The applications are imported here lazily, on
first use, so that ``import rangemesh`` does not load Dask or matplotlib.
"""

from ._version import __version__
from .camera import Orthographic, Pinhole, Rays, Spherical, backproject
from .io import read_mesh, read_range_image, write_mesh
from .mesh import Mesh, Stats
from .metrics import Evaluation, discontinuity_mask, evaluate
from .paper import curvature, delaunay_mesh, fill_gaps, flip_edges, sample_grid, sampling_weights
from .params import MeshParams
from .pipeline import triangulate
from .prepare import to_depth_and_mask
from .render import render_depth

# name -> module, imported on first use (PEP 562)
_LAZY = {
    "mesh_many": "batch",
    "mesh_stream": "batch",
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
    "backproject",
    "calibrate_delta",
    "curvature",
    "delaunay_mesh",
    "discontinuity_mask",
    "evaluate",
    "fill_gaps",
    "flip_edges",
    "mesh_many",
    "mesh_stream",
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
    if name in _LAZY:
        import importlib

        value = getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
