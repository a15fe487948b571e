"""Depth and colour images out of ROS messages: ``sensor_msgs/Image`` and ``CompressedImage``.

A message is first taken apart into a `Payload` (its encoding or format,
size and bytes): small, picklable, and decoded wherever the meshing happens
(a Dask worker), so the process that reads the recording only copies bytes.

Depth, as REP 118 has it: ``16UC1`` (and ``mono16``, the same bytes) in
millimetres, ``32FC1`` in metres; 0, and NaN in float images, is missing
depth. ``compressedDepth`` is image_transport_plugins' format: a 12-byte
header (int32 format, float32 ``depthQuantA``, ``depthQuantB``), then a PNG
holding 16UC1 depth as it is, or 32FC1 depth as quantised inverse depth
``q = A / depth + B`` (0: missing), read back as ``depth = A / (q - B)``.
"""

from __future__ import annotations

import io
import struct
from dataclasses import dataclass

import numpy as np

from ..io.headers import PNG_SIGNATURE, PngHeader, check_pillow_size, pillow_quiet, png_header

__all__ = ["Payload", "DEPTH_SCALES", "COLOR_ENCODINGS", "payload_of", "is_depth",
           "depth_shape", "depth_image", "color_image"]

# encoding -> metres per stored value
DEPTH_SCALES = {"16UC1": 0.001, "mono16": 0.001, "32FC1": 1.0}
COLOR_ENCODINGS = ("rgb8", "bgr8", "rgba8", "bgra8", "mono8")
_DTYPES = {"16UC1": "u2", "mono16": "u2", "32FC1": "f4", "rgb8": "u1", "bgr8": "u1",
           "rgba8": "u1", "bgra8": "u1", "mono8": "u1"}
_CHANNELS = {"rgb8": 3, "bgr8": 3, "rgba8": 4, "bgra8": 4}
COMPRESSED_DEPTH_HEADER = 12


@dataclass(frozen=True)
class Payload:
    """An image message's content, not decoded.

    Attributes
    ----------
    compressed : bool
        A ``CompressedImage`` (then `encoding` is its ``format`` field and
        the size is unknown until decoded: 0).
    encoding : str
    height, width, step : int
    bigendian : bool
    data : bytes
    """

    compressed: bool
    encoding: str
    height: int
    width: int
    step: int
    bigendian: bool
    data: bytes

    @property
    def depth_encoding(self) -> str:
        """The depth encoding: the Image's, or the first word of a compressedDepth format."""
        return self.encoding.split(";")[0].strip() if self.compressed else self.encoding

    def describe(self) -> str:
        """The encoding as a user knows it: ``16UC1`` or ``32FC1; compressedDepth png``."""
        return self.encoding


def payload_of(msg) -> Payload:
    """The `Payload` of a deserialised ``sensor_msgs/Image`` or ``CompressedImage``."""
    data = bytes(memoryview(np.ascontiguousarray(msg.data, np.uint8)))
    if hasattr(msg, "format"):
        return Payload(True, str(msg.format), 0, 0, 0, False, data)
    return Payload(False, str(msg.encoding), int(msg.height), int(msg.width), int(msg.step),
                   bool(msg.is_bigendian), data)


def is_depth(payload: Payload) -> bool:
    """Whether the message holds depth this module decodes (by its encoding alone)."""
    if payload.compressed:
        return "compresseddepth" in payload.encoding.lower() \
            and payload.depth_encoding in ("16UC1", "32FC1")
    return payload.encoding in DEPTH_SCALES


def _raw_layout(payload: Payload, what: str) -> tuple[np.dtype, int, int]:
    """``(dtype, channels, row bytes)`` of an Image message whose size its step and data hold.

    Raises
    ------
    ValueError
        A height or width below 1, a step shorter than a row, or too little data: not an image.
    """
    enc = payload.encoding
    dt = np.dtype(_DTYPES[enc]).newbyteorder(">" if payload.bigendian else "<")
    ch = _CHANNELS.get(enc, 1)
    h, w, step = payload.height, payload.width, payload.step
    row = w * ch * dt.itemsize
    if h < 1 or w < 1 or step < row:
        raise ValueError(f"{what}: a {enc} image of {h}x{w} pixels with a row step of {step} "
                         f"bytes is not an image")
    if len(payload.data) < h * step - (step - row):
        raise ValueError(f"{what}: a {h}x{w} {enc} image needs {h * step} bytes, the message "
                         f"holds {len(payload.data)} (truncated): not an image")
    return dt, ch, row


def _raw(payload: Payload, what: str) -> np.ndarray:
    """The pixels of an Image message as an (H, W[, C]) array, rows cut to `step`."""
    dt, ch, row = _raw_layout(payload, what)
    h, w, step = payload.height, payload.width, payload.step
    buf = np.frombuffer(payload.data, np.uint8, count=min(len(payload.data), h * step))
    if len(buf) < h * step:  # the last row may end without its padding
        buf = np.concatenate([buf, np.zeros(h * step - len(buf), np.uint8)])
    rows = buf.reshape(h, step)[:, :row]
    arr = np.ascontiguousarray(rows).view(dt).reshape((h, w, ch) if ch > 1 else (h, w))
    return arr.astype(dt.newbyteorder("="), copy=False)


def _png(data: bytes, what: str, header: PngHeader) -> np.ndarray:
    import imageio.v3 as iio

    check_pillow_size(what, header.height, header.width)
    try:
        with pillow_quiet():  # its size was read from its header and checked first
            return np.asarray(iio.imread(io.BytesIO(data), extension=".png", plugin="pillow"))
    except Exception as exc:  # Pillow raises many kinds of errors on damaged data
        raise ValueError(f"{what}: the PNG inside the message cannot be decoded "
                         f"({type(exc).__name__}: {exc})") from None


