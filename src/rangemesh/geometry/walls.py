"""The walls of jumps: triangles that join a near surface to a far one (shared geometry).

A mesh of a range image bridges every depth jump with thin "wall" triangles
(a curtain from a chair to the wall behind it). With ``walls=False`` they are
dropped, so that separate surfaces stay separate: by refine's insertion
(`rangemesh.refine.insertion`) and from the strip that closes a 360-degree
seam, whatever the method (`rangemesh.geometry.seam.seam_faces`).

How a jump is decided: an edge of the mesh between vertices of depths ``za``
and ``zb`` (stored units, or metres for a pinhole camera: the ratio is the
same), ``L`` pixels long in the image, is a jump when::

    |za - zb| > jump * min(|za|, |zb|) * max(L, 1)

that is, when the depth changes by more than ``jump`` (`MeshParams.jump`, 5 %) of the
local depth per pixel along the edge. The step scales with the depth, as a
depth camera's noise and its slanted floors do: 10 cm is a jump at 0.5 m
(20 % a pixel) and not at 4 m along a 2-pixel edge (1.25 % a pixel). A
floor seen at a grazing angle changes by about ``z / (f * h)`` per pixel
(``h`` the camera's height, ``f`` its focal length in pixels): 1.5 % a pixel
at 8 m for a Kinect 1 m above the floor, under the default. A triangle with
a jump edge is a wall. For images whose values are not distances from the
camera (disparities, ranges with an offset), the ratio still compares a
step with the local value: choose ``jump`` for the data.
"""

from __future__ import annotations

import numpy as np

from .. import _core
from .._core import build_halfedges, neighbors_from_halfedges, prune_dangling

__all__ = ["wall_faces", "drop_walls", "pixel_lengths", "pixel_angle"]


def pixel_lengths(camera, pixels: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Length of edges a-b in pixels: in the image plane, or by ray angle for per-pixel cameras.

    Parameters
    ----------
    camera : a camera, or None (the image plane)
    pixels : (V, 2) ndarray of int
    a, b : (E,) ndarray of int
        Vertex indices of the edges' ends.
    """
    p = np.asarray(pixels)
    rays = getattr(camera, "directions", None)
    if rays is None:
        p = p.astype(np.float64)
        return np.hypot(p[a, 0] - p[b, 0], p[a, 1] - p[b, 1])
    # the angles' one home: `rangemesh._core.ray_lengths` (the native refine call's too)
    return _core.ray_lengths(camera.as_array(), np.ascontiguousarray(p, dtype=np.int64),
                             np.ascontiguousarray(a, dtype=np.int64),
                             np.ascontiguousarray(b, dtype=np.int64), pixel_angle(camera))


def pixel_angle(camera) -> float:
    """Angle of one pixel: the azimuth step, or the median angle between neighbouring columns."""
    step = getattr(camera, "step", None)
    if step:
        return float(np.radians(abs(step)))
    d = camera.directions
    if d.shape[1] < 2:
        d = d.transpose(1, 0, 2)
    if d.shape[1] < 2:
        return 1.0
    cos = np.clip(np.sum(d[:, 1:] * d[:, :-1], axis=2), -1.0, 1.0)
    angle = float(np.median(np.arccos(cos)))
    return angle if angle > 0 else 1.0


def wall_faces(faces: np.ndarray, pixels: np.ndarray, z: np.ndarray, jump: float,
               camera=None) -> np.ndarray:
    """Which faces have an edge across a jump (see the module's rule).

    Parameters
    ----------
    faces : (F, 3) ndarray of int
    pixels : (V, 2) ndarray of int
        Each vertex's (row, col).
    z : (V,) ndarray of float
        Each vertex's depth.
    jump : float
        Largest depth change per pixel, as a share of the local depth, that is
        not a jump.
    camera : optional
        With a `Spherical` or `Rays` camera, edge lengths are ray angles
        (`pixel_lengths`); otherwise lengths in the image plane.

    Returns
    -------
    (F,) ndarray of bool
    """
    f = np.ascontiguousarray(faces, dtype=np.int64).reshape(-1, 3)
    p = np.ascontiguousarray(pixels, dtype=np.int64).reshape(-1, 2)
    lengths = None  # the kernel measures the image plane itself
    if getattr(camera, "directions", None) is not None:
        lengths = np.stack([pixel_lengths(camera, p, f[:, k], f[:, (k + 1) % 3]) for k in range(3)],
                           axis=1)
    # the rule's one home: `rangemesh._core.wall_faces` (the native refine call's too)
    return _core.wall_faces(f, p, np.ascontiguousarray(z, dtype=np.float64), float(jump), lengths)


def drop_walls(faces: np.ndarray, pixels: np.ndarray, z: np.ndarray,
               jump: float, camera=None) -> tuple[np.ndarray, np.ndarray]:
    """Faces without the walls, then without what leaves a vertex with two fans.

    Dropping walls can leave a vertex with two fans (a bow tie) or a triangle
    with no neighbour; the same pruning as the paper's stage two (SPEC 2.3)
    keeps each vertex's largest fan and drops lone triangles.

    Returns
    -------
    kept : (F,) ndarray of bool
        Faces kept.
    walls : (F,) ndarray of bool
        Faces that were walls (dropped).
    """
    f = np.ascontiguousarray(faces, dtype=np.int64)
    walls = wall_faces(f, pixels, z, jump, camera)
    kept = ~walls
    if walls.any() and kept.any():
        _, halfedges = build_halfedges(f, len(pixels))
        prune_dangling(f, neighbors_from_halfedges(halfedges), kept, len(pixels))
    return kept, walls
