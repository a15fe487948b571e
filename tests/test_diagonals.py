"""Diagonals chosen by the data (`rangemesh.refine.diagonals`, ``diagonals='error'``).

Expected values: a hand-made valley whose two planes one diagonal fits
exactly, pixel sums against a brute-force barycentric sum in NumPy, and the
error of the meshes as `evaluate` renders them (another rasteriser).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import rangemesh
from rangemesh import _core, evaluate, triangulate
from rangemesh._core import ErrorScan, InsertSettings, error_flips, flip_by_error, triangle_error, valid_range
from rangemesh.refine import insertion

from .helpers import assert_valid_mesh

CROPS = Path(__file__).parent / "data" / "crops.npz"


def _orient(a, b, p):
    return (b[0] - a[0]) * (p[..., 1] - a[1]) - (b[1] - a[1]) * (p[..., 0] - a[0])


def _brute_sum(corners, z, own, depth, valid):
    """|depth - plane| summed over the pixels inside ABC or on an owned edge, in NumPy."""
    a, b, c = (np.asarray(p) for p in corners)
    rr, cc = np.mgrid[: depth.shape[0], : depth.shape[1]]
    p = np.stack([rr, cc], axis=-1)
    w = [_orient(a, b, p), _orient(b, c, p), _orient(c, a, p)]  # AB, BC, CA
    inside = valid.copy()
    for wk, ok in zip(w, own, strict=True):
        inside &= (wk > 0) | ((wk == 0) & ok)
    # the plane through the corners, solved independently of the kernel's weights
    coef = np.linalg.solve(np.c_[np.array([a, b, c], float), np.ones(3)], np.asarray(z, float))
    plane = coef[0] * rr + coef[1] * cc + coef[2]
    return float(np.abs(depth - plane)[inside].sum())


@given(st.integers(0, 2**31), st.lists(st.integers(0, 11), min_size=6, max_size=6),
       st.lists(st.booleans(), min_size=3, max_size=3))
def test_triangle_error_is_the_sum_over_its_pixels(seed, coords, own):
    rng = np.random.default_rng(seed)
    a, b, c = (coords[0], coords[1]), (coords[2], coords[3]), (coords[4], coords[5])
    area = _orient(np.array(a), np.array(b), np.array(c))
    if area == 0:
        return
    if area < 0:
        b, c = c, b
    depth = rng.uniform(0, 10, (12, 12))
    valid = rng.uniform(size=(12, 12)) > 0.2
    z = rng.uniform(0, 10, 3)
    got = triangle_error((a[0], b[0], c[0]), (a[1], b[1], c[1]), tuple(z), depth, valid, ErrorScan(*own))
    assert got == pytest.approx(_brute_sum((a, b, c), z, own, depth, valid), rel=1e-9, abs=1e-9)


@given(st.lists(st.integers(0, 11), min_size=6, max_size=6))
def test_triangle_error_of_a_clockwise_triangle_is_zero(coords):
    # A raw call may pass a triangle turned the wrong way: its three edge functions sum to its
    # (negative) doubled area at every pixel, so none is >= 0 on all three and no pixel is its own.
    a, b, c = (coords[0], coords[1]), (coords[2], coords[3]), (coords[4], coords[5])
    area = _orient(np.array(a), np.array(b), np.array(c))
    if area == 0:
        return
    if area > 0:
        b, c = c, b
    depth = np.ones((12, 12))
    valid = np.ones((12, 12), bool)
    assert triangle_error((a[0], b[0], c[0]), (a[1], b[1], c[1]), (0.0, 0.0, 0.0), depth, valid,
                          ErrorScan(True, True, True)) == 0.0


def test_triangle_error_stops_once_the_key_is_reached():
    """With a `stop` key the sum is left after the first row that reaches it, by hand.

    Triangle (0,0), (4,0), (0,4), corners at depth 0 (the plane z = 0): its rows
    hold 5, 4, 3, 2, 1 pixels. Depth 1 on rows 1 and 3: a sum of 4 + 2 = 6.
    Keys in units of 2**-32 of the span (1 here).
    """
    depth = np.zeros((5, 5))
    depth[[1, 3]] = 1.0
    valid = np.ones((5, 5), bool)
    tri = ((0, 4, 0), (0, 0, 4), (0.0, 0.0, 0.0), depth, valid)

    def key(x):
        return float(np.floor(x * 2.0**32 + 0.5))

    assert triangle_error(*tri) == 6.0
    assert triangle_error(*tri, ErrorScan(span=1.0, stop=key(10.0))) == 6.0  # never reached: the whole sum
    assert triangle_error(*tri, ErrorScan(span=1.0, stop=key(3.5))) == 4.0  # reached on row 1: left there
    assert triangle_error(*tri, ErrorScan(span=1.0, stop=key(4.0))) == 4.0  # reached exactly
    assert triangle_error(*tri, ErrorScan(span=1.0, stop=key(4.5))) == 6.0  # only on row 3
    # `base` counts: 3 + 4 >= 6.5
    assert triangle_error(*tri, ErrorScan(base=3.0, span=1.0, stop=key(6.5))) == 4.0


def _serial_sum(corners, z, own, depth, valid, base=0.0, span=1.0, stop=np.inf):
    """plane.hpp's sum in plain Python floats: its formula, pixels in row-major order.

    Each owned pixel's error |depth - (w1 zA + w2 zB + w0 zC) / area| (w the integer edge
    functions of AB, BC, CA), added one at a time; left after a row with owned pixels once
    quantize(base + sum) >= stop, as `triangle_error`'s docstring says.
    """
    (ar, ac), (br, bc), (cr, cc) = corners
    area = (br - ar) * (cc - ac) - (bc - ac) * (cr - ar)
    inv = 1.0 / float(area)
    total = 0.0
    for r in range(depth.shape[0]):
        owned = False
        for col in range(depth.shape[1]):
            w0 = (br - ar) * (col - ac) - (bc - ac) * (r - ar)
            w1 = (cr - br) * (col - bc) - (cc - bc) * (r - br)
            w2 = (ar - cr) * (col - cc) - (ac - cc) * (r - cr)
            if all(w > 0 or (w == 0 and ok) for w, ok in zip((w0, w1, w2), own, strict=True)):
                owned = True
                if valid[r, col]:
                    plane = (float(w1) * z[0] + float(w2) * z[1] + float(w0) * z[2]) * inv
                    total += abs(float(depth[r, col]) - plane)
        if owned and np.floor((base + total) / span * 2.0**32 + 0.5) >= stop:
            break
    return total


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31), st.lists(st.integers(0, 34), min_size=6, max_size=6),
       st.lists(st.booleans(), min_size=3, max_size=3), st.sampled_from([None, 0.3, 2.0]))
def test_triangle_error_of_a_large_triangle_is_the_row_major_sum_bit_for_bit(seed, coords, own, stop_at):
    # boxes above 128 pixels take the four-lane walk where AVX runs: its lanes must give the
    # scalar loop's errors and its sum their row-major order, exactly (a 35 x 35 image: rows
    # whose last groups of four reach the image's right side take the scalar remainder)
    rng = np.random.default_rng(seed)
    a, b, c = (coords[0], coords[1]), (coords[2], coords[3]), (coords[4], coords[5])
    area = _orient(np.array(a), np.array(b), np.array(c))
    if area == 0:
        return
    if area < 0:
        b, c = c, b
    depth = rng.uniform(0, 10, (35, 35)) * np.pi
    valid = rng.uniform(size=(35, 35)) > 0.15
    depth[~valid] = np.nan  # (never read: a lane past the run or on a hole is left out)
    z = tuple(rng.uniform(0, 10, 3).tolist())
    span, base = 10.0, 1.5
    stop = np.inf if stop_at is None else float(np.floor((base + stop_at * abs(area)) / span * 2.0**32 + 0.5))
    scan = ErrorScan(*own) if stop_at is None else ErrorScan(*own, base=base, span=span, stop=stop)
    got = triangle_error((a[0], b[0], c[0]), (a[1], b[1], c[1]), z, depth, valid, scan)
    expected = _serial_sum((a, b, c), z, own, depth, valid, *((0.0, 1.0, np.inf) if stop_at is None
                                                             else (base, span, stop)))
    assert got == expected



@settings(max_examples=120, deadline=None)
@given(st.integers(0, 2**31), st.integers(5, 30), st.integers(9, 44),
       st.lists(st.integers(0, 10**6), min_size=5, max_size=5),
       st.lists(st.booleans(), min_size=3, max_size=3), st.sampled_from([np.nan, np.inf, -0.0, 1e300]),
       st.sampled_from([None, 0.3]))
def test_triangle_error_at_the_right_side_of_any_width_is_the_row_major_sum_bit_for_bit(
        seed, h, w, at, own, hole, stop_at):
    # (review44d) a large triangle with a corner on the image's right column, widths of every
    # remainder mod 4: its rows' last groups of four end 0 to 3 columns from the right side;
    # holes hold non-finite or huge depths and some valid depths are -0.0: neither may reach the sum
    rng = np.random.default_rng(seed)
    a, b, c = (at[0] % h, w - 1), (at[1] % h, at[2] % w), (at[3] % h, at[4] % (w // 2 + 1))
    area = _orient(np.array(a), np.array(b), np.array(c))
    rows = max(a[0], b[0], c[0]) - min(a[0], b[0], c[0]) + 1
    cols = max(a[1], b[1], c[1]) - min(a[1], b[1], c[1]) + 1
    if area == 0 or rows * cols <= 128:  # (small boxes take the scalar walk alone)
        return
    if area < 0:
        b, c = c, b
    depth = rng.uniform(-5, 10, (h, w)) * np.pi
    depth[rng.uniform(size=(h, w)) < 0.05] = -0.0
    valid = rng.uniform(size=(h, w)) > 0.2
    depth[~valid] = hole
    z = tuple(rng.uniform(-5, 10, 3).tolist())
    span, base = 10.0, 1.5
    stop = np.inf if stop_at is None else float(np.floor((base + stop_at * abs(area)) / span * 2.0**32 + 0.5))
    scan = ErrorScan(*own) if stop_at is None else ErrorScan(*own, base=base, span=span, stop=stop)
    got = triangle_error((a[0], b[0], c[0]), (a[1], b[1], c[1]), z, depth, valid, scan)
    expected = _serial_sum((a, b, c), z, own, depth, valid, *((0.0, 1.0, np.inf) if stop_at is None
                                                             else (base, span, stop)))
    assert np.float64(got).view(np.int64) == np.float64(expected).view(np.int64)  # bit for bit

_NO_AVX_CHILD = r"""
import hashlib, json, sys
import numpy as np
import rangemesh
from rangemesh import _core
from rangemesh._core import InsertSettings, flip_by_error, valid_range
from rangemesh.refine import insertion

