"""A mesh as a ``foxglove.SceneUpdate`` protobuf message, built from its arrays as they are.

The message has one `SceneEntity` holding one `TriangleListPrimitive`: the
mesh's vertices as ``points``, its faces as ``indices`` (shared vertices),
its vertex colours as ``colors`` when it has any, else one grey ``color``.
The repeated fields are written by numpy as fixed-size records (a
``Point3`` is 29 bytes: tag, length and three tagged doubles), so no Python
object is made per vertex; the layout is that of the schema the
``foxglove-sdk`` publishes (`SCENE_FIELDS`, checked by the tests against it).
"""

from __future__ import annotations

import numpy as np

__all__ = ["scene_update_bytes", "GREY", "OPTICAL_ROTATION", "ENTITY_ID"]

GREY = (0.8, 0.8, 0.8, 1.0)  # the one colour of a mesh without vertex colours
ENTITY_ID = "mesh"
# parent (x forward, y left, z up) to a camera's optical frame (x right, y down, z forward): x, y, z, w
OPTICAL_ROTATION = (-0.5, 0.5, -0.5, 0.5)

# (message, field) -> field number in foxglove's protobuf schemas
SCENE_FIELDS = {
    ("SceneUpdate", "entities"): 2,
    ("SceneEntity", "timestamp"): 1, ("SceneEntity", "frame_id"): 2, ("SceneEntity", "id"): 3,
    ("SceneEntity", "triangles"): 12,
    ("TriangleListPrimitive", "pose"): 1, ("TriangleListPrimitive", "points"): 2,
    ("TriangleListPrimitive", "color"): 3, ("TriangleListPrimitive", "colors"): 4,
    ("TriangleListPrimitive", "indices"): 5,
    ("Pose", "orientation"): 2, ("Quaternion", "w"): 4,
    ("Timestamp", "seconds"): 1, ("Timestamp", "nanos"): 2,
}
_F = SCENE_FIELDS
_LEN, _I64, _VARINT = 2, 1, 0  # protobuf wire types
_I32 = np.dtype("<i4")

# a Point3 in `points`: tag, length 27, then x, y, z each a tag and a little-endian double
_POINT = np.dtype([("tag", "u1"), ("len", "u1"), ("tx", "u1"), ("x", "<f8"), ("ty", "u1"),
                   ("y", "<f8"), ("tz", "u1"), ("z", "<f8")])
# a Color in `colors`: tag, length 36, then r, g, b, a
_COLOR = np.dtype([("tag", "u1"), ("len", "u1"), ("tr", "u1"), ("r", "<f8"), ("tg", "u1"),
                   ("g", "<f8"), ("tb", "u1"), ("b", "<f8"), ("ta", "u1"), ("a", "<f8")])


def _varint(n: int) -> bytes:
    out = bytearray()
    while True:
        byte, n = n & 0x7F, n >> 7
        if n:
            out.append(byte | 0x80)
        else:
            out.append(byte)
            return bytes(out)


def _tag(number: int, wire: int) -> bytes:
    return _varint(number << 3 | wire)


def _field(number: int, payload: bytes) -> bytes:
    """A length-delimited field: tag, length, payload."""
    return _tag(number, _LEN) + _varint(len(payload)) + payload


def _double(number: int, value: float) -> bytes:
    return _tag(number, _I64) + np.float64(value).astype("<f8").tobytes()


def _timestamp(stamp: int) -> bytes:
    sec, nsec = divmod(int(stamp), 1_000_000_000)
    out = b""
    if sec:  # proto3: a zero is left out
        out += _tag(_F["Timestamp", "seconds"], _VARINT) + _varint(sec)
    if nsec:
        out += _tag(_F["Timestamp", "nanos"], _VARINT) + _varint(nsec)
    return out


def _records(dtype, number: int, columns: dict) -> bytes:
    """Fixed-size submessages, one per row: tags filled, then each double column.

    Every byte of a record is a field's (the dtypes are packed): `numpy.empty`,
    not `numpy.zeros`, whose zeroing lets go of the GIL (a waiting worker may take it).
    """
    n = len(next(iter(columns.values())))
    rec = np.empty(n, dtype)
    rec["tag"] = number << 3 | _LEN
    rec["len"] = dtype.itemsize - 2
    for i, name in enumerate(columns):
        rec["t" + name] = (i + 1) << 3 | _I64
        rec[name] = columns[name]
    return rec.tobytes()


def scene_update_bytes(vertices, faces, stamp: int, frame_id: str, colors=None) -> bytes:
    """A mesh as a serialised ``foxglove.SceneUpdate`` (protobuf).

    Parameters
    ----------
    vertices : (V, 3) array_like of float
    faces : (F, 3) array_like of int
        Indices into `vertices`.
    stamp : int
        The frame's stamp, nanoseconds.
    frame_id : str
    colors : (V, 3) array_like of uint8, optional
        Per-vertex RGB.

    Returns
    -------
    bytes
    """
    v = np.asarray(vertices, np.float64).reshape(-1, 3)
    f = np.asarray(faces)
    # int32 faces (the meshes') are their uint32 bytes: a view, where a cast's copy releases the GIL
    f = f.reshape(-1).view("<u4") if f.dtype == _I32 and f.flags.c_contiguous else \
        np.ascontiguousarray(f, dtype="<u4").reshape(-1)
    tri = _field(_F["TriangleListPrimitive", "pose"],
                 _field(_F["Pose", "orientation"], _double(_F["Quaternion", "w"], 1.0)))
    if len(v):
        tri += _records(_POINT, _F["TriangleListPrimitive", "points"],
                        {"x": v[:, 0], "y": v[:, 1], "z": v[:, 2]})
    if colors is not None and len(v):
        c = np.asarray(colors, np.float64).reshape(-1, 3) / 255.0
        tri += _records(_COLOR, _F["TriangleListPrimitive", "colors"],
                        {"r": c[:, 0], "g": c[:, 1], "b": c[:, 2], "a": np.ones(len(c))})
    else:
        tri += _field(_F["TriangleListPrimitive", "color"],
                      b"".join(_double(i + 1, x) for i, x in enumerate(GREY)))
    if len(f):
        tri += _field(_F["TriangleListPrimitive", "indices"], f.tobytes())
    entity = (_field(_F["SceneEntity", "timestamp"], _timestamp(stamp))
              + _field(_F["SceneEntity", "frame_id"], frame_id.encode())
              + _field(_F["SceneEntity", "id"], ENTITY_ID.encode())
              + _field(_F["SceneEntity", "triangles"], tri))
    return _field(_F["SceneUpdate", "entities"], entity)
