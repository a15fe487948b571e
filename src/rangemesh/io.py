"""Reading range images and reading/writing mesh files, through well-kept libraries.

Range images: ``.npy`` (NumPy), PNG/PGM/PPM/PFM (imageio with Pillow: 8- and
16-bit, ASCII and binary PNM), TIFF (tifffile: integer and float) and the
``z`` channel of organised ``.pcd`` point clouds (pypcd4, an optional extra).

Meshes: PLY through plyfile (binary by default, ASCII on request, optional
per-vertex ``row``/``col``), OBJ, OFF, STL and GLB through trimesh. Every file
is written to a temporary file in the target folder and renamed into place,
so a failed run never leaves a half-written file.

The reader and writer of each suffix are one entry of `FORMATS`; the
suffixes the entry points take (`IMAGE_SUFFIXES`, `MESH_SUFFIXES`) come
from it.
"""

from __future__ import annotations

import dataclasses
import errno
import logging
import math
import os
import struct
import tempfile
import warnings
import zlib
from collections.abc import Callable
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ._optional import require
from .camera import MAX_RAY_PIXELS, Orthographic, Pinhole, Spherical, beams_numbers, read_beams
from .checks import whole_number
from .mesh import Mesh, Stats, check_arrays, count_edges

__all__ = [
    "IMAGE_SUFFIXES",
    "SCAN_SUFFIX",
    "MESH_SUFFIXES",
    "FORMATS",
    "Format",
    "read_range_image",
    "read_image_size",
    "read_lidar_bin",
    "bin_layout",
    "read_scan",
    "read_color_image",
    "write_mesh",
    "read_mesh",
    "atomic_path",
]

# A KITTI-style LiDAR scan: read with its beams file (`read_scan`, `bin_layout`).
SCAN_SUFFIX = ".bin"
# IMAGE_SUFFIXES and MESH_SUFFIXES come from the table of formats, `FORMATS` (below its readers
# and writers).


def _suffix(path: Path) -> str:
    return path.suffix.lower()


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


