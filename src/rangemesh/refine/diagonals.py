"""Each quad's diagonal chosen by the data: edge flips that lower the error over the pixels.

Greedy insertion keeps its mesh Delaunay: every diagonal is the one that
makes rounder triangles, whatever the depths. Along a crease or a jump edge
that is not where the pixels say it is, the round diagonal cuts a corner off
one surface and puts it on the other. Dyn, Levin & Rippa's data-dependent
triangulation (1990) picks each quad's diagonal by the data instead; here the
measure is the one the insertion already ranks by: the sum of |depth - plane|
over the valid pixels of the two triangles (vertex depths copied from their
pixels). An edge is flipped when the other diagonal's sum is smaller, and the
four outer edges of its quad are tested again, until no flip lowers the sum.

* Pixels on the quad's outer edges stay with the same side after a flip (the
  ownership rules of greedy insertion, ``own_edge``: an edge's owner depends on
  its direction only, and the outer edges keep theirs), and the diagonal's pixels
  belong to one triangle either way: both diagonals are measured on the same
  pixels, and every valid pixel counts once.
* Sums are compared in the insertion's key units (2**-32 of the valid depth
  range), so a near-tie does not flip one way in metres and the
  other in millimetres (SPEC P2), and a quad that fits exactly either way (a
  plane) is never flipped.
* A quad with a background vertex (an image corner) is never flipped: those
  triangles hold no valid pixel to be judged by and are dropped afterwards;
  flipping them could uncover valid pixels.
* Every flip lowers the total strictly, so the flips end; at most
  `MAX_TESTS_PER_EDGE` tests an edge bound the time all the same.

They lower the mean error and the error near jumps of the Delaunay mesh at
a moderate cost in time, so they are `method='refine'`'s default
(``benchmarks/diagonals.py``; figures in docs/benchmarks.md).
Two things keep them cheap: on strips (`rangemesh.refine.strips`) each
strip flips on its own thread, and only the seam's edges are tested after
the join (`rangemesh._core.flip_from_edges`); and a test stops scanning once
the other diagonal is known to be no better (`rangemesh._core.triangle_error`'s
`stop`).
Every edge is tested: filters that test fewer gave back too much of the gain
(docs/decisions.md).

The kernels are compiled (``src/rangemesh/_core/refine/diagonals.cpp``):
`rangemesh._core.flip_by_error` on a mesh whose half-edges and triangle sums
greedy insertion kept (`rangemesh._core.greedy_insert` with ``InsertSettings.sums``),
`rangemesh._core.flip_from_edges` from given half-edges (a seam),
`rangemesh._core.error_flips` from scratch, and `rangemesh._core.triangle_error`,
the sum over one triangle's pixels.
"""

__all__: list[str] = []
