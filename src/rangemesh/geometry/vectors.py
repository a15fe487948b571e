"""Small 3-D vector kernels and the camera lift, shared by every stage.

No ``fastmath``: angles and normals must be reproducible bit for bit.
"""

import math

from numba import njit


@njit(cache=True)
def lift(r, c, d, cam):
    """3-D point of pixel (r, c) with stored depth d; same formulas as camera.backproject."""
    if cam[0] == 0.0:
        return cam[1] * r, cam[2] * c, cam[3] * d
    if cam[0] == 2.0:  # a ray per pixel, stored after the 6 header slots
        k = 6 + 3 * (int(r) * int(cam[2]) + int(c))
        s = d * cam[3]
        return s * cam[k], s * cam[k + 1], s * cam[k + 2]
    z = d * cam[5]
    return (c - cam[3]) * z / cam[1], (r - cam[4]) * z / cam[2], z


@njit(cache=True)
def orient(ra, ca, rb, cb, rc, cc):
    """Twice the signed area of (a, b, c) in the (r, c) plane; > 0 is counter-clockwise."""
    return (rb - ra) * (cc - ca) - (cb - ca) * (rc - ra)


@njit(cache=True)
def angle(ax, ay, az, bx, by, bz):
    """Angle between two vectors in radians, 0 if either is zero (atan2 form, robust)."""
    cx = ay * bz - az * by
    cy = az * bx - ax * bz
    cz = ax * by - ay * bx
    return math.atan2(math.sqrt(cx * cx + cy * cy + cz * cz), ax * bx + ay * by + az * bz)


@njit(cache=True)
def unit_normal(vertices, a, b, c):
    """Unit normal of triangle (a, b, c) of `vertices`, (0, 0, 0) when it is degenerate."""
    ux = vertices[b, 0] - vertices[a, 0]
    uy = vertices[b, 1] - vertices[a, 1]
    uz = vertices[b, 2] - vertices[a, 2]
    wx = vertices[c, 0] - vertices[a, 0]
    wy = vertices[c, 1] - vertices[a, 1]
    wz = vertices[c, 2] - vertices[a, 2]
    nx = uy * wz - uz * wy
    ny = uz * wx - ux * wz
    nz = ux * wy - uy * wx
    norm = math.sqrt(nx * nx + ny * ny + nz * nz)
    if norm == 0.0:
        return 0.0, 0.0, 0.0
    return nx / norm, ny / norm, nz / norm


@njit(cache=True)
def max_internal_angle(vertices, a, b, c):
    """Largest of the three 3-D internal angles of triangle (a, b, c), radians."""
    best = 0.0
    for k in range(3):
        p = (a, b, c)[k]
        q = (a, b, c)[(k + 1) % 3]
        s = (a, b, c)[(k + 2) % 3]
        ang = angle(
            vertices[q, 0] - vertices[p, 0],
            vertices[q, 1] - vertices[p, 1],
            vertices[q, 2] - vertices[p, 2],
            vertices[s, 0] - vertices[p, 0],
            vertices[s, 1] - vertices[p, 1],
            vertices[s, 2] - vertices[p, 2],
        )
        best = max(best, ang)
    return best