def read_lidar_bin(path: str | os.PathLike, beams: int, *, column_shift=None,
                   steps: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Read a KITTI-style LiDAR scan (``.bin``) as range and intensity images.

    The file holds float32 ``x y z intensity`` records, one per return,
    ordered azimuth step by azimuth step, all `beams` beams of a step
    together (index ``step * beams + beam``); a missing return is the point
    (0, 0, 0). Row ``b`` of the images is beam ``b``, column ``s`` is step
    ``s``.

    Parameters
    ----------
    path : str or os.PathLike
    beams : int
        Beams of the sensor (64 for an Ouster OS1-64 or a Velodyne HDL-64).
    column_shift : (beams,) sequence of int, optional
        Destagger: roll row ``b`` by ``column_shift[b]`` columns so that a
        column is one azimuth for every beam (the ``column_shift`` of a
        ``.beams.json`` file; what the Ouster SDK's ``destagger`` does).
    steps : int, optional
        The azimuth steps (columns) the scan must have (a beams file's
        ``cols``): the file's size is checked against it before it is read.

    Returns
    -------
    range : (beams, steps) ndarray of float32
        ``sqrt(x² + y² + z²)``, 0 where there is no return.
    intensity : (beams, steps) ndarray of float32

    Raises
    ------
    ValueError
        A file whose size is not a whole number of steps (or not `steps`
        steps), or a shift list of the wrong length.
    """
    path = Path(path)
    _check_readable(path)
    beams = int(beams)
    size = path.stat().st_size
    if beams < 1 or size == 0 or size % (16 * beams):
        raise ValueError(f"{path}: {size} bytes is not a whole number of {beams}-beam steps of "
                         f"float32 x, y, z, intensity (16 bytes a point)")
    if steps is not None and size != 16 * beams * int(steps):
        raise ValueError(f"{path}: {size} bytes is {size // (16 * beams)} steps of {beams} beams, "
                         f"not the {int(steps)} the beams file gives")
    pts = np.fromfile(path, dtype="<f4").reshape(-1, beams, 4).transpose(1, 0, 2)
    with np.errstate(over="ignore", invalid="ignore"):  # a range beyond float32 is inf: no return
        rng = np.sqrt(np.sum(pts[..., :3].astype(np.float64) ** 2, axis=2)).astype(np.float32)
    inten = np.ascontiguousarray(pts[..., 3])
    if column_shift is not None:
        shift = np.asarray(column_shift, dtype=np.int64)
        if shift.shape != (beams,):
            raise ValueError(f"column_shift must have one value per beam ({beams}), "
                             f"got shape {shift.shape}")
        rng = np.stack([np.roll(row, k) for row, k in zip(rng, shift, strict=True)])
        inten = np.stack([np.roll(row, k) for row, k in zip(inten, shift, strict=True)])
    return rng, inten


def bin_layout(beams_path: str | os.PathLike) -> dict:
    """How a ``.bin`` scan is laid out, from its beams file: `read_lidar_bin`'s arguments.

    Returns
    -------
    dict
        ``rows`` (beams), ``cols`` (azimuth steps, or None) and
        ``column_shift`` (one whole number a beam, or None).

    Raises
    ------
    ValueError
        A beams file that cannot be read, or whose values are not whole numbers;
        the message names the file and the key.
    """
    beams = read_beams(beams_path)
    try:
        rows = whole_number("beams: rows", beams["rows"], minimum=1)
        cols = beams.get("cols")
        cols = None if cols is None else whole_number("beams: cols", cols, minimum=1)
        shift = beams.get("column_shift")
        shift = None if shift is None else beams_numbers("column_shift", shift, whole=True)
    except KeyError:
        raise ValueError(f"{beams_path}: a beams file for a .bin scan gives its 'rows'") from None
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{beams_path}: {_first_line(exc)}") from None
    return {"rows": rows, "cols": cols, "column_shift": shift, "beams": beams}


def read_scan(path: str | os.PathLike, layout: dict | None = None) -> np.ndarray:
    """A range image: an image file (`read_range_image`), or a LiDAR ``.bin`` scan's ranges.

    Parameters
    ----------
    path : str or os.PathLike
    layout : dict, optional
        The ``.bin`` scan's layout from its beams file (`bin_layout`); needed
        for ``.bin`` files only.

    Raises
    ------
    ValueError
        A file that cannot be read as either, or a ``.bin`` without `layout`.
    """
    if Path(path).suffix.lower() != SCAN_SUFFIX:
        return read_range_image(path)
    if layout is None:
        raise ValueError(f"{path}: a .bin LiDAR scan needs --beams FILE.json (its rows and "
                         f"column shifts)")
    try:
        rows, cols = layout["rows"], layout["cols"]
        if cols is not None and layout.get("beams") is not None and Path(path).is_file() \
                and Path(path).stat().st_size != 16 * rows * cols:
            # not the organised scan the file lays out: an unorganised cloud (KITTI's dropped
            # returns left out), each point put in its pixel by the file's beams
            from .clouds import project_scan, read_cloud

            return project_scan(read_cloud(path), beams=layout["beams"]).ranges
        rng, _ = read_lidar_bin(path, rows, column_shift=layout["column_shift"], steps=cols)
    except OSError as exc:
        raise ValueError(f"{path}: {_first_line(exc)}") from None
    return rng


def _umask() -> int:
    """The process's umask, read without changing it where Linux allows."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    old = os.umask(0o022)  # elsewhere: the only portable way, set and put back at once
    os.umask(old)
    return old


def _new_file_mode(path: Path) -> int:
    """The mode a plain ``open(path, 'w')`` would give: the old file's, else 0666 less the umask."""
    try:
        return path.stat().st_mode & 0o7777
    except OSError:
        return 0o666 & ~_umask()


def part_owner() -> str:
    """The tag of this process in its temporary files' names: host and process id.

    `rangemesh.batch` removes another run's leftovers only when the process
    that owns them is gone, never the files of a batch still running.
    """
    import socket

    host = "".join(ch if ch.isalnum() or ch == "-" else "-" for ch in socket.gethostname())
    return f"{host or 'host'}.{os.getpid()}"


@contextmanager
def atomic_path(path: str | os.PathLike):
    """Yield a temporary path beside `path`; rename it to `path` only on success.

    The file gets the mode a plain write would give it: an existing file's
    mode is kept, a new file follows the umask (0644 under umask 022). The
    temporary file is removed whatever happens, Ctrl-C included.

    Raises
    ------
    FileNotFoundError
        If the target folder does not exist.
    OSError
        If the file cannot be written (permissions, a full disk, a folder in
        the way); its ``filename`` is `path`, not the temporary name.
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise FileNotFoundError(f"{folder}: folder does not exist")
    if path.is_dir():
        raise IsADirectoryError(errno.EISDIR, "is a folder, not a file to write", str(path))
    tmp = None
    try:
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{path.name}.{part_owner()}.",
                                   suffix=".part" + path.suffix)
        os.close(fd)
        os.chmod(tmp, _new_file_mode(path))  # mkstemp makes it 0600
        yield Path(tmp)
        os.replace(tmp, path)
    except OSError as exc:
        if exc.filename == str(path):
            raise
        raise type(exc)(exc.errno, exc.strerror or str(exc), str(path)) from exc
    finally:
        if tmp is not None:
            Path(tmp).unlink(missing_ok=True)


def _coordinate_type(points: np.ndarray) -> str:
    """``'f4'`` for points float32 holds (range and normal precision), else ``'f8'``.

    Meshes of depths far from 1 (a subnormal pinhole depth scale, depths
    beyond 1e38) would otherwise be written as 0 or inf.
    """
    a = np.abs(points[np.isfinite(points)])
    f4 = np.finfo(np.float32)
    return "f4" if not a.size or (a.max() <= f4.max and a[a > 0].min(initial=1.0) >= f4.tiny) \
        else "f8"


def _write_ply(mesh: Mesh, path: Path, tmp: Path, ascii: bool, pixels: bool, normals: bool):
    from plyfile import PlyData, PlyElement

    xyz = _coordinate_type(mesh.vertices)
    fields = [("x", xyz), ("y", xyz), ("z", xyz)]
    if normals:
        fields += [("nx", "f4"), ("ny", "f4"), ("nz", "f4")]
    if mesh.colors is not None:  # the names and type MeshLab, Open3D and CloudCompare read
        fields += [("red", "u1"), ("green", "u1"), ("blue", "u1")]
    fields += [(name, "f4") for name in mesh.attributes]
    if pixels:
        fields += [("row", "i4"), ("col", "i4")]
    vert = np.zeros(len(mesh.vertices), dtype=fields)
    vert["x"], vert["y"], vert["z"] = mesh.vertices.T
    if normals:
        vert["nx"], vert["ny"], vert["nz"] = mesh.vertex_normals().T
    if mesh.colors is not None:
        vert["red"], vert["green"], vert["blue"] = mesh.colors.T
    for name, values in mesh.attributes.items():
        vert[name] = values
    if pixels:
        vert["row"], vert["col"] = mesh.pixels.T
    face = np.zeros(len(mesh.faces), dtype=[("vertex_indices", "i4", (3,))])
    face["vertex_indices"] = mesh.faces
    PlyData(
        [PlyElement.describe(vert, "vertex"), PlyElement.describe(face, "face")],
        text=ascii,
        comments=[f"rangemesh image_shape {mesh.image_shape[0]} {mesh.image_shape[1]}",
                  *_camera_comments(mesh.camera)],
    ).write(str(tmp))


def _texture_paths(path: Path) -> tuple[Path, Path]:
    """The material and texture files written beside an OBJ file: ``name.mtl``, ``name.texture.png``."""
    return path.with_suffix(".mtl"), path.with_name(path.stem + ".texture.png")


def _write_png(image: np.ndarray, path: Path) -> None:
    import imageio.v3 as iio

    with atomic_path(path) as tmp:
        iio.imwrite(tmp, image, extension=".png", plugin="pillow")


def _write_obj(mesh: Mesh, path: Path, tmp: Path, ascii: bool, pixels: bool,
               normals: bool) -> None:
    """OBJ text: ``v x y z [r g b]``, ``vt``, ``vn``, ``f v/vt/vn``, and MTL + PNG for a texture.

    Written here rather than by trimesh, whose OBJ writer takes vertex colours
    or a texture but not both.
    """
    cols = [mesh.vertices]
    if mesh.colors is not None:  # the common extension: floats in [0, 1] after x y z
        cols.append(mesh.colors / 255.0)
    lines = ["# rangemesh"]
    textured = mesh.texture is not None and len(mesh.pixels) == len(mesh.vertices)
    if textured:
        mtl, png = _texture_paths(path)
        _write_png(mesh.texture, png)
        with atomic_path(mtl) as t:
            t.write_text(f"newmtl rangemesh\nKa 1 1 1\nKd 1 1 1\nKs 0 0 0\nd 1\nillum 1\n"
                         f"map_Kd {png.name}\n")
        lines += [f"mtllib {mtl.name}", "usemtl rangemesh"]
    body = [_rows("v", np.hstack(cols))]
    if textured:
        uv = mesh.uv.copy()
        uv[:, 1] = 1.0 - uv[:, 1]  # OBJ's texture origin is the bottom left
        body.append(_rows("vt", uv))
    if normals:
        body.append(_rows("vn", mesh.vertex_normals()))
    idx = (mesh.faces.astype(np.int64) + 1).astype(str)
    if textured and normals:
        corner = np.char.add(np.char.add(np.char.add(idx, "/"), np.char.add(idx, "/")), idx)
    elif textured:
        corner = np.char.add(np.char.add(idx, "/"), idx)
    elif normals:
        corner = np.char.add(np.char.add(idx, "//"), idx)
    else:
        corner = idx
    body.append("\n".join("f " + " ".join(row) for row in corner.tolist()))
    tmp.write_text("\n".join(lines + [b for b in body if b]) + "\n")


def _rows(tag: str, values: np.ndarray) -> str:
    if not len(values):
        return ""
    return "\n".join(f"{tag} " + " ".join(f"{x:.9g}" for x in row) for row in values.tolist())


def _to_glb(mesh: Mesh, normals: bool) -> bytes:
    """GLB bytes: positions, NORMAL, TEXCOORD_0 and the texture, or COLOR_0, and ``_name`` attributes.

    glTF multiplies COLOR_0 with the base colour texture, so a textured file
    leaves the vertex colours out (they would darken the photo);
    ``texture=False`` writes them instead.
    """
    from PIL import Image

    trimesh = require("trimesh", "GLB output")
    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    if mesh.texture is not None and len(mesh.pixels) == len(mesh.vertices):
        uv = mesh.uv.copy()
        uv[:, 1] = 1.0 - uv[:, 1]  # trimesh keeps OBJ's convention and flips it back for glTF
        tm.visual = trimesh.visual.TextureVisuals(uv=uv, image=Image.fromarray(mesh.texture))
    elif mesh.colors is not None:
        tm.visual = trimesh.visual.ColorVisuals(tm, vertex_colors=mesh.colors)
    for name, values in mesh.attributes.items():
        tm.vertex_attributes["_" + name] = np.asarray(values, np.float32)
    kwargs = {"include_normals": bool(normals)}
    if normals:
        tm.vertex_normals = mesh.vertex_normals()
    return tm.export(file_type="glb", **kwargs)


def _write_glb(mesh: Mesh, path: Path, tmp: Path, ascii: bool, pixels: bool,
               normals: bool) -> None:
    tmp.write_bytes(_to_glb(mesh, normals))


def _write_trimesh(mesh: Mesh, path: Path, tmp: Path, ascii: bool, pixels: bool,
                   normals: bool) -> None:
    """OFF and STL through trimesh's exporter (no normals, colours or texture in them)."""
    suffix = _suffix(path)
    tm = require("trimesh", f"{suffix} output").Trimesh(mesh.vertices, mesh.faces, process=False)
    data = tm.export(file_type=suffix[1:])
    tmp.write_bytes(data.encode() if isinstance(data, str) else data)


def write_mesh(mesh: Mesh, path: str | os.PathLike, *, ascii: bool = False,
               pixels: bool = False, normals: bool = True, texture: bool = True) -> Path:
    """Write a mesh file, chosen by suffix; atomically.

    Parameters
    ----------
    mesh : Mesh
    path : str or os.PathLike
        ``.ply`` (plyfile), ``.obj`` (written here: trimesh's writer cannot
        hold vertex colours and a texture at once), ``.off``, ``.stl``,
        ``.glb`` (trimesh).
    ascii : bool, default False
        PLY only: write text instead of binary.
    pixels : bool, default False
        PLY only: add int32 vertex properties ``row`` and ``col``.
    normals : bool, default True
        Per-vertex normals facing the sensor (`Mesh.vertex_normals`): PLY
        ``nx ny nz``, OBJ ``vn``, GLB ``NORMAL``.
    texture : bool, default True
        With a mesh that has a texture (`Mesh.with_colors`): OBJ writes
        ``name.mtl`` and ``name.texture.png`` beside the file (replacing
        files of those names) and texture coordinates; GLB embeds the image.
        Vertex colours go to PLY (``red green blue`` uchar) and OBJ (``v x y
        z r g b``) always, to GLB (``COLOR_0``) when no texture is written.

    Returns
    -------
    Path
        The path written.

    Raises
    ------
    ValueError
        For an unknown suffix, ``ascii``/``pixels`` with another format, a
        mesh whose arrays are not a mesh (see `rangemesh.mesh.check_arrays`),
        or a vertex coordinate beyond float32's range.
    FileNotFoundError
        If the folder does not exist.

    Notes
    -----
    Vertices are stored as float32 (what viewers expect). Faces keep the
    mesh's orientation (counter-clockwise in the image plane). trimesh is
    called with ``process=False`` so no vertex is merged or reordered.
    """
    path = Path(path)
    suffix = _suffix(path)
    fmt = FORMATS.get(suffix)
    if fmt is None or fmt.kind != "mesh" or fmt.write is None:
        raise ValueError(f"{path}: unknown mesh format {suffix!r}; use one of "
                         f"{', '.join(_suffixes('mesh'))}")
    if not fmt.ply_options and (ascii or pixels):
        raise ValueError(f"{path}: ascii and pixels apply to PLY files only")
    check_arrays(mesh.vertices, mesh.faces, mesh.pixels, mesh.image_shape, what=str(path))
    largest = float(np.abs(mesh.vertices).max()) if mesh.vertices.size else 0.0
    if largest > float(np.finfo(np.float32).max):
        raise ValueError(f"{path}: a vertex coordinate of {largest:g} does not fit the float32 of "
                         f"mesh files; scale the vertices (the camera's kx, ky, kz or depth_scale)")
    if not texture and mesh.texture is not None:
        mesh = dataclasses.replace(mesh, texture=None)
    normals = normals and not mesh.is_empty
    with atomic_path(path) as tmp:
        fmt.write(mesh, path, tmp, ascii, pixels, normals)
    return path


_PLY_SIZES = {"char": 1, "int8": 1, "uchar": 1, "uint8": 1, "short": 2, "int16": 2, "ushort": 2,
              "uint16": 2, "int": 4, "int32": 4, "uint": 4, "uint32": 4, "float": 4,
              "float32": 4, "double": 8, "float64": 8}


def _check_ply_counts(path: Path) -> None:
    """Refuse a PLY whose header claims more elements than the file's bytes can hold.

    Readers size their arrays by the header's counts before they read the
    body; a 5 KB file must not make them allocate gigabytes. Each element
    takes at least its scalar properties' bytes and its lists' count bytes
    (binary), or two characters a property (ASCII).
    """
    size = path.stat().st_size
    with open(path, "rb") as f:
        head = f.read(1 << 16)
    end = head.find(b"end_header")
    if not head.startswith(b"ply") or end < 0:
        return  # not ours to judge: the reader says what is wrong
    body = size - (head.find(b"\n", end) + 1)
    ascii_ = b"format ascii" in head[:end]
    need, counts = 0, []
    for line in head[:end].decode("ascii", "replace").splitlines():
        words = line.split()
        if words[:1] == ["element"] and len(words) == 3 and words[2].isdigit():
            counts.append([words[1], int(words[2]), 0])
        elif words[:1] == ["property"] and counts and len(words) >= 3:
            kind = words[2] if words[1] == "list" else words[1]
            counts[-1][2] += 2 if ascii_ else _PLY_SIZES.get(kind, 1)
    for name, count, each in counts:
        need += count * max(each, 1)
        if need > body:
            raise ValueError(f"{path}: the header claims {count} {name} elements, more than the "
                             f"file's {size} bytes can hold")


@dataclasses.dataclass
class _MeshFile:
    """What a mesh reader found in a file (`read_mesh` checks it)."""

    vertices: np.ndarray
    faces: np.ndarray
    pixels: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 2), np.int32))
    colors: np.ndarray | None = None
    image_shape: tuple = (0, 0)
    camera: object = None  # the camera the file records


