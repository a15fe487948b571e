"""The paper's experiments and today's peers, on the same images, at the same vertex counts.

Run ``python benchmarks/peers.py`` (``--quick`` for a short run, ``--help`` for
options). The budgets are the paper's four grids and about 5000 vertices, or with
``--budgets fractions`` 1, 3 and 10 % of the valid pixels (``all``: both); MeshLab and
Open3D take seconds a call on the larger images, a minute on aloe (1.4 Mpixel). For
every image and budget it meshes with

* rangemesh: adaptive + disparity flips (the paper), adaptive + error flips,
  adaptive without flips, uniform + error flips (the paper's Table I
  baseline), uniform without flips; and ``method="refine"`` (our own greedy
  insertion), with fitted and with copied depths;
* greedy insertion (Garland-Heckbert) through ``pydelatin``, asked for the
  vertex count of the paper's method (raised until that many vertices land
  on valid pixels, since it also meshes the filled holes);
* quadric-error decimation of the full-resolution grid mesh through
  ``fast-simplification``, down to that count (depth rescaled to a range of
  100 for the decimation: its thresholds are absolute);
* MeshLab's quadric edge collapse (``pymeshlab``) and Open3D's
  ``simplify_quadric_decimation`` of the same grid mesh, at the face target
  whose result has that count (settings in `peer_meshlab`, `peer_open3d`);
* RTIN through ``pymartini`` (image padded to 2**k + 1), at the error
  threshold whose vertex count is nearest;

and evaluates every mesh with the same code (`rangemesh.evaluate`): the paper's
relative error over valid pixels, RMS, max, uncovered share, and the error
within 2 px of a discontinuity. Peers are optional (``pip install
"rangemesh[bench]"``); a missing one is skipped and the report says so. The
peers are never a dependency of rangemesh itself: this script lives outside
the package.

What is timed (median of ``--repeat`` calls in this process, after one
warm-up call; 2 calls when one takes over half a second), once the request
that meets the vertex count has been found (that search is not timed):
rangemesh, the whole `triangulate` call from the raw image;
pydelatin, the ``Delatin(...)`` call; fast-simplification, the ``simplify``
call (building the full-resolution grid mesh is not timed); MeshLab and Open3D,
the decimation call alone (building their mesh objects is not timed; a call
over half a second is timed once, the search's own call at that target, as
their calls take seconds on the larger images); pymartini,
``Martini(n)`` + ``create_tile`` + ``get_mesh`` (padding is not timed). Hole
filling for the peers that need a complete height map is not timed either.
Peers see background pixels filled with the nearest valid depth; their
vertices are counted on valid pixels only, as are everyone's.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import statistics
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import ndimage

from rangemesh import scenes
from rangemesh.camera import Orthographic
from rangemesh.io import read_range_image
from rangemesh.mesh import Mesh, Stats, count_edges
from rangemesh.metrics import discontinuity_mask, evaluate
from rangemesh.pipeline import triangulate
from rangemesh.prepare import to_depth_and_mask
from rangemesh.render import render_depth

__all__ = ["main", "run", "IMAGES"]

# The real images of shared/data (path, background marker, note), from its README.
IMAGES = [
    ("odetics/chair-range.npy", 0, "laser range finder, blocky chair"),
    ("middlebury/venus_disp2.npy", None, "piecewise planar, creases"),
    ("middlebury/cones_disp2.png", 0, "cones, many jumps"),
    ("middlebury/teddy_disp2.png", 0, "planes and a curved toy"),
    ("middlebury/tsukuba_disp3.npy", 0, "fronto-parallel layers"),
    ("middlebury/aloeGT.png", 0, "leaves, thin structures (large)"),
    ("rgbd/open3d_TUM_depth.png", 0, "Kinect office"),
    ("rgbd/slambook2_ch7_1_depth.png", 0, "Kinect desk"),
    ("rgbd/open3d_NYU_depth.raw.npy", 2047, "Kinect raw"),
    ("rgbd/open3d_SUN_depth.mm.npy", 0, "corridor walls"),
    ("rgbd/slambook2_ch5_depth_1.npy", 0, "chairs, thin legs"),
    ("rgbd/pcl_grabber_frame_20121214T142255.814212_depth.tiff", 0, "boxes on a table"),
    ("rgbd/pcl_milk_cartoon_all_small_clorox.z.npy", None, "tabletop objects"),
    ("rgbd/pcl_table_scene_mug_stereo_textured.z.npy", None, "noisy stereo"),
    # Every method gets the range image itself (metres, 0 = no return), in the image frame:
    # errors are in range units along the rays, the 360-degree seam left open for all, and
    # the peers' height maps have the no-return pixels filled with the nearest range (_filled).
    ("lidar/rellis3d_os1-64_000000.range.npy", 0, "spinning LiDAR 64x2048, people and trees"),
]
QUICK_IMAGES = ["odetics/chair-range.npy", "middlebury/venus_disp2.npy",
                "rgbd/pcl_grabber_frame_20121214T142255.814212_depth.tiff"]
SCENES = [("crease", 0.0), ("pyramid", 0.0), ("box", 0.0), ("dome", 0.0), ("stairs", 0.0),
          ("pyramid", 0.5), ("box", 0.5), ("dome", 0.5)]
QUICK_SCENES = [("crease", 0.0), ("box", 0.5)]
PAPER_BUDGETS = [(5, 5), (7, 7), (8, 8), (10, 10)]
# budgets.py's budgets (`vertex_budgets`): these shares of the valid pixels, at least 50 vertices
FRACTIONS = (0.01, 0.03, 0.10)
MIN_VERTICES = 50

OURS = [
    ("rangemesh adaptive+disparity (paper)", dict(method="paper", sampling="adaptive",
                                                  flips="disparity")),
    ("rangemesh adaptive+error", dict(method="paper", sampling="adaptive", flips="error")),
    ("rangemesh adaptive, no flips", dict(method="paper", sampling="adaptive", flips=None)),
    ("rangemesh uniform+error (Table I baseline)", dict(method="paper", sampling="uniform",
                                                        flips="error")),
    ("rangemesh uniform, no flips", dict(method="paper", sampling="uniform", flips=None)),
    ("rangemesh refine", dict(method="refine")),
    ("rangemesh refine, pixel heights", dict(method="refine", heights="pixel")),
]
# ``--best``: refine's effort="best" as a row of its own (several times refine's time).
BEST = ("rangemesh refine, effort=best", dict(method="refine", effort="best"))


@dataclass
class Image:
    """One benchmark input with what it takes to evaluate a mesh of it."""

    name: str
    depth: np.ndarray
    background: float | None
    note: str
    discontinuities: np.ndarray


def _timed(fn, repeat):
    t = time.perf_counter()
    out = fn()
    if time.perf_counter() - t > 0.5:
        repeat = min(repeat, 2)  # slow calls (decimating a 1.4 Mpixel grid): fewer repeats
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return out, 1000.0 * statistics.median(times)


def positive_int(text):
    """argparse type of ``--repeat``: an integer of at least 1 (a median needs one call)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def alternating_ms(fns, repeat):
    """Call each function in turn, `repeat` rounds: (each one's last output, its median ms).

    Alternating calls share the machine's drift alike: the ratio of two medians is what a
    change or a peer costs, on a shared and noisy machine.
    """
    outs = [None] * len(fns)
    times = [[] for _ in fns]
    for _ in range(repeat):
        for i, fn in enumerate(fns):
            t = time.perf_counter()
            outs[i] = fn()
            times[i].append(time.perf_counter() - t)
    return outs, [1000.0 * statistics.median(t) for t in times]


