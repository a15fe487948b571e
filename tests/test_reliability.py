"""Regression tests for the hostile-input report of 2026-11-21 (shared/reports/reliability-*.md).

One test (or parametrised group) per defect, named after it: ``test_dN_...``.
Each reproduces the report's case and asserts the expected behaviour, so it
failed before the fix. Expected meshes come from an independent reference:
the same image given in a form the library always handled (float32 instead of
float16, NaN instead of a mask, unscaled instead of subnormal values).
"""

from __future__ import annotations

import math
import os
import signal
import stat
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import rangemesh
from rangemesh import MeshParams, scenes
from rangemesh.cli import main

from .helpers import assert_valid_mesh, interrupt

CROPS = Path(__file__).parent / "data" / "crops.npz"


@pytest.fixture(scope="module")
def chair():
    """A 96x96 uint8 crop of the Odetics chair (background 0)."""
    return np.load(CROPS)["chair"]


@pytest.fixture
def chair_file(tmp_path, chair):
    p = tmp_path / "chair.npy"
    np.save(p, chair)
    return p


def same_mesh(a, b):
    assert np.array_equal(a.pixels, b.pixels)
    assert np.array_equal(a.faces, b.faces)
    assert np.array_equal(a.vertices, b.vertices)


def one_error_line(capsys, code, expected_code=2, match=None):
    """The CLI ended with `expected_code` and said exactly one line on stderr."""
    err = capsys.readouterr().err
    assert code == expected_code, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("rangemesh: error: "), err
    assert "Traceback" not in err
    if match:
        assert match in lines[0], lines[0]
    return lines[0]


# ---------------------------------------------------------------- D1 dtypes


@pytest.mark.parametrize("dtype, reference", [
    (np.float16, np.float32),     # float16 holds these integers exactly
    (np.longdouble, np.float64),
    (">f4", np.float32),
    (">u2", np.uint16),
    (">f8", np.float64),
    ("<i8", np.int64),
])
def test_d1_every_real_dtype_meshes_like_its_native_twin(chair, dtype, reference):
    got = rangemesh.triangulate(chair.astype(dtype), background=0, method="paper")
    same_mesh(got, rangemesh.triangulate(chair.astype(reference), background=0, method="paper"))


def test_d1_mesh_stream_and_cli_take_big_endian(chair, tmp_path, capsys):
    frames = [chair.astype(">f4"), chair.astype(np.float16)]
    got = list(rangemesh.mesh_stream(frames, background=0, method="paper"))
    want = rangemesh.triangulate(chair.astype(np.float32), background=0, method="paper")
    for m in got:
        same_mesh(m, want)
    np.save(tmp_path / "be.npy", chair.astype(">f4"))
    assert main(["mesh", str(tmp_path / "be.npy"), "-o", str(tmp_path / "be.ply"), "--quiet",
                 "--background", "0"]) == 0
    assert main(["info", str(tmp_path / "be.npy")]) == 0


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


# ---------------------------------------------------------------- D2 masked arrays


def test_d2_masked_pixels_are_missing_depth(chair):
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


# ---------------------------------------------------------------- D3 subnormal depths


def test_d3_subnormal_depths_give_the_same_samples(chair):
    z = chair.astype(np.float64)
    tiny = z * 2.0**-1030  # subnormal, and exact: chair values are integers below 256
    assert 0 < tiny[tiny > 0].max() < np.finfo(np.float64).tiny
    a = rangemesh.triangulate(z, background=0, flips=None, method="paper")
    b = rangemesh.triangulate(tiny, background=0, flips=None, method="paper")  # warnings are errors here
    assert np.array_equal(a.pixels, b.pixels) and np.array_equal(a.faces, b.faces)
    ev = rangemesh.evaluate(b, tiny, background=0)
    assert np.isfinite(ev.relative_error)
    assert ev.relative_error == pytest.approx(rangemesh.evaluate(a, z, background=0).relative_error)


# ---------------------------------------------------------------- D6 grid size


