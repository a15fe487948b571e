"""Shared geometry in Python: the 360-degree seam of a spinning LiDAR's image.

The kernels every method builds on (half-edges, Delaunay, the row scan, the
heap, rasterising) are compiled C++ (`rangemesh._core`).
"""