def _filled(depth, valid):
    """Background replaced by the nearest valid depth (for peers that need a full height map)."""
    if valid.all():
        return depth.astype(np.float32)
    _, (ri, ci) = ndimage.distance_transform_edt(~valid, return_indices=True)
    return depth[ri, ci].astype(np.float32)


def _mesh_from(vertices_rc_z, faces, shape, pixels=None):
    """A Mesh in the orthographic (r, c, depth) frame, for evaluate()."""
    v = np.ascontiguousarray(vertices_rc_z, dtype=np.float64)
    f = np.ascontiguousarray(faces, dtype=np.int32)
    px = np.zeros((0, 2), np.int32) if pixels is None else pixels.astype(np.int32)
    stats = Stats(vertices=len(v), triangles=len(f), edges=count_edges(f) if len(f) else 0)
    return Mesh(v, f, px, Orthographic(), tuple(shape), stats)


def _valid_vertex_count(mesh, valid):
    """Vertices standing on a valid pixel (rounded image position)."""
    if len(mesh.vertices) == 0:
        return 0
    if len(mesh.pixels) == len(mesh.vertices):
        r, c = mesh.pixels[:, 0], mesh.pixels[:, 1]
    else:
        r = np.clip(np.round(mesh.vertices[:, 0]).astype(int), 0, valid.shape[0] - 1)
        c = np.clip(np.round(mesh.vertices[:, 1]).astype(int), 0, valid.shape[1] - 1)
    return int(valid[r, c].sum())


# ---------------------------------------------------------------- peers


def delatin_mesh(tin, shape):
    """pydelatin's result as a Mesh in the (r, c, depth) frame."""
    v = np.asarray(tin.vertices, np.float64)
    # pydelatin's y runs up: row = (H - 1) - y; x is the column
    rcz = np.c_[(shape[0] - 1) - v[:, 1], v[:, 0], v[:, 2]]
    pix = np.c_[np.round(rcz[:, 0]), np.round(rcz[:, 1])].astype(np.int32)
    return _mesh_from(rcz, tin.triangles, shape, pix)


