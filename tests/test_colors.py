"""Colour, attributes, texture coordinates and normals: computed, written, read back by other libraries."""

import sys
import types

import imageio.v3 as iio
import numpy as np
import pytest

from rangemesh import Orthographic, Pinhole, triangulate
from rangemesh.attributes import as_rgb8
from rangemesh.io import read_mesh, write_mesh

from .images import lidar_scan, rgbd_frame

# TUM freiburg1 intrinsics (slambook2's camera): the frame in metres
CAMERA = Pinhole(517.3, 516.5, 318.6, 255.3, depth_scale=0.001)


@pytest.fixture(scope="module")
def frame():
    """A registered 480 x 640 RGB-D pair (tests/images.py) and its mesh with colours."""
    depth, rgb = rgbd_frame((480, 640))
    mesh = triangulate(depth, camera=CAMERA, background=0, vertices=1500, color=rgb)
    return depth, rgb, mesh


def _own_pixels(mesh, image):
    return image[mesh.pixels[:, 0], mesh.pixels[:, 1]]


# --- what the mesh holds ----------------------------------------------------------------


def test_colors_are_the_vertex_pixels(frame):
    _, rgb, mesh = frame
    np.testing.assert_array_equal(mesh.colors, _own_pixels(mesh, rgb))
    np.testing.assert_array_equal(mesh.texture, rgb)


def test_mean_colour_of_a_dense_mesh_is_the_pixel():
    """Every pixel a vertex: each vertex stands for its own pixel only."""
    depth = 5.0 + np.random.default_rng(3).random((6, 7))
    rgb = np.random.default_rng(4).integers(0, 256, (6, 7, 3), dtype=np.uint8)
    mesh = triangulate(depth, vertices=42)
    np.testing.assert_array_equal(mesh.with_colors(rgb, how="mean").colors, _own_pixels(mesh, rgb))


def test_mean_colour_averages_noise():
    """A constant colour with noise: the mean over the pixels a vertex stands for is nearer it."""
    rng = np.random.default_rng(5)
    depth = np.add.outer(np.arange(60.0), np.arange(80.0))  # a plane: few vertices cover it
    grey = np.clip(128 + rng.normal(0, 20, depth.shape), 0, 255).astype(np.uint8)
    mesh = triangulate(depth, vertices=30)
    pixel = mesh.with_colors(grey, how="pixel").colors[:, 0].astype(float)
    mean = mesh.with_colors(grey, how="mean").colors[:, 0].astype(float)
    assert np.abs(mean - 128).mean() < 0.5 * np.abs(pixel - 128).mean()
    const = mesh.with_colors(np.full(depth.shape, 77, np.uint8), how="mean").colors
    assert (const == 77).all()


def test_colour_conversions_by_hand():
    np.testing.assert_array_equal(as_rgb8(np.array([[0, 65535]], np.uint16))[0, :, 0], [0, 255])
    np.testing.assert_array_equal(as_rgb8(np.array([[[0.0, 0.5, 1.0]]]))[0, 0], [0, 128, 255])
    # a one-channel float image is stretched between its 1st and 99th percentiles
    ramp = np.linspace(0.0, 0.01, 101)[None, :]
    out = as_rgb8(ramp)[0, :, 0]
    assert out[0] == 0 and out[1] == 0 and out[-1] == 255 and out[50] in (127, 128)
    with pytest.raises(ValueError, match="registered"):
        triangulate(np.ones((4, 5)), vertices=4, color=np.zeros((5, 4, 3), np.uint8))


def test_attribute_is_the_vertex_pixel(frame):
    depth, _, mesh = frame
    m = mesh.with_attribute("depth_mm", depth)
    np.testing.assert_array_equal(m.attributes["depth_mm"], _own_pixels(mesh, depth))
    with pytest.raises(ValueError, match="plain identifier"):
        mesh.with_attribute("two words", depth)
    with pytest.raises(ValueError, match="taken"):
        mesh.with_attribute("red", depth)


