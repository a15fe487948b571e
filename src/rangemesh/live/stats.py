"""The figures of a live run: frames/s in and out, frames dropped, latency; a status line and a CSV.

The latency of a frame runs from its arrival (from the sensor, or its
release by the playback clock) to the end of its publication to every sink.
Rates are over the last `WINDOW` seconds.
"""

from __future__ import annotations

import csv
import math
import os
from collections import deque
from pathlib import Path

import numpy as np

__all__ = ["Stats", "CSV_FIELDS", "WINDOW", "RECENT", "percentile"]

WINDOW = 2.0  # seconds over which the status line's rates are counted
RECENT = 256  # frames whose latencies the current figures' 95th percentile is of
CSV_FIELDS = ("index", "stamp", "arrival_s", "published_s", "latency_ms", "mesh_ms", "publish_ms",
              "vertices", "triangles", "dropped_so_far")


def percentile(values, q: float) -> float:
    """The `q`-th percentile of `values`, interpolated linearly (`numpy.percentile`'s default).

    Raises
    ------
    ValueError
        No values, or `q` outside 0..100.
    """
    if not 0 <= q <= 100:
        raise ValueError(f"q must be in 0..100, got {q!r}")
    s = sorted(values)
    if not s:
        raise ValueError("values must not be empty")
    pos = (len(s) - 1) * (q / 100)
    lo = min(math.floor(pos), len(s) - 1)
    hi = min(lo + 1, len(s) - 1)
    t = pos - lo
    # numpy's lerp: from the nearer end, so that t = 1 gives the upper value exactly
    return s[lo] + (s[hi] - s[lo]) * t if t < 0.5 else s[hi] - (s[hi] - s[lo]) * (1 - t)


class Stats:
    """Counts and per-frame rows of one run.

    Parameters
    ----------
    start : float
        The run's start on its clock, seconds.
    """

    def __init__(self, start: float):
        self.start = start
        self.frames_in = 0
        self.frames_out = 0
        self.dropped = 0
        self.rows: list[tuple] = []
        self._in: deque = deque()
        self._out: deque = deque()
        self._recent: deque = deque(maxlen=RECENT)  # the last frames' latencies, ms

    def arrived(self, t: float) -> None:
        """A frame arrived at `t`."""
        self.frames_in += 1
        self._in.append(t)

    def drop(self) -> None:
        """A frame was dropped unmeshed (a newer one won)."""
        self.dropped += 1

    def published(self, stamp: int, arrival: float, t: float, mesh_s: float, publish_s: float,
                  vertices: int, triangles: int) -> None:
        """A frame's mesh reached every sink at `t` (seconds on the run's clock)."""
        self.frames_out += 1
        self._out.append(t)
        latency = 1e3 * (t - arrival)
        self._recent.append(latency)
        self.rows.append((self.frames_out - 1, int(stamp), arrival - self.start, t - self.start,
                          latency, 1e3 * mesh_s, 1e3 * publish_s, int(vertices),
                          int(triangles), self.dropped))

    def _rate(self, times: deque, now: float) -> float:
        while times and times[0] < now - WINDOW:
            times.popleft()
        span = min(WINDOW, now - self.start)
        return len(times) / span if span > 0 else 0.0

    def figures(self, now: float) -> dict:
        """The current figures: rates over the last `WINDOW` s, totals, latencies (ms).

        ``latency_p95_ms`` is of the last `RECENT` frames. Computed once a
        frame (the stats channel): in plain Python, which on 256 values
        costs a fraction of `numpy.percentile`'s fixed cost.
        """
        lat = self._recent
        return {"fps_in": self._rate(self._in, now), "fps_out": self._rate(self._out, now),
                "frames_in": self.frames_in, "frames_out": self.frames_out, "dropped": self.dropped,
                "latency_ms": lat[-1] if lat else None,
                "latency_p95_ms": percentile(lat, 95) if lat else None}

    def line(self, now: float) -> str:
        """The status line: ``in 6.0/s  out 6.0/s  dropped 0  latency 21 ms (p95 25 ms)``."""
        f = self.figures(now)
        lat = "-" if f["latency_ms"] is None else \
            f"{f['latency_ms']:.0f} ms (p95 {f['latency_p95_ms']:.0f} ms)"
        return (f"in {f['fps_in']:.1f}/s  out {f['fps_out']:.1f}/s  frames {f['frames_out']}  "
                f"dropped {f['dropped']}  latency {lat}")

    def summary(self, now: float) -> dict:
        """The whole run: frames in, out, dropped, mean rates, latency median and 95th percentile."""
        wall = max(now - self.start, 1e-12)
        lat = np.array([r[4] for r in self.rows])
        return {"frames_in": self.frames_in, "frames_out": self.frames_out, "dropped": self.dropped,
                "seconds": wall, "fps_in": self.frames_in / wall, "fps_out": self.frames_out / wall,
                "latency_median_ms": float(np.median(lat)) if len(lat) else None,
                "latency_p95_ms": float(np.percentile(lat, 95)) if len(lat) else None}

    def write_csv(self, path: str | os.PathLike) -> Path:
        """One row per published frame (`CSV_FIELDS`), written atomically."""
        path = Path(path)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.part")
        with open(tmp, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(CSV_FIELDS)
            for row in self.rows:
                w.writerow([f"{v:.6f}" if isinstance(v, float) else v for v in row])
        os.replace(tmp, path)
        return path
