"""A live run: frames from a source, paced, meshed, published; `live` (a generator) and `run` (the command).

Both share every line after the frame source: `open_source` gives the
frames, `rangemesh.live.pacing` releases and drops them, `triangulate`
meshes them (several at once on `rangemesh.live.workers` when the run has
more than one thread); `run` then publishes each mesh to the sinks, in the
frames' order, and keeps the figures (`rangemesh.live.stats`).
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

from ..pipeline import triangulate
from ..prepare import NONPOSITIVE
from ..recordings.meshing import MeshFrame, resolve
from .pacing import Clock, DeviceFeed, Playback, paced, parse_pace
from .sinks import FolderSink, FoxgloveChannels, parse_address
from .sources import open_source, with_offsets
from .stats import Stats
from .workers import Prefetch, frame_workers, pooled

__all__ = ["live", "run", "LiveMesh"]

STATUS_EVERY = 0.25  # seconds between two updates of the status line on a terminal


class LiveMesh(NamedTuple):
    """A frame's mesh with when its frame arrived and how long meshing took."""

    stamp: int
    frame_id: str
    mesh: object
    shape: tuple
    arrival: float
    mesh_seconds: float


class _HeldInterrupt:
    """Ctrl-C held while one frame's messages go out, raised once they are out.

    A frame's mesh and its stats row then reach every sink together: an
    interrupted run's MCAP has as many stats messages as meshes. It holds
    only Python's own SIGINT handler, on the main thread (elsewhere a no-op).
    """

    def __init__(self):
        self._active = (threading.current_thread() is threading.main_thread()
                        and signal.getsignal(signal.SIGINT) is signal.default_int_handler)
        self._pending = False

    def _hold(self, signum, frame):
        self._pending = True

    def __enter__(self):
        if self._active:
            signal.signal(signal.SIGINT, self._hold)
        return self

    def __exit__(self, exc_type, exc, tb):
        if self._active:
            signal.signal(signal.SIGINT, signal.default_int_handler)
            if self._pending and exc_type is None:
                self._pending = False
                raise KeyboardInterrupt
        return False


def _check_count(name: str, value, low: int):
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int) or value < low:
        raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")
    return value


def _within(path: Path, source: Path) -> bool:
    """Whether `path` is `source`, or lies inside it (a ROS 2 bag folder)."""
    p, src = path.resolve(), source.resolve()
    return p == src or (src.is_dir() and src in p.parents) or (
        p.exists() and src.exists() and p.samefile(src))


def check_apart(source, outputs=(), csv=None, names=("outputs", "csv")) -> None:
    """Refuse outputs that would write over the source, or over each other, or are no folder.

    Parameters
    ----------
    source : str or os.PathLike
        The recording (a device's name names no file: nothing to refuse).
    outputs, csv
        As `run` takes them.
    names : (str, str)
        How the message names `outputs` and `csv` (the command line: ``-o``, ``--csv``).

    Raises
    ------
    ValueError
        An output or the CSV that is the source recording or lies inside it
        (it would be replaced while it is read), a CSV that is the MCAP
        output, or a folder output that is an existing file; in one line
        naming the parameter.
    """
    src = Path(source)
    given = [(names[0], Path(o)) for o in outputs] + ([(names[1], Path(csv))] if csv else [])
    for name, p in given:
        if src.exists() and _within(p, src):
            inside = "" if p.resolve() == src.resolve() else " or lies inside it"
            raise ValueError(f"{name} {p} is the source recording {source}{inside}: writing "
                             f"there would replace the recording; write elsewhere")
    mcaps = [Path(o) for o in outputs if Path(o).suffix.lower() == ".mcap"]
    if csv and any(Path(csv).resolve() == m.resolve() for m in mcaps):
        raise ValueError(f"{names[1]} {csv} is the MCAP output too: name the CSV apart")
    for o in outputs:
        p = Path(o)
        if p.suffix.lower() != ".mcap" and p.exists() and not p.is_dir():
            raise ValueError(f"{names[0]} {p} is a file: an output is NAME.mcap or a folder for "
                             f"one mesh file a frame")
    if csv and Path(csv).is_dir():
        raise ValueError(f"{names[1]} {csv} is a folder, not a file to write")


def _open(source, kind, meta, topic, pace, loop, frames, queue, method, vertices, max_error,
          options):
    """Everything checked, then the source opened: errors at the call, not at the first frame."""
    call = resolve(method, vertices, max_error, dict(options))
    pace = parse_pace(pace)
    _check_count("frames", frames, 1)
    _check_count("queue", queue, 1)
    if not isinstance(loop, bool):
        raise TypeError(f"loop must be True or False, got {loop!r}")
    return call, pace, open_source(source, kind=kind, meta=meta, topic=topic, loop=loop)


