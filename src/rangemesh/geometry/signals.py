"""Holding Ctrl-C and termination signals while compiled code runs.

Python runs a signal handler between two bytecodes. A Numba kernel is one
long C call, but it may call back into Python (to build an exception object,
say); a ``KeyboardInterrupt`` raised inside such a callback cannot unwind
through the compiled frames and ends in ``SystemError`` or a segmentation
fault. So while the kernels of a stage run:

* SIGINT, SIGTERM and SIGHUP are blocked in the calling thread, and
* their Python handlers are swapped for one that only notes the signal
  (a signal sent to the process may reach another thread, a BLAS worker
  for instance, that does not block it; its handler still runs in the main
  thread, possibly inside such a callback, where it must not raise).

When the stage returns, the mask and the handlers are put back and a noted
signal is raised again, in plain Python code, where the original handler
unwinds normally (``finally`` blocks run, temporary files are removed).

The cost is a few system calls per hold, about 40 microseconds; nested holds
cost nothing, so `rangemesh.pipeline.run` holds once for a whole meshing. A
Ctrl-C waits for the meshing that is running (milliseconds, a few seconds
on the largest images), never for the whole job.
"""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager

__all__ = ["deferred_signals", "holding_signals", "HELD_SIGNALS"]

HELD_SIGNALS = tuple(
    getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name)
)

_state = {"depth": 0}
_noted: list[int] = []


def _note(signum, frame):
    _noted.append(signum)


@contextmanager
def deferred_signals():
    """Hold `HELD_SIGNALS` inside the block; deliver the first one that came after it.

    Nested blocks hold them once, for the outermost. Outside the main thread
    (where Python runs no handler) this does nothing.
    """
    if _state["depth"] or threading.current_thread() is not threading.main_thread():
        yield
        return
    # only handlers set from Python can be put back (getsignal gives None otherwise)
    held = [s for s in HELD_SIGNALS if signal.getsignal(s) is not None]
    old_handlers = {s: signal.signal(s, _note) for s in held}
    mask = hasattr(signal, "pthread_sigmask")
    old_mask = signal.pthread_sigmask(signal.SIG_BLOCK, held) if mask else None
    _state["depth"] = 1
    try:
        yield
    finally:
        _state["depth"] = 0
        if mask:
            signal.pthread_sigmask(signal.SIG_SETMASK, old_mask)  # pending ones reach _note
        for s, handler in old_handlers.items():
            signal.signal(s, handler)
        if _noted:
            first = _noted[0]
            _noted.clear()
            signal.raise_signal(first)  # now the original handler takes it


def holding_signals(func):
    """Decorator: run `func` inside `deferred_signals` (for Python functions that call kernels)."""
    import functools

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        if _state["depth"]:  # inside a hold already: entering it again cost 4-5 us a call
            return func(*args, **kwargs)
        with deferred_signals():
            return func(*args, **kwargs)

    return wrapper