crops = np.load(sys.argv[1])
out, boxes = {"avx": bool(_core._uses_avx())}, []
for name in ("tum", "nyu", "chair"):
    depth, valid = rangemesh.pipeline.prepare(crops[name].astype(float), rangemesh.MeshParams(),
                                              2047 if name == "nyu" else 0)
    depth = depth * np.pi  # (whole depths would make many sums exact in any order)
    lo, hi, n_valid = valid_range(depth, valid)
    for n in (20, 60, 300):
        start = insertion.first_mesh(depth, valid, insertion.grid_size(n, n_valid, False))
        ins = _core.greedy_insert(depth, valid, start, InsertSettings(n, -1.0, hi - lo, sums=True))
        vr, vc, tv, he, tsum = (np.array(x) for x in (ins.vr, ins.vc, ins.tv, ins.he, ins.tsum))
        f = tv.reshape(-1, 3)
        boxes += ((np.ptp(vr[f], axis=1) + 1) * (np.ptp(vc[f], axis=1) + 1)).tolist()
        flips, tests = flip_by_error((vr, vc, tv, he, tsum), depth, valid, hi - lo)
        out[f"{name} {n}"] = [flips, tests, hashlib.sha256(tv.tobytes() + tsum.tobytes()).hexdigest()]
out["large boxes"] = sum(b > 128 for b in boxes)
print(json.dumps(out))
"""


def test_the_scalar_walk_gives_the_four_lane_walks_flips_bit_for_bit():
    # RANGEMESH_NO_AVX=1 runs the flips' scalar box walk: the same flips and the same sums
    import json
    import os
    import subprocess
    import sys

    if not _core._uses_avx():
        pytest.skip("this machine runs the scalar loops only")
    runs = {}
    for off in ("1", "0"):
        env = {**os.environ, "RANGEMESH_NO_AVX": off}
        p = subprocess.run([sys.executable, "-c", _NO_AVX_CHILD, str(CROPS)], capture_output=True,
                           text=True, env=env, timeout=600)
        assert p.returncode == 0, p.stderr
        runs[off] = json.loads(p.stdout)
    assert runs["1"].pop("avx") is False and runs["0"].pop("avx") is True
    assert runs["1"]["large boxes"] > 20  # (the four-lane walk had triangles to scan)
    assert all(v[0] > 0 for key, v in runs["1"].items() if key.endswith(" 300"))  # (flips to compare)
    assert runs["1"] == runs["0"]


def _square(depth, diagonal):
    """The image's four corners as a mesh of two triangles cut along `diagonal`."""
    h, w = depth.shape
    vr = np.array([0, h - 1, h - 1, 0], np.int64)
    vc = np.array([0, 0, w - 1, w - 1], np.int64)
    # corners 0 (0,0), 1 (H-1,0), 2 (H-1,W-1), 3 (0,W-1); counter-clockwise in (row, column)
    tv = {"main": [0, 1, 2, 0, 2, 3], "anti": [0, 1, 3, 1, 2, 3]}[diagonal]
    return vr, vc, np.array(tv, np.int64)


