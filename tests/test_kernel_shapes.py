"""Raw `rangemesh._core` calls with malformed arrays are refused in one line, before any work.

The kernels index the arrays they are given: arrays of mismatched shapes or
lengths, or ids out of range, would read or write out of bounds. Every call
below is malformed in one way, named by its id; each check raises ValueError
(or RuntimeError where the kernel's own check came first: ``broken
invariant``) naming the kernel. The well-formed call beside each family shows
the arrays are otherwise fine.
"""

from __future__ import annotations

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
    return _core.disparity_verdict(triangles, halfedges, normals, vertices, e0, 0.3, 0.005, 2.8, 0.08)


def _flips(fn, vr=VR, vc=VC, *extra):
    return fn(vr, vc, TV.copy(), HE.copy(), np.zeros(2), DEPTH, VALID, 1.0, *extra)


def test_the_well_formed_calls_work():
    # the arrays the malformed calls below change one thing of
    # the square's corners lie on one circle: Simulation of Simplicity flips 0-2 to 1-3 (vertex 0
    # dominates, and orient((3, 3), (0, 3), (3, 0)) = 9 > 0 puts 3 inside)
    assert _core.legalize_all(TV.copy(), HE.copy(), VR, VC) == 1
    assert _core.build_halfedges(FACES, 4)[1].tolist() == HE.tolist()
    assert _core.count_edges(FACES.astype(np.int32), 4) == 5
    assert _core.canonical_faces(TV, 4).tolist() == [[0, 1, 2], [0, 2, 3]]
    assert _core.valid_range(DEPTH, VALID)[2] == 16
    assert _core.nearest_valid(VALID, 3, 3) == (3, 3)
    assert len(_core.grid_pixels(VALID, 2, 2, 0, 3, False)[0]) >= 4
    assert _verdict() in _core.FLIP_VERDICTS.values()
    assert _flips(_core.flip_by_error)[1] >= 0
    assert _flips(_core.flip_from_edges, VR, VC, np.array([2], I64))[1] >= 0
    assert _core.error_flips(VR, VC, TV, DEPTH, VALID, 1.0)[0].shape == (6,)
    assert _core.triangle_error(0, 0, 0.0, 3, 0, 3.0, 3, 3, 12.0, True, True, True, DEPTH, VALID) >= 0
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
        0, 0, 0.0, 4, 0, 3.0, 3, 3, 12.0, True, True, True, DEPTH, VALID),
    "flip_by_error/vertex outside": lambda: _flips(_core.flip_by_error, VR + 1),
    "flip_from_edges/vertex outside": lambda: _flips(_core.flip_from_edges, VR, VC - 1,
                                                     np.array([2], I64)),
    "error_flips/vertex outside": lambda: _core.error_flips(VR, VC + 1, TV, DEPTH, VALID, 1.0),
    "error_flips/vertex id": lambda: _core.error_flips(VR[:3], VC[:3], TV, DEPTH, VALID, 1.0),
}


# the message's start where it is not the kernel's own name
NAMED = {"_heap_sift_up": "heap: ", "_heap_rekey": "heap: ", "flip_by_error": "flips: ",
         "flip_from_edges": "flips: ", "error_flips/vertex outside": "flips: ",
         "error_flips/vertex id": "build_halfedges: "}


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
    "greedy_insert/twin below -1": lambda: _core.greedy_insert(
        DEPTH, VALID, VR, VC, np.zeros(4), TV, np.array([-2, -1, 3, 2, -1, -1], I64), 5, -1.0, 1.0),
    "greedy_insert/vr and vc lengths": lambda: _core.greedy_insert(
        DEPTH, VALID, VR, VC[:3], np.zeros(4), TV, HE, 5, -1.0, 1.0),
    "greedy_insert/depth and valid": lambda: _core.greedy_insert(
        DEPTH, VALID[:3], VR, VC, np.zeros(4), TV, HE, 5, -1.0, 1.0),
    "flip_by_error/halfedges length": lambda: _core.flip_by_error(
        VR, VC, TV.copy(), HE[:3].copy(), np.zeros(2), DEPTH, VALID, 1.0),
    "gather_blocks/shapes": lambda: _core.gather_blocks(
        FACES, np.zeros((1, 3, 3)), np.zeros((2, 3)), np.zeros(4), 1e-3),
    "flip_loop/halfedges length": lambda: _core.flip_loop(
        TV.copy(), HE[:3].copy(), PTS, np.zeros((4, 3)), DEPTH, VALID, Orthographic().as_array(),
        rule=1, threshold=-np.inf, delta=0.3, epsilon=0.005, max_angle=2.8, min_bend=0.08,
        quantum=2.0**-32, max_edge2=np.inf, verdicts=np.zeros(8, I64), log=np.zeros((0, 3), I64)),
}


@pytest.mark.parametrize("case", REFUSED_BY_THE_KERNEL, ids=REFUSED_BY_THE_KERNEL)
def test_a_malformed_call_is_refused_by_the_kernel(case):
    with pytest.raises(RuntimeError, match="broken invariant"):
        REFUSED_BY_THE_KERNEL[case]()
