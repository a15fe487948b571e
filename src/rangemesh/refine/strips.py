"""Greedy insertion on two vertical strips of the image at once: the same mesh on any machine.

The image is cut down one column, the seam. Its vertices are chosen first
(`rangemesh._core.seam_rows`, greedy insertion on that column's profile) and stay
fixed; each strip is then meshed by greedy insertion, on the
whole image but from a first mesh of its own columns, whose hull edges down
the seam own no pixel. No triangle crosses the seam, so the two strips'
insertions do not interact: inserting the worst triangle of the image, one
at a time, is the same as inserting each strip's worst, in the order of
their keys.

That order is kept without running the strips in lock step. Both advance
on two threads until their first key falls below a common threshold (a
*round*): whatever the threads' timing, the state they reach is the one the
one-at-a-time order passes through. Thresholds are predicted from each
strip's keys so far (a power law of the count) to reach a growing share of
the vertices asked; the last 3 % are inserted one at a time, from the strip
whose key is larger (the tail), landing exactly on the count. A round
whose prediction was far off stops a strip by count instead; the next round
(same threshold) brings it back to that order, unless it was the last. The
mesh depends only on the image and the request, never on the number of
threads. With ``diagonals='error'`` each strip's edges are then flipped on
its own thread, and after the join the seam's (`rangemesh.refine.diagonals`).

The strips' insertion, rounds, tail and flips run in compiled code
(``src/rangemesh/_core/refine/strips.cpp``), the two strips on two native threads
with the GIL released, inside the refine call (`rangemesh._core.refine_mesh`),
which also chooses the seam, builds the first meshes and joins the two meshes;
this module decides whether to use strips (`use_strips`) and holds the seam's
settings. Their former Python steps are the tests' reference
(``tests/strips_reference.py``).

``benchmarks/strips.py`` compares them with one strip (docs/benchmarks.md). A
round costs a hand-over between the threads, which is why strips start at
STRIP_MIN_VERTICES.
"""

from __future__ import annotations

__all__ = ["use_strips"]

# Strips pay once the kernel's own time dwarfs a round's overhead and the seam's vertices
# are a small share: at least this many vertices and columns.
STRIP_MIN_VERTICES = 2000
STRIP_MIN_COLUMNS = 64
# ... on images of STRIP_MIN_PIXELS valid pixels or more, with a count or an error bound alike:
# max_error's count is not known beforehand, and on smaller images strips cost it their
# set-up at small counts, while vertices=N gains little there.
STRIP_MIN_PIXELS = 60_000
# Seam vertices: this times the vertices a column gets in a mesh of uniform density.
SEAM_DENSITY = 0.7
# ... and under an error bound, as many as bring the seam's summed error to this share of its
# column's part of the bound (1-D greedy insertion gets there with few; a smaller share
# spends more vertices in the strips).
SEAM_ERROR_SHARE = 1.0
# (The rounds' own settings, ROUND_SHARE to EXPONENT_RANGE, live with them in strips.cpp.)


def use_strips(shape, vertices: int | None, max_error, n_valid: int) -> bool:
    """Whether `greedy_mesh` meshes the image as two strips.

    Images of STRIP_MIN_PIXELS valid pixels or more (and STRIP_MIN_COLUMNS
    columns): under an error bound always, with a vertex count from
    STRIP_MIN_VERTICES to half the valid pixels (the seam's pixels that are
    not its vertices can never be inserted, so strips cannot give every
    pixel). The choice depends on the request and the image only, so the
    mesh is the same on every machine (threads or not).
    """
    if shape[1] < STRIP_MIN_COLUMNS or n_valid < STRIP_MIN_PIXELS:
        return False
    if max_error is not None:
        return True
    return vertices is not None and STRIP_MIN_VERTICES <= vertices <= n_valid // 2
