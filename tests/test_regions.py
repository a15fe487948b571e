"""Speckle removal (rangemesh.regions): regions split at jumps, min_region drops the small ones."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import rangemesh
from rangemesh.regions import REGION_JUMP, drop_small_regions, label_regions

from .conftest import PHASES
from .images import load


def ten_by_ten():
    """Two 25-pixel blocks apart by a jump, a 3-pixel speck and a diagonal pair in a hole.

    By hand: rows 0-4 x cols 0-4 at 2.0 (25 px); rows 5-9 x cols 0-4 at 3.0, its last row
    3.1 (a 3.3 % step, joined): 25 px, apart from the first (a 50 % step); (2, 7), (2, 8),
    (3, 8) at 2.0: 3 px; (7, 7) and (8, 8), diagonal neighbours at 2.0: 2 px. The rest is 0.
    """
    d = np.zeros((10, 10))
    d[0:5, 0:5] = 2.0
    d[5:10, 0:5] = 3.0
    d[9, 0:5] = 3.1
    for r, c in ((2, 7), (2, 8), (3, 8), (7, 7), (8, 8)):
        d[r, c] = 2.0
    return d


def test_regions_split_at_jumps_and_join_diagonals():
    d = ten_by_ten()
    labels, sizes = label_regions(d, d > 0)
    # ids in row-major order of each region's first pixel: (0,0), (2,7), (5,0), (7,7)
    assert sizes.tolist() == [25, 3, 25, 2]
    assert (labels[0:5, 0:5] == 0).all() and (labels[5:10, 0:5] == 2).all()
    assert labels[2, 7] == labels[2, 8] == labels[3, 8] == 1
    assert labels[7, 7] == labels[8, 8] == 3
    assert (labels[d == 0] == -1).all()


@pytest.mark.parametrize("k, dropped", [(2, 0), (3, 2), (4, 5), (26, 55)])
def test_min_region_drops_regions_of_fewer_pixels(k, dropped):
    d = ten_by_ten()
    v = d > 0
    expect = v.copy()
    sizes = {0: 25, 1: 3, 2: 25, 3: 2}
    labels, _ = label_regions(d, v)
    for i, n in sizes.items():
        if n < k:
            expect[labels == i] = False
    assert drop_small_regions(d, v, k) == dropped
    assert np.array_equal(v, expect)
    assert (d[~v] == 0.0).all()  # the background's value


def _reference_sizes(d, v, share):
    """Union-find over the pairs of 8-neighbours the rule joins: sorted region sizes."""
    h, w = d.shape
    parent = list(range(h * w))

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for r in range(h):
        for c in range(w):
            for dr, dc in ((0, 1), (1, -1), (1, 0), (1, 1)):
                rr, cc = r + dr, c + dc
                if not (0 <= rr < h and 0 <= cc < w) or not (v[r, c] and v[rr, cc]):
                    continue
                length = 2 ** 0.5 if dr and dc else 1.0
                a, b = d[r, c], d[rr, cc]
                if abs(a - b) <= share * length * min(abs(a), abs(b)):
                    parent[find(r * w + c)] = find(rr * w + cc)
    roots = [find(i) for i in range(h * w) if v.flat[i]]
    return sorted(np.unique(roots, return_counts=True)[1].tolist()) if roots else []


@settings(max_examples=60, deadline=None, phases=PHASES)
@given(hnp.arrays(np.float64, st.tuples(st.integers(1, 8), st.integers(1, 8)),
                  elements=st.sampled_from([0.0, 1.0, 1.02, 1.5, 2.0, 2.05, -1.0])))
def test_regions_are_those_of_a_union_find_over_the_rule(d):
    v = d != 0
    labels, sizes = label_regions(d, v)
    assert sorted(sizes.tolist()) == _reference_sizes(d, v, REGION_JUMP)
    assert sizes.sum() == v.sum()
    assert np.array_equal(np.bincount(labels[v], minlength=len(sizes)), sizes)


def test_min_region_drops_the_lone_pixel_and_its_fan_of_triangles(shared_data):
    # issue 41: a lone valid pixel at (0, 0) in a 100-pixel invalid border of a Kinect frame
    # pulled a fan of 27 triangles (8 % of the mesh's area)
    img = load(shared_data, "rgbd/open3d_TUM_depth.png").copy()
    img[:100, :] = 0
    img[-100:, :] = 0
    img[:, :100] = 0
    img[:, -100:] = 0
    clean = img.copy()
    img[0, 0] = img[240, 320]
    cam = rangemesh.Pinhole(525.0, 525.0, 319.5, 239.5, depth_scale=0.0002)
    fan = rangemesh.triangulate(img, camera=cam)
    corner = np.flatnonzero((fan.pixels == 0).all(axis=1))
    assert np.isin(corner, fan.faces).any()  # the speck is a vertex with triangles
    got = rangemesh.triangulate(img, camera=cam, min_region=2)
    want = rangemesh.triangulate(clean, camera=cam, min_region=2)  # (inner specks go too)
    assert not (got.pixels == 0).all(axis=1).any()
    assert np.array_equal(got.pixels, want.pixels) and np.array_equal(got.faces, want.faces)
    np.testing.assert_array_equal(got.vertices, want.vertices)


def test_label_regions_refuses_arrays_of_two_shapes():
    with pytest.raises(ValueError, match="one shape"):
        label_regions(np.ones((3, 3)), np.ones((3, 2), bool))