def test_a_valley_along_the_other_diagonal_is_flipped_onto_it():
    # z = |r - c|: two planes meeting along the main diagonal (0,0)-(4,4). Cut along the
    # anti-diagonal, the two triangles miss the valley (the pixel (2,2) is off by 4); cut
    # along the main one, each triangle lies on one plane and every pixel fits exactly.
    r, c = np.mgrid[:5, :5]
    depth = np.abs(r - c).astype(float)
    valid = np.ones_like(depth, bool)
    vr, vc, tv = _square(depth, "anti")
    out = error_flips(vr, vc, tv, depth, valid, 4.0)
    tri, flips, tests = out.triangles, out.flips, out.tests
    assert (flips, tests) == (1, 1)
    assert sorted(map(sorted, tri.reshape(-1, 3).tolist())) == [[0, 1, 2], [0, 2, 3]]
    # and the right diagonal stays
    vr, vc, tv = _square(depth, "main")
    out = error_flips(vr, vc, tv, depth, valid, 4.0)
    tri, flips, tests = out.triangles, out.flips, out.tests
    assert flips == 0 and np.array_equal(tri, tv)


def test_a_plane_is_never_flipped():
    r, c = np.mgrid[:6, :7]
    depth = 2.0 * r - 0.5 * c + 3.0
    valid = np.ones_like(depth, bool)
    for diagonal in ("main", "anti"):
        vr, vc, tv = _square(depth, diagonal)
        out = error_flips(vr, vc, tv, depth, valid, float(np.ptp(depth)))
        assert out.flips == out.tests == 0 and np.array_equal(out.triangles, tv)


