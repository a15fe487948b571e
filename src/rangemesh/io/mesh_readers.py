"""The readers of mesh files, one a format; `rangemesh.io.formats` registers them.

PLY through plyfile, with what rangemesh records in it; the others through trimesh.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from .camera_text import _camera_from_text

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