def test_uv_maps_each_vertex_to_its_pixel(frame):
    _, _, mesh = frame
    h, w = mesh.image_shape
    np.testing.assert_allclose(mesh.uv[:, 0] * (w - 1), mesh.pixels[:, 1], atol=1e-9)
    np.testing.assert_allclose(mesh.uv[:, 1] * (h - 1), mesh.pixels[:, 0], atol=1e-9)


# --- normals ------------------------------------------------------------------------------


def test_normals_of_a_wall_facing_a_pinhole_camera():
    """Depth constant: the plane Z = 2 m, whose normal toward the camera is (0, 0, -1)."""
    mesh = triangulate(np.full((30, 40), 2000.0), camera=Pinhole(50, 50, 20, 15, 0.001),
                       vertices=20)
    np.testing.assert_allclose(mesh.vertex_normals(), np.tile([0.0, 0.0, -1.0], (20, 1)),
                               atol=1e-12)


def test_normals_of_a_slanted_plane_by_hand():
    """Orthographic X = r, Y = c, Z = 0.5 r + 2 c: normal +-(0.5, 2, -1) / sqrt(5.25), toward -Z."""
    r, c = np.mgrid[0:20, 0:30]
    mesh = triangulate(0.5 * r + 2.0 * c + 100.0, camera=Orthographic(), vertices=12,
                       heights="pixel")
    expected = np.array([0.5, 2.0, -1.0]) / np.sqrt(5.25)
    np.testing.assert_allclose(mesh.vertex_normals(), np.tile(expected, (12, 1)), atol=1e-12)


def test_normals_face_the_sensor_on_real_data(frame, tmp_path):
    _, _, mesh = frame
    n = mesh.vertex_normals()
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0)
    assert (np.sum(n * -mesh.vertices, axis=1) > 0).mean() > 0.99
    from rangemesh import Spherical

    os1 = lidar_scan(tmp_path)
    rng = np.load(os1["range"])
    cam = Spherical.from_beams(os1["beams"])
    scan = triangulate(rng, camera=cam, background=0, vertices=3000)
    n = scan.vertex_normals()
    assert (np.sum(n * -scan.vertices, axis=1) > 0).mean() > 0.99


# --- files, read back with another library than the writer --------------------------------


def test_ply_colours_normals_attributes_read_back(tmp_path, frame):
    """Colours read by trimesh, normals and the attribute by meshio (the writer is plyfile).

    meshio 5.3 reads ``uchar`` as int8, so it is not asked for the colours.
    """
    meshio = pytest.importorskip("meshio")
    trimesh = pytest.importorskip("trimesh")
    depth, rgb, mesh = frame
    mesh = mesh.with_attribute("depth_mm", depth)
    write_mesh(mesh, tmp_path / "f.ply")
    header = (tmp_path / "f.ply").read_bytes()[:600]
    assert b"property uchar red\nproperty uchar green\nproperty uchar blue\n" in header
    tm = trimesh.load(tmp_path / "f.ply", process=False)
    np.testing.assert_array_equal(tm.visual.vertex_colors[:, :3], _own_pixels(mesh, rgb))
    back = meshio.read(tmp_path / "f.ply")
    normals = np.stack([back.point_data[k] for k in ("nx", "ny", "nz")], axis=1)
    np.testing.assert_allclose(normals, mesh.vertex_normals(), atol=1e-6)
    np.testing.assert_array_equal(back.point_data["depth_mm"], _own_pixels(mesh, depth))
    assert read_mesh(tmp_path / "f.ply").colors.tolist() == mesh.colors.tolist()


