"""rangemesh.io: the readers and writers, atomic outputs, file modes, and files that lie."""

import json
import os
import signal
import stat
from pathlib import Path

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


# D14 of the 2026-11-21 hostile-input report
def test_an_output_that_is_a_folder_is_one_line(chair_file, tmp_path, capsys):
    (tmp_path / "adir.ply").mkdir()
    code = main(["mesh", str(chair_file), "-o", str(tmp_path / "adir.ply")])
    one_error_line(capsys, code, match="folder")


# D14 of the 2026-11-21 hostile-input report
@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_a_read_only_output_folder_is_one_line(chair_file, tmp_path, capsys):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        code = main(["mesh", str(chair_file), "-o", str(ro / "o.ply")])
    finally:
        ro.chmod(0o755)
    one_error_line(capsys, code, match="Permission denied")


# D14 of the 2026-11-21 hostile-input report
def test_permission_denied_names_the_output(chair_file, tmp_path, capsys, monkeypatch):
    import errno
    import tempfile

    def denied(*args, dir=None, **kwargs):
        raise PermissionError(errno.EACCES, "Permission denied", str(Path(dir) / ".o.ply.x.part.ply"))

    monkeypatch.setattr(tempfile, "mkstemp", denied)
    line = one_error_line(capsys, main(["mesh", str(chair_file), "-o", str(tmp_path / "o.ply")]))
    assert line == f"rangemesh: error: {tmp_path / 'o.ply'}: Permission denied"


# D14 of the 2026-11-21 hostile-input report
@pytest.mark.parametrize("suffix, target", [(".ply", "write"),
                                            (".png", "matplotlib.figure.Figure.savefig")])
def test_a_full_disk_leaves_no_file(chair_file, tmp_path, capsys, monkeypatch, suffix, target):
    import errno

    import rangemesh.io as rio

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    if target == "write":  # the PLY writer of the table of formats
        monkeypatch.setattr(rio.FORMATS[".ply"], "write", full)
    else:
        monkeypatch.setattr(target, full)
    args = ["mesh", str(chair_file)]
    args += ["-o", str(tmp_path / "o.ply")] if suffix == ".ply" else ["--preview", str(tmp_path / "p.png")]
    line = one_error_line(capsys, main(args), match="No space left on device")
    assert "o.ply" in line or "p.png" in line  # the target, not the temporary name
    assert sorted(p.name for p in tmp_path.iterdir()) == ["chair.npy"]


# D15 of the 2026-11-21 hostile-input report
@pytest.mark.parametrize("umask, mode", [(0o022, 0o644), (0o002, 0o664), (0o077, 0o600)])
def test_outputs_follow_the_umask(chair_file, tmp_path, umask, mode):
    old = os.umask(umask)
    try:
        assert main(["mesh", str(chair_file), "-o", str(tmp_path / "m.ply"),
                     "--preview", str(tmp_path / "m.png"), "--quiet"]) == 0
    finally:
        os.umask(old)
    for name in ("m.ply", "m.png"):
        assert stat.S_IMODE((tmp_path / name).stat().st_mode) == mode


# D15 of the 2026-11-21 hostile-input report
def test_an_overwritten_file_keeps_its_mode(chair_file, tmp_path):
    out = tmp_path / "m.obj"
    out.write_text("old")
    out.chmod(0o640)
    assert main(["mesh", str(chair_file), "-o", str(out), "--quiet"]) == 0
    assert stat.S_IMODE(out.stat().st_mode) == 0o640 and out.read_text() != "old"


# D17 of the 2026-11-21 hostile-input report
@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGHUP, signal.SIGINT])
def test_a_signal_while_writing_leaves_nothing(chair_file, tmp_path, monkeypatch, capsys, signum):
    import rangemesh.io as rio

    real = rio.FORMATS[".ply"].write

    def write_then_signal(mesh, path, tmp, *args):
        real(mesh, path, tmp, *args)  # the temporary file exists and is complete
        os.kill(os.getpid(), signum)

    monkeypatch.setattr(rio.FORMATS[".ply"], "write", write_then_signal)
    (tmp_path / "out.ply").write_text("old")
    code = main(["mesh", str(chair_file), "-o", str(tmp_path / "out.ply"), "--quiet"])
    assert code == 128 + signum
    assert "interrupted" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["chair.npy", "out.ply"]
    assert (tmp_path / "out.ply").read_text() == "old"
    assert signal.getsignal(signal.SIGTERM) == signal.SIG_DFL  # handlers are put back


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


