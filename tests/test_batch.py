"""Issue 6: streams, batches, and a real local Dask cluster."""

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import rangemesh
from rangemesh import scenes
from rangemesh.batch import expand_inputs, mesh_many, mesh_stream
from rangemesh.cli import main
from rangemesh.io import read_mesh

from .golden import crops
from .helpers import one_error_line


def test_stream_equals_triangulate_frame_by_frame():
    frames = [scenes.box((90, 120), noise=0.3, seed=s).depth for s in range(3)]
    frames += [scenes.dome((70, 80)).depth, scenes.pyramid((90, 120)).depth]
    got = list(mesh_stream(iter(frames), samples=8, method="paper"))
    assert len(got) == len(frames)
    for frame, mesh in zip(frames, got, strict=True):
        want = rangemesh.triangulate(frame, samples=8, method="paper")
        assert np.array_equal(mesh.faces, want.faces)
        assert np.array_equal(mesh.pixels, want.pixels)
        assert mesh.vertices.tobytes() == want.vertices.tobytes()
        assert mesh.stats.seconds["total"] > 0


def test_stream_reports_bad_frames_clearly():
    with pytest.raises(ValueError, match="2-D"):
        list(mesh_stream([np.zeros((4, 4, 3))], method="paper"))
    good = scenes.plane((20, 30)).depth
    # a boolean frame after a good one of the same shape
    stream = mesh_stream([good, good > 100], method="paper")
    assert not next(stream).is_empty
    with pytest.raises(TypeError, match="dtype"):
        next(stream)
    empty = list(mesh_stream([np.zeros((20, 20))], background=0, method="paper"))
    assert empty[0].is_empty and empty[0].stats.reason


def _inputs(tmp_path):
    """The committed crops of the real images as PNG (TIFF for the TIFF one), named as their sources."""
    import json

    import imageio.v3 as iio

    src = tmp_path / "in"
    src.mkdir()
    meta = json.loads((Path(__file__).parent / "data" / "crops.json").read_text())
    for name, (arr, _) in crops().items():
        if arr.dtype.kind == "u":  # (PNG and TIFF hold no float32)
            stem, suffix = os.path.splitext(os.path.basename(meta[name]["source"]))
            iio.imwrite(src / (stem + (".tiff" if suffix == ".tiff" else ".png")), arr)
    (src / "corrupt.png").write_bytes(b"\x89PNG\r\n\x1a\n this is no image")
    os.symlink(tmp_path / "nowhere.png", src / "unreadable.png")
    return src


@pytest.fixture(scope="module")
def batch_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("batch")
    src = _inputs(tmp)
    out = tmp / "out"
    out.mkdir()
    (out / ".venus_disp2.ply.abc.part.ply").write_bytes(b"half a mesh")  # left by a killed run
    results = mesh_many([src], out, workers=2, background="auto", method="paper")
    return src, out, results


@pytest.mark.slow
def test_batch_meshes_good_files_and_reports_bad_ones(batch_run):
    src, out, results = batch_run
    by_name = {os.path.basename(r.input): r for r in results}
    assert by_name["corrupt.png"].status == "failed" and by_name["corrupt.png"].error
    assert by_name["unreadable.png"].status == "failed" and "no such file" in by_name["unreadable.png"].error
    good = [r for r in results if r.status == "meshed"]
    assert len(good) == len(results) - 2
    for r in good:
        assert r.vertices > 100 and np.isfinite(r.relative_error)
        assert os.path.getsize(r.output) > 0
    # nothing half-written, stale temporaries cleaned
    assert not list(out.glob(".*part*")) and not (out / "corrupt.ply").exists()
    doc = json.loads((out / "rangemesh-batch.json").read_text())
    assert doc["summary"]["failed"] == 2 and doc["summary"]["meshed"] == len(good)
    assert (out / "rangemesh-batch.csv").read_text().count("\n") == len(results) + 1


@pytest.mark.slow
def test_batch_output_equals_single_meshing(batch_run):
    src, out, results = batch_run
    import meshio

    img = rangemesh.io.read_range_image(src / "cones_disp2.png")
    want = rangemesh.triangulate(img, background=0, method="paper")
    back = meshio.read(out / "cones_disp2.ply")
    assert np.array_equal(back.cells_dict["triangle"], want.faces)


