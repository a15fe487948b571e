"""rangemesh.io.files: atomic outputs, file modes, and what a failed or interrupted write leaves."""

import os
import signal
import stat
from pathlib import Path

import pytest

from rangemesh.cli import main

from .helpers import one_error_line


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
