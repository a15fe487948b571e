#pragma once
// A first mesh's arrays, for the whole image (mesh.cpp) and for a strip (halves.cpp): the
// corners first, then grid (and seam) pixels, triangulated in the Delaunay test's units.

#include <cmath>
#include <utility>
#include <vector>

#include "../geometry/delaunay.hpp"
#include "image.hpp"
#include "insertion.hpp"

namespace rangemesh::refine {

template <class T>
Span<const T> view(const std::vector<T>& v) {
    return {v.data(), static_cast<index_t>(v.size())};
}

template <class T>
Span<const T> view(Span<T> s) {
    return {s.data, s.size};
}

// Python's int(round(x)) of a float: ties to even.
inline index_t round_even(double x) { return static_cast<index_t>(std::nearbyint(x)); }

// Grid rows (or columns) of a first mesh: Python's int(round(sqrt(a / b))).
inline index_t grid_side(index_t a, index_t b) {
    return round_even(std::sqrt(static_cast<double>(a) / static_cast<double>(b)));
}

struct StartArrays {
    std::vector<index_t> vr, vc, triangles, halfedges;
    std::vector<double> vz;  // the four corners' depths, set by the caller; the others added here

    FirstMesh view() const {
        return {refine::view(vr), refine::view(vc), refine::view(vz), refine::view(triangles), refine::view(halfedges)};
    }

    // The image rectangle cut in two, (0,0) (H-1,0) (H-1,W-1) and (0,0) (H-1,W-1) (0,W-1).
    void rectangle() {
        triangles = {0, 1, 2, 0, 2, 3};
        halfedges = {-1, -1, 3, 2, -1, -1};
    }

    // Delaunay of the points in units sr x sc (the rectangle for the corners alone), and the
    // depths of the points after the corners.
    void triangulate(const Image& image, index_t sr, index_t sc) {
        const index_t n = static_cast<index_t>(vr.size());
        if (n > 4) {
            std::vector<index_t> r(n), c(n);
            for (index_t i = 0; i < n; ++i) {
                r[i] = vr[i] * sr;
                c[i] = vc[i] * sc;
            }
            Triangulation t = delaunay_sweep(PointSet{refine::view(r), refine::view(c)});
            require(!t.triangles.empty(), "first_mesh: the image corners cannot be collinear");
            triangles = std::move(t.triangles);
            halfedges = std::move(t.halfedges);
        } else {
            rectangle();
        }
        for (index_t i = 4; i < n; ++i) vz.push_back(image.depth(vr[i], vc[i]));
    }
};

}  // namespace rangemesh::refine
