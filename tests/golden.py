"""Fingerprints of the paper method's meshes, saved before a refactor and checked after it.

``python -m tests.golden`` (from the repository root, data folder beside it)
rewrites ``tests/data/golden.json``. Do that only when a change is *meant* to
change the paper's meshes, and say so in the commit: the file is the proof
that moves, re-layouts and new methods left the paper's method bit for bit
as it was.
"""

import hashlib
import json
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
GOLDEN = HERE / "data" / "golden.json"

# (name, keyword arguments of rangemesh.triangulate)
CONFIGS = [
    ("paper", {}),
    ("adaptive-error", {"flips": "error"}),
    ("uniform-error", {"sampling": "uniform", "flips": "error"}),
    ("uniform-none", {"sampling": "uniform", "flips": None}),
    ("tiles3-samples7", {"tiles": 3, "samples": 7}),
    ("vertices-400", {"vertices": 400}),
    ("max-error-1", {"max_error": 1.0}),
    ("max-edge-9", {"max_edge": 9.0}),
    ("pinhole", {"camera": ("pinhole", 525.0, 525.0, 60.0, 40.0, 0.001)}),
    ("workers-2", {"workers": 2}),
]
FULL_CONFIGS = ["paper", "adaptive-error", "uniform-error", "vertices-400"]


def fingerprint(mesh) -> str:
    """SHA-256 over the mesh's vertices, faces and pixels (dtype and shape included)."""
    h = hashlib.sha256()
    for a in (mesh.vertices, mesh.faces, mesh.pixels):
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype.str}{a.shape}".encode())
        h.update(a.tobytes())
    return h.hexdigest()[:32]


def kwargs_for(config: dict) -> dict:
    import rangemesh

    kw = dict(config)
    kw["method"] = "paper"  # these are the paper's meshes, whatever the default method
    if "workers" in kw:  # the configs' name of the in-call thread count
        kw["threads"] = kw.pop("workers")
    cam = kw.pop("camera", None)
    if cam is not None:
        kw["camera"] = rangemesh.Pinhole(*cam[1:])
    return kw


def crops():
    """The committed real-image crops: name -> (array, background marker)."""
    meta = json.loads((HERE / "data" / "crops.json").read_text())
    with np.load(HERE / "data" / "crops.npz") as z:
        return {k: (z[k], meta[k]["background"]) for k in meta}


def compute(shared_data=None) -> dict:
    import rangemesh

    out = {}
    for name, (arr, bg) in crops().items():
        for cname, cfg in CONFIGS:
            out[f"crop:{name}:{cname}"] = fingerprint(
                rangemesh.triangulate(arr, background=bg, **kwargs_for(cfg)))
    if shared_data is not None:
        from .images import REAL_IMAGES, load

        for rel, bg in REAL_IMAGES:
            arr = load(shared_data, rel)
            for cname, cfg in CONFIGS:
                if cname in FULL_CONFIGS:
                    out[f"full:{rel}:{cname}"] = fingerprint(
                        rangemesh.triangulate(arr, background=bg, **kwargs_for(cfg)))
    return out


if __name__ == "__main__":
    from .conftest import data_dir

    GOLDEN.write_text(json.dumps(compute(data_dir()), indent=1, sort_keys=True) + "\n")
    print(f"wrote {GOLDEN}")
