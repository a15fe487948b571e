"""End-to-end tests of the ``rangemesh`` command on real files, through its entry points."""

import errno
import json
import shutil
import struct
import subprocess
import sys

import meshio
import numpy as np
import pytest
import trimesh

import rangemesh
import rangemesh.memory
from rangemesh.cli import main
from rangemesh.io import read_range_image

from .golden import crops
from .helpers import one_error_line
from .images import REAL_IMAGES, load, rgbd_frame
from .pngs import png_header


def run(argv, capsys):
    rc = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return rc, out, err


def _glb_positions(path):
    """Vertex positions and triangle indices of a GLB, decoded with pygltflib."""
    import pygltflib

    g = pygltflib.GLTF2().load(str(path))
    blob = g.binary_blob()
    prim = g.meshes[0].primitives[0]

    def read(acc_id, dtype, width):
        acc = g.accessors[acc_id]
        view = g.bufferViews[acc.bufferView]
        start = (view.byteOffset or 0) + (acc.byteOffset or 0)
        n = acc.count * width
        return np.frombuffer(blob, dtype=dtype, count=n, offset=start).reshape(acc.count, width)

    pos = read(prim.attributes.POSITION, np.float32, 3)
    comp = {5125: np.uint32, 5123: np.uint16}[g.accessors[prim.indices].componentType]
    idx = read(prim.indices, comp, 1).reshape(-1, 3)
    return pos, idx


# ---------------------------------------------------------------- the commands


def test_mesh_png_to_ply_with_preview(shared_data, tmp_path, capsys):
    src = shared_data / "middlebury/cones_disp2.png"
    out, prev = tmp_path / "scan.ply", tmp_path / "scan-preview.png"
    rc, _, err = run(["mesh", src, "-o", out, "--background", "0", "--method", "paper", "--tiles", "4x4",
                      "--samples", "10x10", "--preview", prev], capsys)
    assert rc == 0, err
    assert "relative error" in err and f"wrote {out}" in err
    want = rangemesh.triangulate(load(shared_data, "middlebury/cones_disp2.png"), background=0,
                                 method="paper")
    back = meshio.read(out)  # another library than plyfile, which wrote it
    np.testing.assert_allclose(back.points, want.vertices, rtol=1e-6)
    assert np.array_equal(back.cells_dict["triangle"], want.faces)
    import imageio.v3 as iio

    img = iio.imread(prev)
    assert img.ndim == 3 and img.shape[1] > 1000 and img.std() > 10  # a real picture


def test_mesh_pinhole_to_glb(shared_data, tmp_path, capsys):
    src = shared_data / "rgbd/slambook2_ch7_1_depth.png"
    out = tmp_path / "frame.glb"
    rc, _, err = run(["mesh", src, "--depth-scale", "0.0002", "--intrinsics",
                      "525,525,319.5,239.5", "-o", out], capsys)
    assert rc == 0, err
    img = load(shared_data, "rgbd/slambook2_ch7_1_depth.png")
    want = rangemesh.triangulate(img, background=0,
                                 camera=rangemesh.Pinhole(525, 525, 319.5, 239.5, 0.0002))
    pos, idx = _glb_positions(out)
    np.testing.assert_allclose(pos, want.vertices, rtol=1e-6, atol=1e-7)
    assert np.array_equal(idx, want.faces)
    # metric: depth in metres is value / 5000, between 0.97 and 8.56 m for this frame
    assert 0.9 < pos[:, 2].min() and pos[:, 2].max() < 8.6


def test_mesh_ascii_pgm_to_obj_with_error_flips(shared_data, tmp_path, capsys):
    out = tmp_path / "venus.obj"
    rc, _, err = run(["mesh", shared_data / "middlebury/venus_disp2.pgm", "-o", out,
                      "--method", "paper", "--flips", "error", "--quiet"], capsys)
    assert rc == 0 and err == ""
    want = rangemesh.triangulate(np.load(shared_data / "middlebury/venus_disp2.npy"),
                                 background=0, flips="error", method="paper")
    back = meshio.read(out)
    np.testing.assert_allclose(back.points, want.vertices, rtol=1e-6)
    assert np.array_equal(back.cells_dict["triangle"], want.faces)


