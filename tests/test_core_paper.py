"""The paper's compiled kernels refuse views that disagree and stop cleanly on Ctrl-C."""

import copy
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

from rangemesh import Orthographic, _core

from .helpers import core_settings, interrupt


def _flip(pixels, faces=((0, 1, 2),), shape=(4, 4)):
    tri, he = _core.build_halfedges(np.array(faces, np.int64), 3)
    vertices = np.zeros((3, 3))
    settings = core_settings(_core.FlipSettings, rule=1, threshold=-np.inf, delta=0.3, epsilon=0.005,
                             max_angle=2.8, min_bend=0.08, quantum=2.0**-32, max_edge2=np.inf)
    return _core.flip_loop(tri, he, np.array(pixels, np.int64), vertices, np.zeros(shape),
                           np.ones(shape, bool), Orthographic().as_array(), settings).flips


def test_flip_settings_hold_each_test_angle_apart():
    # the four angles are properties over FlipSettings' tests: each reads back what it was set to
    settings = core_settings(_core.FlipSettings, delta=0.1, epsilon=0.2, max_angle=0.3, min_bend=0.4)
    for s in (settings, copy.copy(settings)):
        assert (s.delta, s.epsilon, s.max_angle, s.min_bend) == (0.1, 0.2, 0.3, 0.4)


def test_flip_loop_takes_a_sound_mesh():
    assert _flip([[0, 0], [0, 3], [3, 0]]) == 0  # one triangle: no inner edge to flip


def test_flip_loop_refuses_a_pixel_outside_the_image():
    with pytest.raises(RuntimeError, match="pixels must lie in the image"):
        _flip([[0, 0], [0, 4], [3, 0]])


def test_sample_tiles_refuses_borders_outside_the_image():
    grid = np.zeros((3, 3, 2), np.int32)
    f = np.ones((5, 5))
    _core.sample_tiles(f, np.array([0, 4]), np.array([0, 4]), 3, 3, grid)
    assert grid[2, 2].tolist() == [4, 4]
    with pytest.raises(RuntimeError, match="column borders"):
        _core.sample_tiles(f, np.array([0, 4]), np.array([0, 5]), 3, 3, grid)
    with pytest.raises(RuntimeError, match="grid's shape"):
        _core.sample_tiles(f, np.array([0, 4]), np.array([0, 4]), 4, 3, grid)


def test_edge_error_refuses_a_vertex_out_of_range():
    pixels, vertices = np.array([[0, 0], [1, 1]], np.int64), np.zeros((2, 3))
    image = (np.zeros((2, 2)), np.ones((2, 2), bool), Orthographic().as_array())
    assert _core.edge_error(0, 1, pixels, vertices, *image) > 0.0
    with pytest.raises(ValueError, match="must agree"):
        _core.edge_error(0, 2, pixels, vertices, *image)


def _rays_camera(h, w, width=None):
    """A packed per-pixel camera of an h x w image (``Camera.as_array()``'s layout), its stated
    width replaced by ``width``."""
    cam = np.zeros(6 + 3 * h * w)
    cam[:3] = [2.0, h, w if width is None else width]
    return cam


# Found by the sanitized build (issue 35): the checks themselves converted the camera's width to
# an integer (undefined for NaN or huge values: UBSan float-cast-overflow) and multiplied the
# row by it (signed overflow). They now refuse these before any conversion.
@pytest.mark.parametrize("width", [np.nan, np.inf, -np.inf, 1e300, -1.0, 0.0, 2.5])
def test_a_per_pixel_camera_with_a_bad_width_is_refused(width):
    cam = _rays_camera(2, 2, width)
    with pytest.raises(ValueError, match="per-pixel camera"):
        _core.lift(0, 0, 1.0, cam)
    pixels, vertices = np.array([[0, 0], [1, 1]], np.int64), np.zeros((2, 3))
    with pytest.raises(ValueError, match="must agree"):
        _core.edge_error(0, 1, pixels, vertices, np.zeros((2, 2)), np.ones((2, 2), bool), cam)


