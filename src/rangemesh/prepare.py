"""Input checks and the background mask: the first line of every pipeline.

The background marker is turned into a boolean ``valid`` mask here and its
numeric value never travels further (SPEC P1).
"""

from __future__ import annotations

import math
import numbers
from decimal import Decimal

import numpy as np

from . import _core
from ._core import mask_image, valid_range
from .camera import Pinhole, Rays, Spherical
from .checks import kernel_array

__all__ = ["to_depth_and_mask", "check_image", "mask_into", "guess_background", "fill_gaps",
           "fill_gaps_inplace", "NONPOSITIVE"]

# `background` for "0 and below mark missing depth": what 'auto' means before a camera that
# measures distance (REP 118: depth is a distance in front of the camera).
NONPOSITIVE = "nonpositive"
# float64 and float32, native-endian: `kernel_array` passes them unchanged.
_KERNEL_DTYPES = (np.dtype(np.float64), np.dtype(np.float32))


def to_depth_and_mask(image, background=None, *, camera=None) -> tuple[np.ndarray, np.ndarray]:
    """Check a range image and split it into float depth and a validity mask.

    Parameters
    ----------
    image : (H, W) array_like of int or float
        The range image. Boolean and complex arrays are refused; the masked
        pixels of a `numpy.ma.MaskedArray` are missing depth.
    background : float, 'auto', 'nonpositive' or None, optional
        Value that marks pixels without depth (``0``, ``65535``, ...).
        ``'auto'`` (what `rangemesh.triangulate` and the command line use by
        default): with a `Pinhole`, `Spherical` or `Rays` camera every
        value of 0 or below (``'nonpositive'``), else 0 in integer images
        and nothing in float ones (`guess_background`). NaN, +inf and -inf
        always mark missing depth, whatever `background` says;
        ``background=float('nan')`` is the same as ``None``.
    camera : Orthographic, Pinhole, Spherical or Rays, optional
        The camera the image is meshed with: what ``'auto'`` means.

    Returns
    -------
    depth : (H, W) ndarray of float64
        A new C-contiguous array; background pixels hold 0.0, a value that no
        later stage reads.
    valid : (H, W) ndarray of bool

    Raises
    ------
    TypeError
        If the image is not numeric or `background` is not a number.
    ValueError
        If the image is not 2-D or is empty, `background` lies beyond the
        float range, or a ``longdouble`` image holds finite values beyond it.

    Examples
    --------
    >>> d, v = to_depth_and_mask(np.array([[0, 5], [7, 0]], np.uint16), background="auto")
    >>> v
    array([[False,  True],
           [ True, False]])
    """
    arr, background = check_image(image, background, camera=camera)
    depth = np.zeros(arr.shape, np.float64)
    valid = np.zeros(arr.shape, np.bool_)
    mask_into(arr, background, depth, valid)
    return depth, valid


def check_image(image, background=None, *, camera=None):
    """Check a range image and its background marker; copy only when a dtype needs it.

    Parameters
    ----------
    image : (H, W) array_like of int or float
        A masked array's masked pixels are missing depth. float16, wider
        floats and non-native byte orders are converted (see
        `rangemesh.checks.kernel_array`); other arrays are used as they are.
    background : float, 'auto', 'nonpositive' or None, optional
        ``'auto'`` is resolved by the camera and the image's dtype (`guess_background`).
    camera : optional
        The camera the image is meshed with.

    Returns
    -------
    arr : (H, W) ndarray
        The image in a dtype the kernels take; masked pixels hold NaN.
    background : float, 'nonpositive' or None
        None when only NaN/inf mark missing depth (``NaN`` is folded into None).

    Raises
    ------
    TypeError, ValueError
        As `to_depth_and_mask`.
    """
    mask = np.ma.getmaskarray(image) if np.ma.isMaskedArray(image) else None
    try:
        arr = np.asarray(np.ma.getdata(image) if mask is not None else image)
    except ValueError as exc:  # a ragged nested list
        raise ValueError(f"image must be a rectangular 2-D array of numbers ({exc})") from None
    dt = arr.dtype
    if dt.kind not in "iuf":  # (object arrays too: kind "O")
        raise TypeError(
            f"image must be an array of integers or floats, got dtype {arr.dtype}"
        )
    if arr.ndim != 2:
        hint = " (a colour image? pass one channel)" if arr.ndim == 3 else ""
        raise ValueError(f"image must be 2-D (rows, cols), got shape {arr.shape}{hint}")
    if arr.size == 0:
        raise ValueError(f"image must not be empty, got shape {arr.shape}")
    if isinstance(background, str):
        if background not in ("auto", NONPOSITIVE):
            raise TypeError(f"background must be a number, NaN, None, 'auto' or "
                            f"'{NONPOSITIVE}', got {background!r}")
        if background == "auto":  # by the dtype as given, before any conversion
            background = guess_background(arr, camera)
    if dt not in _KERNEL_DTYPES:  # (the dtypes the kernels take pass by identity: every call)
        wide = arr
        arr = kernel_array(arr)
        if arr.dtype.itemsize < wide.dtype.itemsize and arr.dtype.kind == "f":
            _check_narrowed(wide, arr, mask)
    if mask is not None and mask.any():
        # NaN is missing depth whatever the background is; the kernels compare
        # integers as float64, so the float64 copy changes no value they see
        arr = arr.astype(np.float64 if arr.dtype.kind in "iu" else arr.dtype)
        arr[mask] = np.nan
    if background is not None and not isinstance(background, str):
        if isinstance(background, (bool, np.bool_)) or not isinstance(background, numbers.Real):
            raise TypeError(f"background must be a number, NaN or None, got {background!r}")
        try:
            value = float(background)
        except OverflowError:  # a Python int or Fraction beyond float64
            value = math.inf
        infinite = isinstance(background, (float, np.floating)) and np.isinf(background)
        if math.isinf(value) and not infinite:
            raise ValueError(f"background={_short(background)} lies beyond the float range "
                             f"(float64, up to 1.8e+308): no pixel can hold it")
        if math.isnan(value):
            background = None
    return arr, background


