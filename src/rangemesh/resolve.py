"""A call's settings, checked once: the method, the targets and the options.

`resolve_call` is the one rule for `rangemesh.triangulate`,
`rangemesh.mesh_stream`, `rangemesh.mesh_many`, recordings and the command
line: ``method=`` alone chooses the method, and an option of the other method
(`rangemesh.params.OPTION_TABLE` says which method reads each) is an error.
"""

from __future__ import annotations

import functools
import math
import operator
import warnings

from .checks import real_number, whole_number
from .options import check_option, split_options
from .params import METHODS, OPTION_TABLE, OPTIONS_BY_NAME, MeshParams, misplaced_option

__all__ = ["resolve_call", "resolve_keywords", "resolve_params", "call_options",
           "keyword_options", "call_keywords", "OPTIONS", "ALIASES"]

# The keyword options of `triangulate`, `mesh_stream` and `mesh_many` besides the targets.
OPTIONS = tuple(o.name for o in OPTION_TABLE)
_read_options = operator.itemgetter(*OPTIONS)
# The name "refine" had before (greedy insertion); still accepted, with a warning.
ALIASES = {"greedy": "refine"}
# The MeshParams fields the deprecated spellings let method="refine" take (history: the options
# of both methods and refine's when `params=` was deprecated, and `workers`, which it ignored).
_LEGACY_REFINE_FIELDS = ("fill_gaps", "workers", "heights", "diagonals", "walls", "jump", "wrap",
                         "depth_limits", "min_region")


@functools.lru_cache(maxsize=1)
def defaults() -> MeshParams:
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
        params = defaults()
    elif not isinstance(params, MeshParams):
        raise TypeError(
            f"params must be a rangemesh.MeshParams or None, got {type(params).__name__}"
        )
    return params.replace(**overrides) if overrides else params


def keyword_options(scope: dict) -> dict:
    """The `OPTIONS` a call of `triangulate` got: from its `locals()`.

    `triangulate` names every option as a keyword (a test holds its signature
    to the table); this reads them back in one place.
    """
    return dict(zip(OPTIONS, _read_options(scope), strict=True))


def call_keywords(given: dict) -> tuple[dict, dict]:
    """A call's ``**options`` as ``(options, rest)``: every option, and the other keywords.

    `options` holds each option as given, or its value when not given (None;
    ``'disparity'`` for ``flips``); `rest` goes to `resolve_call` as its
    `overrides` (a deprecated name, or an unknown keyword: TypeError there).
    """
    return split_options(OPTION_TABLE, given)


def call_options(params: MeshParams, method: str) -> dict:
    """The keyword options that give `params` to `method` (those away from their defaults).

    Examples
    --------
    >>> call_options(MeshParams(tiles=2, workers=3, flips=None), "paper")
    {'tiles': (2, 2), 'flips': 'none', 'threads': 3}
    """
    base = defaults()
    out = {}
    for o in OPTION_TABLE:
        value = getattr(params, o.field)
        if value != getattr(base, o.field) and method in o.methods:
            out[o.name] = "none" if o.none_is_value and value is None else value
    return out


@functools.lru_cache(maxsize=64)
def _params_cached(items: tuple) -> MeshParams:
    return MeshParams(**dict(items))


def _params_of(fields: dict) -> MeshParams:
    """`MeshParams` of these fields, built once per distinct set (it checks every field)."""
    if not fields:
        return defaults()
    try:
        return _params_cached(tuple(sorted(fields.items())))
    except TypeError:  # an unhashable value: build it, uncached
        return MeshParams(**fields)


def _method_name(method, stacklevel: int) -> str:
    if method in ALIASES:
        warnings.warn(f"method={method!r} is the earlier name of method={ALIASES[method]!r}; "
                      f"it goes in the next release", DeprecationWarning, stacklevel=stacklevel + 1)
        return ALIASES[method]
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    return method


def _legacy_method(params: MeshParams, vertices, max_error, overrides) -> str:
    """The method a call with ``params=`` or ``**overrides`` and no ``method=`` got before.

    ``'refine'`` when a target is given and nothing only the paper's method
    reads is; ``'paper'`` otherwise: the deprecated spellings keep their meshes.
    """
    if vertices is None and max_error is None:
        return "paper"
    if set(overrides) - set(_LEGACY_REFINE_FIELDS):
        return "paper"
    base = defaults()
    for o in OPTION_TABLE:
        if o.field not in _LEGACY_REFINE_FIELDS \
                and getattr(params, o.field) != getattr(base, o.field):
            return "paper"
    return "refine"


def _targets_given(params: MeshParams, vertices, max_error, fields,
                   deviations=(None, None), method: str = "refine") -> list[str]:
    if vertices is not None and max_error is not None:
        raise ValueError("vertices and max_error exclude each other: give one target")
    check_deviations(deviations, vertices, max_error, method)
    given = [k for k, v in (("vertices", vertices), ("max_error", max_error),
                            ("max_edge", params.max_edge)) if v is not None]
    if given and "samples" in fields:
        raise ValueError(
            f"{' and '.join(given)} choose the samples per tile themselves; "
            f"do not give samples={fields['samples']!r} as well"
        )
    # (a plain int or float in range passes without the general checks' ABC lookups: every
    # call makes them)
    if vertices is not None and not (type(vertices) is int and vertices >= 3):
        whole_number("vertices", vertices, minimum=3)
    if max_error is not None and not (type(max_error) is float and 0.0 < max_error < math.inf):
        if real_number("max_error", max_error, finite=False) <= 0 or not math.isfinite(
                float(max_error)):
            raise ValueError(f"max_error must be a positive number of percent, got {max_error!r}")
    return given


