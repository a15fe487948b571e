"""Ask for the result, not the grid: a vertex count, an error bound, an edge length.

The paper fixes the sample grid (tiles x samples per tile). These functions
choose that grid for the user, on top of the paper's method: the grid is
still the paper's grid, only its size is searched. The sampling weights are
computed once per image and reused by every try; counting the distinct valid
samples of a candidate grid runs only stage one's kernel (well under a
millisecond), so most candidates are judged without meshing.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..mesh import Mesh
from ..params import MeshParams
from ..render import relative_error
from ..timing import timed
from .flipping import flip_edges
from .sampling import max_grid_entries, sample_grid, sampling_weights
from .stages import mesh_grid, refine_to_edge

__all__ = ["auto_tiles", "fit_vertices", "fit_error", "fit_edge", "count_samples"]

# The paper's running example has 10 samples per tile side; keep tiles about that full.
_SAMPLES_PER_TILE = 10
_TOLERANCE = 0.02


def auto_tiles(shape: tuple[int, int], grid: tuple[float, float]) -> tuple[int, int]:
    """A tile layout for a grid of about ``grid`` points: about 10 samples per tile side.

    Parameters
    ----------
    shape : (int, int)
        Image shape.
    grid : (float, float)
        Wanted grid shape (rows, columns of samples).

    Returns
    -------
    (int, int)
        Tiles ``(V, H)``, each at least 1 and leaving tiles at least 2 pixels thick.

    Examples
    --------
    >>> auto_tiles((188, 208), (37, 37))   # the paper's example: 4 x 4 tiles
    (4, 4)
    """
    out = []
    for n, g in zip(shape, grid, strict=True):
        t = int(round((g - 1) / (_SAMPLES_PER_TILE - 1)))
        out.append(max(1, min(t, n - 1)))
    return out[0], out[1]


def count_samples(depth, valid, params: MeshParams, weights) -> int:
    """Distinct valid pixels in the sample grid of `params` (stage one only)."""
    grid = sample_grid(depth, valid, params, weights=weights)
    w = depth.shape[1]
    lin = np.unique(grid[..., 0].astype(np.int64) * w + grid[..., 1])
    return int(valid.ravel()[lin].sum())


def _grid_for(shape, n_points):
    """Grid (rows, cols) with about n_points samples and the image's aspect."""
    h, w = shape
    aspect = max(h - 1, 1) / max(w - 1, 1)
    gc = math.sqrt(max(n_points, 4.0) / aspect)
    return max(aspect * gc, 2.0), max(gc, 2.0)


def _candidates(shape, target_points, tiles):
    """(tiles, samples) pairs whose grid size brackets target_points, aspect kept."""
    h, w = shape
    gr0, gc0 = _grid_for(shape, target_points)
    if tiles is None:
        v0, h0 = auto_tiles(shape, (gr0, gc0))
        tile_opts = [(v, t) for v in (v0 - 1, v0, v0 + 1) for t in (h0 - 1, h0, h0 + 1)
                     if 1 <= v <= h - 1 and 1 <= t <= w - 1]
    else:
        tile_opts = [tuple(tiles)]
    out = set()
    limit = max_grid_entries(shape)
    for v, t in tile_opts:
        rs0 = (gr0 - 1) / v + 1
        z0 = (gc0 - 1) / t + 1
        for rs in {math.floor(rs0) - 1, math.floor(rs0), math.ceil(rs0), math.ceil(rs0) + 1}:
            for z in {math.floor(z0) - 1, math.floor(z0), math.ceil(z0), math.ceil(z0) + 1}:
                # sample_grid refuses grids larger than max_grid_entries
                if rs >= 2 and z >= 2 and ((rs - 1) * v + 1) * ((z - 1) * t + 1) <= limit:
                    out.add(((v, t), (rs, z)))
    return sorted(out)


