"""A pytest plugin for .ci/sanitize: counts the calls of each compiled kernel in pytest's process.

Loaded with ``-p kernel_calls`` (this folder on PYTHONPATH) before any test imports rangemesh, so
that ``from rangemesh._core import name`` gets the counting wrapper too. Calls made in the tests'
child processes are not counted (they run sanitized all the same).
"""

import functools
from collections import Counter

from rangemesh import _core

CALLS: Counter = Counter()
KERNELS = sorted(name for name, obj in vars(_core).items() if type(obj).__name__ == "nb_func")


def _counted(name, kernel):
    @functools.wraps(kernel)
    def call(*args, **kwargs):
        CALLS[name] += 1
        return kernel(*args, **kwargs)

    return call


for _name in KERNELS:
    setattr(_core, _name, _counted(_name, getattr(_core, _name)))


def pytest_terminal_summary(terminalreporter):
    """One line of figures: the kernels called in this process, their calls, those never called."""
    called = [name for name in KERNELS if CALLS[name]]
    missed = [name for name in KERNELS if not CALLS[name]]
    terminalreporter.write_line(
        f"sanitized kernels: {len(called)} of {len(KERNELS)} called, {sum(CALLS.values()):,} calls in "
        f"pytest's process; never called: {', '.join(missed) or 'none'}"
    )
