"""A small image's refine mesh in one native call: the fixed cost of `rangemesh.triangulate`.

On an image of fewer than `SMALL_PIXELS` pixels, with no camera and no option (what
`rangemesh.small_call` checks), a vertex count or the default target is met by one
native function, `rangemesh._core.refine_image`: the image masked, its single-pixel gaps filled
and its valid range taken, then the whole search of `greedy_mesh`. For such images the request
does not depend on how many pixels are valid (one strip, the fit's pass on one thread, the
default target's cap its least, ``min_vertices``), so it is made once per count and reused.
Where the general path has more to do or to say (fewer valid pixels than the count, a valid
range holding 0 or beyond the float range, depths far from 1, no face), the native call
declines and `triangulate` takes the general path: the mesh and its stats are the same either way.
"""

from __future__ import annotations

from .. import _core
from ..camera import _UNIT
from ..mesh import Mesh, Stats, Target
from ..params import DEFAULT_TARGET, NONE_MEANS
from . import heights as _heights
from .insertion import (
    _REQUEST_SETTINGS,
    MAX_BISECT_RUNS,
    MAX_ERROR_STOP,
    MAX_RUNS,
    _count_record,
    _error_record,
    grid_size,
)

__all__ = ["SMALL_PIXELS", "mesh_small"]

# Images of fewer pixels take the one native call. Below it a mesh has fewer than
# FIT_SPLIT_MIN_FACES faces (the fit's pass on one thread), never two strips (STRIP_MIN_PIXELS)
# and the default target's cap is its least (`default_vertex_cap`): tests/test_refine.py holds
# these to it. A larger image's call costs milliseconds: the general path's steps weigh nothing there.
# (the native call declines larger images: the figure is its own)
SMALL_PIXELS = _core.SMALL_IMAGE_PIXELS
# `_request`'s key: the request, made once (read only)
_REQUESTS: dict = {}
# The instance dicts a small call's Stats and Mesh copy, in the fields' order (the values set
# here are those no small call changes; the others are set at each call)
_STATS = {"vertices": 0, "edges": 0, "triangles": 0, "flipped_edges": 0, "grid_shape": None,
          "sampled_points": 0, "flip_tests": None, "seconds": None, "target": None, "reason": "",
          "method": "refine", "insertions": 0, "strips": 1, "heights": "pixel"}
_MESH = {"vertices": None, "faces": None, "pixels": None, "camera": _UNIT, "image_shape": None,
         "stats": None, "colors": None, "texture": None, "attributes": None}


def _request(key: tuple) -> _core.RefineRequest:
    """The request of `mesh_small`'s `key` on a small image, made once.

    `key`: the count (None: the default target), what None means for ``heights`` and
    ``diagonals`` (`NONE_MEANS`) and the values of `height_rule` but its threads.
    """
    vertices, fit, flip = key[0], key[1] == "fit", key[2] == "error"
    req = _core.RefineRequest()
    if vertices is None:  # `_plan` with max_vertices = the cap, every valid pixel at least as many
        cap = DEFAULT_TARGET.min_vertices
        req.vertices, req.n_grid = cap, min(grid_size(cap, cap, True), grid_size(cap, cap, False))
        req.max_error = float(DEFAULT_TARGET.max_error)
        req.max_error_stop = MAX_ERROR_STOP if fit else 1.0
    else:
        req.vertices, req.n_grid = vertices, grid_size(vertices, vertices, False)
    # `_native`'s settings with the options' defaults (walls kept, jump 0.05: tests/test_pipeline.py)
    settings = (flip, fit, True, 0.05, MAX_RUNS, MAX_BISECT_RUNS)
    if settings != _REQUEST_SETTINGS:
        req.flip, req.fit, req.walls, req.jump, req.max_runs, req.max_bisect_runs = settings
    req.heights = _heights._rule(key[3:] + (1,))
    if len(_REQUESTS) >= 256:  # (a long run of distinct counts: start again)
        _REQUESTS.clear()
    _REQUESTS[key] = req
    return req


def mesh_small(image, vertices: int | None, masking: tuple[float, float, bool], t0: float,
               now) -> Mesh | None:
    """`triangulate(image, vertices=vertices)` of a small image, or None (declined).

    Parameters
    ----------
    image : ndarray
        The native call declines anything but a C-contiguous (H, W) array of a dtype the kernels
        take, fewer than `SMALL_PIXELS` pixels, at least 2 a side.
    vertices : int or None
        A count from 3 to below `SMALL_PIXELS`, or None: the default target.
    masking : tuple of (float, float, bool)
        ``(int_background, float_background, fill_gaps)``: what marks missing depth besides NaN
        and infinities in an integer image and in a float one (NaN: nothing else), and whether
        single-pixel gaps are filled.
    t0 : float
        When the call started (`now`), the clock of ``stats.seconds``.
    now : callable
        That clock, read where the call ends.
    """
    # (`height_rule(h * w)`'s values, one thread below SMALL_PIXELS (tests/test_pipeline.py), and
    # what None means, read at each call as the general path reads them: a request's key)
    key = (vertices, NONE_MEANS["heights"], NONE_MEANS["diagonals"], _heights.OUTLIER_MADS,
           _heights.OUTLIER_FLOOR, _heights.RIDGE, _heights.CG_RTOL, _heights.RESIDUAL_STRIDE,
           _heights.RESIDUAL_MIN, _heights.RESIDUAL_SAMPLE, _heights.ORDER_TILE, _heights.ORDER_MIN_PIXELS)
    req = _REQUESTS.get(key) or _request(key)
    # (its Stats and Mesh made by the native call too, from _MADE: tests/test_pipeline.py holds
    # them to the general path's)
    return _core.refine_image(image, vertices, masking, req, _heights._direct_solve, t0, now, _MADE)


_MET: dict = {}  # (count, meshings): the Target of a count met, made once (frozen: shared)


def _met(got: int, meshings: int) -> Target:
    """The Target of ``vertices=got`` met in `meshings` meshings (`_count_record`), made once."""
    if len(_MET) >= 256:
        _MET.clear()
    target = _MET[got, meshings] = _target(got, got, got, got, meshings, 0.0, got, got)
    return target


def _target(vertices, got, n_valid, n_pixels, meshings, achieved, asked, want) -> Target:
    """The Target record `greedy_mesh` and `run` make of a count (None: the default target)."""
    if vertices is None:
        record = _error_record(achieved, float(DEFAULT_TARGET.max_error), meshings, got, asked,
                               want, want)
    else:
        record = _count_record(got, vertices, meshings, n_valid, n_pixels, True)
    return Target.from_record(record, vertices=got, default=vertices is None)


def _target_of(vertices, got, n_valid, n_pixels, meshings, achieved, asked, want) -> Target:
    """`_target`, or `_met`'s of a count met: the Target of a call `_MET` does not hold."""
    if vertices is not None and got == vertices:
        return _met(got, meshings)
    return _target(vertices, got, n_valid, n_pixels, meshings, achieved, asked, want)


# What `_core.refine_image` makes a small call's Mesh of: the classes, copies of their instance
# dicts (their fields in order, those no small call changes set), the Targets of counts met
# (looked up by (count, meshings)), and the Target of any other call
_MADE = (Stats, Mesh, _STATS, _MESH, _MET, _target_of)