@pytest.mark.parametrize("suffix", [".off", ".stl"])
def test_other_formats_read_back(tmp_path, capsys, suffix):
    src = tmp_path / "chair.npy"  # the committed crop of odetics/chair-range
    np.save(src, crops()["chair"][0])
    out = tmp_path / f"chair{suffix}"
    rc, _, _ = run(["mesh", src, "-o", out, "--quiet"], capsys)
    assert rc == 0
    want = rangemesh.triangulate(crops()["chair"][0], background=0)
    back = meshio.read(out)
    tri = back.cells_dict["triangle"]
    assert len(tri) == len(want.faces)
    # STL repeats vertices per face: compare the triangles' corner coordinates
    np.testing.assert_allclose(back.points[tri], want.vertices[want.faces], rtol=1e-6)


def test_ascii_ply_with_pixels_and_eval(tmp_path, capsys):
    import tifffile

    src = tmp_path / "boxes.tiff"  # the committed crop of the PCL grabber frame, a 16-bit TIFF
    tifffile.imwrite(src, crops()["boxes"][0])
    out = tmp_path / "boxes.ply"
    rc, _, _ = run(["mesh", src, "-o", out, "--ascii", "--pixels", "--quiet"], capsys)
    assert rc == 0
    assert out.read_bytes().startswith(b"ply\nformat ascii")
    tm = trimesh.load(out, process=False)
    img = read_range_image(src)
    want = rangemesh.triangulate(img, background=0)
    np.testing.assert_allclose(tm.vertices, want.vertices, rtol=1e-6)
    rc, stdout, _ = run(["eval", src, out, "--json"], capsys)
    got = json.loads(stdout)
    ev = rangemesh.evaluate(want, img, background=0)
    assert got["relative_error"] == pytest.approx(ev.relative_error, rel=1e-5)
    assert got["covered_pixels"] == ev.covered_pixels


def test_eval_projects_meshes_without_pixels(tmp_path, capsys):
    import imageio.v3 as iio

    src = tmp_path / "frame.png"  # a Kinect-like frame in 1/5000 m, 0 = no depth
    iio.imwrite(src, rgbd_frame((480, 640))[0])
    cam = ["--depth-scale", "0.0002", "--intrinsics", "525,525,319.5,239.5"]
    out = tmp_path / "f.glb"
    assert run(["mesh", src, "-o", out, "--quiet", *cam], capsys)[0] == 0
    rc, stdout, _ = run(["eval", src, out, "--json", *cam], capsys)
    img = read_range_image(src)
    want = rangemesh.evaluate(
        rangemesh.triangulate(img, background=0,
                              camera=rangemesh.Pinhole(525, 525, 319.5, 239.5, 0.0002)),
        img, background=0)
    got = json.loads(stdout)
    assert got["covered_pixels"] == want.covered_pixels
    assert got["relative_error"] == pytest.approx(want.relative_error, rel=1e-4)


def test_info(shared_data, capsys):
    rc, out, _ = run(["info", shared_data / "rgbd/open3d_TUM_depth.png", "--json"], capsys)
    info = json.loads(out)
    assert rc == 0 and info["shape"] == [480, 640] and info["dtype"] == "uint16"
    assert info["background"] == 0 and info["background_guessed"]
    # README: 0 marks 19.2 % of this frame; 1.46-9.33 m at 1/5000 m per unit
    assert info["valid_share_percent"] == pytest.approx(80.8, abs=0.1)
    assert info["depth_min"] / 5000 == pytest.approx(1.46, abs=0.01)
    assert info["depth_max"] / 5000 == pytest.approx(9.33, abs=0.01)
    rc, out, _ = run(["info", shared_data / "rgbd/pcl_table_scene_mug_stereo_textured.pcd"], capsys)
    assert rc == 0 and "NaN" in out and "68.1 %" in out  # README: NaN on 31.9 %


