"""The one way a stage's wall time is taken: `timed`, on the one clock `now`.

Every ``stats.seconds`` entry, a batch row's ``seconds`` and the command
line's elapsed time are measured with them, so that they all mean the same
thing (wall time, ``time.perf_counter``).
"""

from __future__ import annotations

from time import perf_counter

__all__ = ["timed", "now"]

# The clock: what `triangulate` reads at its start and end (a plain call there: its fixed cost).
now = perf_counter


class timed:  # noqa: N801 - a context manager read as a phrase: ``with timed(seconds, "seam")``
    """Time a block into ``seconds[name]``, or read a running clock.

    ``with timed(seconds, name):`` adds the block's wall time to
    ``seconds[name]`` (0 when absent), also when the block raises. Without a
    ``with``, ``clock = timed()`` starts a clock whose `elapsed` is read where
    a function returns (a function with several returns times all of them).

    Parameters
    ----------
    seconds : dict of str to float, optional
        Filled on leaving the block; None: only `elapsed`.
    name : str, default 'total'

    Examples
    --------
    >>> seconds = {}
    >>> with timed(seconds, "sampling"):
    ...     pass
    >>> list(seconds), seconds["sampling"] >= 0.0
    (['sampling'], True)
    """

    __slots__ = ("seconds", "name", "start")

    def __init__(self, seconds: dict | None = None, name: str = "total"):
        self.seconds = seconds
        self.name = name
        self.start = perf_counter()

    def __enter__(self) -> timed:
        self.start = perf_counter()
        return self

    def __exit__(self, *exc) -> None:
        if self.seconds is not None:
            self.seconds[self.name] = self.seconds.get(self.name, 0.0) + perf_counter() - self.start

    @property
    def elapsed(self) -> float:
        """Seconds since the clock started (its creation, or entering the block)."""
        return perf_counter() - self.start
