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
import functools
import math
import time
import warnings

import numpy as np

from ._core import EXACT_SPAN, valid_range
from .camera import Spherical, as_camera, check_reach, check_shape
from .checks import real_number, whole_number
from .geometry.seam import seam_strip, strip_to_keep, unrolled_columns
from .mesh import Mesh, Stats, Target, count_edges, empty_mesh, with_fields
from .paper import targets
from .paper.sampling import fill_gaps_inplace, sample_grid, sampling_weights
from .paper.stages import mesh_grid
from .params import DEFAULT_TARGET, METHODS, OPTION_METHOD, MeshParams, default_vertex_cap, misplaced_option
from .prepare import check_image, mask_into, to_depth_and_mask
from .refine import greedy_mesh
from .refine.walls import wall_faces

__all__ = ["triangulate", "resolve_call", "resolve_params", "prepare", "run", "Workspace",
           "check_memory", "memory_need", "vertex_ceiling", "OPTIONS"]


@functools.lru_cache(maxsize=1)
def _defaults() -> MeshParams:
    """`MeshParams()`, built once (it checks every field)."""
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
# method="refine": bytes a pixel (depth, mask, the reference and render of an error bound) plus
# bytes a vertex (the insertion's triangles, heap and keys, the faces, the fit's system), from
# `python benchmarks/memory.py --refine` (2000 x 2000: 11-25 B a pixel, 370-640 B a vertex
# with strips; the report's dense max_error mesh 600), rounded up.
REFINE_BYTES_PER_PIXEL = 32
REFINE_BYTES_PER_VERTEX = 700
# The largest depth magnitude the paper's method meshes: its kernels square depths (plane fits,
# curvature), which overflow float64 beyond about 1e154. (method="refine" divides depths by a power
# of two first, `rangemesh.refine.insertion.depth_exponent`: any finite depth range.)
MAX_DEPTH = 1e150


# `available_memory` reads /proc/meminfo at most once in this many seconds: the read weighs on
# a call on a small image, and a check that old still stops a runaway image.
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


def memory_need(shape, method: str = "paper", vertices: int | None = None) -> int:
    """Bytes `run` needs to mesh an image of `shape` with `method`, as `check_memory` counts them.

    ``'paper'``: BYTES_PER_PIXEL a pixel. ``'refine'``: REFINE_BYTES_PER_PIXEL a
    pixel plus REFINE_BYTES_PER_VERTEX for each of `vertices` (at most one a
    pixel; None: none counted, the error bound's search watches its count
    itself, `vertex_ceiling`).

    Examples
    --------
    >>> memory_need((100, 100)), memory_need((100, 100), "refine", 1000)
    (200000, 1020000)
    """
    pixels = int(shape[0]) * int(shape[1])
    if method != "refine":
        return pixels * BYTES_PER_PIXEL
    return pixels * REFINE_BYTES_PER_PIXEL + min(int(vertices or 0), pixels) * REFINE_BYTES_PER_VERTEX


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


def check_memory(shape, method: str = "paper", vertices: int | None = None) -> None:
    """Refuse an image whose meshing would need more memory than the machine has free.

    The rule: `memory_need` (20 bytes a pixel for the paper's method; for
    refine 32 a pixel and 700 a requested vertex), against the memory
    available now. Failing at once with a clear message beats being killed by
    the kernel's out-of-memory handler half way, or swapping the machine to a
    halt.

    Raises
    ------
    MemoryError
    """
    need = memory_need(shape, method, vertices)
    free = available_memory()
    if free is not None and need > free:
        per = (f"{BYTES_PER_PIXEL} bytes a pixel" if method != "refine" else
               f"{REFINE_BYTES_PER_PIXEL} bytes a pixel and {REFINE_BYTES_PER_VERTEX} a vertex")
        budget = f" with {vertices} vertices" if method == "refine" and vertices else ""
        raise MemoryError(
            f"a {shape[0]}x{shape[1]} image needs about {_size(need)} of memory to mesh{budget} "
            f"({per}) and {_size(free)} are available; mesh it in parts, with fewer vertices "
            f"or on a larger machine"
        )