def _read_ply(path: Path, camera, image_shape) -> _MeshFile:
    """A PLY file through plyfile, with what rangemesh records: pixels, colours, shape, camera."""
    from plyfile import PlyData

    pixels = np.zeros((0, 2), np.int32)
    shape = (0, 0)
    recorded = None
    colors = None
    _check_ply_counts(path)
    ply = PlyData.read(str(path))
    v = ply["vertex"].data
    vertices = np.stack([v["x"], v["y"], v["z"]], axis=1).astype(np.float64)
    faces = np.stack(ply["face"].data["vertex_indices"]) \
        if len(ply["face"].data) else np.zeros((0, 3), np.int32)
    if not np.issubdtype(faces.dtype, np.integer):
        whole = np.isfinite(faces).all() and (faces == np.round(faces)).all()
        if not whole:
            raise ValueError("face indices must be whole numbers")
    with np.errstate(invalid="ignore"):
        big = faces.size and (faces.max() > np.iinfo(np.int32).max or faces.min() < 0)
    if big:
        raise ValueError(f"a face index is out of range (0 .. {np.iinfo(np.int32).max})")
    faces = faces.astype(np.int32)
    if "row" in v.dtype.names and "col" in v.dtype.names:
        pixels = np.stack([v["row"], v["col"]], axis=1).astype(np.int32)
    if {"red", "green", "blue"} <= set(v.dtype.names):
        colors = np.stack([v["red"], v["green"], v["blue"]], axis=1).astype(np.uint8)
    camera_words = []
    for c in ply.comments:
        parts = c.split()
        if len(parts) == 4 and parts[:2] == ["rangemesh", "image_shape"]:
            shape = (int(parts[2]), int(parts[3]))
        if len(parts) >= 3 and parts[:2] == ["rangemesh", "camera"]:
            camera_words = parts[2:]
        if len(parts) >= 3 and parts[:2] == ["rangemesh", "camera+"] and camera_words:
            camera_words += parts[2:]
    if camera_words:
        recorded = _camera_from_text(camera_words, image_shape or shape)
        if recorded is None and camera is None:
            raise ValueError(f"the file records a camera that cannot be read back "
                             f"({' '.join(camera_words)[:60]}); give camera=")
    return _MeshFile(vertices, faces, pixels, colors, shape, recorded)


