"""Greedy insertion as two strips (`rangemesh.refine.strips`): one mesh whatever the threads.

The reference for the rounds is the one-at-a-time order (``rounds=False``):
each step inserts into the strip whose first key is larger. Rounds on two
threads must give that mesh bit for bit; the seam's choice is checked against
hand values.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import rangemesh
from rangemesh import MeshParams, _core, scenes, triangulate
from rangemesh._core import valid_range
from rangemesh.pipeline import prepare
from rangemesh.refine import insertion, strips

from . import strips_reference as reference
from .helpers import assert_valid_mesh
from .images import load, rgbd_frame

CROPS = np.load(__import__("pathlib").Path(__file__).parent / "data" / "crops.npz")


def _insert(image, background, n, **kw):
    d, v = prepare(image, MeshParams(), background)
    lo, hi, nv = valid_range(d, v)
    grid = insertion.grid_size(n, nv, False)
    return reference.strip_insert(d, v, n, float(hi - lo), (1, 1), grid, **kw), v


def _same(a, b):
    return all(np.array_equal(x, y) for x, y in zip(a[:3], b[:3], strict=True)) and a[3] == b[3]


# --- the seam, by hand -------------------------------------------------------------------


def test_seam_rows_by_hand():
    # a jump between rows 2 and 3: against the line from row 0 to row 7 (z = 10 j / 7), row 3
    # is farthest (10 - 30/7 = 5.71); then row 2 (line 0 -> 10 over rows 0..3: 6.67 at row 2)
    z = np.array([0, 0, 0, 10, 10, 10, 10, 10], float)
    ok = np.ones(8, bool)
    assert reference.seam_rows(z, ok, 4).tolist() == [0, 2, 3, 7]
    # every pixel on the lines: the middle of the longest gap (rows 3-7: row 5), then the
    # first of the equally long ones (rows 0-2: row 1)
    assert reference.seam_rows(z, ok, 6).tolist() == [0, 1, 2, 3, 5, 7]
    # the first and last valid pixels always; background never
    ok[[0, 1, 7]] = False
    assert reference.seam_rows(z, ok, 2).tolist() == [2, 6]
    assert reference.seam_rows(z, ok, 3).tolist() == [2, 3, 6]
    assert reference.seam_rows(z, np.zeros(8, bool), 5).tolist() == []


def test_seam_column_by_hand():
    valid = np.ones((10, 100), bool)
    assert reference.seam_column(valid) == 49  # 500 of 1000 valid pixels in columns 0-49
    valid[:, 30:] = False
    assert reference.seam_column(valid) == 25  # 150 in columns 0-14, kept in the middle half


@pytest.mark.parametrize("threads", [1, 2])
def test_the_native_seam_column_halves_the_valid_pixels(threads, monkeypatch):
    """The refine call's own count of each column's valid pixels (issue 44: byte sums a row block)."""
    rows, cols = np.mgrid[0:300, 0:200]  # (more rows than a block of 255)
    image = 100.0 + 10.0 * np.sin(cols / 7.0) + 5.0 * np.cos(rows / 5.0)
    image[:150, 80:] = 0.0  # top half: columns 0-79 valid; bottom half: all 200
    valid = image > 0
    # 300 valid pixels a column up to 79, 150 beyond: 42000 in all, 21000 reached at column 69
    # (the top rows alone would give 39 -> 50, the bottom rows alone 99)
    assert reference.seam_column(valid) == 69
    monkeypatch.setenv("RANGEMESH_THREADS", str(threads))
    mesh = _strip_mesh(image, 0.0, 300, diagonals="delaunay")
    assert_valid_mesh(mesh, valid)
    face_cols = mesh.pixels[mesh.faces, 1]
    assert ((face_cols <= 69).all(axis=1) | (face_cols >= 69).all(axis=1)).all()
    assert {0, 299} <= set(mesh.pixels[mesh.pixels[:, 1] == 69, 0].tolist())


def test_power_laws_by_hand():
    """The rounds' predictions (compiled with the driver, strips.cpp), by hand."""
    # counts against keys: key 100 -> 10 while the count goes 10 -> 100, n ~ key**-1
    law = _core._strip_power_law([(10, 100.0), (100, 10.0)])
    assert (law.n, law.key, law.e) == (100, 10.0, 1.0)
    # errors against counts: 80 -> 10 while the count goes 10 -> 40, t ~ n**-1.5, so the
    # error reaches 1.25 at 40 * (10 / 1.25) ** (1 / 1.5) = 160 vertices
    assert _core._strip_error_target([(10, 80.0), (40, 10.0)], 1.25) == pytest.approx(160.0)
    # keys that rose: no fit, the default exponent 1; steep falls are held to at most 4
    assert _core._strip_power_law([(10, 10.0), (20, 30.0)]).e == 1.0
    assert _core._strip_exponent(1.0, 1.0, 2.0, 1e-9) == 4.0
    # shallow falls to at least 0.75: y halves while x grows 16-fold, e = 0.25
    assert _core._strip_exponent(1.0, 2.0, 16.0, 1.0) == 0.75
    # below the budget already: the count stays
    assert _core._strip_error_target([(10, 80.0), (40, 1.0)], 1.25) == 40.0