def _choose_grid(depth, valid, params, weights, target, tiles, frac):
    """The candidate grid whose distinct valid sample count is closest to `target`."""
    shape = depth.shape
    cands = _candidates(shape, target / max(frac, 1e-9), tiles)
    aspect = math.log(max(shape[0] - 1, 1) / max(shape[1] - 1, 1))

    def grid_dims(c):
        (v, t), (rs, z) = c
        return (rs - 1) * v + 1, (z - 1) * t + 1

    def estimate(c):
        gr, gc = grid_dims(c)
        return abs(math.log(frac * gr * gc / target))

    # Judge the closest few by estimate exactly, by counting their valid samples.
    cands.sort(key=lambda c: (estimate(c), c))
    best = None
    for c in cands[:12]:
        p = params.replace(tiles=c[0], samples=c[1])
        n = count_samples(depth, valid, p, weights)
        gr, gc = grid_dims(c)
        key = (abs(math.log(max(n, 1) / target)), abs(math.log((gr - 1) / (gc - 1)) - aspect), c)
        if best is None or key < best[0]:
            best = (key, c, n)
    return best[1][0], best[1][1], best[2]


def _full_resolution(depth, valid, params, camera):
    h, w = depth.shape
    p = params.replace(tiles=(1, 1), samples=(h, w), sampling="uniform")
    return mesh_grid(depth, valid, p, camera), p


def _target_record(kind, requested, achieved, p, meshings, ok, note="", **extra):
    rec = {"target": kind, "requested": requested, "achieved": achieved,
           "tiles": list(p.tiles), "samples": list(p.samples), "meshings": meshings,
           "met": bool(ok)}
    rec.update(extra)
    if note:
        rec["note"] = note
    return rec


def fit_vertices(depth, valid, params: MeshParams, camera, n: int, *,
                 tiles=None) -> tuple[Mesh, dict]:
    """Mesh with a grid chosen so that the final vertex count is within 2 % of `n`.

    Parameters
    ----------
    depth, valid : (H, W) ndarrays
        Prepared image (`rangemesh.pipeline.prepare`).
    params : MeshParams
        Everything but tiles and samples is kept. With ``max_edge``, every try
        is refined until no edge is longer (see `rangemesh.paper.stages.refine_to_edge`).
    camera : Orthographic or Pinhole
    n : int
        Vertices wanted.
    tiles : (int, int), optional
        Keep these tiles; default: about 10 samples per tile side, tiles
        following the image's aspect (non-square images get non-square grids).

    Returns
    -------
    mesh : Mesh
    target : dict
        ``requested``, ``achieved``, ``met`` (within 2 %), ``tiles``,
        ``samples``, ``meshings`` and a ``note`` when 2 % was out of reach.

    Notes
    -----
    The vertex count is the number of distinct valid samples less the few
    lost with dangling triangles. Candidate grids around the wanted size (tile
    counts within one of the automatic choice, samples within two of the
    estimate) are judged by counting their distinct valid samples exactly;
    the best is meshed, and if the mesh misses by more than 2 % the target is
    corrected by the ratio seen and the search repeated (at most 4 meshings).
    More vertices than valid pixels cannot be had: the image is then meshed
    at full resolution (every valid pixel a vertex) and the note says so.
    """
    n_valid = int(valid.sum())
    weights = sampling_weights(depth, valid, params)
    if n >= n_valid:
        mesh, p = _full_resolution(depth, valid, params, camera)
        got = mesh.stats.vertices
        ok = abs(got - n) <= _TOLERANCE * n
        note = "" if ok else (f"the image has only {n_valid} valid pixels: meshed at full "
                              f"resolution, every valid pixel a vertex")
        return mesh, _target_record("vertices", n, got, p, 1, ok, note)
    frac = n_valid / valid.size
    target = float(n)
    best = None
    seen = set()
    meshings = 0
    for _ in range(4):
        t, s, _count = _choose_grid(depth, valid, params, weights, target, tiles, frac)
        if (t, s) in seen:
            break
        seen.add((t, s))
        p = params.replace(tiles=t, samples=s)
        mesh = mesh_grid(depth, valid, p, camera, weights=weights)
        meshings += 1
        got = mesh.stats.vertices
        if best is None or abs(got - n) < abs(best[0].stats.vertices - n):
            best = (mesh, p)
        if abs(got - n) <= _TOLERANCE * n or got == 0:
            break
        target *= n / got
    mesh, p = best
    got = mesh.stats.vertices
    ok = abs(got - n) <= _TOLERANCE * n
    if ok:
        note = ""
    elif params.max_edge is not None and got > n:
        note = (f"max_edge={params.max_edge:g} needs more vertices than {n} on this image: "
                f"the closest mesh found with no edge longer has {got}")
    else:
        note = (f"closest grid gives {got} vertices; the grid's steps are coarser than "
                f"2 % of {n} on this image")
    return mesh, _target_record("vertices", n, got, p, meshings, ok, note)