def test_demo_writes_mesh_and_preview(tmp_path, capsys):
    out, prev = tmp_path / "d.ply", tmp_path / "d.png"
    rc, stdout, err = run(["demo", "-o", out, "--preview", prev, "--json"], capsys)
    assert rc == 0 and out.stat().st_size > 0 and prev.stat().st_size > 0
    doc = json.loads(stdout)
    # the default target: a box on a plane before a pyramid is planar pieces, met well under the cap
    assert doc["stats"]["method"] == "refine" and doc["stats"]["target"]["met"]
    assert doc["evaluation"]["relative_error"] <= 0.5


def test_demo_replaces_no_file_of_a_default_name_unless_overwrite(tmp_path, capsys, monkeypatch):
    # F14: `rangemesh demo` replaced an existing demo.ply
    monkeypatch.chdir(tmp_path)
    for name, named in (("demo.ply", ["--preview", "p.png"]), ("demo-preview.png", ["-o", "m.ply"])):
        (tmp_path / name).write_text("the user's own file")
        rc, _, err = run(["demo", "--quiet", *named], capsys)
        assert rc == 2 and err.count("\n") == 1
        assert err.startswith(f"rangemesh: error: {name}: already there (the default output name)")
        assert (tmp_path / name).read_text() == "the user's own file"
    rc, _, err = run(["demo", "--quiet", "--overwrite"], capsys)
    assert rc == 0 and err == ""
    assert rangemesh.read_mesh(tmp_path / "demo.ply").faces.shape[1] == 3
    assert (tmp_path / "demo-preview.png").read_bytes()[:4] == b"\x89PNG"


@pytest.mark.slow
def test_console_script_and_module_entry_points(tmp_path):
    from pathlib import Path

    # the console script sits beside the interpreter that installed the package
    beside = Path(sys.executable).parent / "rangemesh"
    exe = str(beside) if beside.exists() else shutil.which("rangemesh")
    assert exe, "the console script is installed with the package"
    for cmd in ([exe], [sys.executable, "-m", "rangemesh"]):
        p = subprocess.run([*cmd, "demo", "-o", str(tmp_path / "e.obj"), "--preview",
                            str(tmp_path / "e.png"), "--quiet"], capture_output=True, text=True)
        assert p.returncode == 0, p.stderr
        assert (tmp_path / "e.obj").exists()
    p = subprocess.run([exe, "mesh", "--help"], capture_output=True, text=True)
    assert "--max-angle" in p.stdout and "degenerate" in p.stdout


@pytest.mark.parametrize("rel, background", REAL_IMAGES + [
    ("rgbd/pcl_milk_cartoon_all_small_clorox.pcd", None),
    ("rgbd/pcl_table_scene_mug_stereo_textured.pcd", None),
    ("rgbd/slambook2_ch5_depth_1.pgm", 0), ("odetics/chair-range.ppm", 0),
    ("middlebury/tsukuba_disp3.pgm", 0), ("middlebury/venus_disp2.pgm", None),
    ("rgbd/open3d_SUN_depth.png", 0), ("rgbd/open3d_NYU_depth.pgm", 0),
], ids=lambda x: str(x))
def test_every_shared_file_loads(shared_data, rel, background):
    arr = read_range_image(shared_data / rel)
    assert arr.ndim == 2 and arr.size > 0
    npy = {".pcd": ".z.npy", ".pgm": ".npy", ".ppm": ".npy"}.get((shared_data / rel).suffix)
    if npy and rel != "rgbd/open3d_NYU_depth.pgm":  # NYU's PGM is byte-swapped on purpose
        ref = np.load((shared_data / rel).with_suffix(npy))
        assert np.array_equal(arr, ref, equal_nan=True)


# ---------------------------------------------------------------- bad input


def _one_line_error(rc, out, err):
    assert rc != 0
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rangemesh") and "error:" in lines[0], err
    assert "Traceback" not in err


