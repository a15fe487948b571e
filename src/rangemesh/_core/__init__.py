"""The compiled core: C++17 kernels (``_ext``), built by scikit-build-core at ``pip install``.

The public functions that call the kernels check shapes, dtypes and values; a
raw call is checked against each kernel's contract all the same (ids and twins
in range, strides and scales within the image: ValueError) before it reads or
writes. Nothing here imports the rest of rangemesh. Names with a leading
underscore are exposed for the tests only.
"""

from . import _ext

globals().update((name, getattr(_ext, name)) for name in dir(_ext) if not name.startswith("__"))
__all__ = [name for name in dir(_ext) if not name.startswith("_")]
