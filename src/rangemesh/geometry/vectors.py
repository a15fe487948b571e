"""The orientation test of the Numba kernels not yet in the compiled core.

The camera lift, angles and normals live in the core (``_core/geometry/vectors.hpp``).
"""

from numba import njit


@njit(cache=True)
def orient(ra, ca, rb, cb, rc, cc):
    """Twice the signed area of (a, b, c) in the (r, c) plane; > 0 is counter-clockwise."""
    return (rb - ra) * (cc - ca) - (cb - ca) * (rc - ra)
