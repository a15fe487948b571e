"""The one path from a range image to a mesh: check, prepare, mesh, assemble.

Every caller goes through `run`: `triangulate` for one image,
`rangemesh.batch.mesh_stream` for frames (with reused buffers), the command
line through `triangulate`. The method itself lives in `rangemesh.paper`.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time

import numpy as np

from .camera import Spherical, as_camera, check_reach, check_shape
from .checks import real_number, whole_number
from .geometry.pixels import valid_range
from .geometry.seam import seam_strip, unrolled_columns
from .geometry.signals import holding_signals
from .greedy import greedy_mesh
from .greedy.walls import wall_faces
from .mesh import Mesh, Stats, count_edges, empty_mesh
from .paper import targets
from .paper.sampling import fill_gaps_inplace, sample_grid, sampling_weights
from .paper.stages import mesh_grid
from .params import MeshParams
from .prepare import check_image, mask_into, to_depth_and_mask

__all__ = ["triangulate", "resolve_params", "prepare", "run", "Workspace", "check_memory",
           "check_call", "default_method"]


@functools.lru_cache(maxsize=1)
def _defaults() -> MeshParams:
    """`MeshParams()`, built once (it checks every field: 25 us, twice a call before)."""
    return MeshParams()


def resolve_params(params: MeshParams | None, overrides: dict) -> MeshParams:
    """`params` (or the defaults) with keyword overrides applied and checked.

    Raises
    ------
    TypeError
        If `params` is not a `MeshParams` or an override is not one of its fields.
    """
    if params is None:
        params = _defaults()
    elif not isinstance(params, MeshParams):
        raise TypeError(
            f"params must be a rangemesh.MeshParams or None, got {type(params).__name__}"
        )
    return params.replace(**overrides) if overrides else params


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


# Peak working memory of `run` per image pixel, bytes: float64 depth, weights, the mask and
# the rest, measured by benchmarks/memory.py (4.2x a float32 image, 17 bytes a pixel), rounded up.
BYTES_PER_PIXEL = 20
# The largest depth magnitude meshed: the kernels square depths (plane fits, least squares),
# which overflow float64 beyond about 1e154.
MAX_DEPTH = 1e150


# `available_memory` reads /proc/meminfo at most once in this many seconds: the read costs
# 0.1 ms, 4 % of a call on a 128x128 image, and a check that old still stops a runaway image.
MEMINFO_SECONDS = 1.0
_meminfo = [-math.inf, None]  # when read (time.monotonic), what was read


def available_memory() -> int | None:
    """Bytes of memory the system can give without swapping (Linux ``MemAvailable``), or None.

    Read at most once every `MEMINFO_SECONDS`.
    """
    now = time.monotonic()
    if now - _meminfo[0] < MEMINFO_SECONDS:
        return _meminfo[1]
    free = None
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    free = int(line.split()[1]) * 1024
                    break
    except (OSError, ValueError, IndexError):
        pass
    _meminfo[0], _meminfo[1] = now, free
    return free


def check_memory(shape) -> None:
    """Refuse an image whose meshing would need more memory than the machine has free.

    The rule: ``BYTES_PER_PIXEL`` (20) bytes per pixel, against the memory
    available now. Failing at once with a clear message beats being killed by
    the kernel's out-of-memory handler half way, or swapping the machine to a
    halt.

    Raises
    ------
    MemoryError
    """
    need = int(shape[0]) * int(shape[1]) * BYTES_PER_PIXEL
    free = available_memory()
    if free is not None and need > free:
        raise MemoryError(
            f"a {shape[0]}x{shape[1]} image needs about {_size(need)} of memory to mesh "
            f"({BYTES_PER_PIXEL} bytes a pixel) and {_size(free)} are available; "
            f"mesh it in parts or on a larger machine"
        )


def _size(n: int) -> str:
    return f"{n / 2**30:.1f} GiB" if n >= 2**30 else f"{n / 2**20:.1f} MiB"


def prepare(image, params: MeshParams, background=None, *,
            workspace: Workspace | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Depth and validity mask as stage one sees them: checked, masked, gap-filled.

    Parameters
    ----------
    image : (H, W) array_like
    params : MeshParams
        Only ``fill_gaps`` is read.
    background : float, optional
    workspace : Workspace, optional
        Write into its buffers (same shape as the image) instead of new arrays.

    Returns
    -------
    depth : (H, W) ndarray of float64
    valid : (H, W) ndarray of bool
    """
    arr, background = check_image(image, background)
    if workspace is None:
        check_memory(arr.shape)
        depth = np.zeros(arr.shape, np.float64)
        valid = np.zeros(arr.shape, np.bool_)
    else:
        depth, valid = workspace.depth, workspace.valid
    mask_into(arr, background, depth, valid)
    if params.fill_gaps:
        # the arrays are ours and hold 0.0 on background: fill in place, no copies
        fill_gaps_inplace(depth, valid)
    return depth, valid


