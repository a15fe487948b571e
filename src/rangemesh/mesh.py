"""The result types: `Mesh` (arrays) and `Stats` (counts, timings, reasons)."""

from __future__ import annotations

from dataclasses import MISSING, asdict, dataclass, field

import numpy as np

from .camera import Orthographic, Pinhole, Rays, Spherical

__all__ = ["Mesh", "Stats", "Target", "with_fields", "count_edges", "check_arrays"]


def with_fields(obj, **changes):
    """``dataclasses.replace(obj, **changes)`` for `Mesh` and `Stats`, at a tenth of its cost.

    Their frozen ``__init__`` sets each field through ``object.__setattr__``
    and they have no ``__post_init__`` to run: copying the instance dict
    gives the same object, and `triangulate` makes two on every call.
    """
    new = object.__new__(type(obj))
    # (a new dict set as the instance dict: updating the empty one costs twice as much)
    _set(new, "__dict__", {**obj.__dict__, **changes})
    return new


_set = object.__setattr__  # (the frozen classes refuse their own __setattr__)


# Old `Stats.target` keys that the `Target` record renamed.
_TARGET_KEYS = {"target": "kind"}


@dataclass(frozen=True)
class Target:
    """What a target asked for and what the mesh achieved (`Stats.target`).

    Attributes
    ----------
    kind : {'vertices', 'max_error', 'max_deviation', 'mean_deviation', 'max_edge'}
        The target.
    requested : int or float
        The value asked for (with the default target, ``DEFAULT_TARGET.max_error``).
    achieved : int or float
        The same quantity measured on the mesh: vertices, relative error
        (percent), largest or mean deviation of a covered valid pixel
        (metres with a metric camera, depth units with `Orthographic`) or
        longest edge (pixels).
    met : bool
        Whether `achieved` meets `requested`.
    meshings : int
        Meshings the search (the paper's) or the insertion (refine's) ran.
    vertices : int
        Vertices of the mesh.
    default : bool
        True when no target was given and the documented default target
        (`rangemesh.params.DEFAULT_TARGET`) was used.
    max_vertices : int or None
        The vertex cap that went with `max_error` (the default target's), or
        with a deviation target (the memory's, when it stopped there).
    tiles, samples : (int, int) or None
        The paper's grid the search chose (``method='paper'`` only).
    added_samples : int or None
        Samples ``max_edge`` added to the grid (``method='paper'``).
    walls_dropped : int or None
        Triangles dropped across jumps (``walls=False``).
    max_edge : float or None
        The longest edge asked for beside the target (``method='refine'``),
        pixels in the image plane.
    longest_edge : float or None
        The mesh's longest edge in the image plane, pixels (with `max_edge`).
    uncovered : int or None
        Valid pixels no triangle covers, which a deviation target does not
        measure (dropped walls, lone pixels); None when not measured.
    note : str
        Why the target was not met, when it was not.

    Notes
    -----
    Reading it as a dict (``target["achieved"]``, ``"tiles" in target``,
    ``target.get(...)``) still works and warns: it was a dict before.
    """

    kind: str
    requested: float
    achieved: float
    met: bool
    meshings: int = 1
    vertices: int = 0
    default: bool = False
    max_vertices: int | None = None
    tiles: tuple[int, int] | None = None
    samples: tuple[int, int] | None = None
    added_samples: int | None = None
    walls_dropped: int | None = None
    note: str = ""
    max_edge: float | None = None
    longest_edge: float | None = None
    uncovered: int | None = None

    @classmethod
    def from_record(cls, rec: dict, *, vertices: int, default: bool = False) -> Target:
        """The record from a method's target dict (``{'target': kind, ...}``).

        Keys it does not know are refused (TypeError): a method's new key needs a field.
        """
        if not rec.keys() <= _RECORD_KEYS:
            raise TypeError(f"target record keys {sorted(rec.keys() - _RECORD_KEYS)} have no "
                            f"Target field")
        # the instance dict filled directly, as `with_fields` does: this runs on every call,
        # and the frozen __init__ sets each field through object.__setattr__
        values = {**_TARGET_DEFAULTS, "vertices": vertices, "default": default, **rec}
        values["kind"] = values.pop("target")
        for k in ("tiles", "samples"):
            if values[k] is not None:
                values[k] = tuple(values[k])
        new = object.__new__(cls)
        _set(new, "__dict__", values)
        return new

    def to_dict(self) -> dict:
        """Plain-Python dictionary (JSON-ready); fields that do not apply are left out."""
        d = {k: v for k, v in asdict(self).items() if v is not None}
        for k in ("tiles", "samples"):
            if k in d:
                d[k] = list(d[k])
        return d

    # the dict it was: readable for one release, with a warning
    def _old(self, key):
        import warnings

        warnings.warn("Stats.target is a rangemesh.Target record: read its attributes "
                      "(target.achieved, target.kind) instead of keys; dict access goes in the "
                      "next release", DeprecationWarning, stacklevel=3)
        return _TARGET_KEYS.get(key, key)

    def __getitem__(self, key):
        key = self._old(key)
        value = getattr(self, key, None) if isinstance(key, str) else None
        if value is None or (key == "note" and not value):
            raise KeyError(key)
        return list(value) if key in ("tiles", "samples") else value

    def __contains__(self, key):
        key = self._old(key)
        return key in self.to_dict() and (key != "note" or bool(self.note))

    def get(self, key, default=None):
        """``target[key]``, or `default` (deprecated dict access)."""
        key = self._old(key)
        d = self.to_dict()
        return d.get(key, default) if key != "note" or self.note else default