def _read_trimesh(path: Path, camera, image_shape) -> _MeshFile:
    """OBJ, OFF, STL and GLB through trimesh: vertices and faces."""
    import trimesh

    tm = trimesh.load(path, process=False, force="mesh")
    return _MeshFile(np.asarray(tm.vertices, np.float64), np.asarray(tm.faces, np.int32))


def read_mesh(path: str | os.PathLike, *, camera=None, image_shape=None) -> Mesh:
    """Read a mesh file into a `Mesh` (for `evaluate`).

    Parameters
    ----------
    path : str or os.PathLike
        Any of ``MESH_SUFFIXES``. PLY files written with ``pixels=True`` give
        back their ``row``/``col``; otherwise pixels are empty and `evaluate`
        projects the vertices with the camera.
    camera : Orthographic or Pinhole, optional
        The camera the mesh was made with. Default: the camera a PLY written
        by rangemesh records, else orthographic 1, 1, 1. A camera that
        differs from the recorded one is refused.
    image_shape : (int, int), optional
        Shape of the range image the mesh is meant for; a PLY written by
        rangemesh records the shape it was made from, and a different one is
        refused. Default: the recorded shape, else unknown ``(0, 0)``.

    Returns
    -------
    Mesh

    Raises
    ------
    FileNotFoundError
        Missing file.
    ValueError
        Unreadable file, no triangle, a face index out of range, non-finite
        vertices, pixels outside the image, or a recorded image shape that
        differs from `image_shape`.
    """
    path = Path(path)
    fmt = _readable_format(path, "mesh", "mesh format")
    if fmt.reader_needs is not None:  # a missing extra is said as such, not as a bad file
        require(fmt.reader_needs, f"reading {_suffix(path)} meshes")
    try:
        got = fmt.read(path, camera, image_shape)
    except Exception as exc:  # readers raise many kinds of errors on bad files
        raise ValueError(f"{path}: cannot read it as a mesh "
                         f"({type(exc).__name__}: {_first_line(exc)})") from None
    vertices, faces, colors = got.vertices, got.faces, got.colors
    pixels, shape, recorded = got.pixels, got.image_shape, got.camera
    if faces.ndim != 2 or (len(faces) and faces.shape[1] != 3):
        raise ValueError(f"{path}: only triangle meshes are supported")
    if len(faces) == 0:
        raise ValueError(f"{path}: cannot read it as a mesh: it holds no triangle")
    if image_shape is not None:
        given = tuple(int(x) for x in image_shape)
        if shape != (0, 0) and shape != given:
            raise ValueError(f"{path}: the mesh was made from a {shape[0]}x{shape[1]} image, "
                             f"not from this {given[0]}x{given[1]} one")
        shape = given
    if camera is not None and recorded is not None and camera != recorded:
        raise ValueError(f"{path}: the mesh was made with {recorded}, not {camera}; give its "
                         f"camera, or none to use the one the file records")
    check_arrays(vertices, faces, pixels, shape, what=str(path))
    stats = Stats(vertices=len(vertices), triangles=len(faces), edges=count_edges(faces))
    camera = camera if camera is not None else recorded if recorded is not None else Orthographic()
    return Mesh(vertices=vertices, faces=faces, pixels=pixels, camera=camera,
                image_shape=shape, stats=stats, colors=colors)


