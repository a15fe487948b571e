"""Fingerprints of method="refine"'s meshes, saved before its kernels are ported and checked after.

``python -m tests.golden_refine`` (from the repository root, data folder beside it or
named by ``RANGEMESH_DATA``) rewrites ``tests/data/golden_refine.json``. Do that only
when a change is *meant* to change refine's meshes (a kernel's choice, a default, the
budget rule of ``benchmarks/budgets.py``, the crops or the scenes), and say so in the
commit: the file is the proof that a port of the Numba kernels (to C++), a move or a
speed-up left the meshes of ``method="refine"`` bit for bit as they were. The paper
method's meshes are pinned the same way by `tests.golden`, whose `fingerprint` this
module uses.

The inputs: the committed crops and the package's scenes (always), the shared images
and the LiDAR scan (when the data folder is there). Vertex counts are the benchmarks'
budgets, 1, 3 and 10 % of the valid pixels (`budgets.vertex_budgets`). The LiDAR scan
is meshed with its beams' camera in every config, as ``benchmarks/budgets.py`` meshes
it; the RGB-D frames whose intrinsics the data README gives get one pinhole config.
Every case is meshed on one thread and on two, and must give one mesh.
"""

import importlib.util
import json
import sys
from contextlib import contextmanager

import pytest

from .golden import HERE, crops, fingerprint
from .images import REAL_IMAGES

GOLDEN = HERE / "data" / "golden_refine.json"