def test_bad_inputs(tmp_path, capsys):
    import imageio.v3 as iio

    good = tmp_path / "cones.png"  # the committed crop of middlebury/cones_disp2.png
    iio.imwrite(good, crops()["cones"][0])
    truncated = tmp_path / "cut.png"
    truncated.write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    rgb = tmp_path / "rgb.npy"
    np.save(rgb, np.zeros((10, 10, 3)))
    empty = tmp_path / "empty.npy"
    np.save(empty, np.zeros((30, 30), np.uint16))
    junk = tmp_path / "junk.pgm"
    junk.write_bytes(b"not an image at all")
    out = tmp_path / "x.ply"
    cases = [
        ["mesh", tmp_path / "missing.png", "-o", out],
        ["mesh", truncated, "-o", out],
        ["mesh", junk, "-o", out],
        ["mesh", rgb, "-o", out],
        ["mesh", empty, "-o", out],
        ["mesh", good, "--tiles", "4y4", "-o", out],
        ["mesh", good, "--tiles", "0", "-o", out],
        ["mesh", good, "--tiles", "400x4", "-o", out],
        ["mesh", good, "-o", tmp_path / "no" / "such" / "dir.ply"],
        ["mesh", good, "-o", tmp_path / "x.xyz"],
        ["mesh", good, "-o", tmp_path / "x.obj", "--ascii"],
        ["mesh", good, "--intrinsics", "1,2,3"],
        ["eval", good, tmp_path / "missing.ply"],
        ["info", tmp_path / "missing.png"],
    ]
    for argv in cases:
        try:
            rc = main([str(a) for a in argv])
        except SystemExit as exc:  # argparse's own errors
            rc = exc.code
        o, e = capsys.readouterr()
        _one_line_error(rc, o, e)
    assert list(tmp_path.glob("*.ply")) == [] and list(tmp_path.glob(".*")) == []


def test_failed_write_leaves_nothing(tmp_path, monkeypatch, capsys):
    import rangemesh.io as rio

    def boom(*a, **k):
        raise OSError(errno.ENOSPC, "No space left on device")

    src = tmp_path / "in" / "chair.npy"  # the committed crop of odetics/chair-range
    src.parent.mkdir()
    np.save(src, crops()["chair"][0])
    out = tmp_path / "out"
    out.mkdir()
    monkeypatch.setattr(rio.FORMATS[".ply"], "write", boom)
    code = main(["mesh", str(src), "-o", str(out / "c.ply")])
    err = capsys.readouterr().err
    assert code == 2
    assert err == f"rangemesh: error: {out / 'c.ply'}: No space left on device\n"
    assert list(out.iterdir()) == []


def test_pfm_and_float_tiff(tmp_path, capsys):
    d = rangemesh.scenes.pyramid((60, 80)).depth.astype(np.float32)
    d[10:12, 10:40] = np.inf
    pfm = tmp_path / "d.pfm"
    with open(pfm, "wb") as fh:  # PFM: bottom row first, little-endian floats
        fh.write(b"Pf\n80 60\n-1.0\n")
        fh.write(d[::-1].astype("<f4").tobytes())
    import tifffile

    tif = tmp_path / "d.tif"
    tifffile.imwrite(tif, np.where(np.isinf(d), np.nan, d))
    for f in (pfm, tif):
        arr = read_range_image(f)
        assert np.array_equal(np.isfinite(arr), np.isfinite(d))
        assert np.array_equal(arr[np.isfinite(arr)], d[np.isfinite(d)])
        rc, _, err = run(["mesh", f, "-o", tmp_path / "p.ply"], capsys)
        assert rc == 0, err


def test_16bit_binary_and_ascii_pgm(tmp_path):
    a = np.array([[0, 1000, 70], [65535, 300, 2]], np.uint16)
    b = tmp_path / "b.pgm"
    b.write_bytes(b"P5\n3 2\n65535\n" + a.astype(">u2").tobytes())
    t = tmp_path / "t.pgm"
    t.write_text("P2\n3 2\n65535\n" + " ".join(map(str, a.ravel())) + "\n")
    for f in (b, t):
        assert np.array_equal(read_range_image(f), a)
    assert struct.calcsize(">H") == 2


