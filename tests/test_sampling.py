import os

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import rangemesh
from rangemesh import MeshParams, _core, curvature, fill_gaps, sample_grid, sampling_weights
from rangemesh.paper.sampling import tile_bounds

from . import reference as ref


def test_fill_gaps_by_hand():
    d = np.arange(25.0).reshape(5, 5)
    v = np.ones((5, 5), bool)
    v[2, 2] = False  # surrounded: filled with the mean of 8 neighbours = 12
    v[0, 4] = False  # on the border: never filled
    v[3, 3] = v[3, 2] = False  # a 2-pixel hole stays
    out, ov = fill_gaps(d, v)
    assert not ov[0, 4] and not ov[3, 3] and not ov[3, 2]
    # (2,2) has background neighbours (3,3),(3,2): not surrounded any more
    assert not ov[2, 2]
    v2 = np.ones((5, 5), bool)
    v2[2, 2] = False
    out, ov = fill_gaps(d, v2)
    assert ov[2, 2] and out[2, 2] == 12.0


@given(st.integers(0, 1000))
def test_fill_gaps_matches_reference(seed):
    rng = np.random.default_rng(seed)
    d = rng.uniform(0, 9, (9, 11))
    v = rng.random((9, 11)) > 0.15
    a, av = fill_gaps(d, v)
    b, bv = ref.fill_gaps(d, v)
    assert np.array_equal(av, bv)
    np.testing.assert_allclose(a[av], b[bv], rtol=1e-12)


@given(st.integers(0, 1000), st.integers(1, 3))
def test_curvature_matches_reference(seed, levels):
    rng = np.random.default_rng(seed)
    d = rng.uniform(0, 9, (13, 10))
    v = rng.random((13, 10)) > 0.2
    K = curvature(d, v, levels)
    jump = d[v].max() - d[v].min()
    want = np.zeros_like(d)
    for level in range(levels):
        s = 1 << level
        k = ref.curvature_one_level(d[::s, ::s], v[::s, ::s], jump)
        want += k[np.arange(13)[:, None] >> level, np.arange(10)[None, :] >> level]
    np.testing.assert_allclose(K, want, rtol=1e-12, atol=1e-12)


def test_curvature_by_hand():
    # z = c^2 along a row: second difference 2 inside, 0 at the borders; rows add nothing.
    d = np.tile(np.arange(6.0) ** 2, (3, 1))
    K = curvature(d, np.ones_like(d, bool), levels=1)
    assert np.array_equal(K, [[0, 2, 2, 2, 2, 0]] * 3)


def test_curvature_ignores_background_value():
    d = np.full((7, 7), 50.0)
    v = np.ones_like(d, bool)
    v[3, 3] = False
    for marker in (0.0, 1e9, -5.0):
        dd = d.copy()
        dd[3, 3] = marker
        assert np.array_equal(curvature(dd, v), curvature(d, v))


def test_weights_uniform_and_floor():
    d = np.add.outer(np.arange(20.0), np.arange(30.0))  # a plane: K = 0 everywhere
    v = np.ones_like(d, bool)
    f = sampling_weights(d, v, MeshParams())
    assert np.allclose(f, np.log(20.0))
    assert np.array_equal(sampling_weights(d, v, MeshParams(sampling="uniform")), np.ones_like(d))


def test_tile_bounds_by_hand():
    assert tile_bounds(9, 4).tolist() == [0, 2, 4, 6, 8]
    assert tile_bounds(10, 4).tolist() == [0, 2, 5, 7, 9]  # 2.25, 4.5 -> 5 (half up), 6.75
    with pytest.raises(ValueError, match="tiles"):
        tile_bounds(4, 4)


def test_uniform_grid_is_rounded_linspace():
    d = np.zeros((41, 61))
    v = np.ones_like(d, bool)
    g = sample_grid(d, v, MeshParams(tiles=(2, 3), samples=(5, 6), sampling="uniform"))
    assert g.shape == (9, 16, 2)
    # rows: tiles 0..20, 20..40, five samples each -> every 5 rows
    assert g[:, 0, 0].tolist() == list(range(0, 41, 5))
    # cols: tiles 0..20, 20..40, 40..60, six samples -> every 4 columns
    assert g[0, :, 1].tolist() == list(range(0, 61, 4))


@given(st.integers(0, 10_000), st.integers(1, 3), st.integers(1, 3), st.integers(2, 6),
       st.integers(2, 6))
def test_sample_grid_matches_reference(seed, tv, th, rs, zs):
    rng = np.random.default_rng(seed)
    h, w = rng.integers(tv + 1, 25), rng.integers(th + 1, 25)
    d = rng.uniform(0, 100, (h, w))
    v = rng.random((h, w)) > 0.1
    p = MeshParams(tiles=(tv, th), samples=(rs, zs))
    f = sampling_weights(d, v, p)
    got = sample_grid(d, v, p)
    assert got.shape == p.grid_shape + (2,)
    assert np.array_equal(got, ref.sample_grid(f, (tv, th), (rs, zs)))
    # tile borders: the first and last grid rows/cols lie on the image border
    assert (got[0, :, 0] == 0).all() and (got[-1, :, 0] == h - 1).all()
    assert (got[:, 0, 1] == 0).all() and (got[:, -1, 1] == w - 1).all()


