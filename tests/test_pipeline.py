"""SPEC section 5, P1-P7, on synthetic scenes and on the real images of ../shared/data."""

import math
import os
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

import rangemesh
from rangemesh import (
    MeshParams,
    Orthographic,
    Pinhole,
    evaluate,
    render_depth,
    scenes,
    triangulate,
)
from rangemesh.cli import main
from rangemesh.pipeline import call_options
from rangemesh.prepare import to_depth_and_mask

from .helpers import assert_valid_mesh, canonical_faces, chair_depths, one_error_line
from .images import REAL_IMAGES, load_or_crop

FLIPS = ["disparity", "error", None]


def same_mesh(a, b):
    assert np.array_equal(a.pixels, b.pixels)
    assert np.array_equal(a.faces, b.faces)


# ---------------------------------------------------------------- P1, P2, P6


@pytest.mark.parametrize("flips", FLIPS)
def test_p1_background_marker_invariance(flips):
    sc = scenes.dome((90, 110))
    base = np.where(np.isnan(sc.depth), 0.0, sc.depth)
    as_zero = triangulate(base.astype(np.uint16), background=0, flips=flips, method="paper")
    as_max = triangulate(np.where(base == 0, 65535, base).astype(np.uint16), background=65535,
                         flips=flips, method="paper")
    as_nan = triangulate(np.where(base == 0, np.nan, base.astype(np.uint16)), flips=flips, method="paper")
    for other in (as_max, as_nan):
        same_mesh(as_zero, other)
        np.testing.assert_array_equal(as_zero.vertices, other.vertices)
    assert_valid_mesh(as_zero, ~np.isnan(sc.depth))


@pytest.mark.parametrize("flips", FLIPS)
@pytest.mark.parametrize("s", [4.0, 0.125, 1000.0])
def test_p2_unit_invariance(flips, s):
    sc = scenes.pyramid((80, 100))
    a = triangulate(sc.depth, flips=flips, camera=Orthographic(1, 1, 1), method="paper")
    b = triangulate(sc.depth * s, flips=flips, camera=Orthographic(1, 1, 1 / s), method="paper")
    same_mesh(a, b)
    np.testing.assert_allclose(a.vertices, b.vertices, rtol=1e-12)


@given(st.integers(0, 2**31), st.integers(-3, 3))
def test_p2_unit_invariance_random(seed, k):
    rng = np.random.default_rng(seed)
    d = np.cumsum(rng.normal(size=(30, 40)), axis=1) + 50
    s = 2.0**k * 10  # not only powers of two
    a = triangulate(d, tiles=2, samples=6, method="paper")
    b = triangulate(d * s, tiles=2, samples=6, camera=(1, 1, 1 / s), method="paper")
    same_mesh(a, b)


def test_p6_determinism():
    sc = scenes.box((100, 120), noise=0.5)
    runs = [triangulate(sc.depth, tiles=4, samples=10, method="paper") for _ in range(3)]
    for r in runs[1:]:
        same_mesh(runs[0], r)
        assert runs[0].vertices.tobytes() == r.vertices.tobytes()
        assert runs[0].stats.flipped_edges == r.stats.flipped_edges


# ---------------------------------------------------------------- P3, P4, P5


@given(st.integers(0, 2**31), st.integers(1, 4), st.integers(1, 4), st.integers(2, 8),
       st.integers(2, 8), st.sampled_from(FLIPS), st.sampled_from(["adaptive", "uniform"]))
def test_p3_p4_random_images(seed, tv, th, rs, zs, flips, sampling):
    rng = np.random.default_rng(seed)
    h, w = int(rng.integers(tv + 1, 40)), int(rng.integers(th + 1, 40))
    d = rng.uniform(0, 100, (h, w))
    d[rng.random((h, w)) < rng.uniform(0, 0.5)] = np.nan  # holes and speckle
    p = MeshParams(tiles=(tv, th), samples=(rs, zs), flips=flips, sampling=sampling)
    m = triangulate(d, method="paper", **call_options(p, "paper"))
    gr, gc = p.grid_shape
    assert m.stats.grid_shape == (gr, gc)
    assert m.stats.vertices <= m.stats.sampled_points <= gr * gc
    _, valid = rangemesh.fill_gaps(*to_depth_and_mask(d))
    assert_valid_mesh(m, valid)


