"""ROS recordings in, meshes back in time: ROS 1 bags, ROS 2 bags (``.db3``, ``.mcap``).

* `reading`: the recording, its depth topics, each depth message with its
  CameraInfo and colour (`rosbags`, an optional extra: ``rangemesh[ros]``).
* `decode`: depth (``16UC1``, ``mono16``, ``32FC1``, ``compressedDepth``) and
  colour images out of the messages.
* `writing`: meshes as ``visualization_msgs/Marker`` messages in an MCAP file.
* `meshing`: `mesh_bag` (a generator) and `mesh_recording` (the batch,
  in this process or on Dask workers).
"""

from .meshing import MeshFrame, SkippedFrame, mesh_bag, mesh_recording
from .reading import Recording, is_recording

__all__ = ["mesh_bag", "mesh_recording", "MeshFrame", "SkippedFrame", "Recording", "is_recording"]
