"""method="refine": a coarse mesh refined by greedy insertion until a target is met."""

from .insertion import greedy_mesh

__all__ = ["greedy_mesh"]