# F17: the size in a Netpbm or PNG header is read first; one the file cannot hold is said in numbers
@pytest.mark.parametrize("name, data, says", [
    ("huge.pfm", b"Pf\n100000 100000\n-1.0\n" + bytes(1000),
     "the header says 100000 x 100000 pixels (width x height), 40,000,000,000 bytes; the file "
     "holds 1,000 bytes after its header (truncated or damaged)"),
    ("huge.pgm", b"P5\n100000 100000\n65535\n" + bytes(1000),
     "the header says 100000 x 100000 pixels (width x height), 20,000,000,000 bytes; the file "
     "holds 1,000 bytes after its header (truncated or damaged)"),
    ("neg.pfm", b"Pf\n-5 10\n-1.0\n" + bytes(1000),
     "the header says -5 x 10 pixels (width x height): not an image"),
    ("zero.pgm", b"P5\n0 10\n255\n" + bytes(100),
     "the header says 0 x 10 pixels (width x height): not an image"),
    ("short.ppm", b"P6\n# a comment\n10 10\n255\n" + bytes(299),
     "the header says 10 x 10 pixels (width x height), 300 bytes; the file holds 299 bytes "
     "after its header (truncated or damaged)"),
    ("ascii.pgm", b"P2\n100 100\n255\n0 0 0\n",  # a digit and a separator a pixel, less one
     "the header says 100 x 100 pixels (width x height), at least 19,999 bytes; the file holds "
     "6 bytes after its header (truncated or damaged)"),
    ("huge.png", png_header(100000, 100000, bit_depth=8) + bytes(1000),  # deflate: 1032:1 at best
     "the header says 100000 x 100000 pixels (width x height), 10,000,000,000 bytes, and 1,033 "
     "bytes cannot hold them even compressed (truncated or damaged)"),
], ids=["huge.pfm", "huge.pgm", "neg.pfm", "zero.pgm", "short.ppm", "ascii.pgm", "huge.png"])
def test_a_header_size_the_file_cannot_hold_is_said_in_numbers(tmp_path, capsys, name, data, says):
    f = tmp_path / name
    f.write_bytes(data)
    with pytest.raises(ValueError) as e:
        read_range_image(f)
    assert str(e.value) == f"{f}: {says}"
    rc, _, err = run(["mesh", f, "-o", tmp_path / "x.ply"], capsys)
    assert rc == 2 and err == f"rangemesh: error: {f}: {says}\n"


def _pillow_open_spy(monkeypatch):
    import PIL.Image

    calls, real = [], PIL.Image.open
    monkeypatch.setattr(PIL.Image, "open", lambda *a, **k: calls.append(a) or real(*a, **k))
    return calls


def test_a_png_past_pillow_s_bomb_limit_reads_without_its_warning(tmp_path, capsys, monkeypatch):
    # F13: Pillow's DecompressionBombWarning never leaks; the memory rule decides, from the header
    import warnings

    import imageio.v3 as iio
    import PIL.Image

    import rangemesh.pipeline

    png = tmp_path / "big.png"
    iio.imwrite(png, (1000 + 10 * np.add.outer(np.arange(40), np.arange(50))).astype(np.uint16),
                extension=".png", plugin="pillow")
    monkeypatch.setattr(PIL.Image, "MAX_IMAGE_PIXELS", 1500)  # 2000 pixels: past its warning
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        rc, out, err = run(["info", png], capsys)
        assert rc == 0 and f"{png}: 40 rows x 50 cols, uint16" in out, err
        rc, _, err = run(["mesh", png, "-o", tmp_path / "big.ply", "--vertices", 100], capsys)
        assert rc == 0, err
    assert [str(w.message) for w in said] == []
    # past twice the limit Pillow refuses: said in one line, before decoding
    monkeypatch.setattr(PIL.Image, "MAX_IMAGE_PIXELS", 900)
    rc, _, err = run(["info", png], capsys)
    assert rc == 2 and err == (f"rangemesh: error: {png}: a 40x50 image (2,000 pixels) is more "
                               f"than Pillow decodes (1,800: twice PIL.Image.MAX_IMAGE_PIXELS); "
                               f"raise that limit to read it\n")
    # the memory rule (20 bytes a pixel: 40,000 bytes) from the header, before decoding
    monkeypatch.setattr(PIL.Image, "MAX_IMAGE_PIXELS", 1500)
    monkeypatch.setattr(rangemesh.memory, "available_memory", lambda: 30_000)
    opened = _pillow_open_spy(monkeypatch)
    for cmd in (["info", png], ["mesh", png, "-o", tmp_path / "m.ply"]):
        rc, _, err = run(cmd, capsys)
        assert rc == 2 and err.count("\n") == 1, err
        assert err.startswith(f"rangemesh: error: not enough memory ({png}: a 40x50 image needs "
                              f"about "), err
    assert opened == []


