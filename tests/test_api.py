"""The public call: one default method, each method its options, one rule for missing depth."""

import dataclasses
import inspect
import json
import subprocess
import sys
import textwrap
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import rangemesh
from rangemesh import MeshParams, Target, mesh_stream, triangulate
from rangemesh.cleanup import ZeroMarkerWarning
from rangemesh.cli import main
from rangemesh.io import read_mesh
from rangemesh.params import OPTION_METHOD, OPTION_TABLE

from .helpers import assert_valid_mesh

# One valid value of each option of one method, to hand to the other.
VALUES = {
    "heights": "pixel", "diagonals": "delaunay", "walls": False, "jump": 0.1,
    "tiles": 2, "samples": 5, "sampling": "uniform", "flips": "error", "levels": 1,
    "curvature_floor": 30.0, "delta": 20.0, "epsilon": 0.5, "max_angle": 150.0,
    "min_bend": 4.0, "gain_threshold": 0.0, "max_edge": 10.0, "threads": 2, "effort": "best",
}
OTHER = {"refine": "paper", "paper": "refine"}


def crease(h=40, w=50):
    c = np.arange(w)[None, :].repeat(h, 0)
    return np.where(c < 25, 100.0 + c, 150.0 - c)


def same_mesh(a, b):
    assert np.array_equal(a.pixels, b.pixels)
    assert np.array_equal(a.faces, b.faces)
    assert np.array_equal(a.vertices, b.vertices)


# ------------------------------------------------------------ the default


def test_default_is_refine_with_the_default_target():
    mesh = triangulate(crease())
    assert mesh.stats.method == "refine"
    t = mesh.stats.target
    assert isinstance(t, Target) and t.default and t.kind == "max_error"
    assert t.requested == 0.5
    # 40 x 50 = 2000 valid pixels: 2 % is 40, below the floor of 50
    assert t.max_vertices == 50
    # two planes meeting at a crease: met far below the cap, at (almost) zero error
    assert t.met and mesh.stats.vertices <= 50
    assert rangemesh.evaluate(mesh, crease()).relative_error < 0.01


def test_default_target_caps_noise_at_two_percent():
    rng = np.random.default_rng(1)
    noise = 100.0 + rng.normal(0.0, 5.0, (80, 100))  # no mesh below 0.5 % short of every pixel
    mesh = triangulate(noise)
    t = mesh.stats.target
    assert t.max_vertices == 160  # 2 % of 8000
    assert mesh.stats.vertices <= 160 and not t.met and "max_vertices" in t.note
    assert_valid_mesh(mesh)


def test_default_with_a_target_is_refine():
    for kw in ({"vertices": 30}, {"max_error": 1.0}):
        mesh = triangulate(crease(), **kw)
        assert mesh.stats.method == "refine" and not mesh.stats.target.default
    assert triangulate(crease(), vertices=30).stats.vertices == 30


def test_paper_reports_its_grid_and_flips():
    s = triangulate(crease(), method="paper", tiles=2, samples=5).stats
    # ((Rs-1)V+1, (Z-1)H+1) = (4*2+1, 4*2+1)
    assert s.method == "paper" and s.grid_shape == (9, 9) and s.target is None
    assert s.flip_tests  # the disparity tests ran
    r = triangulate(crease(), vertices=30).stats
    assert r.grid_shape is None and r.insertions >= 30 and r.strips == 1
    assert r.heights == "fit"


# ------------------------------------------------------------ one rule: method= alone


@pytest.mark.parametrize("option", sorted(k for k, m in OPTION_METHOD.items() if m is not None))
def test_an_option_of_the_other_method_is_refused(option):
    owner = OPTION_METHOD[option]
    with pytest.raises(ValueError, match=rf"^{option} is an option of method='{owner}'; "
                                         rf"method='{OTHER[owner]}' does not take it"):
        triangulate(crease(), method=OTHER[owner], **{option: VALUES[option]})


def test_a_paper_default_passed_to_refine_is_refused():
    # the example: delta=20 is the paper's default, still the paper's option
    with pytest.raises(ValueError, match="delta is an option of method='paper'"):
        triangulate(crease(), vertices=300, delta=20.0)


def test_the_table_covers_every_setting():
    fields = {f.name for f in dataclasses.fields(MeshParams)}
    shared = {"fill_gaps", "wrap", "depth_limits", "min_region", "max_edge"}
    # MeshParams' 'workers' is the option 'threads'
    assert set(OPTION_METHOD) | shared == (fields - {"workers"}) | {"threads"}


