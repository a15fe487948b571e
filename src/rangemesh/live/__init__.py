"""Live meshing: a depth camera or a LiDAR in, meshes out while the sensor runs.

* `sources`: the frames of a RealSense (device or ``.bag``, `pyrealsense2`),
  an Ouster (sensor or ``.pcap``/``.osf``, `ouster-sdk`) or a ROS recording.
* `pacing`: the playback clock (``--pace``), the device's reader thread and
  the newest-frame-wins queue (``--queue``).
* `messages`: a mesh as a ``foxglove.SceneUpdate``, built from its arrays.
* `sinks`: the Foxglove WebSocket server and MCAP file (`foxglove-sdk`), a
  folder of mesh files.
* `stats`: frames/s in and out, drops, latency; the status line and the CSV.
* `workers`: frames meshed at once on a pool of threads (``RANGEMESH_THREADS``),
  a recording read ahead, the meshes handed out in order.
* `session`: `live` (a generator of ``(stamp, frame_id, mesh)``) and `run`
  (``rangemesh live``).

``rangemesh.live`` is this package and is also callable: ``rangemesh.live(source,
**options)`` is `rangemesh.live.session.live`.
"""

import sys
import types

from .session import live, run

__all__ = ["live", "run"]


class _CallablePackage(types.ModuleType):
    """``rangemesh.live(...)`` calls `live`: the package and the function share the name."""

    def __call__(self, source, **options):
        return live(source, **options)


sys.modules[__name__].__class__ = _CallablePackage