def delatin_request(depth, valid, n):
    """``(filled image, max_points)``: the pydelatin request that puts n vertices on valid pixels.

    It also meshes the filled holes, so the request is searched: grown until
    enough, then bisected to 1 % of n (the count grows with the request).
    """
    from pydelatin import Delatin

    arr = _filled(depth, valid)

    def valid_count(ask):
        tin = Delatin(arr, max_error=0.0, max_points=int(ask))
        return _valid_vertex_count(delatin_mesh(tin, depth.shape), valid)

    lo, hi = int(n), int(n)
    limit = int(valid.size)
    while valid_count(hi) < n and hi < limit:
        lo, hi = hi, min(2 * hi, limit)
    ask = hi
    for _ in range(14):
        if hi - lo <= max(1, n // 100):
            break
        mid = (lo + hi) // 2
        if valid_count(mid) < n:
            lo = mid
        else:
            hi = mid
        ask = hi
    return arr, ask


def peer_delatin(depth, valid, n, repeat):
    """Greedy insertion (pydelatin), asked for the count that puts n vertices on valid pixels."""
    from pydelatin import Delatin

    arr, ask = delatin_request(depth, valid, n)
    tin, ms = _timed(lambda: Delatin(arr, max_error=0.0, max_points=ask), repeat)
    return delatin_mesh(tin, depth.shape), ms


def _grid_mesh(depth, valid):
    """Full-resolution mesh: two triangles per 2x2 block of valid pixels."""
    h, w = depth.shape
    idx = np.full((h, w), -1, np.int64)
    idx[valid] = np.arange(valid.sum())
    a, b, c, d = idx[:-1, :-1], idx[:-1, 1:], idx[1:, :-1], idx[1:, 1:]
    t1 = np.stack([a, c, b], -1).reshape(-1, 3)
    t2 = np.stack([b, c, d], -1).reshape(-1, 3)
    faces = np.concatenate([t1[(t1 >= 0).all(1)], t2[(t2 >= 0).all(1)]])
    r, cc = np.nonzero(valid)
    pts = np.c_[r, cc, depth[valid]].astype(np.float64)
    return pts, faces


def peer_quadric(depth, valid, n, repeat):
    """Quadric-error decimation (fast-simplification) of the full grid mesh down to n vertices.

    Depth is rescaled to a range of 100 (pixels keep their units) before
    decimation and back after: fast-simplification's collapse thresholds are
    absolute, and with raw depth units of thousands it stops long before the
    target. The request is corrected until the count lands within 2 %.
    """
    import fast_simplification

    pts, faces = _grid_mesh(depth, valid)
    lo = float(pts[:, 2].min())
    span = float(pts[:, 2].max()) - lo or 1.0
    scaled = pts.copy()
    scaled[:, 2] = (scaled[:, 2] - lo) * (100.0 / span)

    def run_at(target):
        reduction = max(0.0, min(1.0 - target / max(len(pts), 1), 0.99999))
        return fast_simplification.simplify(scaled, faces, target_reduction=reduction)

    target = float(n)
    for _ in range(3):
        p2, _f2 = run_at(target)
        if abs(len(p2) - n) <= 0.02 * n or len(p2) == 0:
            break
        target = max(4.0, target * n / len(p2))
    (p2, f2), ms = _timed(lambda: run_at(target), repeat)
    p2 = p2.copy()
    p2[:, 2] = p2[:, 2] * (span / 100.0) + lo
    return _mesh_from(p2, f2, depth.shape), ms


# per grid and peer, vertices minus half the faces at the last target that landed: the first
# guess for the next budget on the same grid (each decimation of a large grid takes seconds)
_OFFSETS: dict = {}


def face_target_search(decimate, n, n_faces, valid_count, repeat, tol=0.02, key=None):
    """``(output, ms)`` of the face target whose decimation puts n vertices on valid pixels.

    For the peers that take a face count. ``decimate(faces)`` returns ``(output,
    seconds of the decimation call alone)``; ``valid_count(output)`` its vertices
    on valid pixels. A triangulation of a disc has about twice as many faces as
    vertices, so each step moves the target by twice the vertices missing;
    it stops within `tol` of n, when a target repeats, or when fewer faces no
    longer give fewer vertices (a decimation that cannot go lower). A `key`
    (the grid and the peer) starts from the last landing's offset on that
    grid. The search is not timed: the call that landed is, and called
    `repeat` more times (median) when it took under half a second.
    """
    tried = {}
    target = min(max(int(round(2 * (n - _OFFSETS.get(key, 0.0)))), 4), n_faces)
    for _ in range(8):
        out, seconds = decimate(target)
        got = valid_count(out)
        tried[target] = (abs(got - n), out, seconds, got)
        if abs(got - n) <= tol * n:
            break
        nxt = min(max(int(round(target + 2 * (n - got))), 4), n_faces)
        stuck = [t for t, rec in tried.items() if t > target and rec[3] <= got]
        if nxt in tried or (got > n and stuck):
            break
        target = nxt
    target = min(tried, key=lambda t: tried[t][0])
    _, out, seconds, got = tried[target]
    if key is not None:
        _OFFSETS[key] = got - target / 2
    if seconds < 0.5:
        times = []
        for _ in range(repeat):
            out, seconds = decimate(target)
            times.append(seconds)
        seconds = statistics.median(times)
    return out, 1000.0 * seconds


def _counter(shape, valid):
    """Vertices on valid pixels of a decimation's ``(vertices, faces)``."""
    return lambda out: _valid_vertex_count(_mesh_from(out[0], out[1], shape), valid)


# MeshLab's settings for a range-image grid (the rest are MeshLab's defaults:
# optimalplacement on, preserveboundary off, qualitythr 0.3, planarquadric off, autoclean on)
MESHLAB_OPTIONS = dict(preservenormal=True, preservetopology=True)


def peer_meshlab(depth, valid, n, repeat):
    """MeshLab's quadric edge collapse (pymeshlab) of the full grid mesh, down to n vertices.

    Settings (`MESHLAB_OPTIONS`): ``preservenormal`` refuses collapses that
    flip a face, a fold-over in a height field (without it, vertices placed
    at the quadric's optimum slide across jumps: the synthetic box had 0.9-11 %
    mean error at 700 vertices, 0 with it and ``preservetopology``);
    ``preservetopology`` refuses collapses that close a hole or join surfaces
    across missing depth. ``preserveboundary`` stays off: it freezes every
    vertex of the image border and of the rims of missing depth, so the count
    cannot go below theirs (277 on a 60 x 80 plane), out of reach of 1-3 %
    budgets; the pixels a shrunk border leaves uncovered are reported
    (``uncovered``). ``optimalplacement`` stays on: without it the border is
    frozen the same way. ``planarquadric`` stays off: it spends vertices on
    the shape of triangles in flat parts, not on the error. Depth keeps its
    units: with a face target the filter has no absolute threshold (quality
    and normal checks are ratios and angles). Timed: the decimation call
    alone (building the MeshSet is not).
    """
    import pymeshlab

    pts, faces = _grid_mesh(depth, valid)
    faces = faces.astype(np.int32)

    def decimate(target):
        ms = pymeshlab.MeshSet()
        ms.add_mesh(pymeshlab.Mesh(pts, faces))
        t = time.perf_counter()
        ms.meshing_decimation_quadric_edge_collapse(targetfacenum=int(target), **MESHLAB_OPTIONS)
        seconds = time.perf_counter() - t
        m = ms.current_mesh()
        return (m.vertex_matrix(), m.face_matrix()), seconds

    key = ("meshlab", depth.shape, hash(valid.tobytes()), hash(pts[:, 2].tobytes()))
    (v, f), ms = face_target_search(decimate, n, len(faces), _counter(depth.shape, valid), repeat,
                                    key=key)
    return _mesh_from(v, f, depth.shape), ms


def peer_open3d(depth, valid, n, repeat):
    """Open3D's ``simplify_quadric_decimation`` of the full grid mesh, down to n vertices.

    Open3D's defaults: no error bound (``maximum_error`` infinite) and
    ``boundary_weight`` 1 (its only other option). Depth keeps its units: with
    no error bound nothing in it is absolute. Timed: the decimation call
    alone (building the TriangleMesh is not).
    """
    import open3d as o3d

    pts, faces = _grid_mesh(depth, valid)
    grid = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(pts),
                                     o3d.utility.Vector3iVector(faces.astype(np.int32)))

    def decimate(target):
        t = time.perf_counter()
        out = grid.simplify_quadric_decimation(target_number_of_triangles=int(target))
        seconds = time.perf_counter() - t
        return (np.asarray(out.vertices), np.asarray(out.triangles)), seconds

    key = ("open3d", depth.shape, hash(valid.tobytes()), hash(pts[:, 2].tobytes()))
    (v, f), ms = face_target_search(decimate, n, len(faces), _counter(depth.shape, valid), repeat,
                                    key=key)
    return _mesh_from(v, f, depth.shape), ms