@dataclasses.dataclass
class Format:
    """How files of one suffix are read and written: an entry of `FORMATS`.

    Attributes
    ----------
    kind : {'image', 'mesh'}
        A range image (`read_range_image`) or a mesh (`read_mesh`, `write_mesh`).
    read : callable
        ``read(path) -> array`` for an image; ``read(path, camera, image_shape)
        -> _MeshFile`` for a mesh. Its errors become one ValueError naming the file.
    write : callable or None
        ``write(mesh, path, tmp, ascii, pixels, normals)``, writing `tmp`
        (renamed to `path` when it returns); None: not written.
    reader_needs : str or None
        The optional module the reader needs (its ImportError says which extra).
    ply_options : bool
        The writer takes ``ascii`` and ``pixels``.
    """

    kind: str
    read: Callable
    write: Callable | None = None
    reader_needs: str | None = None
    ply_options: bool = False


_PILLOW = Format("image", _read_pillow)
_TRIMESH = {"read": _read_trimesh, "reader_needs": "trimesh"}

# The one table of file formats, by suffix: adding a format is one entry (and its functions).
# The order is that of IMAGE_SUFFIXES and MESH_SUFFIXES, which messages and the CLI list.
FORMATS = {
    ".npy": Format("image", _read_npy),
    ".png": _PILLOW,
    ".pgm": _PILLOW,
    ".ppm": _PILLOW,
    ".pnm": _PILLOW,
    ".pfm": _PILLOW,
    ".tif": Format("image", _read_tiff),
    ".tiff": Format("image", _read_tiff),
    ".pcd": Format("image", _read_pcd_z),
    ".ply": Format("mesh", _read_ply, _write_ply, ply_options=True),
    ".obj": Format("mesh", write=_write_obj, **_TRIMESH),
    ".off": Format("mesh", write=_write_trimesh, **_TRIMESH),
    ".stl": Format("mesh", write=_write_trimesh, **_TRIMESH),
    ".glb": Format("mesh", write=_write_glb, **_TRIMESH),
}


