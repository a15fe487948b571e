"""Depth files paired with their colour images, for coloured folder batches (`rangemesh.mesh_many`).

Two ways, as RGB-D data sets lay them out:

* a pattern (``--color-pattern``): ``rgb/{stem}.png`` names each depth file's
  colour image from the depth file's ``{stem}`` (name without suffix),
  ``{name}`` (with it) and ``{dir}`` (its folder); a relative result is taken
  from the current folder, as a shell would.
* an association list (``--associations``), as TUM RGB-D's ``associate.py``
  writes it: ``stamp path stamp path`` a line, ``#`` comments, paths relative
  to the list's folder. The path under a ``depth`` folder (or named so) is the
  depth; when the names do not tell, the first path is (``stamp depth stamp rgb``).
"""

from __future__ import annotations

import hashlib
import os
import string
from pathlib import Path

__all__ = ["color_for", "read_associations", "colors_record", "PATTERN_FIELDS"]

PATTERN_FIELDS = ("stem", "name", "dir")
MAX_LIST_BYTES = 64 << 20  # a list of a day's frames is some MB; refuse to read anything huge


def check_pattern(pattern: str) -> str:
    """A colour pattern checked: it names at least one of `PATTERN_FIELDS` and no other field.

    Raises
    ------
    ValueError
        A malformed pattern, or one naming no field or an unknown one.
    """
    if not isinstance(pattern, str):
        raise TypeError(f"colors must be a pattern string or a mapping, got {type(pattern).__name__}")
    try:
        fields = [f for _, f, _, _ in string.Formatter().parse(pattern) if f is not None]
    except ValueError as exc:
        raise ValueError(f"colors pattern {pattern!r}: {exc}") from None
    unknown = [f for f in fields if f not in PATTERN_FIELDS]
    if unknown or not fields:
        raise ValueError(f"colors pattern {pattern!r} must name the depth file by "
                         f"{', '.join('{' + f + '}' for f in PATTERN_FIELDS)}"
                         + (f", not {{{unknown[0]}}}" if unknown else ""))
    return pattern


def color_for(depth: Path, colors) -> Path | None:
    """The colour image of `depth`: by the pattern, or looked up in a mapping (None if it has none)."""
    if isinstance(colors, str):
        return Path(colors.format(stem=depth.stem, name=depth.name, dir=str(depth.parent))).absolute()
    found = colors.get(str(Path(depth).absolute()))
    return None if found is None else Path(found)


def _is_depth(path: str) -> bool:
    p = Path(path)
    return "depth" in p.parent.name.lower() or "depth" in p.name.lower()


def read_associations(path: str | os.PathLike) -> list[tuple[Path, Path]]:
    """``(depth, colour)`` absolute paths of a TUM-style association list, in its order.

    Raises
    ------
    ValueError
        A file that cannot be read, or a line that is not ``stamp path stamp path``
        (its number named).
    """
    path = Path(path)
    try:
        if path.stat().st_size > MAX_LIST_BYTES:
            raise OSError(f"{path.stat().st_size} bytes is too large for an association list")
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path}: cannot read it as an association list "
                         f"({getattr(exc, 'strerror', None) or exc})") from None
    base = path.parent.absolute()
    pairs = []
    for n, line in enumerate(text.splitlines(), start=1):
        words = line.split()
        if not words or words[0].startswith("#"):
            continue
        if len(words) != 4:
            raise ValueError(f"{path}: line {n} is not 'stamp path stamp path' ({len(words)} "
                             f"fields)")
        try:
            float(words[0]), float(words[2])
        except ValueError:
            raise ValueError(f"{path}: line {n} has no stamps in fields 1 and 3") from None
        a, b = words[1], words[3]
        depth, color = (b, a) if _is_depth(b) and not _is_depth(a) else (a, b)
        pairs.append((base / depth, base / color))
    if not pairs:
        raise ValueError(f"{path}: the association list names no pair")
    return pairs


def colors_record(colors) -> str | None:
    """How a batch's colours were chosen, for its record of options: the pattern, or a digest."""
    if colors is None or isinstance(colors, str):
        return colors
    pairs = "\n".join(f"{k}\t{v}" for k, v in sorted(colors.items()))
    return "pairs sha256:" + hashlib.sha256(pairs.encode()).hexdigest()[:16]
