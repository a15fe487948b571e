"""The compiled least-squares depth kernels against plain-Python references (tests/reference_heights.py)."""

import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import Delaunay

from rangemesh import _core, scenes, triangulate
from rangemesh.camera import Orthographic, Pinhole
from rangemesh.refine import heights

from . import reference_heights as ref


def _pixels(rows, cols):
    """The (V, 2) pixels the fit's kernels take, of each vertex's row and column."""
    return np.ascontiguousarray(np.stack([rows, cols], axis=1), dtype=np.int64)


def _sampling(row_stride, face_stride, capacity):
    """FitSettings of the errors' sample: `fit_sample_errors` reads no other field."""
    s = _core.FitSettings()
    s.row_stride, s.face_stride, s.capacity = row_stride, face_stride, capacity
    return s


@st.composite
def fit_cases(draw):
    """A random image and mask, and a mesh over some of its pixels (either orientation)."""
    h = draw(st.integers(2, 30))
    w = draw(st.integers(2, 30))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    image = 5.0 + rng.random((h, w))
    if draw(st.booleans()):  # repeated values: exact errors, ties in the median
        image = np.round(image * 4) / 4
    valid = rng.random((h, w)) < draw(st.floats(0.1, 1.0))
    pts = np.unique(np.stack([rng.integers(0, h, 40), rng.integers(0, w, 40)], axis=1), axis=0)
    if len(pts) < 3 or np.linalg.matrix_rank((pts[1:] - pts[0]).astype(float)) < 2:
        faces = np.array([[0, 0, 0]], np.int64)  # degenerate: owns no pixel
        pts = np.array([[0, 0]])
    else:
        faces = Delaunay(pts.astype(float)).simplices.astype(np.int64)
        faces[::2] = faces[::2, ::-1]
    rows, cols = (np.ascontiguousarray(pts[:, k], dtype=np.int64) for k in (0, 1))
    order = rng.permutation(len(faces)).astype(np.int64)
    return faces, order, rows, cols, np.ascontiguousarray(image[rows, cols]), image, valid


@settings(max_examples=60, deadline=None)
@given(fit_cases(), st.integers(1, 4), st.integers(1, 4))
def test_sampled_errors_are_those_of_the_owned_pixels(case, row_stride, face_stride):
    faces, order, rows, cols, values, image, valid = case
    want = ref.errors(faces, order, rows, cols, values, image, valid, row_stride, face_stride)
    got = _core.fit_sample_errors(faces, order, _pixels(rows, cols), values, image, valid,
                                  _sampling(row_stride, face_stride, image.size))
    assert len(got) == len(want)
    np.testing.assert_allclose(np.sort(got), np.sort(want), rtol=0, atol=1e-12)
    # at most `capacity` errors are kept: the first ones visited
    if len(want) > 2:
        few = _core.fit_sample_errors(faces, order, _pixels(rows, cols), values, image, valid,
                                      _sampling(row_stride, face_stride, 2))
        np.testing.assert_array_equal(few, got[:2])