def peer_martini(depth, valid, n, repeat):
    """RTIN (pymartini) on the image padded to 2**k + 1, at the error giving the nearest count."""
    from pymartini import Martini

    h, w = depth.shape
    size = 2 ** math.ceil(math.log2(max(h, w) - 1)) + 1
    arr = np.pad(_filled(depth, valid), ((0, size - h), (0, size - w)), mode="edge")

    def mesh_at(err):
        tile = Martini(size).create_tile(arr)
        return tile.get_mesh(err)

    tile = Martini(size).create_tile(arr)  # get_mesh is cheap: search the threshold on one tile
    lo, hi = 0.0, float(arr.max() - arr.min()) + 1.0
    best = None
    for _ in range(30):  # bisection on the error threshold for the count on valid pixels
        mid = 0.5 * (lo + hi)
        v, t = tile.get_mesh(mid)
        inside = _martini_valid(v, valid)
        if best is None or abs(inside - n) < abs(best[1] - n):
            best = (mid, inside)
        if inside > n:
            lo = mid
        else:
            hi = mid
    (v, t), ms = _timed(lambda: mesh_at(best[0]), repeat)
    v = np.asarray(v, np.int64).reshape(-1, 2)
    t = np.asarray(t, np.int64).reshape(-1, 3)
    c, r = v[:, 0], v[:, 1]
    # keep triangles inside the image; the padding is not part of the scene
    keep = ((r[t] < h) & (c[t] < w)).all(axis=1)
    t = t[keep]
    used = np.unique(t)
    remap = np.full(len(v), -1)
    remap[used] = np.arange(used.size)
    rcz = np.c_[r[used], c[used], arr[r[used], c[used]]]
    return _mesh_from(rcz, remap[t], depth.shape, np.c_[r[used], c[used]]), ms


