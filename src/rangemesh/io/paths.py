"""What every reader and writer asks of a path, and says of an error.

A path's suffix, a readable file (not a folder or a pipe), an error's first line.
"""

from __future__ import annotations

from pathlib import Path


def _suffix(path: Path) -> str:
    return path.suffix.lower()


def _check_readable(path: Path) -> None:
    """A regular file (or a link to one); a folder or a missing path is said so."""
    if path.is_dir():
        raise ValueError(f"{path}: is a folder, not a file")
    if path.exists() and not path.is_file():
        raise ValueError(f"{path}: is not a regular file (a pipe or a device?)")
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__