@settings(max_examples=60, deadline=None)
@given(fit_cases(), st.sampled_from([np.pi / 50, 0.5 / np.e, np.inf]))
def test_face_blocks_sum_the_kept_pixels(case, threshold):
    faces, order, rows, cols, values, image, valid = case
    got = _core.fit_blocks(faces, order, _pixels(rows, cols), values, image, valid, threshold)
    want_ids, want_block, want_rhs, want_used = ref.blocks(faces, order, rows, cols, values, image, valid,
                                                           threshold)
    np.testing.assert_array_equal(got.ids, want_ids)
    np.testing.assert_allclose(got.block, want_block, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(got.rhs, want_rhs, rtol=1e-12, atol=1e-12)
    assert got.used == want_used  # (no error lies within rounding of these irrational bounds)


def test_a_triangulation_of_the_whole_image_visits_each_pixel_once():
    # The faces of a triangulation of the image's corners and inner points cover it; each pixel
    # is owned by one face, except on hull edges whose own rule gives them to the outside.
    h, w = 17, 23
    rng = np.random.default_rng(5)
    inside = np.stack([rng.integers(1, h - 1, 30), rng.integers(1, w - 1, 30)], axis=1)
    pts = np.unique(np.vstack([[[0, 0], [0, w - 1], [h - 1, 0], [h - 1, w - 1]], inside]), axis=0)
    faces = Delaunay(pts.astype(float)).simplices.astype(np.int64)
    rows, cols = (np.ascontiguousarray(pts[:, k], dtype=np.int64) for k in (0, 1))
    seen = np.zeros((h, w), int)
    for f in faces:
        for r, c, *_ in ref.owned_pixels(f, rows, cols):
            seen[r, c] += 1
    assert seen.max() == 1
    inner = seen[1:-1, 1:-1]
    assert inner.min() == 1  # no inner pixel left out
    image = rng.random((h, w))
    valid = np.ones((h, w), bool)
    order = np.arange(len(faces), dtype=np.int64)
    values = np.ascontiguousarray(image[rows, cols])
    got = _core.fit_blocks(faces, order, _pixels(rows, cols), values, image, valid, np.inf)
    assert got.used == seen.sum()


def test_the_pass_on_two_threads_is_the_pass_on_one():
    # Past 4000 faces the pass is split between the threads (one a 2000 faces: three here at 3
    # threads or more); each face writes its own rows.
    sc = scenes.make("box", (300, 300), noise=0.5)
    m = triangulate(sc.depth, vertices=3000, method="refine", heights="pixel")
    faces = np.ascontiguousarray(m.faces, np.int64)
    assert len(faces) >= 4000
    rows, cols = (np.ascontiguousarray(m.pixels[:, k], dtype=np.int64) for k in (0, 1))
    valid = np.ones(sc.depth.shape, bool)
    order = _core.face_order(faces, rows, cols, 300, 300, 8)
    values = np.ascontiguousarray(sc.depth[rows, cols])
    args = (faces, order, _pixels(rows, cols), values, sc.depth, valid, 1.0)
    one = _core.fit_blocks(*args, threads=1)
    for threads in (2, 3, 8):
        more = _core.fit_blocks(*args, threads=threads)
        for name in ("ids", "block", "rhs", "used"):
            assert np.array_equal(getattr(one, name), getattr(more, name))
    z1 = heights.fit_heights(m.pixels, m.faces, sc.depth, valid, m.camera, threads=1)
    z2 = heights.fit_heights(m.pixels, m.faces, sc.depth, valid, m.camera, threads=2)
    assert np.array_equal(z1.view(np.int64), z2.view(np.int64))
    assert not np.array_equal(z1, sc.depth[rows, cols])  # the fit moved the depths


def test_the_sample_on_several_threads_is_the_sample_on_one():
    # From 1000 sampled faces the sample is split between the threads into lists joined in
    # order: the same errors in the same order, and the same first `capacity` of them.
    sc = scenes.make("box", (300, 300), noise=0.5)
    m = triangulate(sc.depth, vertices=3000, method="refine", heights="pixel")
    faces = np.ascontiguousarray(m.faces, np.int64)
    rows, cols = (np.ascontiguousarray(m.pixels[:, k], dtype=np.int64) for k in (0, 1))
    valid = np.ones(sc.depth.shape, bool)
    order = _core.face_order(faces, rows, cols, 300, 300, 8)
    values = np.ascontiguousarray(sc.depth[rows, cols])
    args = (faces, order, _pixels(rows, cols), values, sc.depth, valid)
    for capacity in (valid.size, 5000):
        one = _core.fit_sample_errors(*args, _sampling(4, 1, capacity))
        assert len(faces) >= 2000 and len(one) == min(capacity, len(one)) and len(one) > 4000
        for threads in (2, 3, 8):
            settings = _sampling(4, 1, capacity)
            settings.threads = threads
            more = _core.fit_sample_errors(*args, settings)
            assert np.array_equal(one.view(np.int64), more.view(np.int64))


def _large_faces():
    """A mesh of few, large faces over a noisy 61 x 75 image with holes and outliers: rows of
    every length mod 4, rows that end 1 to 3 columns from the right side, pixels beyond a bound."""
    rng = np.random.default_rng(7)
    h, w = 61, 75
    r, c = np.mgrid[0:h, 0:w]
    image = 3.0 + 0.02 * r - 0.01 * c + 0.05 * rng.standard_normal((h, w))
    image[rng.random((h, w)) < 0.03] += 4.0
    valid = rng.random((h, w)) > 0.1
    pts = np.array([[0, 0], [0, w - 1], [h - 1, 0], [h - 1, w - 1], [30, 37], [10, 60], [50, 12],
                    [20, 20], [45, 72], [5, 30], [60, 40], [33, 74]])
    faces = Delaunay(pts.astype(float)).simplices.astype(np.int64)
    faces[::2] = faces[::2, ::-1]
    rows, cols = (np.ascontiguousarray(pts[:, k], dtype=np.int64) for k in (0, 1))
    order = np.arange(len(faces), dtype=np.int64)[::-1].copy()
    return faces, order, rows, cols, np.ascontiguousarray(image[rows, cols]), image, valid


def test_large_faces_blocks_and_errors_are_the_references():
    # faces of long rows are summed four columns at once where AVX runs (pass.cpp)
    faces, order, rows, cols, values, image, valid = _large_faces()
    for threshold in (0.1, np.inf):
        got = _core.fit_blocks(faces, order, _pixels(rows, cols), values, image, valid, threshold)
        want_ids, want_block, want_rhs, want_used = ref.blocks(faces, order, rows, cols, values, image, valid,
                                                               threshold)
        np.testing.assert_array_equal(got.ids, want_ids)
        np.testing.assert_allclose(got.block, want_block, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(got.rhs, want_rhs, rtol=1e-12, atol=1e-12)
        assert got.used == want_used
        assert 0 < got.used < valid.sum() or threshold == np.inf
    for row_stride, face_stride in ((1, 1), (1, 2), (4, 1)):
        want = ref.errors(faces, order, rows, cols, values, image, valid, row_stride, face_stride)
        got = _core.fit_sample_errors(faces, order, _pixels(rows, cols), values, image, valid,
                                      _sampling(row_stride, face_stride, image.size))
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)  # in the same order


_FOUR_LANE_CHILD = r"""
import hashlib, json
import numpy as np
from rangemesh import _core
from rangemesh.camera import Orthographic
from rangemesh.refine.heights import fit_heights
from tests.test_core_heights import _large_faces, _pixels, _sampling

faces, order, rows, cols, values, image, valid = _large_faces()
pixels = _pixels(rows, cols)
out = {"avx": bool(_core._uses_avx())}
def digest(*arrays):
    return hashlib.sha256(b"".join(np.ascontiguousarray(a).tobytes() for a in arrays)).hexdigest()
for threshold in (0.1, 0.3, np.inf):
    b = _core.fit_blocks(faces, order, pixels, values, image, valid, threshold)
    out[f"blocks {threshold}"] = [digest(b.ids, b.block, b.rhs), int(b.used)]
for strides in ((1, 1), (1, 2), (4, 1)):
    e = _core.fit_sample_errors(faces, order, pixels, values, image, valid, _sampling(*strides, image.size))
    out[f"errors {strides}"] = [digest(e), len(e)]
out["fit"] = digest(fit_heights(pixels, faces, image, valid, Orthographic()))
print(json.dumps(out))
"""


def test_the_scalar_pass_gives_the_four_lane_pass_blocks_and_errors_bit_for_bit():
    # RANGEMESH_NO_AVX=1 runs the scalar loops (simd.hpp): the same sums, errors and fit
    if not _core._uses_avx():
        pytest.skip("this machine runs the scalar loops only")
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    runs = {}
    for off in ("1", "0"):
        env = {**os.environ, "RANGEMESH_NO_AVX": off}
        p = subprocess.run([sys.executable, "-c", _FOUR_LANE_CHILD], capture_output=True, text=True, env=env,
                           cwd=root, timeout=600)
        assert p.returncode == 0, p.stderr
        runs[off] = json.loads(p.stdout)
    assert runs["1"].pop("avx") is False and runs["0"].pop("avx") is True
    assert len(runs["1"]) == 7
    assert runs["1"] == runs["0"]


_SHAPES_CHILD = r"""
import hashlib, json
import numpy as np
from scipy.spatial import Delaunay
from rangemesh import _core

def digest(*arrays):
    return hashlib.sha256(b"".join(np.ascontiguousarray(a).tobytes() for a in arrays)).hexdigest()

out, wide = {"avx": bool(_core._uses_avx())}, 0
for seed in range(300):
    rng = np.random.default_rng(seed)
    h, w = int(rng.integers(2, 30)), 12 + seed % 4 + 4 * int(rng.integers(0, 8))  # every width mod 4
    r, c = np.mgrid[0:h, 0:w]
    image = (2.0 + 0.03 * r - 0.02 * c + 0.05 * rng.standard_normal((h, w))) * np.pi
    image -= 4.0 * (seed % 2)  # (negative values on odd seeds)
    image[rng.random((h, w)) < 0.05] = -0.0
    valid = rng.random((h, w)) > rng.choice([0.0, 0.1, 0.4])
    valid[:, -1 - seed % 3:] &= rng.random((h, 1 + seed % 3)) > 0.5  # holes at the right side
    image[~valid] = (np.nan, np.inf, -0.0, 1e300)[seed % 4]
    if seed % 5 == 0:
        image[valid & (rng.random((h, w)) < 0.02)] = (np.nan, np.inf, -np.inf)[seed % 3]
    pts = [[0, 0], [0, w - 1], [h - 1, 0], [h - 1, w - 1]]
    pts += [[int(rng.integers(0, h)), int(rng.integers(0, w))] for _ in range(int(rng.integers(0, 5)))]
    pts = np.unique(np.array(pts), axis=0)
    try:
        faces = Delaunay(pts.astype(float)).simplices.astype(np.int64)
    except Exception:  # (all points on a line: no faces)
        continue
    faces[::2] = faces[::2, ::-1]
    rows, cols = (np.ascontiguousarray(pts[:, k], dtype=np.int64) for k in (0, 1))
    for f in faces:
        (ar, br, cr), (ac, bc, cc) = rows[f], cols[f]
        area = abs((br - ar) * (cc - ac) - (bc - ac) * (cr - ar))
        wide += int(np.ptp(cols[f]) >= 8 and area >= 12 * (np.ptp(rows[f]) + 1))
    pixels = np.ascontiguousarray(np.stack([rows, cols], axis=1))
    values = np.ascontiguousarray(np.where(valid[rows, cols], image[rows, cols], 1.5))
    order = rng.permutation(len(faces)).astype(np.int64)
    res = []
    for threshold in (0.05, 0.3, np.inf):
        b = _core.fit_blocks(faces, order, pixels, values, image, valid, threshold)
        res.append([digest(b.ids, b.block, b.rhs), int(b.used)])
    s = _core.FitSettings()
    s.row_stride, s.face_stride, s.capacity = 1, 1, 2 * image.size
    res.append(digest(np.asarray(_core.fit_sample_errors(faces, order, pixels, values, image, valid, s))))
    out[str(seed)] = res
out["wide faces"] = wide
print(json.dumps(out))
"""


def test_the_scalar_pass_gives_the_four_lane_pass_bit_for_bit_at_every_width():
    # (review44d) faces of long rows over images of every width mod 4, rows ending 0 to 3
    # columns from the right side, negative and -0.0 values, non-finite or huge values at holes
    # and some at valid pixels: the four-lane sums, counts and errors are the scalar loop's
    if not _core._uses_avx():
        pytest.skip("this machine runs the scalar loops only")
    runs = {}
    for off in ("1", "0"):
        env = {**os.environ, "RANGEMESH_NO_AVX": off}
        p = subprocess.run([sys.executable, "-c", _SHAPES_CHILD], capture_output=True, text=True, env=env,
                           timeout=600)
        assert p.returncode == 0, p.stderr
        runs[off] = json.loads(p.stdout)
    assert runs["1"].pop("avx") is False and runs["0"].pop("avx") is True
    assert runs["1"]["wide faces"] > 300  # (the four-lane loops had faces to sum)
    assert len(runs["1"]) > 250
    assert runs["1"] == runs["0"]


@given(st.lists(st.one_of(st.floats(0, 1e6), st.sampled_from([0.0, 1.0, 2.5, float("nan"), float("inf")])),
                min_size=1, max_size=200))
def test_the_median_is_numpys(values):
    x = np.array(values, dtype=np.float64)
    want = np.median(x)
    y = x.copy()
    got = _core.median_inplace(y)
    if np.isnan(want):
        assert np.isnan(got)
    else:
        assert np.float64(got).view(np.int64) == want.view(np.int64)  # bit for bit


@settings(max_examples=80, deadline=None)
@given(st.integers(256, 3000), st.integers(0, 2**32 - 1),
       st.sampled_from(["spread", "ties", "zeros", "inf", "sorted", "signed", "gap", "two"]))
def test_the_median_of_many_values_is_numpys(n, seed, kind):
    # From 256 values on the median is selected by partitions between the array and a buffer
    # (and by std::nth_element when a value is negative): np.median's bits either way.
    rng = np.random.default_rng(seed)
    x = rng.exponential(size=n)  # errors: none below 0
    if kind == "ties":
        x = np.round(x * 4) / 4
    elif kind == "zeros":  # most pixels exact
        x[rng.random(n) < 0.6] = 0.0
    elif kind == "inf":
        x[rng.random(n) < 0.3] = np.inf
    elif kind == "sorted":
        x = np.sort(x)
    elif kind == "signed":
        x -= 1.0
    elif kind in ("gap", "two"):  # the two middle values far apart, the lower one repeated
        x[: n // 2] = 0.25
        x[n // 2:] = 0.5 if kind == "two" else 1.0 + x[n // 2:]
        rng.shuffle(x)
    want = np.median(x)
    assert np.float64(_core.median_inplace(x)).view(np.int64) == want.view(np.int64)


def test_the_median_of_nothing_is_refused():
    with pytest.raises(RuntimeError, match="no median"):
        _core.median_inplace(np.zeros(0))


@pytest.mark.parametrize("name, pinhole", [("box", False), ("stairs", False), ("dome", True)])
def test_the_fit_solves_its_least_squares_problem(name, pinhole):
    # The whole fit against the references: the outlier bound from the median of the sampled
    # errors, the kept pixels' normal equations solved densely, the result clipped to the
    # valid values' range.
    sc = scenes.make(name, (50, 60), noise=0.3)
    depth = sc.depth + 10.0
    camera = Pinhole(60.0, 60.0, 30.0, 25.0) if pinhole else Orthographic(1.0, 1.0, 1.0)
    m = triangulate(depth, vertices=90, method="refine", heights="pixel", camera=camera)
    valid = np.isfinite(depth)  # the dome's background is NaN
    image = 1.0 / depth if pinhole else depth
    faces = np.asarray(m.faces, np.int64)
    rows, cols = (np.asarray(m.pixels[:, k], np.int64) for k in (0, 1))
    h0 = image[rows, cols]
    order = np.arange(len(faces))
    row_stride, face_stride = heights.sample_strides(len(faces))
    sample = ref.errors(faces, order, rows, cols, h0, image, valid, row_stride, face_stride)
    threshold = heights.OUTLIER_MADS * 1.4826 * np.median(sample)
    assert threshold > heights.OUTLIER_FLOOR * np.ptp(h0)  # noisy: the fit runs
    ids, block, rhs, used = ref.blocks(faces, order, rows, cols, h0, image, valid, threshold)
    assert 0 < used < valid.sum()
    want = np.clip(ref.solve(ids, block, rhs, h0, heights.RIDGE), image[valid].min(), image[valid].max())
    got = heights.fit_heights(m.pixels, m.faces, depth, valid, camera)
    got = 1.0 / got if pinhole else got
    span = np.ptp(image[valid])
    # conjugate gradients stop at a relative residual of 1e-6, which bounds the heights' error by
    # the system's condition number times that: 7.4e-5 of the range at most on these scenes; a
    # fixed bound, so that loosening CG_RTOL cannot loosen this test
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-4 * span)
    assert np.abs(got - h0).max() > 1e-3 * span  # and it is not the copied depths


def test_the_kernels_refuse_a_vertex_outside_the_image():
    faces = np.array([[0, 1, 2]], np.int64)
    rows = np.array([-1, 3, 0], np.int64)
    cols = np.array([0, 0, 3], np.int64)
    image = np.ones((5, 5))
    valid = np.ones((5, 5), bool)
    args = (faces, np.zeros(1, np.int64), _pixels(rows, cols), np.ones(3), image, valid)
    with pytest.raises(ValueError, match="outside the image"):
        _core.fit_sample_errors(*args, _sampling(1, 1, 25))
    with pytest.raises(ValueError, match="outside the image"):
        _core.fit_blocks(*args, 1.0)
    with pytest.raises(RuntimeError, match="vertex id is out of range"):
        _core.fit_blocks(np.array([[0, 1, 7]], np.int64), *args[1:], 1.0)
    # whether or not its pixels are visited: in a flat face, in no face
    rows = np.array([-1, 3, 0, 1], np.int64)
    cols = np.array([0, 0, 0, 3], np.int64)
    for face in ([0, 1, 2], [1, 2, 3]):
        args = (np.array([face], np.int64), np.zeros(1, np.int64), _pixels(rows, cols), np.ones(4), image,
                valid)
        with pytest.raises(ValueError, match="outside the image"):
            _core.fit_sample_errors(*args, _sampling(1, 1, 25))


def test_a_fit_that_does_not_converge_is_solved_directly(monkeypatch):
    # With a relative residual of 0 asked, conjugate gradients stop at their step limit: the
    # kernel hands back the system, and fit_heights solves it by sparse LU instead.
    sc = scenes.make("box", (40, 50), noise=0.3)
    m = triangulate(sc.depth, vertices=60, method="refine", heights="pixel")
    valid = np.ones(sc.depth.shape, bool)
    want = heights.fit_heights(m.pixels, m.faces, sc.depth, valid, m.camera)
    # the fit by conjugate gradients: within 1e-4 of the range on this scene (a fixed bound, as above)
    atol = 1e-4 * np.ptp(sc.depth)
    outcomes = []
    core_fit = _core.fit_heights

    def fit(*args, **kwargs):
        result = core_fit(*args, **kwargs)
        outcomes.append(result.outcome)
        if result.outcome == _core.FitOutcome.NOT_CONVERGED:
            assert result.system.ids.shape == (len(m.faces), 3)
            assert result.system.block.shape == (len(m.faces), 3, 3)
        return result

    solved = []
    direct_solve = heights._direct_solve

    def direct(*args):
        solved.append(direct_solve(*args))
        return solved[-1]

    monkeypatch.setattr(_core, "fit_heights", fit)
    monkeypatch.setattr(heights, "_direct_solve", direct)
    monkeypatch.setattr(heights, "CG_RTOL", 0.0)
    got = heights.fit_heights(m.pixels, m.faces, sc.depth, valid, m.camera)
    assert outcomes == [_core.FitOutcome.NOT_CONVERGED] and len(solved) == 1
    lo, hi = sc.depth.min(), sc.depth.max()
    np.testing.assert_array_equal(got, np.clip(solved[0], lo, hi))  # the direct solve's depths
    np.testing.assert_allclose(got, want, rtol=0, atol=atol)


def test_the_kernel_clips_the_fitted_values_as_numpy_does():
    # [lo, hi] narrower than the fit's values: what np.minimum(np.maximum(v, lo), hi) makes
    # of the unbounded values, bit for bit.
    sc = scenes.make("stairs", (40, 50), noise=0.3)
    m = triangulate(sc.depth, vertices=60, method="refine", heights="pixel")
    valid = np.ones(sc.depth.shape, bool)
    settings = heights.fit_settings(-np.inf, np.inf, len(m.faces), len(m.pixels), int(valid.sum()), threads=1)
    settings.max_iter = 1000
    fit = _core.fit_heights(m.faces, m.pixels, sc.depth, valid, None, settings)
    assert fit.outcome == _core.FitOutcome.FITTED
    free = fit.values
    lo, hi = np.quantile(free, [0.25, 0.75])
    settings.lo, settings.hi = lo, hi
    got = _core.fit_heights(m.faces, m.pixels, sc.depth, valid, None, settings).values
    want = np.minimum(np.maximum(free, lo), hi)
    assert np.array_equal(got.view(np.int64), want.view(np.int64))
    assert (got == lo).any() and (got == hi).any()


def test_a_fit_after_a_larger_one_on_its_thread_is_the_fit_alone():
    # A thread keeps the fit's buffers from call to call (issue 44): nothing of an earlier, larger
    # fit (its blocks, sampled errors, solver vectors) reaches a later one, some of whose faces
    # own no valid pixel here, so no pixel writes their sums.
    big = scenes.make("stairs", (60, 80), noise=0.3)
    mb = triangulate(big.depth, vertices=400, method="refine", heights="pixel")
    sc = scenes.make("box", (40, 50), noise=0.3)
    m = triangulate(sc.depth, vertices=60, method="refine", heights="pixel")
    valid = np.random.default_rng(3).random(sc.depth.shape) < 0.1
    valid[m.pixels[:, 0], m.pixels[:, 1]] = True

    def small():
        return heights.fit_heights(m.pixels, m.faces, sc.depth, valid, m.camera, threads=1)

    def after_big():
        heights.fit_heights(mb.pixels, mb.faces, big.depth, np.ones(big.depth.shape, bool), mb.camera,
                            threads=1)
        return small()

    with ThreadPoolExecutor(1) as fresh:
        want = fresh.submit(small).result()
    with ThreadPoolExecutor(1) as worker:
        got = worker.submit(after_big).result()
    assert np.array_equal(got.view(np.int64), want.view(np.int64))
    assert not np.array_equal(want, sc.depth[m.pixels[:, 0], m.pixels[:, 1]])  # fitted, not copied


FIT_AFTER_NO_MEMORY = """
import resource, sys
import numpy as np
from rangemesh import _core, triangulate
small = np.random.default_rng(0).uniform(1, 2, (30, 40))
first = triangulate(small)  # this thread keeps a fit's buffers
shape = (6000, 6000)  # 288 MB of depths, sparse files: the sampled errors' room cannot be had
depth = np.memmap(sys.argv[1] + "/d", np.float64, "w+", shape=shape)
valid = np.memmap(sys.argv[1] + "/v", bool, "w+", shape=shape)
depth[:4, :4], valid[:4, :4] = 1.5, True
with open("/proc/self/status") as f:
    vm = next(int(line.split()[1]) for line in f if line.startswith("VmSize:")) * 1024
resource.setrlimit(resource.RLIMIT_AS, (vm + (128 << 20), resource.RLIM_INFINITY))
s = _core.FitSettings()
s.capacity = shape[0] * shape[1]
try:
    _core.fit_heights(np.array([[0, 1, 2]]), np.array([[0, 0], [0, 3], [3, 0]]), depth, valid, None, s)
except MemoryError:
    print("no memory")
again = triangulate(small)
print(np.array_equal(again.vertices, first.vertices) and np.array_equal(again.faces, first.faces))
"""


@pytest.mark.skipif("libasan" in os.environ.get("LD_PRELOAD", ""),
                    reason="ASan maps terabytes of shadow memory: no address-space limit fits it")
def test_a_fit_after_one_that_ran_out_of_memory_on_its_thread_is_the_fit_alone(tmp_path):
    # A kept buffer given back before a larger one could not be had stayed counted as kept: the
    # thread's next fit wrote through a null pointer (a segfault; review of issue 44's fit)
    done = subprocess.run([sys.executable, "-c", FIT_AFTER_NO_MEMORY, str(tmp_path)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["no", "memory", "True"], done.stdout


def test_the_fit_takes_any_integer_arrays():
    # int32 (the insertion's) and int64 without a copy, others converted: one result.
    sc = scenes.make("box", (40, 50), noise=0.3)
    m = triangulate(sc.depth, vertices=60, method="refine", heights="pixel")
    valid = np.ones(sc.depth.shape, bool)
    want = heights.fit_heights(m.pixels, m.faces, sc.depth, valid, m.camera)
    for dtype in (np.int64, np.uint16, np.int32):
        pixels = np.asfortranarray(m.pixels.astype(dtype))  # not C-contiguous either
        got = heights.fit_heights(pixels, m.faces.astype(dtype), sc.depth, valid, m.camera)
        assert np.array_equal(got.view(np.int64), want.view(np.int64))
    assert not np.array_equal(want, sc.depth[m.pixels[:, 0], m.pixels[:, 1]])  # fitted, not copied


def test_a_vertex_without_a_finite_value_is_named():
    sc = scenes.make("box", (40, 50), noise=0.3)
    depth = sc.depth + 10.0
    m = triangulate(depth, vertices=60, method="refine", heights="pixel")
    valid = np.ones(depth.shape, bool)
    r, c = m.pixels[7]
    hole = depth.copy()
    hole[r, c] = 0.0
    with pytest.raises(ValueError, match=rf"depth 0 at pixel \({r}, {c}\) cannot be fitted with a pinhole"):
        heights.fit_heights(m.pixels, m.faces, hole, valid, Pinhole(60.0, 60.0, 25.0, 20.0))
    hole[r, c] = np.nan
    with pytest.raises(ValueError, match="every vertex must sit on a valid pixel"):
        heights.fit_heights(m.pixels, m.faces, hole, valid, Orthographic(1.0, 1.0, 1.0))
    outside = m.pixels.copy()
    outside[7] = (depth.shape[0], 0)
    with pytest.raises(ValueError, match="outside the image"):
        heights.fit_heights(outside, m.faces, depth, valid, m.camera)


def test_the_kernel_names_the_first_vertex_without_a_finite_value():
    # a status and the vertex, no sentinel in place of the values (issue 43)
    sc = scenes.make("box", (40, 50), noise=0.3)
    m = triangulate(sc.depth, vertices=60, method="refine", heights="pixel")
    valid = np.ones(sc.depth.shape, bool)
    settings = heights.fit_settings(sc.depth.min(), sc.depth.max(), len(m.faces), len(m.pixels), valid.size)
    fit = _core.fit_heights(m.faces, m.pixels, sc.depth, valid, None, settings)
    assert fit.outcome == _core.FitOutcome.FITTED and fit.not_finite is None and fit.system is None
    hole = sc.depth.copy()
    for k, value in ((9, np.inf), (7, np.nan)):
        hole[tuple(m.pixels[k])] = value
    fit = _core.fit_heights(m.faces, m.pixels, hole, valid, None, settings)
    assert fit.outcome == _core.FitOutcome.NOT_FINITE and fit.not_finite == 7
    assert fit.values is None and fit.system is None