def test_a_quad_with_a_background_corner_is_never_flipped():
    r, c = np.mgrid[:5, :5]
    depth = np.abs(r - c).astype(float)
    valid = np.ones_like(depth, bool)
    valid[4, 0] = False  # corner 1: the valley's flip would be taken otherwise (test above)
    vr, vc, tv = _square(depth, "anti")
    out = error_flips(vr, vc, tv, depth, valid, 4.0)
    assert out.flips == out.tests == 0 and np.array_equal(out.triangles, tv)


@pytest.mark.parametrize("name", ["chair", "venus", "tum", "nyu"])
@pytest.mark.parametrize("n", [60, 600])
def test_the_insertions_sums_give_the_flips_of_a_fresh_count(name, n):
    """`flip_by_error` on the kernel's own half-edges and sums == `error_flips` from scratch."""
    image = np.load(CROPS)[name].astype(float)
    background = {"chair": 0, "venus": None, "tum": 0, "nyu": 2047}[name]
    depth, valid = rangemesh.pipeline.prepare(image, rangemesh.MeshParams(), background)
    lo, hi, n_valid = valid_range(depth, valid)
    start = insertion.first_mesh(depth, valid, insertion.grid_size(n, n_valid, False))
    out = _core.greedy_insert(depth, valid, start, InsertSettings(n, -1.0, hi - lo, sums=True))
    vr, vc, tv, he, tsum = out.vr, out.vc, out.tv, out.he, out.tsum
    fresh = error_flips(vr, vc, tv, depth, valid, hi - lo)
    assert fresh.flips > 0  # (else the comparison below says nothing)
    flip_by_error((vr, vc, tv, he, tsum), depth, valid, hi - lo)
    assert np.array_equal(tv, fresh.triangles)


