"""The table of file formats by suffix, `FORMATS`: each suffix's reader and writer.

The suffixes the entry points take (`IMAGE_SUFFIXES`, `MESH_SUFFIXES`) come from it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

from .image_readers import _read_npy, _read_pcd_z, _read_pillow, _read_tiff
from .mesh_readers import _read_ply, _read_trimesh
from .mesh_writers import _write_glb, _write_obj, _write_ply, _write_trimesh
from .paths import _check_readable, _suffix


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