@pytest.mark.slow
def test_rerun_skips_and_overwrite_redoes(batch_run, capsys):
    src, out, results = batch_run
    rc = main(["batch", str(src / "cones_disp2.png"), str(src / "venus_disp2.png"), "-o", str(out),
               "--method", "paper", "--workers", "1", "--json"])
    doc = json.loads(capsys.readouterr().out)
    assert rc == 0 and doc["summary"]["skipped"] == 2 and doc["summary"]["meshed"] == 0
    before = (out / "cones_disp2.ply").stat().st_mtime_ns
    rc = main(["batch", str(src / "cones_disp2.png"), "-o", str(out), "--workers", "1",
               "--method", "paper", "--overwrite", "--quiet"])  # the fixture's method
    assert rc == 0 and (out / "cones_disp2.ply").stat().st_mtime_ns != before


@pytest.mark.slow
def test_cli_batch_exit_code_and_summary(batch_run, tmp_path, capsys):
    src, _, _ = batch_run
    rc = main(["batch", str(src / "*.png"), "-o", str(tmp_path / "o"), "--workers", "2",
               "--format", "obj"])
    err = capsys.readouterr().err
    assert rc == 1  # something failed
    assert "failed: " in err and "corrupt.png" in err and "images/s" in err
    assert (tmp_path / "o" / "venus_disp2.obj").exists()
    rc = main(["batch", str(tmp_path / "nothing-*.png"), "-o", str(tmp_path / "p")])
    assert rc == 2 and "no file matches" in capsys.readouterr().err


@pytest.mark.slow
def test_real_local_dask_cluster_gives_the_same_outputs(batch_run, tmp_path):
    from dask.distributed import LocalCluster

    src, out_local, _ = batch_run
    files = sorted(p for p in src.iterdir() if p.name not in ("corrupt.png", "unreadable.png"))[:4]
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=":0", silence_logs=40) as cluster:
        results = mesh_many(files, tmp_path, scheduler=cluster.scheduler_address,
                            background="auto", method="paper")
    assert all(r.status == "meshed" for r in results)
    for f in files:
        name = f.stem + ".ply"
        assert (tmp_path / name).read_bytes() == (out_local / name).read_bytes()


def test_expand_inputs(tmp_path):
    (tmp_path / "a.png").write_bytes(b"")
    (tmp_path / "b.npy").write_bytes(b"")
    (tmp_path / "c.txt").write_bytes(b"")
    assert [p.name for p in expand_inputs([tmp_path])] == ["a.png", "b.npy"]
    assert [p.name for p in expand_inputs([str(tmp_path / "*.png"), tmp_path / "a.png"])] == ["a.png"]
    with pytest.raises(FileNotFoundError):
        expand_inputs([tmp_path / "zzz.png"])


def test_local_workers_run_one_thread_each(tmp_path, monkeypatch):
    """One process per core: method="refine"'s second thread is switched off in the workers."""
    import dask.distributed

    seen = {}

    class Stop(Exception):
        pass

    def fake_cluster(**kwargs):
        seen.update(kwargs)
        raise Stop

    monkeypatch.setattr(dask.distributed, "LocalCluster", fake_cluster)
    np.save(tmp_path / "a.npy", np.ones((8, 8)))
    with pytest.raises(Stop):  # workers=None: a cluster of every core, even of one
        mesh_many([tmp_path / "a.npy"], tmp_path / "out", method="paper")
    assert seen["threads_per_worker"] == 1
    assert seen["env"] == {"RANGEMESH_THREADS": "1"}