def fit_error(depth, valid, params: MeshParams, camera, max_error: float, ref_depth, ref_valid,
              *, tiles=None, max_meshings: int = 6) -> tuple[Mesh, dict]:
    """The smallest grid whose mesh has a relative error of at most `max_error` percent.

    Parameters
    ----------
    depth, valid : (H, W) ndarrays
        Prepared image (gap-filled).
    params : MeshParams
    camera : Orthographic or Pinhole
    max_error : float
        Bound on the paper's relative error, percent (as `evaluate` computes it).
    ref_depth, ref_valid : (H, W) ndarrays
        The original image the error is measured against (not gap-filled).
    tiles
        As for `fit_vertices`.
    max_meshings : int, default 6
        Most full meshings the search may spend.

    Returns
    -------
    mesh : Mesh
    target : dict
        ``requested``, ``achieved`` (the error), ``vertices``, ``met``,
        ``tiles``, ``samples``, ``meshings``.

    Notes
    -----
    The error falls roughly as a power of the number of samples. The search
    models it as ``e = a * n**-alpha`` in log-log space: it starts at the
    paper's 37 x 37 grid, jumps by that model (alpha = 1 until two tries
    measure it), then keeps the largest grid found too coarse and the
    smallest found fine enough and interpolates between them until they are
    within 5 % of each other. Each try is one full meshing and one
    evaluation; the sampling weights are computed once. At full resolution
    the error is 0, so the bound can always be met; if the tries run out
    first, the smallest grid seen that meets it is returned.
    """
    n_valid = int(valid.sum())
    frac = n_valid / valid.size
    weights = sampling_weights(depth, valid, params)
    tries = []  # (distinct samples, error, mesh, params)

    def attempt(target):
        target = min(max(target, 9.0), float(n_valid))
        if target >= n_valid:
            mesh, p = _full_resolution(depth, valid, params, camera)
            count = n_valid
        else:
            t, s, count = _choose_grid(depth, valid, params, weights, target, tiles, frac)
            p = params.replace(tiles=t, samples=s)
            mesh = mesh_grid(depth, valid, p, camera, weights=weights)
        err = relative_error(mesh, ref_depth, ref_valid) if not mesh.is_empty else math.inf
        tries.append((count, err, mesh, p))
        return count, err

    target = min(float(n_valid), 37.0 * 37.0 * frac)
    alpha = 1.0
    for _ in range(max_meshings):
        attempt(target)
        good = [x for x in tries if x[1] <= max_error]
        bad = [x for x in tries if x[1] > max_error]
        lo = max(bad, key=lambda x: x[0]) if bad else None
        hi = min(good, key=lambda x: x[0]) if good else None
        if lo and hi and hi[0] <= lo[0] * 1.05:
            break
        if hi is not None and hi[0] <= 9:
            break
        if lo is not None and lo[0] >= n_valid:
            break
        pts = sorted({(x[0], x[1]) for x in tries if 0 < x[1] < math.inf and x[0] > 0})
        if len(pts) >= 2:
            (n1, e1), (n2, e2) = pts[-2], pts[-1]
            if n1 != n2 and e1 > 0 and e2 > 0 and e1 != e2:
                alpha = min(max(-math.log(e2 / e1) / math.log(n2 / n1), 0.25), 3.0)
        aim = 0.97 * max_error
        if lo and hi:
            if math.isfinite(lo[1]) and hi[1] > 0 and lo[1] > hi[1]:
                # interpolate in log-log between the bracket ends
                f = math.log(lo[1] / aim) / math.log(lo[1] / hi[1])
                nxt = math.exp(math.log(lo[0]) + f * (math.log(hi[0]) - math.log(lo[0])))
            else:
                nxt = math.sqrt(lo[0] * hi[0])
            nxt = min(max(nxt, lo[0] * 1.01), hi[0] * 0.99)
        else:
            count, err = tries[-1][0], tries[-1][1]
            if err == 0:
                nxt = count / 2.0
            elif not math.isfinite(err):
                nxt = count * 2.0
            else:
                nxt = count * (err / aim) ** (1.0 / alpha)
                if err > max_error:
                    nxt = max(nxt, count * 1.1)
                else:
                    nxt = min(nxt, count * 0.9)
        if lo is None and hi is None:
            break
        target = nxt
    good = [x for x in tries if x[1] <= max_error]
    note = ""
    if good:
        count, err, mesh, p = min(good, key=lambda x: (x[0], x[1]))
    else:
        mesh, p = _full_resolution(depth, valid, params, camera)
        err = relative_error(mesh, ref_depth, ref_valid)
        tries.append((n_valid, err, mesh, p))
        note = "no grid tried met the bound; meshed at full resolution"
    met = err <= max_error
    return mesh, _target_record("max_error", max_error, err, p, len(tries), met, note,
                                vertices=mesh.stats.vertices)


