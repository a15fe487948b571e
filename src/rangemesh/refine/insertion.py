"""Meshes by greedy insertion (Garland & Heckbert 1995), on a prepared range image."""

from __future__ import annotations

import math

import numpy as np

from .. import _core
from .. import threads as _threads
from .._core import (
    EXACT_SPAN,
    valid_range,
)
from ..camera import _UNIT, Orthographic, pixel_aspect
from ..mesh import Mesh, Stats, empty_mesh, with_fields
from ..render import deviation_scale
from . import heights as _heights
from .heights import height_rule
from .start import corner_depths, first_mesh, valid_hull
from .strips import SEAM_DENSITY, SEAM_ERROR_SHARE, use_strips
from .walls import pixel_angle

__all__ = ["greedy_mesh", "corner_depths", "first_mesh", "delaunay_scales"]


# The first mesh: the image corners and a coarse grid of valid pixels, about this
# share of the vertices asked (at most GRID_MAX points; GRID_ERROR_BOUND points with
# max_error, whose count is not known beforehand). Starting from the two triangles of
# the image rectangle, the first insertions would each rescan a large part of the image.
GRID_SHARE = 1.0 / 16.0
# Meshings at most: to land on `vertices` when fans or walls are dropped, or on `max_error`.
MAX_RUNS = 8
# ... and once a request gave more than `vertices` (walls dropped), at most this many: the
# count then lands within a few vertices of N, with a note, rather than costing 8 meshings.
MAX_BISECT_RUNS = 5
# max_deviation=D: the first insertion stops at a summed error of this share of D a valid pixel
# (the rounds insert the rest: a smaller share over-inserts, a larger one costs more rounds).
MAX_DEVIATION_SHARE = 0.25
# max_error=E, fitted heights: the first insertion stops at a summed error (copied depths) of
# this many times E's, E / 100 * span * n_valid: at 1.0 the fit rendered 0.28-0.36 % for 0.5 %. The
# largest tried that meets 0.3, 0.5 and 1 % on every real image in one meshing (1.25 misses
# once: docs/benchmarks.md, "The default target"; benchmarks/error_stop.py).
MAX_ERROR_STOP = 1.15
GRID_MAX = 256
GRID_ERROR_BOUND = 64
# Rows (or columns) count an integer times more in the Delaunay test once the sensor's rows lie
# at least ASPECT_MIN times farther apart than its columns (or the reverse): a spinning LiDAR's
# beams (an Ouster OS1-64's 0.55 degrees against 0.18 between columns): its triangles are then
# about as wide as tall in angle, which lowers its error (docs/benchmarks.md). Below that ratio
# (depth cameras' pixels are square to a few %) the pixels' own grid is kept. At most
# ASPECT_MAX, and the scaled image at most EXACT_SIDE a side: the predicates stay exact in int64.
ASPECT_MIN = 1.5
ASPECT_MAX = 8
EXACT_SIDE = EXACT_SPAN
# `greedy_mesh` divides depths by a power of two when their largest magnitude lies beyond
# 2**DEPTH_BAND or below 2**-DEPTH_BAND: the kernels' squares (plane fits, least squares) overflow
# from about 1e150 and underflow below about 1e-160. Within the band nothing is copied.
DEPTH_BAND = _core.DEPTH_BAND  # (64: the small call checks the same band natively)
# effort="best": insertion to this many times the vertices, then collapses down to the count
# (`_core` refine/collapse.hpp). The measured choice: docs/benchmarks.md, "effort".
COLLAPSE_BEST = 4.0


