"""The readers of range-image files, one a format; `rangemesh.io.formats` registers them.

NumPy, TIFF, PNG and Netpbm through Pillow, organised ``.pcd`` clouds.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from .headers import PNG_SIGNATURE, _image_header, check_pillow_size, pillow_quiet
from .paths import _first_line, _suffix


def _read_pcd_z(path: Path) -> np.ndarray:
    try:
        from pypcd4 import PointCloud
    except ImportError:  # an optional extra: say how to get it
        raise ValueError(
            f"{path}: reading .pcd files needs pypcd4 (pip install 'rangemesh[pcd]')"
        ) from None
    pc = PointCloud.from_path(path)
    if "z" not in pc.fields:
        raise ValueError(f"{path}: the point cloud has no 'z' field (fields: {pc.fields})")
    h, w = int(pc.metadata.height), int(pc.metadata.width)
    if h <= 1:
        raise ValueError(f"{path}: the point cloud is not organised (height {h}); no image to mesh")
    return pc.numpy(("z",)).reshape(h, w)


def _undecodable(path: Path, exc: BaseException) -> ValueError:
    """Why an image file cannot be decoded, named by its format, not by the reader's plumbing.

    imageio's words for bytes no Pillow plugin recognises ("`pillow` can not
    handle the given uri") say nothing of the file; a PNG without its
    signature is said so.
    """
    kind = _suffix(path)[1:].upper() or "image"
    a = "an" if kind[0] in "AEIOUi" else "a"
    try:
        with open(path, "rb") as fh:
            head = fh.read(8)
    except OSError:
        head = b""
    if kind == "PNG" and head != PNG_SIGNATURE:
        return ValueError(f"{path}: cannot be decoded as a PNG file: it does not start with the "
                          f"PNG signature (not a PNG file, or damaged at its start)")
    cause = _first_line(exc)
    if any(s in cause for s in ("can not handle", "cannot identify", "Could not find a backend")):
        return ValueError(f"{path}: cannot be decoded as {a} {kind} file: Pillow recognises "
                          f"no image format in its bytes (not {a} {kind} file, or damaged)")
    return ValueError(f"{path}: cannot be decoded as {a} {kind} file ({type(exc).__name__}: {cause})")


def _read_npy(path: Path) -> np.ndarray:
    return np.load(path, allow_pickle=False)


def _read_tiff(path: Path) -> np.ndarray:
    import tifffile

    # tifffile logs damage (a truncated file) before failing; the error says it once
    log = logging.getLogger("tifffile")
    level = log.level
    log.setLevel(logging.CRITICAL)
    try:
        return tifffile.imread(path)
    finally:
        log.setLevel(level)


def _read_pillow(path: Path) -> np.ndarray:
    """PNG and Netpbm images through imageio's Pillow plugin, their size checked from the header."""
    import imageio.v3 as iio

    header = _image_header(path)  # size from the header: a lie is said before decoding
    if header is not None:
        if header[2]:
            raise ValueError(f"{path}: {header[2]}")
        check_pillow_size(str(path), header[0], header[1])
    try:
        with pillow_quiet():
            return iio.imread(path, plugin="pillow")  # no probing of other plugins
    except Exception as exc:
        raise _undecodable(path, exc) from None