def test_cli_batch_takes_the_deviation_targets(tmp_path, capsys):
    # batch lacked --max-deviation and --mean-deviation, which `mesh` takes (issue 42)
    a = scenes.dome((40, 50)).depth
    np.save(tmp_path / "a.npy", a)
    rc = main(["batch", str(tmp_path / "a.npy"), "-o", str(tmp_path / "out"), "--workers", "1",
               "--max-deviation", "0.5"])
    assert rc == 0, capsys.readouterr().err
    back = rangemesh.read_mesh(tmp_path / "out" / "a.ply")
    want = rangemesh.triangulate(a, max_deviation=0.5)
    assert np.array_equal(back.faces, want.faces)
    assert rangemesh.evaluate(want, a).max_deviation <= 0.5
    rc = main(["batch", str(tmp_path / "a.npy"), "-o", str(tmp_path / "o2"), "--max-deviation",
               "0.5", "--vertices", "30"])
    assert rc == 2
    assert "max_deviation and vertices exclude each other" in capsys.readouterr().err


def test_cli_batch_output_that_is_an_input_or_a_file_is_one_line(tmp_path, capsys):
    # `batch a.npy -o a.npy` said only "a.npy: File exists" (issue 42)
    a = tmp_path / "a.npy"
    np.save(a, scenes.dome((40, 50)).depth)
    data = a.read_bytes()
    rc = main(["batch", str(a), "-o", str(a), "--workers", "1"])
    one_error_line(capsys, rc, match=f"-o {a} is the input {a}: the meshes go to a folder")
    (tmp_path / "notes.txt").write_text("mine")
    rc = main(["batch", str(a), "-o", str(tmp_path / "notes.txt"), "--workers", "1"])
    one_error_line(capsys, rc, match="notes.txt is a file: the meshes go to a folder")
    assert a.read_bytes() == data and (tmp_path / "notes.txt").read_text() == "mine"


def test_mesh_many_refuses_a_file_as_out_dir_and_arrays_as_paths(tmp_path):
    # mesh_many(out_dir=<a file>) said only "[Errno 17] File exists"; an array among the paths
    # said "expected str, bytes or os.PathLike object" (found after issue 42)
    a = tmp_path / "a.npy"
    np.save(a, scenes.dome((40, 50)).depth)
    (tmp_path / "notes.txt").write_text("mine")
    with pytest.raises(ValueError, match="out_dir .*notes.txt is a file: the meshes go to a folder"):
        mesh_many([a], tmp_path / "notes.txt", workers=1)
    assert (tmp_path / "notes.txt").read_text() == "mine"
    with pytest.raises(TypeError, match="paths must name files, .* got ndarray"):
        mesh_many([np.ones((8, 8))], tmp_path / "out", workers=1)


def test_one_worker_meshes_in_this_process_without_dask(tmp_path, monkeypatch):
    """workers=1: no cluster is started (Dask need not be installed); the same files come out."""
    import rangemesh.batch as batch

    def no_dask(*args, **kwargs):
        raise AssertionError("a Dask client was asked for")

    monkeypatch.setattr(batch, "dask_client", no_dask)
    a = scenes.dome((40, 50)).depth
    np.save(tmp_path / "a.npy", a)
    (tmp_path / "b.png").write_bytes(b"not a png")
    results = mesh_many([tmp_path / "a.npy", tmp_path / "b.png"], tmp_path / "out", workers=1,
                        vertices=30, progress=True)
    assert [r.status for r in results] == ["meshed", "failed"]
    back = rangemesh.read_mesh(tmp_path / "out" / "a.ply")
    want = rangemesh.triangulate(a, vertices=30)
    assert np.array_equal(back.faces, want.faces)
    np.testing.assert_allclose(back.vertices, want.vertices, rtol=1e-6)  # PLY keeps float32
    assert (tmp_path / "out" / "rangemesh-batch.csv").exists()


