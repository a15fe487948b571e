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

import contextlib
import csv
import glob
import json
import os
import re
import shutil
import statistics
import time
from collections.abc import Iterable, Iterator
from dataclasses import asdict, dataclass
from pathlib import Path

from .camera import as_camera
from .checks import whole_number
from .io import (
    IMAGE_SUFFIXES,
    MESH_SUFFIXES,
    SCAN_SUFFIX,
    NotDepthImage,
    atomic_path,
    bin_layout,
    read_color_image,
    read_scan,
    write_mesh,
)
from .io.files import part_owner
from .mesh import Mesh
from .metrics import evaluate
from .pairing import check_pattern, color_for, colors_record
from .params import MeshParams
from .pipeline import Workspace, run
from .prepare import NONPOSITIVE, check_image
from .resolve import call_keywords, call_options, resolve_call
from .timing import timed

__all__ = ["mesh_stream", "mesh_many", "expand_inputs", "BatchResult", "summarize"]


def mesh_stream(frames: Iterable, params: MeshParams | None = None, *,
                method: str = "refine", vertices: int | None = None,
                max_error: float | None = None, max_deviation: float | None = None,
                mean_deviation: float | None = None, background="auto", camera=None,
                **options) -> Iterator[Mesh]:
    """Mesh a stream of range images, one `Mesh` per frame, in order.

    Parameters
    ----------
    frames : iterable of (H, W) array_like
        Any iterable: a list, a generator reading a sensor, a video decoder.
    params, method, vertices, max_error, background, camera, **options
        As for `rangemesh.triangulate` (every option it takes, the same
        defaults: ``method='refine'``, ``background='auto'``), checked once,
        before the first frame. An unknown keyword is a TypeError.
    max_deviation, mean_deviation : float, optional
        As for `rangemesh.triangulate`.

    Yields
    ------
    Mesh
        The same mesh `triangulate` gives for the frame.

    Notes
    -----
    While consecutive frames have the same shape, the depth, mask and weight
    buffers are reused instead of allocated per frame, and the options are
    checked once for the whole stream.
    """
    options, overrides = call_keywords(options)
    # checked at the call, not at the first next(): a generator would defer the errors
    deviations = (max_deviation, mean_deviation)
    params, method, tiles_given = resolve_call(params, method, vertices, max_error, options,
                                               overrides, deviations=deviations)
    return _stream(frames, params, method, tiles_given, vertices, max_error, background,
                   as_camera(camera), deviations)


def _stream(frames, params, method, tiles_given, vertices, max_error, background, camera,
            deviations=(None, None)):
    ws = None
    for frame in frames:
        arr, bg = check_image(frame, background, camera=camera)  # every frame: clear errors, no copy
        if ws is None or ws.shape != arr.shape:
            ws = Workspace(arr.shape)
        yield run(arr, params, background=bg, camera=camera, vertices=vertices,
                  max_error=max_error, tiles_given=tiles_given, workspace=ws, method=method,
                  max_deviation=deviations[0], mean_deviation=deviations[1])


# ---------------------------------------------------------------- files


@dataclass
class BatchResult:
    """What happened to one input file."""

    input: str
    output: str
    status: str  # 'meshed', 'skipped' (output already there, or not a depth image) or 'failed'
    error: str = ""  # why it failed, or why it was skipped when not for its output
    vertices: int = 0
    triangles: int = 0
    flipped_edges: int = 0
    seconds: float = 0.0
    relative_error: float = float("nan")


REPORT_NAMES = ("rangemesh-batch.csv", "rangemesh-batch.json")
NOT_DEPTH = "not a depth image"  # a skipped row's reason when the input is no range image


def _not_an_output(path: Path) -> bool:
    """Whether a glob's hit can be an input: not a mesh, a batch report or a temporary file."""
    name = path.name
    return not (path.suffix.lower() in MESH_SUFFIXES or name in REPORT_NAMES
                or (name.startswith(".") and ".part" in name))