@pytest.mark.parametrize("name", sorted(scenes.SCENES))
@pytest.mark.parametrize("flips", FLIPS)
def test_p4_scenes(name, flips):
    sc = scenes.make(name, (90, 120), noise=0.2)
    m = triangulate(sc.depth, flips=flips, method="paper")
    _, valid = to_depth_and_mask(sc.depth)
    assert_valid_mesh(m, valid)
    assert m.stats.vertices <= 37 * 37


def test_plane_is_exact_and_needs_no_flip():
    sc = scenes.plane()
    m = triangulate(sc.depth, method="paper")
    e = evaluate(m, sc.depth)
    assert e.relative_error < 1e-9 and e.max_error < 1e-9 and e.uncovered == 0
    assert m.stats.flipped_edges == 0


@pytest.mark.parametrize("flips", ["disparity", "error"])
@pytest.mark.parametrize("samples", [6, 8, 10])
def test_p5_flips_lower_crease_band_error(flips, samples):
    sc = scenes.crease((100, 130))
    before = triangulate(sc.depth, samples=samples, flips=None, method="paper")
    after = triangulate(sc.depth, samples=samples, flips=flips, method="paper")
    assert after.stats.flipped_edges > 0
    assert_valid_mesh(after)
    eb = evaluate(before, sc.depth, discontinuities=sc.discontinuities).edge_band_error
    ea = evaluate(after, sc.depth, discontinuities=sc.discontinuities).edge_band_error
    assert ea < eb


@pytest.mark.parametrize("flips", ["disparity", None])
def test_box_no_triangle_spans_the_jump(flips):
    # A box 60 units tall on a tilted plane. Every covered pixel more than 2 px from the
    # jump is reproduced exactly: no triangle reaches across the jump into either level.
    sc = scenes.box((120, 160))
    m = triangulate(sc.depth, samples=10, flips=flips, method="paper")
    assert_valid_mesh(m)
    pred, _ = render_depth(m)
    far = ~ndimage.binary_dilation(sc.discontinuities, iterations=2)
    assert np.isfinite(pred).all()
    assert np.abs(pred - sc.depth)[far].max() < 1e-9


# ---------------------------------------------------------------- P7 bad input


@pytest.mark.parametrize(
    "image, kwargs, exc, match",
    [
        (np.zeros((4, 4, 3)), {}, ValueError, "2-D"),
        (np.zeros(10), {}, ValueError, "2-D"),
        (np.zeros((0, 5)), {}, ValueError, "empty"),
        (np.array([["a"]]), {}, TypeError, "dtype"),
        (np.ones((4, 4), bool), {}, TypeError, "dtype"),
        (np.ones((1, 1)), {}, ValueError, "tiles"),
        (np.ones((20, 20)), {"tiles": (30, 2)}, ValueError, "tiles"),
        (np.ones((20, 20)), {"tiles": 0}, ValueError, "tiles"),
        (np.ones((20, 20)), {"samples": 0}, ValueError, "samples"),
        (np.ones((20, 20)), {"samples": (1, 5)}, ValueError, "samples"),
        (np.ones((20, 20)), {"sampling": "random"}, ValueError, "sampling"),
        (np.ones((20, 20)), {"flips": "yes"}, ValueError, "flips"),
        (np.ones((20, 20)), {"delta": -1}, ValueError, "delta"),
        (np.ones((20, 20)), {"curvature_floor": 0.5}, ValueError, "curvature_floor"),
        (np.ones((20, 20)), {"colour": 1}, TypeError, "colour"),
        (np.ones((20, 20)), {"background": "zero"}, TypeError, "background"),
        (np.ones((20, 20)), {"camera": "pinhole"}, TypeError, "camera"),
    ],
)
def test_p7_bad_input(image, kwargs, exc, match):
    with pytest.raises(exc, match=match):
        triangulate(image, method="paper", **kwargs)