def _martini_valid(v, valid):
    """Martini vertices (x, y) that fall on a valid pixel of the unpadded image."""
    h, w = valid.shape
    v = np.asarray(v).reshape(-1, 2).astype(np.int64)
    inside = (v[:, 0] < w) & (v[:, 1] < h)
    v = v[inside]
    return int(valid[v[:, 1], v[:, 0]].sum())


PEERS = [
    ("pydelatin greedy insertion", "pydelatin", peer_delatin),
    ("fast-simplification quadric decimation", "fast_simplification", peer_quadric),
    ("MeshLab quadric edge collapse", "pymeshlab", peer_meshlab),
    ("Open3D quadric decimation", "open3d", peer_open3d),
    ("pymartini RTIN", "pymartini", peer_martini),
]
# what to install for each peer's module
EXTRA = {"open3d": "pip install 'rangemesh[open3d]'"}
# the peers drawn beside ours in the figure
FIGURE_PEERS = ("pydelatin greedy insertion", "fast-simplification quadric decimation",
                "MeshLab quadric edge collapse")


# ---------------------------------------------------------------- inputs


def find_data(data: Path | None) -> Path | None:
    """The shared images: `data` if given, else shared/data beside the repository, if any."""
    if data is None:
        repo = Path(__file__).resolve().parents[1]
        for cand in (repo.parent / "shared" / "data", repo / "shared" / "data",
                     Path.cwd().parent / "shared" / "data"):
            if cand.is_dir():
                data = cand
                break
    if data is None or not data.is_dir():
        print("no shared/data folder found: synthetic scenes only (use --data)", file=sys.stderr)
        return None
    return data


def add_image_options(ap) -> None:
    """``--data`` and ``--only`` (repeatable) of the scripts that run over the shared images."""
    ap.add_argument("--data", type=Path, default=None, help="the shared data folder")
    ap.add_argument("--only", action="append", default=[],
                    help="images whose name holds this (repeatable)")


def selected_images(args) -> tuple[Path | None, list[Image]]:
    """The data folder and the images (scenes included) that `add_image_options` selected."""
    data = find_data(args.data)
    images, _ = load_images(data, False)
    chosen = [im for im in images if not args.only or any(o in im.name for o in args.only)]
    if not chosen:  # an empty table would look like a run that measured nothing
        raise SystemExit(f"no image or scene name contains any of {args.only}; names: "
                         + ", ".join(im.name for im in images))
    return data, chosen


def load_images(data: Path | None, quick: bool,
                only: str | None = None) -> tuple[list[Image], list[str]]:
    """Real images that load, then synthetic scenes with exact discontinuities.

    `only`: keep the inputs whose name contains this text (no scene unless it matches).
    """
    out, skipped = [], []
    if data is not None:
        for rel, bg, note in IMAGES:
            if (quick and rel not in QUICK_IMAGES) or (only and only not in rel):
                continue
            path = data / rel
            try:
                img = read_range_image(path)
            except (OSError, ValueError) as exc:
                skipped.append(f"{rel}: {exc}")
                continue
            d, v = to_depth_and_mask(img, bg)
            out.append(Image(Path(rel).name, img, bg, note, discontinuity_mask(d, v)))
    for name, noise in (QUICK_SCENES if quick else SCENES):
        if only and only not in f"synthetic {name}":
            continue
        sc = scenes.make(name, (160, 200), noise=noise)
        label = f"synthetic {name}" + (f" noise {noise}" if noise else "")
        out.append(Image(label, sc.depth, None, sc.description, sc.discontinuities))
    return out, skipped


# ---------------------------------------------------------------- the run


def filled_error(mesh, depth, valid):
    """The relative error with every valid pixel counted (% of the valid depth range, mean).

    A valid pixel no triangle covers is charged with the mesh depth of the nearest covered
    pixel (issue 44; the quality-levers study's "rel. error filled"): an error over the
    covered pixels alone flatters a mesh that leaves pixels out. NaN when none is covered.
    """
    pred = render_depth(mesh, depth.shape)[0]
    covered = np.isfinite(pred)
    if not covered.any():
        return float("nan")
    if not covered[valid].all():
        _, (ri, ci) = ndimage.distance_transform_edt(~covered, return_indices=True)
        pred = pred[ri, ci]
    d = depth[valid]
    span = float(d.max() - d.min())
    err = float(np.mean(np.abs(d - pred[valid])))
    return 100.0 * err / span if span > 0 else err * 0.0


