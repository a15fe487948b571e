"""Synthetic range images with known answers: planes, creases, boxes, domes, stairs.

Every scene is made deterministically (noise from a seeded generator) and
carries its exact discontinuities (jump and crease pixels) and a surface
label per pixel, so that tests and benchmarks can measure what they claim.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Scene", "plane", "crease", "box", "dome", "stairs", "pyramid", "SCENES", "make"]


@dataclass(frozen=True)
class Scene:
    """A synthetic range image and its ground truth.

    Attributes
    ----------
    name : str
    depth : (H, W) ndarray of float64
        Depth; background pixels hold NaN.
    discontinuities : (H, W) ndarray of bool
        Pixels next to a jump or on a crease (exact, from the construction).
    labels : (H, W) ndarray of int64
        One id per planar or smooth surface; -1 on background.
    description : str
    """

    name: str
    depth: np.ndarray
    discontinuities: np.ndarray
    labels: np.ndarray
    description: str


def _grid(shape):
    r, c = np.mgrid[0 : shape[0], 0 : shape[1]]
    return r.astype(np.float64), c.astype(np.float64)


def _jumps(labels: np.ndarray) -> np.ndarray:
    """Pixels with a 4-neighbour of another label."""
    out = np.zeros(labels.shape, bool)
    dv = labels[1:, :] != labels[:-1, :]
    dh = labels[:, 1:] != labels[:, :-1]
    out[1:, :] |= dv
    out[:-1, :] |= dv
    out[:, 1:] |= dh
    out[:, :-1] |= dh
    return out


def _noisy(depth, noise, seed):
    if noise <= 0:
        return depth
    rng = np.random.default_rng(seed)
    return depth + rng.normal(0.0, noise, depth.shape)


def plane(shape=(120, 160), *, slope=(0.3, 0.2), noise=0.0, seed=0) -> Scene:
    """One tilted plane ``100 + a*r + b*c``: no discontinuity at all."""
    r, c = _grid(shape)
    d = 100.0 + slope[0] * r + slope[1] * c
    labels = np.zeros(shape, np.int64)
    return Scene("plane", _noisy(d, noise, seed), np.zeros(shape, bool), labels,
                 "a single tilted plane")


def crease(shape=(120, 160), *, slope=0.6, noise=0.0, seed=0) -> Scene:
    """Two planes meeting along an oblique crease line (a roof ridge)."""
    r, c = _grid(shape)
    u = c - 0.7 * r - 0.5 * shape[1] + 0.35 * shape[0] + 0.3
    d = 100.0 + slope * np.where(u < 0, -u, 0.7 * u) + 0.1 * r
    labels = (u >= 0).astype(np.int64)
    disc = np.abs(u) < 1.0
    return Scene("crease", _noisy(d, noise, seed), disc, labels,
                 "two planes meeting at an oblique crease")


def pyramid(shape=(120, 160), *, height=60.0, noise=0.0, seed=0) -> Scene:
    """A four-sided pyramid on a plane: diagonal creases and a square base crease."""
    r, c = _grid(shape)
    h, w = shape
    rc, cc = (h - 1) / 2.0, (w - 1) / 2.0
    half = 0.35 * min(h, w)
    dr, dc = np.abs(r - rc), np.abs(c - cc)
    m = np.maximum(dr, dc)
    d = 100.0 + np.where(m < half, height * (1.0 - m / half), 0.0)
    labels = np.where(m >= half, 0,
                      np.where(dr > dc, np.where(r < rc, 1, 2), np.where(c < cc, 3, 4)))
    disc = (np.abs(dr - dc) < 1.0) & (m < half) | (np.abs(m - half) < 1.0)
    return Scene("pyramid", _noisy(d, noise, seed), disc, labels.astype(np.int64),
                 "a four-sided pyramid on a plane (creases only)")


def box(shape=(120, 160), *, height=60.0, noise=0.0, seed=0) -> Scene:
    """A box standing on a tilted plane: a rectangle of jump edges."""
    r, c = _grid(shape)
    h, w = shape
    inside = (r >= 0.3 * h) & (r < 0.7 * h) & (c >= 0.3 * w) & (c < 0.65 * w)
    base = 100.0 + 0.2 * r + 0.1 * c
    d = np.where(inside, base + height, base)
    labels = inside.astype(np.int64)
    return Scene("box", _noisy(d, noise, seed), _jumps(labels), labels,
                 "a box on a tilted plane (jump edges)")


def dome(shape=(120, 160), *, noise=0.0, seed=0) -> Scene:
    """A spherical cap on a background of no depth: curved surface, silhouette jumps."""
    r, c = _grid(shape)
    h, w = shape
    rad = 0.4 * min(h, w)
    q = (r - (h - 1) / 2.0) ** 2 + (c - (w - 1) / 2.0) ** 2
    inside = q < rad**2
    d = np.where(inside, 100.0 + np.sqrt(np.maximum(rad**2 - q, 0.0)), np.nan)
    d = _noisy(d, noise, seed)
    labels = np.where(inside, 0, -1).astype(np.int64)
    return Scene("dome", d, _jumps(labels) & inside, labels,
                 "a spherical cap surrounded by background (NaN)")


def stairs(shape=(120, 160), *, steps=4, rise=15.0, noise=0.0, seed=0) -> Scene:
    """A staircase: horizontal treads, each a jump above the previous one."""
    r, c = _grid(shape)
    k = np.minimum((c * steps / shape[1]).astype(np.int64), steps - 1)
    d = 100.0 + rise * k + 0.05 * r
    return Scene("stairs", _noisy(d, noise, seed), _jumps(k), k,
                 f"{steps} stairs (parallel jump edges)")


SCENES = {f.__name__: f for f in (plane, crease, pyramid, box, dome, stairs)}


def make(name: str, shape=(120, 160), **kwargs) -> Scene:
    """Build a scene by name: one of ``SCENES``.

    Raises
    ------
    ValueError
        For an unknown name.
    """
    if name not in SCENES:
        raise ValueError(f"unknown scene {name!r}; choose from {sorted(SCENES)}")
    return SCENES[name](shape, **kwargs)