@pytest.mark.parametrize(
    "image",
    [np.zeros((20, 20)), np.full((20, 20), np.nan), np.full((20, 20), np.inf)],
)
def test_p7_nothing_to_mesh_gives_empty_mesh(image):
    m = triangulate(image, background=0, method="paper")
    assert m.is_empty and "background" in m.stats.reason
    assert m.vertices.shape == (0, 3) and m.faces.shape == (0, 3)


def test_p7_single_valid_row_is_collinear():
    d = np.full((20, 20), np.nan)
    d[7, :] = 5.0
    m = triangulate(d, fill_gaps=False, method="paper")
    assert m.is_empty and m.stats.reason


def test_pinhole_camera_mesh_is_valid_and_metric():
    sc = scenes.box((120, 160))
    cam = Pinhole(100.0, 100.0, 80.0, 60.0, 0.01)
    m = triangulate(sc.depth, camera=cam, method="paper")
    assert_valid_mesh(m)
    z = sc.depth[m.pixels[:, 0], m.pixels[:, 1]] * 0.01
    np.testing.assert_allclose(m.vertices[:, 2], z)
    np.testing.assert_allclose(m.vertices[:, 0], (m.pixels[:, 1] - 80.0) * z / 100.0)
    e = evaluate(m, sc.depth)
    assert e.relative_error < 2.0


def test_stage_functions_compose_to_triangulate():
    sc = scenes.pyramid((90, 100))
    p = MeshParams(samples=8)
    depth, valid = rangemesh.fill_gaps(*to_depth_and_mask(sc.depth))
    grid = rangemesh.sample_grid(depth, valid, p)
    tri = rangemesh.delaunay_mesh(grid, depth, valid)
    flipped = rangemesh.flip_edges(tri, depth, valid, p)
    whole = triangulate(sc.depth, method="paper", **call_options(p, "paper"))
    same_mesh(flipped, whole)
    no_flips = triangulate(sc.depth, method="paper", **{**call_options(p, "paper"), "flips": None})
    assert np.array_equal(canonical_faces(tri), canonical_faces(no_flips))


# ---------------------------------------------------------------- real images


@pytest.mark.parametrize("rel, background", REAL_IMAGES, ids=[r for r, _ in REAL_IMAGES])
def test_real_images(data_or_crops, rel, background):
    img = load_or_crop(data_or_crops, rel)
    _, valid0 = to_depth_and_mask(img, background)
    for flips in ("disparity", "error"):
        m = triangulate(img, background=background, tiles=4, samples=10, flips=flips, method="paper")
        _, valid = rangemesh.fill_gaps(*to_depth_and_mask(img, background))
        assert_valid_mesh(m, valid, check_overlap=flips == "disparity")
        e = evaluate(m, img, background=background)
        assert e.valid_pixels == valid0.sum()
        assert 0 <= e.relative_error < 15, e  # sane: a coarse mesh, not garbage
        assert e.uncovered < 50
        assert m.stats.vertices > 100


@pytest.mark.parametrize("value, error", [(True, TypeError), (2, ValueError), (2.5, ValueError),
                                          ("10", TypeError), (np.int64(2), ValueError)])
def test_a_bad_vertex_count_is_refused_naming_it(value, error):
    # (the plain-int fast path of _targets_given must leave bools and small counts to the checks)
    with pytest.raises(error, match="vertices"):
        triangulate(np.ones((8, 8)), vertices=value)


@pytest.mark.parametrize("value, error", [(0.0, ValueError), (-1.0, ValueError),
                                          (float("nan"), ValueError), (float("inf"), ValueError),
                                          (True, TypeError), ("1", TypeError)])
def test_a_bad_error_bound_is_refused_naming_it(value, error):
    with pytest.raises(error, match="max_error"):
        triangulate(np.ones((8, 8)), max_error=value)


@pytest.mark.parametrize("value", [10, np.int64(10), 10.0])
def test_a_vertex_count_of_any_integer_kind_is_taken(value):
    assert triangulate(np.add.outer(np.arange(8.0), np.arange(8.0) ** 2), vertices=value).stats.vertices == 10