def _suffixes(kind: str) -> tuple[str, ...]:
    return tuple(suffix for suffix, fmt in FORMATS.items() if fmt.kind == kind)


def _readable_format(path: Path, kind: str, noun: str) -> Format:
    """The table's `Format` of a file to read, once the file is known readable; else ValueError."""
    _check_readable(path)
    suffix = _suffix(path)
    fmt = FORMATS.get(suffix)
    if fmt is None or fmt.kind != kind:
        raise ValueError(f"{path}: unknown {noun} {suffix!r}; known: {', '.join(_suffixes(kind))}")
    return fmt


IMAGE_SUFFIXES = _suffixes("image")
MESH_SUFFIXES = _suffixes("mesh")


# Header lines stay well under RPly's 1,024 characters (Open3D aborts on longer ones).
MAX_COMMENT_CHARS = 900


def _camera_comments(camera) -> list[str]:
    """The camera as PLY comments of at most `MAX_COMMENT_CHARS` characters each.

    The first is ``rangemesh camera ...`` (`_camera_text`); a spherical
    camera's per-row values, too long for one line, continue on
    ``rangemesh camera+ ...`` lines, read back in order.
    """
    words = ("rangemesh camera " + _camera_text(camera)).split(" ")
    lines, line = [], words[0] + " " + words[1]
    for word in words[2:]:
        if len(line) + 1 + len(word) > MAX_COMMENT_CHARS:
            lines.append(line)
            line = "rangemesh camera+"
        line += " " + word
    return [*lines, line]


