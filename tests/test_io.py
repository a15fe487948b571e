"""rangemesh.io: the image and mesh readers and writers, and files that lie."""

import json
import os

import numpy as np
import pytest

import rangemesh
from rangemesh import Spherical
from rangemesh.cli import main
from rangemesh.io import read_mesh, write_mesh

from .golden import crops
from .helpers import one_error_line

# ---------------------------------------------------------------- from the hostile-input reports


def _ply_with_faces(path, mesh, faces, rows=None):
    from plyfile import PlyData, PlyElement

    fields = [("x", "f4"), ("y", "f4"), ("z", "f4")] + ([("row", "i4"), ("col", "i4")]
                                                        if rows is not None else [])
    v = np.zeros(len(mesh.vertices), fields)
    v["x"], v["y"], v["z"] = mesh.vertices.T
    if rows is not None:
        v["row"], v["col"] = rows.T
    f = np.zeros(len(faces), [("vertex_indices", "i4", (3,))])
    f["vertex_indices"] = faces
    PlyData([PlyElement.describe(v, "vertex"), PlyElement.describe(f, "face")]).write(str(path))


def _cameras(os1):
    beams = os1["beams"]
    return {
        "orthographic": (np.full((6, 7), 10.0), rangemesh.Orthographic(0.5, 0.5, 2.0)),
        "pinhole": (np.full((6, 7), 1000.0), rangemesh.Pinhole(5.0, 5.0, 3.0, 2.5, 0.001)),
        "spherical": (np.load(os1["range"]), Spherical.from_beams(beams)),
    }


def _ascii_ply(tmp_path, mesh, name="m.ply"):
    path = tmp_path / name
    write_mesh(mesh, path, ascii=True)
    return path


# D18 of the 2026-11-21 hostile-input report
def test_an_empty_pcd_and_a_truncated_tiff_give_one_line(tmp_path, capsys):
    import tifffile

    pytest.importorskip("pypcd4")
    (tmp_path / "empty.pcd").write_bytes(b"")
    one_error_line(capsys, main(["mesh", str(tmp_path / "empty.pcd")]))
    tifffile.imwrite(tmp_path / "t.tiff", np.ones((200, 200), np.float32))
    data = (tmp_path / "t.tiff").read_bytes()
    for cut in (len(data) // 2, 8, 16):
        (tmp_path / "half.tiff").write_bytes(data[:cut])
        one_error_line(capsys, main(["mesh", str(tmp_path / "half.tiff")]))


# D23, D24, D25 of the 2026-11-21 hostile-input report
@pytest.mark.parametrize("bad_index", [2**31 - 1, "V+10", -5, -1])
def test_face_indices_out_of_range_are_refused(chair_file, chair, tmp_path, capsys,
                                                           bad_index):
    m = rangemesh.triangulate(chair, background=0, method="paper")
    faces = m.faces.copy()
    faces[0, 0] = len(m.vertices) + 10 if bad_index == "V+10" else bad_index
    _ply_with_faces(tmp_path / "bad.ply", m, faces)
    code = main(["eval", str(chair_file), str(tmp_path / "bad.ply")])
    one_error_line(capsys, code, match="out of range")
    with pytest.raises(ValueError, match="out of range"):
        rangemesh.read_mesh(tmp_path / "bad.ply")


# D27 of the 2026-11-21 hostile-input report
def test_nonsense_mesh_files_are_refused(chair_file, chair, tmp_path, capsys):
    (tmp_path / "text.obj").write_text("hello world\n")
    one_error_line(capsys, main(["eval", str(chair_file), str(tmp_path / "text.obj")]),
                   match="no triangle")
    m = rangemesh.triangulate(chair, background=0, method="paper")
    _ply_with_faces(tmp_path / "off.ply", m, m.faces, rows=m.pixels + [1000, 0])
    one_error_line(capsys, main(["eval", str(chair_file), str(tmp_path / "off.ply")]),
                   match="outside")
    import dataclasses

    bad = dataclasses.replace(m, vertices=np.where(np.arange(len(m.vertices))[:, None] == 3,
                                                   np.inf, m.vertices))
    _ply_with_faces(tmp_path / "inf.ply", bad, bad.faces)  # another writer: ours refuses
    one_error_line(capsys, main(["eval", str(chair_file), str(tmp_path / "inf.ply")]),
                   match="not finite")
    with pytest.raises(ValueError, match="not finite"):
        rangemesh.write_mesh(bad, tmp_path / "never.ply")
    assert not (tmp_path / "never.ply").exists()


# the second run of the 2026-11-21 hostile-input report
def test_folders_and_pipes_are_not_files(tmp_path, capsys):
    with pytest.raises(ValueError, match="folder"):
        rangemesh.read_range_image(tmp_path)
    fifo = tmp_path / "f.npy"
    os.mkfifo(fifo)
    one_error_line(capsys, main(["mesh", str(fifo)]), match="regular file")


# E4 of the 2026-11-25 hostile-input report
def test_a_camera_comment_for_another_shape_is_refused_before_sizing(tmp_path):
    mesh = rangemesh.triangulate(np.full((4, 5), 10.0), method="refine", vertices=6)
    path = tmp_path / "m.ply"
    write_mesh(mesh, path, ascii=True)
    text = path.read_text()
    # the report's crafted camera: W = 1e8 columns for a 4x5 image (6 GB of rays if built)
    text = text.replace("comment rangemesh camera orthographic 1.0 1.0 1.0",
                        "comment rangemesh camera spherical 1 100000000 1.0 0 0.1 5 0")
    path.write_text(text)
    with pytest.raises(ValueError, match="1x100000000 image, not for this 4x5"):
        read_mesh(path)


# E4 of the 2026-11-25 hostile-input report
def test_header_counts_beyond_the_file_are_refused(tmp_path):
    mesh = rangemesh.triangulate(np.full((4, 5), 10.0), method="refine", vertices=6)
    for ascii_ in (True, False):
        path = tmp_path / f"m{ascii_}.ply"
        write_mesh(mesh, path, ascii=ascii_)
        data = path.read_bytes()
        n = len(mesh.faces)
        path.write_bytes(data.replace(f"element face {n}\n".encode(), b"element face 300000000\n"))
        with pytest.raises(ValueError, match="claims 300000000 face elements"):
            read_mesh(path)


# the 2026-11-25 hostile-input report
@pytest.mark.parametrize("kind", ["orthographic", "pinhole", "spherical"])
def test_ply_header_lines_fit_common_readers_and_keep_the_camera(os1, tmp_path, kind, open3d):
    image, cam = _cameras(os1)[kind]
    bg = 0 if kind == "spherical" else None
    mesh = rangemesh.triangulate(image, camera=cam, background=bg, method="refine", vertices=300)
    path = tmp_path / f"{kind}.ply"
    write_mesh(mesh, path)
    header = path.read_bytes().split(b"end_header")[0]
    assert max(len(line) for line in header.split(b"\n")) < 1024
    back = read_mesh(path)
    assert back.camera == cam
    trimesh = pytest.importorskip("trimesh")
    tm = trimesh.load(path, process=False, force="mesh")
    assert np.array_equal(np.asarray(tm.faces), mesh.faces)
    meshio = pytest.importorskip("meshio")
    mi = meshio.read(path)
    np.testing.assert_array_equal(mi.points, mesh.vertices.astype(np.float32))
    # Open3D aborts the whole process on a header line it cannot take: read in a child process
    import subprocess
    import sys

    code = ("import sys, open3d as o3d; m = o3d.io.read_triangle_mesh(sys.argv[1]); "
            "print(len(m.vertices), len(m.triangles))")
    p = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True,
                       timeout=120)
    assert p.returncode == 0, p.stderr[-500:]
    assert p.stdout.split()[-2:] == [str(len(mesh.vertices)), str(len(mesh.faces))]