# ---------------------------------------------------------------- the parser (issue 41)


def test_an_abbreviated_option_is_an_error_not_the_long_option(tmp_path, capsys):
    # issue 41: argparse's prefix matching took `--vertice 500` as `--vertices 500`
    src = tmp_path / "chair.npy"  # the committed crop of odetics/chair-range
    np.save(src, crops()["chair"][0])
    out = tmp_path / "c.ply"
    cases = [(["mesh", src, "-o", out, "--vertice", "500"], "--vertice"),
             (["batch", src, "-o", tmp_path / "b", "--vertice", "500"], "--vertice"),
             (["demo", "-o", out, "--preview", tmp_path / "p.png", "--quie"], "--quie"),
             (["info", src, "--jso"], "--jso"),
             (["eval", src, out, "--jso"], "--jso"),
             (["--vers"], "")]  # argparse names the missing command; --version would exit 0
    for argv, typed in cases:
        with pytest.raises(SystemExit) as e:
            main([str(a) for a in argv])
        o, err = capsys.readouterr()
        assert e.value.code == 2 and o == "", argv
        assert err.startswith("rangemesh") and typed in err and "error:" in err, err
    assert not out.exists() and not (tmp_path / "b").exists()


def test_rangemesh_alone_prints_the_usage_and_exits_2(capsys):
    # issue 41: `rangemesh` alone printed one error line and no usage
    with pytest.raises(SystemExit) as e:
        main([])
    out, err = capsys.readouterr()
    assert e.value.code == 2 and out == ""
    usage, error = err.splitlines()[0], err.strip().splitlines()[-1]
    assert usage.startswith("usage: rangemesh ")
    for command in ("mesh", "demo", "batch", "info", "eval"):
        assert command in err
    assert error.startswith("rangemesh: error: ")
    p = subprocess.run([sys.executable, "-m", "rangemesh"], capture_output=True, text=True)
    assert p.returncode == 2 and p.stdout == "" and p.stderr.startswith("usage: rangemesh ")


def test_rangemesh_alone_names_every_command_in_the_order_help_lists_them(capsys):
    # issue 43: the message was a third hand-kept list ("batch, live, info or eval" against -h's
    # "batch, info, eval, live"); it is written from the one tuple of command declarations now
    from rangemesh.cli import build_parser

    with pytest.raises(SystemExit):
        main([])
    error = capsys.readouterr().err.strip().splitlines()[-1]
    assert error == ("rangemesh: error: give a command: mesh, demo, batch, info, eval or live "
                     "(rangemesh -h says more)")
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    assert list(sub.choices) == ["mesh", "demo", "batch", "info", "eval", "live"]


def test_quiet_mesh_imports_no_progress_bar(tmp_path):
    # issue 41: tqdm was imported (and a disabled bar built) even with --quiet
    src = tmp_path / "chair.npy"
    np.save(src, crops()["chair"][0])
    out = tmp_path / "c.ply"
    code = ("import sys; from rangemesh.cli import main; "
            f"rc = main(['mesh', {str(src)!r}, '-o', {str(out)!r}, '--vertices', '200', '--quiet']); "
            "print(rc, 'tqdm' in sys.modules)")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert p.stdout.split() == ["0", "False"], p.stderr
    assert p.stderr == "" and rangemesh.read_mesh(out).vertices.shape == (200, 3)