def _camera_text(camera) -> str:
    """The camera as a PLY comment: ``orthographic kx ky kz`` or ``pinhole fx fy cx cy scale``.

    A `Spherical` camera with evenly spaced columns is ``spherical scale H W
    azimuth0 step`` then the H elevations and H row offsets; other per-pixel
    cameras are named only (``rays``), and reading the file needs the camera.
    """
    if isinstance(camera, Spherical):
        az = camera.azimuth
        even = az[0] + camera.step * np.arange(az.size)
        if np.allclose(az, even, rtol=0.0, atol=1e-9):
            values = [camera.range_scale, az[0], camera.step, *camera.elevation,
                      *camera.row_azimuth]
            h, w = camera.shape
            return f"spherical {h} {w} " + " ".join(repr(float(v)) for v in values)
        return "rays"
    if hasattr(camera, "directions"):
        return "rays"
    if isinstance(camera, Pinhole):
        values = (camera.fx, camera.fy, camera.cx, camera.cy, camera.depth_scale)
        return "pinhole " + " ".join(repr(float(v)) for v in values)
    return "orthographic " + " ".join(repr(float(v)) for v in (camera.kx, camera.ky, camera.kz))


def _camera_from_text(parts, image_shape=(0, 0)):
    """The camera of a ``rangemesh camera ...`` comment, or None if it cannot be read.

    A spherical camera must be for `image_shape` (when known, not ``(0, 0)``):
    that is checked before the file's numbers size its rays.

    Raises
    ------
    ValueError
        A spherical camera for another image shape, or too large to be one.
    """
    try:
        values = [float(p) for p in parts[1:]]
    except ValueError:
        return None  # another writer's comment, or a damaged one: the caller's camera decides
    try:  # a damaged value (0, NaN, a degenerate table) reads as no camera
        if parts[0] == "pinhole" and len(values) == 5:
            return Pinhole(*values[:4], depth_scale=values[4])
        if parts[0] == "orthographic" and len(values) == 3:
            return Orthographic(*values)
    except ValueError:
        return None
    if parts[0] != "spherical" or len(values) < 5 or not all(map(math.isfinite, values[:2])):
        return None
    h, w = int(values[0]), int(values[1])
    scale, az0, step = values[2:5]
    rest = values[5:]
    if len(rest) != 2 * h or w < 1:
        return None
    shape = tuple(int(n) for n in image_shape)
    if shape != (0, 0) and (h, w) != shape:
        raise ValueError(f"the file's camera is for a {h}x{w} image, not for this "
                         f"{shape[0]}x{shape[1]} one")
    if h * w > MAX_RAY_PIXELS:
        raise ValueError(f"the file's camera has {h}x{w} pixels, more than {MAX_RAY_PIXELS}")
    try:
        return Spherical(rest[:h], az0 + step * np.arange(w), rest[h:], scale)
    except ValueError:
        return None