# ---------------------------------------------------------------- the table of formats


def test_the_suffixes_are_those_documented():
    from rangemesh.io import IMAGE_SUFFIXES, MESH_SUFFIXES

    # the README's and read_range_image's list, in their order (issue 43: now made from FORMATS)
    assert IMAGE_SUFFIXES == (".npy", ".png", ".pgm", ".ppm", ".pnm", ".pfm", ".tif", ".tiff",
                              ".pcd")
    assert MESH_SUFFIXES == (".ply", ".obj", ".off", ".stl", ".glb")


def test_unknown_suffixes_are_refused_in_one_line(tmp_path):
    odd = tmp_path / "a.xyz"
    odd.write_text("1 2 3\n")
    mesh = rangemesh.triangulate(np.add.outer(np.arange(6.0), np.arange(7.0)), vertices=8)
    with pytest.raises(ValueError) as got:
        rangemesh.read_range_image(odd)
    assert str(got.value) == (f"{odd}: unknown image type '.xyz'; known: .npy, .png, .pgm, "
                              f".ppm, .pnm, .pfm, .tif, .tiff, .pcd")
    with pytest.raises(ValueError) as got:
        read_mesh(odd)
    assert str(got.value) == f"{odd}: unknown mesh format '.xyz'; known: .ply, .obj, .off, .stl, .glb"
    with pytest.raises(ValueError) as got:
        write_mesh(mesh, odd)
    assert str(got.value) == (f"{odd}: unknown mesh format '.xyz'; use one of .ply, .obj, .off, "
                              f".stl, .glb")
    # a mesh suffix is no image, and an image suffix no mesh
    ply = tmp_path / "m.ply"
    ply.touch()
    with pytest.raises(ValueError, match="unknown image type '.ply'"):
        rangemesh.read_range_image(ply)
    with pytest.raises(ValueError, match="unknown mesh format '.png'; use one of"):
        write_mesh(mesh, tmp_path / "m.png")
    with pytest.raises(ValueError, match="ascii and pixels apply to PLY files only"):
        write_mesh(mesh, tmp_path / "m.obj", ascii=True)


def test_a_format_is_one_entry_of_the_table(tmp_path, monkeypatch):
    import rangemesh.io as rio
    from rangemesh.io.mesh_readers import _MeshFile

    def read_xyz(path):
        return np.loadtxt(path, ndmin=2)

    def write_vf(mesh, path, tmp, ascii, pixels, normals):
        with open(tmp, "wb") as fh:
            np.savez(fh, v=mesh.vertices, f=mesh.faces)

    def read_vf(path, camera, image_shape):
        with np.load(path) as got:
            return _MeshFile(got["v"], got["f"])

    monkeypatch.setitem(rio.FORMATS, ".xyz", rio.Format("image", read_xyz))
    monkeypatch.setitem(rio.FORMATS, ".vf", rio.Format("mesh", read_vf, write_vf))
    image = tmp_path / "d.xyz"
    image.write_text("1 2 3\n4 5 6\n")
    np.testing.assert_array_equal(rangemesh.read_range_image(image), [[1, 2, 3], [4, 5, 6]])
    mesh = rangemesh.triangulate(np.add.outer(np.arange(6.0), np.arange(7.0)), vertices=8)
    out = write_mesh(mesh, tmp_path / "m.vf")  # through atomic_path: the temporary is renamed
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.xyz", "m.vf"]
    back = read_mesh(out)
    np.testing.assert_array_equal(back.vertices, mesh.vertices)
    np.testing.assert_array_equal(back.faces, mesh.faces)
    unknown = tmp_path / "d.abc"
    unknown.touch()
    with pytest.raises(ValueError, match=r"known: \.npy, .*, \.pcd, \.xyz$"):
        rangemesh.read_range_image(unknown)
    with pytest.raises(ValueError, match=r"known: \.ply, .*, \.glb, \.vf$"):
        read_mesh(unknown)
    with pytest.raises(ValueError, match="unknown mesh format '.xyz'"):  # an image format
        write_mesh(mesh, tmp_path / "m.xyz")
