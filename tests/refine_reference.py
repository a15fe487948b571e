"""The refine method's target search as its Python steps were (`_greedy`, before 2026-11-27).

The native call (`rangemesh._core.refine_mesh`) is the search's one home; these steps, the
library's own until it moved there, stay here as the reference the tests hold the native call
to, bit for bit (`test_refine.py`). Not the library's: nothing in `src/` imports it.
"""

from __future__ import annotations

import time

import numpy as np

from rangemesh._core import (
    InsertSettings,
    build_halfedges,
    count_edges,
    delaunay_sweep,
    flip_by_error,
    greedy_insert,
    neighbors_from_halfedges,
    prune_dangling,
    valid_faces,
)
from rangemesh.camera import backproject
from rangemesh.mesh import Mesh, Stats, empty_mesh
from rangemesh.refine.heights import fit_heights
from rangemesh.refine.insertion import (
    MAX_BISECT_RUNS,
    MAX_ERROR_STOP,
    MAX_RUNS,
    _count_record,
    _error_record,
    _plan,
)
from rangemesh.refine.start import first_mesh, valid_hull
from rangemesh.refine.walls import drop_walls
from rangemesh.render import relative_error

from .strips_reference import strip_insert


def hull_mesh(depth: np.ndarray, valid: np.ndarray, limit: int, scales=(1, 1)):
    """A first mesh of valid pixels only: at most `limit` corners of their convex hull.

    The start when the image corners' mesh leaves no triangle of valid
    corners (valid pixels far apart in a large background): its triangles
    hold only valid vertices, and insertion refines within them.

    Returns
    -------
    vr, vc, vz, tv, he : ndarrays, or None
        As `rangemesh.refine.start.first_mesh`; None when the valid pixels are fewer than 3 or
        collinear (no triangle exists), or `limit` is under 3.
    """
    hull = valid_hull(valid)
    if len(hull) < 3 or limit < 3:
        return None
    if len(hull) > limit:  # evenly spread corners of a convex polygon: still one
        hull = hull[np.linspace(0, len(hull), int(limit), endpoint=False).astype(np.int64)]
    vr, vc = hull[:, 0].copy(), hull[:, 1].copy()
    tv, he = delaunay_sweep(vr * scales[0], vc * scales[1])
    if len(tv) == 0:
        raise RuntimeError("hull_mesh: the hull's corners cannot be collinear")
    return vr, vc, depth[vr, vc], tv, he


def _assemble(vr, vc, tv, depth, valid, camera, walls, jump):
    """Drop triangles with a background vertex (and walls, unless `walls`), then unused vertices.

    Returns the faces, pixels and the number of walls dropped.
    """
    faces, pixels = valid_faces(vr, vc, tv, valid)
    if 0 < len(faces) < len(tv) // 3:
        faces, pixels = _one_fan_each(faces, pixels, valid)
    n_walls = 0
    if not walls and len(faces):
        kept, wall = drop_walls(faces, pixels, depth[pixels[:, 0], pixels[:, 1]], jump, camera)
        n_walls = int(wall.sum())
        if n_walls:  # the same pass again: every kept face is valid, so it drops unused vertices
            faces, pixels = valid_faces(pixels[:, 0].astype(np.int64), pixels[:, 1].astype(np.int64),
                                        faces[kept].ravel().astype(np.int64), valid)
    return faces, pixels, n_walls


def _one_fan_each(faces, pixels, valid):
    """Drop what leaves a vertex with two fans once the background triangles are gone (SPEC P4).

    Two triangles of valid pixels may meet at one vertex only across a dropped
    background triangle; each such vertex keeps its largest fan (`prune_dangling`,
    as the paper's stage two and `drop_walls` do), and lone triangles stay.
    """
    f = faces.astype(np.int64)
    _, halfedges = build_halfedges(f, len(pixels))
    kept = np.ones(len(f), bool)
    if prune_dangling(f, neighbors_from_halfedges(halfedges), kept, len(pixels), drop_lone=False):
        faces, pixels = valid_faces(pixels[:, 0].astype(np.int64), pixels[:, 1].astype(np.int64),
                                    f[kept].ravel(), valid)
    return faces, pixels


def _copied(pixels, depth, camera):
    """The vertices lifted to 3-D with each pixel's own depth (made only when kept)."""
    return backproject(pixels[:, 0], pixels[:, 1], depth[pixels[:, 0], pixels[:, 1]], camera)


def _fitted(faces, pixels, depth, valid, camera, extent):
    """The vertices with least-squares depths (`fit_heights`), same pixels and faces."""
    z = fit_heights(pixels, faces, depth, valid, camera, extent=extent)
    return backproject(pixels[:, 0], pixels[:, 1], z, camera)


