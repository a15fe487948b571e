"""What is left of the Numba kernels of greedy insertion: the pixel-ownership rule.

Greedy insertion, its strips and the error-chosen diagonals are compiled
(``src/rangemesh/_core/refine/``; `rangemesh._core.greedy_insert`,
`rangemesh._core.strip_insert`, `rangemesh._core.flip_by_error`), where
``ownership.hpp`` holds this rule and the 2**-32 rounding of the keys.
`rangemesh.greedy.heights_kernels` (Numba, until it is ported) still uses
`_owns` to split the pixels of shared edges the same way.
"""

from numba import njit


@njit(cache=True)
def _owns(ar, ac, br, bc):
    """Whether the triangle left of the directed edge a -> b owns the pixels on it."""
    return br > ar or (br == ar and bc > ac)