def fit_edge(depth, valid, params: MeshParams, camera, *, tiles=None) -> tuple[Mesh, dict]:
    """Mesh so that no triangle edge is longer than `max_edge` pixels in the image plane.

    Parameters
    ----------
    depth, valid : (H, W) ndarrays
        Prepared image.
    params : MeshParams
        ``max_edge`` is the longest edge allowed in the image plane, pixels.
    camera : Orthographic or Pinhole
    tiles : (int, int), optional
        Default: the tiles of `params`.

    Returns
    -------
    mesh : Mesh
    target : dict

    Notes
    -----
    How the bound is met:

    1. samples per tile are chosen so that a uniform grid would have cells
       with sides of ``max_edge / sqrt(2)``; the adaptive grid spreads them
       by curvature as usual;
    2. the Delaunay mesh of those samples is refined where needed: every
       edge longer than `max_edge` gets the valid pixels that cut it into
       pieces of at most 0.9 `max_edge`, and the valid pixels where it enters
       or leaves background, added as samples; Delaunay is run again (up to
       6 rounds);
    3. a triangle that still has a longer edge (it spans background, so no
       valid pixel can cut it) is removed before pruning; its area stays
       uncovered (`evaluate` reports it);
    4. a flip whose new edge would be longer is refused.

    The bound therefore holds for every edge of the result, and vertices are
    added only where the adaptive grid was too sparse for it.
    """
    max_edge = params.max_edge
    if max_edge is None:
        raise ValueError("fit_edge needs params.max_edge")
    h, w = depth.shape
    tiles = tuple(tiles) if tiles is not None else params.tiles
    seconds = {}
    with timed(seconds, "sampling"):
        weights = sampling_weights(depth, valid, params)
        v, t = tiles
        step = max_edge / math.sqrt(2.0)
        rs = max(2, math.ceil((max(h - 1, 1) / v) / step) + 1)
        z = max(2, math.ceil((max(w - 1, 1) / t) / step) + 1)
        p = params.replace(tiles=tiles, samples=(rs, z))
        grid = sample_grid(depth, valid, p, weights=weights)
    with timed(seconds, "triangulation"):
        mesh, rounds, points = refine_to_edge(grid, depth, valid, camera, max_edge)
    with timed(seconds, "flipping"):
        mesh = flip_edges(mesh, depth, valid, params)
    added = len(np.unique(points[:, 0] * w + points[:, 1])) - len(
        np.unique(grid[..., 0].astype(np.int64) * w + grid[..., 1]))
    stats = dataclasses.replace(mesh.stats, grid_shape=p.grid_shape, seconds=seconds)
    mesh = dataclasses.replace(mesh, stats=stats)
    longest = _longest_edge(mesh)
    return mesh, _target_record("max_edge", max_edge, longest, p, rounds, longest <= max_edge,
                                added_samples=int(added), vertices=mesh.stats.vertices)


def _longest_edge(mesh: Mesh) -> float:
    if mesh.is_empty:
        return 0.0
    p = mesh.pixels[mesh.faces].astype(np.float64)
    return float(np.sqrt(((p - np.roll(p, 1, axis=1)) ** 2).sum(axis=2)).max())