def _record(image, budget, method, mesh, ms, valid):
    e = evaluate(mesh, image.depth, background=image.background,
                 discontinuities=image.discontinuities)
    masked, ok = to_depth_and_mask(image.depth, image.background)
    return {
        "image": image.name, "budget": budget, "method": method,
        "vertices": _valid_vertex_count(mesh, valid), "triangles": int(len(mesh.faces)),
        "ms": ms, "relative_error": e.relative_error, "rms_error": e.rms_error,
        "max_error": e.max_error, "uncovered": e.uncovered, "edge_band_error": e.edge_band_error,
        "filled_error": filled_error(mesh, masked, ok),
    }


def run(images, budgets, repeat, peers=True, log=print, best=False):
    """Mesh every image at every budget with every method; returns (rows, skipped peers).

    `peers`: True for every peer, False for none, or the modules of those to run; `best`:
    refine's effort="best" too (`BEST`).
    """
    rows = []
    available, skipped = [], []
    chosen = [p for p in PEERS if peers is True or (peers and p[1] in peers)]
    for label, module, fn in chosen:
        try:
            __import__(module)
            available.append((label, fn))
        except (ImportError, OSError) as exc:  # Open3D without libusb raises OSError
            how = EXTRA.get(module, "pip install 'rangemesh[bench]'")
            skipped.append(f"{label}: {module} cannot be imported ({exc}; {how})")
    for image in images:
        masked, valid = to_depth_and_mask(image.depth, image.background)
        for budget in budgets:
            if isinstance(budget, float):  # a share of the valid pixels
                kw = {"vertices": max(int(budget * valid.sum()), MIN_VERTICES)}
                bname = f"{budget:.0%} of valid pixels"
            elif isinstance(budget, int):
                kw, bname = {"vertices": budget}, f"~{budget} vertices"
            else:
                kw = {"tiles": (4, 4), "samples": budget}
                bname = f"4x4 tiles, {budget[0]}x{budget[1]} samples"
            n = None
            for label, opts in OURS + ([BEST] if best else []):
                # method="refine" takes a vertex count: the paper's, as the peers get
                kw_m = {"vertices": n} if opts.get("method") == "refine" else kw
                mesh, ms = _timed(lambda opts=opts, kw=kw_m, image=image: triangulate(
                    image.depth, background=image.background, **opts, **kw), repeat)
                rows.append(_record(image, bname, label, mesh, ms, valid))
                if n is None:
                    n = max(rows[-1]["vertices"], 4)
            for label, fn in available:
                try:
                    mesh, ms = fn(masked, valid, n, repeat)
                except Exception as exc:  # a peer's failure must not stop the benchmark
                    skipped.append(f"{label} on {image.name} ({bname}): {type(exc).__name__}: {exc}")
                    continue
                rows.append(_record(image, bname, label, mesh, ms, valid))
            log(f"done {image.name}, {bname}")
    return rows, skipped


