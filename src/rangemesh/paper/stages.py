"""The paper's method, stage after stage, timed: sample grid -> Delaunay -> flips."""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from ..mesh import Mesh
from ..params import MeshParams
from .flipping import flip_edges
from .sampling import sample_grid
from .triangulation import delaunay_mesh

__all__ = ["mesh_grid"]


def mesh_grid(depth: np.ndarray, valid: np.ndarray, params: MeshParams, camera, *,
              weights: np.ndarray | None = None) -> Mesh:
    """Stages one to three of the paper on a prepared image (see `rangemesh.pipeline.prepare`).

    Parameters
    ----------
    depth, valid : (H, W) ndarrays
        Gap-filled depth and its validity mask.
    params : MeshParams
        Grid, sampling, flip rule and thresholds; ``max_edge`` (if set) drops
        longer Delaunay triangles and refuses longer flips; ``workers`` threads
        share stage one's tiles.
    camera : Orthographic or Pinhole
    weights : (H, W) ndarray, optional
        Precomputed `sampling_weights` for `params` (reused across tries and frames).

    Returns
    -------
    Mesh
        With ``stats.seconds`` for ``sampling``, ``triangulation``, ``flipping``.
    """
    t1 = time.perf_counter()
    grid = sample_grid(depth, valid, params, weights=weights, workers=params.workers)
    t2 = time.perf_counter()
    mesh = delaunay_mesh(grid, depth, valid, camera, max_edge=params.max_edge)
    t3 = time.perf_counter()
    mesh = flip_edges(mesh, depth, valid, params)
    t4 = time.perf_counter()
    seconds = {"sampling": t2 - t1, "triangulation": t3 - t2, "flipping": t4 - t3}
    return dataclasses.replace(mesh, stats=dataclasses.replace(mesh.stats, seconds=seconds))