def expand_inputs(inputs: Iterable[str | os.PathLike], *, scans: bool = False) -> list[Path]:
    """Files named by paths, folders (their range images, sorted) and glob patterns.

    A glob leaves out what a batch writes (meshes, its reports, temporary
    files), so a pattern that matches the output folder gives the same
    inputs on every run. A file named twice (say by a relative and an
    absolute path) is meshed once. With `scans` (a beams file given), a
    folder's LiDAR ``.bin`` scans are inputs too.

    Raises
    ------
    FileNotFoundError
        When an argument matches nothing.
    """
    out = []
    for item in inputs:
        if not isinstance(item, (str, os.PathLike)):
            raise TypeError(f"paths must name files, folders or glob patterns (str or os.PathLike), "
                            f"got {type(item).__name__}: triangulate meshes an array")
        p = Path(item)
        if p.is_dir():
            kinds = (*IMAGE_SUFFIXES, SCAN_SUFFIX) if scans else IMAGE_SUFFIXES
            out += sorted(f for f in p.iterdir() if f.suffix.lower() in kinds)
        elif any(ch in str(item) for ch in "*?["):
            hits = sorted(Path(h) for h in glob.glob(str(item)) if _not_an_output(Path(h)))
            if not hits:
                raise FileNotFoundError(f"{item}: no file matches")
            out += hits
        elif p.exists() or p.is_symlink():
            out.append(p)
        else:
            raise FileNotFoundError(f"{item}: no such file or folder")
    seen, uniq = set(), []
    for p in out:
        key = p.resolve()
        if key not in seen:
            seen.add(key)
            uniq.append(p)
    return uniq


def output_path(path: Path, out_dir: Path, fmt: str) -> Path:
    """Where the mesh of `path` goes: same stem, in `out_dir`."""
    return out_dir / (path.stem + fmt)


def output_paths(files: list[Path], out_dir: Path, fmt: str) -> list[Path | None]:
    """Where each input's mesh goes; None for inputs whose output another input takes.

    An input's mesh is named after its stem (``scan.png`` -> ``scan.ply``).
    Inputs that share a stem (``x.png`` and ``x.npy``) are named after their
    whole file name instead (``x.png.ply``, ``x.npy.ply``). Inputs that
    still share a name (``a/x.png`` and ``b/x.png``) get None: the first of
    them would be overwritten, so none of them is meshed, and the rest of the
    batch goes on.
    """
    stems = [output_path(f, out_dir, fmt) for f in files]
    outs = [o if stems.count(o) == 1 else out_dir / (f.name + fmt) for f, o in zip(files, stems, strict=True)]
    return [o if outs.count(o) == 1 else None for o in outs]


