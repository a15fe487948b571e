"""Meshing parameters: one frozen dataclass holding every default of SPEC.md.

Angles are given in degrees here (and on the command line) and converted to
radians only when they are handed to the kernels.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from .checks import flag, real_number, whole_number, whole_pair

__all__ = ["MeshParams", "SAMPLING_CHOICES", "FLIP_CHOICES", "METHODS", "OPTION_METHOD",
           "DEFAULT_TARGET", "DefaultTarget", "misplaced_option", "default_vertex_cap"]

METHODS = ("refine", "paper")

# Which method reads each option; options of both methods (vertices, max_error, fill_gaps,
# wrap) are not listed. The one rule for Python and the command line (`misplaced_option`).
OPTION_METHOD = {
    "heights": "refine", "diagonals": "refine", "walls": "refine", "jump": "refine",
    "effort": "refine",
    "tiles": "paper", "samples": "paper", "sampling": "paper", "flips": "paper",
    "levels": "paper", "curvature_floor": "paper", "delta": "paper", "epsilon": "paper",
    "max_angle": "paper", "min_bend": "paper", "gain_threshold": "paper",
    "max_edge": "paper", "threads": "paper",
}


def misplaced_option(method: str, given, spell=None) -> str | None:
    """Why an option of `given` does not go with `method`, or None when they all do.

    Parameters
    ----------
    method : {'refine', 'paper'}
    given : iterable of str
        Option names given (keys of `OPTION_METHOD`; others are ignored).
    spell : callable, optional
        How the message writes an option and a method (the command line
        writes ``--delta`` and ``--method paper``); default Python's
        ``delta`` and ``method='paper'``.

    Returns
    -------
    str or None

    Examples
    --------
    >>> misplaced_option("refine", ["delta"])
    "delta is an option of method='paper'; method='refine' does not take it"
    """
    def python(name, m):
        return name, f"method={m!r}"

    spell = python if spell is None else spell
    for name in given:
        owner = OPTION_METHOD.get(name)
        if owner is not None and owner != method:
            opt, own = spell(name, owner)
            _, this = spell(name, method)
            return f"{opt} is an option of {own}; {this} does not take it"
    return None


@dataclass(frozen=True)
class DefaultTarget:
    """The target of ``method='refine'`` when the caller gives none.

    A relative error of `max_error` percent (of the valid depth range, mean
    over the valid pixels), with at most `max_share` of the valid pixels as
    vertices and at least `min_vertices`. The cap stops noisy images, where
    the error bound alone follows the noise, at a size a user keeps; see
    ``docs/benchmarks.md``, "The default target".
    """

    max_error: float = 0.5
    max_share: float = 0.02
    min_vertices: int = 50


# The measured choice (benchmarks/default_target.py, figures in docs/benchmarks.md).
DEFAULT_TARGET = DefaultTarget()


def default_vertex_cap(n_valid: int, rule: DefaultTarget = DEFAULT_TARGET) -> int:
    """The default target's vertex cap for an image of `n_valid` valid pixels.

    Examples
    --------
    >>> default_vertex_cap(32_000), default_vertex_cap(1000)
    (640, 50)
    """
    return max(int(rule.max_share * n_valid), rule.min_vertices)

SAMPLING_CHOICES = ("adaptive", "uniform")
FLIP_CHOICES = ("disparity", "error", None)


HEIGHT_CHOICES = (None, "fit", "pixel")
EFFORT_CHOICES = ("fast", "best")
DIAGONAL_CHOICES = (None, "error", "delaunay")


@dataclass(frozen=True)
class MeshParams:
    """Parameters of the Garcia & Sappa pipeline, with the paper's defaults.

    The settings the stages take (`rangemesh.sample_grid`, `flip_edges`, ...).
    `rangemesh.triangulate` takes them as keywords (``method='paper'``,
    ``tiles=4``); passing a `MeshParams` to it is deprecated.

    Parameters
    ----------
    tiles : int or (int, int), default (4, 4)
        Tiles ``(V, H)``: vertical stripes (along rows) by horizontal stripes
        (along columns). Neighbouring tiles share one row or column of pixels.
    samples : int or (int, int), default (10, 10)
        Samples per tile ``(Rs, Z)``, rows by columns (the paper's R and zeta).
        Each must be at least 2: the first and last samples of a tile are its
        borders. The sample grid has ``((Rs-1)*V + 1) x ((Z-1)*H + 1)`` entries.
    sampling : {'adaptive', 'uniform'}, default 'adaptive'
        ``'adaptive'`` places samples by the log-curvature weight of the paper;
        ``'uniform'`` gives every pixel the same weight (the paper's baseline,
        same grid size).
    flips : {'disparity', 'error', None}, default 'disparity'
        ``'disparity'`` runs the paper's tests 1-5 and its final test;
        ``'error'`` flips every edge whose approximation gain is positive
        (the paper's comparison variant); ``None`` keeps the plain Delaunay mesh.
    levels : int, default 2
        Resolutions added into the curvature image (the paper uses 2: full and half).
    curvature_floor : float, default 20
        Curvature floor on a 0..255 depth scale (the paper's "e.g., 20"). The
        curvature is normalised by the valid depth range, so the floor means
        the same thing in any depth unit. Must be greater than 1 so that every
        log weight is positive.
    fill_gaps : bool, default True
        Fill single-pixel holes (a background pixel with 8 valid neighbours)
        with the mean of the neighbours, as the paper's first step does.
    delta : float, default 20
        Upper disparity threshold, degrees (the paper's Delta).
    epsilon : float, default 0.3
        Lower disparity threshold of test 2, degrees.
    max_angle : float, default 160
        Internal 3-D angle above which test 3 calls a triangle degenerate, degrees.
    min_bend : float, default 5
        Test 4: the two new triangles' normals must differ by more than this, degrees.
    gain_threshold : float or None, default None
        Stop flipping when the head of the queue has a gain below this. ``None``
        means minus infinity: every edge with a finite gain is considered, which
        the paper found works best. Ignored by ``flips='error'``, which always
        stops at the first non-positive gain.
    max_edge : float or None, default None
        Longest triangle edge allowed in the image plane, pixels (at least 1.5,
        a pixel's diagonal is 1.41). ``None``: no bound. Given without a vertex
        or error target, it also chooses the samples per tile (see
        `rangemesh.paper.targets.fit_edge`).
    workers : int, default 1
        Threads sharing stage one's tiles (the paper's parallel stage);
        ``threads=`` of `rangemesh.triangulate` (in calls, workers are
        processes: `rangemesh.mesh_many`). The mesh is the same for any
        number. ``method='refine'`` does not read it: on images of 60,000
        valid pixels or more, from 2000 vertices or under an error bound, it
        meshes two strips of the image on two threads where the process may
        use two cores, and shares its fit's pass over the pixels between them
        (`rangemesh.refine.threads`; ``RANGEMESH_THREADS=1`` keeps one); its
        mesh too is the same either way.
    heights : {'fit', 'pixel'} or None, default None
        Where vertex depths come from. ``'pixel'``: each vertex copies the
        depth of its pixel (the paper's eq. 4; the only choice of
        ``method='paper'``). ``'fit'``: least squares over the pixels each
        vertex's triangles cover, pixels across a jump left out
        (`rangemesh.refine.heights.fit_heights`); ``method='refine'`` only.
        ``None``: the method's default, ``'pixel'`` for the paper,
        ``'fit'`` for ``method='refine'``.
    diagonals : {'error', 'delaunay'} or None, default None
        How each quad of ``method='refine'``'s mesh picks its diagonal.
        ``'error'``: by the data, flipping an edge when the two triangles
        fit their pixels with a smaller summed error the other way
        (data-dependent triangulation, `rangemesh.refine.diagonals`).
        ``'delaunay'``: greedy insertion's Delaunay mesh as it is (in the
        sensor's units, `rangemesh.refine.insertion.delaunay_scales`).
        ``None``: ``'error'`` for ``method='refine'``; the paper's
        method chooses its diagonals with `flips`. ``'error'`` lowers the
        mean error and the error near jumps at some cost in time
        (``benchmarks/diagonals.py``, docs/benchmarks.md).
    walls : bool, default True
        Keep the triangles that bridge a depth jump ("walls"). ``False``
        drops them, so separate surfaces stay separate (`method='refine'`
        only; see `rangemesh.refine.walls` for how a jump is decided).
    jump : float, default 0.05
        With ``walls=False``: an edge is a jump when depth changes along it
        by more than this share of the local depth per pixel.
    effort : {'fast', 'best'}, default 'fast'
        How hard ``method='refine'`` works for a lower error at the same
        vertex count. ``'fast'``: greedy insertion's mesh. ``'best'``:
        insertion to `rangemesh.refine.insertion.COLLAPSE_BEST` (4) times
        the vertices, then vertices collapsed onto a neighbour, cheapest
        first by the exact increase of the summed pixel error, down to the
        count (`rangemesh.refine.insertion.greedy_mesh`): on the cases of
        docs/benchmarks.md ("effort") 0.55-0.75x ``'fast'``'s error on
        smooth or noisy frames, a tenth or less on planar and layered ones,
        for 10-35x its time.
    wrap : bool or None, default None
        Column W-1 is the neighbour of column 0 (a 360-degree scan): the seam
        between them is closed with a strip of triangles
        (`rangemesh.geometry.seam`). ``None``: on when the camera is a
        `rangemesh.Spherical` whose columns go once round.

    Raises
    ------
    ValueError
        If a value is out of range or a string choice is unknown.
    TypeError
        If a value has the wrong type (e.g. ``tiles='44'``, ``fill_gaps='no'``,
        ``levels=None``); the message names the parameter.

    Examples
    --------
    >>> p = MeshParams(tiles=4, samples=(10, 8))
    >>> p.tiles, p.samples, p.grid_shape
    ((4, 4), (10, 8), (37, 29))
    """

    tiles: tuple[int, int] = (4, 4)
    samples: tuple[int, int] = (10, 10)
    sampling: str = "adaptive"
    flips: str | None = "disparity"
    levels: int = 2
    curvature_floor: float = 20.0
    fill_gaps: bool = True
    delta: float = 20.0
    epsilon: float = 0.3
    max_angle: float = 160.0
    min_bend: float = 5.0
    gain_threshold: float | None = None
    max_edge: float | None = None
    workers: int = 1
    heights: str | None = None
    diagonals: str | None = None
    walls: bool = True
    jump: float = 0.05
    wrap: bool | None = None
    effort: str = "fast"

    def __post_init__(self):
        tiles = whole_pair("tiles", self.tiles, minimum=1)
        samples = whole_pair("samples", self.samples)
        object.__setattr__(self, "tiles", tiles)
        object.__setattr__(self, "samples", samples)
        if min(samples) < 2:
            raise ValueError(
                f"samples must be >= 2 in both directions (a tile's first and last "
                f"samples are its borders), got {samples}"
            )
        if not isinstance(self.sampling, str) or self.sampling not in SAMPLING_CHOICES:
            raise ValueError(
                f"sampling must be one of {SAMPLING_CHOICES}, got {self.sampling!r}"
            )
        if not (self.flips is None or isinstance(self.flips, str)) \
                or self.flips not in FLIP_CHOICES:
            raise ValueError(f"flips must be one of {FLIP_CHOICES}, got {self.flips!r}")
        object.__setattr__(self, "levels", whole_number("levels", self.levels, minimum=1))
        for name in ("curvature_floor", "delta", "epsilon", "max_angle", "min_bend"):
            object.__setattr__(self, name, real_number(name, getattr(self, name)))
        if self.curvature_floor <= 1.0:
            raise ValueError(
                f"curvature_floor must be > 1 so that log weights stay positive, "
                f"got {self.curvature_floor}"
            )
        for name in ("delta", "max_angle"):
            if not 0.0 < getattr(self, name) <= 180.0:
                raise ValueError(f"{name} must be in (0, 180] degrees, got {getattr(self, name)}")
        for name in ("epsilon", "min_bend"):
            if not 0.0 <= getattr(self, name) <= 180.0:
                raise ValueError(f"{name} must be in [0, 180] degrees, got {getattr(self, name)}")
        if self.gain_threshold is not None:
            g = real_number("gain_threshold", self.gain_threshold, finite=False)
            if math.isnan(g):
                raise ValueError("gain_threshold must be a number or None, got nan")
            object.__setattr__(self, "gain_threshold", g)
        object.__setattr__(self, "fill_gaps", flag("fill_gaps", self.fill_gaps))
        if self.max_edge is not None:
            e = real_number("max_edge", self.max_edge, finite=False)
            if not math.isfinite(e) or e < 1.5:
                raise ValueError(
                    f"max_edge must be at least 1.5 pixels (a pixel's diagonal is 1.41), "
                    f"got {self.max_edge!r}"
                )
            object.__setattr__(self, "max_edge", e)
        object.__setattr__(self, "workers", whole_number("workers", self.workers, minimum=1))
        if not (self.heights is None or isinstance(self.heights, str)) \
                or self.heights not in HEIGHT_CHOICES:
            raise ValueError(f"heights must be one of {HEIGHT_CHOICES}, got {self.heights!r}")
        if not (self.diagonals is None or isinstance(self.diagonals, str)) \
                or self.diagonals not in DIAGONAL_CHOICES:
            raise ValueError(f"diagonals must be one of {DIAGONAL_CHOICES}, got {self.diagonals!r}")
        object.__setattr__(self, "walls", flag("walls", self.walls))
        jump = real_number("jump", self.jump)
        if not jump > 0:
            raise ValueError(f"jump must be a positive share of the depth, got {self.jump!r}")
        object.__setattr__(self, "jump", jump)
        if not isinstance(self.effort, str) or self.effort not in EFFORT_CHOICES:
            raise ValueError(f"effort must be one of {EFFORT_CHOICES}, got {self.effort!r}")
        if self.wrap is not None:
            object.__setattr__(self, "wrap", flag("wrap", self.wrap))

    @property
    def grid_shape(self) -> tuple[int, int]:
        """Shape ``(Gr, Gc)`` of the sample grid: ``((Rs-1)V+1, (Z-1)H+1)``."""
        (v, h), (rs, z) = self.tiles, self.samples
        return (rs - 1) * v + 1, (z - 1) * h + 1

    def replace(self, **changes) -> MeshParams:
        """Return a copy with some fields changed (checked again).

        Raises
        ------
        TypeError
            If a name is not a field of `MeshParams`.
        """
        unknown = set(changes) - {f.name for f in dataclasses.fields(self)}
        if unknown:
            raise TypeError(
                f"unknown parameter(s) {sorted(unknown)}; known: "
                f"{[f.name for f in dataclasses.fields(self)]}"
            )
        return dataclasses.replace(self, **changes)
