"""The compiled core: C++17 kernels (``_ext``), built by scikit-build-core at ``pip install``.

The kernels trust their inputs: the public functions that call them check
shapes, dtypes and values. Nothing here imports the rest of rangemesh. Names
with a leading underscore are exposed for the tests only.
"""

from . import _ext

globals().update((name, getattr(_ext, name)) for name in dir(_ext) if not name.startswith("__"))
__all__ = [name for name in dir(_ext) if not name.startswith("_")]
