"""rangemesh.io.formats: the table of formats by suffix, and the suffixes it gives the entry points."""

import numpy as np
import pytest

import rangemesh
from rangemesh.io import read_mesh, write_mesh


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
