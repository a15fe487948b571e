"""Stage two: 2-D Delaunay of the valid samples, pruning, lifting to 3-D.

Paper II.B.1; SPEC.md section 2.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import Delaunay, QhullError

from . import _kernels
from .camera import as_camera, backproject
from .mesh import Mesh, Stats, count_edges, empty_mesh

__all__ = ["delaunay_mesh"]


def _empty(camera, shape, grid_shape, n_points, reason):
    return empty_mesh(camera, shape, Stats(grid_shape=grid_shape, sampled_points=n_points,
                                           reason=reason))


def delaunay_mesh(grid: np.ndarray, depth: np.ndarray, valid: np.ndarray, camera=None, *,
                  max_edge: float | None = None) -> Mesh:
    """Triangulate the valid samples and lift them to 3-D (SPEC 2.1-2.4).

    Parameters
    ----------
    grid : (Gr, Gc, 2) ndarray of int
        Sample grid from `sample_grid` (any array of ``(row, col)`` pairs works).
    depth : (H, W) ndarray of float64
        Depth after gap filling; the vertices take their depth from it.
    valid : (H, W) ndarray of bool
    camera : Orthographic or Pinhole, optional
        Default ``Orthographic(1, 1, 1)``.
    max_edge : float, optional
        Drop every triangle with an edge longer than this, in pixels of the
        image plane, before pruning (the hole it leaves stays uncovered).

    Returns
    -------
    Mesh
        Vertices are the distinct valid samples that remain in some triangle,
        ordered by ``row * W + col``; faces are counter-clockwise in the image
        plane. An empty mesh (with ``stats.reason``) when fewer than 3 valid
        samples remain, when they are all collinear, or when pruning leaves
        nothing.

    Notes
    -----
    * 2-D Delaunay runs on integer pixel coordinates through Qhull
      (``scipy.spatial.Delaunay``). Pixel grids are full of co-circular points,
      so the triangulation is one of several valid Delaunay triangulations;
      Qhull's choice is deterministic for the same input. Points Qhull leaves
      out (``coplanar``) are dropped, and any zero-area triangle is removed.
    * A triangle is background when the pixel at its rounded barycentre is
      background. The barycentre ``(r0+r1+r2)/3`` never falls on a half, so
      rounding needs no tie rule.
    * Dangling triangles are removed until none is left: triangles sharing no
      edge with another, and at every vertex all edge-connected fans but the
      largest (ties keep the fan holding the lowest-numbered corner). After
      this every vertex has exactly one fan.
    """
    camera = as_camera(camera)
    h, w = depth.shape
    grid_shape = tuple(int(x) for x in np.shape(grid)[:2])
    g = np.asarray(grid, dtype=np.int64).reshape(-1, 2)
    inside = (g[:, 0] >= 0) & (g[:, 0] < h) & (g[:, 1] >= 0) & (g[:, 1] < w)
    g = g[inside]
    lin = np.unique(g[:, 0] * w + g[:, 1])
    lin = lin[valid.ravel()[lin]]
    n_points = int(lin.size)
    if n_points < 3:
        return _empty(camera, (h, w), grid_shape, n_points,
                      f"only {n_points} valid sample(s); a triangle needs 3")
    pts = np.stack([lin // w, lin % w], axis=1)
    try:
        tri = Delaunay(pts.astype(np.float64))
    except QhullError:
        return _empty(camera, (h, w), grid_shape, n_points,
                      "all valid samples are collinear; no triangle can be formed")
    simplices = tri.simplices.astype(np.int64)
    neighbors = tri.neighbors.astype(np.int64)
    # Orient CCW in (r, c); a swap of two corners must swap the matching neighbours.
    r = pts[simplices, 0]
    c = pts[simplices, 1]
    area = (r[:, 1] - r[:, 0]) * (c[:, 2] - c[:, 0]) - (c[:, 1] - c[:, 0]) * (r[:, 2] - r[:, 0])
    neg = area < 0
    simplices[neg] = simplices[neg][:, [0, 2, 1]]
    neighbors[neg] = neighbors[neg][:, [0, 2, 1]]
    alive = area != 0
    # Background triangles: the pixel at the rounded barycentre is background.
    sr = pts[simplices, 0].sum(axis=1)
    sc = pts[simplices, 1].sum(axis=1)
    bary_r = (sr + 1) // 3
    bary_c = (sc + 1) // 3
    alive &= valid[bary_r, bary_c]
    if max_edge is not None:
        corner = pts[simplices]  # (F, 3, 2)
        d2 = ((corner - np.roll(corner, 1, axis=1)) ** 2).sum(axis=2)
        alive &= (d2 <= float(max_edge) ** 2).all(axis=1)
    if alive.any():
        _kernels.prune_dangling(simplices, neighbors, alive, n_points)
    if not alive.any():
        return _empty(camera, (h, w), grid_shape, n_points,
                      "no triangle is left after removing background and dangling triangles")
    faces = simplices[alive]
    used = np.unique(faces)
    remap = np.full(n_points, -1, np.int64)
    remap[used] = np.arange(used.size)
    faces = remap[faces].astype(np.int32)
    pixels = pts[used].astype(np.int32)
    vertices = backproject(pixels[:, 0], pixels[:, 1], depth[pixels[:, 0], pixels[:, 1]], camera)
    stats = Stats(
        vertices=int(used.size),
        edges=count_edges(faces),
        triangles=int(len(faces)),
        flipped_edges=0,
        grid_shape=grid_shape,
        sampled_points=n_points,
    )
    return Mesh(vertices=vertices, faces=faces, pixels=pixels, camera=camera,
                image_shape=(h, w), stats=stats)
