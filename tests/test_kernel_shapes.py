"""Raw `rangemesh._core` calls with malformed arrays are refused in one line, before any work.

The kernels index the arrays they are given: arrays of mismatched shapes or
lengths, or ids out of range, would read or write out of bounds. Every call
below is malformed in one way, named by its id; each check raises ValueError
(or RuntimeError where the kernel's own check came first: ``broken
invariant``) naming the kernel. The well-formed call beside each family shows
the arrays are otherwise fine.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rangemesh import _core
from rangemesh.camera import Orthographic

I64 = np.int64

# A 4 x 4 image, all valid, and the two triangles of its corners (0, 0) (3, 0) (3, 3) and
# (0, 0) (3, 3) (0, 3), counter-clockwise in (row, col): half-edge 2 (3, 3) -> (0, 0) and
# half-edge 3 (0, 0) -> (3, 3) are twins.
DEPTH = np.add.outer(np.arange(4.0), np.arange(4.0) ** 2)
VALID = np.ones((4, 4), bool)
VR = np.array([0, 3, 3, 0], I64)
VC = np.array([0, 0, 3, 3], I64)
TV = np.array([0, 1, 2, 0, 2, 3], I64)
HE = np.array([-1, -1, 3, 2, -1, -1], I64)
FACES = TV.reshape(-1, 3)
PTS = np.stack([VR, VC], axis=1)


def _heap(n=4):
    return np.zeros(n), np.arange(n, dtype=I64), np.arange(n, dtype=I64)


def _verdict(triangles=TV, halfedges=HE, normals=None, vertices=None, e0=2):
    normals = np.tile([0.0, 0.0, 1.0], (len(triangles) // 3, 1)) if normals is None else normals
    vertices = np.column_stack([VR, VC, np.zeros(4)]).astype(float) if vertices is None else vertices
    return _core.disparity_verdict(triangles, halfedges, normals, vertices, e0, _flip_settings())


def core_settings(cls, **fields):
    """`tests.helpers.core_settings`: this module is imported on its own too (CHILD)."""
    settings = cls()
    for name, value in fields.items():
        setattr(settings, name, value)
    return settings


def _flip_settings(rule=1, log_size=0):
    return core_settings(_core.FlipSettings, rule=rule, threshold=-np.inf, delta=0.3, epsilon=0.005,
                         max_angle=2.8, min_bend=0.08, quantum=2.0**-32, max_edge2=np.inf, log_size=log_size)


def _flips(fn, vr=VR, vc=VC, *extra):
    return fn((vr, vc, TV.copy(), HE.copy(), np.zeros(2)), DEPTH, VALID, 1.0, *extra)


def _insert(depth, valid, vr, vc, vz, tv, he, n, max_sum, span, sr=1, sc=1, sums=False):
    return _core.greedy_insert(depth, valid, (vr, vc, vz, tv, he),
                               _core.InsertSettings(n, max_sum, span, sr, sc, sums))


def test_the_well_formed_calls_work():
    # the arrays the malformed calls below change one thing of
    # the square's corners lie on one circle: Simulation of Simplicity flips 0-2 to 1-3 (vertex 0
    # dominates, and orient((3, 3), (0, 3), (3, 0)) = 9 > 0 puts 3 inside)
    assert _core.legalize_all(TV.copy(), HE.copy(), VR, VC) == 1
    assert _core.build_halfedges(FACES, 4)[1].tolist() == HE.tolist()
    assert _core.count_edges(FACES.astype(np.int32), 4) == 5
    assert _core.canonical_faces(TV, 4).tolist() == [[0, 1, 2], [0, 2, 3]]
    assert _core.valid_range(DEPTH, VALID).count == 16
    assert _core.nearest_valid(VALID, 3, 3) == (3, 3)
    assert len(_core.grid_pixels(VALID, 2, 2, 0, 3, False).rows) >= 4
    assert _verdict() in _core.FLIP_VERDICTS.values()
    assert _flips(_core.flip_by_error)[1] >= 0
    assert _flips(_core.flip_from_edges, VR, VC, np.array([2], I64))[1] >= 0
    assert _core.error_flips(VR, VC, TV, DEPTH, VALID, 1.0).triangles.shape == (6,)
    assert _core.triangle_error((0, 3, 3), (0, 0, 3), (0.0, 3.0, 12.0), DEPTH, VALID) >= 0
    assert len(_core.face_order(FACES, VR, VC, 4, 4, 2)) == 2
    alive = np.empty(2, bool)
    _core.keep_faces(FACES, PTS, VALID, np.inf, alive)
    assert alive.all()
    assert _core.compact_faces(FACES, alive, PTS)[0].shape == (2, 3)
    assert _core.valid_samples(PTS, VALID).tolist() == [[0, 0], [0, 3], [3, 0], [3, 3]]
    _core._heap_rekey(*_heap(), 1, 5.0, 4)


def _mask_image(depth_shape=(4, 4), valid_shape=(4, 4)):
    _core.mask_image(DEPTH, False, 0.0, np.zeros(depth_shape), np.zeros(valid_shape, bool))


MALFORMED = {
    # geometry: the image's arrays
    "mask_image/depth shape": lambda: _mask_image(depth_shape=(4, 3)),
    "mask_image/valid shape": lambda: _mask_image(valid_shape=(3, 4)),
    "valid_range/shapes": lambda: _core.valid_range(DEPTH, VALID[:3]),
    "label_regions/shapes": lambda: _core.label_regions(DEPTH, VALID, 0.05,
                                                        np.zeros((4, 3), np.int32)),
    "label_regions/share NaN": lambda: _core.label_regions(DEPTH, VALID, float("nan"),
                                                           np.zeros((4, 4), np.int32)),
    "covered_error/shapes": lambda: _core.covered_error(DEPTH[:, :3], DEPTH, VALID),
    "nearest_valid/row outside": lambda: _core.nearest_valid(VALID, 4, 0),
    "nearest_valid/column outside": lambda: _core.nearest_valid(VALID, 0, -1),
    "grid_pixels/columns beyond the image": lambda: _core.grid_pixels(VALID, 2, 2, 0, 4, False),
    "grid_pixels/empty image": lambda: _core.grid_pixels(np.ones((0, 4), bool), 2, 2, 0, 3, False),
    "rasterize/faces not (F, 3)": lambda: _core.rasterize(
        np.zeros((1, 2)), np.zeros((1, 2)), np.zeros((1, 2)), np.zeros((4, 4)),
        np.zeros((4, 4), I64)),
    "valid_faces/tv not 3 a triangle": lambda: _core.valid_faces(VR, VC, TV[:5], VALID),
    # geometry: meshes
    "legalize_all/r and c lengths": lambda: _core.legalize_all(TV.copy(), HE.copy(), VR, VC[:3]),
    "legalize_all/vertex id": lambda: _core.legalize_all(np.array([0, 1, 9], I64), HE[:3].copy(),
                                                         VR, VC),
    "legalize_all/twin": lambda: _core.legalize_all(TV.copy(), np.array([-1, -1, 6, 2, -1, -1], I64),
                                                    VR, VC),
    "legalize_all/twin below -1": lambda: _core.legalize_all(TV.copy(),
                                                             np.array([-2, -1, 3, 2, -1, -1], I64), VR, VC),
    "prune_dangling/simplices not (F, 3)": lambda: _core.prune_dangling(
        FACES[:, :2].copy(), np.full((2, 3), -1, I64), np.ones(2, bool), 4),
    "prune_dangling/neighbors not (F, 3)": lambda: _core.prune_dangling(
        FACES, np.full((2, 2), -1, I64), np.ones(2, bool), 4),
    "prune_dangling/negative vertex count": lambda: _core.prune_dangling(
        FACES, np.full((2, 3), -1, I64), np.ones(2, bool), -1),
    "build_halfedges/faces not (F, 3)": lambda: _core.build_halfedges(FACES[:, :2].copy(), 4),
    "build_halfedges/vertex id": lambda: _core.build_halfedges(FACES, 3),
    "build_halfedges/int32 vertex id": lambda: _core.build_halfedges(-FACES.astype(np.int32), 4),
    "build_halfedges/negative vertex count": lambda: _core.build_halfedges(FACES[:0], -1),
    "count_edges/faces not (F, 3)": lambda: _core.count_edges(FACES[:, :2].copy(), 4),
    "count_edges/vertex id": lambda: _core.count_edges(FACES, 3),
    "count_edges/negative id": lambda: _core.count_edges(np.array([[0, -1, 2]], np.int32), 4),
    "neighbors_from_halfedges/not 3 a triangle": lambda: _core.neighbors_from_halfedges(HE[:4]),
    "canonical_faces/not 3 a triangle": lambda: _core.canonical_faces(TV[:4], 4),
    "canonical_faces/vertex id": lambda: _core.canonical_faces(TV, 3),
    "canonical_faces/negative vertex count": lambda: _core.canonical_faces(TV[:0], -1),
    # the heap (tests' bindings)
    "_heap_sift_up/position": lambda: _core._heap_sift_up(*_heap(), 4),
    "_heap_sift_up/id without a slot": lambda: _core._heap_sift_up(
        np.zeros(4), np.array([0, 1, 2, 7], I64), np.arange(4, dtype=I64), 3),
    "_heap_sift_up/keys and heap lengths": lambda: _core._heap_sift_up(
        np.zeros(3), np.arange(4, dtype=I64), np.arange(4, dtype=I64), 1),
    "_heap_rekey/id": lambda: _core._heap_rekey(*_heap(), 4, 1.0, 4),
    "_heap_rekey/more entries than the heap": lambda: _core._heap_rekey(*_heap(), 1, 1.0, 5),
    # the paper's method
    "disparity_verdict/halfedges length": lambda: _verdict(halfedges=HE[:3]),
    "disparity_verdict/vertex id": lambda: _verdict(triangles=np.array([0, 1, 2, 0, 2, 7], I64)),
    "disparity_verdict/unpaired twin": lambda: _verdict(halfedges=np.array([-1, -1, 3, 1, -1, -1], I64)),
    "disparity_verdict/vertices not (V, 3)": lambda: _verdict(vertices=np.zeros((4, 2))),
    "valid_samples/samples not (N, 2)": lambda: _core.valid_samples(np.zeros((3, 3), I64), VALID),
    "keep_faces/point id": lambda: _core.keep_faces(FACES, PTS[:3], VALID, np.inf, np.empty(2, bool)),
    "keep_faces/one flag a face": lambda: _core.keep_faces(FACES, PTS, VALID, np.inf, np.empty(3, bool)),
    "keep_faces/barycentre outside": lambda: _core.keep_faces(FACES, PTS + 4, VALID, np.inf,
                                                              np.empty(2, bool)),
    "compact_faces/point id": lambda: _core.compact_faces(FACES, np.ones(2, bool), PTS[:3]),
    "compact_faces/one flag a face": lambda: _core.compact_faces(FACES, np.ones(1, bool), PTS),
    # the least-squares fit
    "face_order/faces not (F, 3)": lambda: _core.face_order(FACES[:, :2].copy(), VR, VC, 4, 4, 2),
    "face_order/rows and cols lengths": lambda: _core.face_order(FACES, VR, VC[:3], 4, 4, 2),
    "face_order/tile": lambda: _core.face_order(FACES, VR, VC, 4, 4, 0),
    "face_order/negative image size": lambda: _core.face_order(FACES[:0], VR, VC, -4, 4, 2),
    # refine
    "triangle_error/corner outside": lambda: _core.triangle_error(
        (0, 4, 3), (0, 0, 3), (0.0, 3.0, 12.0), DEPTH, VALID),
    "flip_by_error/vertex outside": lambda: _flips(_core.flip_by_error, VR + 1),
    "flip_from_edges/vertex outside": lambda: _flips(_core.flip_from_edges, VR, VC - 1,
                                                     np.array([2], I64)),
    "error_flips/vertex outside": lambda: _core.error_flips(VR, VC + 1, TV, DEPTH, VALID, 1.0),
    "error_flips/vertex id": lambda: _core.error_flips(VR[:3], VC[:3], TV, DEPTH, VALID, 1.0),
    # a flip writes through the twins: a twin of -2 wrote 8 bytes before the array (F1)
    "flip_by_error/twin below -1": lambda: _core.flip_by_error(
        (VR, VC, TV.copy(), np.array([-1, -1, -2, 2, -1, -1], I64), np.zeros(2)), DEPTH, VALID, 1.0),
    "flip_from_edges/twin below -1": lambda: _core.flip_from_edges(
        (VR, VC, TV.copy(), np.array([-1, -1, 3, -2, -1, -1], I64), np.zeros(2)), DEPTH, VALID, 1.0,
        np.array([3], I64)),
    "flip_by_error/twins that do not pair up": lambda: _core.flip_by_error(
        (VR, VC, TV.copy(), HE.astype(bool).astype(I64), np.zeros(2)), DEPTH, VALID, 1.0),
    "flip_from_edges/first half-edge": lambda: _flips(_core.flip_from_edges, VR, VC, np.array([6], I64)),
    "legalize_all/twins that do not pair up": lambda: _core.legalize_all(
        TV.copy(), np.array([-1, -1, 3, 1, -1, -1], I64), VR, VC),
    "neighbors_from_halfedges/twin below -1": lambda: _core.neighbors_from_halfedges(
        np.array([-1, -1, -2, 2, -1, -1], I64)),
    "prune_dangling/neighbour below -1": lambda: _core.prune_dangling(
        FACES, np.array([[-1, -1, -1], [-2, -1, -1]], I64), np.ones(2, bool), 4),
    "flip_loop/rule": lambda: _flip_loop(rule=2),
    "flip_loop/log size": lambda: _flip_loop(log_size=2**62),
    "flip_loop/twins that do not pair up": lambda: _flip_loop(
        halfedges=np.array([-1, -1, 3, 1, -1, -1], I64)),
    # greedy insertion from a first mesh whose twins do not pair up never ended, its arrays
    # growing without bound (F5)
    "greedy_insert/twin below -1": lambda: _insert(
        DEPTH, VALID, VR, VC, np.zeros(4), TV, np.array([-2, -1, 3, 2, -1, -1], I64), 5, -1.0, 1.0),
    "greedy_insert/twins that do not pair up": lambda: _insert(
        DEPTH, VALID, VR, VC, np.zeros(4), TV, HE.astype(bool).astype(I64), 5, -1.0, 1.0),
    "greedy_insert/twins that do not pair up, with sums": lambda: _insert(
        DEPTH, VALID, VR, VC, np.zeros(4), TV, np.array([-1, -1, 3, 1, -1, -1], I64), 5, -1.0, 1.0,
        sums=True),
    "greedy_insert/clockwise triangle": lambda: _insert(
        DEPTH, VALID, VR, VC, np.zeros(4), np.array([0, 2, 1, 0, 3, 2], I64),
        np.array([-1, -1, -1, -1, -1, -1], I64), 5, -1.0, 1.0),
    "strip_insert/twins that do not pair up": lambda: _strips(left_he=HE.astype(bool).astype(I64)),
    # (rows - 1) * sr overflowed int64 and passed the EXACT_SPAN check (F6)
    "greedy_insert/Delaunay scale beyond EXACT_SPAN": lambda: _insert(
        DEPTH, VALID, VR, VC, np.zeros(4), TV, HE, 5, -1.0, 1.0, 2**62, 1),
    "greedy_insert/Delaunay scale beyond EXACT_SPAN, with sums": lambda: _insert(
        DEPTH, VALID, VR, VC, np.zeros(4), TV, HE, 5, -1.0, 1.0, 1, 2**62, sums=True),
    "strip_insert/Delaunay scale beyond EXACT_SPAN": lambda: _strips(sr=2**62),
    "greedy_insert/Delaunay scale 0": lambda: _insert(
        DEPTH, VALID, VR, VC, np.zeros(4), TV, HE, 5, -1.0, 1.0, 0, 1),
    # every vertex is checked, not only each face's smallest row and column (F9)
    "face_order/vertex outside": lambda: _core.face_order(FACES, np.array([0, 3, 10, 0], I64), VC, 4, 4, 2),
    "face_order/vertex far outside": lambda: _core.face_order(FACES, VR, np.array([0, 0, 2**31, 3], I64),
                                                              4, 4, 2),
    "face_order/more cells than an image has": lambda: _core.face_order(FACES, VR, VC, 2**40, 2**40, 1),
    "fit_sample_errors/stride 0": lambda: _sample_errors(row_stride=0),
    "fit_sample_errors/pixels not (V, 2)": lambda: _core.fit_sample_errors(
        FACES, np.arange(2, dtype=I64), np.column_stack([VR, VC, VC]), DEPTH[VR, VC], DEPTH, VALID,
        _sampling(1, 1, 16)),
    "fit_heights/pixels not (V, 2)": lambda: _core.fit_heights(
        FACES, np.column_stack([VR, VC, VC]), DEPTH, VALID, None, _core.FitSettings()),
    "fit_blocks/pixels not (V, 2)": lambda: _core.fit_blocks(
        FACES, np.arange(2, dtype=I64), np.column_stack([VR, VC, VC]), DEPTH[VR, VC], DEPTH, VALID, 1.0),
    "fit_sample_errors/order entry": lambda: _core.fit_sample_errors(
        FACES, np.array([0, 2], I64), PTS, np.zeros(4), DEPTH, VALID, _sampling(1, 1, 16)),
    # (a barycentre inside, a corner outside: the squared edge lengths overflowed for far ones)
    "keep_faces/point outside": lambda: _core.keep_faces(
        FACES, np.array([[0, 0], [-3, 0], [6, 3], [0, 3]], I64), VALID, np.inf, np.empty(2, bool)),
    # (the inverted sums put a sample 10,000 columns past the tile: read out of bounds)
    "compact_faces/point beyond int32": lambda: _core.compact_faces(FACES, np.ones(2, bool), PTS + 2**40),
    "sample_tiles/weights not positive": lambda: _sample_tiles(f=np.tile([1.0, -0.001, -10.0, -10.0], (4, 1)),
                                                               zs=3),
    "line_pixel/k beyond the line": lambda: _core.line_pixel(0, 0, 3, 1, 4),
    "line_pixel/far endpoint": lambda: _core.line_pixel(0, 0, 2**62, 1, 1),
    "_triangle_rows/corners not (3, 2)": lambda: _core._triangle_rows(np.array([[0, 0], [4, 0]]),
                                                                      (True,) * 3),
    "_triangle_rows/step": lambda: _core._triangle_rows(np.array([[0, 0], [4, 0], [0, 4]]), (True,) * 3, 0,
                                                        2**62),
}


def _flip_loop(halfedges=HE, rule=1, log_size=0):
    return _core.flip_loop(
        TV.copy(), halfedges.copy(), PTS, np.column_stack([VR, VC, np.zeros(4)]).astype(float), DEPTH, VALID,
        Orthographic().as_array(), _flip_settings(rule, log_size))


# Two strips of a 4 x 7 image meeting down column 3, each first meshed by its corners' two triangles.
STRIP_DEPTH = np.add.outer(np.arange(4.0), np.arange(7.0) ** 2)
STRIP_VALID = np.ones((4, 7), bool)


def _strip_request(target, sr):
    return core_settings(_core.StripRequest, vertices=20, target=target, reserve=20, budget=-1.0, sr=sr, sc=1,
                         threads=2, rounds=True, flip=True)


def _strips(left_he=HE, sr=1, target=22):
    left = (VR, VC, np.zeros(4), TV, left_he)
    right = (VR, VC + 3, np.zeros(4), TV, HE)
    return _core.strip_insert(STRIP_DEPTH, STRIP_VALID, left, right, 45.0, _strip_request(target, sr))


STRIP = "vr vc tv he tsum"  # a StripMesh's arrays


def _arrays(result, names):
    """A result's arrays named in `names`, as lists."""
    return [getattr(result, n).tolist() for n in names.split()]