@pytest.mark.filterwarnings("ignore:The TBB threading layer")  # Numba's, on first parallel use
@pytest.mark.parametrize("option, owner", sorted(
    (k, m) for k, m0 in OPTION_METHOD.items() for m in ((m0,) if m0 else ("refine", "paper"))))
def test_each_option_is_taken_by_its_method(option, owner):
    # (an option listed with None, max_edge, is taken by both methods)
    kw = {option: VALUES[option]}
    if option in ("walls", "jump"):
        kw["walls"] = False
    if option == "max_edge":
        kw.pop("samples", None)
    mesh = triangulate(crease(), method=owner, **kw)
    assert mesh.stats.method == owner
    assert_valid_mesh(mesh)


def test_cli_refuses_the_other_methods_flags(tmp_path, capsys):
    img = tmp_path / "c.npy"
    np.save(img, crease())
    for argv, message in (
        (["--delta", "20"], "--delta is an option of --method paper; --method refine does not"),
        (["--method", "paper", "--no-walls"],
         "--no-walls is an option of --method refine; --method paper does not"),
        (["--tiles", "2x2", "--vertices", "300"], "--tiles is an option of --method paper"),
    ):
        rc = main(["mesh", str(img), "-o", str(tmp_path / "c.ply"), *argv])
        err = capsys.readouterr().err
        assert rc == 2 and message in err, err


# ------------------------------------------------------------ deprecated spellings


def test_params_warns_and_gives_the_same_mesh():
    with pytest.warns(DeprecationWarning, match="params=MeshParams"):
        old = triangulate(crease(), MeshParams(tiles=2, samples=5))
    same_mesh(old, triangulate(crease(), method="paper", tiles=2, samples=5))
    with pytest.warns(DeprecationWarning):
        old = triangulate(crease(), MeshParams(), vertices=20)  # a target: refine, as before
    same_mesh(old, triangulate(crease(), vertices=20))


@pytest.mark.filterwarnings("ignore:The TBB threading layer")  # Numba's, on first parallel use
def test_workers_and_greedy_warn_and_give_the_same_mesh():
    with pytest.warns(DeprecationWarning, match="threads="):
        old = triangulate(crease(), method="paper", workers=2)
    same_mesh(old, triangulate(crease(), method="paper", threads=2))
    with pytest.warns(DeprecationWarning, match="greedy"):
        old = triangulate(crease(), method="greedy", vertices=20)
    same_mesh(old, triangulate(crease(), method="refine", vertices=20))


def test_unknown_keyword_is_a_type_error():
    with pytest.raises(TypeError, match="unknown option"):
        triangulate(crease(), tilez=2)


# ------------------------------------------------------------ missing depth, entry points


def write_png(path, img):
    from PIL import Image

    Image.fromarray(img).save(path)


def holed_uint16():
    r, c = np.mgrid[0:48, 0:64]
    img = (1000 + 3 * r + 2 * c).astype(np.uint16)
    img[10:20, 30:45] = 0  # missing depth, as depth PNGs mark it
    img[0, :] = 0
    return img


def test_auto_takes_zero_as_missing_in_integer_images_only():
    img = holed_uint16()
    mesh = triangulate(img, vertices=40)
    same_mesh(mesh, triangulate(img, vertices=40, background=0))
    assert mesh.vertices[:, 2].min() >= 1000  # no vertex at z = 0
    as_float = img.astype(np.float64)  # a float 0 is a depth, named when it looks like a marker
    with pytest.warns(ZeroMarkerWarning, match="look like a no-return marker"):
        assert triangulate(as_float, vertices=40).vertices[:, 2].min() == 0.0


def ranges_with_no_returns():
    """A float range image with 0 (no return) and negative values (behind the sensor) in it."""
    r, c = np.mgrid[0:40, 0:50]
    img = 3.0 + 0.02 * r + 0.01 * c
    img[5:12, 8:20] = 0.0
    img[30, 40] = 0.0  # a one-pixel hole: filled from its neighbours, as any hole
    img[20:24, 30:33] = -1.5
    img[0, 0] = -0.0
    return img