def test_strips_only_for_large_vertex_counts():
    assert strips.use_strips((480, 640), 2000, None, 100_000)
    assert not strips.use_strips((480, 640), 1999, None, 100_000)
    assert strips.use_strips((480, 640), 50_000, None, 100_000)
    assert not strips.use_strips((480, 640), 50_001, None, 100_000)  # over half the pixels
    assert strips.use_strips((480, 640), None, 1.0, 60_000)  # an error bound: any count
    assert not strips.use_strips((480, 640), None, 1.0, 59_999)  # a small image: one strip
    assert not strips.use_strips((200, 160), 3200, None, 32_000)
    assert not strips.use_strips((480, 63), 2000, None, 100_000)


def test_every_valid_pixel_when_asked_for_more():
    """Strips cannot give the seam's other pixels: a request beyond the image goes to one strip."""
    image = CROPS["chair"]
    n_valid = int(rangemesh.fill_gaps(*rangemesh.to_depth_and_mask(image, 0))[1].sum())
    mesh = triangulate(image, background=0, vertices=20000, method="refine")
    assert len(mesh.vertices) == n_valid


# --- rounds against one at a time --------------------------------------------------------


def test_rounds_give_the_one_at_a_time_mesh():
    """Whenever the last round stopped both strips by the threshold, as it does in most cases."""
    cases = capped = 0
    for name, background in [("nyu", 2047), ("cones", 0), ("venus", None), ("chair", 0),
                             ("tum", 0), ("boxes", 0), ("mug", None)]:
        for n in (100, 300, 1500, 3000):
            info = {}
            two, _ = _insert(CROPS[name], background, n, threads=2, info=info)
            one, _ = _insert(CROPS[name], background, n, threads=1)
            assert _same(two, one), (name, n)  # threads never change the mesh
            assert two[3] == n
            cases += 1
            if info["capped"]:
                capped += 1
                continue
            ref, _ = _insert(CROPS[name], background, n, rounds=False)
            assert _same(two, ref), (name, n, info)
    # 3 of 28 when written, all at 3000 vertices (a quarter of a crop's pixels, where keys are
    # nearly flat and the power law misjudges the count); two of them differ from the reference
    assert capped <= 3, (capped, cases)


@pytest.mark.parametrize("rel, background, share", [("middlebury/teddy_disp2.png", 0, 0.03),
                                                    ("rgbd/open3d_NYU_depth.raw.npy", 2047, 0.1)])
def test_rounds_on_shared_images(shared_data, rel, background, share):
    image = load(shared_data, rel)
    _, valid = rangemesh.to_depth_and_mask(image, background)
    n = int(share * valid.sum())
    ref, _ = _insert(image, background, n, rounds=False)
    two, _ = _insert(image, background, n, threads=2)
    assert _same(two, ref)


# --- the strip mesh ----------------------------------------------------------------------


def _strip_mesh(image, background, n, **kw):
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(strips, "STRIP_MIN_VERTICES", 0)
        mp.setattr(strips, "STRIP_MIN_COLUMNS", 8)
        mp.setattr(strips, "STRIP_MIN_PIXELS", 0)
        return triangulate(image, background=background, vertices=n, method="refine", **kw)


def _check_seam(mesh, valid):
    """The insertion's own mesh (with ``diagonals='error'`` the flips that follow may cross)."""
    m = reference.seam_column(valid)
    cols = mesh.pixels[mesh.faces, 1]
    # no triangle crosses the seam column
    assert ((cols <= m).all(axis=1) | (cols >= m).all(axis=1)).all()
    return m


@settings(max_examples=25, deadline=None)
@given(kind=st.sampled_from(["box", "pyramid", "stairs", "dome"]),
       noise=st.sampled_from([0.0, 0.5]), seed=st.integers(0, 2**16),
       n=st.integers(20, 600), hole=st.booleans())