# A Target's optional fields at their defaults (`Target.from_record` starts from them).
_TARGET_DEFAULTS = {k: f.default for k, f in Target.__dataclass_fields__.items()
                    if f.default is not MISSING}
_RECORD_KEYS = {"target", "requested", "achieved", "met", "meshings", "vertices", "max_vertices",
                "tiles", "samples", "added_samples", "walls_dropped", "note", "max_edge",
                "longest_edge", "uncovered"}


@dataclass(frozen=True)
class Stats:
    """What a meshing run produced, what its method did and how long each stage took.

    Attributes
    ----------
    vertices, edges, triangles : int
        Counts of the final mesh (edges are undirected and counted once).
    method : {'refine', 'paper'}
        The method that made the mesh.
    flipped_edges : int
        Edge flips taken: by the paper's disparity tests (``flips=``) or, for
        ``method='refine'``, by the error (``diagonals='error'``).
    grid_shape : (int, int) or None
        The paper's sample grid, ``((Rs-1)V+1, (Z-1)H+1)``; None for
        ``method='refine'``, which has no grid.
    sampled_points : int
        Distinct valid pixels in the sample grid (the Delaunay input); for
        ``method='refine'`` the vertices.
    insertions : int
        ``method='refine'``: vertices its last insertion placed, the first
        coarse mesh and background corners included (0 for the paper).
    strips : int
        ``method='refine'``: 1, or 2 when the image was meshed as two strips
        on two threads (`rangemesh.refine.strips`); 0 for the paper.
    heights : {'fit', 'pixel'}
        Vertex depths: least-squares fit or copied from the pixel.
    flip_tests : dict of str to int
        How many edges each of the paper's flip tests rejected
        (``t1_deadlock`` ... ``final_test``) and how many were ``flipped``;
        empty without them.
    seconds : dict of str to float
        Wall time of each stage (``'prepare'``, ``'sampling'``,
        ``'triangulation'``, ``'flipping'`` for the paper; ``'insertion'``,
        ``'fit'`` for refine), of a target search (``'search'``) and
        ``'total'``.
    target : Target or None
        What the target asked and what was achieved; None when the paper's
        method ran on its grid without a target.
    reason : str
        Empty for a normal mesh; for an empty mesh, why it is empty.
    """

    vertices: int = 0
    edges: int = 0
    triangles: int = 0
    flipped_edges: int = 0
    grid_shape: tuple[int, int] | None = (0, 0)
    sampled_points: int = 0
    flip_tests: dict = field(default_factory=dict)
    seconds: dict = field(default_factory=dict)
    target: Target | None = None
    reason: str = ""
    method: str = "paper"
    insertions: int = 0
    strips: int = 0
    heights: str = "pixel"

    def to_dict(self) -> dict:
        """Plain-Python dictionary (JSON-ready)."""
        d = asdict(self)
        d["grid_shape"] = None if self.grid_shape is None else list(self.grid_shape)
        d["target"] = None if self.target is None else self.target.to_dict()
        return d


