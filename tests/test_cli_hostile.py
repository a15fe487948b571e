"""Every subcommand, every option, hostile values: a result or one line on stderr, never a traceback.

The options are read from the parser itself, so an option added later is
swept too. An accepted value must end with exit status 0; a refused one with
status 2 and exactly one line ``rangemesh...: error: ...`` on stderr.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pytest

import rangemesh
from rangemesh.cli import build_parser, main
from rangemesh.io import write_mesh

from .helpers import one_error_line

CROPS = Path(__file__).parent / "data" / "crops.npz"

# numbers out of range, not numbers, overflowing, subnormal, empty, lists, odd spellings
HOSTILE = ["nan", "-inf", "-1", "0", "1e400", "abc", "", "3,4,5,6,7", "99999999999", "1e-320", "2x"]


def _options(command):
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return sorted(a.option_strings[-1] for a in sub.choices[command]._actions
                  if a.option_strings and a.nargs is None and not isinstance(a, argparse._HelpAction))


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("hostile")
    img = np.load(CROPS)["chair"][:48, :48]
    np.save(d / "chair.npy", img)
    assert main(["mesh", str(d / "chair.npy"), "-o", str(d / "chair.ply"), "--quiet"]) == 0
    return d


def _run(capsys, argv):
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse refuses an option before main's own checks
        code = exc.code
    out = capsys.readouterr()
    assert "Traceback" not in out.err, (argv, out.err)
    assert code in (0, 2), (argv, code, out.err)
    if code == 2:
        lines = out.err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("rangemesh") and ": error: " in lines[0], \
            (argv, out.err)
        assert lines[0].split(": error: ", 1)[1].strip(), (argv, "empty message")
    return code


def _base(command, d):
    return {
        "mesh": ["mesh", str(d / "chair.npy"), "-o", str(d / "out.ply")],
        "demo": ["demo", "-o", str(d / "demo.ply"), "--preview", ""],
        "info": ["info", str(d / "chair.npy")],
        "eval": ["eval", str(d / "chair.npy"), str(d / "chair.ply")],
        "batch": ["batch", str(d / "chair.npy"), "-o", str(d / "batch"), "--workers", "1"],
    }[command]


def _sweep(command, files, capsys, values):
    refused = 0
    for opt in _options(command):
        if opt in ("--preview", "--output", "--output-dir"):
            continue  # paths: swept by test_hostile_paths
        for value in values:
            argv = _base(command, files) + [opt, value]
            if command == "demo" and opt == "--preview":
                continue
            refused += _run(capsys, argv) == 2
    assert refused > 0  # the sweep reached the checks


@pytest.mark.parametrize("command", ["mesh", "demo", "info", "eval"])
def test_every_option_with_hostile_values(command, files, capsys):
    _sweep(command, files, capsys, HOSTILE)


@pytest.mark.slow
def test_batch_every_option_with_hostile_values(files, capsys):
    pytest.importorskip("dask.distributed")
    # every accepted value starts a cluster: the values most likely to get through
    _sweep("batch", files, capsys, ["nan", "-1", "0", "abc", "1e400"])


@pytest.mark.parametrize("path", ["", "/", "/dev/null", "/proc/self/status", "missing.npy",
                                  "dir.ply", "x.PLY", "x.ply/", "chair.npy", "/nonexistent/x.ply"])
def test_hostile_paths(files, capsys, path, monkeypatch):
    monkeypatch.chdir(files)
    (files / "dir.ply").mkdir(exist_ok=True)
    src = str(files / "chair.npy")
    for argv in (["mesh", src, "-o", path], ["mesh", src, "--preview", path],
                 ["mesh", path], ["info", path], ["eval", src, path], ["eval", path, "chair.ply"]):
        _run(capsys, argv)
    assert (files / "chair.npy").is_file() and np.load(files / "chair.npy").shape == (48, 48)


# ---------------------------------------------------------------- from the hostile-input reports


# D6 of the 2026-11-21 hostile-input report
def test_a_huge_sample_grid_is_refused_at_once(chair_file, capsys):
    code = main(["mesh", str(chair_file), "--samples", "10000"])
    one_error_line(capsys, code, match="samples")


# D12 of the 2026-11-21 hostile-input report
def test_a_preview_may_not_replace_the_input(tmp_path, chair, capsys):
    import imageio.v3 as iio

    src = tmp_path / "teddy.png"
    iio.imwrite(src, chair)
    before = src.read_bytes()
    code = main(["mesh", str(src), "-o", str(tmp_path / "t.ply"), "--preview", str(src)])
    one_error_line(capsys, code, match="input")
    assert src.read_bytes() == before
    assert not (tmp_path / "t.ply").exists()


# D12 of the 2026-11-21 hostile-input report
def test_a_symlink_to_the_input_is_the_input(tmp_path, chair, capsys):
    import imageio.v3 as iio

    src = tmp_path / "teddy.png"
    iio.imwrite(src, chair)
    (tmp_path / "link.png").symlink_to(src)
    code = main(["mesh", str(src), "--preview", str(tmp_path / "link.png")])
    one_error_line(capsys, code, match="input")


# D13 of the 2026-11-21 hostile-input report
@pytest.mark.parametrize("option", [
    ["--delta", "nan"], ["--delta", "-1"], ["--epsilon", "-1"], ["--max-angle", "-1"],
    ["--min-bend", "-1"], ["--levels", "0"], ["--curvature-floor", "0"],
    ["--intrinsics", "0,525,64,64"], ["--intrinsics", "nan,525,64,64"],
    ["--intrinsics", "525,525,64,64", "--depth-scale", "-1"], ["--scale", "0,1,1"],
])
def test_out_of_range_options_give_one_line(chair_file, capsys, option):
    one_error_line(capsys, main(["mesh", str(chair_file), *option]))


# D13 of the 2026-11-21 hostile-input report
def test_out_of_range_batch_options_give_one_line(chair_file, tmp_path, capsys):
    one_error_line(capsys, main(["batch", str(chair_file), "-o", str(tmp_path / "o"),
                                 "--delta", "nan"]))


# E4 of the 2026-11-25 hostile-input report
def test_eval_of_a_crafted_ply_header_is_one_line(tmp_path, capsys):
    img = np.full((4, 5), 10.0)
    np.save(tmp_path / "img.npy", img)
    mesh = rangemesh.triangulate(img, method="refine", vertices=6)
    path = tmp_path / "m.ply"
    write_mesh(mesh, path)
    data = path.read_bytes().replace(b"element vertex 6\n", b"element vertex 900000000\n")
    path.write_bytes(data)
    assert main(["eval", str(tmp_path / "img.npy"), str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "claims 900000000 vertex elements" in err[0]


# E6 of the 2026-11-25 hostile-input report
def test_beams_dev_zero_is_one_line(scan_file, tmp_path, capsys):
    assert main(["mesh", str(scan_file), "--beams", "/dev/zero", "--vertices", "200",
                 "-o", str(tmp_path / "o.ply")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not a regular file" in err[0]


# E8 of the 2026-11-25 hostile-input report
def test_outputs_that_are_the_same_file_are_refused(tmp_path, capsys):
    img = tmp_path / "d.npy"
    np.save(img, np.add.outer(np.arange(20.0), np.arange(30.0)))
    col = tmp_path / "c.npy"
    np.save(col, np.zeros((20, 30, 3), np.uint8))
    obj = tmp_path / "m.obj"
    # the OBJ's texture is m.texture.png: a preview of that name would overwrite it
    assert main(["mesh", str(img), "--color", str(col), "--vertices", "30", "-o", str(obj),
                 "--preview", str(tmp_path / "m.texture.png")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "two outputs would be the same file" in err[0]
    assert not obj.exists()