def _owns(twin, ar, ac, br, bc, w):
    """Whether a triangle owns the pixels on its edge a -> b (geometry/ownership.hpp's rule)."""
    if twin < 0:
        return not (ac == bc and 0 < ac < w - 1)
    return br > ar or (br == ar and bc > ac)


@pytest.mark.parametrize("name", ["tum", "nyu"])
def test_triangle_error_is_the_insertions_own_sum_bit_for_bit(name):
    """`triangle_error` (a box walk on small triangles) == the insertion's row-walk sums, exactly.

    The flips compare fresh sums with the insertion's cached ones, so any last-bit difference
    could change a flip; the two budgets give triangles on either side of the box walk's size.
    """
    image = np.load(CROPS)[name].astype(float)
    background = {"tum": 0, "nyu": 2047}[name]
    depth, valid = rangemesh.pipeline.prepare(image, rangemesh.MeshParams(), background)
    depth = depth * np.pi  # (whole depths would make every plane's numerator exact in any order)
    lo, hi, n_valid = valid_range(depth, valid)
    w = depth.shape[1]
    boxes = []
    for n in (60, 2000):
        start = insertion.first_mesh(depth, valid, insertion.grid_size(n, n_valid, False))
        out = _core.greedy_insert(depth, valid, start, InsertSettings(n, -1.0, hi - lo, sums=True))
        vr, vc, tv, he, tsum = (np.asarray(x) for x in (out.vr, out.vc, out.tv, out.he, out.tsum))
        for t in range(len(tv) // 3):
            ids = tv[3 * t: 3 * t + 3]
            rows, cols = vr[ids], vc[ids]
            if tsum[t] == 0.0 or not valid[rows, cols].all():  # (keyed without a scan)
                continue
            own = [bool(_owns(he[3 * t + k], rows[k], cols[k], rows[(k + 1) % 3], cols[(k + 1) % 3], w))
                   for k in range(3)]
            z = tuple(depth[rows, cols].tolist())
            got = triangle_error(tuple(rows.tolist()), tuple(cols.tolist()), z, depth, valid, ErrorScan(*own))
            assert got == tsum[t], (n, t, rows, cols)
            boxes.append((np.ptp(rows) + 1) * (np.ptp(cols) + 1))
    assert len(boxes) > 100 and min(boxes) <= 128 < max(boxes)  # both walks were compared


def _errors(image, background=None, **kw):
    """Both meshes, each with its `evaluate` against the image the flips see (gaps filled)."""
    depth, valid = rangemesh.fill_gaps(*rangemesh.to_depth_and_mask(image, background))
    seen = np.where(valid, depth, np.nan)
    out = {}
    for diagonals in ("delaunay", "error"):
        m = triangulate(image, background=background, method="refine", heights="pixel",
                        diagonals=diagonals, **kw)
        out[diagonals] = (m, evaluate(m, seen))
    return out


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**31), st.integers(6, 28), st.integers(6, 28), st.integers(4, 60),
       st.floats(0.0, 0.5))