def check_arrays(vertices: np.ndarray, faces: np.ndarray, pixels: np.ndarray | None = None,
                 image_shape=None, *, what: str = "mesh") -> None:
    """Refuse arrays that cannot be a mesh: checked before anything is sized by them.

    Parameters
    ----------
    vertices : (V, 3) ndarray
    faces : (F, 3) ndarray of int
    pixels : (V, 2) or (0, 2) ndarray of int, optional
    image_shape : (int, int), optional
        With `pixels`: every pixel must lie inside it.
    what : str
        How the message names the mesh (a file name, say).

    Raises
    ------
    ValueError
        Vertices not (V, 3) or not finite; faces not (F, 3) integers, or an
        index negative or not below V; pixels of the wrong shape or outside
        the image.
    """
    if vertices.ndim != 2 or vertices.shape[1] != 3:
        raise ValueError(f"{what}: vertices must be (V, 3), got shape {vertices.shape}")
    if not np.isfinite(vertices).all():
        bad = int((~np.isfinite(vertices).all(axis=1)).sum())
        raise ValueError(f"{what}: {bad} vertices are not finite (NaN or infinite coordinates)")
    if faces.ndim != 2 or (faces.size and faces.shape[1] != 3):
        raise ValueError(f"{what}: only triangle meshes are supported (faces of shape {faces.shape})")
    if faces.size and not np.issubdtype(faces.dtype, np.integer):
        raise ValueError(f"{what}: face indices must be integers, got {faces.dtype}")
    if faces.size:
        lo, hi = int(faces.min()), int(faces.max())
        if lo < 0 or hi >= len(vertices):
            bad = lo if lo < 0 else hi
            raise ValueError(f"{what}: face index {bad} is out of range for {len(vertices)} "
                             f"vertices (indices run from 0 to {len(vertices) - 1})")
    if pixels is not None and len(pixels):
        if pixels.shape != (len(vertices), 2):
            raise ValueError(f"{what}: pixels must be (V, 2) = ({len(vertices)}, 2), "
                             f"got {pixels.shape}")
        if image_shape is not None and tuple(image_shape) != (0, 0):
            h, w = image_shape
            outside = ((pixels[:, 0] < 0) | (pixels[:, 0] >= h)
                       | (pixels[:, 1] < 0) | (pixels[:, 1] >= w))
            if outside.any():
                raise ValueError(f"{what}: {int(outside.sum())} vertex pixels (row, col) lie "
                                 f"outside the {h}x{w} image")
# the face ids `count_edges` hands the kernel as they are
_FACE_TYPES = (np.dtype(np.int32), np.dtype(np.int64))


def count_edges(faces: np.ndarray) -> int:
    """Number of distinct undirected edges of a face array.

    Parameters
    ----------
    faces : (F, 3) array of int

    Returns
    -------
    int

    Examples
    --------
    >>> count_edges(np.array([[0, 1, 2], [2, 1, 3]]))
    5
    """
    faces = np.asarray(faces)
    # the kernel takes int32 (a mesh's own) and int64 ids: no copy of millions of faces
    faces = np.ascontiguousarray(faces, dtype=faces.dtype if faces.dtype in _FACE_TYPES else np.int64)
    if len(faces) == 0:
        return 0
    if faces.min() < 0:
        raise ValueError(f"face index {int(faces.min())} is negative")
    from . import _core

    return int(_core.count_edges(faces, int(faces.max()) + 1))


