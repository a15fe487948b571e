"""Reading KITTI-style LiDAR ``.bin`` scans, laid out by their beams file."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..camera import beams_numbers, read_beams
from ..checks import whole_number
from .images import read_range_image
from .paths import _check_readable, _first_line

# A KITTI-style LiDAR scan: read with its beams file (`read_scan`, `bin_layout`).
SCAN_SUFFIX = ".bin"


def read_lidar_bin(path: str | os.PathLike, beams: int, *, column_shift=None,
                   steps: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Read a KITTI-style LiDAR scan (``.bin``) as range and intensity images.

    The file holds float32 ``x y z intensity`` records, one per return,
    ordered azimuth step by azimuth step, all `beams` beams of a step
    together (index ``step * beams + beam``); a missing return is the point
    (0, 0, 0). Row ``b`` of the images is beam ``b``, column ``s`` is step
    ``s``.

    Parameters
    ----------
    path : str or os.PathLike
    beams : int
        Beams of the sensor (64 for an Ouster OS1-64 or a Velodyne HDL-64).
    column_shift : (beams,) sequence of int, optional
        Destagger: roll row ``b`` by ``column_shift[b]`` columns so that a
        column is one azimuth for every beam (the ``column_shift`` of a
        ``.beams.json`` file; what the Ouster SDK's ``destagger`` does).
    steps : int, optional
        The azimuth steps (columns) the scan must have (a beams file's
        ``cols``): the file's size is checked against it before it is read.

    Returns
    -------
    range : (beams, steps) ndarray of float32
        ``sqrt(x² + y² + z²)``, 0 where there is no return.
    intensity : (beams, steps) ndarray of float32

    Raises
    ------
    ValueError
        A file whose size is not a whole number of steps (or not `steps`
        steps), or a shift list of the wrong length.
    """
    path = Path(path)
    _check_readable(path)
    beams = int(beams)
    size = path.stat().st_size
    if beams < 1 or size == 0 or size % (16 * beams):
        raise ValueError(f"{path}: {size} bytes is not a whole number of {beams}-beam steps of "
                         f"float32 x, y, z, intensity (16 bytes a point)")
    if steps is not None and size != 16 * beams * int(steps):
        raise ValueError(f"{path}: {size} bytes is {size // (16 * beams)} steps of {beams} beams, "
                         f"not the {int(steps)} the beams file gives")
    pts = np.fromfile(path, dtype="<f4").reshape(-1, beams, 4).transpose(1, 0, 2)
    with np.errstate(over="ignore", invalid="ignore"):  # a range beyond float32 is inf: no return
        rng = np.sqrt(np.sum(pts[..., :3].astype(np.float64) ** 2, axis=2)).astype(np.float32)
    inten = np.ascontiguousarray(pts[..., 3])
    if column_shift is not None:
        shift = np.asarray(column_shift, dtype=np.int64)
        if shift.shape != (beams,):
            raise ValueError(f"column_shift must have one value per beam ({beams}), "
                             f"got shape {shift.shape}")
        rng = np.stack([np.roll(row, k) for row, k in zip(rng, shift, strict=True)])
        inten = np.stack([np.roll(row, k) for row, k in zip(inten, shift, strict=True)])
    return rng, inten


def bin_layout(beams_path: str | os.PathLike) -> dict:
    """How a ``.bin`` scan is laid out, from its beams file: `read_lidar_bin`'s arguments.

    Returns
    -------
    dict
        ``rows`` (beams), ``cols`` (azimuth steps, or None) and
        ``column_shift`` (one whole number a beam, or None).

    Raises
    ------
    ValueError
        A beams file that cannot be read, or whose values are not whole numbers;
        the message names the file and the key.
    """
    beams = read_beams(beams_path)
    try:
        rows = whole_number("beams: rows", beams["rows"], minimum=1)
        cols = beams.get("cols")
        cols = None if cols is None else whole_number("beams: cols", cols, minimum=1)
        shift = beams.get("column_shift")
        shift = None if shift is None else beams_numbers("column_shift", shift, whole=True)
    except KeyError:
        raise ValueError(f"{beams_path}: a beams file for a .bin scan gives its 'rows'") from None
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{beams_path}: {_first_line(exc)}") from None
    return {"rows": rows, "cols": cols, "column_shift": shift, "beams": beams}


def read_scan(path: str | os.PathLike, layout: dict | None = None) -> np.ndarray:
    """A range image: an image file (`read_range_image`), or a LiDAR ``.bin`` scan's ranges.

    Parameters
    ----------
    path : str or os.PathLike
    layout : dict, optional
        The ``.bin`` scan's layout from its beams file (`bin_layout`); needed
        for ``.bin`` files only.

    Raises
    ------
    ValueError
        A file that cannot be read as either, or a ``.bin`` without `layout`.
    """
    if Path(path).suffix.lower() != SCAN_SUFFIX:
        return read_range_image(path)
    if layout is None:
        raise ValueError(f"{path}: a .bin LiDAR scan needs --beams FILE.json (its rows and "
                         f"column shifts)")
    try:
        rows, cols = layout["rows"], layout["cols"]
        if cols is not None and layout.get("beams") is not None and Path(path).is_file() \
                and Path(path).stat().st_size != 16 * rows * cols:
            # not the organised scan the file lays out: an unorganised cloud (KITTI's dropped
            # returns left out), each point put in its pixel by the file's beams
            from ..clouds import project_scan, read_cloud

            return project_scan(read_cloud(path), beams=layout["beams"]).ranges
        rng, _ = read_lidar_bin(path, rows, column_shift=layout["column_shift"], steps=cols)
    except OSError as exc:
        raise ValueError(f"{path}: {_first_line(exc)}") from None
    return rng