def test_an_undecodable_png_is_said_to_be_no_png_not_pillow_s_uri(tmp_path, capsys):
    # issue 41: the cause read "`pillow` can not handle the given uri"
    import imageio.v3 as iio

    good = tmp_path / "cones.png"  # the committed crop of middlebury/cones_disp2.png
    iio.imwrite(good, crops()["cones"][0])
    data = good.read_bytes()
    text, badsig, junk, damaged = (tmp_path / n for n in ("text.png", "badsig.png", "junk.pgm",
                                                          "damaged.png"))
    text.write_text("a depth frame, said in words")
    badsig.write_bytes(b"\x00" + data[1:])
    junk.write_bytes(b"not an image at all")
    idat = data.index(b"IDAT") + 4  # the compressed pixels, past the header the checks read
    damaged.write_bytes(data[:idat] + bytes(b ^ 0x5A for b in data[idat:-12]) + data[-12:])
    no_png = ("cannot be decoded as a PNG file: it does not start with the PNG signature (not a "
              "PNG file, or damaged at its start)")
    says = {text: no_png, badsig: no_png,
            junk: "cannot be decoded as a PGM file: Pillow recognises no image format in its bytes "
                  "(not a PGM file, or damaged)",
            damaged: "cannot be decoded as a PNG file ("}
    for f, said in says.items():
        with pytest.raises(ValueError) as e:
            read_range_image(f)
        assert str(e.value).startswith(f"{f}: {said}") and "pillow" not in str(e.value)
        rc, _, err = run(["mesh", f, "-o", tmp_path / "x.ply"], capsys)
        assert rc == 2 and err.startswith(f"rangemesh: error: {f}: {said}") and err.count("\n") == 1
    rc, _, err = run(["mesh", good, "-o", tmp_path / "x.ply", "--color", text], capsys)
    assert rc == 2 and err == f"rangemesh: error: {good}: --color: {text}: {no_png}\n"


# ---------------------------------------------------------------- from the hostile-input reports


# D19 of the 2026-11-21 hostile-input report
def test_unicode_names_in_previews_are_quiet(tmp_path, chair, capsys):
    src = tmp_path / "ünïcödé-深度.npy"
    np.save(src, chair)
    assert main(["mesh", str(src), "--preview", str(tmp_path / "p.png"), "--quiet"]) == 0
    assert capsys.readouterr().err == ""


# D26 of the 2026-11-21 hostile-input report
def test_eval_refuses_a_mesh_of_another_image_size(chair_file, tmp_path, capsys):
    assert main(["mesh", str(chair_file), "-o", str(tmp_path / "good.ply"), "--quiet"]) == 0
    other = tmp_path / "other.npy"
    np.save(other, np.ones((50, 70), np.uint8))
    line = one_error_line(capsys, main(["eval", str(other), str(tmp_path / "good.ply")]))
    assert "96x96" in line and "50x70" in line


# the second run of the 2026-11-21 hostile-input report
def test_eval_uses_the_camera_the_file_records(chair_file, tmp_path, capsys):
    ply = tmp_path / "p.ply"
    assert main(["mesh", str(chair_file), "-o", str(ply), "--intrinsics", "500,500,48,48",
                 "--depth-scale", "0.001", "--quiet", "--json"]) == 0
    made = capsys.readouterr().out
    import json

    want = json.loads(made)["evaluation"]["relative_error"]
    assert main(["eval", str(chair_file), str(ply), "--json"]) == 0  # no camera flags needed
    assert json.loads(capsys.readouterr().out)["relative_error"] == pytest.approx(want, rel=1e-6)
    # another camera than the recorded one is refused instead of giving 75 % uncovered
    one_error_line(capsys, main(["eval", str(chair_file), str(ply), "--scale", "1,1,1"]),
                   match="was made with")
    m = rangemesh.read_mesh(ply)
    assert m.camera == rangemesh.Pinhole(500, 500, 48, 48, 0.001)


