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

from rangemesh.cli import build_parser, main

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
