"""The compiled core: C++17 kernels (``_ext``), built by scikit-build-core at ``pip install``.

The kernels trust their inputs: the public functions that call them check
shapes, dtypes and values. Nothing here imports the rest of rangemesh.
"""

from . import _ext
from ._ext import *  # noqa: F403 - the extension's functions are this package's names

__all__ = [name for name in dir(_ext) if not name.startswith("_")]
