"""Many images: a folder of scans, a recorded sequence, a live stream, a Dask cluster.

* `mesh_stream` meshes an iterable of frames in this process, reusing its
  buffers while the frame size stays the same.
* `mesh_many` meshes files to mesh files through Dask's distributed
  scheduler: a local cluster of worker processes by default, or an existing
  cluster given by its address. It is one code path either way: the same
  task function, submitted with ``Client.map`` and collected with
  ``as_completed``.

A bad input never stops a batch: its result says what went wrong and the
rest go on. Mesh files are written to a temporary name and renamed, so an
interrupted batch leaves no half-written mesh, and a re-run skips the files
that are already there (unless ``overwrite``).
"""

from __future__ import annotations

import csv
import glob
import json
import os
import statistics
import time
from collections.abc import Iterable, Iterator
from dataclasses import asdict, dataclass
from pathlib import Path

from .camera import as_camera
from .io import IMAGE_SUFFIXES, MESH_SUFFIXES, read_range_image, write_mesh
from .mesh import Mesh
from .metrics import evaluate
from .params import MeshParams
from .pipeline import Workspace, resolve_params, run
from .prepare import check_image, guess_background

__all__ = ["mesh_stream", "mesh_many", "expand_inputs", "BatchResult", "summarize"]


def mesh_stream(frames: Iterable, params: MeshParams | None = None, *, background=None,
                camera=None, **overrides) -> Iterator[Mesh]:
    """Mesh a stream of range images, one `Mesh` per frame, in order.

    Parameters
    ----------
    frames : iterable of (H, W) array_like
        Any iterable: a list, a generator reading a sensor, a video decoder.
    params : MeshParams, optional
    background, camera, **overrides
        As for `rangemesh.triangulate` (targets such as ``vertices`` are not
        taken here: a stream keeps one grid).

    Yields
    ------
    Mesh
        The same mesh `triangulate` gives for the frame.

    Notes
    -----
    While consecutive frames have the same shape, the depth, mask and weight
    buffers are reused instead of allocated per frame, and the kernels are
    compiled (or loaded from Numba's cache) once for the whole stream.
    """
    params = resolve_params(params, overrides)
    camera = as_camera(camera)
    ws = None
    for frame in frames:
        arr, bg = check_image(frame, background)  # every frame: clear errors, no copy
        if ws is None or ws.shape != arr.shape:
            ws = Workspace(arr.shape)
        yield run(arr, params, background=bg, camera=camera, workspace=ws)


# ---------------------------------------------------------------- files


@dataclass
class BatchResult:
    """What happened to one input file."""

    input: str
    output: str
    status: str  # 'meshed', 'skipped' (output already there) or 'failed'
    error: str = ""
    vertices: int = 0
    triangles: int = 0
    flipped_edges: int = 0
    seconds: float = 0.0
    relative_error: float = float("nan")


def expand_inputs(inputs: Iterable[str | os.PathLike]) -> list[Path]:
    """Files named by paths, folders (their range images, sorted) and glob patterns.

    Raises
    ------
    FileNotFoundError
        When an argument matches nothing.
    """
    out = []
    for item in inputs:
        p = Path(item)
        if p.is_dir():
            out += sorted(f for f in p.iterdir() if f.suffix.lower() in IMAGE_SUFFIXES)
        elif any(ch in str(item) for ch in "*?["):
            hits = sorted(Path(h) for h in glob.glob(str(item)))
            if not hits:
                raise FileNotFoundError(f"{item}: no file matches")
            out += hits
        elif p.exists() or p.is_symlink():
            out.append(p)
        else:
            raise FileNotFoundError(f"{item}: no such file or folder")
    seen, uniq = set(), []
    for p in out:
        if p not in seen:
            seen.add(p)
            uniq.append(p)
    return uniq


def output_path(path: Path, out_dir: Path, fmt: str) -> Path:
    """Where the mesh of `path` goes: same stem, in `out_dir`."""
    return out_dir / (path.stem + fmt)


def _one(path: str, out: str, params: MeshParams, background, camera, overwrite: bool,
         targets: dict) -> BatchResult:
    """The task every worker runs: read, mesh, evaluate, write. Never raises."""
    from .pipeline import triangulate

    t0 = time.perf_counter()
    if not overwrite and Path(out).exists():
        return BatchResult(path, out, "skipped")
    try:
        img = read_range_image(path)
        if isinstance(background, str):  # 'auto': by the image's dtype, as `rangemesh mesh` does
            background = guess_background(img)
        mesh = triangulate(img, params, background=background, camera=camera, **targets)
        if mesh.is_empty:
            raise ValueError(f"nothing to mesh: {mesh.stats.reason}")
        ev = evaluate(mesh, img, background=background)
        write_mesh(mesh, out)
    except Exception as exc:  # one bad file must not stop the batch: report it in one line
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        return BatchResult(path, out, "failed", error=f"{type(exc).__name__}: {msg}",
                           seconds=time.perf_counter() - t0)
    s = mesh.stats
    return BatchResult(path, out, "meshed", vertices=s.vertices, triangles=s.triangles,
                       flipped_edges=s.flipped_edges, seconds=time.perf_counter() - t0,
                       relative_error=ev.relative_error)


def _clean_stale_parts(out_dir: Path):
    """Remove temporary files an interrupted run left behind (never a finished mesh)."""
    for f in out_dir.glob(".*.part.*"):
        if f.is_file():
            f.unlink(missing_ok=True)