def default_method(params: MeshParams, vertices, max_error, overrides) -> str:
    """The method a call without ``method=`` gets.

    ``'refine'`` when a target (``vertices`` or ``max_error``) is given and
    nothing only the paper's method reads is (a keyword, or a field of
    `params` away from its default); ``'paper'`` otherwise, so that every
    call written for the paper's parameters keeps meshing with them.
    """
    if vertices is None and max_error is None:
        return "paper"
    if set(overrides) - set(REFINE_FIELDS):
        return "paper"
    defaults = _defaults()
    for f in dataclasses.fields(MeshParams):
        if f.name not in REFINE_FIELDS and getattr(params, f.name) != getattr(defaults, f.name):
            return "paper"
    return "refine"


def check_call(params: MeshParams, vertices=None, max_error=None, method=None,
               overrides: dict | None = None) -> str:
    """Check the targets and the method of a `triangulate` call before any work; return the method.

    The command line calls it before saying that kernels will compile, so that
    a bad value fails with its own message first.

    Raises
    ------
    ValueError, TypeError
        As `triangulate` does, naming the parameter.
    """
    overrides = {} if overrides is None else overrides
    _targets_given(params, vertices, max_error, overrides)
    if method is None:
        method = default_method(params, vertices, max_error, overrides)
    elif isinstance(method, str):
        method = ALIASES.get(method, method)
    _check_method(method, params, vertices, max_error, overrides)
    return method


def _check_method(method, params: MeshParams, vertices, max_error, overrides) -> None:
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    if method == "refine":
        if vertices is None and max_error is None:
            raise ValueError("method='refine' needs a target: vertices=N or max_error=E")
        paper_only = sorted(set(overrides) - set(REFINE_FIELDS))
        if paper_only or params.max_edge is not None:
            raise ValueError(f"{paper_only or ['max_edge']} are parameters of method='paper'; "
                             f"method='refine' takes vertices or max_error (and "
                             f"{', '.join(REFINE_FIELDS)})")
    elif params.heights == "fit":
        raise ValueError("heights='fit' belongs to method='refine'; the paper's method copies "
                         "each vertex's depth from its pixel")
    elif params.diagonals is not None:
        raise ValueError(f"diagonals={params.diagonals!r} belongs to method='refine'; the "
                         f"paper's method chooses its diagonals with flips=")
    elif not params.walls or "jump" in overrides:
        raise ValueError("walls=False and jump belong to method='refine'")


def _targets_given(params: MeshParams, vertices, max_error, overrides) -> list[str]:
    if vertices is not None and max_error is not None:
        raise ValueError("vertices and max_error exclude each other: give one target")
    given = [k for k, v in (("vertices", vertices), ("max_error", max_error),
                            ("max_edge", params.max_edge)) if v is not None]
    if given and "samples" in overrides:
        raise ValueError(
            f"{' and '.join(given)} choose the samples per tile themselves; "
            f"do not give samples={overrides['samples']!r} as well"
        )
    if vertices is not None:
        whole_number("vertices", vertices, minimum=3)
    if max_error is not None:
        if real_number("max_error", max_error, finite=False) <= 0 or not np.isfinite(max_error):
            raise ValueError(f"max_error must be a positive number of percent, got {max_error!r}")
    return given