def _far_depth_strips():
    """Whether the strips of an image with a depth of 1e300 come back well formed, within the count."""
    depth = STRIP_DEPTH.copy()
    depth[1, 1] = 1e300  # keys and sums of inf and NaN
    left, right = (VR, VC, np.zeros(4), TV, HE), (VR, VC + 3, np.zeros(4), TV, HE)
    out = _core.strip_insert(depth, STRIP_VALID, left, right, 45.0, _strip_request(22, 1))
    ok = out.left.valid_vertices + out.right.valid_vertices <= 22
    for strip in (out.left, out.right):
        vr, vc, tv, he = strip.vr, strip.vc, strip.tv, strip.he
        _, twins = _core.build_halfedges(tv.reshape(-1, 3), len(vr))
        ok &= twins.tolist() == he.tolist() and bool(((0 <= vr) & (vr < 4) & (0 <= vc) & (vc < 7)).all())
    return [ok]


def _sampling(row_stride, face_stride, capacity):
    return core_settings(_core.FitSettings, row_stride=row_stride, face_stride=face_stride, capacity=capacity)


def _sample_errors(row_stride=1, face_stride=1, capacity=16):
    return _core.fit_sample_errors(FACES, np.arange(2, dtype=I64), PTS, DEPTH[VR, VC], DEPTH, VALID,
                                   _sampling(row_stride, face_stride, capacity))


