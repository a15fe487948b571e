import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import rangemesh
from rangemesh import Pinhole, evaluate, render_depth, scenes, triangulate
from rangemesh.mesh import Mesh, Stats

from . import reference as ref
from .helpers import chair_depths


def test_relative_error_by_hand():
    # One triangle (0,0),(0,2),(2,0) with depths 0, 0, 0 over an image that is 0 except
    # pixel (1,0) = 4 and pixel (1,1) = 8 (range 0..8). Covered valid pixels: the 6 pixels
    # with r + c <= 2. Errors: 4 and 8 at two of them -> mean 12/6 = 2 -> 2/8 = 25 %.
    depth = np.zeros((3, 3))
    depth[1, 0] = 4.0
    depth[1, 1] = 8.0
    pixels = np.array([[0, 0], [0, 2], [2, 0]], np.int32)
    mesh = Mesh(np.zeros((3, 3)), np.array([[0, 2, 1]], np.int32), pixels,
                __import__("rangemesh").Orthographic(), (3, 3), Stats())
    e = evaluate(mesh, depth, discontinuities=np.zeros((3, 3), bool))
    assert e.covered_pixels == 6 and e.valid_pixels == 9
    assert e.relative_error == pytest.approx(25.0)
    assert e.max_error == pytest.approx(100.0)
    assert e.rms_error == pytest.approx(100 * np.sqrt((16 + 64) / 6) / 8)
    assert e.uncovered == pytest.approx(300 / 9)
    assert np.isnan(e.edge_band_error)


@pytest.mark.parametrize("name", ["box", "dome", "pyramid"])
def test_errors_match_brute_force(name):
    sc = scenes.make(name, (40, 50), noise=0.3)
    m = triangulate(sc.depth, tiles=2, samples=5, method="paper")
    valid = np.isfinite(sc.depth)
    errs = ref.rendered_errors(m, sc.depth, valid)
    span = np.nanmax(sc.depth) - np.nanmin(sc.depth)
    e = evaluate(m, sc.depth)
    want = np.array(list(errs.values())) / span * 100
    assert e.covered_pixels == len(errs)
    assert e.relative_error == pytest.approx(want.mean(), rel=1e-9)
    assert e.max_error == pytest.approx(want.max(), rel=1e-9)


def test_pinhole_render_is_exact_on_a_3d_plane():
    # A 3-D plane Z = 2 + 0.01 X seen by a pinhole camera: depth is not linear in pixels,
    # but the mesh of a plane must reproduce it exactly (inverse depth is).
    cam = Pinhole(50.0, 50.0, 32.0, 24.0, 1.0)
    r, c = np.mgrid[0:48, 0:64].astype(float)
    # Z = 2 + 0.01 * (c - cx) Z / fx  ->  Z = 2 / (1 - 0.01 (c - cx) / fx)
    Z = 2.0 / (1.0 - 0.01 * (c - 32.0) / 50.0)
    m = triangulate(Z, camera=cam, tiles=2, samples=4, flips=None, method="paper")
    pred, _ = render_depth(m)
    np.testing.assert_allclose(pred, Z, rtol=1e-12)


def test_edge_band_uses_given_mask():
    sc = scenes.box((60, 80))
    m = triangulate(sc.depth, samples=6, method="paper")
    e = evaluate(m, sc.depth, discontinuities=sc.discontinuities)
    e0 = evaluate(m, sc.depth, discontinuities=sc.discontinuities, band=0)
    assert e.edge_band_pixels > e0.edge_band_pixels == sc.discontinuities.sum()
    assert e.edge_band_error > e.relative_error  # the error lives at the jump


def test_evaluate_rejects_other_shape():
    m = triangulate(np.ones((20, 20)) + np.arange(20), samples=3, method="paper")
    with pytest.raises(ValueError, match="shape"):
        evaluate(m, np.ones((10, 10)))


@given(st.integers(1, 12), st.integers(1, 12), st.integers(0, 4), st.integers(0, 2**32 - 1))
def test_dilate_square_is_scipys_binary_dilation(h, w, radius, seed):
    from scipy import ndimage

    from rangemesh.metrics import dilate_square

    mask = np.random.default_rng(seed).random((h, w)) < 0.1
    want = mask if radius == 0 else ndimage.binary_dilation(mask, structure=np.ones((3, 3), bool),
                                                            iterations=radius)
    assert np.array_equal(dilate_square(mask, radius), want)


# ---------------------------------------------------------------- from the hostile-input reports


# D24, D25 of the 2026-11-21 hostile-input report
def test_evaluate_checks_a_hand_made_meshs_indices(chair):
    m = rangemesh.triangulate(chair, background=0, method="paper")
    import dataclasses

    for bad in (-1, len(m.vertices)):
        f = m.faces.copy()
        f[3, 1] = bad
        with pytest.raises(ValueError, match="out of range"):
            rangemesh.evaluate(dataclasses.replace(m, faces=f), chair, background=0)


# E23 of the 2026-11-25 hostile-input report
def test_a_subnormal_depth_scale_evaluates_quietly_and_right():
    import warnings

    chair = chair_depths()
    errors = []
    for scale in (0.001, 1e-310):  # 1e-310: the 3-D depths are subnormal and 1/z overflows
        cam = rangemesh.Pinhole(525, 525, 64, 64, scale)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            mesh = rangemesh.triangulate(chair, background=0, camera=cam, vertices=500)
            errors.append(rangemesh.evaluate(mesh, chair, background=0).relative_error)
    # the prediction in stored units does not depend on the depth scale (before: 56.6 %)
    assert errors[1] == pytest.approx(errors[0], rel=1e-9)
