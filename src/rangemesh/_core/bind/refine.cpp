// Python bindings of the refine method's kernels: greedy insertion, its strips, its diagonals.
// Settings are classes Python fills (InsertSettings, ErrorScan, StripRequest); results of more
// than two parts are classes with named, read-only properties (Insertion, StripResult, ...).
#include <nanobind/stl/array.h>
#include <nanobind/stl/pair.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>

#include <array>
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
    require(depth.shape(0) == valid.shape(0) && depth.shape(1) == valid.shape(1), "depth and valid: one shape");
    return Image{grid(depth), grid(valid), span};
}

// Where greedy insertion stops and how it ranks (`greedy_insert`).
struct InsertSettings {
    index_t max_vertices = 0;
    double max_sum = -1.0;
    double span = 0.0;
    index_t sr = 1, sc = 1;
    bool sums = false;
};

// What greedy insertion left: the mesh, and with `sums` its twins and triangle sums.
struct InsertResult {
    std::vector<index_t> vr, vc, tv, he;
    std::vector<double> tsum;
    index_t valid_vertices = 0;
    double total = 0.0;
};

// How `triangle_error` scans a triangle: the edges it owns, the key units, the early stop.
struct ErrorScan {
    bool own_ab = true, own_bc = true, own_ca = true;
    double base = 0.0;
    double span = 0.0;
    double stop = std::numeric_limits<double>::infinity();
};

// `error_flips`' result: the flipped triangles and the counts.
struct ErrorFlips {
    std::vector<index_t> triangles;
    index_t flips = 0, tests = 0;
};

// Greedy insertion from a first mesh until the stop: the finished state.
Insertion insert_all(const Image& image, const FirstMesh& first, index_t max_vertices, double max_sum, index_t sr,
                     index_t sc) {
    // arrays sized for `max_vertices` when it is the stop; grown as needed under an error bound
    Insertion ins(image, first, max_sum < 0.0 ? max_vertices : 0, sr, sc);
    ins.advance(Stop{max_vertices, max_sum});
    return ins;
}

// A half-edge mesh as Python passes it to the flips: vr, vc, tri, he, tsum (the last three in place).
using EdgeArrays = std::tuple<In1<index_t>, In1<index_t>, Out1<index_t>, Out1<index_t>, Out1<double>>;

FlipMesh flip_mesh(const EdgeArrays& a) {
    return FlipMesh{span(std::get<0>(a)), span(std::get<1>(a)), span(std::get<2>(a)), span(std::get<3>(a)),
                    span(std::get<4>(a))};
}

std::pair<index_t, index_t> counts(FlipCount c) { return {c.flips, c.tests}; }

// A first mesh as Python passes it: vr, vc, vz, tv, he.
using FirstArrays = std::tuple<In1<index_t>, In1<index_t>, In1<double>, In1<index_t>, In1<index_t>>;

FirstMesh first_of(const FirstArrays& a) {
    return FirstMesh{span(std::get<0>(a)), span(std::get<1>(a)), span(std::get<2>(a)), span(std::get<3>(a)),
                     span(std::get<4>(a))};
}

// A greedy insertion's triangulation as read-only NumPy views of a result's vectors (the result
// keeps them alive), under the same five names on every class that holds one: vr, vc, tv, he, tsum.
template <class C>
nb::class_<C> bind_triangulation(nb::class_<C> cls, std::vector<index_t> C::* vr, std::vector<index_t> C::* vc,
                                 std::vector<index_t> C::* tv, std::vector<index_t> C::* he,
                                 std::vector<double> C::* tsum) {
    constexpr auto keep = nb::rv_policy::reference_internal;
    cls.def_prop_ro("vr", array_of(vr), keep, "The vertices' rows ...")
        .def_prop_ro("vc", array_of(vc), keep, "... and columns.")
        .def_prop_ro("tv", array_of(tv), keep, "3T vertex ids, counter-clockwise in (row, column).")
        .def_prop_ro("he", array_of(he), keep, "The twin half-edges (-1 on the hull).")
        .def_prop_ro("tsum", array_of(tsum), keep, "Each triangle's error sum over the pixels it owns.");
    return cls;
}

}  // namespace