def _pixel_list(*args):
    got = _core.grid_pixels(*args)
    return got.rows, got.cols


def _sample_tiles(f, rs=2, zs=2):
    grid = np.zeros((rs, zs, 2), np.int32)
    _core.sample_tiles(f, np.array([0, 3], I64), np.array([0, 3], I64), rs, zs, grid)
    return grid


# the message's start where it is not the kernel's own name
NAMED = {"_heap_sift_up": "heap: ", "_heap_rekey": "heap: ", "flip_by_error": "flips: ",
         "flip_from_edges": "flips: ", "error_flips/vertex outside": "flips: ",
         "error_flips/vertex id": "build_halfedges: ",
         "strip_insert": "greedy_insert: ", "fit_sample_errors": "fit: ", "fit_blocks": "fit: ",
         "fit_heights": "fit: "}


@pytest.mark.parametrize("case", MALFORMED, ids=MALFORMED)
def test_a_malformed_call_is_refused(case):
    kernel = case.split("/")[0]
    start = NAMED.get(case, NAMED.get(kernel, f"{kernel}: "))
    with pytest.raises(ValueError) as err:
        MALFORMED[case]()
    assert str(err.value).startswith(start), str(err.value)
    assert "\n" not in str(err.value)  # one line


# Malformed calls the kernels' own checks refuse (``broken invariant``, RuntimeError), before any
# array is read out of bounds.
REFUSED_BY_THE_KERNEL = {
    "delaunay_sweep/r and c lengths": lambda: _core.delaunay_sweep(VR, VC[:3]),
    "fill_gaps_inplace/shapes": lambda: _core.fill_gaps_inplace(DEPTH.copy(), VALID[:3].copy()),
    "add_curvature/shapes": lambda: _core.add_curvature(DEPTH, VALID, 1.0, 2, np.zeros((4, 3))),
    "seam_rows/lengths": lambda: _core.seam_rows(DEPTH[:, 0].copy(), VALID[:3, 0].copy(), 2, -1.0, 1.0),
    "greedy_insert/vr and vc lengths": lambda: _insert(
        DEPTH, VALID, VR, VC[:3], np.zeros(4), TV, HE, 5, -1.0, 1.0),
    "greedy_insert/depth and valid": lambda: _insert(
        DEPTH, VALID[:3], VR, VC, np.zeros(4), TV, HE, 5, -1.0, 1.0),
    "flip_by_error/halfedges length": lambda: _core.flip_by_error(
        (VR, VC, TV.copy(), HE[:3].copy(), np.zeros(2)), DEPTH, VALID, 1.0),
    "gather_blocks/shapes": lambda: _core.gather_blocks(
        FACES, np.zeros((1, 3, 3)), np.zeros((2, 3)), np.zeros(4), 1e-3),
    "flip_loop/halfedges length": lambda: _core.flip_loop(
        TV.copy(), HE[:3].copy(), PTS, np.zeros((4, 3)), DEPTH, VALID, Orthographic().as_array(),
        _flip_settings()),
}


