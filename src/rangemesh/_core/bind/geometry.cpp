// Python bindings of the shared geometry kernels.
#include "../geometry/halfedges.hpp"
#include "bindings.hpp"
#include "numpy.hpp"
#include "release.hpp"

namespace rangemesh::bind {

void bind_geometry(nb::module_& m) {
    m.def(
        "build_halfedges",
        [](In2<index_t> faces, index_t n_vertices) {
            std::vector<index_t> triangles, halfedges;
            run_released([&] { build_halfedges(grid(faces), n_vertices, triangles, halfedges); });
            return nb::make_tuple(to_numpy(std::move(triangles)), to_numpy(std::move(halfedges)));
        },
        nb::arg("faces"), nb::arg("n_vertices"),
        "Flat ``(triangles, halfedges)`` arrays (3F each) of an oriented, edge-manifold (F, 3) "
        "int64 face list; a border half-edge's twin is -1.");
    m.def(
        "count_edges",
        [](In2<index_t> faces, index_t n_vertices) {
            return run_released([&] { return count_edges(grid(faces), n_vertices); });
        },
        nb::arg("faces"), nb::arg("n_vertices"),
        "Distinct undirected edges of an (F, 3) int64 face list, any orientation, manifold or not.");
    m.def(
        "neighbors_from_halfedges",
        [](In1<index_t> halfedges) {
            const index_t n_t = halfedges.shape(0) / 3;
            std::vector<index_t> out(3 * n_t);
            run_released([&] { neighbors_from_halfedges(span(halfedges), Grid<index_t>{out.data(), n_t, 3}); });
            return to_numpy(std::move(out), n_t, 3);
        },
        nb::arg("halfedges"),
        "SciPy-style (F, 3) neighbours: entry (t, k) is the triangle across the edge opposite "
        "corner k, -1 on the border.");
}

}  // namespace rangemesh::bind
