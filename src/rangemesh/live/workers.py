"""Frames meshed at once: meshing threads that take their frames from the pacing, handed out in order.

With more than one thread for the run (`frame_workers`: ``RANGEMESH_THREADS``,
at most the cores this process may use), `rangemesh.live.session` meshes
several frames at once, each on a worker thread of its own that meshes with
one native thread (`rangemesh.threads.one_thread`): the native
meshing releases the GIL, so the workers run side by side, and each mesh is
the one a single thread makes. A recording's frames are read and decoded
ahead on a thread of their own (`Prefetch`), while the caller's thread
publishes. The pacing is that of one thread: a frame is taken from `paced`
only when a worker is free, by that worker, so frames that come while every worker is busy
wait in the queue (``--queue``) or are dropped, the newest winning; at
``--pace fast`` the playback releases a frame each time a worker asks, and
none is dropped. The meshes are handed out in the frames' order, whatever
order the workers finish in.
"""

from __future__ import annotations

import os
import queue as queues
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import Future

from ..threads import THREADS_VARIABLE, one_thread
from .pacing import paced

__all__ = ["frame_workers", "cores", "Prefetch", "pooled", "UNPUBLISHED_PER_WORKER"]

_POLL = 0.05  # seconds between two looks at the stop flag while a thread waits
_JOIN = 2.0  # seconds to wait for a thread to end when the run stops
UNPUBLISHED_PER_WORKER = 2  # frames taken but not yet handed out, per worker: bounds the backlog


def cores() -> int:
    """The cores this process may use."""
    n = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return max(1, n or 1)


def frame_workers() -> int:
    """Frames a live run meshes at once: ``RANGEMESH_THREADS`` (default: every core), at most the cores.

    One (``RANGEMESH_THREADS=1``, or one core allowed, as under
    ``taskset -c 0``) keeps the sequential path: read, mesh, publish in turn.
    """
    n = cores()
    value = os.environ.get(THREADS_VARIABLE, "").strip()
    setting = int(value) if value.isdigit() and int(value) > 0 else n
    return max(1, min(n, setting))


class _Raised:
    """An exception of a helper thread, raised on the caller's thread in its turn."""

    def __init__(self, exc: BaseException):
        self.exc = exc


_END = object()


class Prefetch:
    """A recording's frames read (and decoded) on a thread of their own, up to `ahead` in advance.

    An iterator of the frames of `frames`, in order; an error of the reader
    is raised in its turn. `close` stops the thread and waits for it, so the
    source may then be closed: no read is under way.
    """

    def __init__(self, frames: Iterator, ahead: int):
        self._queue: queues.Queue = queues.Queue(maxsize=max(1, ahead))
        self._stop = threading.Event()
        self._done = False
        self._thread = threading.Thread(target=self._read, args=(frames,), daemon=True,
                                        name="rangemesh-live-read")
        self._thread.start()

    def _put(self, item) -> bool:
        """Queue `item`; False once stopped (`close` makes room: a put under way then ends)."""
        while not self._stop.is_set():
            try:
                self._queue.put(item, timeout=_POLL)
                return not self._stop.is_set()
            except queues.Full:
                continue
        return False

    def _read(self, frames) -> None:
        try:
            for frame in frames:
                if not self._put(frame):
                    return
            self._put(_END)
        except BaseException as exc:  # raised on the mesher's side, in the frames' order
            self._put(_Raised(exc))
        finally:  # the source's objects (an SDK's frames) let go here, before the source closes
            close = getattr(frames, "close", None)
            if close is not None:
                close()

    def __iter__(self):
        return self

    def __next__(self):
        while not self._done:
            try:
                item = self._queue.get(timeout=_POLL)
            except queues.Empty:
                if self._stop.is_set():
                    break
                continue
            if item is _END:
                break
            if isinstance(item, _Raised):
                self._done = True
                raise item.exc
            return item
        self._done = True
        raise StopIteration

    def close(self) -> None:
        """Stop reading; wait for the thread to end.

        The frames read ahead are let go, so that a reader waiting for room
        ends at once: it waited up to `_POLL` (50 ms) after a run's last
        frame, which a run of two threads counts (60 frames at 130 frames/s
        last 0.46 s).
        """
        self._stop.set()
        try:
            while True:
                self._queue.get_nowait()
        except queues.Empty:
            pass
        self._thread.join(_JOIN)


