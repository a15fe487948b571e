"""rangemesh: discontinuity-preserving adaptive triangle meshes from range images.

A fast implementation of Garcia & Sappa (IEEE SMC-B 2004): curvature-based
adaptive sampling, 2.5-D Delaunay triangulation and discontinuity-preserving
edge flips.

>>> import numpy as np, rangemesh
>>> mesh = rangemesh.triangulate(np.add.outer(np.arange(30.0), np.arange(40.0)))
>>> mesh.vertices.shape[1], mesh.faces.shape[1]
(3, 3)
"""

from ._version import __version__
from .batch import mesh_many, mesh_stream
from .calibrate import calibrate_delta, triangle_disparities
from .camera import Orthographic, Pinhole, backproject
from .flipping import flip_edges
from .mesh import Mesh, Stats
from .metrics import Evaluation, discontinuity_mask, evaluate, render_depth
from .params import MeshParams
from .pipeline import triangulate
from .prepare import to_depth_and_mask
from .sampling import curvature, fill_gaps, sample_grid, sampling_weights
from .triangulation import delaunay_mesh

__all__ = [
    "__version__",
    "Evaluation",
    "Mesh",
    "MeshParams",
    "Orthographic",
    "Pinhole",
    "Stats",
    "backproject",
    "calibrate_delta",
    "curvature",
    "delaunay_mesh",
    "discontinuity_mask",
    "evaluate",
    "mesh_many",
    "mesh_stream",
    "fill_gaps",
    "flip_edges",
    "render_depth",
    "sample_grid",
    "sampling_weights",
    "to_depth_and_mask",
    "triangle_disparities",
    "triangulate",
]
