"""Raw kernels given the arguments of real calls, one of them mutated, refuse it or give a valid result.

The arguments are captured from ordinary meshing of a small synthetic image with holes and a
background corner: ``method='refine'`` by count and by error bound (diagonals by Delaunay and by the error,
no walls), on one strip and on two (the strips' size thresholds lowered so a 48 x 40 image uses
them; two threads), and ``method='paper'`` on two threads with both flip rules. The kernels
meshing does not reach (the fit's fallbacks, the paper's single tests, the tests' primitives)
are called on arguments derived from those captured. Each example changes one argument: an id
or twin set to -2, -1, its array's length, 2^31, 2^62 or INT64_MIN/MAX, an index array permuted
or cast to bool, an array cut short, a float made NaN, inf or -1, a scalar stride, scale or
count set to 0, -1, 2^62 or INT64_MAX. The call must raise ValueError (bad input),
RuntimeError (a broken invariant) or nanobind's TypeError (a value its C++ type cannot hold),
or return a valid result. A hang ends the run through faulthandler's timer (exit status 1) and a
crash ends it too: pytest's capture then loses the report, so rerun the kernel's case with
``-s`` to see the stacks. ``RANGEMESH_CONTRACT_EXAMPLES=500`` searches deeper;
``RANGEMESH_CONTRACT_LOG=file.json`` writes each kernel's calls and outcomes (the sanitizer
run's figures).
"""

from __future__ import annotations

import copy
import faulthandler
import json
import os
import sys
from contextlib import contextmanager

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import rangemesh
import rangemesh.refine.heights as refine_heights
import rangemesh.refine.strips as refine_strips
from rangemesh._core import _ext

from . import strips_reference
from .conftest import PHASES

