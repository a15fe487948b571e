"""The walls of jumps, whose home is now `rangemesh.geometry.walls`: both methods' seams use them.

The names stay importable from here (``rangemesh.refine.walls.wall_faces``
was named in the documentation).
"""

from ..geometry.walls import drop_walls, pixel_angle, pixel_lengths, wall_faces

__all__ = ["wall_faces", "drop_walls", "pixel_lengths", "pixel_angle"]