def _csv_rows(path):
    import csv

    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def test_a_folder_batch_skips_colour_images_and_previews_without_failing(shared_data, tmp_path,
                                                                          capsys):
    # issue 41: a folder's colour images and previews were counted as failed inputs
    import shutil

    import imageio.v3 as iio

    src = tmp_path / "in"
    src.mkdir()
    iio.imwrite(src / "cones.png", crops()["cones"][0])  # the committed crop of cones_disp2.png
    shutil.copy(shared_data / "rgbd/slambook2_ch7_1_color.png", src / "color.png")  # 8-bit RGB
    assert main(["mesh", str(src / "cones.png"), "-o", str(tmp_path / "c.ply"), "--preview",
                 str(src / "cones-preview.png"), "--vertices", "100", "--quiet"]) == 0
    capsys.readouterr()
    rc = main(["batch", str(src), "-o", str(tmp_path / "out"), "--vertices", "100",
               "--workers", "1"])
    err = capsys.readouterr().err
    assert rc == 0, err
    assert "meshed 1, skipped 2 (0 already there, 2 not depth images: colour images or " \
           "previews), failed 0 of 3" in err
    rows = {Path(r["input"]).name: r for r in _csv_rows(tmp_path / "out" / "rangemesh-batch.csv")}
    assert rows["cones.png"]["status"] == "meshed" and rows["cones.png"]["vertices"] == "100"
    for name in ("color.png", "cones-preview.png"):
        assert rows[name]["status"] == "skipped"
        assert rows[name]["error"].startswith("not a depth image: a range image has one channel; "
                                              "this file holds ")
    assert sorted(p.name for p in (tmp_path / "out").glob("*.ply")) == ["cones.ply"]
    doc = json.loads((tmp_path / "out" / "rangemesh-batch.json").read_text())
    assert doc["summary"]["failed"] == 0 and doc["summary"]["skipped_not_depth"] == 2


def test_a_rerun_with_other_options_refuses_and_the_report_keeps_earlier_rows(tmp_path, capsys):
    # issue 41: a re-run with other options skipped every file as "already there" and replaced
    # the CSV with empty "skipped" rows
    src = tmp_path / "in"
    src.mkdir()
    np.save(src / "chair.npy", crops()["chair"][0])  # the committed crop of odetics/chair-range
    np.save(src / "venus.npy", crops()["venus"][0])
    out = tmp_path / "out"
    csv_path, mesh = out / "rangemesh-batch.csv", out / "chair.ply"

    def batch(*argv):
        rc = main(["batch", *map(str, argv), "-o", str(out), "--workers", "1", "--quiet"])
        return rc, capsys.readouterr().err

    assert batch(src / "chair.npy", "--vertices", 100) == (0, "")
    first = _csv_rows(csv_path)
    assert [(r["status"], r["vertices"]) for r in first] == [("meshed", "100")]
    # the same options: the mesh is there; its row keeps the figures, a new input's row joins it
    assert batch(src / "chair.npy", src / "venus.npy", "--vertices", 100) == (0, "")
    rows = _csv_rows(csv_path)
    assert rows[0] == first[0]
    assert [(Path(r["input"]).name, r["status"], r["vertices"]) for r in rows] == [
        ("chair.npy", "meshed", "100"), ("venus.npy", "meshed", "100")]
    doc = json.loads((out / "rangemesh-batch.json").read_text())
    assert doc["summary"]["skipped"] == 1 and doc["summary"]["meshed"] == 1
    # other options: refused in one line naming --overwrite; nothing written, no row lost
    report, stamp = csv_path.read_bytes(), mesh.stat().st_mtime_ns
    rc, err = batch(src / "chair.npy", "--vertices", 200)
    assert rc == 2 and err.count("\n") == 1
    assert err.startswith(f"rangemesh: error: {out}: its meshes were made with other options "
                          f"(vertices 100 then, 200 now); give --overwrite")
    assert csv_path.read_bytes() == report and mesh.stat().st_mtime_ns == stamp
    rc, err = batch(src / "chair.npy", "--vertices", 100, "--no-walls")
    assert rc == 2 and "walls default then, False now" in err, err
    # --overwrite meshes again with the new options and keeps the other input's row
    assert batch(src / "chair.npy", "--vertices", 200, "--overwrite") == (0, "")
    rows = _csv_rows(csv_path)
    assert sorted((Path(r["input"]).name, r["status"], r["vertices"]) for r in rows) == [
        ("chair.npy", "meshed", "200"), ("venus.npy", "meshed", "100")]
    assert rangemesh.read_mesh(mesh).vertices.shape == (200, 3)


