"""Meshing a recording: a generator in this process, or a batch to an MCAP file or a folder.

`mesh_bag` yields ``(stamp, frame_id, mesh)`` per depth message.
`mesh_recording` is the batch: one reader in this process, the frames meshed
here (``workers=1``) or on Dask workers (the cluster of
`rangemesh.batch.mesh_many`), the results written in the recording's order
into an MCAP file of markers or a folder of one mesh file per frame, with
the same progress bar and statistics (CSV and JSON) as a batch of files.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..batch import (
    BatchResult,
    _clean_stale_parts,
    _earlier_report,
    _options_record,
    _other_options,
    _report_rows,
    dask_client,
    progress_bar,
    write_report,
)
from ..io import MESH_SUFFIXES, write_mesh
from ..memory import check_memory
from ..mesh import Mesh
from ..metrics import evaluate
from ..pipeline import triangulate
from ..prepare import NONPOSITIVE
from ..resolve import call_keywords, call_options, resolve_call
from ..timing import timed
from .decode import color_image, depth_image, depth_shape
from .ouster import OusterRecording, is_ouster, with_offsets
from .reading import Frame, Recording, stamp_text
from .writing import MarkerBag, marker_bytes

__all__ = ["MeshFrame", "mesh_bag", "mesh_frame", "mesh_recording", "resolve"]

BACKGROUND = NONPOSITIVE  # ROS depth (REP 118): 0 is no return, below 0 is behind the camera


class MeshFrame(NamedTuple):
    """One frame's mesh with the depth message's header."""

    stamp: int  # nanoseconds
    frame_id: str
    mesh: Mesh


def resolve(method: str, vertices, max_error, options: dict) -> dict:
    """`triangulate`'s keywords for every frame, checked once (`rangemesh.resolve.resolve_call`).

    Raises
    ------
    ValueError, TypeError
        A bad option or target; an unknown keyword.
    """
    options = dict(options)
    deviations = (options.pop("max_deviation", None), options.pop("mean_deviation", None))
    given, rest = call_keywords(options)
    params, method, _ = resolve_call(None, method, vertices, max_error, given, rest, stacklevel=4,
                                     deviations=deviations)
    call = {"method": method, "vertices": vertices, "max_error": max_error,
            **call_options(params, method)}
    # (only when given, as mesh_many: a folder's record of its options stays as it was without)
    call.update({k: v for k, v in zip(("max_deviation", "mean_deviation"), deviations, strict=True)
                 if v is not None})
    return call


def mesh_frame(frame: Frame, call: dict, how: str = "pixel") -> tuple[Mesh, object]:
    """Decode one frame and mesh it; its colours when it has a colour image.

    Returns
    -------
    mesh : Mesh
    depth : ndarray
        The decoded depth (values as stored).

    Raises
    ------
    ValueError
        The frame cannot be meshed: the reason in one line, naming the frame.
    MemoryError
        Its size, read from its header, needs more memory than is available
        (`rangemesh.memory.check_memory`): nothing was decoded.
    """
    if frame.error:
        raise ValueError(f"{frame.name}: {frame.error}")
    decoded = isinstance(frame.depth, np.ndarray)  # an SDK's scan (Ouster): no message to decode
    try:  # a compressed frame's size from its PNG header: a bomb is refused before decoding
        shape = frame.depth.shape if decoded else depth_shape(frame.depth, frame.name)
        check_memory(shape, call["method"], call["vertices"])
    except MemoryError as exc:
        raise MemoryError(f"{frame.name}: {exc}") from None
    depth = frame.depth if decoded else depth_image(frame.depth, frame.name)[0]
    try:
        mesh = triangulate(depth, background=BACKGROUND, camera=frame.camera, **call)
        mesh = with_offsets(mesh, frame.offsets)
        if frame.color is not None:
            mesh = mesh.with_colors(color_image(frame.color, frame.name), how=how)
    except ValueError as exc:
        text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ValueError(text if text.startswith(frame.name) else f"{frame.name}: {text}") from None
    return mesh, depth


def mesh_bag(path: str | os.PathLike, topic: str | None = None, *, color_topic: str | None = None,
             camera=None, camera_info_topic: str | None = None, color_how: str = "pixel",
             errors: str = "raise", method: str = "refine", vertices: int | None = None,
             max_error: float | None = None, **options) -> Iterator[MeshFrame]:
    """Mesh every depth message of a recording, in its order: ``(stamp, frame_id, mesh)``.

    Parameters
    ----------
    path : str or os.PathLike
        A ROS 1 ``.bag``, a ROS 2 bag folder, or a ``.db3`` or ``.mcap`` file.
    topic : str, optional
        The depth topic: ``sensor_msgs/Image`` in ``16UC1``/``mono16``
        (millimetres) or ``32FC1`` (metres), or ``CompressedImage`` in
        ``compressedDepth``. Default: the recording's only depth topic.
    color_topic : str, optional
        A colour topic registered with the depth (same size, pixel to pixel;
        ``rgb8``, ``bgr8``, ``rgba8``, ``bgra8``, ``mono8`` or compressed):
        vertex colours from the colour message nearest in stamp.
    camera : Pinhole, Orthographic, ..., optional
        Used as given (with its ``depth_scale``) for every frame. Default:
        each frame's ``CameraInfo`` (its ``K``; the depth scale of the
        encoding), see `Recording.camera_info`.
    camera_info_topic : str, optional
        Take the CameraInfo from this topic.
    color_how : {'pixel', 'mean'}, default 'pixel'
        As `Mesh.with_colors`'s ``how``.
    errors : {'raise', 'skip'}, default 'raise'
        A frame that cannot be meshed (damaged data, an encoding refused, too
        large): ``'raise'`` ends the iteration with its error; ``'skip'``
        warns (`SkippedFrame`, naming the frame and why) and goes on with the
        next frame, as ``rangemesh batch`` does.
    method, vertices, max_error, **options
        As for `rangemesh.triangulate` (``max_deviation`` and ``mean_deviation``
        among the options), checked once, before the first frame.

    Yields
    ------
    MeshFrame
        ``(stamp, frame_id, mesh)``: the header's stamp in nanoseconds, its
        frame id, and the mesh (vertices in metres in the camera's optical
        frame with a CameraInfo's camera). A frame with no valid depth gives
        an empty mesh, as `triangulate` does.

    Raises
    ------
    FileNotFoundError, ValueError
        At the call: no recording there, no such depth topic, no CameraInfo
        and no `camera`, bad options. While iterating, with ``errors='raise'``:
        a frame that cannot be meshed (its encoding, damaged data), naming the
        frame.
    ImportError
        `rosbags` is missing (``pip install "rangemesh[ros]"``).

    Notes
    -----
    ``for stamp, frame_id, mesh in rangemesh.mesh_bag("run.bag", vertices=2000): ...`` (the
    README's "Recordings" runs it on the shared RealSense bag).
    """
    if errors not in ("raise", "skip"):
        raise ValueError(f"errors must be 'raise' or 'skip', got {errors!r}")
    call = resolve(method, vertices, max_error, dict(options))
    with Recording(path) as rec:  # checked at the call, not at the first next()
        rec.frames(topic, color_topic=color_topic, camera=camera,
                   camera_info_topic=camera_info_topic)
    return _meshes(path, topic, color_topic, camera, camera_info_topic, call, color_how, errors)


class SkippedFrame(UserWarning):
    """`mesh_bag(..., errors='skip')` skipped a frame that cannot be meshed; the message says why."""


def _meshes(path, topic, color_topic, camera, camera_info_topic, call, how, errors):
    import warnings

    with Recording(path) as rec:
        frames = rec.frames(topic, color_topic=color_topic, camera=camera,
                            camera_info_topic=camera_info_topic)
        while True:
            # silenced only while a frame is read and meshed: what they warn was said at the
            # call, and the caller's own code between frames keeps its warnings
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)
                frame = next(frames, None)
                if frame is None:
                    return
                try:
                    mesh, _ = mesh_frame(frame, call, how)
                except (ValueError, MemoryError) as exc:
                    if errors == "raise":
                        raise
                    mesh = exc
            if isinstance(mesh, Exception):
                warnings.warn(f"{mesh}; skipped", SkippedFrame, stacklevel=2)
                continue
            yield MeshFrame(frame.stamp, frame.frame_id, mesh)


# ---------------------------------------------------------------- the batch


def _task(frame: Frame, call: dict, how: str, out: str | None, overwrite: bool,
          write_options: dict) -> tuple[BatchResult, bytes | None]:
    """Mesh one frame: its marker (``out`` None) or its mesh file written. Never raises."""
    clock = timed()
    target = out if out is not None else ""
    if out is not None and not overwrite and Path(out).exists():
        return BatchResult(frame.name, target, "skipped"), None
    try:
        mesh, depth = mesh_frame(frame, call, how)
        if mesh.is_empty:
            raise ValueError(f"nothing to mesh: {mesh.stats.reason}")
        ev = evaluate(mesh, depth, background=BACKGROUND, depth_limits=call.get("depth_limits"),
                      min_region=call.get("min_region"))
        data = None
        if out is None:
            data = marker_bytes(mesh, frame.stamp, frame.frame_id)
        else:
            write_mesh(mesh, out, **write_options)
    except Exception as exc:  # one bad frame must not stop the batch: report it in one line
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        prefix = f"{frame.name}: "
        msg = msg[len(prefix):] if msg.startswith(prefix) else msg
        return BatchResult(frame.name, target, "failed", error=f"{type(exc).__name__}: {msg}",
                           seconds=clock.elapsed), None
    s = mesh.stats
    return BatchResult(frame.name, target, "meshed", vertices=s.vertices, triangles=s.triangles,
                       flipped_edges=s.flipped_edges, seconds=clock.elapsed,
                       relative_error=ev.relative_error), data


def mesh_recording(path: str | os.PathLike, output: str | os.PathLike, topic: str | None = None,
                   *, color_topic: str | None = None, camera=None,
                   camera_info_topic: str | None = None, color_how: str = "pixel",
                   scheduler: str | None = None, workers: int | None = None,
                   overwrite: bool = False, fmt: str = ".ply", write_options: dict | None = None,
                   progress: bool = False, connect_timeout: float = 10.0, marker_topic: str | None = None,
                   meta=None, method: str = "refine", vertices: int | None = None,
                   max_error: float | None = None, **options) -> list[BatchResult]:
    """Mesh every depth frame of a recording into an MCAP file of markers, or a folder of meshes.

    Parameters
    ----------
    path, topic, color_topic, camera, camera_info_topic, color_how
        As for `mesh_bag`. An Ouster ``.pcap``/``.osf`` (with `meta`) is read
        through `ouster-sdk` (`rangemesh.recordings.ouster`): every scan with
        the SDK's rays and beam-origin offsets; the ROS options do not apply.
    output : str or os.PathLike
        ``name.mcap``: a ROS 2 MCAP recording with one
        ``visualization_msgs/msg/Marker`` (``TRIANGLE_LIST``) per frame on
        `marker_topic`, stamped with the depth message's header and written
        at its receive time (`rangemesh.recordings.writing`); statistics go
        beside it as ``name.rangemesh-batch.csv`` / ``.json``. Anything
        else: a folder (created) with one mesh file per frame named by its
        stamp (``360.815089000.ply``) and ``rangemesh-batch.csv`` / ``.json``.
    scheduler, workers, connect_timeout
        As for `rangemesh.mesh_many`. ``workers=1`` (and no scheduler) meshes
        in this process, without Dask.
    overwrite : bool, default False
        A folder: mesh again frames whose file is there (else skipped, their
        earlier rows kept in the report); without it, a folder whose meshes
        were made with other options is an error. An MCAP file: replace it
        (else an existing file is an error).
    fmt : str, default '.ply'
        The mesh files' format, one of ``MESH_SUFFIXES`` (folder output).
    write_options : dict, optional
        Keywords of `rangemesh.write_mesh` (``ascii``, ``pixels``).
    progress : bool, default False
        Show the batch's progress bar.
    marker_topic : str, optional
        Default ``<depth topic>/mesh`` (an Ouster recording: ``/os_lidar/mesh``).
    meta : str or os.PathLike, optional
        An Ouster recording's metadata JSON (``--meta``).
    method, vertices, max_error, **options
        As for `rangemesh.triangulate` (``max_deviation`` and ``mean_deviation``
        among the options), checked before any work.

    Returns
    -------
    list of BatchResult
        One per frame, in the recording's order; ``input`` is ``topic@stamp``.

    Raises
    ------
    FileNotFoundError, ValueError, ImportError
        As `mesh_bag` at its call; an MCAP output that exists without
        `overwrite`; a bad format or worker count. Frames that cannot be
        meshed do not raise: their result says why.
    """
    call = resolve(method, vertices, max_error, dict(options))
    if fmt not in MESH_SUFFIXES:
        raise ValueError(f"fmt must be one of {MESH_SUFFIXES}, got {fmt!r}")
    output = Path(output)
    to_bag = output.suffix.lower() == ".mcap"
    _check_apart(Path(path), output)
    if to_bag and output.exists() and not overwrite:
        raise ValueError(f"{output}: exists; give --overwrite (overwrite=True) to replace it")
    clock = timed()
    with _open(path, meta) as rec:
        if getattr(rec, "wraps", False) and call.get("wrap") is None:  # an Ouster's whole circle
            call = {**call, "wrap": True}
        frames = rec.frames(topic, color_topic=color_topic, camera=camera,
                            camera_info_topic=camera_info_topic)
        dt = rec.depth_topic(topic)
        if to_bag:
            report_dir = output.parent if str(output.parent) else Path(".")
            names = (f"{output.stem}.rangemesh-batch.csv", f"{output.stem}.rangemesh-batch.json")
            for name in (output.name, *names):  # what killed runs left: the partial bag, reports
                _clean_stale_parts(report_dir, name)
            sink = _BagSink(output, marker_topic or dt.topic.rstrip("/") + "/mesh")
        else:
            # a folder keeps its record: the options its meshes were made with, and every row
            record = {**_options_record(call, BACKGROUND, camera, fmt, None), "topic": dt.topic,
                      "color_topic": color_topic, "camera_info_topic": camera_info_topic,
                      "color_how": color_how, "write": write_options or {}}
            earlier = _earlier_report(output)
            if earlier.get("options") not in (None, record) and not overwrite:
                raise ValueError(_other_options(output, earlier["options"], record))
            output.mkdir(parents=True, exist_ok=True)
            _clean_stale_parts(output)
            report_dir, names = output, None
            sink = _FolderSink(output, fmt)
        bar = progress_bar(dt.count) if progress else None
        try:
            with sink:
                run = _in_process if workers == 1 and scheduler is None else _on_dask
                results = run(frames, sink, call, color_how, overwrite, write_options or {},
                              bar, scheduler, workers, connect_timeout)
        finally:
            if bar is not None:
                bar.close()
    wall = clock.elapsed
    if names is None:
        write_report(_report_rows(earlier.get("results", ()), results), report_dir, wall,
                     counted=results, options=record)
    else:
        write_report(results, report_dir, wall, names)
    return results


def _open(path, meta):
    """The recording's reader: an Ouster one for a ``.pcap``/``.osf``, else the ROS one."""
    if is_ouster(path):
        return OusterRecording(path, meta=meta)
    if meta is not None:
        raise ValueError("meta (--meta) goes with an Ouster recording (.pcap or .osf)")
    return Recording(path)


def _check_apart(recording: Path, output: Path) -> None:
    """Refuse an output that is the recording, or lies in its folder: it could replace it."""
    rec, out = recording.resolve(), output.resolve()
    if out == rec or (rec.is_dir() and rec in out.parents):
        raise ValueError(f"{output}: the output must not be the recording {recording} or lie "
                         f"inside it; write it elsewhere")


class _BagSink:
    """Markers into one MCAP file, in frame order."""

    def __init__(self, path: Path, topic: str):
        self.bag = MarkerBag(path, topic)

    def __enter__(self):
        self.bag.__enter__()
        return self

    def __exit__(self, *exc):
        return self.bag.__exit__(*exc)

    def out(self, frame: Frame) -> None:
        return None

    def put(self, frame: Frame, result: BatchResult, data: bytes | None) -> None:
        result.output = str(self.bag.path)
        if data is not None:
            self.bag.write(frame.log_time, data)


class _FolderSink:
    """One mesh file per frame, named by its stamp; written by the task itself."""

    def __init__(self, folder: Path, fmt: str):
        self.folder, self.fmt, self.seen = folder, fmt, set()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return None

    def out(self, frame: Frame) -> str:
        name = stamp_text(frame.stamp)
        if name in self.seen:  # two frames of one stamp: the later one named by its place too
            name = f"{name}.{frame.index}"
        self.seen.add(name)
        return str(self.folder / (name + self.fmt))

    def put(self, frame: Frame, result: BatchResult, data: bytes | None) -> None:
        return None


def _tick(bar, results):
    if bar is not None:
        bar.update(1)
        bar.set_postfix(failed=sum(r.status == "failed" for r in results))


def _in_process(frames, sink, call, how, overwrite, write_options, bar, *_):
    results = []
    for frame in frames:
        res, data = _task(frame, call, how, sink.out(frame), overwrite, write_options)
        sink.put(frame, res, data)
        results.append(res)
        _tick(bar, results)
    return results


def _on_dask(frames, sink, call, how, overwrite, write_options, bar, scheduler, workers,
             connect_timeout):
    """Frames read here, meshed on the workers, written here in the recording's order.

    At most a few frames per worker are in flight, so the recording is never
    held in memory whole.
    """
    results: list[BatchResult] = []
    done: dict[int, tuple] = {}
    with dask_client(scheduler, workers, connect_timeout) as (client, as_completed):
        limit = 4 * max(1, len(client.scheduler_info().get("workers", {})))
        queue = as_completed()
        owner = {}

        def collect(fut):
            frame = owner.pop(fut.key)
            done[frame.index] = (frame, *fut.result())
            while len(results) in done:
                f, res, data = done.pop(len(results))
                sink.put(f, res, data)
                results.append(res)
                _tick(bar, results)

        for frame in frames:
            fut = client.submit(_task, frame, call, how, sink.out(frame), overwrite,
                                write_options, pure=False)
            owner[fut.key] = frame
            queue.add(fut)
            while queue.count() >= limit:
                collect(next(queue))
        for fut in queue:
            collect(fut)
    return results
