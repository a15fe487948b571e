"""A picture of a result: wireframe over the range image, samples, shaded mesh."""

from __future__ import annotations

import os
import warnings

import numpy as np

from .geometry.seam import is_seam
from .io import atomic_path
from .mesh import Mesh
from .metrics import Evaluation, render_depth

__all__ = ["shade", "save_preview"]


# Longest side of each panel's image, pixels: larger images are shown one pixel in `step`
# (a 500 px panel cannot show more, and full-size buffers of a large image cost gigabytes).
MAX_PANEL_PIXELS = 1000
# Images this many times wider than tall (a spinning LiDAR's 64 x 2048) get the panels stacked,
# the full width of the picture each, rows stretched to at least PANEL_MIN_HEIGHT inches.
WIDE = 4.0
WIDE_PIXELS = 1600
PANEL_MIN_HEIGHT = 1.8


def shade(mesh: Mesh, shape=None, *, step: int = 1) -> np.ndarray:
    """Lambert shading of the mesh, seen from the camera, as an image.

    Each pixel takes the shade of the face that covers it (flat shading, so
    creases and jumps show as changes of tone); NaN where no face covers it.

    Parameters
    ----------
    mesh : Mesh
    shape : (int, int), optional
        Default ``mesh.image_shape``.
    step : int, default 1
        Shade one pixel in `step` along rows and columns (see `render_depth`).

    Returns
    -------
    (ceil(H/step), ceil(W/step)) ndarray of float64 in [0, 1]
    """
    _, face = render_depth(mesh, shape, step=step)
    out = np.full(face.shape, np.nan)
    if mesh.is_empty:
        return out
    p = mesh.vertices[mesh.faces]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.divide(n, norm, out=np.zeros_like(n), where=norm > 0)
    # Light from the viewer's side, a little from the top-left; the sign of the
    # normal depends on the camera's handedness, so use |cos|.
    light = np.array([-0.35, -0.35, 1.0])
    light /= np.linalg.norm(light)
    tone = 0.15 + 0.85 * np.abs(n @ light)
    hit = face >= 0
    out[hit] = tone[face[hit]]
    return out


def _colour_shade(mesh: Mesh, shaded: np.ndarray, step: int) -> np.ndarray:
    """RGB picture: each face's mean vertex colour times its shade; black where no face."""
    _, face = render_depth(mesh, step=step)
    rgb = np.zeros(face.shape + (3,))
    hit = face >= 0
    face_rgb = mesh.colors[mesh.faces].mean(axis=1) / 255.0
    rgb[hit] = face_rgb[face[hit]] * (0.35 + 0.65 * shaded[hit])[:, None]
    return rgb


def save_preview(mesh: Mesh, depth: np.ndarray, valid: np.ndarray, path: str | os.PathLike, *,
                 evaluation: Evaluation | None = None, title: str = "",
                 weights: np.ndarray | None = None) -> None:
    """Save a three-panel PNG: wireframe on the range image, samples, shaded mesh.

    Parameters
    ----------
    mesh : Mesh
    depth : (H, W) ndarray of float64
        Range image (background values are not shown).
    valid : (H, W) ndarray of bool
    path : str or os.PathLike
        PNG file; written atomically.
    evaluation : Evaluation, optional
        Adds the relative error to the title.
    title : str
        Shown before the key figures.
    weights : (H, W) ndarray, optional
        Sampling weights shown under the sample points (default: the range image).
    """
    from ._optional import require

    matplotlib = require("matplotlib", "the preview picture")
    matplotlib.use("Agg", force=False)
    Figure = require("matplotlib.figure", "the preview picture").Figure  # noqa: N806

    h, w = depth.shape
    wide = w > WIDE * h
    step = max(1, -(-max(h, w) // (WIDE_PIXELS if wide else MAX_PANEL_PIXELS)))
    depth, valid = depth[::step, ::step], valid[::step, ::step]  # views: no full-size copy
    shown = np.where(valid, depth, np.nan)
    s = mesh.stats
    did = (f"{s.flipped_edges} flips by the error" if s.method == "refine"
           else f"{s.flipped_edges} flips")  # refine's flips follow the error, not disparity
    figs = [f"{s.vertices} vertices", f"{s.triangles} triangles", s.method, did]
    if s.seconds.get("total"):
        figs.append(f"{1000 * s.seconds['total']:.1f} ms")
    if evaluation is not None:
        figs.append(f"relative error {evaluation.relative_error:.3f} %")
    aspect = h / max(w, 1)
    if wide:
        panel = max(PANEL_MIN_HEIGHT, 16.0 * aspect)
        fig = Figure(figsize=(16, 3 * panel + 1.0), dpi=100, layout="constrained")
        axes = fig.subplots(3, 1)
        stretch = panel / (16.0 * aspect)
        if stretch > 1.05:
            figs.append(f"rows stretched {stretch:.1f}x")
    else:
        fig = Figure(figsize=(15, max(3.0, 5.0 * aspect) + 0.6), dpi=100, layout="constrained")
        axes = fig.subplots(1, 3)
    show = {"interpolation": "nearest", "aspect": "auto" if wide else "equal"}
    cmap = matplotlib.colormaps["viridis"].with_extremes(bad="black")
    axes[0].imshow(shown, cmap=cmap, **show)
    px = mesh.pixels / step  # pixel centres in the shown image's coordinates
    if not mesh.is_empty:
        # the seam's faces of a 360-degree scan would cross the whole picture
        plain = mesh.faces[~is_seam(mesh.pixels, mesh.faces)]
        axes[0].triplot(px[:, 1], px[:, 0], plain, lw=0.35 if not wide else 0.2,
                        color="white", alpha=0.8)
    axes[0].set_title("triangles over the range image")
    under = shown if weights is None else np.where(valid, weights[::step, ::step], np.nan)
    grey = matplotlib.colormaps["Greys"].with_extremes(bad="white")
    axes[1].imshow(under, cmap=grey, **show)
    if not mesh.is_empty:
        axes[1].scatter(px[:, 1], px[:, 0], s=2.0 if not wide else 0.5, c="tab:red",
                        linewidths=0)
    axes[1].set_title("sample points" + (" over the sampling weight" if weights is not None else ""))
    shaded = shade(mesh, (h, w), step=step)
    if mesh.colors is not None and not mesh.is_empty:
        axes[2].imshow(_colour_shade(mesh, shaded, step), **show)
        axes[2].set_title("shaded mesh in its vertex colours (flat shading)")
    else:
        gray = matplotlib.colormaps["gray"].with_extremes(bad="black")
        axes[2].imshow(shaded, cmap=gray, vmin=0, vmax=1, **show)
        axes[2].set_title("shaded mesh (flat shading)")
    for ax in axes:
        ax.set_xticks([])
        ax.set_yticks([])
    if step > 1:
        figs.append(f"shown 1 pixel in {step}")
    fig.suptitle((title + ": " if title else "") + ", ".join(figs))
    with atomic_path(path) as tmp, warnings.catch_warnings():
        # a file name in a script the font lacks (CJK...) is drawn with boxes; say nothing
        warnings.filterwarnings("ignore", message="Glyph .* missing from font", category=UserWarning)
        fig.savefig(tmp, format="png")