def ray_cameras(shape):
    h, w = shape
    el, az = np.linspace(15, -15, h), np.linspace(60, -60, w)
    spherical = rangemesh.Spherical(el, az)
    return {"pinhole": rangemesh.Pinhole(60.0, 60.0, w / 2, h / 2),
            "spherical": spherical, "rays": rangemesh.Rays(spherical.directions)}


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.uint32, np.int16, np.float32])
def test_nonpositive_marks_zero_and_below_missing_in_every_dtype(dtype):
    # an unsigned image skips the pass that looks for negative depths: zeros are still missing
    image = np.array([[0, 5, 7], [3, 0, 9]], dtype)
    if np.dtype(dtype).kind != "u":
        image[1, 2] = -9
    depth, valid = rangemesh.to_depth_and_mask(image, background="nonpositive")
    want = [[False, True, True], [True, False, np.dtype(dtype).kind == "u"]]
    assert valid.tolist() == want
    assert depth.tolist() == [[0.0, 5.0, 7.0], [3.0, 0.0, 9.0 if want[1][2] else 0.0]]


@pytest.mark.parametrize("kind", ["pinhole", "spherical", "rays"])
def test_auto_takes_zero_and_below_as_no_return_before_a_sensor(kind):
    # F16, issue 41: a float image's 0 put vertices at the sensor (Spherical, Rays) or was
    # refused (Pinhole), and negative depths were meshed behind the camera
    img = ranges_with_no_returns()
    camera = ray_cameras(img.shape)[kind]
    mesh = triangulate(img, camera=camera, vertices=200)
    assert len(mesh.vertices) == 200
    if kind == "pinhole":
        assert mesh.vertices[:, 2].min() > 0
    else:
        assert np.linalg.norm(mesh.vertices, axis=1).min() > 2.9  # the nearest return is 3.0
    # NaN is no return in every dtype and under any background: the same mesh
    same_mesh(mesh, triangulate(np.where(img > 0, img, np.nan), camera=camera, vertices=200))
    same_mesh(mesh, triangulate(img, camera=camera, vertices=200, background="nonpositive"))
    ev = rangemesh.evaluate(mesh, img)  # 'auto' by the mesh's camera, as triangulate took it
    assert ev.valid_pixels == int((img > 0).sum())
    # heights and disparities (Orthographic): 0 and below are data
    assert triangulate(img, vertices=200).vertices[:, 2].min() < 0