@pytest.mark.parametrize("samples", [10_000, 10**6, 10**9])
def test_d6_huge_sample_grids_are_refused_before_allocating(chair, samples):
    with pytest.raises(ValueError, match="samples"):
        rangemesh.triangulate(chair, samples=samples, method="paper")


def test_d6_small_images_keep_grids_up_to_65536(chair):
    # 4 tiles of 24 px with 60 samples each: a 237x237 grid (56,169 entries) on 9,216 px
    m = rangemesh.triangulate(chair, background=0, samples=60, method="paper")
    assert m.stats.grid_shape == (237, 237)
    with pytest.raises(ValueError, match="at most 65536"):
        rangemesh.triangulate(chair, background=0, samples=66, method="paper")  # 261 x 261 = 68,121


def test_d6_cli_refuses_at_once(chair_file, capsys):
    code = main(["mesh", str(chair_file), "--samples", "10000"])
    one_error_line(capsys, code, match="samples")


# ---------------------------------------------------------------- D7, D8, D9 parameter types


@pytest.mark.parametrize("kwargs, name", [
    ({"vertices": "100"}, "vertices"),
    ({"max_error": "1"}, "max_error"),
    ({"max_edge": "5"}, "max_edge"),
    ({"levels": "1"}, "levels"),
    ({"tiles": "44"}, "tiles"),          # D8: not (4, 4)
    ({"samples": "10"}, "samples"),      # D8: not (1, 0)
    ({"fill_gaps": "no"}, "fill_gaps"),  # D8: not True
    ({"fill_gaps": "False"}, "fill_gaps"),
    ({"delta": "20"}, "delta"),
    ({"threads": "2"}, "threads"),
])
def test_d7_d8_wrong_types_name_the_parameter(kwargs, name):
    with pytest.raises(TypeError, match=name):
        rangemesh.triangulate(np.ones((30, 30)), method="paper", **kwargs)


def test_d8_none_is_the_default_in_calls_and_refused_in_meshparams():
    # a keyword left at None takes the method's default; MeshParams has no "not given"
    a = rangemesh.triangulate(np.add.outer(np.arange(30.0), np.arange(30.0)), method="paper",
                              levels=None)
    b = rangemesh.triangulate(np.add.outer(np.arange(30.0), np.arange(30.0)), method="paper",
                              levels=2)
    assert np.array_equal(a.faces, b.faces)
    with pytest.raises(TypeError, match="levels"):
        rangemesh.MeshParams(levels=None)


def test_d7_ragged_list_names_the_image():
    with pytest.raises(ValueError, match="image"):
        rangemesh.triangulate([[1, 2, 3], [4, 5]], method="paper")


@pytest.mark.parametrize("value, pair", [
    (np.int64(3), (3, 3)), (np.int32(3), (3, 3)), (np.float64(3.0), (3, 3)), (3.0, (3, 3)),
    ((np.int16(2), np.uint8(3)), (2, 3)), ([2, 3], (2, 3)),
])
def test_d9_numpy_whole_numbers_are_accepted(value, pair):
    assert MeshParams(tiles=value).tiles == pair
    assert isinstance(MeshParams(tiles=value).tiles[0], int)


def test_d9_flags_take_numpy_bools():
    assert MeshParams(fill_gaps=np.bool_(False)).fill_gaps is False


# ---------------------------------------------------------------- D10 max_edge with a target


@pytest.mark.parametrize("target", [{"vertices": 500}, {"max_error": 1.0}, {"vertices": 2000}])
def test_d10_max_edge_with_a_target_covers_the_image(target):
    z = scenes.crease((120, 120)).depth  # every pixel valid
    m = rangemesh.triangulate(z, background=0, max_edge=5, method="paper", **target)
    assert rangemesh.evaluate(m, z, background=0).uncovered == 0.0
    p = m.pixels[m.faces].astype(float)
    assert np.sqrt(((p - np.roll(p, 1, axis=1)) ** 2).sum(-1)).max() <= 5.0
    assert_valid_mesh(m)