def _workers(workers) -> int:
    """Worker processes of a local cluster: at least 1, at most the cores this process may use."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    cores = cores or 1
    if workers is None:
        return cores
    n = whole_number("workers", workers, minimum=1)
    if n > cores:
        # each worker is single-threaded and CPU-bound: more processes than cores
        # only add start-up time and memory (100 on 2 cores: 3 minutes, 6.7 GB)
        raise ValueError(f"workers={n} is more than the {cores} CPU cores this process may use; "
                         f"give at most {cores}")
    return n


async def _identity(address: str):
    from distributed.core import rpc

    async with rpc(address) as scheduler:
        return await scheduler.identity()


def _connect(client_cls, scheduler: str, timeout: float):
    """A client of the Dask scheduler at `scheduler`, or a ValueError saying why not.

    The address is first asked for its identity under a deadline: a port that
    accepts connections but does not speak Dask's protocol (a web server, a
    silent listener) would otherwise hold the client's handshake forever, and
    one that answers with other bytes can make it allocate whatever length
    those bytes spell.
    """
    import asyncio

    try:
        who = asyncio.run(asyncio.wait_for(_identity(scheduler), timeout))
        if not isinstance(who, dict) or who.get("type") != "Scheduler":
            raise ValueError(f"it answers as {who.get('type') if isinstance(who, dict) else who!r}")
        return client_cls(scheduler, timeout=timeout)
    except Exception as exc:  # anything a wrong address can cause: timeouts, garbage, refusals
        text = str(exc).strip().splitlines()
        raise ValueError(f"cannot connect to a Dask scheduler at {scheduler!r} within "
                         f"{timeout:g} s ({type(exc).__name__}"
                         + (f": {text[0]}" if text else "") + ")") from None


def _one(path: str, out: str, call: dict, background, camera, overwrite: bool,
         layout: dict | None = None, color: str | None = None) -> BatchResult:
    """The task every worker runs: read, mesh, evaluate, write. Never raises.

    `call` holds `triangulate`'s keywords (method, targets, options), checked
    by `mesh_many` before any work; `layout`, a ``.bin`` scan's
    (`rangemesh.io.bin_layout`); `color`, the paired colour image ("" when
    colours were asked for and none is paired with this file).
    """
    from .pipeline import triangulate

    clock = timed()
    if not overwrite and Path(out).exists():
        return BatchResult(path, out, "skipped")
    try:
        try:
            img = read_scan(path, layout)
        except NotDepthImage as exc:  # a colour image or a preview in the folder: not an input
            why = str(exc).removeprefix(f"{path}: ")
            return BatchResult(path, out, "skipped", error=f"{NOT_DEPTH}: {why}")
        mesh = triangulate(img, background=background, camera=camera, **call)
        if mesh.is_empty:
            raise ValueError(f"nothing to mesh: {mesh.stats.reason}")
        ev = evaluate(mesh, img, background=background, depth_limits=call.get("depth_limits"),
                      min_region=call.get("min_region"))
        if color == "":
            raise ValueError("no colour image is paired with it (colors=, --associations)")
        if color is not None:
            mesh = mesh.with_colors(read_color_image(color))
        write_mesh(mesh, out, pixels=getattr(camera, "z_depth", False))  # as `rangemesh mesh`
    except Exception as exc:  # one bad file must not stop the batch: report it in one line
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        return BatchResult(path, out, "failed", error=f"{type(exc).__name__}: {msg}",
                           seconds=clock.elapsed)
    s = mesh.stats
    return BatchResult(path, out, "meshed", vertices=s.vertices, triangles=s.triangles,
                       flipped_edges=s.flipped_edges, seconds=clock.elapsed,
                       relative_error=ev.relative_error)


def _one_paired(path: str, out: str, color: str | None, **task) -> BatchResult:
    """`_one` with the colour image as a positional argument: `Client.map` maps only those."""
    return _one(path, out, color=color, **task)


# Another host's leftovers (a shared folder) are removed only after this long: its processes
# cannot be asked whether they still run.
STALE_PART_SECONDS = 24 * 3600


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, ValueError):
        return pid > 0  # another user's process, or a number that is no process id
    return True


_PART = re.compile(r"^\.(?P<name>.+)\.(?P<host>[A-Za-z0-9-]+)\.(?P<pid>\d+)\.[^.]+\.part(\.[^.]*)?$")


def _clean_stale_parts(out_dir: Path, name: str | None = None):
    """Remove temporary files that interrupted runs left behind (never a finished mesh).

    A temporary file names its writer (`rangemesh.io.part_owner`): it is
    removed when that process is gone, or, for another host's, when it is a
    day old. The files of batches still running into the same folder are
    left alone; untagged ones (an older rangemesh's) are removed. A tagged
    temporary folder (`rangemesh.recordings.writing.MarkerBag`'s partial
    bag) is removed whole by the same rule; an untagged folder never.

    Parameters
    ----------
    out_dir : Path
    name : str, optional
        Only the temporaries of the output file `name` (``.NAME.*.part``):
        for an output in a folder that holds other things.
    """
    host = part_owner().rsplit(".", 1)[0]
    now = time.time()
    pattern = f".{glob.escape(name)}.*.part*" if name is not None else ".*.part*"
    for f in out_dir.glob(pattern):
        folder = f.is_dir() and not f.is_symlink()
        if not (f.is_file() or folder):
            continue
        tag = _PART.match(f.name)
        if tag is None and (folder or name is not None):
            continue  # an untagged folder, or a file among other things: not surely a leftover
        if name is not None and tag["name"] != name:
            continue  # another output's (``.NAME.x.*`` of an output named NAME.x)
        try:
            if tag is None:
                stale = True
            elif tag["host"] == host:
                stale = not _alive(int(tag["pid"]))
            else:
                stale = now - f.stat().st_mtime > STALE_PART_SECONDS
        except (ValueError, OSError):
            stale = False
        if stale and folder:
            shutil.rmtree(f, ignore_errors=True)
        elif stale:
            f.unlink(missing_ok=True)


@contextlib.contextmanager
def _script_not_rerun():
    """Worker processes started inside the block do not run the calling script again.

    Python's "spawn" start method (Dask's) has each new process import the
    parent's ``__main__`` script, whose top-level `mesh_many` call would then
    start clusters of its own: the reason scripts needed an ``if __name__ ==
    "__main__":`` guard. The workers run only rangemesh's task, so the
    script's name is hidden from `multiprocessing` while they start.
    """
    import sys

    main = sys.modules.get("__main__")
    saved = {k: main.__dict__[k] for k in ("__file__", "__spec__") if main and k in main.__dict__}
    try:
        if main is not None:
            main.__dict__.pop("__file__", None)
            if "__spec__" in saved:
                main.__spec__ = None
        yield
    finally:
        if main is not None:
            main.__dict__.update(saved)


def progress_bar(total: int):
    """The batch's progress bar on stderr: inputs done, per second, failures."""
    from tqdm import tqdm

    return tqdm(total=total, unit="image", desc="meshing", dynamic_ncols=True)