METHODS = ("paper", "refine")
# The name "refine" had before: greedy insertion, its algorithm's (and pydelatin's) name. It says
# how vertices are chosen, not what the method does; it is still accepted and means "refine".
ALIASES = {"greedy": "refine"}
# the MeshParams fields method="refine" reads
REFINE_FIELDS = ("fill_gaps", "workers", "heights", "diagonals", "walls", "jump", "wrap")


def wraps(params: MeshParams, camera) -> bool:
    """Whether the seam between the last and first column is closed: `params.wrap`, or the camera's say."""
    if params.wrap is not None:
        return params.wrap
    return isinstance(camera, Spherical) and camera.wraps


def close_seam(mesh: Mesh, depth: np.ndarray, params: MeshParams) -> Mesh:
    """`mesh` with the strip of `rangemesh.geometry.seam.seam_strip` added.

    With ``walls=False`` the strip's triangles across a jump are dropped by
    the same rule as the others, their pixel lengths measured across the seam.
    """
    if mesh.is_empty:
        return mesh
    w = mesh.image_shape[1]
    strip = seam_strip(mesh.pixels, mesh.faces, w)
    if len(strip) and not params.walls:
        z = depth[mesh.pixels[:, 0], mesh.pixels[:, 1]]
        if hasattr(mesh.camera, "directions"):  # lengths are ray angles: the seam is no gap
            walls = wall_faces(strip, mesh.pixels, z, params.jump, mesh.camera)
        else:
            coords = np.stack([mesh.pixels[:, 0], unrolled_columns(mesh.pixels, w)], axis=1)
            walls = wall_faces(strip, coords, z, params.jump)
        strip = strip[~walls]
    if not len(strip):
        return mesh
    faces = np.concatenate([mesh.faces, strip]).astype(np.int32)
    stats = dataclasses.replace(mesh.stats, triangles=len(faces), edges=count_edges(faces))
    return dataclasses.replace(mesh, faces=faces, stats=stats)


