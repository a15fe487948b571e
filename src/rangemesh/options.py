"""One declaration per option: what each meshing option is, and what is made from it.

An option is declared once, as a field of `rangemesh.MeshParams` made by
`option` (the pattern of ``dataclasses.fields()`` with ``metadata``). Its
`Option` record says which method reads it, what it takes, how it is checked,
its documentation and its command-line flag; from the records come:

* the checks of `MeshParams` and of every call (`check_option`);
* which method takes which option (`rangemesh.params.OPTION_METHOD`) and the
  message for an option of the other method (`rangemesh.params.misplaced_option`);
* the forwarding of `rangemesh.mesh_stream`, `rangemesh.mesh_many` and
  `rangemesh.mesh_bag`'s ``**options`` (`split_options`);
* the option paragraphs of `rangemesh.triangulate`'s and `MeshParams`'
  docstrings (`option_docs`) and the table of ``docs/options.md`` (`markdown_table`);
* the flags of ``rangemesh mesh``, ``demo`` and ``batch`` (`rangemesh.cli.options`).

``docs/options.md`` says how to add one.
"""

from __future__ import annotations

import dataclasses
import math
import textwrap
from collections.abc import Callable
from dataclasses import dataclass

from .checks import flag, real_number, whole_number, whole_pair

__all__ = ["Option", "Flag", "option", "options_of", "check_option", "split_options",
           "option_docs", "markdown_table", "BOTH"]

BOTH = ("refine", "paper")


@dataclass(frozen=True)
class Flag:
    """How the command line spells an option.

    Attributes
    ----------
    help : str
        The flag's help; ``{default}`` is replaced by the option's default.
    parse : {'int', 'float', 'pair', 'limits', 'flips', 'choice', 'off', 'on_off'}
        How the text is read (`rangemesh.cli.options` holds the parsers): ``'choice'``
        one of the option's `choices`; ``'off'`` a ``--no-NAME`` switch that
        gives False; ``'on_off'`` ``--NAME`` (True) and ``--no-NAME`` (False).
    metavar : str, optional
    """

    help: str
    parse: str = "float"
    metavar: str | None = None


@dataclass(frozen=True)
class Option:
    """One meshing option (the metadata of its `MeshParams` field).

    Attributes
    ----------
    name : str
        Its keyword in `rangemesh.triangulate` (the field's name unless said).
    field : str
        Its `MeshParams` field.
    methods : tuple of str
        The methods that read it: ``('refine',)``, ``('paper',)`` or both.
    default : object
        The field's default.
    type : str
        The numpydoc type, ``{'fit', 'pixel'}`` or ``float``.
    doc : str
        What it does (one paragraph; the method it goes with is added).
    check : callable
        ``check(name, value) -> value``: the value checked and normalised;
        ValueError or TypeError naming `name` in one line.
    flag : Flag or None
        Its command-line flag (None: none).
    choices : tuple or None
        The closed set of a string option, for the flag.
    none_is_value : bool
        None is a setting of its own (``flips=None``: no flips), so not
        giving the option is its default rather than None; ``'none'`` is
        taken for None in calls and on the command line.
    none_means : object
        What None stands for in the method that reads the option, when None
        is "the method's default" (``heights`` None is ``'fit'``); None when
        it is no setting of that kind. `rangemesh.params.NONE_MEANS` is the
        table of them, which the pipeline resolves from.
    """

    name: str
    field: str
    methods: tuple
    default: object
    type: str
    doc: str
    check: Callable
    flag: Flag | None = None
    choices: tuple | None = None
    none_is_value: bool = False
    none_means: object = None

    @property
    def unset(self):
        """What a call's keyword holds when the option is not given."""
        return self.default if self.none_is_value else None

    @property
    def cli(self) -> str:
        """The flag as messages write it (``--max-edge``, ``--no-walls``)."""
        dashed = self.name.replace("_", "-")
        if self.flag is not None and self.flag.parse == "off":
            return f"--no-{dashed}"
        return f"--{dashed}"


def option(default, *, methods, type: str, doc: str, check: Callable, name: str | None = None,
           flag: Flag | None = None, choices: tuple | None = None,
           none_is_value: bool = False, none_means=None):
    """A `MeshParams` field declaring an option (see `Option` for the arguments).

    Returns
    -------
    dataclasses.Field
        With the option's record in ``metadata['option']`` (its `name` and
        `field` are filled in by `options_of`).
    """
    record = Option(name or "", "", tuple(methods), default, type, doc, check, flag, choices,
                    none_is_value, none_means)
    return dataclasses.field(default=default, metadata={"option": record})


def options_of(cls) -> tuple[Option, ...]:
    """The `Option` records of a dataclass's option fields, in field order."""
    out = []
    for f in dataclasses.fields(cls):
        rec = f.metadata.get("option")
        if rec is not None:
            out.append(dataclasses.replace(rec, name=rec.name or f.name, field=f.name))
    return tuple(out)


# ------------------------------------------------------------------ checks


def choice(choices: tuple) -> Callable:
    """A check that the value is one of `choices` (strings, or None)."""
    def check(name, value):
        if not (value is None or isinstance(value, str)) or value not in choices:
            raise ValueError(f"{name} must be one of {choices}, got {value!r}")
        return value
    return check


def boolean_or_none(name, value):
    """True, False (as `rangemesh.checks.flag` takes them) or None."""
    return None if value is None else flag(name, value)


