"""The writers of mesh files, one a format; `rangemesh.io.formats` registers them.

PLY through plyfile, OBJ written here, GLB, OFF and STL through trimesh.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._optional import require
from ..mesh import Mesh
from .camera_text import _camera_comments
from .files import atomic_path
from .paths import _suffix


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