# ---------------------------------------------------------------- from the hostile-input reports


# the memory rule (the 2026-11-21 hostile-input report)
def test_an_image_larger_than_free_memory_is_refused_before_work(monkeypatch, chair, chair_file,
                                                                  capsys):
    import rangemesh.memory as pl

    # 96 x 96 pixels x 20 bytes = 184,320 bytes: refuse with less available, mesh with more
    monkeypatch.setattr(pl, "available_memory", lambda: 184_319)
    with pytest.raises(MemoryError, match="96x96 image needs"):
        rangemesh.triangulate(chair, background=0, method="paper")
    one_error_line(capsys, main(["mesh", str(chair_file)]), match="memory")
    monkeypatch.setattr(pl, "available_memory", lambda: 184_320)
    assert not rangemesh.triangulate(chair, background=0, method="paper").is_empty


# the memory rule (the 2026-11-21 hostile-input report)
def test_free_memory_is_read_at_most_once_a_second(monkeypatch):
    import builtins
    import time

    import rangemesh.memory as pl

    if not os.path.exists("/proc/meminfo"):
        pytest.skip("no /proc/meminfo on this system")
    reads = []
    real_open = builtins.open

    def counting_open(path, *args, **kwargs):
        if path == "/proc/meminfo":
            reads.append(path)
        return real_open(path, *args, **kwargs)

    now = [1000.0]
    monkeypatch.setattr(builtins, "open", counting_open)
    monkeypatch.setattr(time, "monotonic", lambda: now[0])
    monkeypatch.setattr(pl, "_meminfo", [-math.inf, None])
    first = pl.available_memory()
    assert first is not None and first > 0
    now[0] += 0.5  # within MEMINFO_SECONDS: the value read before
    assert pl.available_memory() == first and len(reads) == 1
    now[0] += 0.6  # 1.1 s after the read: read again
    pl.available_memory()
    assert len(reads) == 2


# E19 of the 2026-11-25 hostile-input report
def test_refine_checks_the_memory_of_its_vertices_before_work(monkeypatch, capsys):
    import rangemesh.memory as pl

    chair = chair_depths()
    # 96 x 96 pixels x 32 bytes + 500 vertices x 700 bytes = 294,912 + 350,000 = 644,912
    monkeypatch.setattr(pl, "available_memory", lambda: 644_911)
    with pytest.raises(MemoryError, match="96x96 image needs about .* with 500 vertices"):
        rangemesh.triangulate(chair, background=0, vertices=500)
    monkeypatch.setattr(pl, "available_memory", lambda: 644_912)
    assert len(rangemesh.triangulate(chair, background=0, vertices=500).vertices) == 500
    # the paper's method keeps its 20 bytes a pixel: 184,320 bytes
    monkeypatch.setattr(pl, "available_memory", lambda: 184_320)
    assert not rangemesh.triangulate(chair, background=0, method="paper").is_empty