def _bounded(faces, pixels, depth, valid, camera, shape, max_error, ref, fit, extent):
    """The vertices to keep under `max_error`, and their relative error against `ref`.

    With `fit`, fitted depths are tried first: they meet the bound far more
    often than copied ones, so one render of the mesh usually decides (measuring
    the copied depths' error first would cost a second render). Copied depths
    are kept only when they meet the bound
    and the fitted ones do not.
    """
    def error(v):
        return relative_error(Mesh(v, faces, pixels, camera, shape), *ref)

    if not fit:
        verts = _copied(pixels, depth, camera)
        return verts, error(verts)
    fitted = _fitted(faces, pixels, depth, valid, camera, extent)
    fitted_error = error(fitted)
    if fitted_error > max_error:
        verts = _copied(pixels, depth, camera)
        copied_error = error(verts)
        if copied_error <= max_error:
            return verts, copied_error
    return fitted, fitted_error


def _refine(depth, valid, start, strips, asked, max_sum, span, scales, n_grid, diagonals,
            info=None):
    """``vr, vc, tv`` of greedy insertion, on one strip or two (`strip_insert`).

    With ``diagonals='error'`` each quad then takes the diagonal that fits
    its pixels better (`rangemesh.refine.diagonals`; on strips, each strip
    on its thread, then the seam); `info` receives ``flips`` and ``total``,
    the insertion's summed error of the valid pixels where it stopped.
    """
    info = {} if info is None else info
    info["flips"] = 0
    if strips:  # two strips on two threads (`rangemesh.refine.strips`)
        vr, vc, tv, _, info["total"] = strip_insert(depth, valid, asked, span, scales, n_grid,
                                                    max_sum=max_sum, diagonals=diagonals,
                                                    info=info)
        return vr, vc, tv
    if diagonals != "error":
        out = greedy_insert(depth, valid, start, InsertSettings(asked, max_sum, span, *scales))
        info["total"] = out.total
        return out.vr, out.vc, out.tv
    # the insertion's own half-edges and triangle sums: no second pass over the pixels
    out = greedy_insert(depth, valid, start, InsertSettings(asked, max_sum, span, *scales, sums=True))
    vr, vc, tv, he, tsum = out.vr, out.vc, out.tv, out.he, out.tsum
    info["total"] = float(tsum.sum())
    info["flips"] = int(flip_by_error((vr, vc, tv, he, tsum), depth, valid, span)[0])
    return vr, vc, tv