def test_lift_refuses_a_pixel_outside_a_per_pixel_camera():
    cam = _rays_camera(2, 2)
    cam[6 + 3 * 3:] = [1.0, 2.0, 3.0]  # the ray of pixel (1, 1)
    assert _core.lift(1, 1, 2.0, cam).tolist() == [0.0, 0.0, 0.0]  # range_scale 0
    cam[3] = 1.0
    assert _core.lift(1, 1, 2.0, cam).tolist() == [2.0, 4.0, 6.0]
    for r, c in [(2, 0), (0, 2), (-1, 0), (0, -1), (2**62, 0), (-(2**62), 1), (0, 2**62)]:
        with pytest.raises(ValueError, match="per-pixel camera"):
            _core.lift(r, c, 1.0, cam)


_KERNEL_LOOP = textwrap.dedent("""
    import numpy as np, sys
    from rangemesh import Orthographic, _core
    n = 700  # a regular mesh of n x n pixels, one diagonal a cell, random depths: many flips
    r, c = np.divmod(np.arange(n * n), n)
    pixels = np.stack([r, c], axis=1).astype(np.int64)
    depth = np.random.default_rng(0).uniform(1, 50, (n, n))
    vertices = np.stack([r, c, depth.ravel()], axis=1).astype(float)
    v = (r * n + c).reshape(n, n)
    faces = np.concatenate([np.stack([v[:-1, :-1], v[1:, :-1], v[:-1, 1:]], -1).reshape(-1, 3),
                            np.stack([v[1:, :-1], v[1:, 1:], v[:-1, 1:]], -1).reshape(-1, 3)])
    f = np.random.default_rng(1).uniform(0.5, 2.0, (3000, 3000))
    b = np.linspace(0, 2999, 201).round().astype(np.int64)
    grid = np.zeros((200 * 19 + 1, 200 * 19 + 1, 2), np.int32)
    settings = _core.FlipSettings()
    settings.rule, settings.threshold, settings.quantum, settings.max_edge2 = 1, -np.inf, 2.0**-32, np.inf
    settings.delta, settings.epsilon, settings.max_angle, settings.min_bend = 0.35, 0.005, 2.8, 0.09
    print("ready", flush=True)
    while True:
        tri, he = _core.build_halfedges(faces, n * n)
        _core.flip_loop(tri, he, pixels, vertices, depth, np.ones((n, n), bool),
                        Orthographic().as_array(), settings)
        _core.sample_tiles(f, b, b, 20, 20, grid, 2)
""")


def _interrupt_at(script, delays):
    """Run `script` (it prints "ready", then loops) once a delay; SIGINT it after that delay."""
    for delay in delays:
        proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True)
        assert proc.stdout.readline().strip() == "ready"
        time.sleep(delay)
        err = interrupt(proc)
        assert proc.returncode == -signal.SIGINT, err  # an uncaught KeyboardInterrupt
        assert err.rstrip().endswith("KeyboardInterrupt"), err


def test_ctrl_c_stops_the_flips_and_the_sample_threads(tmp_path):
    """SIGINT at various moments, mostly inside the kernels: KeyboardInterrupt, never a crash."""
    script = tmp_path / "loop.py"
    script.write_text(_KERNEL_LOOP)
    _interrupt_at(script, (0.1, 0.4, 0.9, 1.6))


