"""Meshing parameters: one frozen dataclass holding every default of SPEC.md.

Angles are given in degrees here (and on the command line) and converted to
radians only when they are handed to the kernels.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from .checks import flag
from .options import (
    BOTH,
    Flag,
    above,
    boolean_or_none,
    choice,
    degrees,
    edge_or_none,
    limits_or_none,
    number_or_none,
    option,
    option_docs,
    options_of,
    pair,
    whole,
    whole_or_none,
)

__all__ = ["MeshParams", "SAMPLING_CHOICES", "FLIP_CHOICES", "METHODS", "OPTION_METHOD",
           "OPTION_TABLE", "NONE_MEANS", "DEFAULT_TARGET", "DefaultTarget", "misplaced_option",
           "default_vertex_cap"]

METHODS = ("refine", "paper")
REFINE, PAPER = ("refine",), ("paper",)


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
        opt = OPTIONS_BY_NAME.get(name)
        if opt is not None and method not in opt.methods:
            owner = opt.methods[0]
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


def _angle(default: float, *, low_open: bool, doc: str, flag: str):
    """A flip test's angle of the paper's method, in degrees: the `option` of each of the four.

    `low_open`: 0 is refused (the range is ``(0, 180]``, else ``[0, 180]``); `flag` is the
    flag's help, to which the default is added.
    """
    return option(default, methods=PAPER, type="float", check=degrees(low_open=low_open),
                  doc=doc, flag=Flag(flag + " (default {default})"))


@dataclass(frozen=True)
class MeshParams:
    """Every meshing option, with the paper's defaults: the one declaration of each.

    The settings the stages take (`rangemesh.sample_grid`, `flip_edges`, ...).
    `rangemesh.triangulate` takes them as keywords (``method='paper'``,
    ``tiles=4``); passing a `MeshParams` to it is deprecated. Each field is
    declared with `rangemesh.options.option`: its record says which method
    reads it, how it is checked, its documentation and its command-line flag
    (``docs/options.md``).

    Parameters
    ----------
    {options}

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

    tiles: tuple[int, int] = option(
        (4, 4), methods=PAPER, type="int or (int, int)", check=pair(1),
        doc="Tiles ``(V, H)`` of stage one: vertical stripes (along rows) by horizontal "
            "stripes (along columns); neighbouring tiles share one row or column of pixels. "
            "With a target, chosen for the image unless given.",
        flag=Flag("tiles, rows x columns; neighbours share one line of pixels (default "
                  "{default}; chosen for the image with --vertices/--max-error)", "pair", "VxH"))
    samples: tuple[int, int] = option(
        (10, 10), methods=PAPER, type="int or (int, int)",
        check=pair(2, "a tile's first and last samples are its borders"),
        doc="Samples per tile ``(Rs, Z)``, rows by columns (the paper's R and zeta), each at "
            "least 2: the first and last samples of a tile are its borders. The sample grid "
            "has ``((Rs-1)*V + 1) x ((Z-1)*H + 1)`` entries. Not with a target, which "
            "chooses them.",
        flag=Flag("samples per tile; the grid is ((R-1)V+1) x ((Z-1)H+1) points "
                  "(default {default})", "pair", "RxZ"))
    sampling: str = option(
        "adaptive", methods=PAPER, type="{'adaptive', 'uniform'}",
        check=choice(SAMPLING_CHOICES), choices=SAMPLING_CHOICES,
        doc="``'adaptive'`` places samples by the log-curvature weight of the paper; "
            "``'uniform'`` gives every pixel the same weight (the paper's baseline, same "
            "grid size).",
        flag=Flag("place samples by log-curvature (paper) or evenly (baseline) "
                  "(default {default})", "choice"))
    flips: str | None = option(
        "disparity", methods=PAPER, type="{'disparity', 'error', None}",
        check=choice(FLIP_CHOICES), none_is_value=True,
        doc="``'disparity'`` runs the paper's tests 1-5 and its final test; ``'error'`` "
            "flips every edge whose approximation gain is positive (the paper's comparison "
            "variant); None (or ``'none'``) keeps the plain Delaunay mesh.",
        flag=Flag("edge flips: disparity tests (paper), error gain > 0, or none "
                  "(default {default})", "flips", "{disparity,error,none}"))
    levels: int = option(
        2, methods=PAPER, type="int", check=whole(1),
        doc="Resolutions added into the curvature image (the paper uses 2: full and half).",
        flag=Flag("resolutions summed into the curvature image (default {default}: "
                  "full + half)", "int"))
    curvature_floor: float = option(
        20.0, methods=PAPER, type="float",
        check=above(1.0, "> 1 so that log weights stay positive"),
        doc="Curvature floor on a 0..255 depth scale (the paper's \"e.g., 20\"). The "
            "curvature is normalised by the valid depth range, so the floor means the same "
            "thing in any depth unit. Must be greater than 1 so that every log weight is "
            "positive.",
        flag=Flag("curvature floor on a 0..255 depth scale; flat areas still get points "
                  "(default {default})"))
    fill_gaps: bool = option(
        True, methods=BOTH, type="bool", check=flag,
        doc="Fill single-pixel holes (a background pixel with 8 valid neighbours) with the "
            "mean of the neighbours first, as the paper's first step does.",
        flag=Flag("keep single-pixel holes instead of filling them with the 8-neighbour "
                  "mean (both methods)", "off"))
    delta: float = _angle(
        20.0, low_open=True,
        doc="Upper disparity threshold, degrees (the paper's Delta): above it a triangle is "
            "off its surroundings.",
        flag="upper disparity threshold Delta: above it a triangle is off its surroundings, "
             "degrees")
    epsilon: float = _angle(
        0.3, low_open=False,
        doc="Lower disparity threshold of test 2, degrees: the smallest disparity change "
            "worth a flip.",
        flag="test 2: smallest disparity change worth a flip, degrees")
    max_angle: float = _angle(
        160.0, low_open=True,
        doc="Internal 3-D angle above which test 3 calls a triangle degenerate, degrees.",
        flag="test 3: a triangle with an angle above this is degenerate, degrees")
    min_bend: float = _angle(
        5.0, low_open=False,
        doc="Test 4: the two new triangles' normals must differ by more than this, degrees.",
        flag="test 4: new triangles must bend more than this, degrees")
    gain_threshold: float | None = option(
        None, methods=PAPER, type="float or None", check=number_or_none,
        doc="Stop flipping when the head of the queue has a gain below this. None means "
            "minus infinity: every edge with a finite gain is considered, which the paper "
            "found works best. Ignored by ``flips='error'``, which always stops at the first "
            "non-positive gain.",
        flag=Flag("stop flipping when the best gain left is below this (default: none, "
                  "every edge with a finite gain is tried)"))
    max_edge: float | None = option(
        None, methods=BOTH, type="float or None", check=edge_or_none,
        doc="Longest triangle edge allowed in the image plane, pixels (at least 1.5, a "
            "pixel's diagonal is 1.41); None: no bound. The paper's method adds samples "
            "(given without a vertex or error target, it also chooses the samples per tile, "
            "`rangemesh.paper.targets.fit_edge`); refine inserts pixels after its target is "
            "met, so a vertex count may be exceeded (`stats.target` says so; "
            "`rangemesh.refine.insertion.greedy_mesh`).",
        flag=Flag("no triangle edge longer than this in the image, pixels (both methods; "
                  "refine may exceed --vertices for it)"))
    workers: int = option(
        1, name="threads", methods=PAPER, type="int", check=whole(1),
        doc="Threads sharing stage one's tiles (the paper's parallel stage); the mesh is the "
            "same for any number (`MeshParams` names it ``workers``; in calls, workers are "
            "processes: `rangemesh.mesh_many`). ``method='refine'`` decides itself: on images "
            "of 60,000 valid pixels or more, from 2000 vertices or under an error bound, it "
            "meshes two strips of the image on two threads where the process may use two "
            "cores (`rangemesh.threads`; ``RANGEMESH_THREADS=1`` keeps one); its mesh "
            "too is the same either way.",
        flag=Flag("threads sharing stage one's tiles; the mesh is the same for any number "
                  "(default {default})", "int"))
    heights: str | None = option(
        None, methods=REFINE, type="{'fit', 'pixel'} or None", check=choice(HEIGHT_CHOICES),
        choices=("fit", "pixel"), none_means="fit",
        doc="Where vertex depths come from. ``'fit'`` (None: the default): least squares "
            "over the pixels each vertex's triangles cover, pixels across a jump left out "
            "(`rangemesh.refine.heights.fit_heights`); ``'pixel'``: each vertex copies the "
            "depth of its pixel (the paper's eq. 4, its method's only choice).",
        flag=Flag("vertex depths: least squares over the pixels, jumps left out (fit, the "
                  "default) or copied from the vertex's pixel (pixel)", "choice"))
    diagonals: str | None = option(
        None, methods=REFINE, type="{'error', 'delaunay'} or None",
        check=choice(DIAGONAL_CHOICES), choices=("error", "delaunay"), none_means="error",
        doc="How each quad picks its diagonal. ``'error'`` (None: the default): by the "
            "data, flipping an edge when the two triangles fit their pixels with a smaller "
            "summed error the other way (`rangemesh.refine.diagonals`); ``'delaunay'``: "
            "greedy insertion's Delaunay mesh as it is (in the sensor's units), a little "
            "faster, higher error (``benchmarks/diagonals.py``). The paper's method chooses "
            "its diagonals with `flips`.",
        flag=Flag("each quad's diagonal is the one that fits its pixels better (error, the "
                  "default) or the Delaunay one (delaunay: a little faster, higher error)",
                  "choice"))
    walls: bool = option(
        True, methods=REFINE, type="bool", check=flag,
        doc="Keep the triangles that bridge a depth jump (\"walls\"). False drops them, so "
            "separate surfaces stay separate (see `rangemesh.geometry.walls` for how a jump is "
            "decided).",
        flag=Flag("drop the triangles across depth jumps, so separate surfaces stay "
                  "separate", "off"))
    jump: float = option(
        0.05, methods=REFINE, type="float", check=above(0.0, "a positive share of the depth"),
        doc="With ``walls=False``: an edge is a jump when depth changes along it by more "
            "than this share of the local depth per pixel.",
        flag=Flag("with --no-walls: a depth change above this share of the local depth per "
                  "pixel is a jump (default {default})"))
    wrap: bool | None = option(
        None, methods=BOTH, type="bool or None", check=boolean_or_none,
        doc="Column W-1 is the neighbour of column 0 (a 360-degree scan): the seam between "
            "them is closed with a strip of triangles (`rangemesh.geometry.seam`). None: on "
            "when the camera is a `rangemesh.Spherical` whose columns go once round.",
        flag=Flag("column W-1 is beside column 0 (360 degrees): close the seam (default: on "
                  "for a --beams camera that goes once round); --no-wrap leaves it open",
                  "on_off"))

    depth_limits: tuple[float, float] | None = option(
        None, methods=BOTH, type="(float, float) or None", check=limits_or_none,
        doc="``(near, far)``: pixels whose depth lies outside are missing depth (None on a "
            "side: no limit there). In metres with a metric camera (a `rangemesh.Pinhole`'s "
            "``depth_scale`` or a ray camera's ``range_scale`` applied), in stored depth units "
            "with `rangemesh.Orthographic` (`rangemesh.cleanup`).",
        flag=Flag("pixels whose depth is outside are missing depth: metres with "
                  "--intrinsics/--camera/--beams (depth scale applied), stored units "
                  "otherwise; one side may be empty", "limits", "NEAR,FAR"))
    min_region: int | None = option(
        None, methods=BOTH, type="int or None", check=whole_or_none(1),
        doc="Drop connected regions of valid pixels smaller than this many pixels, regions "
            "split where depth jumps by more than 5 % of the depth a pixel (specks and flying "
            "pixels; `rangemesh.regions`; 20 suits depth cameras, docs/decisions.md). None: "
            "keep every region.",
        flag=Flag("drop connected regions of fewer than K valid pixels, split where depth "
                  "jumps by more than 5 % a pixel: specks (default off; 20 suits depth "
                  "cameras)", "int", "K"))
    effort: str = option(
        "fast", methods=REFINE, type="{'fast', 'best'}", check=choice(EFFORT_CHOICES),
        choices=EFFORT_CHOICES,
        doc="How hard refine works for a lower error at the same vertex count. ``'fast'``: "
            "greedy insertion's mesh. ``'best'``: insertion to "
            "`rangemesh.refine.insertion.COLLAPSE_BEST` (4) times the vertices, then "
            "vertices collapsed onto a neighbour, cheapest first by the exact increase of the "
            "summed pixel error, down to the count; the target is met as with ``'fast'`` "
            "(`rangemesh.refine.insertion.greedy_mesh`). Under a vertex count, ``'fast'``'s "
            "mesh is kept where its relative error is lower, so ``'best'`` never errs more. On "
            "the cases of docs/benchmarks.md "
            "(\"effort\") 0.55-0.75x ``'fast'``'s error on smooth or noisy frames, a tenth or "
            "less on planar and layered ones; on the 69 cases of ``benchmarks/peers.py --budgets "
            "fractions --best`` a median 0.77x its error for a median 25x its time (4-300x).",
        flag=Flag("fast (the default): greedy insertion's mesh; best: a lower error at the "
                  "same vertex count for a median 25 times the time (insertion to more vertices, "
                  "then the cheapest collapses down to the count)", "choice"))

    def __post_init__(self):
        for opt in OPTIONS_BY_FIELD.values():
            value = getattr(self, opt.field)
            checked = opt.check(opt.field, value)
            if checked is not value:
                object.__setattr__(self, opt.field, checked)

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


# The table of options, from MeshParams' fields (`rangemesh.options`), in field order.
OPTION_TABLE = options_of(MeshParams)
OPTIONS_BY_FIELD = {o.field: o for o in OPTION_TABLE}
OPTIONS_BY_NAME = {o.name: o for o in OPTION_TABLE}
# What None stands for in the method that reads an option (its `Option.none_means`): the
# one place a method's default behind a None is resolved from (docs/decisions.md, "MeshParams").
NONE_MEANS = {o.name: o.none_means for o in OPTION_TABLE if o.none_means is not None}
# Which method reads each option; options of both methods (fill_gaps, wrap) are not listed.
# The one rule for Python and the command line (`misplaced_option`).
OPTION_METHOD = {o.name: o.methods[0] for o in OPTION_TABLE if len(o.methods) == 1}
if MeshParams.__doc__:  # (None under python -OO)
    MeshParams.__doc__ = MeshParams.__doc__.replace(
        "    {options}", option_docs(OPTION_TABLE, style="params"))


if __name__ == "__main__":  # python -m rangemesh.params: the table of docs/options.md
    from rangemesh.options import markdown_table

    print(markdown_table(OPTION_TABLE))
