"""Writing and reading mesh files by suffix (through `FORMATS`), checked as meshes."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np

from .._optional import require
from ..camera import Orthographic
from ..mesh import Mesh, Stats, check_arrays, count_edges
from .files import atomic_path
from .formats import FORMATS, _readable_format, _suffixes
from .paths import _first_line, _suffix


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