@dataclass(frozen=True, eq=False)
class Mesh:
    """A triangle mesh made from a range image.

    Attributes
    ----------
    vertices : (V, 3) ndarray of float64
        3-D points, in the camera's 3-D space.
    faces : (F, 3) ndarray of int32
        Vertex indices, counter-clockwise in the image plane: the signed area
        ``(r1-r0)*(c2-c0) - (c1-c0)*(r2-r0)`` of every face is positive, which is
        counter-clockwise on screen when rows run down and columns right.
    pixels : (V, 2) ndarray of int32
        The ``(row, col)`` pixel each vertex came from.
    camera : Orthographic, Pinhole, Spherical or Rays
        The mapping used to lift pixels to 3-D.
    image_shape : (int, int)
        Shape of the range image the mesh was made from.
    stats : Stats
        Counts, timings and, for an empty mesh, the reason.
    colors : (V, 3) ndarray of uint8 or None
        Per-vertex RGB colours (`with_colors`), written to PLY, OBJ and GLB.
    texture : (H, W, 3) ndarray of uint8 or None
        The colour image, written as the texture of OBJ and GLB files with
        `uv` as texture coordinates.
    attributes : dict of str to (V,) ndarray of float32
        Scalar per-vertex values (`with_attribute`, e.g. a LiDAR
        ``intensity``), written to PLY (and GLB as ``_name``).

    Notes
    -----
    With a wrap-around image (`MeshParams.wrap`) the faces that close the
    360-degree seam are counter-clockwise once their column-0 vertices are
    moved to column W, and so clockwise in the image plane
    (`rangemesh.geometry.seam`).
    """

    vertices: np.ndarray
    faces: np.ndarray
    pixels: np.ndarray
    camera: Orthographic | Pinhole | Spherical | Rays
    image_shape: tuple[int, int]
    stats: Stats = field(default_factory=Stats)
    colors: np.ndarray | None = None
    texture: np.ndarray | None = None
    attributes: dict = field(default_factory=dict)

    @property
    def is_empty(self) -> bool:
        """True when the mesh has no triangle."""
        return len(self.faces) == 0

    def with_colors(self, image, *, how: str = "pixel", texture: bool = True) -> Mesh:
        """A copy with per-vertex colours from an image registered with the range image.

        Parameters
        ----------
        image : (H, W, 3), (H, W, 4) or (H, W) array_like
            RGB(A) or grey, same height and width as the range image: an RGB-D
            camera's colour frame, or a LiDAR intensity image (grey). Converted
            by `rangemesh.attributes.as_rgb8`.
        how : {'pixel', 'mean'}, default 'pixel'
            The vertex's own pixel, or the mean over the pixels it stands for
            (`rangemesh.attributes.vertex_values`).
        texture : bool, default True
            Keep the image as the mesh's texture (written by OBJ and GLB).

        Returns
        -------
        Mesh

        Examples
        --------
        >>> import numpy as np, rangemesh
        >>> m = rangemesh.triangulate(np.ones((4, 5)), vertices=4)
        >>> rgb = np.zeros((4, 5, 3), np.uint8); rgb[..., 0] = 200
        >>> m.with_colors(rgb).colors[0].tolist()
        [200, 0, 0]
        """
        import dataclasses

        from .attributes import as_rgb8, vertex_values

        rgb = as_rgb8(image)
        values = vertex_values(self, rgb, how)
        colors = np.clip(np.round(values), 0, 255).astype(np.uint8)
        return dataclasses.replace(self, colors=colors, texture=rgb if texture else None)

    def with_attribute(self, name: str, image, *, how: str = "pixel") -> Mesh:
        """A copy with a scalar per-vertex attribute from a registered (H, W) image.

        Parameters
        ----------
        name : str
            A plain identifier (letters, digits, ``_``), e.g. ``'intensity'``;
            it names the PLY property.
        image : (H, W) array_like of numbers
        how : {'pixel', 'mean'}, default 'pixel'

        Returns
        -------
        Mesh
        """
        import dataclasses

        from .attributes import vertex_values

        if not (isinstance(name, str) and name.isidentifier() and name.isascii()):
            raise ValueError(f"an attribute name is a plain identifier, got {name!r}")
        if name in ("x", "y", "z", "nx", "ny", "nz", "red", "green", "blue", "row", "col"):
            raise ValueError(f"{name!r} is taken by a vertex property of the mesh files")
        img = np.asarray(image)
        if img.ndim != 2 or not np.issubdtype(img.dtype, np.number):
            raise ValueError(f"an attribute image is (H, W) numbers, got {img.dtype} {img.shape}")
        values = vertex_values(self, img, how).astype(np.float32)
        return dataclasses.replace(self, attributes={**self.attributes, name: values})

    @property
    def uv(self) -> np.ndarray:
        """Texture coordinates ``(col / (W-1), row / (H-1))`` of each vertex's own pixel."""
        from .attributes import texture_uv

        return texture_uv(self)

    def vertex_normals(self) -> np.ndarray:
        """Unit per-vertex normals facing the sensor (`rangemesh.attributes.vertex_normals`)."""
        from .attributes import vertex_normals

        return vertex_normals(self)

    def to_trimesh(self):
        """Return a `trimesh.Trimesh` with the same vertices and faces (no merging).

        Vertex colours, normals (facing the sensor) and attributes come along
        (``vertex_attributes``).

        Returns
        -------
        trimesh.Trimesh
        """
        from ._optional import require

        trimesh = require("trimesh", "Mesh.to_trimesh")
        tm = trimesh.Trimesh(self.vertices, self.faces, process=False,
                             vertex_colors=self.colors,
                             vertex_normals=None if self.is_empty else self.vertex_normals())
        for name, values in self.attributes.items():
            tm.vertex_attributes[name] = values
        return tm

    def to_open3d(self):
        """Return an ``open3d.geometry.TriangleMesh`` (Open3D is imported only here).

        Vertices, faces, vertex normals (facing the sensor) and vertex colours
        (as floats in [0, 1]) are copied.

        Returns
        -------
        open3d.geometry.TriangleMesh

        Raises
        ------
        ImportError
            Open3D is not installed (``pip install open3d``).
        """
        from ._optional import require

        o3d = require("open3d", "Mesh.to_open3d")
        out = o3d.geometry.TriangleMesh(
            o3d.utility.Vector3dVector(np.ascontiguousarray(self.vertices, np.float64)),
            o3d.utility.Vector3iVector(np.ascontiguousarray(self.faces, np.int32)))
        if not self.is_empty:
            out.vertex_normals = o3d.utility.Vector3dVector(self.vertex_normals())
        if self.colors is not None:
            out.vertex_colors = o3d.utility.Vector3dVector(self.colors / 255.0)
        return out

    def __repr__(self) -> str:
        s = self.stats
        extra = f", reason={s.reason!r}" if s.reason else ""
        return (
            f"Mesh(vertices={len(self.vertices)}, faces={len(self.faces)}, "
            f"flipped_edges={s.flipped_edges}, image_shape={self.image_shape}{extra})"
        )


def empty_mesh(camera, image_shape, stats: Stats) -> Mesh:
    """A well-formed mesh with no vertex and no face, carrying `stats`."""
    return Mesh(
        vertices=np.zeros((0, 3), np.float64),
        faces=np.zeros((0, 3), np.int32),
        pixels=np.zeros((0, 2), np.int32),
        camera=camera,
        image_shape=tuple(image_shape),
        stats=stats,
    )