def test_d10_unreachable_vertex_target_says_why():
    z = scenes.crease((120, 120)).depth
    m = rangemesh.triangulate(z, background=0, vertices=500, max_edge=5, method="paper")
    # a 120x120 image with edges <= 5 px needs at least (119/5)^2 ~ 566 points
    assert m.stats.vertices > 566
    assert not m.stats.target.met
    assert "max_edge" in m.stats.target.note


# ---------------------------------------------------------------- D11 camera overflow


def test_d11_overflowing_camera_is_refused(chair):
    with pytest.raises(ValueError, match="camera"):
        rangemesh.triangulate(chair, background=0,
                              camera=rangemesh.Pinhole(1e-300, 1e-300, 0, 0, 1e300), method="paper")
    with pytest.raises(ValueError, match="camera"):
        rangemesh.triangulate(np.full((20, 20), 1e300), camera=(1, 1, 1e10), method="paper")


# ---------------------------------------------------------------- D12 outputs never replace inputs


def test_d12_preview_may_not_replace_the_input(tmp_path, chair, capsys):
    import imageio.v3 as iio

    src = tmp_path / "teddy.png"
    iio.imwrite(src, chair)
    before = src.read_bytes()
    code = main(["mesh", str(src), "-o", str(tmp_path / "t.ply"), "--preview", str(src)])
    one_error_line(capsys, code, match="input")
    assert src.read_bytes() == before
    assert not (tmp_path / "t.ply").exists()


def test_d12_a_symlink_to_the_input_is_the_input(tmp_path, chair, capsys):
    import imageio.v3 as iio

    src = tmp_path / "teddy.png"
    iio.imwrite(src, chair)
    (tmp_path / "link.png").symlink_to(src)
    code = main(["mesh", str(src), "--preview", str(tmp_path / "link.png")])
    one_error_line(capsys, code, match="input")


# ---------------------------------------------------------------- D13 bad options: one line


@pytest.mark.parametrize("option", [
    ["--delta", "nan"], ["--delta", "-1"], ["--epsilon", "-1"], ["--max-angle", "-1"],
    ["--min-bend", "-1"], ["--levels", "0"], ["--curvature-floor", "0"],
    ["--intrinsics", "0,525,64,64"], ["--intrinsics", "nan,525,64,64"],
    ["--intrinsics", "525,525,64,64", "--depth-scale", "-1"], ["--scale", "0,1,1"],
])
def test_d13_out_of_range_options_give_one_line(chair_file, capsys, option):
    one_error_line(capsys, main(["mesh", str(chair_file), *option]))


def test_d13_batch_too(chair_file, tmp_path, capsys):
    one_error_line(capsys, main(["batch", str(chair_file), "-o", str(tmp_path / "o"),
                                 "--delta", "nan"]))


# ---------------------------------------------------------------- D14 write failures


def test_d14_output_that_is_a_folder(chair_file, tmp_path, capsys):
    (tmp_path / "adir.ply").mkdir()
    code = main(["mesh", str(chair_file), "-o", str(tmp_path / "adir.ply")])
    one_error_line(capsys, code, match="folder")


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_d14_read_only_folder(chair_file, tmp_path, capsys):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        code = main(["mesh", str(chair_file), "-o", str(ro / "o.ply")])
    finally:
        ro.chmod(0o755)
    one_error_line(capsys, code, match="Permission denied")


def test_d14_permission_denied_as_any_user(chair_file, tmp_path, capsys, monkeypatch):
    import errno
    import tempfile

    def denied(*args, dir=None, **kwargs):
        raise PermissionError(errno.EACCES, "Permission denied", str(Path(dir) / ".o.ply.x.part.ply"))

    monkeypatch.setattr(tempfile, "mkstemp", denied)
    line = one_error_line(capsys, main(["mesh", str(chair_file), "-o", str(tmp_path / "o.ply")]))
    assert line == f"rangemesh: error: {tmp_path / 'o.ply'}: Permission denied"


@pytest.mark.parametrize("suffix, target", [(".ply", "rangemesh.io._write_ply"),
                                            (".png", "matplotlib.figure.Figure.savefig")])
