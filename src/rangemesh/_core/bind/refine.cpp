// Python bindings of the refine method's kernels: greedy insertion, its strips, its diagonals.
#include "../refine/insertion.hpp"
#include "bindings.hpp"
#include "numpy.hpp"
#include "release.hpp"

namespace rangemesh::bind {

namespace {

using refine::FirstMesh;
using refine::Image;
using refine::Insertion;
using refine::Stop;

template <class T>
std::vector<T> copy(Span<const T> s) {
    return std::vector<T>(s.begin(), s.end());
}

template <class T>
std::vector<T> copy(Span<T> s) {
    return std::vector<T>(s.begin(), s.end());
}

Image image_of(const In2<double>& depth, const In2<bool>& valid, double span) {
    require(depth.shape(0) == valid.shape(0) && depth.shape(1) == valid.shape(1),
            "depth and valid: one shape");
    return Image{grid(depth), grid(valid), span};
}

// Greedy insertion from a first mesh until the stop: the finished state.
Insertion insert_all(const Image& image, const FirstMesh& first, index_t max_vertices, double max_sum,
                     index_t sr, index_t sc) {
    // arrays sized for `max_vertices` when it is the stop; grown as needed under an error bound
    Insertion ins(image, first, max_sum < 0.0 ? max_vertices : 0, sr, sc);
    ins.advance(Stop{max_vertices, max_sum});
    return ins;
}

}  // namespace

void bind_refine(nb::module_& m) {
    m.def(
        "greedy_insert",
        [](In2<double> depth, In2<bool> valid, In1<index_t> vr0, In1<index_t> vc0, In1<double> vz0,
           In1<index_t> tv0, In1<index_t> he0, index_t max_vertices, double max_sum, double unit, index_t sr,
           index_t sc) {
            const Image image = image_of(depth, valid, unit);
            const FirstMesh first{span(vr0), span(vc0), span(vz0), span(tv0), span(he0)};
            std::vector<index_t> vr, vc, tv;
            index_t n_valid = 0;
            double total = 0.0;
            run_released([&] {
                Insertion ins = insert_all(image, first, max_vertices, max_sum, sr, sc);
                vr = copy(ins.vertex_rows());
                vc = copy(ins.vertex_cols());
                tv = copy(ins.triangles());
                n_valid = ins.valid_vertices();
                total = ins.total();
            });
            return nb::make_tuple(to_numpy(std::move(vr)), to_numpy(std::move(vc)), to_numpy(std::move(tv)),
                                  n_valid, total);
        },
        nb::arg("depth"), nb::arg("valid"), nb::arg("vr0"), nb::arg("vc0"), nb::arg("vz0"), nb::arg("tv0"),
        nb::arg("he0"), nb::arg("max_vertices"), nb::arg("max_sum"), nb::arg("span"), nb::arg("sr") = 1,
        nb::arg("sc") = 1,
        "Refine a first mesh at worst pixels, one vertex at a time (greedy insertion).\n\n"
        "``depth`` (H, W) float64 and ``valid`` (H, W) bool; the first mesh ``vr0, vc0, vz0`` (the "
        "four image corners first, then valid pixels), ``tv0, he0`` (triangles counter-clockwise in "
        "(row, column), Delaunay, and their twins). Stops at ``max_vertices`` vertices on valid "
        "pixels or, when ``max_sum`` is not negative, once the summed error is at most it (no pixel "
        "left to cover). Errors rank in units of ``span / 2**32``; rows count ``sr`` and columns "
        "``sc`` in the Delaunay test. Returns ``vr, vc, tv, n_valid_vertices, total``.");
    m.def(
        "greedy_insert_sums",
        [](In2<double> depth, In2<bool> valid, In1<index_t> vr0, In1<index_t> vc0, In1<double> vz0,
           In1<index_t> tv0, In1<index_t> he0, index_t max_vertices, double max_sum, double unit, index_t sr,
           index_t sc) {
            const Image image = image_of(depth, valid, unit);
            const FirstMesh first{span(vr0), span(vc0), span(vz0), span(tv0), span(he0)};
            std::vector<index_t> vr, vc, tv, he;
            std::vector<double> tsum;
            run_released([&] {
                Insertion ins = insert_all(image, first, max_vertices, max_sum, sr, sc);
                vr = copy(ins.vertex_rows());
                vc = copy(ins.vertex_cols());
                tv = copy(ins.triangles());
                he = copy(ins.halfedges());
                tsum = ins.sums();
            });
            return nb::make_tuple(to_numpy(std::move(vr)), to_numpy(std::move(vc)), to_numpy(std::move(tv)),
                                  to_numpy(std::move(he)), to_numpy(std::move(tsum)));
        },
        nb::arg("depth"), nb::arg("valid"), nb::arg("vr0"), nb::arg("vc0"), nb::arg("vz0"), nb::arg("tv0"),
        nb::arg("he0"), nb::arg("max_vertices"), nb::arg("max_sum"), nb::arg("span"), nb::arg("sr") = 1,
        nb::arg("sc") = 1,
        "``greedy_insert``, returning ``vr, vc, tv, he, tsum``: the triangles' twin half-edges and "
        "each triangle's error sum over the pixels it owns (0 for a triangle with a background "
        "corner, and for one keyed without a scan as an exact fit).");
}

}  // namespace rangemesh::bind