def _meshes(src, call, pace, frames, queue, clock, stats) -> Iterator[LiveMesh]:
    if getattr(src, "wraps", False) and "wrap" not in call:  # a whole circle: --no-wrap opens it
        call = {**call, "wrap": True}
    workers = frame_workers()
    # with workers, a recording is read and decoded on a thread of its own while they mesh,
    # unless its SDK reads ahead itself (a thread between would add a hand-over of the GIL a frame)
    reader = Prefetch(src.frames(), workers) \
        if workers > 1 and not src.device and not getattr(src, "reads_ahead", False) else None
    feed = DeviceFeed(src.frames(), clock, max(queue, 8)) if src.device else \
        Playback(reader if reader is not None else src.frames(), pace, clock,
                 getattr(src, "fps", None))

    def mesh_one(frame, arrival) -> LiveMesh:
        t0 = clock.now()
        mesh = triangulate(frame.depth, background=NONPOSITIVE, camera=frame.camera, **call)
        mesh = with_offsets(mesh, frame.offsets)
        return LiveMesh(frame.stamp, frame.frame_id, mesh, frame.depth.shape, arrival,
                        clock.now() - t0)

    try:
        if workers > 1:
            yield from pooled(feed, mesh_one, workers, queue, frames, stats)
            return
        for n, (frame, arrival) in enumerate(paced(feed, queue, stats)):
            yield mesh_one(frame, arrival)
            if frames is not None and n + 1 >= frames:
                return
    finally:
        feed.close()
        if reader is not None:  # no read under way when the caller closes the source
            reader.close()


def live(source: str | os.PathLike, *, kind: str | None = None, meta=None, topic: str | None = None,
         pace="recorded", loop: bool = False, frames: int | None = None, queue: int = 1,
         method: str = "refine", vertices: int | None = None, max_error: float | None = None,
         **options) -> Iterator[MeshFrame]:
    """Mesh a sensor's frames as they come, or a recording's at its pace: ``(stamp, frame_id, mesh)``.

    Parameters
    ----------
    source : str or os.PathLike
        ``'realsense'`` (the first RealSense device) or ``'realsense:SERIAL'``;
        a RealSense SDK ``.bag`` (played back by `pyrealsense2`); an Ouster
        ``.pcap``/``.osf`` with `meta`, or an Ouster sensor's hostname; a ROS
        recording (``.bag``, ``.db3``, ``.mcap``, ROS 2 bag folder), see
        `rangemesh.live.sources.source_kind`.
    kind : {'realsense', 'ouster', 'ros'}, optional
        Which reader, when the name does not say.
    meta : str or os.PathLike, optional
        An Ouster recording's metadata JSON.
    topic : str, optional
        A ROS recording's depth topic (default: its only one).
    pace : 'recorded', 'fast' or float, default 'recorded'
        A recording's playback: its own stamps, as fast as meshing goes
        (nothing dropped), or this many frames/s. A device gives its own pace.
    loop : bool, default False
        Replay a recording without end. A RealSense recording whose decoded
        frames fit in `rangemesh.live.sources.REPLAY_BYTES` is decoded by the
        SDK once: later passes replay its frames from memory.
    frames : int, optional
        Stop after this many meshes.
    queue : int, default 1
        Frames kept waiting while one is meshed; beyond, the oldest are
        dropped (1: the newest frame wins).
    method, vertices, max_error, **options
        As for `rangemesh.triangulate` (``max_deviation`` and ``mean_deviation``
        among the options), checked once, at the call.

    Yields
    ------
    rangemesh.recordings.MeshFrame
        The frame's stamp (nanoseconds), its frame id and its mesh: metres in
        the camera's optical frame, or the LiDAR's frame with the SDK's exact
        points (each vertex's beam-origin offset added).

    Raises
    ------
    FileNotFoundError, ValueError, TypeError
        At the call: no such recording, no device, bad options.
    ImportError
        The SDK a source needs is missing, named with its ``pip install``.

    Notes
    -----
    With one thread (``RANGEMESH_THREADS=1``, or one core allowed) frames
    are read, meshed and handed out in turn, and the time the caller spends
    on each mesh counts as meshing time: frames that arrive meanwhile wait in
    the queue or are dropped. With more (`rangemesh.live.workers`), that
    many frames are meshed at once while a recording is read ahead, and the
    meshes come in the frames' order; the same meshes either way.
    """
    call, pace, src = _open(source, kind, meta, topic, pace, loop, frames, queue, method,
                            vertices, max_error, options)
    return _yielding(src, _meshes(src, call, pace, frames, queue, Clock(), None))


def _yielding(src, meshes):
    try:
        for m in meshes:
            yield MeshFrame(m.stamp, m.frame_id, m.mesh)
    finally:
        meshes.close()
        src.close()