def test_a_batch_keeps_each_vertex_pixel_when_the_camera_needs_it(tmp_path):
    # a distorted camera's rays (z_depth) cannot be projected back to pixels: the mesh file must
    # carry them, as `rangemesh mesh` writes them, or `rangemesh eval` cannot place its vertices
    from rangemesh import Rays, read_mesh, triangulate

    r, c = np.mgrid[0:24, 0:32].astype(np.float64)
    img = (1000 + 3 * r + 2 * c).astype(np.uint16)
    rays = np.stack([(c - 16.0) / 30.0, (r - 12.0) / 30.0, np.ones_like(r)], axis=-1)
    cam = Rays(rays, 0.001, z_depth=True)
    np.save(tmp_path / "a.npy", img)
    [res] = rangemesh.mesh_many([tmp_path / "a.npy"], tmp_path / "out", camera=cam,
                                vertices=20, workers=1)
    assert res.status == "meshed", res.error
    written = read_mesh(res.output, camera=cam)
    want = triangulate(img, camera=cam, vertices=20)
    assert written.pixels is not None
    assert np.array_equal(written.pixels, want.pixels)


# ---------------------------------------------------------------- from the hostile-input reports


# D20 of the 2026-11-21 hostile-input report
def test_too_many_workers_are_refused_at_once(chair_file, tmp_path, capsys):
    pytest.importorskip("dask.distributed")
    cores = len(os.sched_getaffinity(0))
    code = main(["batch", str(chair_file), "-o", str(tmp_path / "o"), "--workers",
                 str(cores + 1)])
    one_error_line(capsys, code, match="cores")


# D21 of the 2026-11-21 hostile-input report
def test_a_server_that_is_not_dask_fails_fast(chair_file, tmp_path, capsys):
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


# D22 of the 2026-11-21 hostile-input report
def test_inputs_sharing_a_stem_are_all_meshed(tmp_path, chair, capsys):
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


# D22 of the 2026-11-21 hostile-input report
def test_the_same_file_name_in_two_folders_fails_those_only(tmp_path, chair):
    pytest.importorskip("dask.distributed")
    from rangemesh.batch import mesh_many

    for d in ("a", "b"):
        (tmp_path / d).mkdir()
        np.save(tmp_path / d / "x.npy", chair)
    np.save(tmp_path / "a" / "z.npy", chair)
    res = mesh_many([tmp_path / "a", tmp_path / "b"], tmp_path / "out", workers=1, method="paper")
    status = {Path(r.input).relative_to(tmp_path).as_posix(): r.status for r in res}
    assert status == {"a/x.npy": "failed", "a/z.npy": "meshed", "b/x.npy": "failed"}


# E1 of the 2026-11-25 hostile-input report
@pytest.mark.slow
def test_batch_with_beams_takes_zero_as_no_return(scan_file, beams_file, tmp_path):
    out = tmp_path / "out"
    assert main(["batch", str(scan_file), "-o", str(out), "--beams", str(beams_file),
                 "--vertices", "1500", "--quiet", "--workers", "1"]) == 0
    mesh = read_mesh(out / "scan.ply")
    # a no-return pixel as a vertex sits at the sensor origin
    assert (np.linalg.norm(mesh.vertices, axis=1) > 0).all()
    # and each vertex is one of the scan's returns: its pixel's range times its ray
    rng = np.load(scan_file)
    assert len(mesh.vertices) == 1500 and (rng > 0).sum() > len(mesh.vertices)


# the 2026-11-25 hostile-input report
@pytest.mark.slow
def test_batch_runs_when_another_program_holds_the_dashboard_port(tmp_path):
    import socket

    img = tmp_path / "a.npy"
    np.save(img, np.add.outer(np.arange(20.0), np.arange(30.0)))
    with socket.socket() as held:
        try:
            held.bind(("127.0.0.1", 8787))  # Dask's default dashboard port
        except OSError:
            pass  # already held by another program: the case under test
        held.listen()
        results = rangemesh.mesh_many([img], tmp_path / "out", workers=1, method="refine",
                                      vertices=20)
    assert [r.status for r in results] == ["meshed"]


