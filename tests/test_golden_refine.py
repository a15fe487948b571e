"""method="refine"'s meshes are bit for bit those saved in tests/data/golden_refine.json.

See tests/golden_refine.py. Every case is meshed on one thread and on two (the strips
and the fit share their work between two threads): the saved mesh is the one of any machine.
"""

import json

import pytest

from . import golden_refine
from .golden import fingerprint

SAVED = json.loads(golden_refine.GOLDEN.read_text())
CONFIGS = dict(golden_refine.CONFIGS)
CROPS = golden_refine.crop_inputs()
SCENES = golden_refine.scene_inputs()
THREADS = [1, 2]


def _mismatch(key, inp, cname, threads):
    """None when the case's mesh has its saved fingerprint, else what differs."""
    mesh, calls = golden_refine.mesh(inp, CONFIGS[cname], threads)
    if CONFIGS[cname].get("strips") and (calls != [(threads, 2)] or mesh.stats.strips != 2):
        return (f"{key}: the native calls gave {calls} ((threads, strips) per call), "
                f"not one two-strip mesh on {threads}")
    got = fingerprint(mesh)
    return None if got == SAVED[key] else f"{key}: {got} != {SAVED[key]}"


def _ids(cases):
    return [f"{name}:{cname}" for name, cname in cases]


@pytest.mark.parametrize("threads", THREADS)
@pytest.mark.parametrize("name, cname", golden_refine.config_names(CROPS),
                         ids=_ids(golden_refine.config_names(CROPS)))
def test_crop_meshes_unchanged(name, cname, threads):
    assert _mismatch(f"crop:{name}:{cname}", CROPS[name], cname, threads) is None


@pytest.mark.parametrize("threads", THREADS)
@pytest.mark.parametrize("name, cname", golden_refine.config_names(SCENES),
                         ids=_ids(golden_refine.config_names(SCENES)))
def test_scene_meshes_unchanged(name, cname, threads):
    assert _mismatch(f"scene:{name}:{cname}", SCENES[name], cname, threads) is None


@pytest.mark.parametrize("threads", THREADS)
@pytest.mark.parametrize("rel, background", golden_refine.FULL_IMAGES,
                         ids=[r for r, _ in golden_refine.FULL_IMAGES])
def test_full_image_meshes_unchanged(shared_data, rel, background, threads):
    inp = golden_refine.full_input(shared_data, rel, background)
    cases = golden_refine.config_names({rel: inp})
    assert {f"full:{rel}:{c}" for _, c in cases} == {k for k in SAVED if k.startswith(f"full:{rel}:")}
    bad = [m for _, c in cases if (m := _mismatch(f"full:{rel}:{c}", inp, c, threads))]
    assert not bad, bad


def test_every_saved_fingerprint_is_checked():
    """No saved entry is left out by a renamed input or config."""
    small = {f"{prefix}:{name}:{cname}" for prefix, inputs in (("crop", CROPS), ("scene", SCENES))
             for name, cname in golden_refine.config_names(inputs)}
    assert {k for k in SAVED if not k.startswith("full:")} == small
    assert {k.split(":")[1] for k in SAVED if k.startswith("full:")} \
        == {rel for rel, _ in golden_refine.FULL_IMAGES}