def _deprecated_workers(overrides: dict, given: dict, stacklevel: int) -> None:
    """``workers=`` (the old name of ``threads``) into `given`; any other keyword is refused."""
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


_UNSET = {o.name: o.unset for o in OPTION_TABLE}
_NOT_GIVEN = dict(_UNSET)  # the options of a call that gives none
_NOT_GIVEN_VALUES = tuple(_NOT_GIVEN[name] for name in OPTIONS)


def _unset(name: str, value) -> bool:
    """Whether a call's option holds its value for "not given" (None; flips: 'disparity')."""
    unset = _UNSET[name]
    return value is None if unset is None else (value is not None and value == unset)


def check_deviations(deviations, vertices, max_error, method: str) -> None:
    """Refuse a bad ``(max_deviation, mean_deviation)``: each a number >= 0, one target at most.

    Raises
    ------
    ValueError
        A negative, NaN or infinite bound, two targets given, or the paper's method.
    TypeError
        A bound that is not a real number.
    """
    if deviations[0] is None and deviations[1] is None:  # (most calls: no list built)
        return
    given = [(k, v) for k, v in zip(("max_deviation", "mean_deviation"), deviations, strict=True)
             if v is not None]
    others = [k for k, v in (("vertices", vertices), ("max_error", max_error)) if v is not None]
    names = [k for k, _ in given] + others
    if len(names) > 1:
        raise ValueError(f"{' and '.join(names)} exclude each other: give one target")
    name, value = given[0]
    if method != "refine":
        raise ValueError(f"{name} is a target of method='refine'; method={method!r} does not "
                         f"take it")
    x = real_number(name, value, finite=False)
    if not (math.isfinite(x) and x >= 0.0):
        raise ValueError(f"{name} must be a finite number of 0 or more (metres with a metric "
                         f"camera, depth units with Orthographic), got {value!r}")


def resolve_keywords(params, method, vertices, max_error, scope: dict, overrides: dict, *,
                     stacklevel: int = 3, deviations=(None, None)) -> tuple[MeshParams, str, bool]:
    """`resolve_call` of a `triangulate` call, its options read from its `locals()` (`scope`).

    A call that gives no option (most calls) is resolved without building the
    options' dict: they are compared with their "not given" values by identity.
    """
    values = _read_options(scope)
    if params is None and not overrides and all(map(operator.is_, values, _NOT_GIVEN_VALUES)):
        method = _method_name(method, stacklevel)
        base = defaults()
        _targets_given(base, vertices, max_error, {}, deviations, method)
        return base, method, False
    return resolve_call(params, method, vertices, max_error, dict(zip(OPTIONS, values, strict=True)),
                        overrides, stacklevel=stacklevel + 1, deviations=deviations)


def resolve_call(params, method, vertices, max_error, options: dict, overrides: dict, *,
                 stacklevel: int = 3, deviations=(None, None)) -> tuple[MeshParams, str, bool]:
    """The settings of a `triangulate` (or `mesh_stream`, `mesh_many`) call, checked.

    Parameters
    ----------
    params : MeshParams or None
        Deprecated spelling of the options.
    method, vertices, max_error
        As `triangulate` takes them.
    options : dict
        The keyword options of `OPTIONS`, each as given or its value when
        not given (`call_keywords`: None; ``'disparity'`` for ``flips``).
    overrides : dict
        Other keywords: ``workers`` (deprecated name of ``threads``); any
        other is a TypeError.
    stacklevel : int
        Where a deprecation warning points: the user's call.
    deviations : (float or None, float or None)
        ``(max_deviation, mean_deviation)`` as `triangulate` takes them.

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
    if params is None and not overrides and len(options) == len(_NOT_GIVEN) \
            and all(map(operator.is_, options.values(), _NOT_GIVEN.values())):
        # no option given (most calls): the defaults, built once (by identity: an array
        # option must not be compared with ==)
        base = defaults()
        _targets_given(base, vertices, max_error, {}, deviations, method)
        return base, method, False
    given = {k: v for k, v in options.items() if not _unset(k, v)}
    if overrides:
        _deprecated_workers(overrides, given, stacklevel)
    if params is None and given:
        message = misplaced_option(method, given)
        if message:
            raise ValueError(f"{message} (method is chosen by method= alone)")
    # checked under the names the call gave them (MeshParams calls threads workers)
    fields = {OPTIONS_BY_NAME[k].field: check_option(OPTIONS_BY_NAME[k], v, k)
              for k, v in given.items()}
    if params is None:
        params = _params_of(fields)
        _targets_given(params, vertices, max_error, fields, deviations, method)
        return params, method, "tiles" in fields
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
    _targets_given(params, vertices, max_error, fields, deviations, method)
    base = defaults()
    changed = [o.name for o in OPTION_TABLE
               if getattr(params, o.field) != getattr(base, o.field)
               and not (o.name == "threads" and method == "refine")  # refine ignored it
               and not (o.name == "heights" and params.heights == "pixel" and method == "paper")]
    message = misplaced_option(method, changed)
    if message:
        raise ValueError(message)
    return params, method, "tiles" in fields