# E15 of the 2026-11-25 hostile-input report
@pytest.mark.slow
def test_a_glob_over_the_output_folder_gives_the_same_inputs_every_run(tmp_path, capsys):
    g = tmp_path / "g"
    g.mkdir()
    img = np.add.outer(np.arange(20.0), np.arange(30.0))
    np.save(g / "c0.npy", img)
    np.save(g / "c1.npy", img + 1)
    for _ in range(2):
        assert main(["batch", str(g / "*"), "-o", str(g), "--vertices", "30", "--workers", "1",
                     "--quiet"]) == 0
    names = sorted(p.name for p in g.iterdir())
    assert names == ["c0.npy", "c0.ply", "c1.npy", "c1.ply", "rangemesh-batch.csv",
                     "rangemesh-batch.json"]
    report = json.loads((g / "rangemesh-batch.json").read_text())
    assert report["summary"]["skipped"] == 2  # a re-run skips, and keeps the rows of the meshes
    assert [r["status"] for r in report["results"]] == ["meshed", "meshed"]


# E16 of the 2026-11-25 hostile-input report
def test_a_running_batchs_temp_files_are_left_alone(tmp_path):
    import os
    import subprocess
    import sys

    from rangemesh.batch import _clean_stale_parts, write_report
    from rangemesh.io import atomic_path
    from rangemesh.io.files import part_owner

    # a temp file of this (running) process, one of a process that is gone, one of another host
    with atomic_path(tmp_path / "m.ply") as mine:
        mine.write_text("x")
        gone = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                              capture_output=True, text=True, check=True).stdout.strip()
        host = part_owner().rsplit(".", 1)[0]
        dead = tmp_path / f".n.ply.{host}.{gone}.abc.part.ply"
        dead.write_text("x")
        other = tmp_path / ".o.ply.otherhost.1.abc.part.ply"
        other.write_text("x")
        old = tmp_path / ".p.ply.otherhost.2.abc.part.ply"
        old.write_text("x")
        os.utime(old, (0, 0))
        _clean_stale_parts(tmp_path)
        assert mine.exists() and other.exists()
        assert not dead.exists() and not old.exists()
    # the reports go through unique temporary names, not fixed ones
    write_report([], tmp_path, 0.0)
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        ".o.ply.otherhost.1.abc.part.ply", "m.ply", "rangemesh-batch.csv", "rangemesh-batch.json"]


# E27 of the 2026-11-25 hostile-input report
def test_the_same_file_by_two_paths_is_meshed_once(tmp_path, monkeypatch):
    from rangemesh.batch import expand_inputs

    (tmp_path / "in").mkdir()
    np.save(tmp_path / "in" / "c.npy", np.ones((4, 4)))
    monkeypatch.chdir(tmp_path)
    assert expand_inputs(["in/c.npy", str(tmp_path / "in" / "c.npy")]) == [Path("in/c.npy")]


# E28 of the 2026-11-25 hostile-input report
@pytest.mark.slow
def test_batch_reads_the_bin_scans_that_mesh_reads(os1, beams_file, tmp_path, capsys):
    folder = tmp_path / "in"
    folder.mkdir()
    shutil.copy(os1["bin"], folder / "s.bin")
    shutil.copy(os1["range"], folder / "r.npy")
    made = tmp_path / "m.ply"
    assert main(["mesh", str(folder / "s.bin"), "--beams", str(beams_file), "--vertices", "1500",
                 "-o", str(made), "--pixels", "--quiet"]) == 0
    want = read_mesh(made)
    for name, inputs in (("file", [str(folder / "s.bin")]), ("folder", [str(folder)])):
        out = tmp_path / name
        assert main(["batch", *inputs, "-o", str(out), "--beams", str(beams_file), "--vertices",
                     "1500", "--workers", "1", "--quiet"]) == 0, capsys.readouterr().err
        got = read_mesh(out / "s.ply")  # before: "unknown image type '.bin'", or left out
        assert np.array_equal(got.faces, want.faces)
        np.testing.assert_allclose(got.vertices, want.vertices, rtol=1e-6)
    assert (tmp_path / "folder" / "r.ply").exists()
    # without --beams a named .bin fails in one line, as `rangemesh mesh` does
    assert main(["batch", str(folder / "s.bin"), "-o", str(tmp_path / "x"), "--vertices", "1500",
                 "--workers", "1"]) == 1
    assert "needs --beams" in capsys.readouterr().err