@given(st.integers(0, 10_000), st.integers(1, 7), st.integers(1, 7), st.integers(2, 5),
       st.integers(2, 5))
def test_sample_tiles_gives_the_same_grid_on_any_number_of_threads(seed, tv, th, rs, zs):
    # each thread takes a fixed share of the tiles and writes only its own samples
    rng = np.random.default_rng(seed)
    h, w = rng.integers(tv + 1, 40), rng.integers(th + 1, 40)
    f = rng.uniform(0.1, 5.0, (h, w))
    rb, cb = tile_bounds(h, tv), tile_bounds(w, th)
    want = ref.sample_grid(f, (tv, th), (rs, zs))
    for workers in (1, 2, 3, 64):
        grid = np.full(want.shape, -1, np.int32)
        _core.sample_tiles(f, rb, cb, rs, zs, grid, workers)
        assert np.array_equal(grid, want), workers


def test_sample_grid_workers_change_nothing():
    rng = np.random.default_rng(7)
    d = rng.uniform(0, 100, (60, 80))
    v = rng.random((60, 80)) > 0.1
    p = MeshParams(tiles=(5, 6), samples=(6, 5))
    one = sample_grid(d, v, p)
    assert np.array_equal(sample_grid(d, v, p, workers=2), one)
    assert np.array_equal(sample_grid(d, v, p, workers=3), one)


def test_adaptive_samples_crowd_at_a_jump():
    c = np.arange(101.0)
    d = np.tile(np.where(c < 50, 0.0, 100.0), (21, 1))  # a step between columns 49 and 50
    v = np.ones_like(d, bool)
    near = {}
    for mode in ("adaptive", "uniform"):
        g = sample_grid(d, v, MeshParams(tiles=1, samples=(3, 41), sampling=mode))
        near[mode] = int(np.sum(np.abs(g[1, :, 1] - 49.5) <= 4))
    # uniform: round(2.5 k) = ..., 45, 48, 50, 53, 55 -> 3 within 4 px of 49.5; the log
    # weights at the jump (about 6.2 against log 20 = 3.0) pull more columns in
    assert near["uniform"] == 3
    assert near["adaptive"] > near["uniform"]


def test_tile_threads_follow_workers_within_the_cores_and_the_batch_cap(monkeypatch):
    from rangemesh.paper.sampling import _tile_threads

    monkeypatch.delenv("RANGEMESH_THREADS", raising=False)
    assert _tile_threads(1) == 1
    assert _tile_threads(10_000) == len(os.sched_getaffinity(0))  # never more than the cores
    monkeypatch.setenv("RANGEMESH_THREADS", "1")  # what batch workers set: one thread each
    assert _tile_threads(4) == 1


def test_tile_threads_are_one_within_a_live_frame_worker(monkeypatch):
    from rangemesh.paper.sampling import _tile_threads
    from rangemesh.threads import one_thread

    monkeypatch.delenv("RANGEMESH_THREADS", raising=False)
    cores = len(os.sched_getaffinity(0))
    assert _tile_threads(4) == min(4, cores)
    with one_thread():  # the live workers already use the cores, a frame each
        assert _tile_threads(4) == 1
    assert _tile_threads(4) == min(4, cores)


def test_weights_into_a_strided_buffer_are_the_same():
    rng = np.random.default_rng(3)
    d = rng.uniform(0, 100, (30, 40))
    v = rng.random((30, 40)) > 0.1
    p = MeshParams()
    buffer = np.zeros((30, 80))
    got = sampling_weights(d, v, p, out=buffer[:, ::2])
    assert got.base is buffer  # written where asked
    assert np.array_equal(got, sampling_weights(d, v, p))


# ---------------------------------------------------------------- from the hostile-input reports


# D3 of the 2026-11-21 hostile-input report
def test_subnormal_depths_give_the_same_samples(chair):
    z = chair.astype(np.float64)
    tiny = z * 2.0**-1030  # subnormal, and exact: chair values are integers below 256
    assert 0 < tiny[tiny > 0].max() < np.finfo(np.float64).tiny
    a = rangemesh.triangulate(z, background=0, flips=None, method="paper")
    b = rangemesh.triangulate(tiny, background=0, flips=None, method="paper")  # warnings are errors here
    assert np.array_equal(a.pixels, b.pixels) and np.array_equal(a.faces, b.faces)
    ev = rangemesh.evaluate(b, tiny, background=0)
    assert np.isfinite(ev.relative_error)
    assert ev.relative_error == pytest.approx(rangemesh.evaluate(a, z, background=0).relative_error)


# D6 of the 2026-11-21 hostile-input report
@pytest.mark.parametrize("samples", [10_000, 10**6, 10**9])
def test_huge_sample_grids_are_refused_before_allocating(chair, samples):
    with pytest.raises(ValueError, match="samples"):
        rangemesh.triangulate(chair, samples=samples, method="paper")


# D6 of the 2026-11-21 hostile-input report
def test_small_images_keep_sample_grids_up_to_65536(chair):
    # 4 tiles of 24 px with 60 samples each: a 237x237 grid (56,169 entries) on 9,216 px
    m = rangemesh.triangulate(chair, background=0, samples=60, method="paper")
    assert m.stats.grid_shape == (237, 237)
    with pytest.raises(ValueError, match="at most 65536"):
        rangemesh.triangulate(chair, background=0, samples=66, method="paper")  # 261 x 261 = 68,121
