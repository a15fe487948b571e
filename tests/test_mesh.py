"""rangemesh.mesh: the Mesh and its records (Stats, Target), frozen, typed and copied by field."""

import dataclasses

import numpy as np
import pytest

from rangemesh import Target, triangulate


def crease(h=40, w=50):
    """Two planes meeting at a crease (tests/test_api.py's image)."""
    c = np.arange(w)[None, :].repeat(h, 0)
    return np.where(c < 25, 100.0 + c, 150.0 - c)


def test_target_record_is_frozen_and_typed():
    t = triangulate(crease(), vertices=20).stats.target
    with pytest.raises(dataclasses.FrozenInstanceError):
        t.achieved = 3
    assert t.to_dict()["kind"] == "vertices"


def test_target_read_as_a_dict_warns():
    t = triangulate(crease(), vertices=20).stats.target
    with pytest.warns(DeprecationWarning, match="Target record"):
        assert t["achieved"] == 20 and t["target"] == "vertices"
    with pytest.warns(DeprecationWarning):
        assert "tiles" not in t and t.get("note", "none") == "none"


def test_with_fields_is_dataclasses_replace():
    from rangemesh.mesh import with_fields

    mesh = triangulate(crease(), vertices=12)
    for obj, change in ((mesh.stats, {"method": "paper", "seconds": {"total": 1.0}}),
                        (mesh, {"stats": mesh.stats})):
        fast, slow = with_fields(obj, **change), dataclasses.replace(obj, **change)
        assert type(fast) is type(slow)
        assert fast.__dict__.keys() == slow.__dict__.keys()
        assert all(fast.__dict__[k] is slow.__dict__[k] for k in fast.__dict__)


def test_target_record_refuses_unknown_keys():
    with pytest.raises(TypeError, match="extra"):
        Target.from_record({"target": "vertices", "requested": 3, "achieved": 3, "met": True,
                            "extra": 1}, vertices=3)
