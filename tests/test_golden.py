"""The paper's meshes are bit for bit those saved in tests/data/golden.json (see tests/golden.py)."""

import json

import pytest

import rangemesh

from . import golden
from .images import REAL_IMAGES, load

SAVED = json.loads(golden.GOLDEN.read_text())
CROPS = golden.crops()


@pytest.mark.parametrize("name", sorted(CROPS))
@pytest.mark.parametrize("config", golden.CONFIGS, ids=[c for c, _ in golden.CONFIGS])
def test_crop_meshes_unchanged(name, config):
    cname, cfg = config
    arr, bg = CROPS[name]
    mesh = rangemesh.triangulate(arr, background=bg, **golden.kwargs_for(cfg))
    assert golden.fingerprint(mesh) == SAVED[f"crop:{name}:{cname}"]


@pytest.mark.parametrize("rel, background", REAL_IMAGES, ids=[r for r, _ in REAL_IMAGES])
def test_full_image_meshes_unchanged(shared_data, rel, background):
    arr = load(shared_data, rel)
    cfgs = dict(golden.CONFIGS)
    for cname in golden.FULL_CONFIGS:
        mesh = rangemesh.triangulate(arr, background=background, **golden.kwargs_for(cfgs[cname]))
        assert golden.fingerprint(mesh) == SAVED[f"full:{rel}:{cname}"], cname
