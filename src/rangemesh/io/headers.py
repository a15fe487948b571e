"""Image headers read without decoding, and the image size Pillow decodes.

A PNG's IHDR chunk, a Netpbm header; a decompression bomb is refused before decoding.
"""

from __future__ import annotations

import dataclasses
import os
import struct
import warnings
import zlib
from contextlib import contextmanager
from pathlib import Path

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
# deflate's best case codes a 258-byte match in 2 bits: n bytes of PNG hold at most 1032 n of rows
DEFLATE_MAX_RATIO = 1032
_PNG_CHANNELS = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}
_PNG_DEPTHS = {0: (1, 2, 4, 8, 16), 2: (8, 16), 3: (1, 2, 4, 8), 4: (8, 16), 6: (8, 16)}
_PNG_COLOURS = {0: "grey", 2: "RGB", 3: "palette", 4: "grey and alpha", 6: "RGBA"}


@dataclasses.dataclass(frozen=True)
class PngHeader:
    """What a PNG's IHDR chunk says: size and pixel format."""

    height: int
    width: int
    bit_depth: int
    color_type: int

    @property
    def kind(self) -> str:
        """The pixel format in words: ``16-bit grey``, ``8-bit RGB``."""
        return f"{self.bit_depth}-bit {_PNG_COLOURS[self.color_type]}"


def png_header(data: bytes, size: int | None = None) -> PngHeader:
    """The size and pixel format of a PNG from its first 33 bytes (signature and IHDR), not decoded.

    Parameters
    ----------
    data : bytes
        The PNG's first bytes (at least 33; more are ignored).
    size : int, optional
        The PNG's whole length in bytes: a header whose pixels that many
        bytes cannot hold, even at deflate's best ratio, is refused.

    Raises
    ------
    ValueError
        No PNG signature, a header cut short or damaged, a size of 0 or a
        size the data cannot hold: the reason in one line, not naming the file.
    """
    if data[:8] != PNG_SIGNATURE:
        raise ValueError("not a PNG (no PNG signature)")
    if len(data) < 33:
        raise ValueError(f"the PNG header is cut short ({len(data)} bytes; the IHDR chunk ends at 33)")
    length, kind = struct.unpack(">I4s", data[8:16])
    if length != 13 or kind != b"IHDR":
        raise ValueError("the PNG's first chunk is not the 13-byte IHDR")
    if struct.unpack(">I", data[29:33])[0] != zlib.crc32(data[12:29]):
        raise ValueError("the PNG's IHDR chunk is damaged (CRC mismatch)")
    width, height, depth, ctype = struct.unpack(">IIBB", data[16:26])
    if not (0 < width < 2**31 and 0 < height < 2**31):
        raise ValueError(f"the header says {width} x {height} pixels (width x height): not an image")
    if depth not in _PNG_DEPTHS.get(ctype, ()):
        raise ValueError(f"the PNG header's bit depth {depth} with colour type {ctype} is no PNG format")
    need = height * width * _PNG_CHANNELS[ctype] * depth // 8
    if size is not None and need > DEFLATE_MAX_RATIO * size:
        raise ValueError(f"the header says {width} x {height} pixels (width x height), {need:,} "
                         f"bytes, and {size:,} bytes cannot hold them even compressed (truncated "
                         f"or damaged)")
    return PngHeader(height, width, depth, ctype)


# Netpbm magic -> (header numbers after the magic, bytes a pixel at least: a function of maxval)
_PNM = {
    b"P1": (2, lambda m: 1),  # ASCII bits: digits need no separator
    b"P2": (3, lambda m: 2),  # ASCII: a digit and a separator each
    b"P3": (3, lambda m: 6),
    b"P4": (2, None),  # packed bits: a row is a whole number of bytes
    b"P5": (3, lambda m: 1 if m < 256 else 2),
    b"P6": (3, lambda m: 3 if m < 256 else 6),
    b"Pf": (3, lambda m: 4),
    b"PF": (3, lambda m: 12),
}


