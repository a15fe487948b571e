"""PNG files for the tests, written by the format's definition (not by rangemesh or Pillow).

A large PNG of zeros costs a few hundred kilobytes: its rows are compressed one at a time, so
no full-size array is ever made.
"""

import struct
import zlib

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def chunk(kind: bytes, data: bytes) -> bytes:
    """A PNG chunk: length, type, data and CRC."""
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def png_header(height: int, width: int, bit_depth: int = 16, color_type: int = 0) -> bytes:
    """The signature and IHDR chunk of a PNG (colour type 0: grey, 2: RGB)."""
    ihdr = struct.pack(">IIBBBBB", width, height, bit_depth, color_type, 0, 0, 0)
    return PNG_SIGNATURE + chunk(b"IHDR", ihdr)


def zeros_png(height: int, width: int, bit_depth: int = 16, color_type: int = 0) -> bytes:
    """A valid PNG of `height` x `width` zeros (filter type 0 on every row)."""
    channels = {0: 1, 2: 3, 4: 2, 6: 4}[color_type]
    row = bytes(1 + width * channels * bit_depth // 8)  # the filter byte, then the samples
    z = zlib.compressobj(9)
    idat = b"".join(z.compress(row) for _ in range(height)) + z.flush()
    return png_header(height, width, bit_depth, color_type) + chunk(b"IDAT", idat) \
        + chunk(b"IEND", b"")