def test_obj_colours_and_texture_read_by_trimesh(tmp_path, frame):
    trimesh = pytest.importorskip("trimesh")
    _, rgb, mesh = frame
    write_mesh(mesh, tmp_path / "f.obj")
    assert (tmp_path / "f.mtl").exists()
    np.testing.assert_array_equal(iio.imread(tmp_path / "f.texture.png"), rgb)
    tm = trimesh.load(tmp_path / "f.obj", process=False, maintain_order=True)
    np.testing.assert_allclose(tm.vertices, mesh.vertices, rtol=1e-8)
    h, w = mesh.image_shape
    uv = tm.visual.uv  # OBJ's convention: v up from the bottom of the image
    np.testing.assert_allclose(uv[:, 0] * (w - 1), mesh.pixels[:, 1], atol=1e-5)
    np.testing.assert_allclose((1 - uv[:, 1]) * (h - 1), mesh.pixels[:, 0], atol=1e-5)
    # the texture trimesh found shows each vertex its own pixel
    tex = np.asarray(tm.visual.material.image.convert("RGB"))
    np.testing.assert_array_equal(tex[mesh.pixels[:, 0], mesh.pixels[:, 1]], _own_pixels(mesh, rgb))
    # the vertex colours of the v lines, without the texture
    write_mesh(mesh, tmp_path / "g.obj", texture=False)
    plain = trimesh.load(tmp_path / "g.obj", process=False, maintain_order=True)
    np.testing.assert_array_equal(plain.visual.vertex_colors[:, :3], _own_pixels(mesh, rgb))


def _glb_attribute(gltf, blob, name):
    """An accessor's array, read with pygltflib's structures (not trimesh's reader)."""
    prim = gltf.meshes[0].primitives[0]
    acc = gltf.accessors[getattr(prim.attributes, name)]
    view = gltf.bufferViews[acc.bufferView]
    kinds = {5121: np.uint8, 5126: np.float32}
    width = {"VEC2": 2, "VEC3": 3, "VEC4": 4}[acc.type]
    start = view.byteOffset + (acc.byteOffset or 0)
    data = np.frombuffer(blob, kinds[acc.componentType], acc.count * width, start)
    return data.reshape(acc.count, width)


def test_glb_colours_uv_normals_read_by_pygltflib(tmp_path, frame):
    pygltflib = pytest.importorskip("pygltflib")
    _, rgb, mesh = frame
    write_mesh(mesh, tmp_path / "c.glb", texture=False)
    g = pygltflib.GLTF2().load(tmp_path / "c.glb")
    colors = _glb_attribute(g, g.binary_blob(), "COLOR_0")
    np.testing.assert_array_equal(colors[:, :3], _own_pixels(mesh, rgb))
    normals = _glb_attribute(g, g.binary_blob(), "NORMAL")
    np.testing.assert_allclose(normals, mesh.vertex_normals(), atol=1e-6)
    write_mesh(mesh, tmp_path / "t.glb")
    g = pygltflib.GLTF2().load(tmp_path / "t.glb")
    uv = _glb_attribute(g, g.binary_blob(), "TEXCOORD_0")  # glTF: v down from the top
    h, w = mesh.image_shape
    np.testing.assert_allclose(uv[:, 0] * (w - 1), mesh.pixels[:, 1], atol=1e-3)
    np.testing.assert_allclose(uv[:, 1] * (h - 1), mesh.pixels[:, 0], atol=1e-3)
    assert g.meshes[0].primitives[0].attributes.COLOR_0 is None  # glTF would multiply them
    assert len(g.images) == 1


def test_to_open3d_hands_over_every_array(monkeypatch, frame):
    """A stand-in for Open3D (a large wheel with system libraries) records what is given."""
    _, _, mesh = frame

    class TriangleMesh:
        def __init__(self, vertices, faces):
            self.vertices, self.triangles = vertices, faces

    fake = types.ModuleType("open3d")
    fake.geometry = types.SimpleNamespace(TriangleMesh=TriangleMesh)
    fake.utility = types.SimpleNamespace(Vector3dVector=np.array, Vector3iVector=np.array)
    monkeypatch.setitem(sys.modules, "open3d", fake)
    out = mesh.to_open3d()
    np.testing.assert_array_equal(out.vertices, mesh.vertices)
    np.testing.assert_array_equal(out.triangles, mesh.faces)
    np.testing.assert_allclose(out.vertex_colors, mesh.colors / 255.0)
    np.testing.assert_allclose(out.vertex_normals, mesh.vertex_normals())


def test_to_open3d_with_open3d(frame, open3d):
    o3d = open3d
    _, _, mesh = frame
    out = mesh.to_open3d()
    assert isinstance(out, o3d.geometry.TriangleMesh)
    np.testing.assert_allclose(np.asarray(out.vertices), mesh.vertices)
    np.testing.assert_allclose(np.asarray(out.vertex_colors), mesh.colors / 255.0)