def pooled(feed, mesh_one: Callable, workers: int, queue: int, frames: int | None,
           stats=None) -> Iterator:
    """The meshes of `feed`'s frames, meshed `workers` at a time, in the frames' order.

    Parameters
    ----------
    feed : Playback or DeviceFeed
        What `paced` takes the frames from (on the workers' threads, one at a time).
    mesh_one : callable
        ``mesh_one(frame, arrival)``: the frame's mesh (`LiveMesh`), called on
        a worker thread.
    workers : int
        Frames meshed at once (2 or more).
    queue : int
        Frames kept waiting while every worker is busy (`paced`).
    frames : int, optional
        Stop after this many frames.
    stats : rangemesh.live.stats.Stats, optional
        Told of arrivals and drops (by the worker taking a frame; the caller's
        thread only publishes).

    Notes
    -----
    A worker that is done with a frame takes the next one itself, under a
    lock that keeps the frames' order (no thread between: a frame's end and
    the next one's start cost no hand-over of the GIL to a dispatching
    thread and back). At most ``UNPUBLISHED_PER_WORKER * workers`` frames
    are taken and not yet handed back by the caller (meshing, meshed, being
    published): a caller slower than the meshing holds the workers back, so
    frames wait in the feed and the newest wins, as with one thread.
    """
    unpublished = threading.Semaphore(UNPUBLISHED_PER_WORKER * workers)
    handed: queues.Queue = queues.Queue()
    stop = threading.Event()
    take = threading.Lock()  # one worker at a time takes a frame: the frames' order kept
    taken = paced(feed, queue, stats)
    state = {"n": 0, "ended": False}

    def acquire(slot) -> bool:
        while not stop.is_set():
            if slot.acquire(timeout=_POLL):
                return True
        return False

    def next_frame():
        """The next frame and its place in `handed`, or None at the end (under `take`)."""
        if state["ended"] or stop.is_set():
            return None
        if frames is not None and state["n"] >= frames:
            state["ended"] = True
            handed.put(_END)
            return None
        if not acquire(unpublished) or stop.is_set():  # stopped while the caller held them all
            return None
        try:
            item = next(taken, None)
        except BaseException as exc:  # the source's error, raised after the frames before it
            state["ended"] = True
            handed.put(_Raised(exc))
            return None
        if item is None or stop.is_set():
            state["ended"] = True
            handed.put(_END)
            return None
        state["n"] += 1
        slot: Future = Future()
        handed.put(slot)
        return item, slot

    meshing: set = set()  # the workers meshing a frame now

    def work():
        me = threading.current_thread()
        with one_thread():  # the workers use the cores: one native thread each
            while True:
                with take:
                    got = next_frame()
                    if got is None:
                        return
                    meshing.add(me)
                (frame, arrival), slot = got
                try:
                    slot.set_result(mesh_one(frame, arrival))
                except BaseException as exc:  # raised on the caller's thread in its turn
                    slot.set_exception(exc)
                finally:
                    meshing.discard(me)

    threads = [threading.Thread(target=work, daemon=True, name=f"rangemesh-live-mesh_{i}")
               for i in range(workers)]
    for t in threads:
        t.start()
    held = False
    try:
        while True:
            if held:  # the caller is done with the last mesh: one more frame may be taken
                unpublished.release()
                held = False
            item = handed.get()
            if item is _END:
                return
            if isinstance(item, _Raised):
                raise item.exc
            held = True
            yield item.result()
    finally:
        stop.set()
        for _ in threads:  # a worker waiting for the caller to let go of a frame ends at once
            unpublished.release()
        feed.close()
        for t in threads:  # a frame being meshed is finished; a wait for one ends within _JOIN
            t.join(_JOIN)
            while t.is_alive() and t in meshing:
                t.join(_JOIN)
