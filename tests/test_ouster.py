"""Ouster recordings in ``rangemesh info``, ``mesh`` and ``batch`` (issue 41), through ouster-sdk.

The tests that need the SDK skip without it and run in .ci/ouster (an environment of their own:
ouster-sdk pins rosbags==0.9.23). Expected points come from the SDK itself (its XYZ lookup
table applied to its own scans), not from rangemesh's reader.
"""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from plyfile import PlyData

from rangemesh.cli import main

from .test_live import ENV, META, PCAP, sdk


def _rangemesh(*args):
    return subprocess.run([sys.executable, "-m", "rangemesh", *map(str, args)],
                          capture_output=True, text=True, env=ENV, timeout=300)


def _sdk_scans(shared_data):
    """Every scan's stamp, range and points (destaggered), read by the SDK alone."""
    from ouster.sdk import core, open_source

    src = open_source(str(shared_data / PCAP), meta=[str(shared_data / META)])
    info = src.sensor_info[0]
    lut = core.XYZLut(info)
    out = []
    for group in src:
        scan = group[0]
        stamp = int(scan.timestamp[scan.get_first_valid_column()])
        rng = core.destagger(info, scan.field(core.ChanField.RANGE))
        out.append((stamp, rng, core.destagger(info, lut(scan))))
    src.close()
    return out


def _vertices(path: Path) -> np.ndarray:
    v = PlyData.read(str(path))["vertex"]
    return np.stack([v["x"], v["y"], v["z"]], axis=1).astype(np.float64)


def test_ouster_info_counts_the_scans_and_their_valid_pixels(shared_data):
    sdk("ouster.sdk")
    scans = _sdk_scans(shared_data)
    p = _rangemesh("info", shared_data / PCAP, "--meta", shared_data / META, "--frame", 2, "--json")
    assert p.returncode == 0, p.stderr
    got = json.loads(p.stdout)
    stamp, rng, _ = scans[2]
    assert got["scans"] == len(scans) == 3
    assert got["shape"] == [128, 1024] and got["sensor"] == "OS-1-128" and got["whole_circle"]
    assert got["stamp_ns"] == stamp
    assert got["valid_pixels"] == int(np.count_nonzero(rng))  # 0 mm: no return
    assert got["range_max_m"] == pytest.approx(rng.max() / 1000.0)
    text = _rangemesh("info", shared_data / PCAP, "--meta", shared_data / META)
    assert text.returncode == 0, text.stderr
    assert "3 scans of 128 rows x 1024 columns at 10 Hz, the whole circle" in text.stdout


def test_ouster_mesh_of_one_frame_puts_each_vertex_at_the_sdk_s_point(shared_data, tmp_path):
    sdk("ouster.sdk")
    scans = _sdk_scans(shared_data)
    out = tmp_path / "scan1.ply"
    # each vertex at its own pixel's range (no fitted heights, no gap filled): the SDK's point
    p = _rangemesh("mesh", shared_data / PCAP, "--meta", shared_data / META, "--frame", 1,
                   "--vertices", 1500, "--heights", "pixel", "--no-fill-gaps", "--pixels",
                   "-o", out)
    assert p.returncode == 0, p.stderr
    assert "vertices 1500" in p.stderr
    ply = PlyData.read(str(out))["vertex"]
    r, c = np.asarray(ply["row"], int), np.asarray(ply["col"], int)
    xyz = scans[1][2]
    # the PLY file keeps float32 coordinates: equal within their rounding (the offsets are ~3 cm)
    assert np.allclose(_vertices(out), xyz[r, c], rtol=1e-6, atol=1e-6)
    # scan 1 is not scan 0: its points differ (the sensor moved between them)
    assert not np.allclose(_vertices(out), scans[0][2][r, c], rtol=0, atol=1e-3)


def test_ouster_mesh_defaults_to_the_first_scan_beside_the_recording(shared_data, tmp_path):
    sdk("ouster.sdk")
    rec = tmp_path / "run.pcap"
    rec.write_bytes((shared_data / PCAP).read_bytes())
    p = _rangemesh("mesh", rec, "--meta", shared_data / META, "--vertices", 800,
                   "--heights", "pixel", "--no-fill-gaps", "--pixels")
    assert p.returncode == 0, p.stderr
    out = tmp_path / "run.frame0.ply"
    ply = PlyData.read(str(out))["vertex"]
    r, c = np.asarray(ply["row"], int), np.asarray(ply["col"], int)
    assert np.allclose(_vertices(out), _sdk_scans(shared_data)[0][2][r, c], rtol=1e-6,
                       atol=1e-6)
    # the whole circle: faces join column 1023 to column 0 (the seam closed, as `live` does)
    faces = np.stack(PlyData.read(str(out))["face"]["vertex_indices"])
    cols = c[faces]
    assert ((cols == 0).any(axis=1) & (cols == 1023).any(axis=1)).sum() > 0