def vertex_ceiling(shape) -> int | None:
    """Vertices method="refine" can make in the memory available now (None: not known).

    An error bound's search stops there (`run`) and says that memory, not
    the bound, ended it: its count is not known before the work.
    """
    free = available_memory()
    if free is None:
        return None
    rest = free - int(shape[0]) * int(shape[1]) * REFINE_BYTES_PER_PIXEL
    return max(rest // REFINE_BYTES_PER_VERTEX, 0)


def _size(n: int) -> str:
    return f"{n / 2**30:.1f} GiB" if n >= 2**30 else f"{n / 2**20:.1f} MiB"


def prepare(image, params: MeshParams, background=None, *,
            workspace: Workspace | None = None, camera=None) -> tuple[np.ndarray, np.ndarray]:
    """Depth and validity mask as stage one sees them: checked, masked, gap-filled.

    Parameters
    ----------
    image : (H, W) array_like
    params : MeshParams
        Only ``fill_gaps`` is read.
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
    return _prepare_checked(arr, params, background, workspace)


def _prepare_checked(arr, params: MeshParams, background, workspace, need=("paper", None)):
    """`prepare` of an image `check_image` has checked (and its background resolved).

    `need`: the method and vertex count `check_memory` checks the image for.
    """
    if workspace is None:
        check_memory(arr.shape, *need)
        depth = np.zeros(arr.shape, np.float64)
        valid = np.zeros(arr.shape, np.bool_)
    else:
        depth, valid = workspace.depth, workspace.valid
    mask_into(arr, background, depth, valid)
    if params.fill_gaps:
        # the arrays are ours and hold 0.0 on background: fill in place, no copies
        fill_gaps_inplace(depth, valid)
    return depth, valid


def _legacy_method(params: MeshParams, vertices, max_error, overrides) -> str:
    """The method a call with ``params=`` or ``**overrides`` and no ``method=`` got before.

    ``'refine'`` when a target is given and nothing only the paper's method
    reads is; ``'paper'`` otherwise: the deprecated spellings keep their meshes.
    """
    if vertices is None and max_error is None:
        return "paper"
    if set(overrides) - set(_LEGACY_REFINE_FIELDS):
        return "paper"
    defaults = _defaults()
    for f in dataclasses.fields(MeshParams):
        if f.name not in _LEGACY_REFINE_FIELDS \
                and getattr(params, f.name) != getattr(defaults, f.name):
            return "paper"
    return "refine"


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
    # (a plain int or float in range passes without the general checks' ABC lookups: every
    # call makes them)
    if vertices is not None and not (type(vertices) is int and vertices >= 3):
        whole_number("vertices", vertices, minimum=3)
    if max_error is not None and not (type(max_error) is float and 0.0 < max_error < math.inf):
        if real_number("max_error", max_error, finite=False) <= 0 or not np.isfinite(max_error):
            raise ValueError(f"max_error must be a positive number of percent, got {max_error!r}")
    return given


# The name "refine" had before (greedy insertion); still accepted, with a warning.
ALIASES = {"greedy": "refine"}
# the MeshParams fields the deprecated spellings let method="refine" take
_LEGACY_REFINE_FIELDS = ("fill_gaps", "workers", "heights", "diagonals", "walls", "jump", "wrap")
# option -> MeshParams field (the in-call thread count is `threads`; MeshParams calls it workers)
_FIELD_OF = {name: ("workers" if name == "threads" else name) for name in OPTION_METHOD}
# The keyword options of `triangulate`, `mesh_stream` and `mesh_many` besides the targets.
OPTIONS = ("fill_gaps", "wrap", *OPTION_METHOD)


def keyword_options(scope: dict) -> dict:
    """The `OPTIONS` a call of `triangulate`, `mesh_stream` or `mesh_many` got: from its `locals()`.

    Each of those functions names every option as a keyword; this reads them
    back in one place, so adding an option means adding it to `OPTIONS` and to
    the signatures only.
    """
    return {name: scope[name] for name in OPTIONS}


def call_options(params: MeshParams, method: str) -> dict:
    """The keyword options that give `params` to `method` (those away from their defaults).

    Examples
    --------
    >>> call_options(MeshParams(tiles=2, workers=3, flips=None), "paper")
    {'tiles': (2, 2), 'flips': 'none', 'threads': 3}
    """
    defaults = _defaults()
    out = {}
    for name in OPTIONS:
        field = _FIELD_OF.get(name, name)
        value = getattr(params, field)
        if value != getattr(defaults, field) and OPTION_METHOD.get(name, method) == method:
            out[name] = "none" if name == "flips" and value is None else value
    return out


@functools.lru_cache(maxsize=64)
def _params_cached(items: tuple) -> MeshParams:
    return MeshParams(**dict(items))


def _params_of(fields: dict) -> MeshParams:
    """`MeshParams` of these fields, built once per distinct set (it checks every field)."""
    if not fields:
        return _defaults()
    try:
        return _params_cached(tuple(sorted(fields.items())))
    except TypeError:  # an unhashable value (a list of tiles): build it, uncached
        return MeshParams(**fields)


def _method_name(method, stacklevel: int) -> str:
    if method in ALIASES:
        warnings.warn(f"method={method!r} is the earlier name of method={ALIASES[method]!r}; "
                      f"it goes in the next release", DeprecationWarning, stacklevel=stacklevel + 1)
        return ALIASES[method]
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    return method


def resolve_call(params, method, vertices, max_error, options: dict, overrides: dict, *,
                 stacklevel: int = 3) -> tuple[MeshParams, str, bool]:
    """The settings of a `triangulate` (or `mesh_stream`, `mesh_many`) call, checked.

    Parameters
    ----------
    params : MeshParams or None
        Deprecated spelling of the options.
    method, vertices, max_error
        As `triangulate` takes them.
    options : dict
        The keyword options of `OPTIONS`, None where not given (``flips``:
        ``'disparity'`` where not given).
    overrides : dict
        Deprecated ``**overrides`` (``workers``: the old name of ``threads``).
    stacklevel : int
        Where a deprecation warning points: the user's call.

    Returns
    -------
    params : MeshParams
        Every setting, the method's defaults where not given.
    method : {'refine', 'paper'}
    tiles_given : bool
        Whether the user gave the tiles (a target search of the paper keeps them).

    Raises
    ------
    ValueError
        An option of the other method (naming it and its method), a bad
        target or value.
    TypeError
        An unknown keyword, or `params` not a `MeshParams`.
    """
    method = _method_name(method, stacklevel)
    # None means "not given" except for flips, where it means no flips (as in MeshParams)
    given = {k: v for k, v in options.items() if v is not None and k != "flips"}
    flips = options.get("flips", "disparity")
    if flips != "disparity":
        given["flips"] = "none" if flips is None else flips
    if overrides:
        unknown = set(overrides) - {"workers"}
        if unknown:
            raise TypeError(f"unknown option(s) {sorted(unknown)}; the options are "
                            f"{', '.join(OPTIONS)}, vertices, max_error and method")
        warnings.warn("workers= is now threads= (in rangemesh, workers are processes: "
                      "mesh_many); workers= goes in the next release", DeprecationWarning,
                      stacklevel=stacklevel)
        if "threads" in given:
            raise TypeError("give threads= only (workers= is its old name)")
        given["threads"] = overrides["workers"]
    fields = {}
    if given:
        if "threads" in given:  # checked under its own name: MeshParams calls it workers
            whole_number("threads", given["threads"], minimum=1)
        fields = {_FIELD_OF.get(k, k): v for k, v in given.items()}
        if fields.get("flips") == "none":
            fields["flips"] = None
    if params is not None:
        # the deprecated spelling keeps the method and the mesh it gave before
        if not isinstance(params, MeshParams):
            raise TypeError(f"params must be a rangemesh.MeshParams or None, got "
                            f"{type(params).__name__}")
        warnings.warn("params=MeshParams(...) is deprecated: give method= and the options as "
                      "keywords (triangulate(image, method='paper', tiles=4)); it goes in the "
                      "next release", DeprecationWarning, stacklevel=stacklevel)
        params = params.replace(**fields) if fields else params
        if method == "refine":
            method = _legacy_method(params, vertices, max_error, fields)
        _targets_given(params, vertices, max_error, fields)
        changed = [k for k, f in _FIELD_OF.items() if getattr(params, f) != getattr(_defaults(), f)
                   and not (k == "threads" and method == "refine")  # refine ignored it
                   and not (k == "heights" and params.heights == "pixel" and method == "paper")]
        message = misplaced_option(method, changed)
        if message:
            raise ValueError(message)
        return params, method, "tiles" in fields
    if given:
        message = misplaced_option(method, given)
        if message:
            raise ValueError(f"{message} (method is chosen by method= alone)")
    params = _params_of(fields)
    _targets_given(params, vertices, max_error, fields)
    return params, method, "tiles" in fields


def wraps(params: MeshParams, camera) -> bool:
    """Whether the seam between the last and first column is closed: `params.wrap`, or the camera's say."""
    if params.wrap is not None:
        return params.wrap
    return isinstance(camera, Spherical) and camera.wraps


def close_seam(mesh: Mesh, depth: np.ndarray, params: MeshParams) -> Mesh:
    """`mesh` with the strip of `rangemesh.geometry.seam.seam_strip` added.

    With ``walls=False`` the strip's triangles across a jump are dropped by
    the same rule as the others, their pixel lengths measured across the seam.
    Then every strip triangle that would repeat an edge of the mesh or give a
    vertex a second fan is dropped
    (`rangemesh.geometry.seam.strip_to_keep`): the mesh's own triangles and
    vertices stay, so a vertex count asked for is kept.
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
    # a strip face that repeats a mesh edge or reaches a vertex across a dropped wall would
    # break P4: such faces go, the mesh's own faces and vertices stay
    strip = strip[strip_to_keep(mesh.faces, strip)]
    if not len(strip):
        return mesh
    faces = np.concatenate([mesh.faces, strip]).astype(np.int32)
    stats = dataclasses.replace(mesh.stats, triangles=len(faces), edges=count_edges(faces))
    return dataclasses.replace(mesh, faces=faces, stats=stats)


def run(image, params: MeshParams, *, background="auto", camera=None, vertices=None,
        max_error=None, tiles_given: bool = True, workspace: Workspace | None = None,
        method: str = "refine") -> Mesh:
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
    t0 = time.perf_counter()
    image, background = check_image(image, background, camera=camera)  # resolves 'auto'
    check_side(image.shape)
    if method == "paper" and min(image.shape) < 2:  # no tile fits, with or without a target
        raise ValueError(f"the paper's method needs an image of at least 2x2 pixels (its "
                         f"tiles are at least 2 pixels thick), got {image.shape[0]}x"
                         f"{image.shape[1]}")
    default_target = method == "refine" and vertices is None and max_error is None
    # refine's need grows with its vertices: those asked, or the default target's cap at most
    budget = default_vertex_cap(image.size) if default_target else vertices
    depth, valid = _prepare_checked(image, params, background, workspace, (method, budget))
    check_shape(camera, depth.shape)
    lo, hi, n_valid = valid_range(depth, valid)
    if n_valid:
        if not math.isfinite(hi - lo):
            raise ValueError(f"depths {lo:g} .. {hi:g}: their range exceeds the float range; "
                             f"scale the image (and its camera) down")
        if method == "paper" and max(abs(lo), abs(hi)) > MAX_DEPTH:
            raise ValueError(f"depths {lo:g} .. {hi:g} reach beyond {MAX_DEPTH:g}, where the "
                             f"kernels' squares overflow: scale the image (and its camera) down")
        check_reach(camera, depth.shape, lo, hi)
    t1 = time.perf_counter()
    if not n_valid:
        # Still check the tiling so that bad parameters fail the same way on any image.
        if method == "paper":
            sample_grid(depth, valid, params.replace(sampling="uniform"))
        stats = Stats(grid_shape=params.grid_shape if method == "paper" else None,
                      seconds={"prepare": t1 - t0, "total": t1 - t0}, method=method,
                      reason="the image has no valid pixel (all background)")
        return empty_mesh(camera, depth.shape, stats)
    target = {}
    tiles = params.tiles if tiles_given else None
    if method == "refine":
        cap = memory_cap = None
        if default_target:
            max_error, cap = DEFAULT_TARGET.max_error, default_vertex_cap(n_valid)
        asked_cap = cap
        if vertices is None and workspace is None:
            # an error bound's count is known only at the end: stop where memory runs out
            ceiling = vertex_ceiling(depth.shape)
            if ceiling is not None and ceiling < min(cap or n_valid, n_valid):
                cap = memory_cap = max(ceiling, 3)
        ref = to_depth_and_mask(image, background) if max_error is not None else None
        mesh, target = greedy_mesh(depth, valid, camera, vertices=vertices, max_error=max_error,
                                   reference=ref, fit=params.heights != "pixel",
                                   diagonals=params.diagonals or "error",
                                   walls=params.walls, jump=params.jump, effort=params.effort,
                                   extent=(lo, hi, n_valid), max_vertices=cap)
        if memory_cap is not None and target and not target["met"] \
                and target.get("note", "").startswith("stopped at max_vertices"):
            raise MemoryError(
                f"the error bound {max_error:g} % needs more than {memory_cap} vertices, which "
                f"is what the {_size(available_memory() or 0)} of memory available hold "
                f"({REFINE_BYTES_PER_VERTEX} bytes a vertex); give a larger max_error or a "
                f"vertex count, or mesh on a larger machine")
        if memory_cap is not None and target:  # the record keeps the cap that was asked for
            target.pop("max_vertices", None)
            if asked_cap is not None:
                target["max_vertices"] = asked_cap
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
    record = Target.from_record(target, vertices=mesh.stats.vertices,
                                default=default_target) if target else None
    changes = {"seconds": seconds, "target": record, "method": method}
    if record is not None and record.tiles is not None:
        # the grid the search chose; with max_edge the mesh's points are a list, not a grid
        (v, h), (rs, z) = record.tiles, record.samples
        changes["grid_shape"] = ((rs - 1) * v + 1, (z - 1) * h + 1)
    return with_fields(mesh, stats=with_fields(mesh.stats, **changes))


def triangulate(image, params: MeshParams | None = None, *,
                method: str = "refine", vertices: int | None = None,
                max_error: float | None = None, background="auto", camera=None, color=None,
                fill_gaps: bool | None = None, wrap: bool | None = None,
                heights: str | None = None, diagonals: str | None = None,
                walls: bool | None = None, jump: float | None = None,
                effort: str | None = None,
                tiles: int | tuple[int, int] | None = None,
                samples: int | tuple[int, int] | None = None, sampling: str | None = None,
                flips: str | None = "disparity", levels: int | None = None,
                curvature_floor: float | None = None, delta: float | None = None,
                epsilon: float | None = None, max_angle: float | None = None,
                min_bend: float | None = None, gain_threshold: float | None = None,
                max_edge: float | None = None, threads: int | None = None,
                **overrides) -> Mesh:
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
    fill_gaps : bool, optional
        Both methods. Fill single-pixel holes (a background pixel with 8
        valid neighbours) with their mean first (default True).
    wrap : bool, optional
        Both methods. Close the seam between the last and first column (a
        360-degree scan); default: the camera's say.
    heights : {'fit', 'pixel'}, optional
        ``'refine'`` only. Vertex depths by least squares over the pixels,
        jumps left out (``'fit'``, default), or copied from the pixel.
    diagonals : {'error', 'delaunay'}, optional
        ``'refine'`` only. Each quad's diagonal: the one that fits its pixels
        better (``'error'``, default) or greedy insertion's Delaunay one.
    walls : bool, optional
        ``'refine'`` only. False drops the triangles across depth jumps, so
        separate surfaces stay separate (default True).
    jump : float, optional
        ``'refine'`` only, with ``walls=False``: a depth change above this
        share of the local depth per pixel is a jump (default 0.05).
    effort : {'fast', 'best'}, optional
        ``'refine'`` only. ``'fast'`` (default): greedy insertion's mesh.
        ``'best'``: a lower error at the same vertex count for several times
        the time: insertion to more vertices, then the vertices whose
        removal raises the summed pixel error least are collapsed onto a
        neighbour until the count is met (the target is met as with
        ``'fast'``; see `MeshParams`).
    tiles : int or (int, int), optional
        ``'paper'`` only. Tiles ``(V, H)`` of stage one (default (4, 4); with
        a target, chosen for the image unless given).
    samples : int or (int, int), optional
        ``'paper'`` only. Samples per tile ``(Rs, Z)`` (default (10, 10));
        not with a target, which chooses them.
    sampling : {'adaptive', 'uniform'}, optional
        ``'paper'`` only. Log-curvature sampling (default) or the uniform baseline.
    flips : {'disparity', 'error', None}, default 'disparity'
        ``'paper'`` only. The paper's disparity tests, its error-based
        variant, or no flips (None, or ``'none'``).
    levels : int, optional
        ``'paper'`` only. Resolutions summed into the curvature (default 2).
    curvature_floor : float, optional
        ``'paper'`` only. Curvature floor on a 0..255 depth scale (default 20).
    delta, epsilon, max_angle, min_bend : float, optional
        ``'paper'`` only. The flip tests' thresholds in degrees (defaults 20,
        0.3, 160, 5; see `MeshParams`).
    gain_threshold : float, optional
        ``'paper'`` only. Stop flipping below this gain (default: none).
    max_edge : float, optional
        ``'paper'`` only. No triangle edge longer than this in the image
        plane, pixels; alone, it also chooses the samples per tile
        (`rangemesh.paper.targets.fit_edge`).
    threads : int, optional
        ``'paper'`` only. Threads sharing stage one's tiles; the mesh is the
        same for any number (default 1). (``'refine'`` decides itself:
        `rangemesh.refine.threads`.)
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
    options = keyword_options(locals())
    params, method, tiles_given = resolve_call(params, method, vertices, max_error, options,
                                               overrides)
    if color is not None:
        shape, cshape = np.shape(image)[:2], np.shape(color)[:2]
        if shape != cshape:
            raise ValueError(f"color is {cshape[0]}x{cshape[1]} and the image "
                             f"{shape[0]}x{shape[1]}: they must be registered pixel to pixel")
    mesh = run(image, params, background=background, camera=camera, vertices=vertices,
               max_error=max_error, tiles_given=tiles_given, method=method)
    return mesh if color is None or mesh.is_empty else mesh.with_colors(color)