void bind_refine(nb::module_& m) {
    m.attr("MAX_TESTS_PER_EDGE") = refine::MAX_TESTS_PER_EDGE;

    nb::class_<InsertSettings>(m, "InsertSettings", "Where ``greedy_insert`` stops and how it ranks.")
        .def(
            "__init__",
            [](InsertSettings* s, index_t max_vertices, double max_sum, double unit, index_t sr, index_t sc,
               bool sums) { new (s) InsertSettings{max_vertices, max_sum, unit, sr, sc, sums}; },
            nb::arg("max_vertices") = 0, nb::arg("max_sum") = -1.0, nb::arg("span") = 0.0, nb::arg("sr") = 1,
            nb::arg("sc") = 1, nb::arg("sums") = false)
        .def("__copy__", [](const InsertSettings& s) { return InsertSettings(s); })
        .def_rw("max_vertices", &InsertSettings::max_vertices, "Stop at this many vertices on valid pixels ...")
        .def_rw("max_sum", &InsertSettings::max_sum,
                "... or, when not negative, once the summed error is at most this (no pixel left to cover).")
        .def_rw("span", &InsertSettings::span, "Errors rank in units of ``span / 2**32``.")
        .def_rw("sr", &InsertSettings::sr, "The weight of rows in the Delaunay test ...")
        .def_rw("sc", &InsertSettings::sc, "... and of columns.")
        .def_rw("sums", &InsertSettings::sums, "Also return the twins ``he`` and the triangles' sums ``tsum``.");
    bind_triangulation(nb::class_<InsertResult>(m, "Insertion",
                                                "What ``greedy_insert`` left: ``he`` and ``tsum`` are empty unless "
                                                "``settings.sums``; ``tsum`` is 0 for a triangle with a background "
                                                "corner, and for one keyed without a scan as an exact fit."),
                       &InsertResult::vr, &InsertResult::vc, &InsertResult::tv, &InsertResult::he, &InsertResult::tsum)
        .def_ro("valid_vertices", &InsertResult::valid_vertices, "Vertices on valid pixels.")
        .def_ro("total", &InsertResult::total, "The summed error of the valid pixels.");
    nb::class_<ErrorScan>(m, "ErrorScan", "How ``triangle_error`` scans a triangle.")
        .def(
            "__init__",
            [](ErrorScan* s, bool own_ab, bool own_bc, bool own_ca, double base, double unit, double stop) {
                new (s) ErrorScan{own_ab, own_bc, own_ca, base, unit, stop};
            },
            nb::arg("own_ab") = true, nb::arg("own_bc") = true, nb::arg("own_ca") = true, nb::arg("base") = 0.0,
            nb::arg("span") = 0.0, nb::arg("stop") = std::numeric_limits<double>::infinity())
        .def("__copy__", [](const ErrorScan& s) { return ErrorScan(s); })
        .def_rw("own_ab", &ErrorScan::own_ab, "Whether the pixels on edge AB count ...")
        .def_rw("own_bc", &ErrorScan::own_bc, "... on BC ...")
        .def_rw("own_ca", &ErrorScan::own_ca, "... and on CA.")
        .def_rw("base", &ErrorScan::base, "A sum the stop adds to the triangle's ...")
        .def_rw("span", &ErrorScan::span, "... in key units of ``span / 2**32`` ...")
        .def_rw("stop", &ErrorScan::stop, "... left after a row once ``quantize(base + sum, span) >= stop``.");
    // (nine values: built with its defaults and filled by property, as FlipSettings and FitSettings
    // are, not by a constructor of more than eight arguments)
    nb::class_<refine::StripRequest>(m, "StripRequest",
                                     "What ``strip_insert`` inserts, and how: built with the defaults "
                                     "(budget -1, sr, sc and threads 1, rounds true, the rest 0 or false), "
                                     "then filled by property.")
        .def("__init__",
             [](refine::StripRequest* r) { new (r) refine::StripRequest{0, 0, 0, -1.0, 1, 1, 1, true, false}; })
        .def("__copy__", [](const refine::StripRequest& r) { return refine::StripRequest(r); })
        .def_rw("vertices", &refine::StripRequest::vertices, "Valid vertices wanted, the seam's once ...")
        .def_rw("target", &refine::StripRequest::target, "... counted the seam's twice (once a strip).")
        .def_rw("reserve", &refine::StripRequest::reserve, "Room for this many vertices a strip (0: grown).")
        .def_rw("budget", &refine::StripRequest::budget, "The strips' summed error bound, or -1.")
        .def_rw("sr", &refine::StripRequest::sr, "The weight of rows in the Delaunay test ...")
        .def_rw("sc", &refine::StripRequest::sc, "... and of columns.")
        .def_rw("threads", &refine::StripRequest::threads, "1: one strip after the other; 2: on two threads.")
        .def_rw("rounds", &refine::StripRequest::rounds, "False: every vertex one at a time (tests).")
        .def_rw("flip", &refine::StripRequest::flip, "Then flip each strip's edges by the error.");
    using refine::StripMesh;
    bind_triangulation(
        nb::class_<StripMesh>(m, "StripMesh",
                              "One strip's mesh once inserted (and flipped): ``tsum`` as ``Insertion``'s, "
                              "and -1 after the flips for a triangle with a background corner."),
        &StripMesh::vr, &StripMesh::vc, &StripMesh::triangles, &StripMesh::halfedges, &StripMesh::sums)
        .def_ro("valid_vertices", &StripMesh::valid_vertices, "Vertices on valid pixels.")
        .def_ro("total", &StripMesh::total, "The insertion's summed error (flips leave it alone).")
        .def_ro("flips", &StripMesh::flips, "Edges flipped by the error.");
    nb::class_<refine::Strips>(m, "StripResult", "What ``strip_insert`` left.")
        .def_ro("left", &refine::Strips::left, "The left strip's StripMesh ...")
        .def_ro("right", &refine::Strips::right, "... and the right one's.")
        .def_ro("rounds", &refine::Strips::rounds, "Rounds run.")
        .def_ro("capped", &refine::Strips::capped, "Whether the last round stopped a strip by count.");
    nb::class_<ErrorFlips>(m, "ErrorFlips", "What ``error_flips`` did.")
        .def_prop_ro("triangles", array_of<ErrorFlips>(&ErrorFlips::triangles), nb::rv_policy::reference_internal,
                     "The flipped triangles, 3T vertex ids.")
        .def_ro("flips", &ErrorFlips::flips, "Edges flipped.")
        .def_ro("tests", &ErrorFlips::tests, "Edges tested.");
    nb::class_<refine::PowerLaw>(m, "PowerLaw", "A strip's count against its first key, n ~ key^-e.")
        .def_ro("n", &refine::PowerLaw::n, "The last count ...")
        .def_ro("key", &refine::PowerLaw::k, "... and key.")
        .def_ro("e", &refine::PowerLaw::e, "The exponent.");

    m.def(
        "triangle_error",
        [](std::array<index_t, 3> rows, std::array<index_t, 3> cols, std::array<double, 3> z, In2<double> depth,
           In2<bool> valid, const ErrorScan& scan) {
            const Image image = image_of(depth, valid, scan.span);
            for (int k = 0; k < 3; ++k)
                check_input(0 <= rows[k] && rows[k] < image.rows() && 0 <= cols[k] && cols[k] < image.cols(),
                            "triangle_error: the corners must be pixels of the image");
            return run_released([&] {
                return refine::triangle_error(
                    image, {rows[0], cols[0], z[0]}, {rows[1], cols[1], z[1]}, {rows[2], cols[2], z[2]},
                    EdgeOwnership{scan.own_ab, scan.own_bc, scan.own_ca}, scan.base, scan.stop);
            });
        },
        nb::arg("rows"), nb::arg("cols"), nb::arg("z"), nb::arg("depth"), nb::arg("valid"),
        nb::arg("scan") = ErrorScan{},
        "Sum of |depth - plane| over the valid pixels of triangle ABC (corners ``rows``, ``cols``, "
        "counter-clockwise): inside, or on an edge the scan owns (``own_ab``, ``own_bc``, ``own_ca``); the plane "
        "through the corners' depths ``z``. With a key ``scan.stop`` the sum is left after a row once "
        "``quantize(scan.base + sum, scan.span) >= scan.stop``.");
    m.def(
        "flip_by_error",
        [](EdgeArrays mesh, In2<double> depth, In2<bool> valid, double unit) {
            const Image image = image_of(depth, valid, unit);
            const FlipMesh flip = flip_mesh(mesh);
            return counts(run_released([&] { return refine::flip_by_error(image, flip); }, work(depth)));
        },
        nb::arg("mesh"), nb::arg("depth"), nb::arg("valid"), nb::arg("span"),
        "Flip the edges of a half-edge mesh ``vr, vc, tri, he, tsum`` in place while a flip lowers the "
        "error of its two triangles; ``tsum`` holds each triangle's error sum over the pixels it owns "
        "(as ``greedy_insert`` gives it with ``sums``). Returns ``flips, tests``.");
    m.def(
        "flip_from_edges",
        [](EdgeArrays mesh, In2<double> depth, In2<bool> valid, double unit, In1<index_t> first) {
            const Image image = image_of(depth, valid, unit);
            const FlipMesh flip = flip_mesh(mesh);
            return counts(run_released([&] { return refine::flip_from_edges(image, flip, span(first)); }));
        },
        nb::arg("mesh"), nb::arg("depth"), nb::arg("valid"), nb::arg("span"), nb::arg("first"),
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
        [](In2<double> depth, In2<bool> valid, FirstArrays left, FirstArrays right, double unit,
           const refine::StripRequest& req) {
            const Image image = image_of(depth, valid, unit);
            return run_released([&] { return refine::strip_insert(image, first_of(left), first_of(right), req); });
        },
        nb::arg("depth"), nb::arg("valid"), nb::arg("left"), nb::arg("right"), nb::arg("span"), nb::arg("request"),
        "Greedy insertion on two strips from their first meshes ``left`` and ``right`` (each "
        "``vr, vc, vz, tv, he``), errors in units of ``span / 2**32``, on ``request.threads`` native "
        "threads (the same mesh for 1 or 2): rounds to common key thresholds (unless "
        "``request.rounds`` is false), then one vertex at a time until the strips hold "
        "``request.target`` valid vertices (the seam's twice) or their summed error is at most "
        "``request.budget`` (when not negative); with ``request.flip`` each strip's edges are then "
        "flipped by the error. Returns a StripResult.");
    m.def("_strip_exponent", &refine::strip_exponent, "The strips' power-law exponent through two points (tests).");
    m.def(
        "_strip_power_law",
        [](const std::vector<std::pair<double, double>>& hist) {
            require(!hist.empty(), "_strip_power_law: a history");
            return refine::strip_power_law(hist);
        },
        "The PowerLaw of a strip's (count, first key) history (tests).");
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
            ErrorFlips out;
            run_released([&] {
                std::vector<index_t> he;
                const index_t n_t = tv.shape(0) / 3;
                build_halfedges(Grid<const index_t>{tv.data(), n_t, 3}, static_cast<index_t>(vr.shape(0)),
                                out.triangles, he);
                std::vector<double> sums(n_t, 0.0);
                const FlipMesh mesh{
                    span(vr), span(vc), {out.triangles.data(), 3 * n_t}, {he.data(), 3 * n_t}, {sums.data(), n_t}};
                refine::face_errors(image, mesh);
                const FlipCount c = refine::flip_by_error(image, mesh);
                out.flips = c.flips;
                out.tests = c.tests;
            });
            return out;
        },
        nb::arg("vr"), nb::arg("vc"), nb::arg("tv"), nb::arg("depth"), nb::arg("valid"), nb::arg("span"),
        "Flip the edges of a mesh (``tv`` 3T vertex ids, counter-clockwise, edge-manifold; not "
        "changed) while a flip lowers the error of its two triangles, the sums computed from "
        "scratch. Returns an ErrorFlips.");
    m.def(
        "greedy_insert",
        [](In2<double> depth, In2<bool> valid, FirstArrays first, const InsertSettings& s) {
            const Image image = image_of(depth, valid, s.span);
            const FirstMesh start = first_of(first);
            InsertResult out;
            run_released(
                [&] {
                    Insertion ins = insert_all(image, start, s.max_vertices, s.max_sum, s.sr, s.sc);
                    out.vr = copy_polled(ins.vertex_rows());
                    out.vc = copy_polled(ins.vertex_cols());
                    out.tv = copy_polled(ins.triangles());
                    out.valid_vertices = ins.valid_vertices();
                    out.total = ins.total();
                    if (s.sums) {
                        out.he = copy_polled(ins.halfedges());
                        out.tsum = ins.sums();
                    }
                },
                work(depth));
            return out;
        },
        nb::arg("depth"), nb::arg("valid"), nb::arg("first"), nb::arg("settings"),
        "Refine a first mesh at worst pixels, one vertex at a time (greedy insertion).\n\n"
        "``depth`` (H, W) float64 and ``valid`` (H, W) bool; the first mesh ``vr0, vc0, vz0, tv0, he0`` "
        "(the four image corners first, then valid pixels; triangles counter-clockwise in (row, column), "
        "Delaunay, and their twins). Stops at ``settings.max_vertices`` vertices on valid pixels or, when "
        "``settings.max_sum`` is not negative, once the summed error is at most it (no pixel left to "
        "cover). Errors rank in units of ``settings.span / 2**32``; rows count ``settings.sr`` and "
        "columns ``settings.sc`` in the Delaunay test. Returns an Insertion (its ``he`` and ``tsum`` "
        "with ``settings.sums``).");
}

}  // namespace rangemesh::bind