# the second run of the 2026-11-21 hostile-input report
def test_a_closed_stdout_ends_quietly(chair_file):
    # `rangemesh mesh ... --json | head`: here the reader leaves before the JSON is written
    cmd = f"{sys.executable} -m rangemesh mesh {chair_file} --json --background 0 | true"
    proc = subprocess.run(["bash", "-c", cmd], capture_output=True, text=True, timeout=120)
    assert proc.stderr == "", proc.stderr


# ---------------------------------------------------------------- deviation targets (issue 44)


def test_mesh_max_deviation_in_metres_and_eval_prints_the_deviations(tmp_path, capsys):
    import imageio.v3 as iio

    src = tmp_path / "frame.png"  # a Kinect-like frame in 1/5000 m, 0 = no depth
    image = rgbd_frame((120, 160))[0]
    iio.imwrite(src, image)
    out = tmp_path / "frame.ply"
    cam = ["--depth-scale", "0.0002", "--intrinsics", "100,100,79.5,59.5"]
    rc, _, err = run(["mesh", src, "-o", out, "--max-deviation", "0.01", "--max-edge", "20",
                      *cam], capsys)
    assert rc == 0
    # the same mesh as the Python call
    want = rangemesh.triangulate(image, camera=rangemesh.Pinhole(100, 100, 79.5, 59.5,
                                                                 depth_scale=0.0002),
                                 max_deviation=0.01, max_edge=20.0)
    assert f"vertices {want.stats.vertices} " in err
    assert "target max_deviation 0.01: achieved" in err and "not met" not in err
    assert "max deviation " in err and " m  mean deviation " in err
    rc, stdout, _ = run(["eval", src, out, *cam, "--json"], capsys)
    got = json.loads(stdout)
    # (a PLY stores float32 vertices: their rounding, a micrometre, on top of the bound)
    assert got["max_deviation"] <= 0.01 + 1e-5
    rc, stdout, _ = run(["eval", src, out, *cam], capsys)
    assert "max deviation" in stdout


def test_mesh_deviation_targets_exclude_the_others(tmp_path, capsys):
    src = tmp_path / "c.npy"
    np.save(src, np.add.outer(np.arange(20.0), np.arange(30.0)))
    rc, _, err = run(["mesh", src, "-o", tmp_path / "c.ply", "--max-deviation", "0.1",
                      "--vertices", "10"], capsys)
    assert rc == 2 and "max_deviation and vertices exclude each other" in err
    rc, _, err = run(["mesh", src, "-o", tmp_path / "c.ply", "--mean-deviation", "-1"], capsys)
    assert rc == 2 and "mean_deviation must be a finite number of 0 or more" in err


# ---------------------------------------------------------------- one set of mesh options


def _flags(command):
    from rangemesh.cli import build_parser

    sub = next(a for a in build_parser()._actions if a.dest == "command")
    return {f for a in sub.choices[command]._actions for f in a.option_strings}


# `mesh`'s flags about its input and outputs; every other flag of it is a meshing option
MESH_IO_FLAGS = {"-h", "--help", "-o", "--output", "--preview", "--color", "--intensity",
                 "--color-mean", "--ascii", "--pixels", "--overwrite", "--background", "--quiet",
                 "--json", "--meta", "--frame"}


@pytest.mark.parametrize("command", ["batch", "live", "demo"])
def test_every_meshing_command_takes_every_mesh_option_of_mesh(command):
    # batch and live lacked --max-deviation and --mean-deviation (issue 42)
    options = _flags("mesh") - MESH_IO_FLAGS
    assert {"--method", "--vertices", "--max-error", "--max-edge", "--max-deviation",
            "--mean-deviation", "--tiles", "--intrinsics"} <= options
    assert options - _flags(command) == set()