def _pnm_header(head: bytes) -> tuple[int, int, int, int] | None:
    """``(width, height, least raster bytes, header bytes)`` of a PGM/PPM/PBM/PFM, or None.

    None when `head` does not start with a header this reads (then the decoder speaks).
    """
    spec = _PNM.get(head[:2])
    if spec is None:
        return None
    count, per_pixel = spec
    pos, tokens = 2, []
    while len(tokens) < count:
        while pos < len(head) and (head[pos:pos + 1].isspace() or head[pos:pos + 1] == b"#"):
            if head[pos:pos + 1] == b"#":  # a comment runs to the end of its line
                while pos < len(head) and head[pos:pos + 1] not in (b"\n", b"\r"):
                    pos += 1
            else:
                pos += 1
        start = pos
        while pos < len(head) and not head[pos:pos + 1].isspace() and head[pos:pos + 1] != b"#":
            pos += 1
        if start == pos or pos >= len(head):
            return None
        tokens.append(head[start:pos])
    try:
        width, height = int(tokens[0]), int(tokens[1])
        maxval = float(tokens[2]) if count == 3 else 1.0
    except ValueError:
        return None
    if width <= 0 or height <= 0:
        return width, height, 0, pos + 1
    need = height * ((width + 7) // 8) if per_pixel is None else \
        width * height * per_pixel(abs(maxval)) - (1 if head[:2] in (b"P2", b"P3") else 0)
    return width, height, need, pos + 1  # one whitespace byte ends the header


def _image_header(path: Path) -> tuple | None:
    """``(height, width, reason)`` from a PNG's or Netpbm file's header; None for other files.

    `reason` says why the file cannot hold the image its header describes ("" when it can).
    """
    if not path.is_file():  # a pipe would block the open; `read_range_image` says what it is
        return None
    try:
        with open(path, "rb") as fh:
            head = fh.read(1024)
        size = path.stat().st_size
    except OSError:
        return None
    if head[:8] == PNG_SIGNATURE:
        try:
            h = png_header(head, size)
        except ValueError as exc:
            return 0, 0, str(exc)
        return h.height, h.width, ""
    pnm = _pnm_header(head)
    if pnm is None:
        return None
    width, height, need, start = pnm
    if width <= 0 or height <= 0:
        return height, width, f"the header says {width} x {height} pixels (width x height): not an image"
    have = size - start
    if have < need:
        least = "at least " if head[:2] in (b"P1", b"P2", b"P3") else ""  # ASCII: as few digits
        return height, width, (f"the header says {width} x {height} pixels (width x height), "
                               f"{least}{need:,} bytes; the file holds {max(have, 0):,} bytes "
                               f"after its header (truncated or damaged)")
    return height, width, ""


def read_image_size(path: str | os.PathLike) -> tuple[int, int] | None:
    """``(height, width)`` of a PNG, PGM/PPM/PBM or PFM file from its header, nothing decoded.

    Returns
    -------
    (int, int) or None
        None for other formats, a file that cannot be opened, or a header
        that cannot describe an image (`read_range_image` then says why).
    """
    got = _image_header(Path(path))
    if got is None or got[2]:
        return None
    return got[0], got[1]


def check_pillow_size(what: str, height: int, width: int) -> None:
    """Refuse, in one line, an image beyond Pillow's decompression-bomb limit, before decoding it.

    Raises
    ------
    ValueError
        More than twice ``PIL.Image.MAX_IMAGE_PIXELS`` pixels (Pillow would refuse it).
    """
    from PIL import Image

    limit = Image.MAX_IMAGE_PIXELS
    if limit is not None and height * width > 2 * limit:
        raise ValueError(f"{what}: a {height}x{width} image ({height * width:,} pixels) is more "
                         f"than Pillow decodes ({2 * limit:,}: twice PIL.Image.MAX_IMAGE_PIXELS); "
                         f"raise that limit to read it")


@contextmanager
def pillow_quiet():
    """Pillow's DecompressionBombWarning silenced: rangemesh checks sizes against memory itself."""
    from PIL import Image

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Image.DecompressionBombWarning)
        yield
