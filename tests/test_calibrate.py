import numpy as np
import pytest

from rangemesh import calibrate_delta, scenes, triangle_disparities


def test_planes_calibrate_to_zero():
    sc = scenes.pyramid((100, 120))
    d = triangle_disparities(sc.depth, sc.labels)
    assert d.size > 100
    assert calibrate_delta(sc.depth, sc.labels) < 1e-6


def test_noise_and_curvature_raise_delta():
    flat = calibrate_delta(scenes.pyramid((100, 120)).depth, scenes.pyramid((100, 120)).labels)
    noisy = scenes.pyramid((100, 120), noise=0.5)
    dome = scenes.dome((100, 120))
    assert calibrate_delta(noisy.depth, noisy.labels) > flat + 1
    assert calibrate_delta(dome.depth, dome.labels) > flat + 1


def test_sphere_disparity_by_hand():
    # On a sphere of radius R sampled every s pixels, neighbouring normals differ by about
    # s/R radians; a span's mean normal sits about one spacing away from the triangle's.
    sc = scenes.dome((200, 200))
    d = triangle_disparities(sc.depth, sc.labels, tiles=1, samples=11, sampling="uniform")
    R, s = 0.4 * 200, 199 / 10
    assert 0.2 * np.degrees(s / R) < np.median(d) < 2 * np.degrees(s / R)


def test_bad_labels():
    with pytest.raises(ValueError, match="shape"):
        calibrate_delta(np.ones((10, 10)), np.zeros((5, 5), int))
    with pytest.raises(ValueError, match="surface"):
        calibrate_delta(np.add.outer(np.arange(10.0), np.arange(10.0)), -np.ones((10, 10), int))