def delaunay_scales(camera, shape) -> tuple[int, int]:
    """Integer weights ``(rows, columns)`` of the Delaunay test, from the camera's pixel aspect.

    ``(round(a), 1)`` when the camera's rows lie ``a >= ASPECT_MIN`` times
    farther apart than its columns (`rangemesh.camera.pixel_aspect`), ``(1,
    round(1/a))`` in the other direction, else ``(1, 1)``: triangles are then
    about as wide as tall in the sensor's units (angles for a spinning
    LiDAR), not in pixels. Capped at ASPECT_MAX and so that the scaled image
    stays within EXACT_SIDE a side.

    Examples
    --------
    >>> from rangemesh.camera import Orthographic
    >>> delaunay_scales(Orthographic(3.1, 1.0), (64, 2048))
    (3, 1)
    >>> delaunay_scales(Orthographic(1.2, 1.0), (64, 2048))
    (1, 1)
    """
    a = pixel_aspect(camera)
    h, w = shape
    if a >= ASPECT_MIN:
        k = min(int(round(a)), ASPECT_MAX, max(EXACT_SIDE // max(h - 1, 1), 1))
        return k, 1
    if a <= 1.0 / ASPECT_MIN:
        k = min(int(round(1.0 / a)), ASPECT_MAX, max(EXACT_SIDE // max(w - 1, 1), 1))
        return 1, k
    return 1, 1


def grid_size(want: int, n_valid: int, by_error: bool) -> int:
    """Grid points of the first mesh: a share of `want` vertices, or a fixed few for max_error."""
    if by_error:
        return min(GRID_ERROR_BOUND, int(n_valid * GRID_SHARE))
    return min(GRID_MAX, int(want * GRID_SHARE))


def _empty_reason(walls_dropped: int, walls: bool, valid: np.ndarray, n_valid: int) -> str:
    """Why the native call left no triangle (its hull restart included): the cause, named."""
    if walls_dropped and not walls:
        return f"every triangle was a wall across a jump ({walls_dropped} dropped)"
    if n_valid >= 3 and len(valid_hull(valid)) < 3:
        return f"the {n_valid} valid pixels lie on one line: no triangle"
    if n_valid < 3:
        return f"only {n_valid} valid pixel{'s' if n_valid != 1 else ''}: a triangle needs 3"
    return "no triangle with valid corners"


def _count_note(got: int, asked: int, n_valid: int, n_pixels: int, no_walls_dropped: bool) -> str:
    """Why a mesh has `got` vertices, not the `asked` ones: the cause that applies, named."""
    if n_valid < asked:
        return f"the image has only {n_valid} valid pixels"
    if got > asked:
        return f"{got} vertices: the image rectangle's corners are always vertices"
    if n_valid < n_pixels or not no_walls_dropped:
        dropped = "background triangles" if n_valid < n_pixels else ""
        walls = "" if no_walls_dropped else "walls"
        return f"{got} vertices kept after dropping {' and '.join(x for x in (dropped, walls) if x)}"
    return f"{got} vertices: the insertion found no other pixel to insert"


def greedy_mesh(depth: np.ndarray, valid: np.ndarray, camera, *, vertices: int | None = None,
                max_error: float | None = None, reference=None, fit: bool = True,
                diagonals: str = "error", walls: bool = True, jump: float = 0.05,
                extent=None, max_vertices: int | None = None, max_deviation: float | None = None,
                mean_deviation: float | None = None,
                max_edge: float | None = None, effort: str = "fast") -> tuple[Mesh, dict]:
    """Mesh a prepared image by inserting its worst pixel until a target is met.

    Parameters
    ----------
    depth, valid : (H, W) ndarrays
        Prepared image (`rangemesh.pipeline.prepare`): float64 depth, bool mask.
    camera : Orthographic, Pinhole, Spherical or Rays
        Lifts the vertices to 3-D; its pixel aspect also sets the units of
        the Delaunay test (`delaunay_scales`): a spinning LiDAR's rows, 3x
        farther apart than its columns, count 3x.
    vertices : int, optional
        Exactly this many vertices (every valid pixel if there are fewer).
    max_error : float, optional
        Insert until the relative error (percent of the valid depth range,
        mean over the valid pixels, as `rangemesh.evaluate`) is at most this.
    reference : (depth, valid), optional
        The image the error bound is checked against (the original, before
        gap filling); default `depth`, `valid`.
    fit : bool, default True
        Fit the vertex depths by least squares (`fit_heights`) once the
        triangulation is chosen; else copy each from its pixel. With
        `max_error`, fitted depths are kept only when they meet the bound.
    diagonals : {'error', 'delaunay'}, default 'error'
        ``'error'``: once the vertices are chosen, flip each edge whose two
        triangles fit their pixels better the other way
        (`rangemesh.refine.diagonals`); ``'delaunay'``: keep the Delaunay
        mesh of the insertion.
    walls : bool, default True
        Keep the triangles across depth jumps; ``False`` drops them
        (`rangemesh.refine.walls`), and insertion goes on until `vertices`
        vertices remain in use.
    jump : float, default 0.05
        The jump rule's share of the local depth per pixel (``walls=False``).
    extent : (float, float, int), optional
        ``valid_range(depth, valid)`` when the caller has it.
    max_vertices : int, optional
        With `max_error`, `max_deviation` or `mean_deviation`: stop at this
        many vertices even if the bound is not met (noisy images would
        otherwise take a large share of their pixels; `run` gives the
        vertices the memory available holds).
    max_deviation : float, optional
        Insert until every valid pixel of `reference` the mesh covers lies
        within this of the mesh (L-infinity, `deviation_scale`). One
        insertion, stopped when its summed error reaches a quarter of the
        bound a pixel, then rounds: the mesh's depths are set (copied first,
        until they meet the bound, then fitted, each fitted depth kept within
        the bound of its own pixel), its render measured, and the worst pixel
        of every triangle still beyond the bound inserted into the insertion
        (its diagonals then chosen again), until no pixel is beyond. Every round
        inserts a pixel at least, so the bound is met unless a pixel beyond it
        cannot be inserted (the render's rounding at a vertex, a pixel
        valid only in `reference`).
    mean_deviation : float, optional
        Insert until the mean deviation over the covered valid pixels is at
        most this: one insertion stopped at that summed error, then rounds
        with fitted depths inserting the worst pixels of the triangles of the
        largest summed deviation (holding twice the excess) until met.
    max_edge : float, optional
        With any target: then insert the worst pixel (the pixel nearest the
        middle of the longest edge when it covers none) of every triangle
        with an edge longer than this many pixels in the image plane, in
        rounds, until none is left; the vertex count may then exceed
        `vertices`.
    effort : {'fast', 'best'}, default 'fast'
        ``'best'``: the count is met by insertion to `COLLAPSE_BEST` times
        as many vertices, then half-edge collapses of interior vertices,
        cheapest first by the exact increase of the summed error over their
        star's pixels, each survivor's depth refitted, then data-dependent
        flips, then the heights as for ``'fast'``. Under an error bound the
        search finds the count as ``'fast'`` does, and the collapsed mesh of
        that count is kept when it meets the bound (or errs less). Where
        the collapses cannot reach the count (too few interior vertices),
        the mesh is ``'fast'``'s.

    Returns
    -------
    mesh : Mesh
    target : dict
        What was asked and achieved, as the paper's targets report it.

    Notes
    -----
    Triangles with a background vertex (an image corner outside the object)
    are refined until they hold no valid pixel, then dropped, so the mesh
    covers the valid pixels without spending vertices on the background.
    When that leaves no triangle, insertion starts again from the valid
    pixels' convex hull (``hull_mesh``, ``refine/mesh.cpp``).

    A pixel's deviation (`deviation_scale`) is ``|predicted - measured|``
    depth, the prediction `rangemesh.render.render_depth`'s, times the
    camera's ``depth_scale`` (`Pinhole`: z-depth in metres) or
    ``range_scale`` (`Spherical`, `Rays`: range along the ray in metres; a
    ``z_depth=True`` camera's z-depth), or 1 with `Orthographic` (depth units).

    Depths far from 1 (beyond ``2**DEPTH_BAND`` or below its inverse) are
    divided by a power of two first (`depth_exponent`) and the vertices
    lifted in the image's units: the mesh is the same for any depth unit
    (SPEC P2), bit for bit.
    """
    h, w = depth.shape
    if diagonals not in ("delaunay", "error"):
        raise ValueError(f"diagonals must be 'delaunay' or 'error', got {diagonals!r}")
    if h < 2 or w < 2:
        raise ValueError(f"greedy insertion needs an image of at least 2x2 pixels, got {h}x{w}")
    ref = (depth, valid) if reference is None else reference
    if extent is None:
        span = valid_range(depth, valid)
        extent = (span.lo, span.hi, span.count)
    exponent = depth_exponent(extent[0], extent[1])
    if exponent:  # exact: the mesh of depth * 2**k is the same for every k
        depth = np.ldexp(depth, -exponent)
        ref = (np.ldexp(ref[0], -exponent), ref[1])
        extent = (math.ldexp(extent[0], -exponent), math.ldexp(extent[1], -exponent), extent[2])
    if effort not in ("fast", "best"):
        raise ValueError(f"effort must be 'fast' or 'best', got {effort!r}")
    bounds = (max_deviation, mean_deviation, max_edge)
    mesh, target = _native(depth, valid, camera, ref, extent, exponent, vertices, max_error,
                           max_vertices, fit=fit, diagonals=diagonals, walls=walls, jump=jump,
                           bounds=bounds, effort=effort)
    if exponent and len(mesh.faces):
        mesh = with_fields(mesh, vertices=_in_units(mesh.vertices, camera, exponent))
    return mesh, target


def depth_exponent(lo: float, hi: float) -> int:
    """The power of two `greedy_mesh` divides depths by: 0 unless they lie far from 1.

    0 when the largest depth magnitude lies within ``2**-DEPTH_BAND ..
    2**DEPTH_BAND`` (every depth unit in use: the kernels' squares and sums
    stay far from overflow and underflow there); otherwise the exponent that
    brings it into ``[1, 2)``. Powers of two scale exactly, and the kernels
    compute the same mesh for any depth scale within the band.

    Examples
    --------
    >>> depth_exponent(0.5, 65535.0), depth_exponent(1e-200, 3e-200), depth_exponent(-2.0**600, 0.0)
    (0, -663, 600)
    """
    top = max(abs(lo), abs(hi))
    if top == 0.0 or not math.isfinite(top) or 2.0**-DEPTH_BAND <= top <= 2.0**DEPTH_BAND:
        return 0
    return math.frexp(top)[1] - 1


def _in_units(points, camera, exponent):
    """3-D points lifted from depths / 2**exponent, as lifted from the depths themselves (exact).

    Every coordinate of `backproject` is the depth times factors of the pixel,
    except an orthographic camera's x and y.
    """
    out = np.array(points, dtype=np.float64)
    if isinstance(camera, Orthographic):
        out[:, 2] = np.ldexp(out[:, 2], exponent)
    else:
        out = np.ldexp(out, exponent)
    return out


def _plan(shape, camera, n_valid, vertices, max_error, max_vertices):
    """``want, scales, n_grid, strips`` of a `greedy_mesh` call.

    The vertices sought, the Delaunay scales, the first mesh's grid points
    and whether the image is meshed as two strips.
    """
    want = n_valid if vertices is None else min(int(vertices), n_valid)
    if vertices is None and max_vertices is not None:
        want = min(int(max_vertices), n_valid)
    n_grid = grid_size(want, n_valid, vertices is None)
    if vertices is None and max_vertices is not None:  # the first mesh stays under the cap
        n_grid = min(n_grid, grid_size(want, n_valid, False))
    scales = (1, 1) if camera is _UNIT else delaunay_scales(camera, shape)  # (square pixels)
    return want, scales, n_grid, use_strips(shape, want, max_error, n_valid)


def _round_record(target: dict, res, bounds, exponent, cap=None) -> dict:
    """`target` with what the rounds of `bounds` (max_deviation, mean_deviation, max_edge) reached.

    `cap`: the vertex cap of a deviation target (None: none).
    """
    max_deviation, mean_deviation, max_edge = bounds
    if max_deviation is not None or mean_deviation is not None:
        kind = "max_deviation" if max_deviation is not None else "mean_deviation"
        asked = max_deviation if max_deviation is not None else mean_deviation
        # (the depths were divided by 2**exponent: the deviation comes back in their units)
        got = math.ldexp(res.deviation_max if max_deviation is not None else res.deviation_mean,
                         exponent)
        target = {"target": kind, "requested": float(asked), "achieved": got,
                  "met": got <= asked, "meshings": res.meshings + res.rounds,
                  "vertices": res.vertex_count,
                  **({"walls_dropped": target["walls_dropped"]} if "walls_dropped" in target else {})}
        if cap is not None:
            target["max_vertices"] = cap
        if not target["met"]:
            target["note"] = (f"stopped at max_vertices={cap}"
                              if cap is not None and res.vertex_count >= cap else
                              "no pixel beyond the bound is left to insert: it rounds at a "
                              "vertex or is valid only before gap filling")
    else:
        target = dict(target, meshings=target.get("meshings", 1) + res.rounds)
    target["uncovered"] = int(res.uncovered)
    if max_edge is not None:
        target["max_edge"], target["longest_edge"] = float(max_edge), float(res.longest_edge)
        if res.longest_edge > max_edge and "note" not in target:
            target["note"] = "a triangle's long edge had no pixel left to insert"
        if target["target"] == "vertices" and target["achieved"] > target["requested"]:
            target["met"] = False
            target["note"] = (f"{target['achieved']} vertices: max_edge={max_edge:g} inserted "
                              f"{target['achieved'] - target['requested']} more")
    return target


def _count_record(got, asked, runs, n_valid, n_pixels, no_walls_dropped,
                  walls_dropped=None) -> dict:
    """The target record of ``vertices=asked`` met with `got` vertices in `runs` meshings.

    `walls_dropped`: the walls dropped, with ``walls=False`` (None: walls kept).
    """
    target = {"target": "vertices", "requested": asked, "achieved": got, "met": got == asked,
              "meshings": runs}
    if walls_dropped is not None:
        target["walls_dropped"] = walls_dropped
    if got != asked:
        target["note"] = _count_note(got, asked, n_valid, n_pixels, no_walls_dropped)
    return target


# What `_native`'s stats and meshes start from (`with_fields`).
_NATIVE_STATS = Stats(method="refine", grid_shape=None, strips=1)
_new = _core.RefineRequest()  # the settings a new request holds, which `_native` leaves as they are
_REQUEST_SETTINGS = (_new.flip, _new.fit, _new.walls, _new.jump, _new.max_runs, _new.max_bisect_runs)
del _new
_UNIT_ARRAY = _UNIT.as_array()  # the default camera's, made once (read-only)
_UNIT_ARRAY.flags.writeable = False
_NATIVE_MESH = Mesh(np.zeros((0, 3)), np.zeros((0, 3), np.int32), np.zeros((0, 2), np.int32),
                    Orthographic(), (0, 0), _NATIVE_STATS)


def _native(depth, valid, camera, ref, extent, exponent, vertices, max_error, max_vertices, *,
            fit, diagonals, walls=True, jump=0.05, bounds=(None, None, None),
            effort="fast"):
    """`greedy_mesh` on one strip or two, as one native call (`rangemesh._core.refine_mesh`).

    The call holds the whole search (first mesh, insertion, diagonals, walls,
    heights, the hull restart); a fit conjugate gradients do not converge on
    is solved by `_direct_solve` (a sparse LU). Returns ``(mesh, target)``;
    with no triangle left, an empty mesh whose ``stats.reason`` names why.
    """
    h, w = depth.shape
    lo, hi, n_valid = extent
    want, scales, n_grid, strips = _plan((h, w), camera, n_valid, vertices, max_error,
                                         max_vertices)
    req = _core.RefineRequest()
    max_deviation, mean_deviation, max_edge = bounds
    if bounds != (None, None, None):  # (rounds rebuild one mesh: no strips)
        strips = False
        if max_deviation is not None or mean_deviation is not None:
            n_grid = 0  # the image rectangle first: a plane keeps its four corners only
        req.deviation_scale, req.deviation_inverse = deviation_scale(camera)
        # the depths were divided by 2**exponent: so is a metre's worth of them
        req.deviation_scale = math.ldexp(req.deviation_scale, exponent)
    if max_deviation is not None:
        req.max_deviation, req.max_deviation_share = float(max_deviation), MAX_DEVIATION_SHARE
    if mean_deviation is not None:
        req.mean_deviation = float(mean_deviation)
    if max_edge is not None:
        req.max_edge = float(max_edge)
    if strips:
        req.strips, req.seam_density, req.seam_error_share = True, SEAM_DENSITY, SEAM_ERROR_SHARE
        req.threads = _threads.threads()
    req.vertices, req.n_valid, req.lo, req.hi, req.n_grid = want, n_valid, lo, hi, n_grid
    if scales != (1, 1):
        req.sr, req.sc = scales
    settings = (diagonals == "error", fit, walls, float(jump), MAX_RUNS, MAX_BISECT_RUNS)
    if settings != _REQUEST_SETTINGS:  # (a call with the defaults sets none of them: every call)
        req.flip, req.fit, req.walls, req.jump, req.max_runs, req.max_bisect_runs = settings
    if not walls and getattr(camera, "directions", None) is not None:
        req.pixel_angle = pixel_angle(camera)  # (edge lengths are ray angles)
    req.heights = height_rule(n_valid)
    if effort == "best":
        req.collapse = COLLAPSE_BEST
    if max_error is not None:
        # (copied heights render about the insertion's own sum: no room to stop later)
        req.max_error, req.max_error_stop = float(max_error), MAX_ERROR_STOP if fit else 1.0
    cam = _UNIT_ARRAY if camera is _UNIT else camera.as_array()
    res = _core.refine_mesh(depth, valid, cam, req, *((None, None) if ref is None else ref),
                            _heights._direct_solve)
    if not res.done:  # (only a call without a direct solve declines)
        raise RuntimeError("refine: the native call declined with a direct solve given")
    got = res.vertex_count
    if not got:
        stats = Stats(seconds={"insertion": res.seconds}, method="refine", grid_shape=None,
                      reason=_empty_reason(res.walls_dropped, walls, valid, n_valid))
        return empty_mesh(camera, (h, w), stats), {}
    fit_seconds = res.fit_seconds
    seconds = {"insertion": res.seconds - fit_seconds, "fit": fit_seconds} if fit else \
        {"insertion": res.seconds}
    faces = res.faces
    # (from templates, their instance dicts filled directly: the frozen classes' own __init__,
    # and keyword arguments, weigh on a call on a small image)
    stats = object.__new__(Stats)
    fields = _NATIVE_STATS.__dict__.copy()  # (set as the instance dict: no update of an empty one)
    object.__setattr__(stats, "__dict__", fields)
    fields["vertices"] = fields["sampled_points"] = got
    fields["triangles"], fields["edges"], fields["seconds"] = len(faces), res.edges, seconds
    fields["flip_tests"], fields["flipped_edges"] = {}, res.flips
    fields["insertions"], fields["strips"] = res.insertions, res.strips
    fields["heights"] = "fit" if fit and res.fitted else "pixel"
    mesh = object.__new__(Mesh)
    fields = _NATIVE_MESH.__dict__.copy()
    object.__setattr__(mesh, "__dict__", fields)
    fields["vertices"], fields["faces"], fields["pixels"] = res.vertices, faces, res.pixels
    fields["camera"], fields["image_shape"], fields["stats"] = camera, (h, w), stats
    fields["attributes"] = {}
    dropped = None if walls else res.walls_dropped
    if vertices is not None:
        target = _count_record(got, int(vertices), res.meshings, n_valid, h * w, walls, dropped)
    elif max_error is not None:
        target = _error_record(res.achieved, float(max_error), res.meshings, got, res.asked, want,
                               max_vertices, dropped)
    else:
        target = {} if walls else {"walls_dropped": dropped}
    if bounds != (None, None, None):
        cap = want if max_vertices is not None else None
        target = _round_record(target, res, bounds, exponent, cap)
    return mesh, target


def _error_record(achieved, asked, runs, got, last, want, max_vertices, walls_dropped=None) -> dict:
    """The target record of ``max_error=asked`` (and `max_vertices`), `achieved` in `runs` meshings.

    `last` is the last meshing's request, `want` the vertex cap, `walls_dropped`
    as `_count_record` takes it.
    """
    ok = achieved <= asked
    capped = not ok and max_vertices is not None and last >= want
    target = {"target": "max_error", "requested": asked, "achieved": achieved, "met": ok,
              "meshings": runs, "vertices": got}
    if max_vertices is not None:
        target["max_vertices"] = want
    if walls_dropped is not None:
        target["walls_dropped"] = walls_dropped
    if not ok:
        target["note"] = f"stopped at max_vertices={want}" if capped else "the bound was not reached"
    return target