class _Status:
    """The status line on stderr: rewritten in place on a terminal, a line a second otherwise."""

    def __init__(self, stream, quiet: bool):
        self.stream, self.quiet = stream, quiet
        self.tty = hasattr(stream, "isatty") and stream.isatty()
        self.last = -1e9

    def due(self, now: float) -> bool:
        """Whether the line is shown at `now`: its text need be made only then."""
        return not self.quiet and now - self.last >= (STATUS_EVERY if self.tty else 1.0)

    def show(self, text: str, now: float, force: bool = False) -> None:
        if self.quiet or not (force or self.due(now)):
            return
        self.last = now
        self.stream.write(("\r\033[K" + text) if self.tty else text + "\n")
        self.stream.flush()

    def end(self) -> None:
        if not self.quiet and self.tty:
            self.stream.write("\n")
            self.stream.flush()


def run(source: str | os.PathLike, *, foxglove: str | None = None, outputs=(),
        csv: str | os.PathLike | None = None, fmt: str = ".ply", overwrite: bool = False,
        quiet: bool = False, url_stream=None, status_stream=None, clock: Clock | None = None,
        kind: str | None = None, meta=None, topic: str | None = None, pace="recorded",
        loop: bool = False, frames: int | None = None, queue: int = 1, method: str = "refine",
        vertices: int | None = None, max_error: float | None = None, **options) -> dict:
    """``rangemesh live``: mesh a source and publish every mesh to the sinks; the run's summary.

    Parameters
    ----------
    source, kind, meta, topic, pace, loop, frames, queue, method, vertices, max_error, **options
        As for `live`.
    foxglove : str, optional
        ``[HOST:]PORT`` of a Foxglove WebSocket server (port 0: a free one;
        host 127.0.0.1 unless given). Its URL is written to `url_stream`
        (stdout) and flushed before the first frame.
    outputs : sequence of str or os.PathLike
        ``NAME.mcap`` (the same messages as the server's, with the stats
        channel) and/or a folder (one mesh file per frame in `fmt`).
    csv : str or os.PathLike, optional
        One row per published frame (`rangemesh.live.stats.CSV_FIELDS`),
        written at the end. Default: ``NAME.rangemesh-live.csv`` beside an
        MCAP output, else ``rangemesh-live.csv`` in a folder output, else none.
    overwrite : bool, default False
        Replace an existing MCAP file or mesh files.
    quiet : bool, default False
        No status line on `status_stream` (stderr).

    Returns
    -------
    dict
        `rangemesh.live.stats.Stats.summary` plus ``url`` and ``csv``.

    Raises
    ------
    ValueError
        As `live`; and an output or `csv` that would replace the source
        recording or each other (`check_apart`), before anything is opened.
    KeyboardInterrupt
        After the sinks are closed (the MCAP file readable) and the CSV written.
    """
    url_stream = sys.stdout if url_stream is None else url_stream
    status_stream = sys.stderr if status_stream is None else status_stream
    clock = clock or Clock()
    mcaps = [Path(o) for o in outputs if Path(o).suffix.lower() == ".mcap"]
    folders = [Path(o) for o in outputs if Path(o).suffix.lower() != ".mcap"]
    if len(mcaps) > 1:
        raise ValueError("outputs: one MCAP file at most")
    server = parse_address(foxglove) if foxglove is not None else None
    if csv is None:
        csv = mcaps[0].with_name(mcaps[0].stem + ".rangemesh-live.csv") if mcaps else \
            (folders[0] / "rangemesh-live.csv" if folders else None)
    check_apart(source, outputs, csv)
    call, pace, src = _open(source, kind, meta, topic, pace, loop, frames, queue, method,
                            vertices, max_error, options)
    fox = None
    try:
        sinks = [FolderSink(f, fmt, overwrite) for f in folders]
        if server is not None or mcaps:
            fox = FoxgloveChannels(server, mcaps[0] if mcaps else None, overwrite)
    except BaseException:
        src.close()
        raise
    status = _Status(status_stream, quiet)
    stats = Stats(clock.now())
    try:
        if fox is not None and fox.url is not None:
            print(fox.url, file=url_stream, flush=True)
        meshes = contextlib.closing(_meshes(src, call, pace, frames, queue, clock, stats))
        with meshes as items:  # the source closed at once on Ctrl-C during publishing too
            held = _HeldInterrupt()
            for item in items:
                with held:  # a frame's mesh, files and stats row all out, or none of them
                    t0 = clock.now()
                    if fox is not None:
                        fox.publish(item.stamp, item.frame_id, item.mesh, item.shape)
                    for sink in sinks:
                        sink.write(item.stamp, item.mesh)
                    now = clock.now()
                    stats.published(item.stamp, item.arrival, now, item.mesh_seconds, now - t0,
                                    item.mesh.stats.vertices, item.mesh.stats.triangles)
                    if fox is not None:
                        fox.log_stats(stats.figures(now))
                if status.due(now):
                    status.show(stats.line(now), now)
    finally:
        now = clock.now()
        status.show(stats.line(now), now, force=True)
        status.end()
        src.close()
        if fox is not None:
            fox.close()
        if csv is not None and stats.rows:
            stats.write_csv(csv)
    return {**stats.summary(clock.now()), "url": fox.url if fox is not None else None,
            "csv": None if csv is None or not stats.rows else str(csv)}