def test_the_command_line_takes_no_returns_as_the_api_does(tmp_path, capsys):
    img = ranges_with_no_returns()
    src = tmp_path / "scan.npy"
    np.save(src, img.astype(np.float32))
    camera = rangemesh.Pinhole(60.0, 60.0, 25.0, 20.0)
    one = triangulate(img.astype(np.float32), camera=camera, vertices=200)
    assert main(["mesh", str(src), "--intrinsics", "60,60,25,20", "--vertices", "200", "-o",
                 str(tmp_path / "cli.ply"), "--quiet"]) == 0
    m = read_mesh(tmp_path / "cli.ply")
    assert np.array_equal(m.faces, one.faces)
    np.testing.assert_allclose(m.vertices, one.vertices, rtol=1e-6)  # PLY keeps float32
    assert main(["eval", str(src), str(tmp_path / "cli.ply"), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["relative_error"] == pytest.approx(rangemesh.evaluate(one, img).relative_error,
                                                  rel=1e-4)
    assert main(["info", str(src), "--intrinsics", "60,60,25,20", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["background"] == "0 or below" and doc["valid_pixels"] == int((img > 0).sum())
    assert main(["info", str(src), "--json"]) == 0  # no camera: a float image's 0 is data
    doc = json.loads(capsys.readouterr().out)
    assert doc["valid_pixels"] == img.size and doc["zero_pixels_valid"] == 7 * 12 + 2  # -0.0 too


@pytest.mark.parametrize("background", [10**400, -10**400, Fraction(10**401, 3)]
                         + ([np.longdouble("1e400")]
                            if np.finfo(np.longdouble).max > np.finfo(np.float64).max else []),
                         ids=lambda b: type(b).__name__ + ("-" if b < 0 else ""))
def test_a_background_beyond_the_float_range_is_refused_naming_it(background):
    # F12: 10**400 raised "OverflowError: int too large to convert to float"
    with pytest.raises(ValueError, match=r"^background=\S+ lies beyond the float range"):
        triangulate(np.ones((10, 10), np.uint16), background=background)


def test_four_entry_points_give_the_same_mesh(tmp_path, capsys):
    pytest.importorskip("distributed")
    img = holed_uint16()
    png = tmp_path / "scan.png"
    write_png(png, img)
    one = triangulate(rangemesh.read_range_image(png))
    (streamed,) = list(mesh_stream([img]))
    same_mesh(one, streamed)
    res = rangemesh.mesh_many([png], tmp_path / "many", workers=1)
    assert res[0].status == "meshed", res[0].error
    assert main(["mesh", str(png), "-o", str(tmp_path / "cli.ply"), "--quiet"]) == 0
    for path in (tmp_path / "many" / "scan.ply", tmp_path / "cli.ply"):
        m = read_mesh(path)
        assert np.array_equal(m.faces, one.faces)
        np.testing.assert_allclose(m.vertices, one.vertices, rtol=1e-6)  # PLY keeps float32


def test_triangulates_keywords_are_the_option_table():
    # triangulate names each option (for editors and help()); it must be the table's, in order,
    # with the table's "not given" default, so the keywords and the table cannot drift apart
    tri = inspect.signature(triangulate).parameters
    fixed = ["method", "vertices", "max_error", "max_deviation", "mean_deviation", "background",
             "camera", "color"]
    keywords = [n for n, p in tri.items() if p.kind == p.KEYWORD_ONLY]
    assert keywords == fixed + [o.name for o in OPTION_TABLE]
    for o in OPTION_TABLE:
        # None is "not given" (the method's default), except where None is a setting: flips
        expected = "disparity" if o.name == "flips" else None
        assert tri[o.name].default == expected, o.name


def test_triangulates_docstring_documents_each_option_from_the_table():
    doc = inspect.getdoc(triangulate)
    for o in OPTION_TABLE:
        head = f"\n{o.name} : {o.type}, "
        assert doc.count(head) == 1, o.name
        entry = doc.split(head)[1].split("\n\n")[0]
        body = " ".join(entry.split("\n", 1)[1].split())
        # the method it goes with, then its own paragraph, as the table words them
        note = "Both methods." if len(o.methods) == 2 else f"``{o.methods[0]!r}`` only."
        assert body.startswith(f"{note} {' '.join(o.doc.split())}"), o.name


@pytest.mark.parametrize("option", sorted(OPTION_METHOD))
def test_stream_forwards_each_option_as_triangulate_takes_it(option):
    owner = OPTION_METHOD[option]
    kw = {option: VALUES[option]}
    if option == "jump":
        kw["walls"] = False
    (m,) = mesh_stream([crease()], method=owner, **kw)
    same_mesh(m, triangulate(crease(), method=owner, **kw))


@pytest.mark.parametrize("fn", ["mesh_stream", "mesh_many"])
def test_stream_and_many_refuse_what_is_no_option(fn, tmp_path):
    call = getattr(rangemesh, fn)
    args = ([crease()],) if fn == "mesh_stream" else ([], tmp_path / "out")
    with pytest.raises(TypeError, match=r"^unknown option\(s\) \['delat'\]; the options are"):
        call(*args, delat=20.0)
    with pytest.raises(ValueError, match="delta is an option of method='paper'"):
        call(*args, delta=20.0)
    assert not (tmp_path / "out").exists()  # refused before any work


def test_stream_checks_at_the_call_and_takes_vertices():
    with pytest.raises(ValueError, match="delta is an option of method='paper'"):
        mesh_stream([crease()], delta=10.0)
    (m,) = mesh_stream([crease()], vertices=25)
    assert m.stats.vertices == 25


@given(st.integers(3, 60))
def test_stream_is_triangulate_for_any_count(n):
    (m,) = mesh_stream([crease()], vertices=n)
    same_mesh(m, triangulate(crease(), vertices=n))


# ------------------------------------------------------------ command line


def test_mesh_without_output_writes_beside_the_input(tmp_path, capsys):
    img = tmp_path / "scan.npy"
    np.save(img, crease())
    assert main(["mesh", str(img)]) == 0
    err = capsys.readouterr().err
    out = tmp_path / "scan.ply"
    assert out.exists() and f"wrote {out} (no -o given: beside the input)" in err
    assert read_mesh(out).faces.shape[1] == 3


def test_mesh_without_output_replaces_no_file_unless_overwrite(tmp_path, capsys):
    # F14: an unrelated keep.ply beside keep.npy was replaced, exit 0
    img = tmp_path / "keep.npy"
    np.save(img, crease())
    out = tmp_path / "keep.ply"
    out.write_text("the user's own file")
    assert main(["mesh", str(img), "--quiet"]) == 2
    assert capsys.readouterr().err == (f"rangemesh: error: {out}: already there (the default "
                                       f"output name); give -o FILE to write elsewhere, or "
                                       f"--overwrite to replace it\n")
    assert out.read_text() == "the user's own file"
    assert main(["mesh", str(img), "--quiet", "--overwrite"]) == 0
    assert read_mesh(out).faces.shape[1] == 3
    assert main(["mesh", str(img), "--quiet", "-o", str(out)]) == 0  # a file named is replaced


def test_summary_says_what_each_method_did(tmp_path, capsys):
    img = tmp_path / "c.npy"
    np.save(img, crease())
    main(["mesh", str(img), "-o", str(tmp_path / "r.ply")])
    err = capsys.readouterr().err
    assert "grid" not in err and "flips by the error" in err and "default target" in err
    main(["mesh", str(img), "-o", str(tmp_path / "p.ply"), "--method", "paper",
          "--tiles", "2", "--samples", "5"])
    assert "grid 9x9" in capsys.readouterr().err
    main(["mesh", str(img), "-o", str(tmp_path / "e.ply"), "--method", "paper",
          "--max-edge", "8"])
    err = capsys.readouterr().err
    assert "x1 " not in err and "target max_edge 8.0" in err
    main(["mesh", str(img), "-o", str(tmp_path / "v.ply"), "--method", "paper",
          "--vertices", "60", "--max-edge", "6"])
    err = capsys.readouterr().err
    grid = err.split("grid ")[1].split(" ")[0]
    assert min(int(x) for x in grid.split("x")) > 1, err  # the searched grid, not points x 1


def test_version_and_help(capsys):
    with pytest.raises(SystemExit):
        main(["--version"])
    assert capsys.readouterr().out.strip() == f"rangemesh {rangemesh.__version__}"
    with pytest.raises(SystemExit):
        main(["mesh", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "refine (the default)" in text
    for name in OPTION_METHOD:
        flag = {"walls": "--no-walls"}.get(name, "--" + name.replace("_", "-"))
        assert flag in text, flag


def test_mesh_many_runs_from_a_plain_script(tmp_path):
    pytest.importorskip("distributed")
    write_png(tmp_path / "a.png", holed_uint16())
    script = tmp_path / "plain.py"
    script.write_text(textwrap.dedent(f"""
        import rangemesh
        res = rangemesh.mesh_many([{str(tmp_path / 'a.png')!r}], {str(tmp_path / 'out')!r},
                                  workers=1)
        print("STATUS", res[0].status)
    """))
    run = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                         timeout=240, cwd=tmp_path)
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.count("STATUS meshed") == 1  # the workers did not run the script


# ---------------------------------------------------------------- from the hostile-input reports


# D1 of the 2026-11-21 hostile-input report
@pytest.mark.parametrize("dtype, reference", [
    (np.float16, np.float32),     # float16 holds these integers exactly
    (np.longdouble, np.float64),
    (">f4", np.float32),
    (">u2", np.uint16),
    (">f8", np.float64),
    ("<i8", np.int64),
])
def test_every_real_dtype_meshes_like_its_native_twin(chair, dtype, reference):
    got = rangemesh.triangulate(chair.astype(dtype), background=0, method="paper")
    same_mesh(got, rangemesh.triangulate(chair.astype(reference), background=0, method="paper"))


# D1 of the 2026-11-21 hostile-input report
def test_mesh_stream_and_the_cli_take_big_endian_images(chair, tmp_path, capsys):
    frames = [chair.astype(">f4"), chair.astype(np.float16)]
    got = list(rangemesh.mesh_stream(frames, background=0, method="paper"))
    want = rangemesh.triangulate(chair.astype(np.float32), background=0, method="paper")
    for m in got:
        same_mesh(m, want)
    np.save(tmp_path / "be.npy", chair.astype(">f4"))
    assert main(["mesh", str(tmp_path / "be.npy"), "-o", str(tmp_path / "be.ply"), "--quiet",
                 "--background", "0"]) == 0
    assert main(["info", str(tmp_path / "be.npy")]) == 0


# F15 (found after the 2026-11-21 hostile-input report)
def test_longdouble_depths_beyond_float64_are_refused_with_their_range():
    # F15: they became infinite in float64, i.e. missing depth, and an image of them meshed
    # to nothing ("no valid pixel") without a word
    if np.finfo(np.longdouble).max <= np.finfo(np.float64).max:
        pytest.skip("longdouble is float64 on this platform")
    with pytest.raises(ValueError, match=r"^depths 1e\+400 \.\. 1e\+400: their range exceeds the "
                                         r"float range"):
        rangemesh.triangulate(np.full((20, 20), np.longdouble("1e400")), vertices=50)
    d = np.full((20, 20), 5.0, np.longdouble)
    d[3, 4] = np.longdouble(np.finfo(np.float64).max) * 4
    for method in ("refine", "paper"):
        with pytest.raises(ValueError, match=r"^depths 5 \.\. 7\.19077e\+308: their range"):
            rangemesh.triangulate(d, method=method)
    d[3, 4] = np.inf  # infinite is missing depth in any dtype
    masked = np.ma.masked_array(np.full((20, 20), np.longdouble("1e400")), mask=True)
    masked[5:15, 5:15] = 5.0  # a masked pixel is missing, whatever its value
    for image in (d, masked):
        m = rangemesh.triangulate(image, vertices=30)
        assert len(m.vertices) == 30 and np.isfinite(m.vertices).all()


# D2 of the 2026-11-21 hostile-input report
def test_masked_pixels_are_missing_depth(chair):
    z = chair.astype(np.float64)
    mask = z > 120
    got = rangemesh.triangulate(np.ma.masked_array(z, mask=mask), background=0, method="paper")
    want = rangemesh.triangulate(np.where(mask, np.nan, z), background=0, method="paper")
    same_mesh(got, want)
    assert not mask[got.pixels[:, 0], got.pixels[:, 1]].any()
    # integer masked arrays too, and evaluate honours the mask as well
    got_int = rangemesh.triangulate(np.ma.masked_array(chair, mask=mask), background=0, method="paper")
    same_mesh(got_int, want)
    ev = rangemesh.evaluate(got, np.ma.masked_array(z, mask=mask), background=0)
    assert ev.valid_pixels == int(((z != 0) & ~mask).sum())


# D7 of the 2026-11-21 hostile-input report
def test_a_ragged_list_names_the_image():
    with pytest.raises(ValueError, match="image"):
        rangemesh.triangulate([[1, 2, 3], [4, 5]], method="paper")


# E17 of the 2026-11-25 hostile-input report
@pytest.mark.parametrize("option", [{"walls": False}, {"jump": 0.1}, {"diagonals": "error"},
                                    {"heights": "fit"}])
def test_mesh_stream_refuses_what_triangulate_refuses(option):
    z = np.add.outer(np.arange(20.0), np.arange(30.0))
    with pytest.raises(ValueError) as want:
        rangemesh.triangulate(z, method="paper", **option)
    with pytest.raises(ValueError) as got:
        rangemesh.mesh_stream([z], method="paper", **option)  # at the call, before any frame
    assert str(got.value) == str(want.value)


# E17 of the 2026-11-25 hostile-input report
def test_mesh_stream_gives_triangulates_mesh_with_a_target():
    from tests.golden import fingerprint

    frames = [np.add.outer(np.arange(20.0), np.arange(30.0)) ** 1.5, np.ones((10, 12))]
    for kw in ({"vertices": 40}, {"max_error": 0.5}, {"vertices": 40, "method": "paper"}):
        got = list(rangemesh.mesh_stream(frames, **kw))
        want = [rangemesh.triangulate(f, **kw) for f in frames]
        assert [fingerprint(m) for m in got] == [fingerprint(m) for m in want]


# E11 of the 2026-11-25 hostile-input report
@pytest.mark.parametrize("method", ["refine", "paper"])
def test_depths_beyond_the_kernels_reach_are_one_valueerror(method):
    z = np.full((30, 30), 1e308)
    z[10:20] = -1e307
    if method == "paper":
        with pytest.raises(ValueError, match="reach beyond 1e\\+150"):
            rangemesh.triangulate(z, vertices=30, method=method)
    else:  # refine scales depths by a power of two first (E9): a finite range meshes
        mesh = rangemesh.triangulate(z, vertices=30, method=method)
        assert len(mesh.vertices) == 30 and np.isfinite(mesh.vertices).all()
        assert np.isfinite(rangemesh.evaluate(mesh, z).relative_error)
    big = np.finfo(float).max
    z = np.full((40, 40), big)
    z[5:10, 5:10] = -big
    with pytest.raises(ValueError, match="reach beyond|exceeds the float range"):
        rangemesh.triangulate(z, vertices=30, method=method)