@contextlib.contextmanager
def dask_client(scheduler: str | None, workers: int | None, connect_timeout: float = 10.0):
    """A Dask client and its ``as_completed``: of a local cluster started here, or of `scheduler`.

    The local cluster has `workers` single-threaded processes (checked by
    `_workers`); client and cluster are closed when the block ends.

    Yields
    ------
    (distributed.Client, distributed.as_completed)
    """
    from ._optional import require

    dd = require("dask.distributed", "rangemesh batch / mesh_many")
    n_workers = _workers(workers) if scheduler is None else None
    cluster = None
    if scheduler is None:
        # One single-threaded process per core: method="refine"'s second thread
        # (`rangemesh.threads`) would only oversubscribe the cores.
        with _script_not_rerun():
            cluster = dd.LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                                      dashboard_address=":0", silence_logs=40,  # any free port
                                      env={"RANGEMESH_THREADS": "1"})
        client = dd.Client(cluster)
    else:
        client = _connect(dd.Client, scheduler, timeout=connect_timeout)
    try:
        yield client, dd.as_completed
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def mesh_many(paths, out_dir, params: MeshParams | None = None, *,
              method: str = "refine", vertices: int | None = None,
              max_error: float | None = None, max_deviation: float | None = None,
              mean_deviation: float | None = None, background="auto", camera=None,
              scheduler: str | None = None, workers: int | None = None, overwrite: bool = False,
              fmt: str = ".ply", progress: bool = False, connect_timeout: float = 10.0,
              beams: str | os.PathLike | None = None, colors=None, **options) -> list[BatchResult]:
    """Mesh many range images into `out_dir`, in parallel through Dask, or in this process.

    Parameters
    ----------
    paths : iterable of str or os.PathLike
        Files, folders or glob patterns (see `expand_inputs`).
    out_dir : str or os.PathLike
        Folder for the meshes (created if needed) and for
        ``rangemesh-batch.csv`` / ``.json`` with one row per input.
    params, method, vertices, max_error, background, camera, **options
        As for `rangemesh.triangulate` (every option it takes, the same
        defaults: ``method='refine'``, ``background='auto'``, resolved image
        by image), the same for every image, checked before any work. An
        unknown keyword is a TypeError.
    max_deviation, mean_deviation : float, optional
        As for `rangemesh.triangulate`.
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://head:8786``). Default: a
        local cluster of `workers` processes started for this batch.
    workers : int, optional
        Worker processes of the local cluster (default: the CPU cores this
        process may use; more are refused, as they only cost memory).
        ``workers=1`` without a scheduler meshes in this process, one image
        after the other: no cluster is started, and Dask is not needed.
        `workers` are processes everywhere in rangemesh; `threads` is the
        in-call thread count of the paper's method.
    overwrite : bool, default False
        Mesh again files whose output already exists. Without it, a batch
        into a folder whose report records other options (method, targets,
        options, background, camera, format) is refused with a ValueError
        naming them: the meshes there would be skipped as done.
    fmt : str, default '.ply'
        Output format, one of ``MESH_SUFFIXES``.
    progress : bool, default False
        Show a progress bar (images done, images per second, failures) on stderr.
    connect_timeout : float, default 10
        Seconds to wait for the scheduler given by `scheduler` to answer.
    beams : str or os.PathLike, optional
        A beams file (``.beams.json``): LiDAR ``.bin`` scans are read with its
        rows and column shifts (`rangemesh.io.read_scan`), as ``rangemesh
        mesh --beams`` reads them, and a folder's ``.bin`` files are inputs
        too. The camera is still `camera` (``Spherical.from_beams(beams)``).
    colors : str or mapping, optional
        Vertex colours from each depth file's colour image, registered pixel to
        pixel: a pattern naming it from the depth file (``"rgb/{stem}.png"``;
        fields ``{stem}``, ``{name}``, ``{dir}``: `rangemesh.pairing`), or a
        mapping of depth file to colour file (`rangemesh.pairing.read_associations`
        reads TUM's ``associate.txt`` lists). A depth file whose colour image is
        missing, or another size, fails with the reason.

    Returns
    -------
    list of BatchResult
        In input order. Inputs that share a stem are written under their
        whole file name (``x.png.ply``); see `output_paths`. An image of
        several channels (a colour image, a preview) is ``'skipped'``, its
        `error` saying it is not a depth image; it is no failure. The report
        keeps earlier runs' rows: of other inputs, and of inputs skipped
        because their mesh is there.

    Raises
    ------
    ValueError
        For an unknown format, bad parameters or too many workers (checked
        before any work), or a scheduler that does not answer as one.
    FileNotFoundError
        When an input argument matches nothing.

    Notes
    -----
    Works from a plain script: the local cluster's worker processes do not
    run the calling script again (no ``if __name__ == "__main__":`` guard
    is needed), see `_script_not_rerun`.
    """
    if fmt not in MESH_SUFFIXES:
        raise ValueError(f"fmt must be one of {MESH_SUFFIXES}, got {fmt!r}")
    if isinstance(background, str) and background not in ("auto", NONPOSITIVE):
        raise ValueError(f"background must be a number, None, 'auto' or '{NONPOSITIVE}', "
                         f"got {background!r}")
    options, overrides = call_keywords(options)
    params, method, _ = resolve_call(params, method, vertices, max_error, options, overrides,
                                     deviations=(max_deviation, mean_deviation))
    camera = as_camera(camera)
    # the workers call triangulate with the resolved method and every field of params: the
    # deprecated spellings arrive as keywords, so the workers warn nothing
    call = {"method": method, "vertices": vertices, "max_error": max_error,
            **call_options(params, method)}
    # (only when given: a batch's record of its options stays as it was without them)
    call.update({k: v for k, v in (("max_deviation", max_deviation),
                                   ("mean_deviation", mean_deviation)) if v is not None})
    files = expand_inputs([paths] if isinstance(paths, (str, os.PathLike)) else paths,
                          scans=beams is not None)
    layout = None
    if beams is not None and any(f.suffix.lower() == SCAN_SUFFIX for f in files):
        layout = bin_layout(beams)  # checked before any work
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise ValueError(f"out_dir {out_dir} is a file: the meshes go to a folder")
    record = _options_record(call, background, camera, fmt, beams)
    if colors is not None:  # (only when given: the records of batches without colour stay)
        if isinstance(colors, str):
            check_pattern(colors)
        elif hasattr(colors, "items"):
            colors = {str(Path(k).absolute()): str(Path(v).absolute()) for k, v in colors.items()}
        else:
            raise TypeError(f"colors must be a pattern string or a mapping, got "
                            f"{type(colors).__name__}")
        record["colors"] = colors_record(colors)
    earlier = _earlier_report(out_dir)
    before = earlier.get("options")
    if before is not None and before != record and not overwrite:
        raise ValueError(_other_options(out_dir, before, record))
    out_dir.mkdir(parents=True, exist_ok=True)
    _clean_stale_parts(out_dir)
    outs = output_paths(files, out_dir, fmt)
    clock = timed()
    results: dict[int, BatchResult] = {
        i: BatchResult(str(f), str(output_path(f, out_dir, fmt)), "failed",
                       error="another input has the same file name: no unique output name")
        for i, (f, o) in enumerate(zip(files, outs, strict=True)) if o is None}
    todo = [i for i, o in enumerate(outs) if o is not None]
    task = {"call": call, "background": background, "camera": camera, "overwrite": overwrite,
            "layout": layout}
    paired = {i: None if colors is None else str(color_for(files[i], colors) or "") for i in todo}
    bar = progress_bar(len(todo)) if progress else None
    try:
        if scheduler is None and workers is not None and _workers(workers) == 1:
            # one process: no cluster to start, and no Dask needed
            done = ((i, _one(str(files[i]), str(outs[i]), **task, color=paired[i])) for i in todo)
            _gather(done, results, bar)
        else:
            with dask_client(scheduler, workers, connect_timeout) as (client, as_completed):
                futures = client.map(_one_paired, [str(files[i]) for i in todo],
                                     [str(outs[i]) for i in todo], [paired[i] for i in todo],
                                     **task, pure=False)
                index = {f.key: i for i, f in zip(todo, futures, strict=True)}
                _gather(((index[f.key], f.result()) for f in as_completed(futures)), results, bar)
    finally:
        if bar is not None:
            bar.close()
    ordered = [results[i] for i in range(len(files))]
    write_report(_report_rows(earlier.get("results", ()), ordered), out_dir,
                 clock.elapsed, counted=ordered, options=record)
    return ordered