@holding_signals
def run(image, params: MeshParams, *, background=None, camera=None, vertices=None,
        max_error=None, tiles_given: bool = True, workspace: Workspace | None = None,
        method: str = "paper") -> Mesh:
    """Prepare `image`, mesh it with the paper's method (or a target search), assemble stats.

    The arguments are those of `triangulate`, already resolved: `params`
    holds every setting, `tiles_given` says whether the tiles of `params` are
    the user's (a target search then keeps them) or the defaults (the search
    chooses them). With a `workspace`, the image's buffers are reused.

    Returns
    -------
    Mesh
        ``stats.seconds`` holds ``prepare``, each stage, ``search`` (target
        searches only) and ``total``.

    Notes
    -----
    Ctrl-C and termination signals are held for the whole call
    (`rangemesh.geometry.signals`) and delivered when it returns: once, not
    once per stage (40 us each, 4 % of a 5 ms call).
    """
    camera = as_camera(camera)
    t0 = time.perf_counter()
    depth, valid = prepare(image, params, background, workspace=workspace)
    check_shape(camera, depth.shape)
    lo, hi, n_valid = valid_range(depth, valid)
    if n_valid:
        if max(abs(lo), abs(hi)) > MAX_DEPTH:
            raise ValueError(f"depths {lo:g} .. {hi:g} reach beyond {MAX_DEPTH:g}, where the "
                             f"kernels' squares overflow: scale the image (and its camera) down")
        check_reach(camera, depth.shape, lo, hi)
    t1 = time.perf_counter()
    if not n_valid:
        # Still check the tiling so that bad parameters fail the same way on any image.
        sample_grid(depth, valid, params.replace(sampling="uniform"))
        stats = Stats(grid_shape=params.grid_shape, seconds={"prepare": t1 - t0, "total": t1 - t0},
                      reason="the image has no valid pixel (all background)")
        return empty_mesh(camera, depth.shape, stats)
    target = {}
    tiles = params.tiles if tiles_given else None
    if method == "refine":
        ref = to_depth_and_mask(image, background) if max_error is not None else None
        mesh, target = greedy_mesh(depth, valid, camera, vertices=vertices, max_error=max_error,
                                   reference=ref, fit=params.heights != "pixel",
                                   diagonals=params.diagonals or "error",
                                   walls=params.walls, jump=params.jump,
                                   extent=(lo, hi, n_valid))
    elif vertices is not None:
        mesh, target = targets.fit_vertices(depth, valid, params, camera, int(vertices), tiles=tiles)
    elif max_error is not None:
        ref_depth, ref_valid = to_depth_and_mask(image, background)
        mesh, target = targets.fit_error(depth, valid, params, camera, float(max_error),
                                         ref_depth, ref_valid, tiles=tiles)
    elif params.max_edge is not None:
        mesh, target = targets.fit_edge(depth, valid, params, camera, tiles=tiles)
    else:
        weights = None
        if workspace is not None:
            weights = sampling_weights(depth, valid, params, out=workspace.weights)
        t2 = time.perf_counter()
        mesh = mesh_grid(depth, valid, params, camera, weights=weights)
        mesh.stats.seconds["sampling"] += t2 - t1  # the weights belong to stage one
    if wraps(params, camera):
        t3 = time.perf_counter()
        mesh = close_seam(mesh, depth, params)
        mesh.stats.seconds["seam"] = time.perf_counter() - t3
    t4 = time.perf_counter()
    seconds = {"prepare": t1 - t0, **mesh.stats.seconds}
    if target:
        seconds["search"] = t4 - t1 - sum(mesh.stats.seconds.values())
    seconds["total"] = t4 - t0
    stats = dataclasses.replace(mesh.stats, seconds=seconds, target=target)
    return dataclasses.replace(mesh, stats=stats)


