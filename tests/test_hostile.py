"""Property-based hostile inputs: whatever goes in, a valid mesh or a documented error comes out.

Random dtypes (byte orders, float16, longdouble, bool, complex), shapes, masks,
values (NaN, infinities, subnormals, huge numbers), parameters of every type
and cameras go into `triangulate`, `evaluate`, `write_mesh`/`read_mesh`,
`read_range_image` and the command line. Each call must give a valid mesh
(SPEC P4, finite vertices) or raise ValueError/TypeError with a message; a
crash, any other exception, or a warning (warnings are errors in the test
configuration) fails.

The default run is bounded; ``RANGEMESH_HOSTILE_EXAMPLES=2000 pytest
tests/test_hostile.py`` searches deeper.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import rangemesh
from rangemesh.cli import main

from .conftest import PHASES
from .helpers import assert_valid_mesh

EXAMPLES = int(os.environ.get("RANGEMESH_HOSTILE_EXAMPLES", "30"))
hostile = settings(max_examples=EXAMPLES, deadline=None, derandomize=EXAMPLES <= 100, phases=PHASES,
                   suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                          HealthCheck.function_scoped_fixture])

REAL_DTYPES = ["<f2", ">f2", "<f4", ">f4", "<f8", ">f8", "g", "|i1", "|u1", "<i2", ">u2",
               "<i4", ">i4", "<u4", "<i8", ">i8", "<u8"]
BAD_DTYPES = ["?", "<c8", "O", "U3"]

special = st.sampled_from([0.0, -0.0, np.nan, np.inf, -np.inf, 1e-310, 5e-324, 1e300, -1e300,
                           65535.0, 2.0**53 + 1])
values = st.one_of(st.floats(-1e6, 1e6, allow_nan=False), special, st.integers(-300, 70000))


@st.composite
def images(draw):
    dtype = draw(st.sampled_from(REAL_DTYPES))
    h = draw(st.integers(1, 24))
    w = draw(st.integers(1, 24))
    kind = draw(st.sampled_from(["smooth", "random", "steps"]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    if kind == "smooth":
        r, c = np.mgrid[0:h, 0:w]
        base = draw(st.floats(-1e3, 1e4)) + draw(st.floats(-5, 5)) * r + draw(st.floats(-5, 5)) * c
    elif kind == "random":
        base = rng.uniform(-100, 1000, (h, w))
    else:
        base = np.where(rng.random((h, w)) < 0.5, 10.0, 200.0)
    for _ in range(draw(st.integers(0, 4))):  # sprinkle special values
        base[rng.integers(0, h), rng.integers(0, w)] = draw(values)
    with np.errstate(invalid="ignore", over="ignore"):
        if np.dtype(dtype).kind in "iu":
            info = np.iinfo(np.dtype(dtype))
            base = np.nan_to_num(base, nan=0, posinf=info.max, neginf=info.min)
            base = np.clip(np.round(base), info.min, info.max)
        arr = base.astype(dtype)
    if draw(st.booleans()) and draw(st.booleans()):
        arr = np.ma.masked_array(arr, mask=rng.random((h, w)) < draw(st.floats(0, 1)))
    return arr


param_values = st.one_of(
    st.integers(-3, 70), st.floats(allow_nan=True, allow_infinity=True), st.none(), st.booleans(),
    st.sampled_from(["4", "44", "no", "adaptive", "error", "", "1e3", "refine", "paper", "fit",
                     "pixel"]),
    st.tuples(st.integers(-1, 12), st.integers(-1, 12)),
    st.builds(np.int64, st.integers(-2, 40)), st.builds(np.float32, st.floats(-5, 200)),
)
FIELDS = ["tiles", "samples", "sampling", "flips", "levels", "curvature_floor", "fill_gaps",
          "delta", "epsilon", "max_angle", "min_bend", "gain_threshold", "max_edge", "threads",
          "method", "heights", "walls", "jump", "wrap"]


@st.composite
def keywords(draw):
    kw = {}
    for name in draw(st.lists(st.sampled_from(FIELDS + ["vertices", "max_error", "background",
                                                        "camera"]), max_size=4, unique=True)):
        if name == "camera":
            kw[name] = draw(st.one_of(
                st.none(), st.tuples(values, values, values),
                st.builds(lambda *a: a, values, values, values, values, values)))
        else:
            kw[name] = draw(param_values)
    if isinstance(kw.get("camera"), tuple) and len(kw["camera"]) == 5:
        try:
            kw["camera"] = rangemesh.Pinhole(*kw["camera"])
        except (ValueError, TypeError):
            kw["camera"] = None
    return kw


def _documented(exc: BaseException) -> None:
    assert isinstance(exc, (ValueError, TypeError)), repr(exc)
    assert str(exc).strip(), f"{type(exc).__name__} without a message"


def _mesh_or_error(image, kw):
    try:
        mesh = rangemesh.triangulate(image, **kw)
    except (ValueError, TypeError) as exc:
        _documented(exc)
        return None
    assert np.isfinite(mesh.vertices).all()
    wrap = "wrap" in kw and not isinstance(kw["wrap"], str) and kw["wrap"] in (True, 1)
    assert_valid_mesh(mesh, check_overlap=False, wrap=wrap)
    return mesh


@hostile
@given(images(), keywords())
def test_triangulate_and_evaluate_any_image(image, kw):
    mesh = _mesh_or_error(image, kw)
    if mesh is None:
        return
    # triangulate took the background, so evaluate must take it as well
    ev = rangemesh.evaluate(mesh, image, background=kw.get("background"))
    assert 0 <= ev.covered_pixels <= ev.valid_pixels


@hostile
@given(st.sampled_from(BAD_DTYPES + REAL_DTYPES), st.sampled_from([(0,), (5,), (0, 4), (3, 4, 2),
                                                                   (2, 3), (1, 1, 1), ()]))
def test_shapes_and_dtypes(dtype, shape):
    try:
        arr = np.zeros(shape, dtype)
    except (TypeError, ValueError):
        return
    _mesh_or_error(arr, {})


@hostile
@given(images(), st.sampled_from([".ply", ".obj", ".off", ".stl", ".glb"]))
def test_written_meshes_read_back(tmp_path_factory, image, suffix):
    mesh = _mesh_or_error(image, {"tiles": 1, "samples": 2, "fill_gaps": False})
    if mesh is None or mesh.is_empty:
        return
    path = tmp_path_factory.mktemp("w") / ("m" + suffix)
    try:
        rangemesh.write_mesh(mesh, path)
    except ValueError as exc:  # vertices beyond float32
        _documented(exc)
        assert "float32" in str(exc) and np.abs(mesh.vertices).max() > np.finfo(np.float32).max
        return
    back = rangemesh.read_mesh(path, image_shape=mesh.image_shape)
    assert len(back.faces) == len(mesh.faces)
    # float32 in the files
    scale = np.maximum(np.abs(mesh.vertices), 1.0)
    if suffix != ".stl":  # STL repeats every vertex per face
        assert np.all(np.abs(back.vertices - mesh.vertices) <= 1e-6 * scale)


@hostile
@given(st.sampled_from([".npy", ".png", ".pgm", ".pfm", ".tif", ".pcd", ".ply", ".obj"]),
       st.binary(max_size=300), st.sampled_from([b"", b"\x93NUMPY", b"\x89PNG\r\n\x1a\n", b"P5\n",
                                                 b"Pf\n", b"II*\x00", b"ply\n", b"v 1 2 3\n"]))
def test_garbage_files(tmp_path_factory, suffix, payload, magic):
    path = tmp_path_factory.mktemp("g") / ("x" + suffix)
    path.write_bytes(magic + payload)
    for read in (rangemesh.read_range_image, rangemesh.read_mesh):
        try:
            read(path)
        except (ValueError, ImportError) as exc:
            assert str(exc).strip() and "\n" not in str(exc).strip()


ARGS = st.lists(st.sampled_from([
    "--tiles", "--samples", "--vertices", "--max-error", "--max-edge", "--delta", "--levels",
    "--background", "--scale", "--intrinsics", "--depth-scale", "--flips", "--threads",
    "--sampling", "--curvature-floor"]), min_size=1, max_size=3, unique=True)
ARG_VALUES = st.sampled_from(["1", "2", "3x2", "0", "-1", "nan", "inf", "1e9", "abc", "1,1,1",
                              "525,525,24,24", "0.001", "none", "error", "uniform", "2.5"])


@hostile
@given(ARGS, st.lists(ARG_VALUES, min_size=3, max_size=3))
def test_cli_option_combinations(tmp_path_factory, options, vals):
    import contextlib
    import io

    d = tmp_path_factory.mktemp("c")
    np.save(d / "i.npy", np.load(Path(__file__).parent / "data" / "crops.npz")["venus"][:40, :40])
    argv = ["mesh", str(d / "i.npy"), "-o", str(d / "o.ply")]
    for opt, v in zip(options, vals, strict=False):
        argv += [opt, v]
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = main(argv)
        except SystemExit as exc:
            code = exc.code
    text = err.getvalue()
    assert "Traceback" not in text
    assert code in (0, 2), (argv, code, text)
    if code == 2:
        assert len(text.strip().splitlines()) == 1, (argv, text)
    else:
        assert (d / "o.ply").is_file()


@pytest.mark.parametrize("kind", ["inf", "nan", "index"])
def test_read_mesh_refuses_what_evaluate_cannot_use(tmp_path, kind):
    v = np.array([[0, 0, 1], [0, 1, 1], [1, 0, 1]], float)
    f = np.array([[0, 1, 2]])
    if kind == "index":
        f = np.array([[0, 1, 3]])
    else:
        v[1, 2] = np.inf if kind == "inf" else np.nan
    (tmp_path / "m.obj").write_text("".join(f"v {a} {b} {c}\n" for a, b, c in v)
                                    + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in f))
    with pytest.raises(ValueError):
        rangemesh.read_mesh(tmp_path / "m.obj")