@pytest.mark.parametrize("case", REFUSED_BY_THE_KERNEL, ids=REFUSED_BY_THE_KERNEL)
def test_a_malformed_call_is_refused_by_the_kernel(case):
    with pytest.raises(RuntimeError, match="broken invariant"):
        REFUSED_BY_THE_KERNEL[case]()


# F6: hi - lo of a coordinate of INT64_MIN overflowed and passed the EXACT_SPAN check; a
# triangulation came back on a point at -9.2e18.
FAR = np.array([np.iinfo(I64).min, 3, 3, 0], I64)


@pytest.mark.parametrize("kernel", ["delaunay_sweep", "legalize_all"])
def test_a_coordinate_of_int64_min_is_beyond_the_exact_span(kernel):
    with pytest.raises(ValueError, match="EXACT_SPAN"):
        if kernel == "delaunay_sweep":
            _core.delaunay_sweep(FAR, VC)
        else:
            _core.legalize_all(TV.copy(), HE.copy(), FAR, VC)


# Counts, strides and tiles beyond the image ask for no more than the image holds: the same
# result as the largest that means something, with no int64 overflow on the way (F6). (Before
# the fix UBSan aborted these; a plain build gave undefined results.)
BIG = [2**62, np.iinfo(I64).max]


@pytest.mark.parametrize("big", BIG)
def test_a_row_stride_beyond_the_image_samples_its_first_row(big):
    # The square 2 rows down a 6 x 4 image: rows 2..5, none a multiple of a stride of 6 or more
    # (top + stride - 1 overflowed, and the walk started 2^63 rows above the image). A stride of
    # 3 samples row 3, where both faces' plane is r + 3c against depth r + c^2: |c^2 - 3c| at
    # columns 0 (the lower face's), 1 and 2 (the upper's; column 3, on the border edge that
    # runs up, is no face's). A face stride beyond the faces samples the first face alone.
    depth, valid = np.add.outer(np.arange(6.0), np.arange(4.0) ** 2), np.ones((6, 4), bool)
    rows = VR + 2

    def sample(row_stride, face_stride=1):
        return _core.fit_sample_errors(FACES, np.arange(2, dtype=I64), np.stack([rows, VC], axis=1),
                                       depth[rows, VC], depth, valid,
                                       _sampling(row_stride, face_stride, 24)).tolist()

    assert sample(big) == sample(6) == []
    assert sample(3) == pytest.approx([0.0, 2.0, 2.0], abs=1e-12)
    assert sample(3, big) == sample(3, 2) == [0.0]