def test_to_open3d_missing_says_how_to_install(monkeypatch, frame):
    monkeypatch.setitem(sys.modules, "open3d", None)  # import open3d raises ImportError
    with pytest.raises(ImportError, match=r"rangemesh\[open3d\]"):
        frame[2].to_open3d()


def test_cli_color_writes_textured_obj_and_coloured_ply(tmp_path, capsys):
    from rangemesh.cli import main

    depth, color = tmp_path / "depth.png", tmp_path / "color.png"
    for path, image in zip((depth, color), rgbd_frame((480, 640)), strict=True):
        iio.imwrite(path, image)
    obj, ply = tmp_path / "f.obj", tmp_path / "f.ply"
    common = ["--intrinsics", "517.3,516.5,318.6,255.3", "--depth-scale", "0.001",
              "--vertices", "1000", "--color", str(color), "--quiet"]
    assert main(["mesh", str(depth), "-o", str(obj), *common]) == 0
    assert (tmp_path / "f.mtl").exists() and (tmp_path / "f.texture.png").exists()
    assert main(["mesh", str(depth), "-o", str(ply), "--pixels", *common]) == 0
    m = read_mesh(ply)
    rgb = iio.imread(color)
    np.testing.assert_array_equal(m.colors, rgb[m.pixels[:, 0], m.pixels[:, 1]])
    # an OBJ's texture never replaces an input
    shutil_copy = tmp_path / "in.texture.png"
    shutil_copy.write_bytes(color.read_bytes())
    capsys.readouterr()
    assert main(["mesh", str(depth), "-o", str(tmp_path / "in.obj"), "--intrinsics",
                 "517.3,516.5,318.6,255.3", "--vertices", "100", "--color",
                 str(shutil_copy)]) == 2
    assert "never replaces an input" in capsys.readouterr().err
    other = tmp_path / "other.png"  # a colour image of another size than the depth
    iio.imwrite(other, np.zeros((383, 434), np.uint8))
    assert main(["mesh", str(depth), "-o", str(ply), "--vertices", "100",
                 "--color", str(other)]) == 2
    assert "registered" in capsys.readouterr().err


def test_preview_shows_the_colours(tmp_path, frame):
    from rangemesh.preview import save_preview

    depth, _, mesh = frame
    import dataclasses

    save_preview(mesh, depth.astype(float), depth > 0, tmp_path / "c.png")
    save_preview(dataclasses.replace(mesh, colors=None), depth.astype(float), depth > 0,
                 tmp_path / "g.png")
    third = iio.imread(tmp_path / "c.png")[:, -400:, :3].astype(int)
    plain = iio.imread(tmp_path / "g.png")[:, -400:, :3].astype(int)
    spread = lambda a: np.abs(a[..., 0] - a[..., 2]).mean()  # noqa: E731
    assert spread(third) > 5 * max(spread(plain), 0.1)  # colour where the grey one has none


# ---------------------------------------------------------------- from the hostile-input reports


# E24 of the 2026-11-25 hostile-input report
@pytest.mark.parametrize("shape", [(4, 4, 2), (4, 4, 5)])
def test_colour_images_of_2_or_5_channels_are_refused_naming_the_shape(shape):
    from rangemesh.attributes import as_rgb8

    with pytest.raises(ValueError, match=rf"shape \({shape[0]}, {shape[1]}, {shape[2]}\)"):
        as_rgb8(np.zeros(shape))


# E23 of the 2026-11-25 hostile-input report
def test_huge_intensities_and_complex_colours_make_no_warning():
    from rangemesh.attributes import as_rgb8

    with np.errstate(all="raise"):
        out = as_rgb8(np.array([[0, 2**64 - 1], [2**63, 7]], np.uint64))
        assert out[0, 1, 0] == 255 and out[0, 0, 0] == 0
        out = as_rgb8(np.array([[-1e308, 1e308], [0.0, 0.0]]))
        assert out[..., 0].tolist() == [[0, 255], [128, 128]]  # by hand: the middle of the range
    with pytest.raises(ValueError, match="real numbers"):
        as_rgb8(np.ones((3, 3, 3), complex))
