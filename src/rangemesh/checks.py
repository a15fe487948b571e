"""Checks of what users hand in: numbers, flags, pairs and arrays.

One place for the rules, so that every parameter of the library is checked
the same way and every message names the parameter it is about:

* a wrong *type* (a string for a count, ``None`` for a number, a bool for a
  count) raises `TypeError`;
* a value of the right type that is out of range raises `ValueError`.

Strings are never taken apart or read as numbers or truth values here:
``tiles='44'`` is refused, not read as ``(4, 4)``, and ``fill_gaps='no'``
is refused, not read as True. NumPy scalars count as numbers.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

__all__ = ["whole_number", "real_number", "flag", "whole_pair", "kernel_array"]


def _show(value) -> str:
    return f"{value!r} ({type(value).__name__})"


def real_number(name: str, value, *, finite: bool = True) -> float:
    """`value` as a Python float, or an error naming `name`.

    Parameters
    ----------
    name : str
        The parameter's name, for the message.
    value : int, float or NumPy real scalar
    finite : bool, default True
        Also refuse NaN and infinities.

    Raises
    ------
    TypeError
        If `value` is not a real number (bools and strings are not).
    ValueError
        If `finite` and the value is NaN or infinite.

    Examples
    --------
    >>> real_number("delta", np.float32(2.5))
    2.5
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a number, got {_show(value)}")
    out = float(value)
    if finite and not math.isfinite(out):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return out


def whole_number(name: str, value, *, minimum: int | None = None) -> int:
    """`value` as a Python int, or an error naming `name`.

    Integers of any kind (Python, NumPy) are taken, and so are floats with a
    whole value (``3.0``, ``np.float64(3)``).

    Raises
    ------
    TypeError
        If `value` is not a real number (bools and strings are not).
    ValueError
        If it is not whole, or below `minimum`.

    Examples
    --------
    >>> whole_number("tiles", np.int64(3)), whole_number("tiles", 4.0)
    (3, 4)
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a whole number, got {_show(value)}")
    if isinstance(value, numbers.Integral):
        out = int(value)
    else:
        x = float(value)
        if not x.is_integer():  # also NaN and inf
            raise ValueError(f"{name} must be a whole number, got {value!r}")
        out = int(x)
    if minimum is not None and out < minimum:
        raise ValueError(f"{name} must be a whole number >= {minimum}, got {value!r}")
    return out


def flag(name: str, value) -> bool:
    """`value` as a bool: True, False, NumPy bools, and the integers 0 and 1.

    Raises
    ------
    TypeError
        For anything else, strings included (``'no'`` is not False).
    """
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, numbers.Integral) and int(value) in (0, 1):
        return bool(value)
    raise TypeError(f"{name} must be True or False, got {_show(value)}")


def whole_pair(name: str, value, *, minimum: int | None = None) -> tuple[int, int]:
    """``n`` or ``(n, m)`` as a pair of Python ints, or an error naming `name`.

    Raises
    ------
    TypeError
        If `value` is neither a whole number nor a sequence of two (strings
        are refused whole: ``'44'`` is not ``(4, 4)``).
    ValueError
        If a member is not whole or is below `minimum`.

    Examples
    --------
    >>> whole_pair("tiles", 4), whole_pair("samples", (np.int32(10), 8.0))
    ((4, 4), (10, 8))
    """
    if isinstance(value, (str, bytes)):
        raise TypeError(f"{name} must be a whole number or a pair of them, got {_show(value)}")
    if isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_)):
        n = whole_number(name, value, minimum=minimum)
        return n, n
    try:
        members = list(value)
    except TypeError:
        raise TypeError(
            f"{name} must be a whole number or a pair of them, got {_show(value)}"
        ) from None
    if len(members) != 2:
        raise TypeError(f"{name} must be a whole number or a pair of them, got {value!r}")
    a, b = (whole_number(name, m, minimum=minimum) for m in members)
    return a, b


# dtypes the compiled kernels take as stored (no conversion, no copy)
_KERNEL_KINDS = "iuf"
_NATIVE_FLOATS = (np.dtype(np.float32), np.dtype(np.float64))


def kernel_array(arr: np.ndarray) -> np.ndarray:
    """A numeric array in a dtype the kernels take, converting only when needed.

    Native-endian integers, float32 and float64 pass unchanged (no copy).
    float16 becomes float32 and wider floats (``longdouble``) become float64;
    values beyond float64's range become infinite (`rangemesh.prepare.check_image`
    refuses finite ones that do). Other byte orders are swapped to the native
    one. Values are never changed otherwise.

    Parameters
    ----------
    arr : ndarray of int or float

    Returns
    -------
    ndarray
    """
    dt = arr.dtype
    if dt.kind not in _KERNEL_KINDS:
        raise TypeError(f"expected an array of integers or floats, got dtype {dt}")
    if dt.kind == "f" and dt.newbyteorder("=") not in _NATIVE_FLOATS:
        target = np.float32 if dt.itemsize < 4 else np.float64
        with np.errstate(over="ignore"):  # longdouble beyond float64: inf (check_image refuses)
            return arr.astype(target)
    if not dt.isnative:
        return arr.astype(dt.newbyteorder("="))
    return arr
