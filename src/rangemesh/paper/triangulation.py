"""Stage two: 2-D Delaunay of the valid samples, pruning, lifting to 3-D.

Paper II.B.1; SPEC.md section 2.
"""

from __future__ import annotations

import numpy as np

from .._core import build_halfedges, delaunay_sweep, legalize_all, neighbors_from_halfedges, prune_dangling
from ..camera import as_camera, backproject
from ..mesh import Mesh, Stats, count_edges, empty_mesh

__all__ = ["delaunay_mesh", "triangulate_points"]


def _empty(camera, shape, grid_shape, n_points, reason):
    return empty_mesh(camera, shape, Stats(grid_shape=grid_shape, sampled_points=n_points,
                                           reason=reason))
def triangulate_points(pts: np.ndarray, engine: str = "sweep") -> tuple[np.ndarray, np.ndarray]:
    """The canonical Delaunay triangulation of distinct integer points.

    Parameters
    ----------
    pts : (N, 2) ndarray of int
        Distinct ``(row, col)`` points; their order defines the tie-break.
    engine : {'sweep', 'qhull'}, default 'sweep'
        ``'sweep'``: our compiled sweep-hull with exact integer predicates.
        ``'qhull'``: ``scipy.spatial.Delaunay``; kept as an independent
        reference. Both end in the same triangulation.

    Returns
    -------
    simplices : (F, 3) ndarray of int64
        Counter-clockwise in (r, c), in canonical order: each face starts at
        its smallest vertex, faces sorted lexicographically.
    neighbors : (F, 3) ndarray of int64
        Face across the edge opposite corner k, or -1.

    Notes
    -----
    Co-circular points make Delaunay triangulations non-unique; both engines
    are followed by Lawson flips under Simulation of Simplicity (lifted
    heights perturbed by ``eps**i``, smaller index dominant), which lead to
    the one triangulation that is Delaunay for the perturbed points. So the
    result depends only on the point set and its order, never on the engine
    or on floating-point luck.
    """
    pr = np.ascontiguousarray(pts[:, 0], dtype=np.int64)
    pc = np.ascontiguousarray(pts[:, 1], dtype=np.int64)
    n = len(pr)
    empty = np.zeros((0, 3), np.int64)
    if n < 3:
        return empty, empty
    if engine == "sweep":
        triangles, halfedges = delaunay_sweep(pr, pc)
        if len(triangles) == 0:
            return empty, empty
    elif engine == "qhull":
        from scipy.spatial import Delaunay, QhullError  # the reference engine only

        try:
            simplices = Delaunay(np.stack([pr, pc], axis=1).astype(np.float64)).simplices
        except QhullError:
            return empty, empty
        simplices = simplices.astype(np.int64)
        r, c = pr[simplices], pc[simplices]
        area = (r[:, 1] - r[:, 0]) * (c[:, 2] - c[:, 0]) - (c[:, 1] - c[:, 0]) * (r[:, 2] - r[:, 0])
        simplices[area < 0] = simplices[area < 0][:, [0, 2, 1]]
        simplices = simplices[area != 0]
        if len(simplices) == 0:
            return empty, empty
        triangles, halfedges = build_halfedges(simplices, n)
    else:
        raise ValueError(f"engine must be 'sweep' or 'qhull', got {engine!r}")
    legalize_all(triangles, halfedges, pr, pc)
    faces = triangles.reshape(-1, 3)
    # canonical order: start each face at its smallest vertex (keeping its turn), then sort
    k = np.argmin(faces, axis=1)
    idx = (k[:, None] + np.arange(3)[None, :]) % 3
    faces = np.take_along_axis(faces, idx, axis=1)
    if n < 2**20:  # one int64 key per face: an argsort instead of a lexsort
        key = (faces[:, 0] * n + faces[:, 1]) * n + faces[:, 2]
        faces = faces[np.argsort(key, kind="stable")]
    else:
        faces = faces[np.lexsort((faces[:, 2], faces[:, 1], faces[:, 0]))]
    faces = np.ascontiguousarray(faces)
    _, halfedges = build_halfedges(faces, n)
    return faces, neighbors_from_halfedges(halfedges)
def delaunay_mesh(grid: np.ndarray, depth: np.ndarray, valid: np.ndarray, camera=None, *,
                  max_edge: float | None = None, engine: str = "sweep") -> Mesh:
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
    engine : {'sweep', 'qhull'}, default 'sweep'
        Delaunay implementation; both give the same canonical triangulation
        (see `triangulate_points`).

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
    * 2-D Delaunay runs on integer pixel coordinates with exact predicates.
      Pixel grids are full of co-circular points; ties are broken by
      Simulation of Simplicity so that the triangulation is unique (see
      `triangulate_points`), whichever engine computes it.
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
    # distinct valid samples in linear-index order (a mark per pixel: cheaper than a sort)
    mark = np.zeros(h * w, bool)
    mark[g[:, 0] * w + g[:, 1]] = True
    mark &= valid.ravel()
    lin = np.flatnonzero(mark)
    n_points = int(lin.size)
    if n_points < 3:
        return _empty(camera, (h, w), grid_shape, n_points,
                      f"only {n_points} valid sample(s); a triangle needs 3")
    pts = np.stack([lin // w, lin % w], axis=1)
    simplices, neighbors = triangulate_points(pts, engine=engine)
    if len(simplices) == 0:
        return _empty(camera, (h, w), grid_shape, n_points,
                      "all valid samples are collinear; no triangle can be formed")
    alive = np.ones(len(simplices), bool)
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
        prune_dangling(simplices, neighbors, alive, n_points)
    if not alive.any():
        return _empty(camera, (h, w), grid_shape, n_points,
                      "no triangle is left after removing background and dangling triangles")
    faces = simplices[alive]
    in_use = np.zeros(n_points, bool)
    in_use[faces.ravel()] = True
    used = np.flatnonzero(in_use)
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