def _options_record(call: dict, background, camera, fmt: str, beams) -> dict:
    """What a batch's meshes are made with, as JSON holds it: compared on a re-run."""
    import hashlib

    def value(v):
        if hasattr(v, "tobytes"):  # a per-pixel camera's arrays: their digest, not their numbers
            return "sha256:" + hashlib.sha256(v.tobytes()).hexdigest()[:16]
        return v

    cam = camera
    fields = getattr(cam, "__dataclass_fields__", {})
    mesh_options = {k: v for k, v in call.items() if k != "threads"}  # any count: the same mesh
    record = {**mesh_options, "background": background, "format": fmt,
              "beams": None if beams is None else str(beams),
              "camera": None if cam is None else
              {"type": type(cam).__name__, **{k: value(getattr(cam, k)) for k in fields}}}
    return json.loads(json.dumps(record, default=str))  # tuples as lists, as read back


def _earlier_report(out_dir: Path) -> dict:
    """The JSON report of an earlier batch into `out_dir` ({} if none, or unreadable)."""
    try:
        doc = json.loads((out_dir / REPORT_NAMES[1]).read_text())
    except (OSError, ValueError):
        return {}
    return doc if isinstance(doc, dict) else {}


def _other_options(out_dir: Path, before: dict, now: dict) -> str:
    """One line: the folder's meshes were made with other options, which, and what to do."""
    keys = [k for k in {**before, **now} if before.get(k) != now.get(k)]
    def said_of(record, k):  # an option left out of a record is at its default
        return repr(record[k]) if k in record else "default"

    said = "; ".join(f"{k} {said_of(before, k)} then, {said_of(now, k)} now" for k in keys[:3])
    more = f" and {len(keys) - 3} more" if len(keys) > 3 else ""
    return (f"{out_dir}: its meshes were made with other options ({said}{more}); give --overwrite "
            f"(overwrite=True) to mesh again with these, or another output folder")