def test_ouster_batch_meshes_every_scan_as_a_recording(shared_data, tmp_path):
    sdk("ouster.sdk")
    from scipy.spatial import cKDTree

    scans = _sdk_scans(shared_data)
    out = tmp_path / "frames"
    p = _rangemesh("batch", shared_data / PCAP, "--meta", shared_data / META, "-o", out,
                   "--workers", 1, "--vertices", 600, "--heights", "pixel", "--no-fill-gaps")
    assert p.returncode == 0, p.stderr
    assert "meshed 3, skipped 0" in p.stderr
    # one file per scan, named by the SDK's stamp (seconds.nanoseconds)
    names = sorted(f.name for f in out.glob("*.ply"))
    assert names == [f"{s // 10**9}.{s % 10**9:09d}.ply" for s, _, _ in scans]
    for (_, rng, xyz), name in zip(scans, names, strict=True):
        v = _vertices(out / name)
        assert len(v) == 600
        d, _ = cKDTree(xyz[rng > 0]).query(v)
        assert d.max() < 1e-4  # every vertex is one of that scan's own points (float32 in the file)


def test_ouster_batch_to_mcap_needs_a_rosbags_that_writes_it(shared_data, tmp_path):
    sdk("ouster.sdk")
    from importlib.metadata import version

    out = tmp_path / "frames.mcap"
    p = _rangemesh("batch", shared_data / PCAP, "--meta", shared_data / META, "-o", out,
                   "--workers", 1, "--vertices", 300)
    major, minor = (int(x) for x in version("rosbags").split(".")[:2])
    if (major, minor) < (0, 10):  # ouster-sdk 1.0's pin: one line, no traceback
        assert p.returncode == 2 and "rosbags>=0.10" in p.stderr and "-o FOLDER" in p.stderr
        assert "Traceback" not in p.stderr and not out.exists()
        return
    assert p.returncode == 0, p.stderr
    from rosbags.highlevel import AnyReader

    with AnyReader([out]) as reader:
        assert [c.topic for c in reader.connections] == ["/os_lidar/mesh"]
        assert sum(1 for _ in reader.messages()) == 3


def test_ouster_eval_of_a_mesh_file_gives_the_errors_mesh_reported(shared_data, tmp_path):
    sdk("ouster.sdk")
    rec = ["--meta", shared_data / META, "--frame", 1]
    out, bare = tmp_path / "scan1.ply", tmp_path / "bare.ply"
    made = _rangemesh("mesh", shared_data / PCAP, *rec, "--vertices", 600, "--pixels", "-o", out)
    assert made.returncode == 0, made.stderr
    got = _rangemesh("eval", shared_data / PCAP, out, *rec)
    assert got.returncode == 0, got.stderr
    # the file read back (offsets taken off, pixels from its columns) against the mesh in memory
    for line in ("relative error", "max deviation"):
        (want,) = [x for x in made.stderr.splitlines() if x.startswith(line)]
        assert want in got.stdout, (want, got.stdout)
    # without its pixels a ray camera cannot place the mesh: one line naming --pixels
    assert _rangemesh("mesh", shared_data / PCAP, *rec, "--vertices", 600, "-o", bare).returncode == 0
    p = _rangemesh("eval", shared_data / PCAP, bare, *rec)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "--pixels" in p.stderr, p.stderr


def test_ouster_frame_past_the_end_and_camera_flags_are_one_line(shared_data, tmp_path):
    sdk("ouster.sdk")
    p = _rangemesh("mesh", shared_data / PCAP, "--meta", shared_data / META, "--frame", 3,
                   "-o", tmp_path / "x.ply")
    assert p.returncode == 2 and "--frame 3 is past the recording's end (it has 3 scans" in p.stderr
    p = _rangemesh("mesh", shared_data / PCAP, "--meta", shared_data / META, "--beams",
                   shared_data / "lidar/rellis3d_os1-64_000000.beams.json", "-o", tmp_path / "x.ply")
    assert p.returncode == 2 and "--beams does not apply to an Ouster recording" in p.stderr


# ------------------------------------------------------------------ without the SDK


def test_ouster_commands_name_the_extra_when_the_sdk_is_missing(shared_data, tmp_path, capsys,
                                                                monkeypatch):
    monkeypatch.setitem(sys.modules, "ouster", None)  # as if not installed
    monkeypatch.setitem(sys.modules, "ouster.sdk", None)
    for argv in (["info", shared_data / PCAP, "--meta", shared_data / META],
                 ["mesh", shared_data / PCAP, "--meta", shared_data / META, "-o", tmp_path / "a.ply"],
                 ["batch", shared_data / PCAP, "--meta", shared_data / META, "-o", tmp_path / "d",
                  "--workers", 1]):
        assert main([str(a) for a in argv]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and 'pip install "rangemesh[ouster]"' in err, err


def test_ouster_options_go_with_an_ouster_recording_only(shared_data, tmp_path, capsys):
    image = shared_data / "middlebury/tsukuba_disp3.npy"
    for argv in (["mesh", image, "--meta", shared_data / META, "-o", tmp_path / "a.ply"],
                 ["mesh", image, "--frame", 1, "-o", tmp_path / "a.ply"],
                 ["info", image, "--frame", 0],
                 ["batch", image, "--meta", shared_data / META, "-o", tmp_path / "d"]):
        assert main([str(a) for a in argv]) == 2
        err = capsys.readouterr().err
        assert "goes with an Ouster recording (.pcap or .osf)" in err, err
