"""Optional dependencies: import them when a feature needs them, or say which extra to install."""

from __future__ import annotations

import importlib

__all__ = ["require"]

# module -> the extra of rangemesh that installs it
EXTRAS = {
    "matplotlib": "preview",
    "trimesh": "formats",
    "pypcd4": "pcd",
    "dask": "dask",
    "distributed": "dask",
    "open3d": "open3d",
    "rosbags": "ros",
    "foxglove": "live",
    "pyrealsense2": "realsense",
    "ouster": "ouster",
}


def require(module: str, feature: str):
    """Import `module` (dotted names allowed) or raise an ImportError that says what to install.

    Parameters
    ----------
    module : str
        E.g. ``"matplotlib.figure"``.
    feature : str
        What needs it, for the message (``"--preview"``, ``"OBJ output"``).

    Raises
    ------
    ImportError
        One line naming the feature and the pip command that installs the module.
    """
    try:
        return importlib.import_module(module)
    except ImportError:
        top = module.split(".")[0]
        extra = EXTRAS.get(top, "all")
        raise ImportError(
            f"{feature} needs {top}, which is not installed: pip install \"rangemesh[{extra}]\""
        ) from None