@pytest.mark.parametrize("big", BIG)
def test_a_tile_beyond_the_image_is_one_cell(big):
    # one cell: the faces as they come (stable)
    assert _core.face_order(FACES[::-1].copy(), VR, VC, 4, 4, big).tolist() == [0, 1]


@pytest.mark.parametrize("big", BIG)
def test_a_capacity_beyond_the_pixels_is_the_pixels(big):
    assert _sample_errors(capacity=big).tolist() == _sample_errors(capacity=16).tolist()


@pytest.mark.parametrize("big", BIG)
def test_a_vertex_count_beyond_the_pixels_inserts_every_pixel(big):
    every = _insert(DEPTH, VALID, VR, VC, DEPTH[VR, VC], TV, HE, big, -1.0, 12.0)
    assert every.valid_vertices == 16  # all 16 pixels are vertices
    assert _arrays(every, "vr vc tv") == _arrays(_insert(DEPTH, VALID, VR, VC, DEPTH[VR, VC], TV, HE, 16,
                                                         -1.0, 12.0), "vr vc tv")
    # (target - count overflowed for a target of INT64_MIN)
    least = _strips(target=-big - 1)
    assert _arrays(least.left, STRIP) == _arrays(_strips(target=0).left, STRIP)
    strips = _strips(target=big)
    # every pixel, the seam's four twice, but its two inner ones (fixed beforehand: a first mesh
    # of a strip holds them)
    assert strips.left.valid_vertices + strips.right.valid_vertices == 28 + 4 - 4
    assert _arrays(strips.left, STRIP) == _arrays(_strips(target=56).left, STRIP)


