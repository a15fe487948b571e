"""Reading range images and reading/writing mesh files, through well-kept libraries.

Range images: ``.npy`` (NumPy), PNG/PGM/PPM/PFM (imageio with Pillow: 8- and
16-bit, ASCII and binary PNM), TIFF (tifffile: integer and float) and the
``z`` channel of organised ``.pcd`` point clouds (pypcd4, an optional extra).

Meshes: PLY through plyfile (binary by default, ASCII on request, optional
per-vertex ``row``/``col``), OBJ, OFF, STL and GLB through trimesh. Every file
is written to a temporary file in the target folder and renamed into place,
so a failed run never leaves a half-written file.

The reader and writer of each suffix are one entry of `FORMATS`; the
suffixes the entry points take (`IMAGE_SUFFIXES`, `MESH_SUFFIXES`) come
from it.

One module a job, data flowing one way (entry points -> the table -> the formats):

* `images` (`read_range_image`, `read_color_image`), `scans` (LiDAR ``.bin``:
  `read_lidar_bin`, `bin_layout`, `read_scan`) and `meshes` (`write_mesh`,
  `read_mesh`): the entry points;
* `formats`: the table of formats by suffix (`FORMATS`, `Format`);
* `image_readers`, `mesh_readers`, `mesh_writers`: one reader or writer a format;
* `headers` (PNG and Netpbm headers, Pillow's size limit), `files` (atomic
  writes: `atomic_path`, `part_owner`), `camera_text` (the camera in a mesh
  file's comments) and `paths` (what every reader checks of a path).
"""

from .files import atomic_path
from .formats import FORMATS, IMAGE_SUFFIXES, MESH_SUFFIXES, Format
from .headers import read_image_size
from .images import NotDepthImage, read_color_image, read_range_image
from .meshes import read_mesh, write_mesh
from .scans import SCAN_SUFFIX, bin_layout, read_lidar_bin, read_scan

__all__ = [
    "IMAGE_SUFFIXES",
    "SCAN_SUFFIX",
    "MESH_SUFFIXES",
    "FORMATS",
    "Format",
    "read_range_image",
    "read_image_size",
    "read_lidar_bin",
    "bin_layout",
    "read_scan",
    "read_color_image",
    "write_mesh",
    "read_mesh",
    "atomic_path",
    "NotDepthImage",
]