# ------------------------------------------------------------------ coloured folder batches


def _rgbd_folder(root: Path) -> Path:
    """Two 20 x 30 frames, depth/a.png and depth/b.png (a plane: 1000 + 10 row + 5 col, uint16),
    with rgb/a.png and rgb/b.png: red 8 col, green 8 row, blue 40 (a) or 200 (b)."""
    import imageio.v3 as iio

    (root / "depth").mkdir(parents=True)
    (root / "rgb").mkdir()
    r, c = np.mgrid[0:20, 0:30]
    for name, blue in (("a", 40), ("b", 200)):
        iio.imwrite(root / "depth" / f"{name}.png", (1000 + 10 * r + 5 * c).astype(np.uint16))
        rgb = np.stack([8 * c, 8 * r, np.full_like(r, blue)], axis=-1).astype(np.uint8)
        iio.imwrite(root / "rgb" / f"{name}.png", rgb)
    return root


def _colored(path: Path):
    """A PLY file's vertex depth and colours."""
    from plyfile import PlyData

    v = PlyData.read(str(path))["vertex"]
    return np.asarray(v["z"], float), np.stack([v["red"], v["green"], v["blue"]], -1).astype(int)


def _check_colors(path: Path, blue: int):
    z, rgb = _colored(path)
    assert len(z) == 12 and (rgb[:, 2] == blue).all()
    # each vertex's colour is its own pixel's: the pixel (green / 8, red / 8) has the vertex's depth
    assert np.array_equal(z, 1000 + 10 * (rgb[:, 1] // 8) + 5 * (rgb[:, 0] // 8))


def test_a_folder_batch_takes_colours_by_a_pattern(tmp_path, capsys, monkeypatch):
    _rgbd_folder(tmp_path)
    monkeypatch.chdir(tmp_path)  # a relative pattern is taken from the current folder
    rc = main(["batch", "depth", "--color-pattern", "rgb/{stem}.png", "-o", "out",
               "--vertices", "12", "--heights", "pixel", "--workers", "1"])
    assert rc == 0, capsys.readouterr().err
    _check_colors(tmp_path / "out/a.ply", 40)
    _check_colors(tmp_path / "out/b.ply", 200)


def test_a_folder_batch_takes_colours_from_an_association_list(tmp_path, capsys):
    root = _rgbd_folder(tmp_path / "seq")
    # TUM's associate.py order either way round; here each depth takes the *other* frame's
    # colour, so the pairs come from the list and not from the names
    (root / "associations.txt").write_text("# depth and rgb\n"
                                           "1305031102.175304 depth/a.png 1305031102.160407 rgb/b.png\n"
                                           "1305031102.211214 rgb/a.png 1305031102.226738 depth/b.png\n")
    rc = main(["batch", "--associations", str(root / "associations.txt"), "-o",
               str(tmp_path / "out"), "--vertices", "12", "--heights", "pixel", "--workers", "1"])
    err = capsys.readouterr().err
    assert rc == 0, err
    assert "meshed 2, skipped 0 (already there), failed 0 of 2" in err
    _check_colors(tmp_path / "out/a.ply", 200)
    _check_colors(tmp_path / "out/b.ply", 40)


def test_a_depth_file_without_its_colour_fails_alone_and_colour_files_are_skipped(tmp_path, capsys):
    import shutil

    root = _rgbd_folder(tmp_path / "seq")
    flat = tmp_path / "flat"
    flat.mkdir()
    shutil.copy(root / "depth/a.png", flat / "a.png")
    shutil.copy(root / "depth/b.png", flat / "b.png")
    shutil.copy(root / "rgb/a.png", flat / "a_rgb.png")  # b has none
    rc = main(["batch", str(flat), "--color-pattern", "{dir}/{stem}_rgb.png", "-o",
               str(tmp_path / "out"), "--vertices", "12", "--heights", "pixel", "--workers", "1"])
    err = capsys.readouterr().err
    assert rc == 1, err
    assert "meshed 1, skipped 1 (0 already there, 1 not depth images" in err and "failed 1 of 3" in err
    rows = {Path(r["input"]).name: r for r in _csv_rows(tmp_path / "out/rangemesh-batch.csv")}
    assert rows["a_rgb.png"]["status"] == "skipped"
    assert rows["b.png"]["status"] == "failed" and "b_rgb.png" in rows["b.png"]["error"]
    _check_colors(tmp_path / "out/a.ply", 40)


def test_colour_options_say_what_is_wrong_in_one_line(tmp_path, capsys, shared_data):
    root = _rgbd_folder(tmp_path / "seq")
    out = str(tmp_path / "out")
    one_error_line(capsys, main(["batch", str(root / "depth"), "--color-pattern", "rgb/x.png",
                                 "-o", out]), match="must name the depth file by {stem}")
    one_error_line(capsys, main(["batch", str(root / "depth"), "--color-pattern", "{stem}.png",
                                 "--associations", str(root / "x.txt"), "-o", out]),
                   match="exclude each other")
    (root / "bad.txt").write_text("1.0 depth/a.png rgb/a.png\n")
    one_error_line(capsys, main(["batch", "--associations", str(root / "bad.txt"), "-o", out]),
                   match="line 1 is not 'stamp path stamp path'")
    one_error_line(capsys, main(["batch", "-o", out]), match="give the inputs")
    bag = shared_data / "rosbag/librealsense_d435_single_depth_color_640x480.bag"
    one_error_line(capsys, main(["batch", str(bag), "--color-pattern", "{stem}.png", "-o", out]),
                   match="--color-topic")


def test_a_rerun_with_other_colours_is_refused_as_other_options(tmp_path):
    root = _rgbd_folder(tmp_path / "seq")
    pairs = {root / "depth/a.png": root / "rgb/a.png", root / "depth/b.png": root / "rgb/b.png"}
    res = mesh_many(root / "depth", tmp_path / "out", colors=pairs, vertices=12, workers=1)
    assert [r.status for r in res] == ["meshed", "meshed"]
    with pytest.raises(ValueError, match="colors"):
        mesh_many(root / "depth", tmp_path / "out", colors=str(root / "rgb/{stem}.png"),
                  vertices=12, workers=1)
    with pytest.raises(TypeError, match="colors must be a pattern string or a mapping"):
        mesh_many(root / "depth", tmp_path / "other", colors=3, vertices=12, workers=1)


def test_a_coloured_batch_of_the_tum_frame_gives_what_mesh_color_gives(shared_data, tmp_path,
                                                                         capsys):
    import shutil

    seq = tmp_path / "tum"
    (seq / "depth").mkdir(parents=True)
    (seq / "rgb").mkdir()
    shutil.copy(shared_data / "rgbd/slambook2_ch7_1_depth.png", seq / "depth/1.png")
    shutil.copy(shared_data / "rgbd/slambook2_ch7_1_color.png", seq / "rgb/1.png")
    (seq / "associations.txt").write_text("1.0 rgb/1.png 1.0 depth/1.png\n")
    cam = ["--intrinsics", "520.9,521.0,325.1,249.7", "--depth-scale", "0.0002"]
    assert main(["batch", "--associations", str(seq / "associations.txt"), "-o",
                 str(tmp_path / "out"), "--vertices", "2000", "--workers", "1", *cam]) == 0
    assert main(["mesh", str(seq / "depth/1.png"), "--color", str(seq / "rgb/1.png"), "-o",
                 str(tmp_path / "one.ply"), "--vertices", "2000", "--quiet", *cam]) == 0
    capsys.readouterr()
    z, rgb = _colored(tmp_path / "out/1.ply")
    z1, rgb1 = _colored(tmp_path / "one.ply")
    assert np.array_equal(z, z1) and np.array_equal(rgb, rgb1)
    assert len(np.unique(rgb, axis=0)) > 500  # the photo's colours, not one grey