def _report_rows(rows, results: list[BatchResult]) -> list[BatchResult]:
    """The report's rows: earlier runs' rows of other outputs, then this run's.

    An input skipped because its output is already there keeps its earlier row, which holds the
    figures of its mesh.
    """
    fields = BatchResult.__dataclass_fields__
    earlier = {}
    for row in rows if isinstance(rows, list) else ():
        if isinstance(row, dict) and {"input", "output", "status"} <= row.keys():
            r = BatchResult(**{k: v for k, v in row.items() if k in fields})
            if r.relative_error is None:  # JSON's null for NaN
                r.relative_error = float("nan")
            earlier[r.output] = r
    now = {r.output for r in results}
    kept = [r for out, r in earlier.items() if out not in now]
    return kept + [earlier.get(r.output, r) if r.status == "skipped" and not r.error else r
                   for r in results]


def _gather(done, results: dict, bar) -> None:
    """Put each ``(index, BatchResult)`` of `done` into `results`, ticking the progress bar."""
    failed = 0
    for i, res in done:
        results[i] = res
        failed += res.status == "failed"
        if bar is not None:
            bar.update(1)
            bar.set_postfix(failed=failed)


def summarize(results: list[BatchResult], wall: float) -> dict:
    """Counts, total and median time per image."""
    done = [r for r in results if r.status == "meshed"]
    return {
        "inputs": len(results),
        "meshed": len(done),
        "skipped": sum(r.status == "skipped" for r in results),
        "skipped_not_depth": sum(r.status == "skipped" and r.error.startswith(NOT_DEPTH)
                                 for r in results),
        "failed": sum(r.status == "failed" for r in results),
        "wall_seconds": wall,
        "images_per_second": len(done) / wall if wall > 0 else float("nan"),
        "median_seconds_per_image": statistics.median(r.seconds for r in done) if done else None,
        "total_seconds_in_workers": sum(r.seconds for r in done),
    }


def write_report(results: list[BatchResult], out_dir: Path, wall: float,
                 names: tuple[str, str] = REPORT_NAMES, *, counted: list[BatchResult] | None = None,
                 options: dict | None = None):
    """``rangemesh-batch.csv`` (one row per input) and ``rangemesh-batch.json`` (with the summary).

    `names` gives other names to the two files (a recording's batch names them after its output).
    `counted` are the results the summary counts (default `results`: a re-run's report keeps
    earlier rows, its summary counts this run); `options`, what the meshes were made with, goes
    into the JSON file.
    """
    rows = [asdict(r) for r in results]
    fields = list(BatchResult.__dataclass_fields__)
    with atomic_path(out_dir / names[0]) as tmp, open(tmp, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)
    clean = [{k: (None if isinstance(v, float) and v != v else v) for k, v in r.items()}
             for r in rows]  # JSON has no NaN
    doc = {"summary": summarize(results if counted is None else counted, wall), "results": clean}
    if options is not None:
        doc["options"] = options
    with atomic_path(out_dir / names[1]) as tmp:
        tmp.write_text(json.dumps(doc, indent=1))