def test_strip_meshes_are_valid_and_exact(kind, noise, seed, n, hole):
    image = scenes.make(kind, (40, 72), noise=noise, seed=seed).depth.copy()
    background = None
    if hole:  # background on the left edge, so the strips' corners there are background
        background = 0.0
        image[5:30, :9] = 0.0
        image[0, 30:40] = 0.0
    depth, valid = rangemesh.fill_gaps(*rangemesh.to_depth_and_mask(image, background))
    n = min(n, int(valid.sum()) // 2)  # strips take at most half the pixels (`use_strips`)
    flipped = _strip_mesh(image, background, n, diagonals="error")  # one mesh, flipped
    assert_valid_mesh(flipped, valid)
    assert len(flipped.vertices) == n
    mesh = _strip_mesh(image, background, n, diagonals="delaunay")
    assert_valid_mesh(mesh, valid)
    assert np.array_equal(mesh.pixels, flipped.pixels)
    m = _check_seam(mesh, valid)
    # the seam's first and last valid pixels are vertices: nothing on it is left uncovered
    on_seam = np.nonzero(valid[:, m])[0]
    rows = set(mesh.pixels[mesh.pixels[:, 1] == m, 0].tolist())
    assert {on_seam[0], on_seam[-1]} <= rows
    if n >= 120:  # (a few vertices cannot trace a silhouette: no bound there, as in one strip)
        assert rangemesh.evaluate(mesh, image, background=background).uncovered <= 1.0


def test_strip_mesh_of_a_shared_image_is_valid(shared_data):
    image = load(shared_data, "rgbd/open3d_NYU_depth.raw.npy")
    depth, valid = rangemesh.fill_gaps(*rangemesh.to_depth_and_mask(image, 2047))
    mesh = triangulate(image, background=2047, vertices=3000, method="refine")
    assert strips.use_strips(image.shape, 3000, None, int(valid.sum()))
    assert_valid_mesh(mesh, valid)
    assert len(mesh.vertices) == 3000
    ev = rangemesh.evaluate(mesh, image, background=2047)
    assert ev.uncovered <= 1.0
    # the insertion's own mesh: no triangle across the seam (the default's flips may cross it)
    delaunay = triangulate(image, background=2047, vertices=3000, diagonals="delaunay")
    assert_valid_mesh(delaunay, valid)
    _check_seam(delaunay, valid)


def test_error_bound_on_strips():
    """max_error on an image of 60,000 valid pixels or more: strips, the bound held, any threads."""
    image, _ = rgbd_frame((480, 640))
    image[image == 0] = 2047  # the NYU frame's marker of no depth
    depth, valid = rangemesh.fill_gaps(*rangemesh.to_depth_and_mask(image, 2047))
    assert strips.use_strips(image.shape, None, 0.3, int(valid.sum()))
    mesh = triangulate(image, background=2047, max_error=0.3, method="refine")
    assert mesh.stats.target.met
    assert rangemesh.evaluate(mesh, image, background=2047).relative_error <= 0.3
    assert_valid_mesh(mesh, valid, check_overlap=False)
    # the kernels' own sum, the seam's pixels included, is within the bound; threads change nothing
    d, v = prepare(image, MeshParams(), 2047)
    lo, hi, nv = valid_range(d, v)
    max_sum = 0.3 / 100.0 * float(hi - lo) * nv
    grid = insertion.grid_size(nv, nv, True)
    two = reference.strip_insert(d, v, nv, float(hi - lo), (1, 1), grid, max_sum=max_sum, threads=2)
    one = reference.strip_insert(d, v, nv, float(hi - lo), (1, 1), grid, max_sum=max_sum, threads=1)
    assert _same(two, one)
    m = reference.seam_column(v)
    rows = np.unique(two[0][two[1] == m])
    rows = rows[v[rows, m]]  # (a strip's corner on the seam may be background)
    assert two[4] <= max_sum  # (the seam's own error included)
    assert two[4] > reference._seam_error(d[:, m], v[:, m], rows) > 0.0


def test_fit_on_two_threads_is_the_fit_on_one():
    """The fit's full pass split between two threads gives the same depths bit for bit."""
    from rangemesh.refine import heights

    image, _ = rgbd_frame((375, 450))  # teddy_disp2's size
    d, v = prepare(image, MeshParams(), 0)
    mesh = triangulate(image, background=0, vertices=3000, heights="pixel", method="refine")
    assert len(mesh.faces) >= 4000  # where the pass is split
    two = heights.fit_heights(mesh.pixels, mesh.faces, d, v, mesh.camera, threads=2)
    one = heights.fit_heights(mesh.pixels, mesh.faces, d, v, mesh.camera, threads=1)
    assert np.array_equal(one.view(np.int64), two.view(np.int64))
    # and the fit moved the depths (the check can fail: not a copy of the pixels')
    assert not np.array_equal(two, d[mesh.pixels[:, 0], mesh.pixels[:, 1]])


@pytest.mark.parametrize("diagonals", ["delaunay", "error"])
@pytest.mark.parametrize("s", [0.001, 1 / 3.0, 7.3])
def test_p1_p2_on_strips(shared_data, s, diagonals):
    """SPEC P1 and P2 with two strips: another background marker, another depth unit, one mesh.

    (The seam's rows ranked by raw errors broke P2 at 3000 vertices on this frame: near-ties
    reorder when the depths are scaled. They are ranked by the kernel's quantised keys.)
    """
    image = load(shared_data, "rgbd/open3d_NYU_depth.raw.npy").astype(float)
    nan = np.where(image == 2047, np.nan, image)
    ref = triangulate(image, background=2047, vertices=3000, method="refine", diagonals=diagonals)
    assert strips.use_strips(image.shape, 3000, None, int(np.isfinite(nan).sum()))
    a = triangulate(nan, vertices=3000, method="refine", diagonals=diagonals)
    b = triangulate(nan * s, vertices=3000, method="refine", camera=(1, 1, 1 / s),
                    diagonals=diagonals)
    for m in (a, b):
        assert np.array_equal(m.pixels, ref.pixels) and np.array_equal(m.faces, ref.faces)
    np.testing.assert_allclose(b.vertices, ref.vertices, rtol=1e-9)


# --- diagonals chosen by the error, on strips --------------------------------------------


@pytest.mark.parametrize("name, background", [("nyu", 2047), ("cones", 0), ("tum", 0)])
def test_flipped_strips_are_the_same_on_one_thread_or_two(name, background, monkeypatch):
    """Each strip flips on its own thread, then the seam: one mesh whatever the threads.

    The joined mesh's twin half-edges, the seam's paired by `_joined_halfedges`,
    are those a fresh build from its faces finds.
    """
    from rangemesh._core import build_halfedges

    seams = []
    joined = reference._joined_halfedges

    def checked(a, b, tv, vc, m):
        he, seam = joined(a, b, tv, vc, m)
        assert np.array_equal(he, build_halfedges(tv.reshape(-1, 3), len(vc))[1])
        assert (vc[tv[seam]] == m).all() and (vc[tv[he[seam]]] == m).all()
        seams.append(len(seam))
        return he, seam

    monkeypatch.setattr(reference, "_joined_halfedges", checked)
    two, valid = _insert(CROPS[name], background, 1500, threads=2, diagonals="error")
    one, _ = _insert(CROPS[name], background, 1500, threads=1, diagonals="error")
    assert _same(two, one)
    assert len(seams) == 2 and seams[0] > 10
    plain, _ = _insert(CROPS[name], background, 1500, threads=2)
    assert np.array_equal(two[0], plain[0]) and np.array_equal(two[1], plain[1])  # same vertices
    assert not np.array_equal(two[2], plain[2])  # (flipped)


def test_a_large_strip_mesh_is_the_same_on_one_thread_or_two(monkeypatch):
    """The strips' join, the valid faces of a mesh of 8000 triangles or more and the count of its
    edges run on the second thread with two (issue 44): the same faces, vertices and edge count.
    """
    image, _ = rgbd_frame()
    meshes = {}
    for threads in (1, 2):
        monkeypatch.setenv("RANGEMESH_THREADS", str(threads))
        meshes[threads] = triangulate(image, background=0, vertices=6000, method="refine")
    one, two = meshes[1], meshes[2]
    assert two.stats.strips == 2 and len(two.faces) >= 8000  # (where the valid faces are split)
    assert np.array_equal(one.faces, two.faces) and np.array_equal(one.pixels, two.pixels)
    assert np.array_equal(one.vertices.view(np.int64), two.vertices.view(np.int64))
    # the edge count against the faces' own distinct undirected edges
    f = two.faces
    pairs = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    assert one.stats.edges == two.stats.edges == len(np.unique(pairs, axis=0))


def _python_steps(depth, valid, camera, ref, extent, exponent, vertices, max_error, max_vertices, *,
                  fit, diagonals, walls=True, jump=0.05, **_):
    """`insertion._native`'s stand-in: the Python steps it replaced (the tests' reference)."""
    from .refine_reference import _greedy

    return _greedy(depth, valid, camera, ref, extent, exponent, vertices=vertices, max_error=max_error,
                   fit=fit, diagonals=diagonals, walls=walls, jump=jump, max_vertices=max_vertices,
                   first=None)


def test_the_seams_flips_lower_the_error(monkeypatch):
    """After the join the seam's edges are tested too: some flip across it, the error drops.

    Copied depths, measured by `evaluate` (a render). The mesh is the native
    call's; the one without the seam's pass is the Python steps' with
    `flip_from_edges` replaced by nothing: no triangle crosses the seam column.
    """
    image = CROPS["nyu"].astype(float)
    valid = rangemesh.fill_gaps(*rangemesh.to_depth_and_mask(image, 2047))[1]
    seen = np.where(valid, image, np.nan)
    m = reference.seam_column(valid)

    def crossing(mesh):
        cols = mesh.pixels[mesh.faces, 1]
        return int(((cols < m).any(axis=1) & (cols > m).any(axis=1)).sum())

    with_seam = _strip_mesh(image, 2047, 1500, diagonals="error", heights="pixel")
    monkeypatch.setattr(_core, "flip_from_edges", lambda *args: (0, 0))
    monkeypatch.setattr(insertion, "_native", _python_steps)
    without = _strip_mesh(image, 2047, 1500, diagonals="error", heights="pixel")
    assert crossing(without) == 0 and crossing(with_seam) > 0
    assert_valid_mesh(with_seam, valid)
    assert np.array_equal(with_seam.pixels, without.pixels)
    e_with = rangemesh.evaluate(with_seam, seen).relative_error
    assert e_with < rangemesh.evaluate(without, seen).relative_error


@pytest.mark.parametrize("name, background", [("nyu", 2047), ("cones", 0)])
def test_flips_on_strips_are_counted(name, background):
    """Each flip makes one edge the insertion did not have: at least that many are counted.

    The insertion's own mesh (``diagonals='delaunay'``) has the same vertices;
    every edge of the flipped mesh missing from it was made by a flip.
    """
    def edges(tv):
        t = tv.reshape(-1, 3)
        e = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
        return {tuple(sorted(x)) for x in e.tolist()}

    info = {}
    flipped, _ = _insert(CROPS[name], background, 1500, diagonals="error", info=info)
    plain_info = {}
    plain, _ = _insert(CROPS[name], background, 1500, info=plain_info)
    assert np.array_equal(flipped[0], plain[0]) and np.array_equal(flipped[1], plain[1])
    made = len(edges(flipped[2]) - edges(plain[2]))
    assert made > 0 and info["flips"] >= made
    assert plain_info["flips"] == 0


def test_a_strip_mesh_reports_its_flips(monkeypatch):
    """`Stats.flipped_edges` is a count on two strips too (it was None), and 0 without flips."""
    for key, value in (("STRIP_MIN_VERTICES", 0), ("STRIP_MIN_COLUMNS", 8), ("STRIP_MIN_PIXELS", 0)):
        monkeypatch.setattr(strips, key, value)
    image = CROPS["nyu"]
    mesh = triangulate(image, background=2047, vertices=1500)
    assert mesh.stats.strips == 2 and isinstance(mesh.stats.flipped_edges, int)
    assert mesh.stats.flipped_edges > 0
    plain = triangulate(image, background=2047, vertices=1500, diagonals="delaunay")
    assert plain.stats.strips == 2 and plain.stats.flipped_edges == 0


@pytest.mark.parametrize("threads", [1, 2])
def test_a_strip_mesh_with_every_triangle_kept_counts_its_edges(threads, monkeypatch):
    """No pixel invalid: the call counts the joined strips' edges from their half-edges ((3 F +
    hull half-edges) / 2; issue 44), against the faces' own distinct undirected edges.
    """
    monkeypatch.setenv("RANGEMESH_THREADS", str(threads))
    depth = scenes.box((240, 320), noise=0.3, seed=3).depth
    mesh = triangulate(depth, vertices=3000, method="refine")
    assert mesh.stats.strips == 2 and np.isfinite(depth).all()
    f = mesh.faces
    pairs = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    assert mesh.stats.edges == len(np.unique(pairs, axis=0))
