"""The one path from a range image to a mesh: check, prepare, mesh, assemble.

Every caller goes through `resolve_call` (the options, checked, and the
method: ``method=`` alone chooses it, `rangemesh.params.OPTION_METHOD` says
which method takes which option) and `run`: `triangulate` for one image,
`rangemesh.batch.mesh_stream` for frames (with reused buffers),
`rangemesh.batch.mesh_many` for files, the command line. The methods live in
`rangemesh.refine` (``'refine'``) and `rangemesh.paper` (``'paper'``).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from . import memory
from ._core import EXACT_SPAN, valid_range
from .camera import Orthographic, Spherical, as_camera, check_reach, check_shape
from .cleanup import clean_inplace, warn_zero_marker
from .geometry.seam import seam_faces
from .mesh import Mesh, Stats, Target, count_edges, empty_mesh, with_fields
from .options import option_docs
from .paper import targets
from .paper.sampling import sample_grid, sampling_weights
from .paper.stages import mesh_grid
from .params import DEFAULT_TARGET, NONE_MEANS, OPTION_TABLE, MeshParams, default_vertex_cap
from .prepare import check_image, fill_gaps_inplace, mask_into, to_depth_and_mask
from .refine import greedy_mesh
from .resolve import (  # noqa: F401 - re-exported: their home was here
    ALIASES,
    OPTIONS,
    call_options,
    keyword_options,
    resolve_call,
    resolve_keywords,
    resolve_params,
)
from .small_call import FLIPS_UNSET, small_call
from .timing import now, timed

__all__ = ["triangulate", "resolve_call", "resolve_params", "prepare", "run", "Workspace",
           "OPTIONS"]

# The memory model's names, whose home was here (`rangemesh.memory`): still readable from here
# (PEP 562). To change them (a test's monkeypatch), set them on `rangemesh.memory`, their home.
_MEMORY_NAMES = frozenset({"available_memory", "memory_need", "check_memory", "vertex_ceiling",
                           "BYTES_PER_PIXEL", "REFINE_BYTES_PER_PIXEL", "REFINE_BYTES_PER_VERTEX",
                           "MEMINFO_SECONDS", "_meminfo"})


def __getattr__(name):
    if name in _MEMORY_NAMES:
        return getattr(memory, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


class Workspace:
    """Buffers for one frame size, reused from frame to frame by `run`.

    Parameters
    ----------
    shape : (int, int)
    """

    def __init__(self, shape):
        self.shape = tuple(shape)
        self.depth = np.zeros(shape)
        self.valid = np.zeros(shape, np.bool_)
        self.weights = np.zeros(shape)


# The largest depth magnitude the paper's method meshes: its kernels square depths (plane fits,
# curvature), which overflow float64 beyond about 1e154. (method="refine" divides depths by a power
# of two first, `rangemesh.refine.insertion.depth_exponent`: any finite depth range.)
MAX_DEPTH = 1e150


def check_side(shape) -> None:
    """Refuse an image with more than ``EXACT_SPAN + 1`` pixels a side (29,001).

    The Delaunay tests are exact in 64-bit integers up to that span
    (`rangemesh._core.EXACT_SPAN`); such an image would also need tens of GiB.

    Raises
    ------
    ValueError
    """
    if max(shape) - 1 > EXACT_SPAN:
        raise ValueError(f"a {shape[0]}x{shape[1]} image is more than {EXACT_SPAN + 1} pixels a "
                         f"side, beyond the exact Delaunay tests: mesh it in tiles")


def prepare(image, params: MeshParams, background=None, *,
            workspace: Workspace | None = None, camera=None) -> tuple[np.ndarray, np.ndarray]:
    """Depth and validity mask as stage one sees them: checked, masked, gap-filled.

    Parameters
    ----------
    image : (H, W) array_like
    params : MeshParams
        Only ``depth_limits``, ``min_region`` and ``fill_gaps`` are read.
    background : float, 'auto', 'nonpositive' or None, optional
    workspace : Workspace, optional
        Write into its buffers (same shape as the image) instead of new arrays.
    camera : optional
        The camera the image is meshed with: what ``background='auto'`` means
        (`rangemesh.prepare.guess_background`).

    Returns
    -------
    depth : (H, W) ndarray of float64
    valid : (H, W) ndarray of bool
    """
    arr, background = check_image(image, background, camera=camera)
    return _prepare_checked(arr, params, background, workspace, camera=camera)


def _prepare_checked(arr, params: MeshParams, background, workspace, need=("paper", None),
                     camera=None, cleaned=None):
    """`prepare` of an image `check_image` has checked (and its background resolved).

    `need`: the method and vertex count `check_memory` checks the image for;
    `camera`: the units of ``params.depth_limits`` (`rangemesh.cleanup`);
    `cleaned`: a list that gets the mask after the clean-up, before gaps are filled (when
    there is a clean-up or a fill: the error bound's reference, `reference`, `refine_reference`).
    """
    if workspace is None:
        memory.check_memory(arr.shape, *need)
        depth = np.empty(arr.shape, np.float64)  # (mask_into writes every pixel)
        valid = np.empty(arr.shape, np.bool_)
    else:
        depth, valid = workspace.depth, workspace.valid
    mask_into(arr, background, depth, valid)
    if (params.depth_limits is not None or params.min_region is not None) \
            and clean_inplace(depth, valid, params, camera) and cleaned is not None:  # before gaps fill
        cleaned.append(valid.copy())
    if params.fill_gaps:
        if cleaned is not None and not cleaned:  # (the reference's mask, 1/8 of the depths' bytes)
            cleaned.append(valid.copy())
        # the arrays are ours and hold 0.0 on background: fill in place, no copies
        fill_gaps_inplace(depth, valid)
    return depth, valid


def wraps(params: MeshParams, camera) -> bool:
    """Whether the seam between the last and first column is closed: `params.wrap`, or the camera's say."""
    if params.wrap is not None:
        return params.wrap
    return isinstance(camera, Spherical) and camera.wraps


def close_seam(mesh: Mesh, depth: np.ndarray, params: MeshParams) -> Mesh:
    """`mesh` with the faces that close its seam (`rangemesh.geometry.seam.seam_faces`).

    With ``walls=False`` the strip's walls are dropped by the mesh's rule
    (`rangemesh.geometry.walls`); the mesh's own triangles and vertices stay.
    """
    if mesh.is_empty:
        return mesh
    strip = seam_faces(mesh.pixels, mesh.faces, mesh.image_shape[1], depth=depth,
                       jump=None if params.walls else params.jump, camera=mesh.camera)
    if not len(strip):
        return mesh
    faces = np.concatenate([mesh.faces, strip]).astype(np.int32)
    stats = dataclasses.replace(mesh.stats, triangles=len(faces), edges=count_edges(faces))
    return dataclasses.replace(mesh, faces=faces, stats=stats)


def run(image, params: MeshParams, *, background="auto", camera=None, vertices=None,
        max_error=None, tiles_given: bool = True, workspace: Workspace | None = None,
        method: str = "refine", max_deviation=None, mean_deviation=None) -> Mesh:
    """Prepare `image`, mesh it with `method` (for a target, or the default one), assemble stats.

    The arguments are those of `triangulate`, already resolved
    (`resolve_call`): `params` holds every setting, `tiles_given` says
    whether the tiles of `params` are the user's (a target search then keeps
    them) or the defaults (the search chooses them). ``method='refine'``
    without a target takes `rangemesh.params.DEFAULT_TARGET`. With a
    `workspace`, the image's buffers are reused.

    Returns
    -------
    Mesh
        ``stats.seconds`` holds ``prepare``, each stage, ``search`` (target
        searches only) and ``total``.

    Notes
    -----
    The compiled kernels run with the GIL released and watch for Ctrl-C: a
    KeyboardInterrupt ends the call within a fraction of a second, whatever the
    image's size, and leaves nothing half-made.
    """
    camera = as_camera(camera)
    t0 = now()
    image, background = check_image(image, background, camera=camera)  # resolves 'auto'
    check_side(image.shape)
    if method == "paper" and min(image.shape) < 2:  # no tile fits, with or without a target
        raise ValueError(f"the paper's method needs an image of at least 2x2 pixels (its "
                         f"tiles are at least 2 pixels thick), got {image.shape[0]}x"
                         f"{image.shape[1]}")
    deviation = max_deviation is not None or mean_deviation is not None
    default_target = method == "refine" and vertices is None and max_error is None \
        and not deviation
    # refine's need grows with its vertices: those asked, or the default target's cap at most
    budget = default_vertex_cap(image.size) if default_target else vertices
    bounded = max_error is not None or deviation or params.max_edge is not None or default_target
    cleaned = [] if bounded else None  # (the mask before gaps fill: only an error bound reads it)
    depth, valid = _prepare_checked(image, params, background, workspace, (method, budget),
                                    camera=camera, cleaned=cleaned)
    check_shape(camera, depth.shape)
    # (by name: unpacking the DepthRange ends in an IndexError its binding throws, ~15K
    # instructions a call)
    span = valid_range(depth, valid)
    lo, hi, n_valid = span.lo, span.hi, span.count
    if n_valid and lo <= 0.0 <= hi and isinstance(camera, Orthographic):  # (else: no zero)
        warn_zero_marker(depth, valid)
    if n_valid:
        if not math.isfinite(hi - lo):
            raise ValueError(f"depths {lo:g} .. {hi:g}: their range exceeds the float range; "
                             f"scale the image (and its camera) down")
        if method == "paper" and max(abs(lo), abs(hi)) > MAX_DEPTH:
            raise ValueError(f"depths {lo:g} .. {hi:g} reach beyond {MAX_DEPTH:g}, where the "
                             f"kernels' squares overflow: scale the image (and its camera) down")
        check_reach(camera, depth.shape, lo, hi)
    t1 = now()
    if not n_valid:
        # Still check the tiling so that bad parameters fail the same way on any image.
        if method == "paper":
            sample_grid(depth, valid, params.replace(sampling="uniform"))
        stats = Stats(grid_shape=params.grid_shape if method == "paper" else None,
                      seconds={"prepare": t1 - t0, "total": t1 - t0}, method=method,
                      reason="the image has no valid pixel (all background)")
        return empty_mesh(camera, depth.shape, stats)
    target = {}
    extra = {}  # seconds of the steps here, beside the method's own (its Stats stay as made)
    tiles = params.tiles if tiles_given else None
    if method == "refine":
        cap = memory_cap = None
        if default_target:
            max_error, cap = DEFAULT_TARGET.max_error, default_vertex_cap(n_valid)
        asked_cap = cap
        if vertices is None and workspace is None:
            # an error bound's count is known only at the end: stop where memory runs out
            ceiling = memory.vertex_ceiling(depth.shape)
            if ceiling is not None and ceiling < min(cap or n_valid, n_valid):
                cap = memory_cap = max(ceiling, 3)
        ref = refine_reference(depth, cleaned) if bounded else None
        mesh, target = greedy_mesh(depth, valid, camera, vertices=vertices, max_error=max_error,
                                   reference=ref,
                                   fit=(params.heights or NONE_MEANS["heights"]) == "fit",
                                   diagonals=params.diagonals or NONE_MEANS["diagonals"],
                                   walls=params.walls, jump=params.jump, effort=params.effort,
                                   extent=(lo, hi, n_valid), max_vertices=cap,
                                   max_deviation=max_deviation, mean_deviation=mean_deviation,
                                   max_edge=params.max_edge)
        if memory_cap is not None and target and not target["met"] \
                and target.get("note", "").startswith("stopped at max_vertices"):
            bound = (f"the error bound {max_error:g} %" if max_error is not None else
                     f"max_deviation={max_deviation:g}" if max_deviation is not None else
                     f"mean_deviation={mean_deviation:g}")
            raise MemoryError(
                f"{bound} needs more than {memory_cap} vertices, which "
                f"is what the {memory.size_text(memory.available_memory() or 0)} of memory "
                f"available hold ({memory.REFINE_BYTES_PER_VERTEX} bytes a vertex); give a larger "
                f"{'max_error' if max_error is not None else 'bound'} or a vertex count, or mesh "
                f"on a larger machine")
        if memory_cap is not None and target:  # the record keeps the cap that was asked for
            target.pop("max_vertices", None)
            if asked_cap is not None:
                target["max_vertices"] = asked_cap
    elif vertices is not None:
        mesh, target = targets.fit_vertices(depth, valid, params, camera, int(vertices), tiles=tiles)
    elif max_error is not None:
        ref_depth, ref_valid = reference(image, background, cleaned)
        mesh, target = targets.fit_error(depth, valid, params, camera, float(max_error),
                                         ref_depth, ref_valid, tiles=tiles)
    elif params.max_edge is not None:
        mesh, target = targets.fit_edge(depth, valid, params, camera, tiles=tiles)
    else:
        weights = None
        if workspace is not None:
            with timed(extra, "sampling"):  # the weights: stage one's
                weights = sampling_weights(depth, valid, params, out=workspace.weights)
        mesh = mesh_grid(depth, valid, params, camera, weights=weights)
        extra["sampling"] = mesh.stats.seconds["sampling"] + extra.get("sampling", 0.0)
    if wraps(params, camera):
        with timed(extra, "seam"):
            mesh = close_seam(mesh, depth, params)
    t4 = now()
    stages = {**mesh.stats.seconds, **extra} if extra else mesh.stats.seconds
    seconds = {"prepare": t1 - t0, **stages}
    if target:
        seconds["search"] = t4 - t1 - sum(stages.values())
    seconds["total"] = t4 - t0
    record = Target.from_record(target, vertices=mesh.stats.vertices,
                                default=default_target) if target else None
    changes = {"seconds": seconds, "target": record, "method": method}
    if record is not None and record.tiles is not None:
        # the grid the search chose; with max_edge the mesh's points are a list, not a grid
        (v, h), (rs, z) = record.tiles, record.samples
        changes["grid_shape"] = ((rs - 1) * v + 1, (z - 1) * h + 1)
    stats = object.__new__(Stats)  # (`with_fields` without its keyword arguments: every call)
    object.__setattr__(stats, "__dict__", {**mesh.stats.__dict__, **changes})
    return with_fields(mesh, stats=stats)


def refine_reference(depth, cleaned):
    """`reference` as refine reads it: the prepared depths, valid where `cleaned` (if any) says.

    Gap filling writes only pixels invalid before it and the clean-up only drops pixels, so the
    prepared depths equal the reference's on its valid pixels, the only ones refine reads: the
    image is not masked a second time. None: the prepared image is the reference.
    """
    return (depth, cleaned[0]) if cleaned else None


def reference(image, background, cleaned=()):
    """The error bound's reference: the image masked, not gap-filled, the clean-up's pixels missing.

    `cleaned`: the mask `_prepare_checked` left after the clean-up (empty when there was none).
    """
    depth, valid = to_depth_and_mask(image, background)
    if cleaned:
        np.logical_and(valid, cleaned[0], out=valid)
        depth[~valid] = 0.0
    return depth, valid


def triangulate(image, params: MeshParams | None = None, *,
                method: str = "refine", vertices: int | None = None,
                max_error: float | None = None, max_deviation: float | None = None,
                mean_deviation: float | None = None, background="auto", camera=None, color=None,
                # the options, in the order of rangemesh.params.OPTION_TABLE (a test holds
                # them to it; their documentation comes from it)
                tiles: int | tuple[int, int] | None = None,
                samples: int | tuple[int, int] | None = None, sampling: str | None = None,
                flips: str | None = "disparity", levels: int | None = None,
                curvature_floor: float | None = None, fill_gaps: bool | None = None,
                delta: float | None = None, epsilon: float | None = None,
                max_angle: float | None = None, min_bend: float | None = None,
                gain_threshold: float | None = None, max_edge: float | None = None,
                threads: int | None = None, heights: str | None = None,
                diagonals: str | None = None, walls: bool | None = None,
                jump: float | None = None, wrap: bool | None = None,
                depth_limits: tuple[float, float] | None = None, min_region: int | None = None,
                effort: str | None = None, **overrides) -> Mesh:
    """Mesh a range image: refined at its worst pixels (default), or Garcia & Sappa's pipeline.

    Parameters
    ----------
    image : (H, W) array_like of int or float
        The range image (depth, disparity or range values).
    params : MeshParams, optional
        Deprecated: give `method` and the options as keywords. A call with it
        keeps the method and mesh it gave before (the paper's method unless a
        target and no paper option is given).
    method : {'refine', 'paper'}, default 'refine'
        ``'refine'``: a coarse mesh refined where it fits worst, by greedy
        insertion (`rangemesh.refine`): the pixel whose triangle fits worst
        becomes a vertex until the target is met, in one pass; jumps keep
        vertices on both sides. ``'paper'``: Garcia & Sappa's pipeline
        (adaptive sampling grid, 2.5-D Delaunay, discontinuity-preserving
        flips), the meshes it has always given. The method is chosen by this
        argument alone: an option of the other method is an error.
        (``'greedy'``, the earlier name of ``'refine'``, is deprecated.)
    vertices : int, optional
        ``'refine'``: exactly this many vertices (every valid pixel if there
        are fewer). ``'paper'``: about this many, its grid searched to within
        2 % (`rangemesh.paper.targets.fit_vertices`).
    max_error : float, optional
        The smallest mesh whose relative error (percent of the valid depth
        range, mean, as `evaluate`) is at most this: ``'refine'`` stops
        there; ``'paper'`` searches its grid (`rangemesh.paper.targets.fit_error`).
        `vertices` and `max_error` exclude each other. With neither,
        ``'refine'`` takes the default target `rangemesh.params.DEFAULT_TARGET`:
        ``max_error=0.5`` with at most 2 % of the valid pixels as vertices
        (at least 50); ``'paper'`` meshes its grid of `tiles` x `samples`.
    max_deviation : float, optional
        ``'refine'`` only. Every valid pixel the mesh covers within this of
        the mesh (the largest deviation, L-infinity, as delatin's
        ``max_error``), fitted depths included. A pixel's deviation is
        ``|predicted - measured|`` along its ray: z-depth in metres with a
        `Pinhole` (times ``depth_scale``), range in metres with `Spherical`
        and `Rays` (times ``range_scale``; z-depth with ``z_depth=True``),
        depth units with `Orthographic`; the prediction is `render_depth`'s.
        Met in one call: an insertion, then rounds inserting the worst pixel
        of each triangle still beyond it, with each fitted depth kept within
        it of its own pixel (`rangemesh.refine.insertion.greedy_mesh`). 0
        gives every pixel exactly. Excludes the other targets.
    mean_deviation : float, optional
        ``'refine'`` only. The mean deviation of the covered valid pixels
        (as `max_deviation` defines it) at most this. Excludes the other
        targets.
    background : float, 'auto', 'nonpositive' or None, default 'auto'
        What marks missing depth. ``'auto'``: with a `Pinhole`, `Spherical`
        or `Rays` camera every value of 0 or below (a depth or range is a
        distance in front of the sensor), else 0 in integer images and
        nothing in float images (`rangemesh.prepare.guess_background`); a
        number (``0``, ``65535``, ...); ``'nonpositive'``: 0 and below;
        None: only NaN/inf. NaN and infinite pixels are always missing depth.
    camera : Orthographic, Pinhole, Spherical, Rays or (kx, ky, kz), optional
        How pixels become 3-D points; default ``Orthographic(1, 1, 1)``, the
        paper's eq. (4) with unit scales. `Spherical` (a spinning LiDAR,
        ``Spherical.from_beams``) and `Rays` put each vertex at ``range *
        ray`` of its pixel; a `Spherical` camera that goes once round closes
        the 360-degree seam (`wrap`).
    color : (H, W, 3) or (H, W) array_like, optional
        A colour image registered pixel to pixel with the range image: the
        mesh gets each vertex's colour and keeps the image as its texture
        (`Mesh.with_colors`).
    {options}
    **overrides
        Deprecated: ``workers``, the old name of `threads`.

    Returns
    -------
    Mesh
        ``vertices (V, 3)``, ``faces (F, 3)`` counter-clockwise in the image
        plane, ``pixels (V, 2)``, and ``stats`` (`Stats`: what the method
        did, and ``stats.target``, a `rangemesh.Target` record of what was
        asked and achieved). When nothing can be meshed (no valid pixel,
        fewer than 3 valid samples, all collinear) the mesh is empty and
        ``stats.reason`` says why.

    Raises
    ------
    ValueError
        An option of the other method (the message names it and its
        method), bad image shape, parameters out of range, both targets, or
        a camera that maps pixels beyond the float range. The message names
        the parameter.
    TypeError
        Wrong kind of image, camera or parameter, or an unknown keyword.
    MemoryError
        The image needs more memory than the machine has available (see
        `check_memory`: 20 bytes a pixel for the paper's method; for refine 32
        a pixel and 700 a vertex asked, or, under an error bound, once its
        vertices fill the memory available), or an allocation failed.

    See Also
    --------
    rangemesh.mesh_stream, rangemesh.mesh_many : the same call over many images.
    evaluate : relative error of the result.

    Notes
    -----
    Vertices take their depth from the gap-filled image (paper eq. 4 uses
    the filtered image ``R_f``) unless ``heights='fit'`` (refine's default).
    Stage timings are in ``stats.seconds``.

    References
    ----------
    .. [1] M. A. Garcia and A. D. Sappa, "Efficient generation of
       discontinuity-preserving adaptive triangulations from range images",
       IEEE Trans. Systems, Man, and Cybernetics, Part B, 34(5), 2004.

    Examples
    --------
    >>> import numpy as np
    >>> r, c = np.mgrid[0:40, 0:50]
    >>> depth = np.where(c < 25, 100.0 + c, 150.0 - c)        # a roof crease
    >>> triangulate(depth, vertices=6).stats.vertices
    6
    >>> mesh = triangulate(depth, method="paper", tiles=2, samples=5)
    >>> mesh.stats.grid_shape, mesh.faces.shape[1]
    ((9, 9), 3)
    """
    if params is None and camera is None and color is None and not overrides and method == "refine" \
            and max_error is None and max_deviation is None and mean_deviation is None \
            and type(image) is np.ndarray and tiles is None and samples is None and sampling is None \
            and flips is FLIPS_UNSET and levels is None and curvature_floor is None and fill_gaps is None \
            and delta is None and epsilon is None and max_angle is None and min_bend is None \
            and gain_threshold is None and max_edge is None and threads is None and heights is None \
            and diagonals is None and walls is None and jump is None and wrap is None \
            and depth_limits is None and min_region is None and effort is None:
        mesh = small_call(image, vertices, background)  # (a small image: one native call)
        if mesh is not None:
            return mesh
    params, method, tiles_given = resolve_keywords(params, method, vertices, max_error, locals(),
                                                   overrides,
                                                   deviations=(max_deviation, mean_deviation))
    if color is not None:
        shape, cshape = np.shape(image)[:2], np.shape(color)[:2]
        if shape != cshape:
            raise ValueError(f"color is {cshape[0]}x{cshape[1]} and the image "
                             f"{shape[0]}x{shape[1]}: they must be registered pixel to pixel")
    mesh = run(image, params, background=background, camera=camera, vertices=vertices,
               max_error=max_error, tiles_given=tiles_given, method=method,
               max_deviation=max_deviation, mean_deviation=mean_deviation)
    return mesh if color is None or mesh.is_empty else mesh.with_colors(color)


if triangulate.__doc__:  # (None under python -OO)
    triangulate.__doc__ = triangulate.__doc__.replace("    {options}", option_docs(OPTION_TABLE))
