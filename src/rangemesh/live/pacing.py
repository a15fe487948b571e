"""When frames arrive, and which are meshed: the playback clock and the newest-frame-wins queue.

A recording's frames are released by a `Playback` at ``--pace recorded``
(their own stamps), ``--pace N`` (N frames/s) or ``--pace fast`` (one frame
each time the mesher asks: nothing is ever dropped). A device's frames are
gathered by a `DeviceFeed` thread as the sensor gives them. `paced` hands
the mesher the frames in order, keeping at most ``queue`` of those that
arrived while it was busy: when more came, the oldest are dropped (counted),
so the newest frame wins. The clock is a parameter: tests drive a fake one.
"""

from __future__ import annotations

import math
import threading
import time
from collections import deque
from collections.abc import Iterator

__all__ = ["Clock", "Playback", "DeviceFeed", "paced", "parse_pace", "FAST", "RECORDED"]

FAST, RECORDED = "fast", "recorded"
_GAP = 0.1  # seconds between two passes of a looped recording whose rate is unknown


class Clock:
    """The wall clock: ``now()`` in seconds (monotonic) and ``sleep(seconds)``."""

    now = staticmethod(time.perf_counter)

    @staticmethod
    def sleep(seconds: float) -> None:
        """Sleep `seconds` (nothing when not positive)."""
        if seconds > 0:
            time.sleep(seconds)


def parse_pace(pace) -> str | float:
    """``'recorded'``, ``'fast'`` or a positive rate in frames/s from a ``--pace`` value.

    Raises
    ------
    ValueError
        Anything else, naming ``pace``.
    """
    if isinstance(pace, str) and pace.strip().lower() in (FAST, RECORDED):
        return pace.strip().lower()
    try:
        rate = float(pace)
    except (TypeError, ValueError):
        rate = math.nan
    if not (math.isfinite(rate) and rate > 0):
        raise ValueError(f"pace must be 'recorded', 'fast' or frames per second > 0, got {pace!r}")
    return rate


class Playback:
    """A recording's frames released by the playback clock.

    Parameters
    ----------
    frames : iterator of LiveFrame
        Read one ahead of its release (``stamp`` in nanoseconds).
    pace : 'recorded', 'fast' or float
        See `parse_pace`.
    clock : Clock
    fps : float, optional
        The recording's nominal rate: the gap from a looped recording's last
        frame to its first (else the recording's mean gap, else 0.1 s).
    """

    def __init__(self, frames: Iterator, pace, clock: Clock, fps: float | None = None):
        self._frames = iter(frames)
        self.pace = parse_pace(pace)
        self.clock = clock
        self._fps = fps
        self._next = None  # (frame, release time), read ahead
        self._count = 0
        self._t0 = None
        self._first_stamp = self._last_stamp = None
        self._offset = 0.0  # seconds added to the stamps since the first frame: loops
        self._gap = None  # seconds from a pass's last frame to the next pass's first
        self._last_release = None
        self.ended = False

    def _peek(self):
        if self._next is None and not self.ended:
            frame = next(self._frames, None)
            if frame is None:
                self.ended = True
                return None
            if self._t0 is None:
                self._t0 = self.clock.now()
            self._next = (frame, self._release(frame))
            self._count += 1
        return self._next

    def _release(self, frame) -> float:
        if self.pace == FAST:
            return -math.inf
        if self.pace != RECORDED:
            return self._t0 + self._count / self.pace
        stamp = int(frame.stamp)
        if self._first_stamp is None:
            self._first_stamp = stamp
        elif stamp <= self._last_stamp:  # a loop began again (or stamps went back): one gap later
            if self._gap is None:  # the first pass's mean gap (later passes would shrink it)
                self._gap = 1.0 / self._fps if self._fps else (
                    (self._last_stamp - self._first_stamp) / 1e9 / max(1, self._count - 1) or _GAP)
            self._offset = (self._last_release + self._gap - self._t0
                            - (stamp - self._first_stamp) / 1e9)
        self._last_stamp = stamp
        release = self._t0 + (stamp - self._first_stamp) / 1e9 + self._offset
        self._last_release = release
        return release

    def take(self, now: float) -> list[tuple]:
        """The frames released by `now`, each as ``(frame, release time)``; at ``fast`` one frame."""
        out = []
        while True:
            item = self._peek()
            if item is None or (self.pace != FAST and item[1] > now):
                return out
            self._next = None
            out.append((item[0], now if self.pace == FAST else item[1]))
            if self.pace == FAST:
                return out

    def wait(self) -> bool:
        """Sleep until the next release; False when the recording has ended."""
        item = self._peek()
        if item is None:
            return False
        if self.pace != FAST:
            self.clock.sleep(item[1] - self.clock.now())
        return True

    def lost(self) -> int:
        """None is lost: the playback releases every frame to `paced`."""
        return 0

    def close(self) -> None:
        """Nothing to stop: the playback starts no thread (its frames are read by whoever takes them)."""