# E26 of the 2026-11-25 hostile-input report
def test_non_integer_face_indices_are_refused(tmp_path):
    mesh = rangemesh.triangulate(np.full((4, 5), 10.0), method="refine", vertices=6)
    path = _ascii_ply(tmp_path, mesh)
    text = path.read_text().replace("property list uchar int vertex_indices",
                                    "property list uchar double vertex_indices")
    lines = text.splitlines()
    first_face = len(lines) - len(mesh.faces)
    a, b, c = mesh.faces[0]
    lines[first_face] = f"3 {a} {b} {c}.5"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(ValueError, match="whole numbers"):
        read_mesh(path)
    lines[first_face] = f"3 {a} {b} {c}.0"  # whole values in a double list are indices
    path.write_text("\n".join(lines) + "\n")
    assert np.array_equal(read_mesh(path).faces, mesh.faces)


# E26 of the 2026-11-25 hostile-input report
@pytest.mark.parametrize("comment", ["pinhole 0 0 0 0 0", "orthographic 0 1 1", "rays",
                                     "spherical 4 5 1.0 0 nan 1 2 3 4 0 0 0 0"])
def test_a_camera_comment_that_cannot_be_read_is_said(tmp_path, comment):
    mesh = rangemesh.triangulate(np.full((4, 5), 10.0), method="refine", vertices=6)
    path = _ascii_ply(tmp_path, mesh)
    path.write_text(path.read_text().replace("rangemesh camera orthographic 1.0 1.0 1.0",
                                             "rangemesh camera " + comment))
    with pytest.raises(ValueError, match="records a camera that cannot be read back"):
        read_mesh(path)
    # with the camera given, the file reads
    assert len(read_mesh(path, camera=rangemesh.Orthographic()).faces) == len(mesh.faces)


# E23 of the 2026-11-25 hostile-input report
@pytest.mark.parametrize("ascii_", [True, False])
def test_double_face_indices_beyond_int32_are_refused_quietly(tmp_path, ascii_):
    import warnings

    from plyfile import PlyData, PlyElement

    v = np.zeros(4, dtype=[("x", "f4"), ("y", "f4"), ("z", "f4")])
    v["x"], v["y"] = [0, 1, 0, 1], [0, 0, 1, 1]
    f = np.zeros(2, dtype=[("vertex_indices", "f8", (3,))])
    f["vertex_indices"] = [[0, 1, 2], [1, 3, 4294967301.0]]
    path = tmp_path / "m.ply"
    PlyData([PlyElement.describe(v, "vertex"), PlyElement.describe(f, "face")],
            text=ascii_).write(str(path))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match="face index is out of range"):
            read_mesh(path)


# E23 of the 2026-11-25 hostile-input report
def test_a_subnormal_depth_scale_mesh_file_evaluates_as_made(tmp_path, capsys):
    src = tmp_path / "chair.npy"
    np.save(src, crops()["chair"][0])
    out = tmp_path / "c.ply"
    assert main(["mesh", str(src), "--intrinsics", "525,525,64,64", "--depth-scale", "1e-310",
                 "--vertices", "500", "-o", str(out), "--json"]) == 0
    made = json.loads(capsys.readouterr().out)["evaluation"]
    # float32 would write the 3-D depths (about 1e-308) as 0: the file then covered nothing
    assert main(["eval", str(src), str(out), "--json"]) == 0
    got = json.loads(capsys.readouterr().out)
    assert got["relative_error"] == pytest.approx(made["relative_error"], rel=1e-6)
    assert got["uncovered"] == 0.0