_STAGE_TWO_LOOP = textwrap.dedent("""
    import numpy as np
    from rangemesh import _core
    n = 700  # stage two's whole-mesh kernels on a regular mesh of n x n pixels, one after another
    r, c = np.divmod(np.arange(n * n), n)
    pts = np.stack([r, c], axis=1).astype(np.int64)
    v = (r * n + c).reshape(n, n)
    faces = np.concatenate([np.stack([v[:-1, :-1], v[1:, :-1], v[:-1, 1:]], -1).reshape(-1, 3),
                            np.stack([v[1:, :-1], v[1:, 1:], v[:-1, 1:]], -1).reshape(-1, 3)])
    faces32 = faces.astype(np.int32)
    valid = np.ones((n, n), bool)
    alive = np.empty(len(faces), bool)
    print("ready", flush=True)
    while True:
        tri, he = _core.delaunay_sweep(pts[:, 0].copy(), pts[:, 1].copy())
        _core.legalize_all(tri, he, pts[:, 0].copy(), pts[:, 1].copy())
        f = _core.canonical_faces(faces.reshape(-1), n * n)
        _, he = _core.build_halfedges(faces32, n * n)
        neighbors = _core.neighbors_from_halfedges(he)
        _core.count_edges(faces32, n * n)
        _core.keep_faces(faces, pts, valid, np.inf, alive)
        _core.prune_dangling(faces, neighbors, alive, n * n)
        _core.compact_faces(faces, alive, pts)
        _core.valid_samples(pts, valid)
""")


def test_ctrl_c_stops_stage_two_and_its_arrays_are_freed(tmp_path):
    """SIGINT at various moments of stage two's kernels (their fills, loops and sorts, arrays freed
    on threads of their own): KeyboardInterrupt, never a crash."""
    script = tmp_path / "loop.py"
    script.write_text(_STAGE_TWO_LOOP)
    _interrupt_at(script, (0.1, 0.5, 1.1, 1.9, 2.8))


# --- stage two's whole-mesh steps (`rangemesh.paper.triangulation`) against NumPy -------------

@pytest.mark.parametrize("dtype", [np.int32, np.int64])
def test_valid_samples_are_numpys_marks_in_row_major_order(dtype):
    # the definition: samples inside the image, marked on a pixel grid, masked by valid, read
    # back in linear order
    rng = np.random.default_rng(7)
    h, w = 23, 31
    valid = rng.random((h, w)) > 0.3
    samples = rng.integers(-3, 35, size=(400, 2)).astype(dtype)
    g = samples.astype(np.int64)
    g = g[(g[:, 0] >= 0) & (g[:, 0] < h) & (g[:, 1] >= 0) & (g[:, 1] < w)]
    mark = np.zeros(h * w, bool)
    mark[g[:, 0] * w + g[:, 1]] = True
    lin = np.flatnonzero(mark & valid.ravel())
    got = _core.valid_samples(samples, valid)
    assert got.dtype == np.int64
    assert np.array_equal(got, np.stack([lin // w, lin % w], axis=1))


@pytest.mark.parametrize("max_edge", [None, 4.0, 6.5])
def test_keep_faces_and_compact_faces_are_numpys(max_edge):
    from scipy.spatial import Delaunay

    rng = np.random.default_rng(11)
    h, w = 20, 24
    valid = rng.random((h, w)) > 0.25
    lin = np.sort(rng.choice(h * w, size=90, replace=False))
    pts = np.stack([lin // w, lin % w], axis=1).astype(np.int64)
    faces = Delaunay(pts.astype(float)).simplices.astype(np.int64)
    # the definition: the pixel at the rounded barycentre valid, no edge longer than max_edge
    bary = (pts[faces].sum(axis=1) + 1) // 3
    want = valid[bary[:, 0], bary[:, 1]]
    if max_edge is not None:
        corner = pts[faces]
        d2 = ((corner - np.roll(corner, 1, axis=1)) ** 2).sum(axis=2)
        want &= (d2 <= max_edge ** 2).all(axis=1)
    alive = np.empty(len(faces), bool)
    _core.keep_faces(faces, pts, valid, np.inf if max_edge is None else max_edge ** 2, alive)
    assert np.array_equal(alive, want) and 0 < want.sum() < len(want)
    # the kept faces renumbered over the points they use, in order
    used = np.unique(faces[want])
    remap = np.full(len(pts), -1)
    remap[used] = np.arange(len(used))
    got_faces, got_pixels = _core.compact_faces(faces, alive, pts)
    assert got_faces.dtype == np.int32 and got_pixels.dtype == np.int32
    assert np.array_equal(got_faces, remap[faces[want]])
    assert np.array_equal(got_pixels, pts[used])