class DeviceFeed:
    """A sensor's frames gathered by a thread as they come, each with its arrival time.

    At most `keep` frames wait between two `take` calls; older ones are
    dropped here and counted (`lost`). An error of the sensor's reader is
    raised by the next `take`.
    """

    def __init__(self, frames: Iterator, clock: Clock, keep: int = 64):
        self.clock = clock
        self.keep = keep
        self._lost = 0
        self._items: list[tuple] = []
        self._cond = threading.Condition()
        self._stop = False
        self.ended = False
        self._error = None
        self._thread = threading.Thread(target=self._read, args=(frames,), daemon=True,
                                        name="rangemesh-live-source")
        self._thread.start()

    def _read(self, frames):
        try:
            for frame in frames:
                with self._cond:
                    if self._stop:
                        return
                    self._items.append((frame, self.clock.now()))
                    if len(self._items) > self.keep:  # a stalled mesher holds no more than this
                        del self._items[0]
                        self._lost += 1
                    self._cond.notify()
        except BaseException as exc:  # handed to the mesher's thread, which raises it
            self._error = exc
        finally:
            with self._cond:
                self.ended = True
                self._cond.notify()

    def take(self, now: float) -> list[tuple]:
        """The frames arrived since the last call, ``(frame, arrival time)``."""
        with self._cond:
            out, self._items = self._items, []
        if self._error is not None:
            raise self._error
        return out

    def lost(self) -> int:
        """Frames dropped here since the last call (arrived and never taken)."""
        with self._cond:
            n, self._lost = self._lost, 0
        return n

    def wait(self) -> bool:
        """Wait for the next frame; False when the sensor's stream has ended."""
        with self._cond:
            while not self._items and not self.ended:
                self._cond.wait(0.5)
            return bool(self._items) or self._error is not None

    def close(self) -> None:
        """Stop reading (the thread ends at its next frame)."""
        with self._cond:
            self._stop = True


def paced(feed, queue: int = 1, stats=None) -> Iterator[tuple]:
    """The frames to mesh, ``(frame, arrival time)``, newest winning.

    Before each frame is handed out, every frame that has arrived is put in
    a queue of at most `queue` frames; beyond that the oldest are dropped
    and counted (``stats.dropped``). The caller meshes and publishes a frame
    before asking for the next: what arrives meanwhile waits in the queue.

    Parameters
    ----------
    feed : Playback or DeviceFeed
    queue : int, default 1
        Frames kept waiting (1: only the newest).
    stats : rangemesh.live.stats.Stats, optional
        Told of every arrival and drop.

    Raises
    ------
    ValueError
        `queue` below 1.
    """
    if isinstance(queue, bool) or not isinstance(queue, int) or queue < 1:
        raise ValueError(f"queue must be an integer >= 1, got {queue!r}")
    waiting: deque = deque()
    while True:
        now = feed.clock.now()
        items = feed.take(now)
        if stats is not None:
            for _ in range(feed.lost()):  # dropped by a device's reader before `take`
                stats.arrived(now)
                stats.drop()
        for item in items:
            waiting.append(item)
            if stats is not None:
                stats.arrived(item[1])
            if len(waiting) > queue:
                waiting.popleft()
                if stats is not None:
                    stats.drop()
        if waiting:
            yield waiting.popleft()
        elif not feed.wait():
            return
