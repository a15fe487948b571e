// 3-D vectors of the mesh: the camera lift of a pixel, angles, triangle normals.
//
// Every expression keeps the order of evaluation of the Python definitions (no contraction, no
// reassociation), so normals and angles are the same doubles bit for bit.
#pragma once

#include <cmath>

#include "../views.hpp"

namespace rangemesh {

struct Vec3 {
    double x = 0.0, y = 0.0, z = 0.0;
};

inline Vec3 operator-(const Vec3& a, const Vec3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }

inline bool is_zero(const Vec3& a) { return a.x == 0.0 && a.y == 0.0 && a.z == 0.0; }

// Python's max(a, b) and min(a, b) on floats: b only when it compares greater (less), so a NaN
// in b keeps a.
inline double py_max(double a, double b) { return b > a ? b : a; }
inline double py_min(double a, double b) { return b < a ? b : a; }

// The camera kinds of `Camera.as_array()` (its first slot); the layout is in camera.py:
// orthographic [0, kx, ky, kz, 0, 0]; pinhole [1, fx, fy, cx, cy, depth_scale];
// rays [2, H, W, range_scale, 0, 0, then the (H, W, 3) unit rays row-major].
enum CameraKind { ORTHOGRAPHIC = 0, PINHOLE = 1, RAYS = 2 };
constexpr index_t CAMERA_HEADER = 6;

// The 3-D point of pixel (r, c) with stored depth d: the formulas of camera.backproject.
inline Vec3 lift(Span<const double> cam, index_t r, index_t c, double d) {
    if (cam[0] == ORTHOGRAPHIC) {
        return {cam[1] * static_cast<double>(r), cam[2] * static_cast<double>(c), cam[3] * d};
    }
    if (cam[0] == RAYS) {
        const index_t k = CAMERA_HEADER + 3 * (r * static_cast<index_t>(cam[2]) + c);
        const double s = d * cam[3];
        return {s * cam[k], s * cam[k + 1], s * cam[k + 2]};
    }
    const double z = d * cam[5];
    return {(static_cast<double>(c) - cam[3]) * z / cam[1], (static_cast<double>(r) - cam[4]) * z / cam[2], z};
}

// The angle between two vectors in radians, 0 when either is zero (the atan2 form, robust near
// 0 and pi).
inline double angle(const Vec3& a, const Vec3& b) {
    const double cx = a.y * b.z - a.z * b.y;
    const double cy = a.z * b.x - a.x * b.z;
    const double cz = a.x * b.y - a.y * b.x;
    return std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz), a.x * b.x + a.y * b.y + a.z * b.z);
}

// Row v of an (n, 3) array of points or normals.
inline Vec3 row3(Grid<const double> points, index_t v) {
    const double* p = points.row(v);
    return {p[0], p[1], p[2]};
}

// The unit normal of triangle (a, b, c) of `vertices`, (0, 0, 0) when it is degenerate.
inline Vec3 unit_normal(Grid<const double> vertices, index_t a, index_t b, index_t c) {
    const Vec3 pa = row3(vertices, a);
    const Vec3 u = row3(vertices, b) - pa;
    const Vec3 w = row3(vertices, c) - pa;
    const double nx = u.y * w.z - u.z * w.y;
    const double ny = u.z * w.x - u.x * w.z;
    const double nz = u.x * w.y - u.y * w.x;
    const double norm = std::sqrt(nx * nx + ny * ny + nz * nz);
    if (norm == 0.0) return {};
    return {nx / norm, ny / norm, nz / norm};
}

// The largest of the three 3-D internal angles of triangle (a, b, c), in radians.
inline double max_internal_angle(Grid<const double> vertices, index_t a, index_t b, index_t c) {
    const index_t corners[3] = {a, b, c};
    double best = 0.0;
    for (int k = 0; k < 3; ++k) {
        const Vec3 p = row3(vertices, corners[k]);
        const Vec3 q = row3(vertices, corners[(k + 1) % 3]);
        const Vec3 s = row3(vertices, corners[(k + 2) % 3]);
        best = py_max(best, angle(q - p, s - p));
    }
    return best;
}

}  // namespace rangemesh