def _load_budgets():
    """``benchmarks/budgets.py``, the rule of the 1, 3 and 10 % budgets (not a package)."""
    path = HERE.parent / "benchmarks" / "budgets.py"
    spec = importlib.util.spec_from_file_location("rangemesh_benchmarks_budgets", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


budgets = _load_budgets()

# (name, options): "budget" is a share of the valid pixels, the vertex count taken from
# `budgets.vertex_budgets`; "strips" lifts the size limits of two strips
# (`rangemesh.refine.strips.use_strips`) so that small inputs are meshed as two strips too;
# "pinhole" gives the input's own pinhole camera (inputs without one skip the config).
# Every other option is a keyword argument of rangemesh.triangulate.
CONFIGS = [
    ("1%", {"budget": 0.01}),
    ("3%", {"budget": 0.03}),
    ("10%", {"budget": 0.10}),
    ("max-error-0.3", {"max_error": 0.3}),
    ("no-walls", {"budget": 0.03, "walls": False}),
    ("pixel-heights", {"budget": 0.03, "heights": "pixel"}),
    ("delaunay", {"budget": 0.03, "diagonals": "delaunay"}),
    ("two-strips", {"budget": 0.01, "strips": True}),
    ("pinhole", {"budget": 0.03, "pinhole": True}),
]

# Pinhole intrinsics (fx, fy, cx, cy, depth_scale) of the RGB-D frames that the data
# README gives them for: the TUM fr1 frame (depth / 5000 m) and the OpenNI frame (mm).
INTRINSICS = {
    "rgbd/slambook2_ch7_1_depth.png": (520.9, 521.0, 325.1, 249.7, 0.0002),
    "rgbd/pcl_grabber_frame_20121214T142255.814212_depth.tiff": (525.0, 525.0, 320.0, 240.0,
                                                                 0.001),
}
# The shared images (path, background marker): tests/images.py's and the LiDAR scan's range
# image (metres, 0 = no return), as benchmarks/budgets.py meshes them.
LIDAR_RANGE = "lidar/rellis3d_os1-64_000000.range.npy"
FULL_IMAGES = [*REAL_IMAGES, (LIDAR_RANGE, 0)]

# The scenes at the size the benchmarks mesh them, without and with noise.
SCENE_SHAPE = (160, 200)
SCENE_NOISE = (0.0, 0.5)


class Input:
    """One image to mesh: its depth, background marker, camera and pinhole intrinsics."""

    def __init__(self, image, background=None, camera=None, intrinsics=None):
        self.image = image
        self.background = background
        self.camera = camera
        self.intrinsics = intrinsics


def crop_inputs() -> dict:
    """The committed crops; a crop of a frame with intrinsics gets them, moved to its origin."""
    meta = json.loads((HERE / "data" / "crops.json").read_text())
    out = {}
    for name, (arr, bg) in crops().items():
        m = meta[name]
        intr = INTRINSICS.get(m["source"])
        if intr is not None:
            fx, fy, cx, cy, scale = intr
            intr = (fx, fy, cx - m["cols"][0], cy - m["rows"][0], scale)
        out[name] = Input(arr, bg, intrinsics=intr)
    return out


def scene_inputs() -> dict:
    """Every scene of `rangemesh.scenes`, without and with noise (NaN marks background)."""
    from rangemesh import scenes

    out = {}
    for name in sorted(scenes.SCENES):
        for noise in SCENE_NOISE:
            label = name if noise == 0 else f"{name}-noise-{noise}"
            out[label] = Input(scenes.make(name, SCENE_SHAPE, noise=noise).depth)
    return out


def full_input(shared_data, rel: str, background) -> Input:
    """One shared image; the LiDAR scan with its beams' camera (`Spherical.from_beams`)."""
    import numpy as np

    from rangemesh import Spherical

    from .images import load

    if rel == LIDAR_RANGE:
        beams = shared_data / rel.replace(".range.npy", ".beams.json")
        return Input(np.load(shared_data / rel), background, camera=Spherical.from_beams(beams))
    return Input(load(shared_data, rel), background, intrinsics=INTRINSICS.get(rel))


def full_inputs(shared_data) -> dict:
    """Every image of FULL_IMAGES, by its path."""
    return {rel: full_input(shared_data, rel, bg) for rel, bg in FULL_IMAGES}


def vertex_count(inp, share) -> int:
    """The benchmarks' vertex count for `share` of the input's valid pixels."""
    import rangemesh

    _, valid = rangemesh.to_depth_and_mask(inp.image, inp.background)
    return dict(budgets.vertex_budgets(valid))[share]


@contextmanager
def meshing(strips=False, threads=None):
    """Refine's meshing with the strips' size limits lifted and on `threads` threads, if given.

    Yields a list that receives, per native call (`rangemesh._core.refine_mesh`,
    which meshes one strip or two), ``(threads, strips)``: the threads it was
    given for two strips (None when asked for one) and the strips of its mesh
    (None when it declined). Threads are those of the strips and of the fit
    (`rangemesh.threads`).
    """
    from rangemesh import threads as threads_module
    from rangemesh.refine import heights, insertion
    from rangemesh.refine import strips as strips_module

    calls = []
    refine_mesh = insertion._core.refine_mesh

    def counted(depth, valid, camera, req, *ref):
        res = refine_mesh(depth, valid, camera, req, *ref)
        calls.append((req.threads if req.strips else None, res.strips if res.done else None))
        return res

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(insertion._core, "refine_mesh", counted)
        if strips:  # the limits tests/test_strips.py lifts
            mp.setattr(strips_module, "STRIP_MIN_VERTICES", 0)
            mp.setattr(strips_module, "STRIP_MIN_COLUMNS", 8)
            mp.setattr(strips_module, "STRIP_MIN_PIXELS", 0)
        if threads is not None:
            mp.setattr(threads_module, "threads", lambda: threads)
            mp.setattr(heights, "threads", lambda: threads)
        yield calls


def applies(inp, config: dict) -> bool:
    """Whether the config meshes this input (a pinhole config needs the input's intrinsics)."""
    return not config.get("pinhole") or inp.intrinsics is not None


def config_names(inputs: dict) -> list:
    """``(input name, config name)`` of every case of these inputs."""
    return [(name, cname) for name, inp in inputs.items() for cname, cfg in CONFIGS
            if applies(inp, cfg)]


def kwargs_for(inp, config: dict) -> dict:
    """Keyword arguments of rangemesh.triangulate for one input under a config that applies."""
    import rangemesh

    kw = dict(config)
    kw["method"] = "refine"  # refine's meshes, whatever the default method
    kw.pop("strips", None)
    if "budget" in kw:
        kw["vertices"] = vertex_count(inp, kw.pop("budget"))
    if kw.pop("pinhole", False):
        kw["camera"] = rangemesh.Pinhole(*inp.intrinsics)
    elif inp.camera is not None:
        kw["camera"] = inp.camera
    return kw


def mesh(inp, config: dict, threads=None):
    """``(mesh, native calls)`` of one input under one config (see `meshing`)."""
    import rangemesh

    with meshing(config.get("strips", False), threads) as calls:
        out = rangemesh.triangulate(inp.image, background=inp.background,
                                    **kwargs_for(inp, config))
    return out, calls


def fingerprints(prefix: str, inputs: dict) -> dict:
    """``{"prefix:name:config": fingerprint}`` of every case, the same on one thread and two.

    A mesh that changes with the threads is not saved: it raises (the
    fingerprint would depend on the machine that wrote it).
    """
    configs = dict(CONFIGS)
    out = {}
    for name, cname in config_names(inputs):
        one, two = (fingerprint(mesh(inputs[name], configs[cname], threads)[0])
                    for threads in (1, 2))
        if one != two:
            raise RuntimeError(f"{prefix}:{name}:{cname}: one thread and two give other meshes")
        out[f"{prefix}:{name}:{cname}"] = two
    return out


def compute(shared_data=None) -> dict:
    out = fingerprints("crop", crop_inputs())
    out.update(fingerprints("scene", scene_inputs()))
    if shared_data is not None:
        out.update(fingerprints("full", full_inputs(shared_data)))
    return out


if __name__ == "__main__":
    from .conftest import data_dir

    if data_dir() is None:  # the file would lose the full images' fingerprints
        raise SystemExit("../shared/data not found (set RANGEMESH_DATA): nothing written")
    GOLDEN.write_text(json.dumps(compute(data_dir()), indent=1, sort_keys=True) + "\n")
    print(f"wrote {GOLDEN}")
