"""Refine's deviation targets (max_deviation=, mean_deviation=) and max_edge=, checked independently.

Each mesh is rendered here with NumPy (barycentric interpolation over every
triangle, written in this file, not the library's rasteriser) and compared
with the image along each pixel's ray: z-depth in metres before a pinhole
(its inverse interpolated: a flat triangle's exact intersection), range in
metres before a spherical camera, depth units before an orthographic one.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import rangemesh
from rangemesh import Orthographic, Pinhole, Rays, Spherical, evaluate, triangulate

from .helpers import assert_valid_mesh

# pixels by faces at most per vectorised block of the reference render
_BLOCK = 2_000_000


def reference_deviation(mesh, depth, valid):
    """Per-pixel deviation (metres, or depth units) of the mesh, NaN where no face covers a valid pixel.

    Every face is rasterised over its bounding box by barycentric
    coordinates of the pixel centres (closed triangles); a pixel covered by
    several faces (a shared edge) keeps its largest deviation.
    """
    cam = mesh.camera
    v = np.asarray(mesh.vertices, np.float64)
    if isinstance(cam, Orthographic):
        val, measured, inverse = v[:, 2] / cam.kz, depth.astype(np.float64), False
    elif isinstance(cam, Pinhole):
        val, measured, inverse = 1.0 / v[:, 2], depth * cam.depth_scale, True
    elif getattr(cam, "z_depth", False):  # depths along the axis, as a pinhole's
        val, measured, inverse = 1.0 / v[:, 2], depth * cam.range_scale, True
    else:
        val, measured, inverse = np.linalg.norm(v, axis=1), depth * cam.range_scale, False
    pr = mesh.pixels[:, 0].astype(np.float64)
    pc = mesh.pixels[:, 1].astype(np.float64)
    f = mesh.faces
    ar, br, cr = pr[f[:, 0]], pr[f[:, 1]], pr[f[:, 2]]
    ac, bc, cc = pc[f[:, 0]], pc[f[:, 1]], pc[f[:, 2]]
    area = (br - ar) * (cc - ac) - (bc - ac) * (cr - ar)
    r0 = np.minimum(np.minimum(ar, br), cr).astype(int)
    c0 = np.minimum(np.minimum(ac, bc), cc).astype(int)
    hh = np.maximum(np.maximum(ar, br), cr).astype(int) - r0 + 1
    ww = np.maximum(np.maximum(ac, bc), cc).astype(int) - c0 + 1
    out = np.full(depth.shape, -np.inf)
    # a wrap-around seam face (clockwise, as wide as the image) covers no pixel centre
    seam = (area < 0) & (ww - 1 > 0.5 * depth.shape[1])
    order = np.argsort(hh * ww, kind="stable")
    order = order[(area[order] != 0) & ~seam[order]]
    start = 0
    while start < len(order):
        stop = start + 1
        while stop < len(order) and (stop + 1 - start) * hh[order[stop]] * ww[order[stop]] <= _BLOCK:
            stop += 1
        idx = order[start:stop]
        start = stop
        H, W = hh[idx].max(), ww[idx].max()
        rr = (r0[idx, None, None] + np.arange(H)[None, :, None]) * np.ones((1, 1, W))
        cc_ = (c0[idx, None, None] + np.arange(W)[None, None, :]) * np.ones((1, H, 1))
        A = area[idx, None, None]
        wa = ((br[idx, None, None] - rr) * (cc[idx, None, None] - cc_)
              - (bc[idx, None, None] - cc_) * (cr[idx, None, None] - rr)) / A
        wb = ((cr[idx, None, None] - rr) * (ac[idx, None, None] - cc_)
              - (cc[idx, None, None] - cc_) * (ar[idx, None, None] - rr)) / A
        wc = 1.0 - wa - wb
        inside = (wa >= -1e-12) & (wb >= -1e-12) & (wc >= -1e-12)
        inside &= (rr < depth.shape[0]) & (cc_ < depth.shape[1])
        k, i, j = np.nonzero(inside)
        fk = idx[k]
        value = (wa[k, i, j] * val[f[fk, 0]] + wb[k, i, j] * val[f[fk, 1]]
                 + wc[k, i, j] * val[f[fk, 2]])
        pred = 1.0 / value if inverse else value
        r, c = rr[k, i, j].astype(int), cc_[k, i, j].astype(int)
        dev = np.abs(pred - measured[r, c])
        np.maximum.at(out, (r, c), dev)
    out[~valid] = np.nan
    out[valid & (out == -np.inf)] = np.nan
    return out


def assert_meets(mesh, depth, valid, bound, *, mean=False, scale=1.0):
    """The mesh meets `bound` by `reference_deviation`, every valid pixel covered."""
    dev = reference_deviation(mesh, depth, valid)
    assert not np.isnan(dev[valid]).any(), "a valid pixel is not covered"
    # (rounding of the two renders: a few ulps of the depths)
    tol = 1e-9 * max(bound, 1e-300) + 1e-12 * float(np.abs(depth[valid]).max()) * scale
    got = dev[valid].mean() if mean else dev[valid].max()
    assert got <= bound + tol, (got, bound)
    return got


def smooth_image(seed, h, w):
    rng = np.random.default_rng(seed)
    r, c = np.mgrid[0:h, 0:w]
    z = 5.0 + rng.uniform(0.1, 1.0) * np.sin(r / rng.uniform(2, 9) + rng.uniform(0, 6))
    return z + rng.uniform(0.1, 1.0) * np.cos(c / rng.uniform(2, 9)) + 0.01 * rng.standard_normal((h, w))


def jump_image(seed, h, w):
    rng = np.random.default_rng(seed)
    r, c = np.mgrid[0:h, 0:w]
    z = 4.0 + 0.05 * r + 0.02 * c
    z = np.where(c > rng.integers(1, w - 1), z + rng.uniform(0.5, 2.0), z)
    return np.where(r > rng.integers(1, h - 1), z - rng.uniform(0.3, 1.0), z)


def camera_for(kind, h, w):
    if kind == "orthographic":
        return Orthographic(1.0, 1.0, 1.0)
    if kind == "pinhole":
        return Pinhole(60.0, 60.0, (w - 1) / 2, (h - 1) / 2, depth_scale=0.5)
    if kind.startswith("rays"):  # a lens's rays, bent off a pinhole's by a radial term
        r, c = np.mgrid[0:h, 0:w]
        x, y = (c - (w - 1) / 2) / 50.0, (r - (h - 1) / 2) / 50.0
        bend = 1.0 + 0.2 * (x * x + y * y)
        rays = np.stack([x * bend, y * bend, np.ones((h, w))], axis=2)
        return Rays(rays, range_scale=0.25, z_depth=kind == "rays_z")
    return Spherical(np.linspace(10.0, -10.0, h), np.linspace(0.0, 0.4 * w, w), range_scale=2.0)


def scale_of(cam):
    return 1.0 if isinstance(cam, Orthographic) else \
        cam.depth_scale if isinstance(cam, Pinhole) else cam.range_scale


@settings(max_examples=50)
@given(seed=st.integers(0, 2**31), h=st.integers(3, 24), w=st.integers(3, 24),
       share=st.floats(0.0, 0.3),
       kind=st.sampled_from(["orthographic", "pinhole", "spherical", "rays", "rays_z"]),
       jumps=st.booleans(), heights=st.sampled_from(["fit", "pixel"]))
def test_max_deviation_bounds_every_valid_pixel(seed, h, w, share, kind, jumps, heights):
    depth = (jump_image if jumps else smooth_image)(seed, h, w)
    cam = camera_for(kind, h, w)
    valid = np.ones(depth.shape, bool)
    d = share * float(depth.max() - depth.min()) * scale_of(cam)
    mesh = triangulate(depth, camera=cam, max_deviation=d, heights=heights)
    assert_valid_mesh(mesh)
    got = assert_meets(mesh, depth, valid, d, scale=scale_of(cam))
    t = mesh.stats.target
    assert (t.kind, t.requested, t.met, t.uncovered) == ("max_deviation", d, True, 0)
    assert abs(t.achieved - got) <= 1e-9 * max(d, 1.0)


@settings(max_examples=20)
@given(seed=st.integers(0, 2**31), h=st.integers(3, 24), w=st.integers(3, 24),
       share=st.floats(0.0, 0.2),
       kind=st.sampled_from(["orthographic", "pinhole", "spherical", "rays", "rays_z"]),
       jumps=st.booleans())
def test_mean_deviation_bounds_the_mean(seed, h, w, share, kind, jumps):
    depth = (jump_image if jumps else smooth_image)(seed, h, w)
    cam = camera_for(kind, h, w)
    d = share * float(depth.max() - depth.min()) * scale_of(cam)
    mesh = triangulate(depth, camera=cam, mean_deviation=d)
    got = assert_meets(mesh, depth, np.ones(depth.shape, bool), d, mean=True, scale=scale_of(cam))
    t = mesh.stats.target
    assert (t.kind, t.met) == ("mean_deviation", True)
    assert abs(t.achieved - got) <= 1e-9 * max(d, 1.0)


@settings(max_examples=20)
@given(a=st.integers(-50, 50), b=st.integers(-5, 5), c=st.integers(-5, 5),
       h=st.integers(2, 40), w=st.integers(2, 40), d=st.floats(1e-6, 100.0),
       heights=st.sampled_from(["fit", "pixel"]))
def test_a_plane_needs_only_its_corners(a, b, c, h, w, d, heights):
    # z = a + b r + c col is linear: the two triangles of the image rectangle give every
    # pixel exactly (by hand: barycentric interpolation of a linear function is exact)
    r, col = np.mgrid[0:h, 0:w]
    depth = 200.0 + a + b * r + c * col
    mesh = triangulate(depth.astype(np.float64), max_deviation=d, heights=heights)
    assert sorted(map(tuple, mesh.pixels.tolist())) == [(0, 0), (0, w - 1), (h - 1, 0),
                                                        (h - 1, w - 1)]
    assert_meets(mesh, depth, np.ones(depth.shape, bool), d)


@pytest.mark.parametrize("kind", ["orthographic", "spherical"])
@pytest.mark.parametrize("jumps", [False, True])
def test_max_deviation_zero_gives_every_pixel_exactly(kind, jumps):
    depth = (jump_image if jumps else smooth_image)(7, 9, 11)
    cam = camera_for(kind, 9, 11)
    mesh = triangulate(depth, camera=cam, max_deviation=0.0)
    dev = reference_deviation(mesh, depth, np.ones(depth.shape, bool))
    # exact up to the lift's rounding (range = |range * ray| with a unit ray)
    assert np.nanmax(dev) <= 4e-16 * float(depth.max()) * scale_of(cam)
    assert mesh.stats.target.met


@pytest.mark.parametrize("kind", ["orthographic", "pinhole", "spherical"])
def test_mean_deviation_zero_gives_every_pixel_exactly_with_fitted_heights(kind):
    # fitted depths miss 0 at their own pixels once every pixel is a vertex: copied ones go on
    depth = smooth_image(11, 7, 9)
    cam = camera_for(kind, 7, 9)
    mesh = triangulate(depth, camera=cam, mean_deviation=0.0)
    t = mesh.stats.target
    assert t.met and t.achieved == 0.0
    dev = reference_deviation(mesh, depth, np.ones(depth.shape, bool))
    assert np.nanmax(dev) <= 1e-15 * float(depth.max()) * scale_of(cam)


def test_max_deviation_with_holes_and_walls_dropped():
    depth = jump_image(3, 30, 40)
    depth[5:9, 10:14] = 0.0  # background (no return)
    cam = Pinhole(60.0, 60.0, 20.0, 15.0, depth_scale=0.25)
    mesh = triangulate(depth, camera=cam, max_deviation=0.01, walls=False)
    valid = depth > 0  # (a 4 x 4 hole: gap filling leaves it)
    dev = reference_deviation(mesh, depth, valid)
    covered = valid & ~np.isnan(dev)
    assert dev[covered].max() <= 0.01 * (1 + 1e-9)
    t = mesh.stats.target
    assert t.met and t.uncovered == int((valid & np.isnan(dev)).sum())
    assert t.walls_dropped is not None


@pytest.mark.parametrize("bad", [-0.1, float("nan"), float("inf"), -1e-300])
@pytest.mark.parametrize("name", ["max_deviation", "mean_deviation"])
def test_bad_deviation_bounds_are_refused(name, bad):
    with pytest.raises(ValueError, match=name):
        triangulate(smooth_image(1, 8, 8), **{name: bad})


def test_a_deviation_bound_that_is_no_number_is_a_type_error():
    with pytest.raises(TypeError, match="max_deviation"):
        triangulate(smooth_image(1, 8, 8), max_deviation="2cm")


@pytest.mark.parametrize("other", [{"vertices": 50}, {"max_error": 0.5}, {"mean_deviation": 0.1}])
def test_deviation_targets_exclude_the_others(other):
    with pytest.raises(ValueError, match=r"max_deviation and .* exclude each other"):
        triangulate(smooth_image(1, 8, 8), max_deviation=0.1, **other)


def test_mean_deviation_excludes_vertices():
    with pytest.raises(ValueError, match=r"mean_deviation and vertices exclude each other"):
        triangulate(smooth_image(1, 8, 8), mean_deviation=0.1, vertices=10)


def test_deviation_targets_are_refine_only():
    with pytest.raises(ValueError, match=r"max_deviation is a target of method='refine'"):
        triangulate(smooth_image(1, 8, 8), method="paper", max_deviation=0.1)


# --- max_edge with refine -----------------------------------------------------------------


def _longest_edge(mesh):
    p = mesh.pixels.astype(np.float64)
    f = mesh.faces
    return max(np.hypot(*(p[f[:, k]] - p[f[:, (k + 1) % 3]]).T).max() for k in range(3))


@settings(max_examples=20)
@given(seed=st.integers(0, 2**31), h=st.integers(4, 40), w=st.integers(4, 40),
       edge=st.floats(1.5, 20.0), target=st.sampled_from(["vertices", "default", "max_deviation"]))
def test_refine_max_edge_bounds_every_edge(seed, h, w, edge, target):
    depth = smooth_image(seed, h, w)
    kw = {"vertices": {"vertices": 5}, "default": {},
          "max_deviation": {"max_deviation": 0.3}}[target]
    mesh = triangulate(depth, max_edge=edge, **kw)
    assert_valid_mesh(mesh)
    assert _longest_edge(mesh) <= edge
    t = mesh.stats.target
    assert t.max_edge == edge and t.longest_edge == pytest.approx(_longest_edge(mesh))
    if target == "vertices" and mesh.stats.vertices > 5:
        assert not t.met and "max_edge" in t.note
    if target == "max_deviation":
        assert_meets(mesh, depth, np.ones(depth.shape, bool), 0.3)


def test_refine_max_edge_keeps_a_vertex_count_it_does_not_need():
    # a plane of 9 x 9 pixels meshed with its 4 corners has 11.3-pixel diagonals and 8-pixel
    # sides (by hand): max_edge=12 leaves it as it is
    r, c = np.mgrid[0:9, 0:9]
    mesh = triangulate(1.0 + r + 2.0 * c, vertices=4, max_edge=12.0)
    assert mesh.stats.vertices == 4 and mesh.stats.target.met


# --- evaluate ---------------------------------------------------------------------------


def test_evaluate_reports_the_deviation_in_metres():
    depth = jump_image(5, 20, 30)
    cam = Pinhole(40.0, 40.0, 15.0, 10.0, depth_scale=0.5)
    mesh = triangulate(depth, camera=cam, vertices=30)
    dev = reference_deviation(mesh, depth, np.ones(depth.shape, bool))
    report = evaluate(mesh, depth)
    assert report.max_deviation == pytest.approx(np.nanmax(dev), rel=1e-9)
    assert report.mean_deviation == pytest.approx(np.nanmean(dev), rel=1e-9)


# --- the shared LiDAR scan ----------------------------------------------------------------


def test_lidar_scan_meets_two_centimetres(shared_data):
    scan = shared_data / "lidar" / "rellis3d_os1-64_000000"
    rng = np.load(f"{scan}.range.npy").astype(np.float64)
    cam = Spherical.from_beams(f"{scan}.beams.json")
    mesh = triangulate(rng, camera=cam, max_deviation=0.02)
    valid = rng > 0  # README: 0 = no return; ranges in metres
    dev = reference_deviation(mesh, rng, valid)
    covered = valid & ~np.isnan(dev)
    assert dev[covered].max() <= 0.02 * (1 + 1e-9)
    t = mesh.stats.target
    assert t.met and t.kind == "max_deviation"
    assert t.uncovered == int((valid & np.isnan(dev)).sum())
    assert mesh.stats.vertices < valid.sum()


# --- every entry point ----------------------------------------------------------------------


def test_mesh_stream_meets_the_bound_as_triangulate_does():
    frames = [smooth_image(s, 20, 30) for s in range(3)]
    for frame, mesh in zip(frames, rangemesh.mesh_stream(frames, max_deviation=0.05), strict=True):
        want = triangulate(frame, max_deviation=0.05)
        np.testing.assert_array_equal(mesh.faces, want.faces)
        assert_meets(mesh, frame, np.ones(frame.shape, bool), 0.05)


def test_max_deviation_on_too_few_valid_pixels_names_why():
    depth = np.zeros((6, 6))
    depth[2, 2] = depth[3, 4] = 5.0
    mesh = triangulate(depth, camera=Pinhole(10, 10, 3, 3), max_deviation=0.01)
    assert mesh.is_empty and "only 2 valid pixels" in mesh.stats.reason


def test_a_deviation_bound_stops_where_memory_runs_out_and_says_so(monkeypatch):
    import rangemesh.memory as pl

    depth = smooth_image(2, 40, 50)  # noisy: 0 needs every pixel as a vertex
    # the image's own bytes and room for 200 vertices (as max_error's test in test_reliability_2)
    monkeypatch.setattr(pl, "available_memory",
                        lambda: 40 * 50 * pl.REFINE_BYTES_PER_PIXEL + 200 * pl.REFINE_BYTES_PER_VERTEX)
    with pytest.raises(MemoryError, match=r"max_deviation=0 needs more than 200 vertices"):
        triangulate(depth, max_deviation=0.0)
    mesh = triangulate(depth, max_deviation=1.0)  # a handful of vertices: they fit
    assert mesh.stats.target.met and mesh.stats.target.max_vertices is None
