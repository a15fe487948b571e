"""The 360-degree seam of a wrap-around image: column W-1 is the neighbour of column 0.

A mesh of the image is a cylinder cut open along the seam. `seam_strip`
closes the cut with a strip of triangles between the mesh's boundary edges on
column W-1 and on column 0, as if column 0 were repeated as column W: the
strip is one pixel wide, covers no pixel centre, and joins the two surfaces
only where both columns have mesh.

Seam faces are counter-clockwise in the image plane once their column-0
vertices are moved to column W ("unrolled"); in the plain image plane they
are clockwise, which is how `is_seam` tells them from every other face (all
counter-clockwise).
"""

from __future__ import annotations

import numpy as np

from .walls import wall_faces

__all__ = ["seam_strip", "is_seam", "unrolled_columns", "strip_to_keep", "seam_faces"]


def _signed_area(r, c, faces):
    r = r[faces]
    c = c[faces]
    return (r[:, 1] - r[:, 0]) * (c[:, 2] - c[:, 0]) - (c[:, 1] - c[:, 0]) * (r[:, 2] - r[:, 0])


def is_seam(pixels: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Which faces cross the seam: those clockwise in the image plane.

    Parameters
    ----------
    pixels : (V, 2) ndarray of int
    faces : (F, 3) ndarray of int

    Returns
    -------
    (F,) ndarray of bool
    """
    if len(faces) == 0:
        return np.zeros(0, bool)
    r = pixels[:, 0].astype(np.int64)
    c = pixels[:, 1].astype(np.int64)
    return _signed_area(r, c, faces) < 0


def unrolled_columns(pixels: np.ndarray, width: int) -> np.ndarray:
    """Vertex columns with column 0 moved to column `width` (valid for seam faces only)."""
    c = pixels[:, 1].astype(np.int64)
    return np.where(c == 0, width, c)


def _seam_side_edges(pixels, faces, width):
    """Directed edges with both ends on column 0 or both on column W-1 and no twin (boundary)."""
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]).astype(np.int64)
    c = pixels[:, 1]
    side = (c[e[:, 0]] == c[e[:, 1]]) & ((c[e[:, 0]] == 0) | (c[e[:, 0]] == width - 1))
    e = e[side]  # the few edges that can matter: the twin test needs only these
    n = len(pixels)
    open_ = ~np.isin(e[:, 0] * n + e[:, 1], e[:, 1] * n + e[:, 0])
    return e[open_]


def _chain(pixels, edges, col):
    """Boundary vertices on column `col`, sorted by row, and which consecutive pairs are edges."""
    n = len(pixels)
    ends = edges[pixels[edges[:, 0], 1] == col]
    if len(ends) == 0:
        return np.zeros(0, np.int64), np.zeros(0, bool), np.zeros((0, 2), np.int64)
    verts = np.unique(ends)
    verts = verts[np.argsort(pixels[verts, 0], kind="stable")]
    pos = np.full(n, -1, np.int64)
    pos[verts] = np.arange(len(verts))
    a, b = pos[ends[:, 0]], pos[ends[:, 1]]
    lo = np.minimum(a, b)
    if not (np.abs(a - b) == 1).all():
        raise RuntimeError("seam_strip: a boundary edge on the seam column skips a vertex")
    has = np.zeros(max(len(verts) - 1, 0), bool)
    has[lo] = True
    rows = pixels[verts, 0].astype(np.int64)
    return verts, has, rows


def _overlaps(rows, has, k, lo, hi):
    """Whether an edge of a chain at its vertex k (before or after it) overlaps rows (lo, hi)."""
    for j in (k - 1, k):
        if 0 <= j < len(has) and has[j] and min(rows[j + 1], hi) > max(rows[j], lo):
            return True
    return False


def seam_strip(pixels: np.ndarray, faces: np.ndarray, width: int) -> np.ndarray:
    """Triangles that close the seam between column ``width-1`` and column 0.

    The boundary edges of the mesh that lie on column 0 and on column
    ``width-1`` are zipped together, the two chains walked by increasing row
    (the next vertex taken from the side whose next row is smaller, the
    shorter diagonal of each quad). A triangle is made on a boundary edge
    only where the other side has a boundary edge over an overlapping span of
    rows, so the strip joins the two sides only where both have mesh.

    Parameters
    ----------
    pixels : (V, 2) ndarray of int
        Each vertex's ``(row, col)``.
    faces : (F, 3) ndarray of int
        The mesh, counter-clockwise in the image plane.
    width : int
        Image width W.

    Returns
    -------
    (K, 3) ndarray of int32
        New faces, counter-clockwise once unrolled (`unrolled_columns`),
        clockwise in the image plane (`is_seam`).
    """
    if width < 3 or len(faces) == 0:
        return np.zeros((0, 3), np.int32)
    edges = _seam_side_edges(pixels, faces, width)
    lv, lhas, lrows = _chain(pixels, edges, 0)
    rv, rhas, rrows = _chain(pixels, edges, width - 1)
    out = []
    i = j = 0
    while i < len(lv) - 1 or j < len(rv) - 1:
        step_left = j >= len(rv) - 1 or (i < len(lv) - 1 and lrows[i + 1] <= rrows[j + 1])
        if step_left:
            if lhas[i] and _overlaps(rrows, rhas, j, lrows[i], lrows[i + 1]):
                out.append((lv[i], lv[i + 1], rv[j]))
            i += 1
        else:
            if rhas[j] and _overlaps(lrows, lhas, i, rrows[j], rrows[j + 1]):
                out.append((lv[i], rv[j], rv[j + 1]))
            j += 1
    if not out:
        return np.zeros((0, 3), np.int32)
    strip = np.array(out, np.int64)
    r = pixels[:, 0].astype(np.int64)
    area = _signed_area(r, unrolled_columns(pixels, width), strip)
    if (area == 0).any():
        raise RuntimeError("seam_strip: a degenerate seam triangle")
    flip = area < 0
    strip[flip] = strip[flip][:, [0, 2, 1]]
    return strip.astype(np.int32)


def _fan_roots(faces):
    """Union-find roots of the corners ``3t + k`` of `faces`, as an (F, 3) array.

    Corners at one vertex of two faces that share an edge are joined, so each
    vertex's fans are its distinct roots.
    """
    n = len(faces)
    parent = np.arange(3 * n)

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    corner = {}
    for t, face in enumerate(faces.tolist()):
        for k in range(3):
            corner[(t, face[k])] = 3 * t + k
    owner = {}
    for t, face in enumerate(faces.tolist()):
        for k in range(3):
            owner.setdefault((face[k], face[(k + 1) % 3]), []).append(t)
    for (a, b), ts in owner.items():
        for u in owner.get((b, a), []) + ts[1:]:
            for v in (a, b):
                ra, rb = find(corner[(ts[0], v)]), find(corner[(u, v)])
                parent[max(ra, rb)] = min(ra, rb)
    return np.array([find(i) for i in range(3 * n)], np.int64).reshape(n, 3)


def strip_to_keep(faces: np.ndarray, strip: np.ndarray) -> np.ndarray:
    """Which faces of `strip` to keep so that the mesh stays a surface with one fan a vertex (SPEC P4).

    `faces` (a valid mesh) stay as they are. A strip face is dropped when it
    repeats a face of the mesh or one of its directed edges (a mesh face across
    the image's whole width already joins those vertices), and then, until none
    is left, when its corner at some vertex lies outside that vertex's fan of
    `faces` (the strip reaching the vertex across a dropped wall or background
    triangle). The strip adds no vertex, so no vertex is lost; and its faces
    cover no pixel centre, so the mesh's error stays the same.

    Parameters
    ----------
    faces : (F, 3) ndarray of int
        The mesh, one fan per vertex.
    strip : (K, 3) ndarray of int
        Seam faces on the mesh's vertices (`seam_strip`).

    Returns
    -------
    (K,) ndarray of bool
    """
    kept = np.ones(len(strip), bool)
    if not len(strip):
        return kept
    on_seam = np.unique(strip)
    # only faces at the strip's vertices can share an edge or a fan with the strip
    near = np.isin(faces, on_seam).any(axis=1)
    local = np.asarray(faces)[near].astype(np.int64)
    seen = {(a, b) for a, b, c in local.tolist() for a, b in ((a, b), (b, c), (c, a))}
    triples = {frozenset(face) for face in local.tolist()}
    for i, (a, b, c) in enumerate(strip.tolist()):
        edges = ((a, b), (b, c), (c, a))
        if frozenset((a, b, c)) in triples or any(e in seen for e in edges):
            kept[i] = False
        else:
            seen.update(edges)
    while kept.any():
        both = np.concatenate([local, strip[kept].astype(np.int64)])
        roots = _fan_roots(both)
        mesh_root = {}
        for face, root in zip(both[:len(local)].tolist(), roots[:len(local)].tolist(),
                              strict=True):
            for v, r in zip(face, root, strict=True):
                mesh_root.setdefault(v, r)
        bad = np.zeros(kept.sum(), bool)
        for i, (face, root) in enumerate(zip(both[len(local):].tolist(),
                                             roots[len(local):].tolist(), strict=True)):
            bad[i] = any(mesh_root.get(v, r) != r for v, r in zip(face, root, strict=True))
        if not bad.any():
            break
        kept[np.flatnonzero(kept)[bad]] = False
    return kept


def seam_faces(pixels: np.ndarray, faces: np.ndarray, width: int, *,
               depth: np.ndarray | None = None, jump: float | None = None,
               camera=None) -> np.ndarray:
    """The faces that close a mesh's seam: `seam_strip`, its walls dropped, what `strip_to_keep` keeps.

    With a `jump` (``walls=False``) the strip's triangles across a jump are
    dropped by the rule of `rangemesh.geometry.walls`, their pixel lengths
    measured across the seam (or as ray angles with a ray `camera`). Then
    every strip face that would repeat an edge of the mesh or give a vertex a
    second fan is dropped: the mesh's own faces and vertices stay, so a
    vertex count asked for is kept.

    Parameters
    ----------
    pixels : (V, 2) ndarray of int
    faces : (F, 3) ndarray of int
        The mesh, one fan per vertex.
    width : int
        The image's width W (column W-1 is beside column 0).
    depth : (H, W) ndarray of float, optional
        The vertices' depths are read from it; needed with `jump`.
    jump : float, optional
        Drop the strip's walls (`rangemesh.geometry.walls.wall_faces`).
    camera : optional
        With a `Spherical` or `Rays` camera, edge lengths are ray angles.

    Returns
    -------
    (K, 3) ndarray of int
        Faces to add to `faces` (counter-clockwise once unrolled).
    """
    strip = seam_strip(pixels, faces, width)
    if len(strip) and jump is not None:
        z = depth[pixels[:, 0], pixels[:, 1]]
        if hasattr(camera, "directions"):  # lengths are ray angles: the seam is no gap
            walls = wall_faces(strip, pixels, z, jump, camera)
        else:
            coords = np.stack([pixels[:, 0], unrolled_columns(pixels, width)], axis=1)
            walls = wall_faces(strip, coords, z, jump)
        strip = strip[~walls]
    # a strip face that repeats a mesh edge or reaches a vertex across a dropped wall would
    # break P4: such faces go, the mesh's own faces and vertices stay
    return strip[strip_to_keep(faces, strip)]