def mesh_many(paths, out_dir, params: MeshParams | None = None, *, background=None, camera=None,
              scheduler: str | None = None, workers: int | None = None, overwrite: bool = False,
              fmt: str = ".ply", progress: bool = False, vertices=None, max_error=None,
              max_edge=None, **overrides) -> list[BatchResult]:
    """Mesh many range images into `out_dir`, in parallel, through Dask.

    Parameters
    ----------
    paths : iterable of str or os.PathLike
        Files, folders or glob patterns (see `expand_inputs`).
    out_dir : str or os.PathLike
        Folder for the meshes (created if needed) and for
        ``rangemesh-batch.csv`` / ``.json`` with one row per input.
    params, background, camera, vertices, max_error, max_edge, **overrides
        As for `rangemesh.triangulate`, the same for every image;
        ``background='auto'`` takes 0 for integer images and only NaN/inf for
        float images, image by image.
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://head:8786``). Default: a
        local cluster of `workers` processes started for this batch.
    workers : int, optional
        Worker processes of the local cluster (default: the CPU count).
    overwrite : bool, default False
        Mesh again files whose output already exists.
    fmt : str, default '.ply'
        Output format, one of ``MESH_SUFFIXES``.
    progress : bool, default False
        Show a progress bar (images done, images per second, failures) on stderr.

    Returns
    -------
    list of BatchResult
        In input order.

    Raises
    ------
    ValueError
        For an unknown format or bad parameters (checked before any work).
    FileNotFoundError
        When an input argument matches nothing.
    """
    from ._optional import require

    dd = require("dask.distributed", "rangemesh batch / mesh_many")
    Client, LocalCluster, as_completed = dd.Client, dd.LocalCluster, dd.as_completed  # noqa: N806

    if fmt not in MESH_SUFFIXES:
        raise ValueError(f"fmt must be one of {MESH_SUFFIXES}, got {fmt!r}")
    if isinstance(background, str) and background != "auto":
        raise ValueError(f"background must be a number, None or 'auto', got {background!r}")
    params = resolve_params(params, overrides)
    camera = as_camera(camera)
    targets = {k: v for k, v in (("vertices", vertices), ("max_error", max_error),
                                 ("max_edge", max_edge)) if v is not None}
    files = expand_inputs([paths] if isinstance(paths, (str, os.PathLike)) else paths)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    _clean_stale_parts(out_dir)
    outs = [output_path(f, out_dir, fmt) for f in files]
    clashes = {o for o in outs if outs.count(o) > 1}
    if clashes:
        raise ValueError(f"several inputs would write the same output: {sorted(map(str, clashes))[:3]}")
    t0 = time.perf_counter()
    results: dict[int, BatchResult] = {}
    cluster = None
    if scheduler is None:
        n = workers or os.cpu_count() or 1
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                               dashboard_address=None, silence_logs=40)
        client = Client(cluster)
    else:
        client = Client(scheduler)
    bar = None
    try:
        futures = client.map(_one, [str(f) for f in files], [str(o) for o in outs],
                             params=params, background=background, camera=camera,
                             overwrite=overwrite, targets=targets, pure=False)
        index = {f.key: i for i, f in enumerate(futures)}
        if progress:
            from tqdm import tqdm

            bar = tqdm(total=len(futures), unit="image", desc="meshing", dynamic_ncols=True)
        failed = 0
        for fut in as_completed(futures):
            res = fut.result()
            results[index[fut.key]] = res
            failed += res.status == "failed"
            if bar is not None:
                bar.update(1)
                bar.set_postfix(failed=failed)
    finally:
        if bar is not None:
            bar.close()
        client.close()
        if cluster is not None:
            cluster.close()
    ordered = [results[i] for i in range(len(files))]
    write_report(ordered, out_dir, time.perf_counter() - t0)
    return ordered


def summarize(results: list[BatchResult], wall: float) -> dict:
    """Counts, total and median time per image."""
    done = [r for r in results if r.status == "meshed"]
    return {
        "inputs": len(results),
        "meshed": len(done),
        "skipped": sum(r.status == "skipped" for r in results),
        "failed": sum(r.status == "failed" for r in results),
        "wall_seconds": wall,
        "images_per_second": len(done) / wall if wall > 0 else float("nan"),
        "median_seconds_per_image": statistics.median(r.seconds for r in done) if done else None,
        "total_seconds_in_workers": sum(r.seconds for r in done),
    }


def write_report(results: list[BatchResult], out_dir: Path, wall: float):
    """``rangemesh-batch.csv`` (one row per input) and ``rangemesh-batch.json`` (with the summary)."""
    rows = [asdict(r) for r in results]
    fields = list(BatchResult.__dataclass_fields__)
    tmp = out_dir / ".rangemesh-batch.csv.part.tmp"
    with open(tmp, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)
    os.replace(tmp, out_dir / "rangemesh-batch.csv")
    clean = [{k: (None if isinstance(v, float) and v != v else v) for k, v in r.items()}
             for r in rows]  # JSON has no NaN
    doc = {"summary": summarize(results, wall), "results": clean}
    tmp = out_dir / ".rangemesh-batch.json.part.tmp"
    tmp.write_text(json.dumps(doc, indent=1))
    os.replace(tmp, out_dir / "rangemesh-batch.json")
