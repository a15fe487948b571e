"""Shared geometry kernels (Numba): vectors, half-edges, the heap, raster lines.

The Delaunay triangulation, fan pruning, the pixel-grid kernels and the depth
render are compiled (`rangemesh._core`).

Every method of rangemesh builds on these; nothing here knows about a method.
Kernels trust their inputs: the public functions that call them check shapes,
dtypes and values and allocate the outputs.
"""
