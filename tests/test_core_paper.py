"""The paper's compiled kernels refuse views that disagree instead of reading out of bounds."""

import numpy as np
import pytest

from rangemesh import Orthographic, _core


def _flip(pixels, faces=((0, 1, 2),), shape=(4, 4)):
    tri, he = _core.build_halfedges(np.array(faces, np.int64), 3)
    vertices = np.zeros((3, 3))
    return _core.flip_loop(tri, he, np.array(pixels, np.int64), vertices, np.zeros(shape),
                           np.ones(shape, bool), Orthographic().as_array(), rule=1,
                           threshold=-np.inf, delta=0.3, epsilon=0.005, max_angle=2.8, min_bend=0.08,
                           quantum=2.0**-32, max_edge2=np.inf, verdicts=np.zeros(8, np.int64),
                           log=np.zeros((0, 3), np.int64))


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