def _greedy(depth, valid, camera, ref, extent, exponent, *, vertices, max_error, fit, diagonals,
            walls, jump, max_vertices, first):
    """`greedy_mesh` on depths divided by ``2**exponent`` (`ref` and `extent` too).

    Its vertices are lifted from those depths; the notes name the depth range
    in the image's own units.
    """
    h, w = depth.shape
    t0 = time.perf_counter()
    lo, hi, n_valid = extent
    span = hi - lo
    want, scales, n_grid, strips = _plan(depth.shape, camera, n_valid, vertices, max_error,
                                         max_vertices)
    strips = strips and first is None
    start = first if first is not None or strips else first_mesh(depth, valid, n_grid, scales)
    stop = MAX_ERROR_STOP if fit else 1.0  # (the first insertion's stop, fitted heights only)
    max_sum = -1.0 if max_error is None else stop * float(max_error) / 100.0 * span * n_valid
    runs = 0
    asked = want
    achieved = float("nan")  # the relative error, measured with max_error only
    short, beyond = 0, n_valid + 1  # requests known to give fewer / more than `want`
    best = None  # with `vertices`: the result nearest `want`, not above it if any is
    fit_seconds = 0.0  # fitting the depths (with max_error, measuring their error too)
    counted = None  # with max_error, once searching by count: its bounds and best result
    info = {}
    while True:
        runs += 1
        vr, vc, tv = _refine(depth, valid, start, strips, asked, max_sum, float(span), scales,
                             n_grid, diagonals, info)
        faces, pixels, n_walls = _assemble(vr, vc, tv, depth, valid, camera, walls, jump)
        got = len(pixels)
        if vertices is not None:
            rank = (got > want, abs(got - want))
            if best is None or rank < best[0]:
                best = (rank, faces, pixels, n_walls)
            if got != want and runs < (MAX_RUNS if beyond > n_valid else MAX_BISECT_RUNS):
                # Vertices left without a triangle (background corners' fans, dropped
                # walls): insert as many more. Dropping walls is not monotone in the
                # request, so past N the request is bisected between the last one short
                # of N and the first beyond it; the nearest result not above N is kept.
                if got < want:
                    short = max(short, asked)
                else:
                    beyond = min(beyond, asked)
                nxt = asked + (want - got) if beyond > n_valid else (short + beyond) // 2
                nxt = min(nxt, n_valid)
                if short < nxt < beyond and nxt != asked:
                    asked = nxt
                    continue
            _, faces, pixels, n_walls = best
            got = len(pixels)
        if max_error is not None and len(faces):
            t = time.perf_counter()
            verts, achieved = _bounded(faces, pixels, depth, valid, camera, (h, w),
                                       max_error, ref, fit, extent)
            if fit:
                fit_seconds += time.perf_counter() - t
            if counted is not None:
                if achieved <= max_error:
                    counted["met"], counted["hi"] = (faces, pixels, n_walls, verts, achieved), asked
                else:
                    counted["lo"] = asked
                few, most = counted["lo"], counted["hi"]
                # the last meshing asks for the largest count if no count met the bound yet
                nxt = want if runs == MAX_RUNS - 1 and counted["met"] is None else (few + most) // 2
                if runs < MAX_RUNS and few < nxt <= most and nxt != asked \
                        and (counted["met"] is None or nxt < most):
                    asked = nxt
                    continue
                if counted["met"] is not None:
                    faces, pixels, n_walls, verts, achieved = counted["met"]
                    got = len(pixels)
            elif achieved > max_error and asked > got and runs < MAX_RUNS:
                if info["total"] > 0.0:
                    max_sum *= 0.9  # the running sum is an estimate: tighten and go on
                    continue
                # The insertion's own sum is 0 (every pixel fits its plane in the kernel's
                # arithmetic) while the rendered mesh rounds otherwise (depths far from 0 with a
                # tiny range): a tighter sum stops at the same mesh. Search by count instead,
                # up to `want` (every valid pixel a vertex renders exactly).
                counted = {"lo": got, "hi": want, "met": None}
                max_sum = -1.0
                if strips:  # (strips never insert the seam column's other pixels)
                    strips = False
                    start = first_mesh(depth, valid, n_grid, scales)
                asked = want if runs == MAX_RUNS - 1 else (got + want) // 2
                continue
        break
    t1 = time.perf_counter()
    if fit and len(faces) and max_error is None:
        verts = _fitted(faces, pixels, depth, valid, camera, extent)
        fit_seconds += time.perf_counter() - t1
    elif max_error is None or not len(faces):
        verts = _copied(pixels, depth, camera)
    seconds = {"insertion": time.perf_counter() - t0 - fit_seconds}
    if fit and len(faces):
        seconds["fit"] = fit_seconds
    # (the kernel itself: faces made here need no checks)
    stats = Stats(vertices=got, triangles=len(faces), edges=count_edges(faces, got),
                  sampled_points=got, seconds=seconds, method="refine", grid_shape=None,
                  flipped_edges=info["flips"], insertions=len(vr), strips=2 if strips else 1,
                  heights="fit" if fit else "pixel")
    if len(faces) == 0 and first is None and (walls or not n_walls):
        # every triangle had a background image corner: start again from valid pixels only
        hull = hull_mesh(depth, valid, want, scales)
        if hull is not None:
            return _greedy(depth, valid, camera, ref, extent, exponent, vertices=vertices,
                           max_error=max_error, fit=fit, diagonals=diagonals, walls=walls,
                           jump=jump, max_vertices=max_vertices, first=hull)
    if len(faces) == 0:
        reason = (f"every triangle was a wall across a jump ({n_walls} dropped)"
                  if n_walls and not walls else
                  f"the {n_valid} valid pixels lie on one line: no triangle"
                  if len(valid_hull(valid)) < 3 and n_valid >= 3 else
                  f"only {n_valid} valid pixel{'s' if n_valid != 1 else ''}: a triangle needs 3"
                  if n_valid < 3 else
                  "no triangle with valid corners")
        stats = Stats(seconds=seconds, method="refine", grid_shape=None, reason=reason)
        return empty_mesh(camera, (h, w), stats), {}
    mesh = Mesh(verts, faces, pixels, camera, (h, w), stats)
    dropped = None if walls else n_walls
    if vertices is not None:
        return mesh, _count_record(got, int(vertices), runs, n_valid, h * w, walls and n_walls == 0,
                                   dropped)
    return mesh, _error_record(achieved, float(max_error), runs, got, asked, want, max_vertices,
                               dropped)