@pytest.mark.parametrize("n_vertices", BIG)
def test_a_vertex_count_beyond_the_ids_in_use_changes_nothing(n_vertices):
    assert _core.build_halfedges(FACES, n_vertices)[1].tolist() == HE.tolist()
    assert _core.count_edges(FACES, n_vertices) == 5
    assert _core.canonical_faces(TV, n_vertices).tolist() == [[0, 1, 2], [0, 2, 3]]
    assert _core.prune_dangling(FACES, np.array([[-1, 1, -1], [-1, -1, 0]], I64), np.ones(2, bool),
                                n_vertices) == 0


# Calls that ran for ever, or until memory ran out, before the fix: each runs in a child
# process with a time and memory limit, so that a regression fails instead of hanging the run.
CHILD = """
import json, os, resource, sys
if "libasan" not in os.environ.get("LD_PRELOAD", ""):  # (ASan's shadow memory needs terabytes)
    resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30))
sys.path.insert(0, {tests!r})
import numpy as np
import test_kernel_shapes as t
try:
    got = eval({call!r}, vars(t))
    print(json.dumps([np.asarray(a).tolist() for a in got]))
except ValueError as e:
    print(json.dumps(str(e)))
"""

ENDLESS = {
    # F8: a loop over 2^62 grid rows; a grid finer than the pixels has every pixel for a centre:
    # the corners, then rows 0..3 at the centres 1 and 3 of 2 columns (no corner twice)
    "grid_pixels/2^62 rows": ("_pixel_list(VALID, 2**62, 2, 0, 3, False)",
                              [[0, 3, 3, 0, 0, 1, 1, 2, 2, 3], [0, 0, 3, 3, 1, 1, 3, 1, 3, 1]]),
    # ... and columns 0..3 on rows 1 and 3 of 2
    "grid_pixels/2^62 columns": ("_pixel_list(VALID, 2, 2**62, 0, 3, False)",
                                 [[0, 3, 3, 0, 1, 1, 1, 1, 3, 3], [0, 0, 3, 3, 0, 1, 2, 3, 1, 2]]),
    # F8: a list of 2^31 rows
    "_triangle_rows/corner at 2^31": ("_core._triangle_rows(np.array([[0, 0], [2**31, 0], [0, 4]]), "
                                      "(True,) * 3)",
                                      "_triangle_rows: corners are pixels within EXACT_SPAN"),
    # the strips' last vertices one at a time: a NaN key (a depth of 1e300) made neither strip
    # go on, and the loop asked them again for ever
    "strip_insert/a depth of 1e300": ("_far_depth_strips()", [True]),
    # F5: insertion on twins that do not pair up grew its arrays at 100 MB/s
    "strip_insert/twins that do not pair up": ("_strips(left_he=HE.astype(bool).astype(I64))",
                                               "greedy_insert: "),
}


@pytest.mark.parametrize("case", ENDLESS, ids=ENDLESS)
def test_a_call_that_ran_for_ever_ends_at_once(case):
    call, expected = ENDLESS[case]
    code = CHILD.format(tests=str(Path(__file__).parent), call=call)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr[-2000:]
    got = json.loads(done.stdout)
    if isinstance(expected, str):  # a refusal
        assert got.startswith(expected), got
    else:
        assert got == expected