I64 = np.iinfo(np.int64)
EXAMPLES = int(os.environ.get("RANGEMESH_CONTRACT_EXAMPLES", "20"))
contract = settings(max_examples=EXAMPLES, deadline=None, derandomize=EXAMPLES <= 100, phases=PHASES,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
# Far beyond any kernel call of these tiny inputs (milliseconds; a sanitized build takes ten
# times longer): a call still running then is a hang.
HANG_SECONDS = 60
CALLS_KEPT = 3  # captured calls kept a kernel

# (the functions: the bound classes, a request and its result, are no kernels)
KERNELS = sorted(n for n in dir(_ext) if not n.startswith("__") and callable(getattr(_ext, n))
                 and not isinstance(getattr(_ext, n), type))
# Arithmetic on floats and Python lists, no argument at all, or a class and a dict (new_with_dict,
# its refusals tested in test_pipeline.py): no id, count or array to check.
NO_CONTRACT = {"_strip_error_target", "_strip_exponent", "_strip_power_law", "_uses_avx", "new_with_dict"}
CHECKED = [k for k in KERNELS if k not in NO_CONTRACT]

INT_VALUES = [-2, -1, 0, 1, 2**31, 2**62, int(I64.min), int(I64.max)]
FLOAT_VALUES = [float("nan"), float("inf"), -float("inf"), -1.0, 0.0, 1e300]


# Settings objects whose fields are mutated as arguments are (other bound objects are left as they are).
SETTINGS = (_ext.FlipSettings, _ext.FitSettings, _ext.InsertSettings, _ext.ErrorScan, _ext.StripRequest)


def _fields(settings):
    return sorted(n for n in dir(type(settings)) if isinstance(getattr(type(settings), n), property))


def _copy(x):
    if isinstance(x, np.ndarray):
        return x.copy()
    if isinstance(x, SETTINGS):
        return copy.copy(x)
    if isinstance(x, tuple | list):
        return type(x)(_copy(v) for v in x)
    return x


@contextmanager
def _spying(calls):
    """Every module of rangemesh calls the kernels through spies that keep copies of their arguments."""
    originals = {id(getattr(_ext, n)): n for n in KERNELS}
    patched = []
    for name, module in list(sys.modules.items()):
        if module is None or not name.startswith("rangemesh") or module is _ext:
            continue
        for attr, value in list(vars(module).items()):
            # (a wrapper made by functools.wraps, as .ci/kernel_calls.py's counters, is a kernel too)
            kernel = originals.get(id(getattr(value, "__wrapped__", value)))
            if kernel is None:
                continue

            def spy(*args, _kernel=kernel, _fn=value, **kwargs):
                kept = calls.setdefault(_kernel, [])
                if len(kept) < CALLS_KEPT:
                    kept.append((_copy(args), _copy(kwargs)))  # before the call: some write in place
                return _fn(*args, **kwargs)

            patched.append((module, attr, value))
            setattr(module, attr, spy)
    try:
        yield
    finally:
        for module, attr, value in patched:
            setattr(module, attr, value)


@contextmanager
def _patched(module, **values):
    saved = {k: getattr(module, k) for k in values}
    for k, v in values.items():
        setattr(module, k, v)
    try:
        yield
    finally:
        for k, v in saved.items():
            setattr(module, k, v)


def _image():
    """48 x 40: a tilted plane with a bump, a hole, a background corner and a missing notch."""
    r, c = np.mgrid[0:48, 0:40]
    image = 100.0 + 0.5 * r + 0.2 * c + 10.0 * np.exp(-((r - 20.0) ** 2 + (c - 15.0) ** 2) / 30.0)
    image[30:36, 5:9] = np.nan
    image[0, 0] = np.nan  # the corner's depth comes from its nearest valid pixel
    image[:3, 37:] = np.nan
    return image


def _unit_normals(vertices, triangles):
    p = vertices[triangles.reshape(-1, 3)]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def _derive(calls):
    """Calls of the kernels meshing does not reach, on arguments taken from the captured ones."""
    derived = {}
    if not {"fit_heights", "flip_by_error", "flip_loop"} <= calls.keys():
        return derived  # (the test of coverage names what is missing)
    (faces, pixels, image, valid, _, fit_settings), _ = calls["fit_heights"][0]
    faces = faces.astype(np.int64)
    rows, cols = pixels[:, 0].astype(np.int64), pixels[:, 1].astype(np.int64)
    values, order = image[rows, cols], np.arange(len(faces), dtype=np.int64)
    mesh = (faces, order, pixels.astype(np.int64), values, image, valid)
    derived["face_order"] = [((faces, rows, cols, *image.shape, 8), {})]
    derived["fit_sample_errors"] = [(mesh + (fit_settings,), {})]
    derived["fit_blocks"] = [(mesh + (np.inf, 2), {})]
    errors = _ext.fit_sample_errors(*derived["fit_sample_errors"][0][0])
    derived["median_inplace"] = [((errors,), {})]
    blocks = _ext.fit_blocks(*derived["fit_blocks"][0][0])
    ids, block, rhs = blocks.ids, blocks.block, blocks.rhs
    derived["gather_blocks"] = [((ids, block, rhs, values, 1e-3), {})]
    derived["solve_blocks"] = [((ids, block, rhs, values, 1e-3, 1e-8, 10 * len(values)), {})]

    ((vr, vc, tri, he, _), depth, valid, unit), _ = calls["flip_by_error"][0]
    a, b, c = tri[:3]
    corners = [(vr[v], vc[v], depth[vr[v], vc[v]] if valid[vr[v], vc[v]] else 0.0) for v in (a, b, c)]
    rows, cols, z = (tuple(np.asarray(x).item() for x in k) for k in zip(*corners, strict=True))
    scan = _ext.ErrorScan(own_ca=False, base=0.0, span=unit, stop=1e12)
    derived["triangle_error"] = [((rows, cols, z, depth, valid, scan), {})]
    derived["error_flips"] = [((vr, vc, tri, depth, valid, unit), {})]
    abc = np.array([corners[k][:2] for k in range(3)], np.int64)
    derived["_triangle_rows"] = [((abc, (True, False, True), None, 1), {}),
                                 ((abc, (True, True, True), int(min(vr[a], vr[b], vr[c])) + 1, 2), {})]

    (triangles, halfedges, pts, vertices, depth, valid, cam, flip_settings), _ = calls["flip_loop"][0]
    e0 = int(np.flatnonzero(halfedges >= 0)[0])
    va, vb = int(triangles[e0]), int(triangles[e0 - e0 % 3 + (e0 + 1) % 3])
    derived["disparity_verdict"] = [((triangles, halfedges, _unit_normals(vertices, triangles), vertices, e0,
                                      flip_settings), {})]
    derived["edge_error"] = [((va, vb, pts, vertices, depth, valid, cam), {})]
    derived["lift"] = [((int(pts[va, 0]), int(pts[va, 1]), float(depth[pts[va, 0], pts[va, 1]]), cam), {})]
    derived["line_pixel"] = [((*map(int, pts[va]), *map(int, pts[vb]), 1), {})]

    keys = np.linspace(1.0, 0.0, 16)
    heap = np.arange(16, dtype=np.int64)
    derived["_heap_sift_up"] = [((keys, heap, heap.copy(), 9), {})]
    derived["_heap_rekey"] = [((keys, heap, heap.copy(), 9, 2.0, 16), {})]
    return derived


def _python_steps(image):
    """The refine kernels the native call holds, called on `image` as its old Python steps did."""
    from rangemesh.prepare import to_depth_and_mask
    from rangemesh.refine.start import first_mesh
    from rangemesh.refine.walls import drop_walls
    from rangemesh.render import relative_error

    core = rangemesh._core  # (the spies sit on the modules' names, not on _ext's)
    depth, valid = to_depth_and_mask(image)
    lo, hi, _ = core.valid_range(depth, valid)
    start = first_mesh(depth, valid, 4)
    core.greedy_insert(depth, valid, start, core.InsertSettings(60, -1.0, hi - lo, 1, 1))
    out = core.greedy_insert(depth, valid, start, core.InsertSettings(60, -1.0, hi - lo, 1, 1, sums=True))
    vr, vc, tv, he, tsum = out.vr.copy(), out.vc.copy(), out.tv.copy(), out.he.copy(), out.tsum.copy()
    core.flip_by_error((vr, vc, tv, he, tsum), depth, valid, hi - lo)
    faces, pixels = core.valid_faces(vr, vc, tv, valid)
    f = faces.astype(np.int64)
    triangles, halfedges = core.build_halfedges(f, len(pixels))
    core.prune_dangling(f, core.neighbors_from_halfedges(halfedges), np.ones(len(f), bool), len(pixels),
                        drop_lone=False)
    core.prune_cut_fans(triangles, halfedges, np.ones(len(f), bool), len(pixels))
    rays = rangemesh.Spherical.from_beams({"elevation_deg": list(np.linspace(-10, 10, 48)),
                                           "azimuth0_deg": 0.0, "azimuth_step_deg": 0.5, "cols": 40})
    drop_walls(faces, pixels, depth[pixels[:, 0], pixels[:, 1]], 0.05, rays)
    refine_heights.fit_heights(pixels, faces, depth, valid, rangemesh.Orthographic(), extent=(lo, hi, 0))
    relative_error(rangemesh.triangulate(image, vertices=60), depth, valid)  # (an error bound's render)
    with _patched(refine_strips, STRIP_MIN_PIXELS=1000, STRIP_MIN_COLUMNS=16, STRIP_MIN_VERTICES=20):
        for asked, max_sum in ((300, -1.0), (len(pixels), 0.5 / 100.0 * (hi - lo) * valid.sum())):
            strips_reference.strip_insert(depth, valid, asked, hi - lo, (1, 1), 18, max_sum=max_sum,
                                          diagonals="error", info={})


def capture():
    """Kernel name -> [(args, kwargs)]: the calls meshing makes, then those derived from them."""
    calls = {}
    image = _image()
    with _spying(calls), _patched(refine_heights, ORDER_MIN_PIXELS=0):
        rangemesh.triangulate(image, vertices=60, diagonals="delaunay")
        rangemesh.triangulate(image, max_error=0.5, diagonals="error", walls=False)
        rangemesh.triangulate(image, method="paper", threads=2)
        rangemesh.triangulate(image, method="paper", vertices=80, flips="error", threads=2)
        rangemesh.triangulate(image, vertices=60, min_region=5)  # label_regions
        # a small image with no option: one native call, its preparation included (refine_image)
        rangemesh.triangulate(image[:30, :30].copy(), vertices=20)
        rangemesh.triangulate(image[:30, :30].copy())
        with _patched(refine_strips, STRIP_MIN_PIXELS=1000, STRIP_MIN_COLUMNS=16, STRIP_MIN_VERTICES=20):
            strips = [dict(max_error=0.5, diagonals="error", walls=False),
                      dict(vertices=300, diagonals="error", walls=False)]
            for kw in strips:
                rangemesh.triangulate(image, **kw)
        # one native call a whole refine call, its search included: the kernels it holds, called
        # as the Python steps that were its fallback called them (strips, walls by ray lengths)
        _python_steps(image)
    for kernel, kept in _derive(calls).items():
        calls.setdefault(kernel, kept)
    return calls


@pytest.fixture(scope="module")
def captured():
    return capture()


OUTCOMES: dict[str, dict[str, int]] = {}


@pytest.fixture(scope="module", autouse=True)
def _log_outcomes():
    yield
    path = os.environ.get("RANGEMESH_CONTRACT_LOG")
    if path:
        with open(path, "w") as f:
            json.dump(OUTCOMES, f, indent=1, sort_keys=True)


def test_every_kernel_with_a_contract_is_called(captured):
    assert sorted(set(CHECKED) - set(captured)) == []


# The arguments as leaves: ('arg', i), ('arg', i, j) inside a tuple argument, ('field', i, name) of a
# settings object, ('kw', name).
def _leaves(args, kwargs):
    out = []
    for i, a in enumerate(args):
        if isinstance(a, tuple | list) and not (a and isinstance(a[0], tuple)):
            out += [("arg", i, j) for j in range(len(a)) if _mutable(a[j])]
        elif isinstance(a, SETTINGS):
            out += [("field", i, name) for name in _fields(a)]
        elif _mutable(a):
            out.append(("arg", i))
    return out + [("kw", k) for k, v in kwargs.items() if _mutable(v)]


def _mutable(value):
    """Arrays and numbers are mutated; None and bound objects (a request) are left as they are."""
    return isinstance(value, np.ndarray | bool | int | float | np.generic)


def _get(args, kwargs, leaf):
    if leaf[0] == "kw":
        return kwargs[leaf[1]]
    if leaf[0] == "field":
        return getattr(args[leaf[1]], leaf[2])
    return args[leaf[1]] if len(leaf) == 2 else args[leaf[1]][leaf[2]]


def _set(args, kwargs, leaf, value):
    args = list(args)
    if leaf[0] == "kw":
        kwargs = {**kwargs, leaf[1]: value}
    elif leaf[0] == "field":  # (args are fresh copies: the captured object is left as it was)
        setattr(args[leaf[1]], leaf[2], value)
    elif len(leaf) == 2:
        args[leaf[1]] = value
    else:
        inner = list(args[leaf[1]])
        inner[leaf[2]] = value
        args[leaf[1]] = type(args[leaf[1]])(inner)
    return tuple(args), kwargs


@st.composite
def _mutated(draw, value):
    """`value` changed in one way, and a name for the change."""
    if isinstance(value, bool | np.bool_):
        return not value, "negated"
    if isinstance(value, int | np.integer):
        v = draw(st.sampled_from(INT_VALUES))
        return v, f"= {v}"
    if isinstance(value, float | np.floating):
        v = draw(st.sampled_from(FLOAT_VALUES))
        return v, f"= {v}"
    assert isinstance(value, np.ndarray), type(value)
    flat = value.reshape(-1).copy()
    ops = ["cut short"] if len(value) else []
    if flat.size:
        ops += ["set"]
        if value.dtype.kind in "iu":
            ops += ["permuted", "cast to bool"]
    if not ops:
        return value, "unchanged (empty)"
    op = draw(st.sampled_from(ops))
    if op == "cut short":
        return value[:-1].copy(), op
    if op == "permuted":
        seed = draw(st.integers(0, 2**32 - 1))
        return np.random.default_rng(seed).permutation(flat).reshape(value.shape), op
    if op == "cast to bool":
        return value.astype(bool).astype(value.dtype), op
    k = draw(st.integers(0, flat.size - 1))
    if value.dtype.kind == "b":
        flat[k] = not flat[k]
        return flat.reshape(value.shape), f"[{k}] negated"
    if value.dtype.kind == "f":
        v = draw(st.sampled_from(FLOAT_VALUES))
    else:
        info = np.iinfo(value.dtype)
        v = draw(st.sampled_from(INT_VALUES + [len(flat), len(value)]))
        v = min(max(v, int(info.min)), int(info.max))
    flat[k] = v
    return flat.reshape(value.shape), f"[{k}] = {v}"


def _halfedges_ok(triangles, halfedges, n_vertices):
    """Ids in range, every twin -1 or paired back along its edge in another triangle."""
    tri, he = np.asarray(triangles), np.asarray(halfedges)
    if len(tri) != len(he) or len(tri) % 3 or (len(tri) and not (0 <= tri.min() and tri.max() < n_vertices)):
        return False
    if len(he) and not (-1 <= he.min() and he.max() < len(he)):
        return False
    e = np.flatnonzero(he >= 0)
    g = he[e]
    nxt = lambda x: x - x % 3 + (x + 1) % 3  # noqa: E731
    return bool((he[g] == e).all() and (g // 3 != e // 3).all() and (tri[g] == tri[nxt(e)]).all()
                and (tri[nxt(g)] == tri[e]).all())


def _check_result(kernel, args, result):
    """What a returned call must still hold: its meshes well formed, on the image."""
    if kernel in ("flip_by_error", "flip_from_edges"):
        vr, vc, tri, he = args[0][:4]
        assert _halfedges_ok(tri, he, len(vr))
    elif kernel == "legalize_all":
        assert _halfedges_ok(args[0], args[1], len(args[2]))
    elif kernel == "delaunay_sweep":
        assert _halfedges_ok(result[0], result[1], len(args[0]))
    elif kernel == "greedy_insert":
        h, w = args[0].shape
        vr, vc, tv = result.vr, result.vc, result.tv
        assert len(tv) % 3 == 0 and ((0 <= vr) & (vr < h) & (0 <= vc) & (vc < w)).all()
        if args[3].sums:
            assert _halfedges_ok(tv, result.he, len(vr)) and len(result.tsum) * 3 == len(tv)
    elif kernel == "strip_insert":
        h, w = args[0].shape
        for strip in (result.left, result.right):
            vr, vc, tv = strip.vr, strip.vc, strip.tv
            assert _halfedges_ok(tv, strip.he, len(vr)) and len(strip.tsum) * 3 == len(tv)
            assert ((0 <= vr) & (vr < h) & (0 <= vc) & (vc < w)).all()


def _outcome(kernel, what):
    counts = OUTCOMES.setdefault(kernel, {})
    counts[what] = counts.get(what, 0) + 1


@pytest.mark.parametrize("kernel", CHECKED)
@contract
@given(data=st.data())
def test_a_mutated_real_call_is_refused_or_valid(captured, kernel, data):
    args, kwargs = data.draw(st.sampled_from(captured[kernel]), label="call")
    leaf = data.draw(st.sampled_from(_leaves(args, kwargs)), label="argument")
    value, change = data.draw(_mutated(_get(args, kwargs, leaf)), label="change")
    faulthandler.dump_traceback_later(HANG_SECONDS, exit=True)
    try:
        # fresh arrays: kernels write in place; a settings field refuses a value its C++ type cannot hold
        args, kwargs = _set(_copy(args), _copy(kwargs), leaf, value)
        result = getattr(_ext, kernel)(*args, **kwargs)
    except (ValueError, RuntimeError) as e:
        assert "\n" not in str(e), f"{leaf} {change}: {e}"
        _outcome(kernel, type(e).__name__)
        return
    except TypeError as e:  # nanobind's refusal of a value its C++ type cannot hold (2^62 for an int)
        assert "incompatible function arguments" in str(e), f"{leaf} {change}: {e}"
        _outcome(kernel, "TypeError")
        return
    finally:
        faulthandler.cancel_dump_traceback_later()
    _check_result(kernel, args, result)
    _outcome(kernel, "returned")
