"""The paper's method, stage after stage, timed: sample grid -> Delaunay -> flips."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..mesh import Mesh
from ..params import MeshParams
from ..timing import timed
from .flipping import flip_edges
from .sampling import sample_grid
from .triangulation import delaunay_mesh

__all__ = ["mesh_grid", "refine_to_edge", "split_points"]


def mesh_grid(depth: np.ndarray, valid: np.ndarray, params: MeshParams, camera, *,
              weights: np.ndarray | None = None) -> Mesh:
    """Stages one to three of the paper on a prepared image (see `rangemesh.pipeline.prepare`).

    Parameters
    ----------
    depth, valid : (H, W) ndarrays
        Gap-filled depth and its validity mask.
    params : MeshParams
        Grid, sampling, flip rule and thresholds; ``max_edge`` (if set) adds
        samples that cut longer edges (`refine_to_edge`) and refuses longer
        flips; ``workers`` threads share stage one's tiles.
    camera : Orthographic or Pinhole
    weights : (H, W) ndarray, optional
        Precomputed `sampling_weights` for `params` (reused across tries and frames).

    Returns
    -------
    Mesh
        With ``stats.seconds`` for ``sampling``, ``triangulation``, ``flipping``.
    """
    seconds = {}
    with timed(seconds, "sampling"):
        grid = sample_grid(depth, valid, params, weights=weights, workers=params.workers)
    with timed(seconds, "triangulation"):
        if params.max_edge is None:
            mesh = delaunay_mesh(grid, depth, valid, camera)
        else:
            mesh = refine_to_edge(grid, depth, valid, camera, params.max_edge)[0]
    with timed(seconds, "flipping"):
        mesh = flip_edges(mesh, depth, valid, params)
    return dataclasses.replace(mesh, stats=dataclasses.replace(mesh.stats, seconds=seconds))


def refine_to_edge(grid: np.ndarray, depth: np.ndarray, valid: np.ndarray, camera,
                   max_edge: float) -> tuple[Mesh, int, np.ndarray]:
    """Delaunay mesh of `grid`'s samples plus the pixels that cut every edge over `max_edge`.

    Every edge longer than `max_edge` gets the valid pixels that cut it into
    pieces of at most 0.9 `max_edge`, and the valid pixels where it enters or
    leaves background, added as samples; Delaunay is run again, up to 6
    rounds. A triangle that still has a longer edge (it spans background, so
    no valid pixel can cut it) is then removed; its area stays uncovered.

    Parameters
    ----------
    grid : (..., 2) ndarray of int
        Sample pixels (a stage-one grid or any list of them).
    depth, valid : (H, W) ndarrays
    camera : Orthographic or Pinhole
    max_edge : float
        Longest edge allowed in the image plane, pixels.

    Returns
    -------
    mesh : Mesh
        Not flipped yet.
    rounds : int
        Delaunay runs before no edge needed cutting (at most 6).
    points : (N, 2) ndarray of int64
        The samples, added ones included.
    """
    points = np.asarray(grid).reshape(-1, 2).astype(np.int64)
    rounds = 0
    for rounds in range(1, 7):  # noqa: B007 (the count is reported)
        mesh = delaunay_mesh(points.reshape(-1, 1, 2), depth, valid, camera)
        extra = split_points(mesh, valid, max_edge) if not mesh.is_empty else np.zeros((0, 2))
        if len(extra) == 0:
            break
        points = np.concatenate([points, extra.astype(np.int64)])
    mesh = delaunay_mesh(points.reshape(-1, 1, 2), depth, valid, camera, max_edge=max_edge)
    return mesh, rounds, points


def split_points(mesh: Mesh, valid: np.ndarray, max_edge: float) -> np.ndarray:
    """Valid pixels that cut every edge longer than `max_edge` into pieces short enough."""
    f = mesh.faces.astype(np.int64)
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    e = np.unique(np.sort(e, axis=1), axis=0)
    a = mesh.pixels[e[:, 0]].astype(np.float64)
    b = mesh.pixels[e[:, 1]].astype(np.float64)
    length = np.sqrt(((b - a) ** 2).sum(axis=1))
    long = length > max_edge
    if not long.any():
        return np.zeros((0, 2), np.int64)
    a, b, length = a[long], b[long], length[long]

    def along(pieces):
        """Pixels at k/pieces of each long edge, k = 1..pieces-1, in edge order."""
        owner = np.repeat(np.arange(pieces.size), pieces - 1)
        start = np.repeat(np.cumsum(pieces - 1) - (pieces - 1), pieces - 1)
        k = np.arange(owner.size) - start + 1
        t = (k / pieces[owner])[:, None]
        pts = np.floor(a[owner] + t * (b[owner] - a[owner]) + 0.5).astype(np.int64)
        return owner, pts

    # Even cuts, and the valid pixels where an edge enters or leaves background,
    # so that triangles can hug a hole instead of spanning it.
    _, even = along(np.ceil(length / (0.9 * max_edge)).astype(np.int64))
    owner, dense = along(np.ceil(length).astype(np.int64) + 1)
    ok = valid[dense[:, 0], dense[:, 1]]
    same_edge = owner[1:] == owner[:-1]
    change = same_edge & (ok[1:] != ok[:-1])
    border = np.zeros(ok.size, bool)
    border[:-1] |= change & ok[:-1]
    border[1:] |= change & ok[1:]
    pts = np.concatenate([even[valid[even[:, 0], even[:, 1]]], dense[border]])
    return pts