def whole(minimum: int) -> Callable:
    def check(name, value):
        if type(value) is int and value >= minimum:  # the common case, without ABC lookups
            return value
        return whole_number(name, value, minimum=minimum)
    return check


def pair(minimum: int, why: str = "") -> Callable:
    """A check of ``n`` or ``(n, m)``, each at least `minimum` (`why` says why, if given)."""
    def check(name, value):
        if not why:
            return whole_pair(name, value, minimum=minimum)
        out = whole_pair(name, value)
        if min(out) < minimum:
            raise ValueError(f"{name} must be >= {minimum} in both directions ({why}), got {out}")
        return out
    return check


def degrees(low_open: bool) -> Callable:
    """A check of an angle in ``(0, 180]`` (`low_open`) or ``[0, 180]`` degrees."""
    def check(name, value):
        x = real_number(name, value)
        if not ((0.0 < x) if low_open else (0.0 <= x)) or x > 180.0:
            span = "(0, 180]" if low_open else "[0, 180]"
            raise ValueError(f"{name} must be in {span} degrees, got {x}")
        return x
    return check


def above(bound: float, message: str) -> Callable:
    """A check of a finite number above `bound`; `message` says what it must be."""
    def check(name, value):
        x = real_number(name, value)
        if not x > bound:
            raise ValueError(f"{name} must be {message}, got {value!r}")
        return x
    return check


def number_or_none(name, value):
    """Any number but NaN (infinities too), or None."""
    if value is None:
        return None
    x = real_number(name, value, finite=False)
    if math.isnan(x):
        raise ValueError(f"{name} must be a number or None, got nan")
    return x


def edge_or_none(name, value):
    """None, or a length of at least 1.5 pixels."""
    if value is None:
        return None
    e = real_number(name, value, finite=False)
    if not math.isfinite(e) or e < 1.5:
        raise ValueError(f"{name} must be at least 1.5 pixels (a pixel's diagonal is 1.41), "
                         f"got {value!r}")
    return e


def whole_or_none(minimum: int) -> Callable:
    """None, or a whole number of at least `minimum`."""
    def check(name, value):
        return None if value is None else whole_number(name, value, minimum=minimum)
    return check


def limits_or_none(name, value):
    """None, or ``(near, far)`` with near < far (None on a side: no limit there).

    Examples
    --------
    >>> limits_or_none("depth_limits", (0.5, None))
    (0.5, inf)
    """
    if value is None:
        return None
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 2:
        raise TypeError(f"{name} must be (near, far), two numbers (None: no limit), "
                        f"got {value!r}")
    near = -math.inf if value[0] is None else real_number(name, value[0], finite=False)
    far = math.inf if value[1] is None else real_number(name, value[1], finite=False)
    if math.isnan(near) or math.isnan(far) or not near < far:
        raise ValueError(f"{name} must be (near, far) with near < far, got {value!r}")
    return float(near), float(far)


def check_option(opt: Option, value, name: str | None = None):
    """`value` of `opt` checked (``'none'`` read as None where None is a setting)."""
    if opt.none_is_value and isinstance(value, str) and value.lower() == "none":
        value = None
    return opt.check(name or opt.name, value)


# ------------------------------------------------------------------ calls


def split_options(table: tuple[Option, ...], given: dict) -> tuple[dict, dict]:
    """A call's ``**options`` as ``(options, rest)``: every option (its unset value if not given).

    `rest` holds the keywords that are no option (`rangemesh.pipeline.resolve_call`
    refuses them, or takes a deprecated name).
    """
    options = {o.name: given.get(o.name, o.unset) for o in table}
    rest = {k: v for k, v in given.items() if k not in options}
    return options, rest


# ------------------------------------------------------------------ documentation


def _method_note(opt: Option) -> str:
    if opt.methods == BOTH:
        return "Both methods."
    return " and ".join(f"``{m!r}``" for m in opt.methods) + " only."


def _shown(value) -> str:
    return repr(value)


def option_docs(table: tuple[Option, ...], *, style: str = "call", indent: int = 4) -> str:
    """Numpydoc entries of the options: for a call (``style='call'``) or `MeshParams` (``'params'``).

    A call's entries are named by the option and say ``optional`` (its
    default is the method's); `MeshParams`' by the field with its default.
    """
    pad = " " * indent
    lines = []
    for o in table:
        if style == "call":
            head = f"{o.name} : {o.type}, " + (f"default {_shown(o.default)}" if o.none_is_value
                                               else "optional")
        else:
            head = f"{o.field} : {o.type}, default {_shown(o.default)}"
        lines.append(pad + head)
        body = f"{_method_note(o)} {o.doc}"
        lines += textwrap.wrap(body, 76 - indent, initial_indent=pad + "    ",
                               subsequent_indent=pad + "    ", break_on_hyphens=False)
    return "\n".join(lines)


def markdown_table(table: tuple[Option, ...]) -> str:
    """The option table of ``docs/options.md``: keyword, methods, default, flag, doc."""
    rows = ["| option | methods | default | flag | what it does |", "|---|---|---|---|---|"]
    for o in table:
        doc = o.doc.replace("|", "\\|").replace("\n", " ")
        flag_text = f"`{o.cli}`" if o.flag is not None else ""
        if o.flag is not None and o.flag.parse == "on_off":
            flag_text = f"`--{o.name.replace('_', '-')}` / `--no-{o.name.replace('_', '-')}`"
        rows.append(f"| `{o.name}` | {', '.join(o.methods)} | `{o.default!r}` | {flag_text} "
                    f"| {doc} |")
    return "\n".join(rows)