def markdown_tables(rows):
    """One markdown table per image, then the summary."""
    out = []
    for name in dict.fromkeys(r["image"] for r in rows):
        out.append(f"\n### {name}\n")
        out.append("| budget | method | vertices | ms | rel. error % | filled % | edge band % "
                   "| RMS % | max % | uncovered % |")
        out.append("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
        for r in rows:
            if r["image"] == name:
                out.append(f"| {r['budget']} | {r['method']} | {r['vertices']} | {r['ms']:.2f} "
                           f"| {r['relative_error']:.4f} | {r['filled_error']:.4f} "
                           f"| {r['edge_band_error']:.4f} "
                           f"| {r['rms_error']:.4f} | {r['max_error']:.2f} | {r['uncovered']:.2f} |")
    out.append("\n" + summary_table(rows))
    out.append("\n" + peer_table(rows))
    out.append("\n" + peer_table(rows, by_budget=True))
    for mine in ("rangemesh refine", BEST[0]):
        if any(r["method"] == mine for r in rows):
            out.append("\n" + best_peer_table(rows, mine))
    return "\n".join(out)


def best_peer_table(rows, mine):
    """Per case, `mine`'s filled error over the best peer's (issue 44's error target).

    The best peer of a case is the peer (`PEERS`) with the lowest filled error among those
    within 5 % of `mine`'s vertex count; the median and the worst ratio over cases, and the
    cases above 1 (lost), worst first.
    """
    peers = {p[0] for p in PEERS}
    by_case = {}
    for r in rows:
        by_case.setdefault((r["image"], r["budget"]), {})[r["method"]] = r
    ratios = []
    for case, c in by_case.items():
        if mine not in c:
            continue
        n = c[mine]["vertices"]
        near = [r["filled_error"] for m, r in c.items()
                if m in peers and abs(r["vertices"] - n) <= 0.05 * n and np.isfinite(r["filled_error"])]
        if near and min(near) > 0:
            ratios.append((c[mine]["filled_error"] / min(near), case))
        elif near:
            ratios.append((0.0 if c[mine]["filled_error"] == 0 else math.inf, case))
    if not ratios:
        return f"### {mine} against the best peer: no case with a peer at its count"
    ratios.sort(reverse=True)
    values = [x for x, _ in ratios]
    lost = [f"{name} ({budget}) {x:.2f}x" for x, (name, budget) in ratios if x > 1.0]
    return "\n".join([
        f"### {mine} against the best peer per case (filled error ratio; below 1: lower for us)\n",
        "| cases | median ratio | worst ratio | cases above 1 |",
        "|---:|---:|---:|---:|",
        f"| {len(values)} | {statistics.median(values):.3f} | {values[0]:.3f} | {len(lost)} |",
        "\nLost: " + ("; ".join(lost) if lost else "none")])


def peer_table(rows, mine="rangemesh refine", by_budget=False):
    """Medians over cases of `mine`'s figures divided by each other method's, same case.

    With `by_budget`, one line per method and budget, for the paper's method and the peers.
    """
    by_case = {}
    for r in rows:
        by_case.setdefault((r["image"], r["budget"]), {})[r["method"]] = r
    others = [m for m in dict.fromkeys(r["method"] for r in rows) if m != mine]
    budgets = [None]
    if by_budget:
        others = [m for m in others if m == OURS[0][0] or m in {p[0] for p in PEERS}]
        budgets = list(dict.fromkeys(r["budget"] for r in rows))
    lines = [f"### {mine} against each method{', by budget' if by_budget else ''} (medians "
             "over cases of ratios, same image and budget; below 1: lower for us)\n",
             f"| against |{' budget |' if by_budget else ''} cases | rel. error ratio "
             "| edge-band ratio | time ratio |",
             f"|---|{'---|' if by_budget else ''}---:|---:|---:|---:|"]
    for other in others:
        for budget in budgets:
            pairs = [(c[mine], c[other]) for (_, b), c in by_case.items()
                     if mine in c and other in c and budget in (None, b)]

            def ratio(key, pairs=pairs):
                vals = [a[key] / b[key] for a, b in pairs
                        if b[key] > 0 and np.isfinite(a[key]) and np.isfinite(b[key])]
                return statistics.median(vals) if vals else float("nan")

            lines.append(f"| {other} |{f' {budget} |' if by_budget else ''} {len(pairs)} "
                         f"| {ratio('relative_error'):.3f} | {ratio('edge_band_error'):.3f} "
                         f"| {ratio('ms'):.3g} |")
    return "\n".join(lines)


def summary_table(rows):
    """Per method, medians over all (image, budget) cases of errors and time relative to the paper's."""
    ref = {(r["image"], r["budget"]): r for r in rows if r["method"] == OURS[0][0]}
    methods = list(dict.fromkeys(r["method"] for r in rows))
    lines = ["### summary (medians over every image and budget; ratios to the paper's method, "
             "same case)\n",
             "| method | cases | rel. error ratio | edge-band ratio | time ratio | wins on rel. error "
             "| wins on edge band | median ms |",
             "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for m in methods:
        everyone = [r for r in rows if r["method"] == m and (r["image"], r["budget"]) in ref]
        # compare at equal vertex counts only: within 10 % of the paper's count
        mine = [r for r in everyone
                if abs(r["vertices"] - ref[(r["image"], r["budget"])]["vertices"])
                <= 0.1 * ref[(r["image"], r["budget"])]["vertices"]]
        if not mine:
            lines.append(f"| {m} | 0 of {len(everyone)} | | | | | | |")
            continue

        def ratios(key, mine=mine):
            vals = [r[key] / ref[(r["image"], r["budget"])][key] for r in mine
                    if ref[(r["image"], r["budget"])][key] > 0 and np.isfinite(r[key])]
            return statistics.median(vals) if vals else float("nan")

        wins_e = sum(r["relative_error"] < ref[(r["image"], r["budget"])]["relative_error"]
                     for r in mine)
        wins_b = sum(r["edge_band_error"] < ref[(r["image"], r["budget"])]["edge_band_error"]
                     for r in mine)
        lines.append(f"| {m} | {len(mine)} of {len(everyone)} | {ratios('relative_error'):.3f} "
                     f"| {ratios('edge_band_error'):.3f} | {ratios('ms'):.2f} "
                     f"| {wins_e}/{len(mine)} | {wins_b}/{len(mine)} "
                     f"| {statistics.median(r['ms'] for r in mine):.2f} |")
    lines.append("\nA ratio below 1 means lower than the paper's method (adaptive + disparity flips) "
                 "on the same image at the same budget; 'wins' counts the cases where the method's "
                 "error is lower than the paper's. Only cases where the method's vertex count (on "
                 "valid pixels) is within 10 % of the paper's are compared; 'cases' says how many "
                 "of all were.")
    return "\n".join(lines)


def figure(images, out_png, n=1500, modules=None):
    """Fig. 10/11-like: method="refine", the paper's method and `FIGURE_PEERS`, same count.

    `modules`: the peers' modules to draw (default every one of `FIGURE_PEERS`).
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    from rangemesh.preview import shade

    columns = 2 + len(FIGURE_PEERS)
    fig = Figure(figsize=(4 * columns, 4.3 * len(images)), dpi=90, layout="constrained")
    axes = fig.subplots(len(images), columns, squeeze=False)
    for row, image in zip(axes, images, strict=True):
        d, valid = to_depth_and_mask(image.depth, image.background)
        ours = triangulate(image.depth, background=image.background, vertices=n, method="paper")
        n_ours = _valid_vertex_count(ours, valid)
        cands = [("rangemesh refine (default)", triangulate(
                     image.depth, background=image.background, vertices=n_ours)),
                 ("rangemesh paper", ours)]
        for label, module, fn in PEERS:
            if label not in FIGURE_PEERS or (modules is not None and module not in modules):
                continue
            try:
                __import__(module)
            except (ImportError, OSError):
                continue
            cands.append((label, fn(d, valid, n_ours, 1)[0]))
        for ax, (label, mesh) in zip(row, cands, strict=False):
            e = evaluate(mesh, image.depth, background=image.background,
                         discontinuities=image.discontinuities)
            s = shade(mesh, d.shape)
            ax.imshow(s, cmap=matplotlib.colormaps["gray"].with_extremes(bad="black"), vmin=0, vmax=1)
            if len(mesh.pixels) == len(mesh.vertices) and len(mesh.pixels):
                r, c = mesh.pixels[:, 0], mesh.pixels[:, 1]
            else:
                r, c = mesh.vertices[:, 0], mesh.vertices[:, 1]
            ax.triplot(c, r, mesh.faces, lw=0.25, color="tab:orange", alpha=0.7)
            short = Path(image.name).stem[:24]
            ax.set_title(f"{short}: {label}\n{_valid_vertex_count(mesh, valid)} vertices, "
                         f"error {e.relative_error:.3f} %, edge band {e.edge_band_error:.3f} %",
                         fontsize=9)
            ax.set_xticks([])
            ax.set_yticks([])
        for ax in row[len(cands):]:
            ax.axis("off")
    fig.savefig(out_png)


def main(argv=None) -> int:
    """Command line of the benchmark; returns the exit status."""
    ap = argparse.ArgumentParser(prog="python benchmarks/peers.py",
                                 description="rangemesh against the paper's baselines and today's peers.")
    ap.add_argument("--data", type=Path, default=None,
                    help="folder of the shared images (default: shared/data beside the repository)")
    ap.add_argument("--out", type=Path, default=Path("bench-results"),
                    help="folder for results.csv, results.json, results.md, figure.png")
    ap.add_argument("--quick", action="store_true",
                    help="3 real images, 2 scenes, 2 budgets, 1 repeat (about a minute)")
    ap.add_argument("--repeat", type=positive_int, default=None,
                    help="timed calls per case (default 5; 1 quick)")
    ap.add_argument("--budgets", choices=["paper", "fractions", "all"], default="paper",
                    help="the paper's four grids and ~5000 vertices (default), 1, 3 and 10 %% "
                         "of the valid pixels, or both")
    ap.add_argument("--no-peers", action="store_true", help="rangemesh variants only")
    ap.add_argument("--peers", nargs="+", choices=[m for _, m, _ in PEERS], default=None,
                    metavar="MODULE", help="only these peers, by module: "
                    + ", ".join(m for _, m, _ in PEERS) + " (default: all)")
    ap.add_argument("--no-figure", action="store_true", help="skip the figure")
    ap.add_argument("--best", action="store_true",
                    help="also method='refine' with effort='best', a row of its own (several "
                         "times refine's time)")
    ap.add_argument("--only", default=None, metavar="TEXT",
                    help="only the inputs whose name contains TEXT (e.g. rellis3d)")
    args = ap.parse_args(argv)
    data = find_data(args.data)
    repeat = args.repeat or (1 if args.quick else 5)
    budgets = {"paper": PAPER_BUDGETS + [5000], "fractions": list(FRACTIONS),
               "all": PAPER_BUDGETS + [5000, *FRACTIONS]}[args.budgets]
    if args.quick:
        budgets = [(5, 5), 5000]
    images, skipped_images = load_images(data, args.quick, args.only)
    t0 = time.perf_counter()
    peers = False if args.no_peers else (args.peers or True)
    rows, skipped = run(images, budgets, repeat, peers=peers,
                        log=lambda s: print(s, file=sys.stderr), best=args.best)
    args.out.mkdir(parents=True, exist_ok=True)
    with open(args.out / "results.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    (args.out / "results.json").write_text(json.dumps(
        {"rows": rows, "skipped": skipped + skipped_images, "repeat": repeat,
         "seconds": time.perf_counter() - t0}, indent=1, default=float))
    text = markdown_tables(rows)
    if skipped or skipped_images:
        text += "\n\nSkipped:\n" + "\n".join(f"- {s}" for s in skipped + skipped_images)
    (args.out / "results.md").write_text(text + "\n")
    print(text)
    if not args.no_figure:
        picks = [im for im in images if im.name in ("venus_disp2.npy",
                 "pcl_grabber_frame_20121214T142255.814212_depth.tiff")] or images[:2]
        figure(picks[:2], args.out / "figure.png", modules=args.peers)
        print(f"\nfigure: {args.out / 'figure.png'}", file=sys.stderr)
    print(f"total {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
