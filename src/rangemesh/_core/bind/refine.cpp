// Python bindings of the refine method's kernels: greedy insertion, its strips, its diagonals.
#include <nanobind/stl/pair.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>

#include <limits>
#include <tuple>

#include "../geometry/halfedges.hpp"
#include "../refine/diagonals.hpp"
#include "../refine/insertion.hpp"
#include "../refine/strips.hpp"
#include "bindings.hpp"
#include "numpy.hpp"
#include "release.hpp"

namespace rangemesh::bind {

namespace {

using refine::FirstMesh;
using refine::FlipCount;
using refine::FlipMesh;
using refine::Image;
using refine::Insertion;
using refine::Stop;

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

FlipMesh flip_mesh(const In1<index_t>& vr, const In1<index_t>& vc, Out1<index_t>& tri, Out1<index_t>& he,
                   Out1<double>& sums) {
    return FlipMesh{span(vr), span(vc), span(tri), span(he), span(sums)};
}

nb::tuple counts(FlipCount c) { return nb::make_tuple(c.flips, c.tests); }

// A first mesh as Python passes it: vr, vc, vz, tv, he.
using FirstArrays = std::tuple<In1<index_t>, In1<index_t>, In1<double>, In1<index_t>, In1<index_t>>;

FirstMesh first_of(const FirstArrays& a) {
    return FirstMesh{span(std::get<0>(a)), span(std::get<1>(a)), span(std::get<2>(a)), span(std::get<3>(a)),
                     span(std::get<4>(a))};
}

nb::tuple strip_arrays(refine::StripMesh&& s) {
    return nb::make_tuple(to_numpy(std::move(s.vr)), to_numpy(std::move(s.vc)), to_numpy(std::move(s.triangles)),
                          to_numpy(std::move(s.halfedges)), to_numpy(std::move(s.sums)), s.valid_vertices, s.total, s.flips);
}

}  // namespace

void bind_refine(nb::module_& m) {
    m.attr("MAX_TESTS_PER_EDGE") = refine::MAX_TESTS_PER_EDGE;
    m.def(
        "triangle_error",
        [](index_t ar, index_t ac, double az, index_t br, index_t bc, double bz, index_t cr, index_t cc, double cz,
           bool own0, bool own1, bool own2, In2<double> depth, In2<bool> valid, double base, double unit,
           double stop) {
            const Image image = image_of(depth, valid, unit);
            for (const auto& [r, c] : {std::pair{ar, ac}, std::pair{br, bc}, std::pair{cr, cc}})
                check_input(0 <= r && r < image.rows() && 0 <= c && c < image.cols(),
                            "triangle_error: the corners must be pixels of the image");
            return run_released([&] {
                return refine::triangle_error(image, {ar, ac, az}, {br, bc, bz}, {cr, cc, cz}, EdgeOwnership{own0, own1, own2},
                                              base, stop);
            });
        },
        nb::arg("ar"), nb::arg("ac"), nb::arg("az"), nb::arg("br"), nb::arg("bc"), nb::arg("bz"), nb::arg("cr"),
        nb::arg("cc"), nb::arg("cz"), nb::arg("own0"), nb::arg("own1"), nb::arg("own2"), nb::arg("depth"),
        nb::arg("valid"), nb::arg("base") = 0.0, nb::arg("span") = 0.0,
        nb::arg("stop") = std::numeric_limits<double>::infinity(),
        "Sum of |depth - plane| over the valid pixels of triangle ABC (counter-clockwise): inside, or "
        "on an edge whose flag (``own0`` AB, ``own1`` BC, ``own2`` CA) is true; the plane through the "
        "corners' depths. With a key ``stop`` the sum is left after a row once "
        "``quantize(base + sum, span) >= stop``.");
    m.def(
        "flip_by_error",
        [](In1<index_t> vr, In1<index_t> vc, Out1<index_t> tri, Out1<index_t> he, Out1<double> tsum,
           In2<double> depth, In2<bool> valid, double unit) {
            const Image image = image_of(depth, valid, unit);
            const FlipMesh mesh = flip_mesh(vr, vc, tri, he, tsum);
            return counts(run_released([&] { return refine::flip_by_error(image, mesh); }, work(depth)));
        },
        nb::arg("vr"), nb::arg("vc"), nb::arg("tri"), nb::arg("he"), nb::arg("tsum"), nb::arg("depth"),
        nb::arg("valid"), nb::arg("span"),
        "Flip the edges of a half-edge mesh in place while a flip lowers the error of its two "
        "triangles; ``tsum`` holds each triangle's error sum over the pixels it owns (as "
        "``greedy_insert_sums`` gives it). Returns ``flips, tests``.");
    m.def(
        "flip_from_edges",
        [](In1<index_t> vr, In1<index_t> vc, Out1<index_t> tri, Out1<index_t> he, Out1<double> tsum,
           In2<double> depth, In2<bool> valid, double unit, In1<index_t> first) {
            const Image image = image_of(depth, valid, unit);
            const FlipMesh mesh = flip_mesh(vr, vc, tri, he, tsum);
            return counts(run_released([&] { return refine::flip_from_edges(image, mesh, span(first)); }));
        },
        nb::arg("vr"), nb::arg("vc"), nb::arg("tri"), nb::arg("he"), nb::arg("tsum"), nb::arg("depth"),
        nb::arg("valid"), nb::arg("span"), nb::arg("first"),
        "``flip_by_error`` starting from the half-edges ``first`` only, and the edges flips touch "
        "(two meshes joined along a seam, ``first`` the seam's half-edges); the sums of the "
        "triangles on those edges are computed afresh. Returns ``flips, tests``.");
    m.def(
        "seam_rows",
        [](In1<double> z, In1<bool> ok, index_t k, double max_sum, double unit) {
            std::vector<index_t> rows;
            run_released([&] { rows = refine::seam_rows(span(z), span(ok), k, max_sum, unit); });
            return to_numpy(std::move(rows));
        },
        nb::arg("z"), nb::arg("ok"), nb::arg("k"), nb::arg("max_sum"), nb::arg("span"),
        "Rows of about ``k`` valid pixels (``ok``) of a depth profile ``z``, by greedy insertion in "
        "one dimension (errors in units of ``span / 2**32``), or fewer once the summed error is at "
        "most ``max_sum`` (when not negative); the first and last valid pixels always.");
    m.def(
        "strip_insert",
        [](In2<double> depth, In2<bool> valid, FirstArrays left, FirstArrays right, index_t vertices,
           index_t target, index_t reserve, double budget, double unit, index_t sr, index_t sc, int threads,
           bool rounds, bool flip) {
            const Image image = image_of(depth, valid, unit);
            const refine::StripRequest req{vertices, target, reserve, budget, sr, sc, threads, rounds, flip};
            refine::Strips out =
                run_released([&] { return refine::strip_insert(image, first_of(left), first_of(right), req); });
            return nb::make_tuple(strip_arrays(std::move(out.left)), strip_arrays(std::move(out.right)), out.rounds,
                                  out.capped);
        },
        nb::arg("depth"), nb::arg("valid"), nb::arg("left"), nb::arg("right"), nb::arg("vertices"),
        nb::arg("target"), nb::arg("reserve"), nb::arg("budget"), nb::arg("span"), nb::arg("sr"), nb::arg("sc"),
        nb::arg("threads"), nb::arg("rounds"), nb::arg("flip"),
        "Greedy insertion on two strips from their first meshes ``left`` and ``right`` (each "
        "``vr, vc, vz, tv, he``), on ``threads`` native threads (the same mesh for 1 or 2): rounds "
        "to common key thresholds (unless ``rounds`` is false), then one vertex at a time until the "
        "strips hold ``target`` valid vertices (the seam's twice) or their summed error is at most "
        "``budget`` (when not negative); with ``flip`` each strip's edges are then flipped by the "
        "error. Returns ``left, right, rounds, capped``, each strip as ``vr, vc, tv, he, tsum, "
        "n_valid_vertices, total, flips``.");
    m.def("_strip_exponent", &refine::strip_exponent, "The strips' power-law exponent through two points (tests).");
    m.def(
        "_strip_power_law",
        [](const std::vector<std::pair<double, double>>& hist) {
            require(!hist.empty(), "_strip_power_law: a history");
            const refine::PowerLaw law = refine::strip_power_law(hist);
            return std::make_tuple(law.n, law.k, law.e);
        },
        "``(n, key, e)`` of a strip's (count, first key) history (tests).");
    m.def(
        "_strip_error_target",
        [](const std::vector<std::pair<double, double>>& hist, double budget) {
            require(!hist.empty(), "_strip_error_target: a history");
            return refine::strip_error_target(hist, budget);
        },
        "The count at which a (count, summed error) history reaches ``budget`` (tests).");
    m.def(
        "error_flips",
        [](In1<index_t> vr, In1<index_t> vc, In1<index_t> tv, In2<double> depth, In2<bool> valid, double unit) {
            const Image image = image_of(depth, valid, unit);
            require(tv.shape(0) % 3 == 0, "error_flips: three corners a triangle");
            std::vector<index_t> tri, he;
            FlipCount c;
            run_released([&] {
                const index_t n_t = tv.shape(0) / 3;
                build_halfedges(Grid<const index_t>{tv.data(), n_t, 3}, static_cast<index_t>(vr.shape(0)), tri, he);
                std::vector<double> sums(n_t, 0.0);
                const FlipMesh mesh{span(vr), span(vc), {tri.data(), 3 * n_t}, {he.data(), 3 * n_t},
                                    {sums.data(), n_t}};
                refine::face_errors(image, mesh);
                c = refine::flip_by_error(image, mesh);
            });
            return nb::make_tuple(to_numpy(std::move(tri)), c.flips, c.tests);
        },
        nb::arg("vr"), nb::arg("vc"), nb::arg("tv"), nb::arg("depth"), nb::arg("valid"), nb::arg("span"),
        "Flip the edges of a mesh (``tv`` 3T vertex ids, counter-clockwise, edge-manifold; not "
        "changed) while a flip lowers the error of its two triangles, the sums computed from "
        "scratch. Returns the flipped ``tri``, ``flips``, ``tests``.");
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
                vr = copy_polled(ins.vertex_rows());
                vc = copy_polled(ins.vertex_cols());
                tv = copy_polled(ins.triangles());
                n_valid = ins.valid_vertices();
                total = ins.total();
            }, work(depth));
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
                vr = copy_polled(ins.vertex_rows());
                vc = copy_polled(ins.vertex_cols());
                tv = copy_polled(ins.triangles());
                he = copy_polled(ins.halfedges());
                tsum = ins.sums();
            }, work(depth));
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
