"""Issue 7: every optimisation keeps results bit for bit; each fast kernel against the code it replaced."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import rangemesh
from rangemesh import _core, scenes
from rangemesh.camera import Orthographic, Pinhole, Spherical, backproject
from rangemesh.paper.sampling import curvature, fill_gaps
from rangemesh.paper.triangulation import delaunay_mesh, triangulate_points
from rangemesh.pipeline import call_options

from . import reference as ref
from .images import REAL_IMAGES, load_or_crop


def _random_image(seed, h=None, w=None):
    rng = np.random.default_rng(seed)
    h = h or int(rng.integers(1, 40))
    w = w or int(rng.integers(1, 40))
    d = rng.uniform(0, 100, (h, w))
    v = rng.random((h, w)) > rng.uniform(0, 0.6)
    return d, v


@given(st.integers(0, 2**31), st.integers(1, 4))
def test_curvature_kernel_equals_numpy(seed, levels):
    d, v = _random_image(seed)
    assert np.array_equal(curvature(d, v, levels), ref.curvature_numpy(d, v, levels))


@given(st.integers(0, 2**31))
def test_fill_gaps_kernel_equals_numpy(seed):
    d, v = _random_image(seed)
    a, av = fill_gaps(d, v)
    b, bv = ref.fill_gaps_numpy(d, v)
    assert np.array_equal(av, bv) and np.array_equal(a, b)


@pytest.mark.parametrize("rel, background", REAL_IMAGES, ids=[r for r, _ in REAL_IMAGES])
def test_stage_one_on_real_images_equals_numpy(data_or_crops, rel, background):
    d, v = rangemesh.to_depth_and_mask(load_or_crop(data_or_crops, rel), background)
    a, av = fill_gaps(d, v)
    b, bv = ref.fill_gaps_numpy(d, v)
    assert np.array_equal(a, b) and np.array_equal(av, bv)
    assert np.array_equal(curvature(a, av), ref.curvature_numpy(a, av))


def test_mask_kernel_equals_numpy_rules():
    rng = np.random.default_rng(3)
    for dtype, bg in ((np.uint16, 0), (np.uint16, 65535), (np.uint8, 7), (np.float32, None),
                      (np.float64, 0.5), (np.int32, -1)):
        arr = rng.integers(0, 9, (20, 30)).astype(dtype)
        if np.issubdtype(dtype, np.floating):
            arr[rng.random(arr.shape) < 0.2] = np.nan
            arr[0, 0] = np.inf
        d, v = rangemesh.to_depth_and_mask(arr, bg)
        want_v = np.isfinite(arr.astype(np.float64))
        if bg is not None:
            want_v &= arr != bg
        assert np.array_equal(v, want_v)
        assert np.array_equal(d, np.where(want_v, arr.astype(np.float64), 0.0))


@pytest.mark.parametrize("seed", range(40))
def test_sweep_equals_qhull(seed):
    rng = np.random.default_rng(seed)
    kind = seed % 4
    if kind == 0:  # tiny range: many duplicates removed, heavy co-circularity
        pts = rng.integers(0, 8, (int(rng.integers(3, 50)), 2))
    elif kind == 1:  # lattices with holes: the sample grids' worst case
        step = int(rng.integers(1, 4))
        r, c = np.mgrid[0 : int(rng.integers(2, 20)), 0 : int(rng.integers(2, 20))] * step
        pts = np.c_[r.ravel(), c.ravel()]
        pts = pts[rng.random(len(pts)) > 0.25]
    elif kind == 2:
        pts = rng.integers(0, 500, (int(rng.integers(3, 2000)), 2))
    else:  # collinear runs
        t = np.arange(int(rng.integers(3, 30)))
        pts = np.r_[np.c_[t, 2 * t], np.c_[t, 2 * t + 1][: int(rng.integers(0, 3))]]
    pts = np.unique(pts, axis=0)
    a = triangulate_points(pts, "sweep")
    b = triangulate_points(pts, "qhull")
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])


@pytest.mark.parametrize("rel, background", REAL_IMAGES[:6], ids=[r for r, _ in REAL_IMAGES[:6]])
def test_sweep_mesh_equals_qhull_mesh(data_or_crops, rel, background):
    depth, valid = rangemesh.pipeline.prepare(load_or_crop(data_or_crops, rel), rangemesh.MeshParams(),
                                              background)
    grid = rangemesh.sample_grid(depth, valid, rangemesh.MeshParams(tiles=6, samples=9))
    a = delaunay_mesh(grid, depth, valid, engine="sweep")
    b = delaunay_mesh(grid, depth, valid, engine="qhull")
    assert np.array_equal(a.faces, b.faces) and np.array_equal(a.pixels, b.pixels)


@given(st.integers(0, 2**31), st.sampled_from([0, 1, 2, 3]))
def test_incremental_bresenham_edge_error_equals_closed_form(seed, cam_kind):
    rng = np.random.default_rng(seed)
    depth = rng.uniform(1, 50, (40, 40))
    valid = rng.random((40, 40)) > 0.2
    cam = [Orthographic(), Orthographic(0.5, 2.0, -1.5), Pinhole(25.0, 30.0, 14.0, 15.0, 0.01),
           Spherical(np.linspace(15, -15, 40), np.linspace(0, 351, 40), range_scale=0.5)][cam_kind]
    pix = rng.integers(0, 40, (2, 2)).astype(np.int64)
    verts = backproject(pix[:, 0], pix[:, 1], depth[pix[:, 0], pix[:, 1]], cam)
    a = _core.edge_error(0, 1, pix, verts, depth, valid, cam.as_array())
    b = ref.edge_error_closed_form(0, 1, pix, verts, depth, valid, cam)
    assert a == b


def test_whole_pipeline_equals_reference_pipeline():
    """The pipeline built from the reference pieces (NumPy stage one, Qhull) gives the same mesh."""
    for name in ("box", "pyramid", "dome", "crease"):
        sc = scenes.make(name, (90, 120), noise=0.3)
        p = rangemesh.MeshParams(samples=9)
        fast = rangemesh.triangulate(sc.depth, method="paper", **call_options(p, "paper"))
        d, v = rangemesh.to_depth_and_mask(sc.depth)
        d, v = ref.fill_gaps_numpy(d, v)
        K = ref.curvature_numpy(d, v, p.levels)
        span = d[v].max() - d[v].min()
        w = np.log(np.maximum(K * (255.0 / span), p.curvature_floor))
        grid = rangemesh.sample_grid(d, v, p, weights=w)
        slow = rangemesh.flip_edges(delaunay_mesh(grid, d, v, engine="qhull"), d, v, p)
        assert np.array_equal(fast.faces, slow.faces)
        assert np.array_equal(fast.pixels, slow.pixels)
        assert fast.vertices.tobytes() == slow.vertices.tobytes()
