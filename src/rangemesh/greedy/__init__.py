"""Greedy insertion: the worst pixel becomes a vertex, until a vertex count or an error bound is met."""

from .insertion import greedy_mesh

__all__ = ["greedy_mesh"]