# E19 of the 2026-11-25 hostile-input report
def test_an_error_bound_stops_where_memory_runs_out_and_says_so(monkeypatch, tmp_path, capsys):
    import rangemesh.memory as pl

    chair = chair_depths()
    # room for 200 vertices beyond the 294,912 bytes of the pixels
    monkeypatch.setattr(pl, "available_memory", lambda: 294_912 + 200 * 700)
    with pytest.raises(MemoryError, match="needs more than 200 vertices"):
        rangemesh.triangulate(chair, background=0, max_error=0.1)  # 2407 vertices with room
    mesh = rangemesh.triangulate(chair, background=0, max_error=5.0)  # 68 vertices: they fit
    assert mesh.stats.target.met and len(mesh.vertices) < 200
    path = tmp_path / "chair.npy"
    np.save(path, chair.astype(np.uint8))
    assert main(["mesh", str(path), "--max-error", "0.1", "-o", str(tmp_path / "c.ply")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "needs more than 200 vertices" in err[0]


def test_run_leaves_a_methods_stats_as_it_made_them(monkeypatch):
    # issue 43: run added stage one's weights and the seam's time into the paper's Stats.seconds
    # in place (a frozen Stats); the method's mesh must keep the figures it was made with
    from rangemesh import pipeline

    made = []
    real = pipeline.mesh_grid

    def spy(*args, **kwargs):
        mesh = real(*args, **kwargs)
        made.append((mesh, dict(mesh.stats.seconds)))
        return mesh

    monkeypatch.setattr(pipeline, "mesh_grid", spy)
    r, c = np.mgrid[0:24, 0:32]
    out = triangulate(100.0 + r + 0.5 * c, method="paper", tiles=2, samples=5, wrap=True)
    ((mesh, seconds),) = made
    assert mesh.stats.seconds == seconds and "seam" not in mesh.stats.seconds
    assert "seam" in out.stats.seconds and out.stats.seconds["sampling"] >= seconds["sampling"]


def test_a_refine_call_reads_the_valid_depth_range_by_name(monkeypatch):
    # issue 44: unpacking the DepthRange (lo, hi, count = ...) asks its binding for a fourth item,
    # an IndexError thrown in C++: 15K instructions of a 16 x 16 call's 390K
    from rangemesh import pipeline

    real = pipeline.valid_range

    class ByNameOnly:
        def __init__(self, span):
            self.lo, self.hi, self.count = span.lo, span.hi, span.count

    monkeypatch.setattr(pipeline, "valid_range", lambda depth, valid: ByNameOnly(real(depth, valid)))
    r, c = np.mgrid[0:16, 0:16]
    depth = 100.0 + r + 0.5 * c + ((r - 8) ** 2 + (c - 8) ** 2) * 0.1
    # (with a camera: a small image without one is a single native call, `small_call`)
    assert triangulate(depth, vertices=10, camera=Orthographic()).stats.vertices == 10
    assert triangulate(depth, camera=Orthographic()).stats.target.met  # the default target


# ---------------------------------------------------------------- a small image's one native call


def _general(monkeypatch, image, **kwargs):
    """`triangulate(image, **kwargs)` by the general path (`run`), warnings recorded."""
    import warnings

    from rangemesh import pipeline

    with monkeypatch.context() as mp, warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mp.setattr(pipeline, "small_call", lambda *args: None)
        mesh = triangulate(image, **kwargs)
    return mesh, [(w.category, str(w.message)) for w in caught]


def _same_call(a, b):
    """Two meshes of one call: arrays and stats bit for bit, timings aside."""
    for name in ("vertices", "faces", "pixels"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and x.shape == y.shape and np.array_equal(x, y), name
    assert a.camera == b.camera and a.image_shape == b.image_shape
    assert a.attributes == b.attributes and a.colors is None and b.colors is None
    sa, sb = dict(a.stats.__dict__), dict(b.stats.__dict__)
    assert sa.pop("seconds").keys() == sb.pop("seconds").keys()
    assert sa == sb and list(sa) == list(sb)


@st.composite
def _small_images(draw):
    """Small images of every dtype the one call takes, with holes, zeros, negative and huge depths."""
    h, w = draw(st.integers(2, 44)), draw(st.integers(2, 44))
    rng = np.random.default_rng(draw(st.integers(0, 2**31)))
    r, c = np.mgrid[0:h, 0:w]
    kind = draw(st.sampled_from(["float64", "float32", "uint16", "int16", "uint8", "int64"]))
    base = draw(st.sampled_from([0.0, 5.0, 100.0, 1e30]))  # (0: zeros and negative depths)
    image = base + r * draw(st.floats(-3, 3)) + c * draw(st.floats(-3, 3)) \
        + rng.normal(0, draw(st.sampled_from([0.0, 0.5, 4.0])), (h, w))
    if kind.startswith("float"):
        image[rng.random((h, w)) < draw(st.sampled_from([0.0, 0.1, 0.6, 1.0]))] = np.nan
    else:
        info = np.iinfo(kind)
        image = np.clip(np.round(image), info.min, min(info.max, 2**40))
        image[rng.random((h, w)) < draw(st.sampled_from([0.0, 0.1, 0.6]))] = 0
    return image.astype(kind)


@settings(max_examples=150)
@given(_small_images(), st.sampled_from([None, 3, 10, 40, 2000]),
       st.sampled_from(["auto", None, 0, 7.5]))
def test_a_small_call_is_the_general_call_bit_for_bit(image, vertices, background):
    # issue 44 (fixed cost): a small image with no option and no camera is one native call,
    # `rangemesh._core.refine_image`; its mesh, stats, target and warnings are the general path's
    import warnings

    from rangemesh import cleanup

    kwargs = {"background": background} if vertices is None else \
        {"background": background, "vertices": vertices}
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(cleanup, "_warned", [])  # (the zero marker's warning is said once a process)
        try:
            want, want_warnings = _general(mp, image, **kwargs)
        except ValueError as e:  # (refused alike)
            with pytest.raises(ValueError, match=re.escape(str(e))):
                triangulate(image, **kwargs)
            return
        mp.setattr(cleanup, "_warned", [])
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            got = triangulate(image, **kwargs)
    assert [(w.category, str(w.message)) for w in caught] == want_warnings
    _same_call(got, want)


@settings(max_examples=80)
@given(_small_images(), st.sampled_from([None, 3, 10, 40]))
def test_a_refine_meshs_edge_count_is_its_faces_distinct_edges(image, vertices):
    # the native call counts the edges from the insertion's half-edges when it keeps every
    # triangle ((3 F + hull half-edges) / 2); here numpy counts the faces' distinct pairs
    import warnings

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # (a zero marker's warning)
            mesh = triangulate(image, vertices=vertices)
    except ValueError:  # (an image the checks refuse)
        return
    f = mesh.faces.astype(np.int64)
    pairs = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    assert mesh.stats.edges == len(np.unique(pairs, axis=0))


def test_a_small_call_is_one_native_call(monkeypatch):
    # issue 44's fixed cost: "the whole refine call, its target search included, is one native
    # function; Python checks the arguments and wraps the result"
    from rangemesh import _core

    calls = []
    for name in ("refine_image", "refine_mesh", "mask_image", "valid_range", "fill_gaps_inplace"):
        real = getattr(_core, name)
        monkeypatch.setattr(_core, name, lambda *a, _real=real, _name=name, **k: (
            calls.append(_name), _real(*a, **k))[1])
    r, c = np.mgrid[0:16, 0:16]
    depth = 100.0 + r + 0.5 * c + ((r - 8) ** 2 + (c - 8) ** 2) * 0.1
    assert triangulate(depth, vertices=10).stats.vertices == 10
    assert triangulate(depth).stats.target.default  # the default target
    assert calls == ["refine_image", "refine_image"]


@pytest.mark.parametrize("w", range(2, 10))
def test_a_small_float64_calls_mask_is_the_general_masks_at_every_width(monkeypatch, w):
    # the small call masks float64 images four pixels at a time (SSE2) and the rest one by one:
    # NaN, +-inf and the marker (-0.0 too) missing wherever they fall in a group of four, the
    # largest float and the marker's neighbour kept; the mesh and stats those of the general
    # path, and the call declined exactly where numpy's mask and range say it must be
    from rangemesh import _core
    from rangemesh.params import DEFAULT_TARGET
    from rangemesh.refine.insertion import DEPTH_BAND

    _BAND = 2.0**DEPTH_BAND  # (beyond it the general path scales the depths)

    made = []
    real = _core.refine_image

    def spy(*args):
        out = real(*args)
        made.append(out is not None)
        return out

    monkeypatch.setattr(_core, "refine_image", spy)
    rng = np.random.default_rng(w)
    for h in (2, 3, 5):
        r, c = np.mgrid[0:h, 0:w]
        image = 100.0 + r + 0.5 * c + rng.normal(0, 0.3, (h, w))
        flat = image.reshape(-1)
        picks = rng.permutation(flat.size)[:max(1, flat.size // 4)]
        flat[picks] = rng.choice([np.nan, np.inf, -np.inf, 7.5, np.nextafter(7.5, 8)], picks.size)
        big = np.full((h, w), 100.0)
        big.reshape(-1)[picks[:1]] = np.finfo(np.float64).max  # (beyond the band: declined)
        for image, background, vertices in [(image, b, v) for b in ("auto", 7.5, None, -0.0)
                                            for v in (3, None)] + [(big, None, 3)]:
            kwargs = {"background": background, "vertices": vertices}
            want, _ = _general(monkeypatch, image, **kwargs)
            made.clear()
            _same_call(triangulate(image, **kwargs), want)
            depths = image[np.isfinite(image) & ((background in ("auto", None)) | (image != background))]
            top = np.abs(depths).max(initial=0.0)
            meshed = len(depths) >= (vertices or DEFAULT_TARGET.min_vertices) and len(want.faces) > 0 \
                and 1 / _BAND <= top <= _BAND and depths.min() > 0
            assert made == [meshed]


@pytest.mark.parametrize("name, value", [("RIDGE", 10.0), ("OUTLIER_MADS", 0.5), ("CG_RTOL", 0.3)])
def test_a_small_call_reads_the_fits_values_at_each_call(monkeypatch, name, value):
    # the small call's request is made once per count and values of refine.heights (the
    # benchmarks set them): a changed value meshes as the general path does with it
    from rangemesh.refine import heights

    r, c = np.mgrid[0:16, 0:16]
    depth = 100.0 + r + 0.5 * c + ((r - 8) ** 2 + (c - 8) ** 2) * 0.1 + np.sin(r * c)
    before = triangulate(depth, vertices=10)
    monkeypatch.setattr(heights, name, value)
    got, (want, _) = triangulate(depth, vertices=10), _general(monkeypatch, depth, vertices=10)
    _same_call(got, want)
    assert not np.array_equal(got.vertices, before.vertices)


def test_the_small_calls_native_function_refuses_a_count_its_request_does_not_hold():
    # refine_image makes the Mesh and its Target too: a count other than the request's (or not
    # an int) would be recorded as asked and missed, and a `made` of other parts would be read
    # as one: refused, naming the argument
    import time

    from rangemesh import _core
    from rangemesh.refine import small

    r, c = np.mgrid[0:16, 0:16]
    depth = 100.0 + r + 0.5 * c
    req = _core.RefineRequest()  # (the image rectangle first, heights and diagonals as inserted)
    req.vertices, req.fit, req.flip = 10, False, False
    call = lambda vertices, made=small._MADE: _core.refine_image(  # noqa: E731
        depth, vertices, (0.0, math.nan, True), req, None, time.perf_counter(), time.perf_counter,
        made)
    mesh = call(10)
    assert len(mesh.pixels) == 10 and mesh.stats.target.met and mesh.stats.target.requested == 10
    assert mesh.stats.heights == "pixel" and "fit" not in mesh.stats.seconds
    for vertices in (11, 9, 10.0, True, 2**70, "10"):
        with pytest.raises(ValueError, match="refine_image: vertices"):
            call(vertices)
    for made in (small._MADE[:5], list(small._MADE), small._MADE[:2] + ([],) + small._MADE[3:],
                 small._MADE[:5] + (None,)):
        with pytest.raises(ValueError, match="refine_image: made"):
            call(10, made)
    # the markers and the fill, one tuple of two floats and a bool (not read as something else)
    for masking in ((0.0, math.nan), [0.0, math.nan, True], (0, math.nan, True), (0.0, math.nan, 1),
                    (0.0, math.nan, True, True)):
        with pytest.raises(ValueError, match="refine_image: masking"):
            _core.refine_image(depth, 10, masking, req, None, time.perf_counter(), time.perf_counter,
                               small._MADE)


def test_the_small_calls_native_function_refuses_made_classes_it_cannot_make_before_meshing():
    # (review F1) made[0] and made[1] are the classes new_with_dict makes the Stats and the Mesh
    # of: one it cannot make is refused as the other parts of `made` are, naming refine_image's
    # argument, before the image is meshed (the clock, read once meshed, never read)
    import time

    from rangemesh import _core
    from rangemesh.refine import small

    class Slotted:
        __slots__ = ("x",)

    r, c = np.mgrid[0:16, 0:16]
    depth = 100.0 + r + 0.5 * c
    req = _core.RefineRequest()
    req.vertices, req.fit, req.flip = 10, False, False
    reads = []

    def now():
        reads.append(1)
        return time.perf_counter()

    for k in (0, 1):
        for cls in (1, None, dict, Slotted):
            made = small._MADE[:k] + (cls,) + small._MADE[k + 1:]
            with pytest.raises(ValueError, match="refine_image: made"):
                _core.refine_image(depth, 10, (0.0, math.nan, True), req, None,
                                   time.perf_counter(), now, made)
    assert reads == []


def test_new_with_dict_makes_what_object_new_and_a_set_dict_make():
    # the small call's Stats and Mesh: ``object.__new__(cls)`` given `fields` as its __dict__ by
    # ``object.__setattr__``, neither __new__ nor __init__ of the class run
    import abc
    import collections
    import dataclasses

    from rangemesh import _core

    class Plain:
        def __init__(self):
            raise AssertionError("__init__ called")

    fields = {"a": 1}
    obj = _core.new_with_dict(Plain, fields)
    assert type(obj) is Plain and obj.__dict__ is fields and obj.a == 1
    obj.b = 2
    assert fields == {"a": 1, "b": 2}

    @dataclasses.dataclass(frozen=True)
    class Frozen:
        x: int
        y: list

    made = _core.new_with_dict(Frozen, {"x": 3, "y": [4]})
    assert made == Frozen(3, [4]) and repr(made).endswith("Frozen(x=3, y=[4])")
    with pytest.raises(dataclasses.FrozenInstanceError):
        made.x = 5

    class Slotted:
        __slots__ = ("a",)

    class OwnNew:
        def __new__(cls):
            return object.__new__(cls)

    class Abstract(abc.ABC):
        @abc.abstractmethod
        def f(self): ...

    class Sub(dict):
        pass

    for cls, value in ((Slotted, {}), (OwnNew, {}), (Abstract, {}), (int, {}), (Plain, [("a", 1)]),
                       (Plain, Sub(a=1)), (Plain, collections.OrderedDict(a=1)), ("Plain", {})):
        with pytest.raises(ValueError, match="new_with_dict"):
            _core.new_with_dict(cls, value)


@pytest.mark.parametrize("name", [o.name for o in rangemesh.params.OPTION_TABLE])
def test_a_call_giving_any_option_is_checked_as_before(name):
    # the small call takes only calls that give no option: each option given, even a bad one,
    # goes to the general path, which names it
    r, c = np.mgrid[0:16, 0:16]
    with pytest.raises((TypeError, ValueError), match=name):
        triangulate(100.0 + r + c, vertices=10, **{name: object()})


def test_a_small_calls_request_does_not_depend_on_its_valid_pixels():
    # what `rangemesh.refine.small` relies on to make the request before the image is read
    from rangemesh import _core, memory, resolve, small_call
    from rangemesh.params import DEFAULT_TARGET, default_vertex_cap
    from rangemesh.refine import strips
    from rangemesh.refine.small import SMALL_PIXELS

    assert 2 * SMALL_PIXELS <= _core.FIT_SPLIT_MIN_FACES  # the fit's pass on one thread
    assert SMALL_PIXELS <= strips.STRIP_MIN_PIXELS  # one strip
    assert default_vertex_cap(SMALL_PIXELS - 1) == DEFAULT_TARGET.min_vertices
    # the options' defaults it meshes with (walls kept, jump 0.05, no clean-up, no seam)
    base = resolve.defaults()
    assert (base.walls, base.jump, base.effort, base.wrap, base.max_edge, base.depth_limits,
            base.min_region) == (True, 0.05, "fast", None, None, None, None)
    # with the memory it checks free, check_memory passes and an error bound's ceiling lies
    # beyond the default target's cap
    free = small_call.SMALL_NEED
    assert free >= memory.memory_need((SMALL_PIXELS, 1), "refine", SMALL_PIXELS)
    assert (free - SMALL_PIXELS * memory.REFINE_BYTES_PER_PIXEL) // memory.REFINE_BYTES_PER_VERTEX \
        >= DEFAULT_TARGET.min_vertices