def test_flips_never_raise_the_error_and_keep_the_mesh_valid(seed, h, w, n, holes):
    """Each flip lowers the two triangles' summed error: the whole mesh's can only drop.

    Measured by `evaluate` (a render of the mesh), copied depths as in the flips' test,
    on images with background holes; the flipped mesh has the same vertices and covers
    the same pixels.
    """
    rng = np.random.default_rng(seed)
    r, c = np.mgrid[:h, :w]
    image = np.abs(r - 0.7 * c + rng.uniform(-3, 3)) + rng.normal(0, 0.3, (h, w)) + 5.0
    image[rng.uniform(size=(h, w)) < holes] = 0.0
    if (image > 0).sum() < 4:
        return
    out = _errors(image, background=0.0, vertices=n)
    (md, ed), (mf, ef) = out["delaunay"], out["error"]
    assert_valid_mesh(mf, rangemesh.fill_gaps(*rangemesh.to_depth_and_mask(image, 0.0))[1])
    assert np.array_equal(md.pixels, mf.pixels)
    assert ef.relative_error <= ed.relative_error * (1 + 1e-9) + 1e-12
    assert ef.uncovered == pytest.approx(ed.uncovered)


@pytest.mark.parametrize("name", ["chair", "venus", "cones", "tum", "nyu", "mug"])
def test_flips_lower_the_error_on_real_crops(name):
    """Copied depths: never higher (each flip lowers it); on these crops, by at least 1 %."""
    background = {"chair": 0, "venus": None, "cones": 0, "tum": 0, "nyu": 2047,
                  "mug": None}[name]
    image = np.load(CROPS)[name].astype(float)
    out = _errors(image, background=background, vertices=300)
    assert out["error"][1].relative_error < 0.99 * out["delaunay"][1].relative_error


def test_delaunay_keeps_the_insertions_mesh():
    """``diagonals='delaunay'``: the faces of greedy insertion itself (no flip)."""
    image = np.load(CROPS)["venus"].astype(float)
    m = triangulate(image, vertices=200, diagonals="delaunay", heights="pixel")
    depth, valid = rangemesh.pipeline.prepare(image, rangemesh.MeshParams(), None)
    lo, hi, n_valid = valid_range(depth, valid)
    start = insertion.first_mesh(depth, valid, insertion.grid_size(200, n_valid, False))
    tv = _core.greedy_insert(depth, valid, start, InsertSettings(200, -1.0, hi - lo)).tv
    assert np.array_equal(m.faces, tv.reshape(-1, 3))  # venus is all valid: no renumbering


def test_diagonals_belongs_to_refine():
    image = np.load(CROPS)["venus"].astype(float)
    with pytest.raises(ValueError, match="diagonals"):
        triangulate(image, method="paper", diagonals="error")
    with pytest.raises(ValueError, match="diagonals must be one of"):
        triangulate(image, vertices=50, diagonals="round")
    # given alone, it picks method='refine' as the other refine fields do
    m = triangulate(image, vertices=50, diagonals="delaunay")
    assert m.stats.vertices == 50


def test_command_line_diagonals(tmp_path, capsys):
    from rangemesh.cli import main

    image = np.load(CROPS)["venus"]
    src = tmp_path / "venus.npy"
    np.save(src, image)
    assert main(["mesh", str(src), "--vertices", "300", "--diagonals", "error", "--heights",
                 "pixel", "-o", str(tmp_path / "e.ply")]) == 0
    m = rangemesh.read_mesh(tmp_path / "e.ply")
    ref = triangulate(image.astype(float), vertices=300, diagonals="error", heights="pixel")
    assert np.array_equal(np.sort(np.sort(m.faces, axis=1), axis=0),
                          np.sort(np.sort(ref.faces, axis=1), axis=0))
    capsys.readouterr()
    assert main(["mesh", str(src), "--method", "paper", "--diagonals", "error"]) == 2
    assert "--diagonals is an option of --method refine" in capsys.readouterr().err


def test_greedy_mesh_refuses_an_unknown_choice():
    from rangemesh.refine import greedy_mesh

    depth = np.ones((8, 8))
    with pytest.raises(ValueError, match="diagonals must be"):
        greedy_mesh(depth, depth > 0, rangemesh.Orthographic(), vertices=10, diagonals="Error")
