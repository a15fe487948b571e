import dataclasses
from pathlib import Path

import numpy as np
import pytest

import rangemesh
from rangemesh import MeshParams, Orthographic, Pinhole, backproject, to_depth_and_mask
from rangemesh.options import markdown_table
from rangemesh.params import NONE_MEANS, OPTION_METHOD, OPTION_TABLE


def test_defaults_are_the_papers():
    p = MeshParams()
    assert p.tiles == (4, 4) and p.samples == (10, 10) and p.grid_shape == (37, 37)
    assert (p.delta, p.epsilon, p.max_angle, p.min_bend) == (20.0, 0.3, 160.0, 5.0)
    assert p.curvature_floor == 20.0 and p.levels == 2 and p.flips == "disparity"


def test_params_are_frozen_and_checked():
    p = MeshParams()
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.delta = 3
    with pytest.raises(TypeError, match="unknown"):
        p.replace(gamma=500)
    with pytest.raises(TypeError, match="tiles"):
        MeshParams(tiles="4x4")
    with pytest.raises(ValueError, match="levels"):
        MeshParams(levels=0)


def test_every_field_is_an_option_of_the_table():
    # one declaration: each MeshParams field carries its option's record, with the field's default
    fields = dataclasses.fields(MeshParams)
    assert [o.field for o in OPTION_TABLE] == [f.name for f in fields]
    for o, f in zip(OPTION_TABLE, fields, strict=True):
        assert o.default == f.default and o.methods in (("refine",), ("paper",), ("refine", "paper"))
    assert OPTION_METHOD["threads"] == "paper" and OPTION_METHOD["heights"] == "refine"
    assert "fill_gaps" not in OPTION_METHOD and "wrap" not in OPTION_METHOD  # both methods'


@pytest.mark.parametrize("field, bad, error, message", [
    ("workers", 0, ValueError, "^workers must be a whole number >= 1"),
    ("samples", 1, ValueError, r"^samples must be >= 2 in both directions \(a tile's first"),
    ("jump", 0.0, ValueError, "^jump must be a positive share of the depth"),
    ("heights", "fitted", ValueError, r"^heights must be one of \(None, 'fit', 'pixel'\)"),
    ("walls", "no", TypeError, "^walls must be True or False"),
    ("delta", 190.0, ValueError, r"^delta must be in \(0, 180\] degrees, got 190.0"),
])
def test_params_check_each_field_by_its_options_rule(field, bad, error, message):
    with pytest.raises(error, match=message):
        MeshParams(**{field: bad})


def test_what_none_means_is_declared_with_its_option_and_documented():
    # issue 43: "None means the method's default" was spelled in the pipeline (heights != 'pixel',
    # diagonals or 'error'); it is declared on the option and read from one table
    assert NONE_MEANS == {"heights": "fit", "diagonals": "error"}
    for o in OPTION_TABLE:
        if o.none_means is not None:
            assert o.default is None and o.none_means in o.choices
            assert f"``{o.none_means!r}`` (None: the default)" in o.doc


@pytest.mark.parametrize("name, other", [("diagonals", "delaunay"), ("heights", "pixel")])
def test_the_pipeline_resolves_none_from_the_table(monkeypatch, name, other):
    r, c = np.mgrid[0:30, 0:40]
    depth = 100.0 + 5.0 * np.sin(r / 4.0) * np.cos(c / 5.0) + 0.02 * r * c

    def mesh(**options):
        m = rangemesh.triangulate(depth, vertices=60, **options)
        return m.vertices, m.faces

    default, given, changed = mesh(), mesh(**{name: NONE_MEANS[name]}), mesh(**{name: other})
    for a, b in zip(default, given, strict=True):
        np.testing.assert_array_equal(a, b)
    assert any(a.shape != b.shape or (a != b).any() for a, b in zip(default, changed, strict=True))
    monkeypatch.setitem(NONE_MEANS, name, other)
    for a, b in zip(mesh(), changed, strict=True):
        np.testing.assert_array_equal(a, b)


def test_the_docs_option_table_is_the_codes():
    doc = (Path(__file__).parents[1] / "docs" / "options.md").read_text()
    assert markdown_table(OPTION_TABLE) in doc, "paste `python -m rangemesh.params` into docs/options.md"


def test_cameras():
    with pytest.raises(ValueError, match="fx"):
        Pinhole(0, 1, 0, 0)
    with pytest.raises(ValueError, match="kx"):
        Orthographic(-1, 1, 1)
    p = backproject([10], [20], [3.0], Pinhole(2.0, 4.0, 10.0, 2.0, 2.0))
    assert p.tolist() == [[30.0, 12.0, 6.0]]  # Z = 6, X = (20-10)*6/2, Y = (10-2)*6/4


def test_mask_from_markers():
    img = np.array([[0, 7], [65535, 3]], np.uint16)
    d, v = to_depth_and_mask(img, background=65535)
    assert v.tolist() == [[True, True], [False, True]] and d[1, 0] == 0.0
    d, v = to_depth_and_mask(np.array([[np.nan, 1.0], [np.inf, -np.inf]]))
    assert v.tolist() == [[False, True], [False, False]]


# ---------------------------------------------------------------- from the hostile-input reports


# D7, D8 of the 2026-11-21 hostile-input report
@pytest.mark.parametrize("kwargs, name", [
    ({"vertices": "100"}, "vertices"),
    ({"max_error": "1"}, "max_error"),
    ({"max_edge": "5"}, "max_edge"),
    ({"levels": "1"}, "levels"),
    ({"tiles": "44"}, "tiles"),          # D8: not (4, 4)
    ({"samples": "10"}, "samples"),      # D8: not (1, 0)
    ({"fill_gaps": "no"}, "fill_gaps"),  # D8: not True
    ({"fill_gaps": "False"}, "fill_gaps"),
    ({"delta": "20"}, "delta"),
    ({"threads": "2"}, "threads"),
])
def test_wrong_types_name_the_parameter(kwargs, name):
    with pytest.raises(TypeError, match=name):
        rangemesh.triangulate(np.ones((30, 30)), method="paper", **kwargs)


# D8 of the 2026-11-21 hostile-input report
def test_none_is_the_default_in_calls_and_refused_in_meshparams():
    # a keyword left at None takes the method's default; MeshParams has no "not given"
    a = rangemesh.triangulate(np.add.outer(np.arange(30.0), np.arange(30.0)), method="paper",
                              levels=None)
    b = rangemesh.triangulate(np.add.outer(np.arange(30.0), np.arange(30.0)), method="paper",
                              levels=2)
    assert np.array_equal(a.faces, b.faces)
    with pytest.raises(TypeError, match="levels"):
        rangemesh.MeshParams(levels=None)


# D9 of the 2026-11-21 hostile-input report
@pytest.mark.parametrize("value, pair", [
    (np.int64(3), (3, 3)), (np.int32(3), (3, 3)), (np.float64(3.0), (3, 3)), (3.0, (3, 3)),
    ((np.int16(2), np.uint8(3)), (2, 3)), ([2, 3], (2, 3)),
])
def test_numpy_whole_numbers_are_accepted(value, pair):
    assert MeshParams(tiles=value).tiles == pair
    assert isinstance(MeshParams(tiles=value).tiles[0], int)


# D9 of the 2026-11-21 hostile-input report
def test_flags_take_numpy_bools():
    assert MeshParams(fill_gaps=np.bool_(False)).fill_gaps is False