def triangulate(image, params: MeshParams | None = None, *, background=None, camera=None,
                vertices: int | None = None, max_error: float | None = None,
                method: str | None = None, color=None, **overrides) -> Mesh:
    """Mesh a range image: refined at its worst pixels for a target, or Garcia & Sappa's pipeline.

    Parameters
    ----------
    image : (H, W) array_like of int or float
        The range image (depth, disparity or range values).
    params : MeshParams, optional
        All algorithm settings; keyword overrides below take precedence.
    background : float, optional
        Value that marks missing depth (``0``, ``65535``, ...). NaN and
        infinite pixels are always background.
    camera : Orthographic, Pinhole, Spherical, Rays or (kx, ky, kz), optional
        How pixels become 3-D points; default ``Orthographic(1, 1, 1)``, the
        paper's eq. (4) with unit scales. `Spherical` (a spinning LiDAR,
        ``Spherical.from_beams``) and `Rays` put each vertex at ``range *
        ray`` of its pixel; a `Spherical` camera that goes once round closes
        the 360-degree seam (``wrap``).
    vertices : int, optional
        Exactly this many vertices (``method='refine'``; every valid pixel if
        there are fewer). With ``method='paper'``: about this many, the grid
        searched to within 2 % (`rangemesh.paper.targets.fit_vertices`).
    max_error : float, optional
        The smallest mesh whose relative error (percent, as `evaluate`) is at
        most this: ``method='refine'`` stops there, in one pass; the paper's
        method searches its grid (`rangemesh.paper.targets.fit_error`).
    method : {'refine', 'paper'}, optional
        ``'refine'``: a coarse mesh refined where it fits worst, by greedy
        insertion (`rangemesh.greedy`): the pixel whose triangle ranks
        highest by its errors becomes a vertex, until exactly `vertices`
        vertices or a relative error of `max_error` is reached, in one
        pass; jumps keep vertices on both sides. Needs one target and takes
        only ``fill_gaps``, ``heights``, ``diagonals``, ``walls``, ``jump``
        and ``wrap`` of the parameters (vertex depths are fitted by least
        squares unless ``heights='pixel'``; ``diagonals='error'`` gives
        each quad the diagonal that fits its pixels better; ``walls=False``
        drops the triangles across jumps).
        ``'paper'``: Garcia & Sappa's pipeline with every parameter below,
        the meshes it has always given. Default (`default_method`):
        ``'refine'`` with a target and no parameter of the paper's method,
        ``'paper'`` otherwise. ``'greedy'``, the earlier name of ``'refine'``,
        is still accepted.
    color : (H, W, 3) or (H, W) array_like, optional
        A colour image registered pixel to pixel with the range image: the
        mesh gets each vertex's colour and keeps the image as its texture
        (`Mesh.with_colors`, which also takes the mean over the pixels a
        vertex stands for).
    **overrides
        Any field of `MeshParams`: ``tiles``, ``samples``, ``sampling``,
        ``flips``, ``levels``, ``curvature_floor``, ``fill_gaps``, ``delta``,
        ``epsilon``, ``max_angle``, ``min_bend``, ``gain_threshold``, and
        ``max_edge`` (no triangle edge longer than this in the image plane,
        pixels; alone, it also chooses the samples per tile, see
        `rangemesh.paper.targets.fit_edge`) and ``workers`` (threads for stage
        one's tiles; the mesh is the same for any number), and ``wrap``
        (close the seam between the last and the first column).

    Returns
    -------
    Mesh
        ``vertices (V, 3)``, ``faces (F, 3)`` counter-clockwise in the image
        plane, ``pixels (V, 2)``, and ``stats``. When nothing can be meshed (no
        valid pixel, fewer than 3 valid samples, all collinear) the mesh is
        empty and ``stats.reason`` says why. With a target, ``stats.target``
        tells what was asked, what was achieved and which grid was chosen.

    Raises
    ------
    ValueError
        Bad image shape, parameters out of range (e.g. more tiles than fit,
        or a sample grid with more entries than the image has pixels, see
        `rangemesh.paper.sampling.max_grid_entries`), ``samples`` together
        with a target, or a camera that maps pixels beyond the float range.
        The message names the parameter.
    TypeError
        Wrong kind of image, camera or parameter (strings are never read as
        numbers or flags).
    MemoryError
        The image needs more memory than the machine has available (20 bytes
        a pixel, see `check_memory`).

    See Also
    --------
    sample_grid, delaunay_mesh, flip_edges : the three stages, callable one by one.
    evaluate : relative error of the result.

    Notes
    -----
    Vertices take their depth from the gap-filled image (paper eq. 4 uses the
    filtered image ``R_f``). Stage timings are in ``stats.seconds``. With a
    target, the tiles and samples of `params` are replaced by the search
    (tiles given as a keyword are kept).

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
    >>> mesh = triangulate(depth, tiles=2, samples=5)
    >>> mesh.stats.vertices, mesh.faces.shape[1]
    (81, 3)
    """
    params = resolve_params(params, overrides)
    method = check_call(params, vertices, max_error, method, overrides)
    if color is not None:
        shape, cshape = np.shape(image)[:2], np.shape(color)[:2]
        if shape != cshape:
            raise ValueError(f"color is {cshape[0]}x{cshape[1]} and the image "
                             f"{shape[0]}x{shape[1]}: they must be registered pixel to pixel")
    mesh = run(image, params, background=background, camera=camera, vertices=vertices,
               max_error=max_error, tiles_given="tiles" in overrides, method=method)
    return mesh if color is None or mesh.is_empty else mesh.with_colors(color)