def _short(x) -> str:
    """A number in a few digits, whatever its type (a 400-digit int, a long double)."""
    try:
        return format(Decimal(str(x)).normalize(), ".6g")
    except ArithmeticError:  # a Fraction's "p/q"
        return f"{str(x)[:20]}..."


def _check_narrowed(wide: np.ndarray, arr: np.ndarray, mask) -> None:
    """Refuse finite values that became infinite in the narrower float (else: missing, silently)."""
    lost = np.isfinite(wide) & ~np.isfinite(arr)
    if mask is not None:
        lost &= ~mask
    if lost.any():
        finite = wide[np.isfinite(wide) & (True if mask is None else ~mask)]
        raise ValueError(f"depths {_short(finite.min())} .. {_short(finite.max())}: their range "
                         f"exceeds the float range (float64, up to 1.8e+308); scale the image "
                         f"(and its camera) down")


def mask_into(arr: np.ndarray, background, depth: np.ndarray, valid: np.ndarray) -> None:
    """Write float depth (0.0 on background) and validity of a checked image into buffers."""
    below = isinstance(background, str)  # NONPOSITIVE: 0 here, the negative values below
    bg = 0.0 if background is None or below else float(background)
    mask_image(np.ascontiguousarray(arr), background is not None, bg, depth, valid)
    # (an unsigned image holds no negative value: no pass over it)
    if below and arr.dtype.kind != "u" and valid_range(depth, valid).lo < 0.0:
        negative = depth < 0.0
        valid[negative] = False
        depth[negative] = 0.0


def guess_background(image: np.ndarray, camera=None):
    """What marks missing depth, by the usual conventions.

    With a `Pinhole`, `Spherical` or `Rays` camera: every value of 0 or below
    (``'nonpositive'``), in integer and float images alike: a depth or range
    is a distance in front of the sensor (REP 118), and depth cameras and
    LiDARs write 0 for no return. Otherwise (heights, disparities, where 0 can
    be data): integer images 0 (depth PNGs, disparity maps and most scanners
    use it); float images only NaN and infinities.

    Parameters
    ----------
    image : (H, W) ndarray
    camera : optional
        The camera the image is meshed with (default: orthographic).

    Returns
    -------
    float, 'nonpositive' or None

    Examples
    --------
    >>> guess_background(np.zeros((2, 2), np.uint16)), guess_background(np.zeros((2, 2)))
    (0, None)
    >>> guess_background(np.zeros((2, 2)), Pinhole(500, 500, 1, 1))
    'nonpositive'
    """
    if isinstance(camera, (Pinhole, Spherical, Rays)):
        return NONPOSITIVE
    return 0 if image.dtype.kind in "iu" else None  # the kind, not np.issubdtype: every call


def fill_gaps(depth: np.ndarray, valid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Fill single-pixel holes: one pass, paper II.A.1, SPEC 1.1.

    A background pixel whose 8 neighbours all exist and are valid becomes valid
    with the mean of those 8 depths. Pixels on the image border have fewer
    than 8 neighbours and are never filled. Larger holes stay holes.

    Parameters
    ----------
    depth : (H, W) ndarray of float64
        The depths; a background pixel's value is not read.
    valid : (H, W) ndarray of bool
        The pixels that hold data.

    Returns
    -------
    depth_filled : (H, W) ndarray of float64
        A new array; background pixels that stay background hold 0.
    valid_filled : (H, W) ndarray of bool

    Examples
    --------
    >>> d = np.arange(9.0).reshape(3, 3); v = np.ones((3, 3), bool); v[1, 1] = False
    >>> float(fill_gaps(d, v)[0][1, 1])
    4.0
    """
    out_d = np.where(valid, depth, 0.0).astype(np.float64, order="C", copy=False)
    out_v = np.array(valid, dtype=np.bool_, order="C", copy=True)
    _core.fill_gaps_inplace(out_d, out_v)
    return out_d, out_v


def fill_gaps_inplace(depth: np.ndarray, valid: np.ndarray) -> None:
    """`fill_gaps` on our own C-contiguous float64/bool buffers, in place (no copies)."""
    _core.fill_gaps_inplace(depth, valid)