def _compressed_header(payload: Payload, what: str) -> PngHeader:
    """The IHDR of a compressedDepth message's PNG: 16-bit grey, else a one-line ValueError."""
    fmt = payload.encoding
    if "rvl" in fmt.lower():
        raise ValueError(f"{what}: compressedDepth format {fmt!r} (RVL) is not supported; "
                         f"record the topic as PNG compressedDepth or raw")
    data = payload.data
    png = data[COMPRESSED_DEPTH_HEADER:]
    if png[:8] != PNG_SIGNATURE:
        raise ValueError(f"{what}: a compressedDepth message is a 12-byte header and a PNG; "
                         f"this one ({len(data)} bytes) is not")
    try:
        header = png_header(png[:33], len(png))
    except ValueError as exc:
        raise ValueError(f"{what}: the PNG inside the message cannot be decoded ({exc})") from None
    if (header.bit_depth, header.color_type) != (16, 0):
        raise ValueError(f"{what}: the PNG of compressedDepth must be 16-bit grey, got "
                         f"{header.kind}")
    return header


def _compressed_depth(payload: Payload, what: str) -> np.ndarray:
    enc = payload.depth_encoding
    header = _compressed_header(payload, what)  # the header first: nothing decoded for a bad one
    data = payload.data
    _, quant_a, quant_b = struct.unpack("<iff", data[:COMPRESSED_DEPTH_HEADER])
    img = _png(data[COMPRESSED_DEPTH_HEADER:], what, header)
    if img.ndim != 2 or img.dtype != np.uint16 or img.shape != (header.height, header.width):
        raise ValueError(f"{what}: the PNG of compressedDepth must be 16-bit grey of its "
                         f"header's size, got {img.dtype} of shape {img.shape}")
    if enc == "16UC1":
        return img
    # 32FC1: quantised inverse depth; the same float32 arithmetic as the plugin's decoder
    q = img.astype(np.float32)
    with np.errstate(divide="ignore", invalid="ignore"):
        depth = np.float32(quant_a) / (q - np.float32(quant_b))
    depth[img == 0] = np.nan
    return depth


def _not_depth(payload: Payload, what: str) -> ValueError:
    kind = "CompressedImage format" if payload.compressed else "encoding"
    return ValueError(f"{what}: {kind} {payload.encoding!r} is not depth this reads "
                      f"(16UC1, mono16 or 32FC1 Images; 16UC1 or 32FC1 compressedDepth)")


def depth_shape(payload: Payload, what: str = "depth") -> tuple[int, int]:
    """The ``(height, width)`` of a depth message from its header alone: no pixel decoded.

    An Image's height and width, checked against its row step and data; a
    compressedDepth message's PNG header (IHDR), which must say 16-bit grey.

    Raises
    ------
    ValueError
        Not depth, not an image (a size of 0, too little data), RVL, or a PNG
        header that cannot be read: the reason in one line, naming `what`.
    """
    if not is_depth(payload):
        raise _not_depth(payload, what)
    if payload.compressed:
        header = _compressed_header(payload, what)
        return header.height, header.width
    _raw_layout(payload, what)
    return payload.height, payload.width


def depth_image(payload: Payload, what: str = "depth") -> tuple[np.ndarray, float]:
    """The depth of a message, values as stored, and its metres per value.

    Parameters
    ----------
    payload : Payload
    what : str
        Names the message in errors (topic and stamp).

    Returns
    -------
    depth : (H, W) ndarray of uint16 or float32
        0 (and NaN for float) marks missing depth, as in the message.
    scale : float
        0.001 for 16-bit depth (millimetres), 1.0 for 32FC1 (metres).

    Raises
    ------
    ValueError
        Another encoding (named), or damaged data.
    """
    if not is_depth(payload):
        raise _not_depth(payload, what)
    enc = payload.depth_encoding
    arr = _compressed_depth(payload, what) if payload.compressed else _raw(payload, what)
    return arr, DEPTH_SCALES[enc]


def color_image(payload: Payload, what: str = "colour") -> np.ndarray:
    """The RGB (H, W, 3) or grey (H, W) uint8 image of a colour message.

    ``rgb8``, ``bgr8``, ``rgba8``, ``bgra8`` and ``mono8`` Images, and
    CompressedImages (JPEG, PNG: ``image_transport``'s ``compressed``).

    Raises
    ------
    ValueError
        Another encoding (named), or damaged data.
    """
    if payload.compressed:
        import imageio.v3 as iio

        try:
            with pillow_quiet():  # Pillow's own limit still refuses the largest
                img = np.asarray(iio.imread(io.BytesIO(payload.data), plugin="pillow"))
        except Exception as exc:  # Pillow raises many kinds of errors on damaged data
            raise ValueError(f"{what}: the compressed image ({payload.encoding!r}) cannot be "
                             f"decoded ({type(exc).__name__}: {exc})") from None
        if img.dtype != np.uint8:
            raise ValueError(f"{what}: a compressed colour image must be 8-bit, got {img.dtype}")
        return img if img.ndim == 2 else img[..., :3]
    if payload.encoding not in COLOR_ENCODINGS:
        raise ValueError(f"{what}: encoding {payload.encoding!r} is not a colour encoding this "
                         f"reads ({', '.join(COLOR_ENCODINGS)})")
    arr = _raw(payload, what)
    if payload.encoding in ("bgr8", "bgra8"):
        arr = arr[..., 2::-1]
    elif payload.encoding == "rgba8":
        arr = arr[..., :3]
    return np.ascontiguousarray(arr)