def test_d14_full_disk(chair_file, tmp_path, capsys, monkeypatch, suffix, target):
    import errno

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(target, full)
    args = ["mesh", str(chair_file)]
    args += ["-o", str(tmp_path / "o.ply")] if suffix == ".ply" else ["--preview", str(tmp_path / "p.png")]
    line = one_error_line(capsys, main(args), match="No space left on device")
    assert "o.ply" in line or "p.png" in line  # the target, not the temporary name
    assert sorted(p.name for p in tmp_path.iterdir()) == ["chair.npy"]


# ---------------------------------------------------------------- D15 file modes


@pytest.mark.parametrize("umask, mode", [(0o022, 0o644), (0o002, 0o664), (0o077, 0o600)])
def test_d15_outputs_follow_the_umask(chair_file, tmp_path, umask, mode):
    old = os.umask(umask)
    try:
        assert main(["mesh", str(chair_file), "-o", str(tmp_path / "m.ply"),
                     "--preview", str(tmp_path / "m.png"), "--quiet"]) == 0
    finally:
        os.umask(old)
    for name in ("m.ply", "m.png"):
        assert stat.S_IMODE((tmp_path / name).stat().st_mode) == mode


def test_d15_an_overwritten_file_keeps_its_mode(chair_file, tmp_path):
    out = tmp_path / "m.obj"
    out.write_text("old")
    out.chmod(0o640)
    assert main(["mesh", str(chair_file), "-o", str(out), "--quiet"]) == 0
    assert stat.S_IMODE(out.stat().st_mode) == 0o640 and out.read_text() != "old"


# ---------------------------------------------------------------- D16, D17 signals

_DELAUNAY_LOOP = textwrap.dedent("""
    import numpy as np, sys
    from rangemesh.paper.triangulation import triangulate_points
    pts = np.unique(np.random.default_rng(0).integers(0, 1500, (250_000, 2)), axis=0)
    triangulate_points(pts[:100])
    print("ready", flush=True)
    while True:
        triangulate_points(pts)
""")


def test_d16_sigint_during_delaunay_never_crashes(tmp_path):
    """Ctrl-C lands inside the Delaunay kernel most of the time; before the fix some of
    these runs ended in a segmentation fault (exit -11) or SystemError."""
    script = tmp_path / "loop.py"
    script.write_text(_DELAUNAY_LOOP)
    for delay in (0.05, 0.2, 0.45, 0.7, 1.1):
        proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True)
        assert proc.stdout.readline().strip() == "ready"
        import time

        time.sleep(delay)
        err = interrupt(proc)
        # an uncaught KeyboardInterrupt ends Python by SIGINT itself (returncode -2)
        assert proc.returncode == -signal.SIGINT, err
        assert err.rstrip().endswith("KeyboardInterrupt"), err
        assert "SystemError" not in err and "Fatal Python error" not in err


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGHUP, signal.SIGINT])
def test_d17_signal_while_writing_leaves_nothing(chair_file, tmp_path, monkeypatch, capsys, signum):
    import rangemesh.io as rio

    real = rio._write_ply

    def write_then_signal(mesh, tmp, *args):
        real(mesh, tmp, *args)  # the temporary file exists and is complete
        os.kill(os.getpid(), signum)

    monkeypatch.setattr(rio, "_write_ply", write_then_signal)
    (tmp_path / "out.ply").write_text("old")
    code = main(["mesh", str(chair_file), "-o", str(tmp_path / "out.ply"), "--quiet"])
    assert code == 128 + signum
    assert "interrupted" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["chair.npy", "out.ply"]
    assert (tmp_path / "out.ply").read_text() == "old"
    assert signal.getsignal(signal.SIGTERM) == signal.SIG_DFL  # handlers are put back


# ---------------------------------------------------------------- D18, D19 readers and previews


