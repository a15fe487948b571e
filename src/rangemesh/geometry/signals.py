"""Holding Ctrl-C and termination signals while compiled code runs.

Python runs a signal handler between two bytecodes. A Numba kernel is one
long C call, but it may call back into Python (to build an exception object,
say); a ``KeyboardInterrupt`` raised inside such a callback cannot unwind
through the compiled frames and ends in ``SystemError`` or a segmentation
fault. So the kernels of a stage run with SIGINT, SIGTERM and SIGHUP blocked
in the calling thread; a signal that arrives meanwhile stays pending and is
delivered the moment the stage returns, in plain Python code, where it
unwinds normally (``finally`` blocks run, temporary files are removed).

The cost is two system calls per stage, a few microseconds. A Ctrl-C waits
for the stage that is running (milliseconds to a few seconds on the largest
images), never for the whole job.
"""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager

__all__ = ["deferred_signals", "holding_signals", "HELD_SIGNALS"]

HELD_SIGNALS = frozenset(
    getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name)
)


@contextmanager
def deferred_signals():
    """Block `HELD_SIGNALS` in this thread inside the block; deliver pending ones after.

    Does nothing where POSIX signal masks do not exist (Windows) and in
    threads other than the main one (Python runs handlers in the main thread
    only, so only its mask matters).
    """
    if not hasattr(signal, "pthread_sigmask") or threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, HELD_SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def holding_signals(func):
    """Decorator: run `func` inside `deferred_signals` (for Python functions that call kernels)."""
    import functools

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        with deferred_signals():
            return func(*args, **kwargs)

    return wrapper
