"""Whole-array NumPy steps a block at a time, so that Ctrl-C is seen between blocks.

Python runs its SIGINT handler only between bytecodes: one NumPy call on an
8000 x 8000 image (a fill of 512 MB takes 1 s on a loaded machine), or on
the millions of faces of its meshes, keeps Ctrl-C waiting until it ends. Cut
into blocks of `BLOCK` elements, each step takes a millisecond or two, and the
results are the same element for element. On small arrays there is one block,
and the cost is a loop of one turn.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["BLOCK", "blocks", "astype", "filled", "take", "concat"]

# Elements a step works on at a time: a few MB, a millisecond or two.
BLOCK = 1 << 20


def blocks(n: int, per: int = 1):
    """Slices of ``range(n)`` of about ``BLOCK / per`` items each (`per` elements an item).

    At least one slice, empty when `n` is 0.

    Examples
    --------
    >>> list(blocks(5))
    [slice(0, 5, None)]
    >>> [s.stop for s in blocks(3 * BLOCK, per=2)][:2]
    [524288, 1048576]
    """
    step = max(BLOCK // max(int(per), 1), 1)
    return (slice(lo, min(lo + step, n)) for lo in range(0, max(n, 1), step))


def _rows(a: np.ndarray):
    """`blocks` over the first axis of `a`."""
    return blocks(len(a), per=a[:1].size or 1)


def astype(a: np.ndarray, dtype) -> np.ndarray:
    """``a.astype(dtype)`` (C order), a block of rows at a time.

    Examples
    --------
    >>> astype(np.arange(6).reshape(3, 2), np.int32).dtype
    dtype('int32')
    """
    out = np.empty(a.shape, dtype)
    for b in _rows(a):
        out[b] = a[b]
    return out


def filled(shape, value, dtype=np.float64) -> np.ndarray:
    """``np.full(shape, value, dtype)``, a block of rows at a time."""
    if math.prod(shape) <= BLOCK:
        return np.full(shape, value, dtype)
    out = np.empty(shape, dtype)
    for b in _rows(out):
        out[b] = value
    return out


def take(table: np.ndarray, index: np.ndarray) -> np.ndarray:
    """``table[index]`` (an integer `index` array), a block of `index` at a time."""
    out = np.empty(index.shape + table.shape[1:], table.dtype)
    for b in _rows(index):
        out[b] = table[index[b]]
    return out


def concat(parts) -> np.ndarray:
    """``np.concatenate(parts)`` along the first axis, a block at a time."""
    parts = [np.asarray(p) for p in parts]
    out = np.empty((sum(len(p) for p in parts),) + parts[0].shape[1:],
                   np.result_type(*parts))
    at = 0
    for p in parts:
        for b in _rows(p):
            out[at + b.start:at + b.stop] = p[b]
        at += len(p)
    return out
