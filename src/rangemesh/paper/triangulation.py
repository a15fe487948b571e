"""Stage two: 2-D Delaunay of the valid samples, pruning, lifting to 3-D.

Paper II.B.1; SPEC.md section 2.
"""

from __future__ import annotations

import numpy as np

from .._core import (
    build_halfedges,
    canonical_faces,
    compact_faces,
    delaunay_sweep,
    keep_faces,
    legalize_all,
    neighbors_from_halfedges,
    prune_dangling,
    valid_samples,
)
from ..blocks import blocks
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
    # canonical order: each face starts at its smallest vertex (keeping its turn), faces sorted
    faces = canonical_faces(triangles, n)
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
    if np.shape(valid) != (h, w):
        raise ValueError(f"valid must have depth's shape {(h, w)}, got {np.shape(valid)}")
    grid_shape = tuple(int(x) for x in np.shape(grid)[:2])
    g = np.asarray(grid)
    if g.dtype != np.int32 and g.dtype != np.int64:  # (stage one's grids are int32)
        g = g.astype(np.int64)
    # distinct valid samples in linear-index order (the whole image and millions of samples: the
    # kernels here poll Ctrl-C, as NumPy's steps could not)
    pts = valid_samples(np.ascontiguousarray(g.reshape(-1, 2)), valid)
    n_points = len(pts)
    if n_points < 3:
        return _empty(camera, (h, w), grid_shape, n_points,
                      f"only {n_points} valid sample(s); a triangle needs 3")
    simplices, neighbors = triangulate_points(pts, engine=engine)
    if len(simplices) == 0:
        return _empty(camera, (h, w), grid_shape, n_points,
                      "all valid samples are collinear; no triangle can be formed")
    # Background triangles (the pixel at the rounded barycentre is background) and, with
    # max_edge, those with a longer edge are not alive.
    alive = np.empty(len(simplices), bool)
    keep_faces(simplices, pts, valid, np.inf if max_edge is None else float(max_edge) ** 2, alive)
    if alive.any():
        prune_dangling(simplices, neighbors, alive, n_points)
    if not alive.any():
        return _empty(camera, (h, w), grid_shape, n_points,
                      "no triangle is left after removing background and dangling triangles")
    faces, pixels = compact_faces(simplices, alive, pts)
    vertices = np.empty((len(pixels), 3))
    for b in blocks(len(pixels), per=3):  # a block at a time: Ctrl-C is seen between them
        p = pixels[b]
        vertices[b] = backproject(p[:, 0], p[:, 1], depth[p[:, 0], p[:, 1]], camera)
    stats = Stats(
        vertices=len(pixels),
        edges=count_edges(faces),
        triangles=int(len(faces)),
        flipped_edges=0,
        grid_shape=grid_shape,
        sampled_points=n_points,
    )
    return Mesh(vertices=vertices, faces=faces, pixels=pixels, camera=camera,
                image_shape=(h, w), stats=stats)
