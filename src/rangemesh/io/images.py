"""Reading range images (by suffix, through `FORMATS`) and colour images."""

from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from .formats import _readable_format
from .headers import pillow_quiet
from .image_readers import _undecodable
from .paths import _check_readable, _first_line, _suffix


class NotDepthImage(ValueError):
    """An image of several channels (a colour image, a preview): no range image at all."""


@contextmanager
def _reading(path: Path, what: str):
    """A reader's errors as one ValueError naming `path` and `what` it was read as.

    Our own messages, which start with the path, pass as they are; readers
    raise OSError, SyntaxError, struct.error, pydantic's... on bad files.
    """
    try:
        yield
    except ValueError as exc:
        if str(exc).startswith(str(path)):
            raise
        raise ValueError(f"{path}: cannot read it as {what} ({_first_line(exc)})") from None
    except Exception as exc:
        raise ValueError(f"{path}: cannot read it as {what} "
                         f"({type(exc).__name__}: {_first_line(exc)})") from None


def read_range_image(path: str | os.PathLike) -> np.ndarray:
    """Read a range image as a 2-D array, values exactly as stored.

    Parameters
    ----------
    path : str or os.PathLike
        ``.npy``, ``.png``, ``.pgm``/``.ppm``/``.pnm`` (ASCII or binary, 8 or
        16 bit), ``.pfm``, ``.tif``/``.tiff`` (integer or float) or ``.pcd``
        (organised cloud: its ``z`` field, NaN where there is no point).

    Returns
    -------
    (H, W) ndarray
        Integer or float values as stored in the file; no unit conversion.

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    ValueError
        If the suffix is unknown, the file cannot be decoded (truncated or
        not an image), or it does not hold one 2-D channel.

    Notes
    -----
    Missing depth stays as the file stores it: 0 in integer images (depth
    PNGs, disparity maps), NaN in float ones. `rangemesh.triangulate` and the
    other entry points read it so by default (``background='auto'``: 0 in
    integer images, NaN/inf always); give ``background=`` for another marker.

    PGM files whose 16-bit payload is little-endian (against the format,
    as NYU Depth v2's raw frames are) cannot be told apart from correct files;
    they read byte-swapped, as in every standard reader.
    """
    path = Path(path)
    fmt = _readable_format(path, "image", "image type")
    with _reading(path, "a range image"):
        arr = fmt.read(path)
    arr = np.asarray(arr)
    if arr.size == 0:
        raise ValueError(f"{path}: the file holds no pixel (empty or truncated)")
    if arr.ndim == 3 and arr.shape[2] in (1,):
        arr = arr[:, :, 0]
    if arr.ndim == 3 and arr.shape[2] > 1:
        raise NotDepthImage(f"{path}: a range image has one channel; this file holds "
                            f"{arr.shape[2]} channels of {arr.dtype} (a colour image?)")
    if arr.ndim != 2:
        raise ValueError(f"{path}: a range image has one channel; this file holds an array of shape "
                         f"{arr.shape}")
    return arr


def read_color_image(path: str | os.PathLike) -> np.ndarray:
    """Read a colour (or intensity) image: ``.npy``, or PNG, JPEG, TIFF... through imageio.

    Returns
    -------
    (H, W) or (H, W, C) ndarray, values as stored.

    Raises
    ------
    FileNotFoundError, ValueError
    """
    path = Path(path)
    _check_readable(path)
    with _reading(path, "an image"):
        if _suffix(path) == ".npy":
            arr = np.load(path, allow_pickle=False)
        else:
            import imageio.v3 as iio

            try:  # our own handle: imageio leaves its file open when no plugin can read it
                with pillow_quiet(), open(path, "rb") as fh:
                    arr = iio.imread(fh, extension=_suffix(path) or None)
            except Exception as exc:
                raise _undecodable(path, exc) from None
    arr = np.asarray(arr)
    if arr.ndim not in (2, 3) or arr.size == 0:
        raise ValueError(f"{path}: not an image (array of shape {arr.shape})")
    return arr