def test_d18_empty_pcd_and_truncated_tiff_give_one_line(tmp_path, capsys):
    import tifffile

    pytest.importorskip("pypcd4")
    (tmp_path / "empty.pcd").write_bytes(b"")
    one_error_line(capsys, main(["mesh", str(tmp_path / "empty.pcd")]))
    tifffile.imwrite(tmp_path / "t.tiff", np.ones((200, 200), np.float32))
    data = (tmp_path / "t.tiff").read_bytes()
    for cut in (len(data) // 2, 8, 16):
        (tmp_path / "half.tiff").write_bytes(data[:cut])
        one_error_line(capsys, main(["mesh", str(tmp_path / "half.tiff")]))


def test_d19_unicode_names_in_previews_are_quiet(tmp_path, chair, capsys):
    src = tmp_path / "ünïcödé-深度.npy"
    np.save(src, chair)
    assert main(["mesh", str(src), "--preview", str(tmp_path / "p.png"), "--quiet"]) == 0
    assert capsys.readouterr().err == ""


# ---------------------------------------------------------------- D20, D21, D22 batch


def test_d20_too_many_workers_is_refused_at_once(chair_file, tmp_path, capsys):
    pytest.importorskip("dask.distributed")
    cores = len(os.sched_getaffinity(0))
    code = main(["batch", str(chair_file), "-o", str(tmp_path / "o"), "--workers",
                 str(cores + 1)])
    one_error_line(capsys, code, match="cores")


def test_d21_a_server_that_is_not_dask_fails_fast(chair_file, tmp_path, capsys):
    """A listener that accepts and never answers (the report's hang), then one that sends garbage."""
    import socket
    import threading
    import time

    pytest.importorskip("dask.distributed")
    for garbage in (False, True):
        srv = socket.socket()
        srv.bind(("127.0.0.1", 0))
        srv.listen()
        port = srv.getsockname()[1]
        held = []

        def serve(srv=srv, garbage=garbage, held=held):
            try:
                conn, _ = srv.accept()
            except OSError:
                return
            held.append(conn)
            if garbage:
                conn.sendall(b"\xff" * 64 + bytes(range(256)) * 8)

        threading.Thread(target=serve, daemon=True).start()
        t0 = time.perf_counter()
        from rangemesh.batch import mesh_many

        with pytest.raises(ValueError, match="Dask scheduler"):
            mesh_many([chair_file], tmp_path / "o", scheduler=f"tcp://127.0.0.1:{port}",
                      connect_timeout=2.0, method="paper")
        assert time.perf_counter() - t0 < 20
        srv.close()
        for c in held:
            c.close()


def test_d22_inputs_sharing_a_stem_are_all_meshed(tmp_path, chair, capsys):
    pytest.importorskip("dask.distributed")
    import imageio.v3 as iio

    src = tmp_path / "in"
    src.mkdir()
    np.save(src / "x.npy", chair)
    iio.imwrite(src / "x.png", chair)
    np.save(src / "y.npy", chair)
    code = main(["batch", str(src), "-o", str(tmp_path / "out"), "--workers", "1", "--quiet"])
    assert code == 0
    names = sorted(p.name for p in (tmp_path / "out").glob("*.ply"))
    assert names == ["x.npy.ply", "x.png.ply", "y.ply"]


def test_d22_same_file_name_in_two_folders_fails_those_only(tmp_path, chair):
    pytest.importorskip("dask.distributed")
    from rangemesh.batch import mesh_many

    for d in ("a", "b"):
        (tmp_path / d).mkdir()
        np.save(tmp_path / d / "x.npy", chair)
    np.save(tmp_path / "a" / "z.npy", chair)
    res = mesh_many([tmp_path / "a", tmp_path / "b"], tmp_path / "out", workers=1, method="paper")
    status = {Path(r.input).relative_to(tmp_path).as_posix(): r.status for r in res}
    assert status == {"a/x.npy": "failed", "a/z.npy": "meshed", "b/x.npy": "failed"}


# ---------------------------------------------------------------- D23-D27 eval


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


@pytest.mark.parametrize("bad_index", [2**31 - 1, "V+10", -5, -1])
def test_d23_d24_d25_face_indices_out_of_range_are_refused(chair_file, chair, tmp_path, capsys,
                                                           bad_index):
    m = rangemesh.triangulate(chair, background=0, method="paper")
    faces = m.faces.copy()
    faces[0, 0] = len(m.vertices) + 10 if bad_index == "V+10" else bad_index
    _ply_with_faces(tmp_path / "bad.ply", m, faces)
    code = main(["eval", str(chair_file), str(tmp_path / "bad.ply")])
    one_error_line(capsys, code, match="out of range")
    with pytest.raises(ValueError, match="out of range"):
        rangemesh.read_mesh(tmp_path / "bad.ply")


def test_d24_d25_evaluate_checks_a_hand_made_mesh(chair):
    m = rangemesh.triangulate(chair, background=0, method="paper")
    import dataclasses

    for bad in (-1, len(m.vertices)):
        f = m.faces.copy()
        f[3, 1] = bad
        with pytest.raises(ValueError, match="out of range"):
            rangemesh.evaluate(dataclasses.replace(m, faces=f), chair, background=0)


def test_d26_mesh_of_another_image_size_is_refused(chair_file, tmp_path, capsys):
    assert main(["mesh", str(chair_file), "-o", str(tmp_path / "good.ply"), "--quiet"]) == 0
    other = tmp_path / "other.npy"
    np.save(other, np.ones((50, 70), np.uint8))
    line = one_error_line(capsys, main(["eval", str(other), str(tmp_path / "good.ply")]))
    assert "96x96" in line and "50x70" in line


def test_d27_nonsense_meshes_are_refused(chair_file, chair, tmp_path, capsys):
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


# ---------------------------------------------------------------- memory rule


def test_an_image_larger_than_free_memory_is_refused_before_work(monkeypatch, chair, chair_file,
                                                                  capsys):
    import rangemesh.pipeline as pl

    # 96 x 96 pixels x 20 bytes = 184,320 bytes: refuse with less available, mesh with more
    monkeypatch.setattr(pl, "available_memory", lambda: 184_319)
    with pytest.raises(MemoryError, match="96x96 image needs"):
        rangemesh.triangulate(chair, background=0, method="paper")
    one_error_line(capsys, main(["mesh", str(chair_file)]), match="memory")
    monkeypatch.setattr(pl, "available_memory", lambda: 184_320)
    assert not rangemesh.triangulate(chair, background=0, method="paper").is_empty


def test_free_memory_is_read_at_most_once_a_second(monkeypatch):
    import builtins
    import time

    import rangemesh.pipeline as pl

    if not os.path.exists("/proc/meminfo"):
        pytest.skip("no /proc/meminfo on this system")
    reads = []
    real_open = builtins.open

    def counting_open(path, *args, **kwargs):
        if path == "/proc/meminfo":
            reads.append(path)
        return real_open(path, *args, **kwargs)

    now = [1000.0]
    monkeypatch.setattr(builtins, "open", counting_open)
    monkeypatch.setattr(time, "monotonic", lambda: now[0])
    monkeypatch.setattr(pl, "_meminfo", [-math.inf, None])
    first = pl.available_memory()
    assert first is not None and first > 0
    now[0] += 0.5  # within MEMINFO_SECONDS: the value read before
    assert pl.available_memory() == first and len(reads) == 1
    now[0] += 0.6  # 1.1 s after the read: read again
    pl.available_memory()
    assert len(reads) == 2


# ---------------------------------------------------------------- found by the second hostile run


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


def test_folders_and_pipes_are_not_files(tmp_path, capsys):
    with pytest.raises(ValueError, match="folder"):
        rangemesh.read_range_image(tmp_path)
    fifo = tmp_path / "f.npy"
    os.mkfifo(fifo)
    one_error_line(capsys, main(["mesh", str(fifo)]), match="regular file")


def test_a_closed_stdout_ends_quietly(chair_file):
    # `rangemesh mesh ... --json | head`: here the reader leaves before the JSON is written
    cmd = f"{sys.executable} -m rangemesh mesh {chair_file} --json --background 0 | true"
    proc = subprocess.run(["bash", "-c", cmd], capture_output=True, text=True, timeout=120)
    assert proc.stderr == "", proc.stderr
