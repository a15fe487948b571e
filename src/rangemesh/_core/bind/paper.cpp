// Python bindings of the paper method's kernels and the primitives they share (lift, edge error).
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <vector>

#include "../geometry/lines.hpp"
#include "../paper/flipping.hpp"
#include "../paper/sampling.hpp"
#include "../paper/triangulation.hpp"
#include "bindings.hpp"
#include "numpy.hpp"
#include "release.hpp"

namespace rangemesh::bind {

namespace {

// The farthest endpoint `line_pixel` takes: 2 k n stays within int64 for lines up to 2^30 long.
constexpr index_t LINE_REACH = index_t{1} << 29;

RangeImage range_image(const In2<double>& depth, const In2<bool>& valid, const In1<double>& cam) {
    return {grid(depth), grid(valid), span(cam)};
}

// Whether (r, c) is a pixel whose ray a packed per-pixel camera holds. The width is checked as a
// double before it becomes an integer (a NaN or huge one would be undefined behaviour) and the row
// against the rows the array holds, so no product here can overflow.
bool rays_pixel(Span<const double> packed, index_t r, index_t c) {
    const double width = packed[2];
    if (!(width >= 1.0 && width <= static_cast<double>(packed.size)) || width != std::floor(width)) return false;
    const index_t w = static_cast<index_t>(width);
    return 0 <= r && 0 <= c && c < w && r < (packed.size - CAMERA_HEADER) / (3 * w);
}

// valid_samples for samples of type T (stage one's int32 grid, or int64 points).
template <class T>
void bind_valid_samples(nb::module_& m) {
    m.def(
        "valid_samples",
        [](In2<T> samples, In2<bool> valid) {
            std::vector<index_t> points =
                run_released([&] { return paper::valid_samples(grid(samples), grid(valid)); }, work(valid));
            const std::size_t n = points.size() / 2;
            return to_numpy(std::move(points), n, 2);
        },
        nb::arg("samples"), nb::arg("valid"),
        "The distinct (row, col) samples (N, 2) that are valid pixels, in row-major order, as an (M, 2) "
        "int64 array; samples outside the image are left out.");
}

// The decisions a flip loop may log at most (24 bytes each): a raw 2^62 would only allocate.
constexpr index_t FLIP_LOG_MAX = index_t{1} << 24;

// The flip stage's settings as Python fills them: the rule as an integer (one of FLIP_RULES),
// checked before it becomes a FlipRule, and the log's length.
struct FlipOptions {
    index_t rule = paper::RULE_DISPARITY;
    paper::DisparityTests tests;
    double threshold = 0.0;
    double quantum = 0.0;
    double max_edge2 = 0.0;
    index_t log_size = 0;
};

// What flip_loop did.
struct FlipReport {
    index_t flips = 0;
    std::vector<index_t> verdicts;  // a count per verdict
    std::vector<index_t> log;       // (n, 3): endpoints (smaller first), verdict
};

// The disparity tests' angles: properties of FlipSettings, fields of its `tests`.
struct TestAngle {
    const char* name;
    double paper::DisparityTests::* field;
    const char* doc;
};
constexpr TestAngle TEST_ANGLES[] = {
    {"delta", &paper::DisparityTests::delta, "The largest angle between a span and a triangle that is smooth."},
    {"epsilon", &paper::DisparityTests::epsilon, "T2: the least significant change of disparity."},
    {"max_angle", &paper::DisparityTests::max_angle, "T3: an internal angle above this makes a triangle degenerate."},
    {"min_bend", &paper::DisparityTests::min_bend, "T4: the least noticeable bend between the new triangles."}};

void bind_flip_classes(nb::module_& m) {
    nb::class_<FlipOptions> settings(m, "FlipSettings",
                                     "The settings of the paper's flip stage (``flip_loop``, ``disparity_verdict``); "
                                     "rangemesh/paper/flipping.py fills them from MeshParams. Angles in radians.");
    settings.def(nb::init<>())
        .def("__copy__", [](const FlipOptions& o) { return FlipOptions(o); })
        .def_rw("rule", &FlipOptions::rule, "The flip rule, one of FLIP_RULES' values.");
    for (const TestAngle& a : TEST_ANGLES)
        settings.def_prop_rw(
            a.name, [field = a.field](const FlipOptions& o) { return o.tests.*field; },
            [field = a.field](FlipOptions& o, double v) { o.tests.*field = v; }, a.doc);
    settings.def_rw("threshold", &FlipOptions::threshold, "Gains below this are not worth a decision (-inf: none).")
        .def_rw("quantum", &FlipOptions::quantum, "Gains are rounded to multiples of this power of two.")
        .def_rw("max_edge2", &FlipOptions::max_edge2, "The squared bound on a new edge's image length (inf: none).")
        .def_rw("log_size", &FlipOptions::log_size, "The first decisions logged (0 to 2^24; 0: none).");
    nb::class_<FlipReport>(m, "FlipReport", "What ``flip_loop`` did; arrays are views this object keeps alive.")
        .def_ro("flips", &FlipReport::flips, "Edges flipped.")
        .def_prop_ro("verdicts", array_of(&FlipReport::verdicts), nb::rv_policy::reference_internal,
                     "(8,) int64: how often each verdict (FLIP_VERDICTS) was given.")
        .def_prop_ro("log", array_of(&FlipReport::log, 3), nb::rv_policy::reference_internal,
                     "(n, 3) int64: the first decisions, n at most settings.log_size: endpoints (smaller first), "
                     "verdict.");
}

}  // namespace

void bind_paper(nb::module_& m) {
    using namespace paper;

    nb::dict verdicts;
    verdicts["T1_DEADLOCK"] = index_t{T1_DEADLOCK};
    verdicts["T2_DISPARITY_CHANGE"] = index_t{T2_DISPARITY_CHANGE};
    verdicts["T3_DEGENERATE"] = index_t{T3_DEGENERATE};
    verdicts["T4_BEND"] = index_t{T4_BEND};
    verdicts["T5_CREASE"] = index_t{T5_CREASE};
    verdicts["FINAL_TEST"] = index_t{FINAL_TEST};
    verdicts["FLIPPED"] = index_t{FLIPPED};
    verdicts["MAX_EDGE"] = index_t{MAX_EDGE};
    m.attr("FLIP_VERDICTS") = verdicts;
    nb::dict rules;
    rules["disparity"] = index_t{RULE_DISPARITY};
    rules["error"] = index_t{RULE_ERROR};
    m.attr("FLIP_RULES") = rules;

    bind_flip_classes(m);
    m.def(
        "flip_loop",
        [](Out1<index_t> triangles, Out1<index_t> halfedges, In2<index_t> pixels, In2<double> vertices,
           In2<double> depth, In2<bool> valid, In1<double> cam, const FlipOptions& options) {
            check_input(options.rule == RULE_DISPARITY || options.rule == RULE_ERROR,
                        "flip_loop: settings.rule is one of FLIP_RULES");
            check_input(0 <= options.log_size && options.log_size <= FLIP_LOG_MAX,
                        "flip_loop: settings.log_size from 0 to 2^24");
            const FlipMesh mesh{span(triangles), span(halfedges), {grid(pixels), grid(vertices)}};
            const FlipSettings settings{static_cast<FlipRule>(options.rule), options.tests, options.threshold,
                                        options.quantum, options.max_edge2};
            FlipReport report;
            report.verdicts.assign(N_VERDICTS, 0);
            const RangeImage image = range_image(depth, valid, cam);
            report.flips = run_released([&] {
                const FreeLater late(on_throw, report.log);
                fill_polled(report.log, 3 * static_cast<std::size_t>(options.log_size), index_t{0});
                const FlipRecord record{{report.verdicts.data(), N_VERDICTS}, {report.log.data(), options.log_size, 3}};
                return flip_loop(mesh, image, settings, record);
            });
            index_t decisions = 0;
            for (const index_t count : report.verdicts) decisions += count;
            report.log.resize(3 * static_cast<std::size_t>(std::min(decisions, options.log_size)));
            return report;
        },
        nb::arg("triangles"), nb::arg("halfedges"), nb::arg("pixels"), nb::arg("vertices"), nb::arg("depth"),
        nb::arg("valid"), nb::arg("cam"), nb::arg("settings"),
        "Stage three (SPEC 3.3-3.6) on int64 half-edge arrays, in place, under ``settings`` (a FlipSettings); "
        "returns a FlipReport: the flips taken, the verdicts' counts and the first ``settings.log_size`` "
        "decisions.");
    m.def(
        "disparity_verdict",
        [](In1<index_t> triangles, In1<index_t> halfedges, In2<double> normals, In2<double> vertices, index_t e0,
           const FlipOptions& options) {
            check_input(
                halfedges.shape(0) == triangles.shape(0) && triangles.shape(0) % 3 == 0 && vertices.shape(1) == 3,
                "disparity_verdict: triangles and halfedges 3F long each, vertices (V, 3)");
            // the fans' walks follow the twins: every id in range, every twin paired
            const Span<const index_t> tri = span(triangles), he = span(halfedges);
            for (index_t e = 0; e < tri.size; ++e)
                check_input(0 <= tri[e] && tri[e] < static_cast<index_t>(vertices.shape(0)) &&
                                (he[e] == -1 || (0 <= he[e] && he[e] < he.size && he[he[e]] == e)),
                            "disparity_verdict: a vertex id out of range or an unpaired twin");
            return index_t{run_released([&] {
                return disparity_verdict(span(triangles), span(halfedges), grid(normals), grid(vertices), e0,
                                         options.tests);
            })};
        },
        nb::arg("triangles"), nb::arg("halfedges"), nb::arg("normals"), nb::arg("vertices"), nb::arg("e0"),
        nb::arg("settings"),
        "The verdict of the paper's tests T2-T5 and final test on the inner edge of half-edge ``e0``, with "
        "the angles of ``settings`` (a FlipSettings; its other fields are not read).");
    m.def(
        "fill_gaps_inplace",
        [](Out2<double> depth, Out2<bool> valid) {
            return run_released([&] { return fill_gaps_inplace(grid(depth), grid(valid)); }, work(depth));
        },
        nb::arg("depth"), nb::arg("valid"),
        "SPEC 1.1 in place on C-contiguous float64 depth and bool valid; returns the pixels filled.");
    m.def(
        "add_curvature",
        [](In2<double> depth, In2<bool> valid, double jump, index_t levels, Out2<double> curvature) {
            run_released([&] { add_curvature(grid(depth), grid(valid), jump, levels, grid(curvature)); });
        },
        nb::arg("depth"), nb::arg("valid"), nb::arg("jump"), nb::arg("levels"), nb::arg("curvature"),
        "Adds the multiresolution curvature (SPEC 1.2-1.3) of ``levels`` levels to ``curvature``.");
    m.def(
        "sample_tiles",
        [](In2<double> f, In1<index_t> row_bounds, In1<index_t> col_bounds, index_t rs, index_t zs,
           nb::ndarray<std::int32_t, nb::ndim<3>, nb::c_contig, nb::device::cpu> grid_out, index_t workers) {
            const Tiling tiling{span(row_bounds), span(col_bounds), rs, zs};
            const SampleGrid samples{grid_out.data(), static_cast<index_t>(grid_out.shape(0)),
                                     static_cast<index_t>(grid_out.shape(1))};
            if (grid_out.shape(2) != 2) throw nb::value_error("sample_tiles: the grid's last axis must be 2");
            run_released([&] { sample_tiles(grid(f), tiling, samples, workers); });
        },
        nb::arg("f"), nb::arg("row_bounds"), nb::arg("col_bounds"), nb::arg("rs"), nb::arg("zs"), nb::arg("grid"),
        nb::arg("workers") = 1,
        "Fills the (Gr, Gc, 2) int32 sample grid from the weights ``f``, tile by tile; ``workers`` "
        "threads share the tiles and give the same grid for any number.");
    bind_valid_samples<index_t>(m);
    bind_valid_samples<std::int32_t>(m);
    m.def(
        "keep_faces",
        [](In2<index_t> faces, In2<index_t> points, In2<bool> valid, double max_edge2, Out1<bool> alive) {
            run_released([&] { keep_faces(grid(faces), grid(points), grid(valid), max_edge2, span(alive)); },
                         work(faces));
        },
        nb::arg("faces"), nb::arg("points"), nb::arg("valid"), nb::arg("max_edge2"), nb::arg("alive"),
        "Writes to ``alive`` whether each (F, 3) face of the (N, 2) ``points`` stays: the pixel at its "
        "rounded barycentre is valid and no edge's squared length exceeds ``max_edge2``.");
    m.def(
        "compact_faces",
        [](In2<index_t> faces, In1<bool> alive, In2<index_t> points) {
            CompactMesh c =
                run_released([&] { return compact_faces(grid(faces), span(alive), grid(points)); }, work(faces));
            const std::size_t n_f = c.faces.size() / 3, n_v = c.pixels.size() / 2;
            return nb::make_tuple(to_numpy(std::move(c.faces), n_f, 3), to_numpy(std::move(c.pixels), n_v, 2));
        },
        nb::arg("faces"), nb::arg("alive"), nb::arg("points"),
        "``(faces (F', 3) int32, pixels (V, 2) int32)``: the faces ``alive``, numbered over the points "
        "they use, in order, and those points.");
    m.def(
        "edge_error",
        [](index_t va, index_t vb, In2<index_t> pixels, In2<double> vertices, In2<double> depth, In2<bool> valid,
           In1<double> cam) {
            const MeshPoints points{grid(pixels), grid(vertices)};
            const RangeImage image = range_image(depth, valid, cam);
            if (!image.consistent() || !points.fit(image) || va < 0 || vb < 0 || va >= points.size() ||
                vb >= points.size())
                throw nb::value_error("edge_error: vertices, pixels, image and camera must agree");
            return run_released([&] { return edge_error(va, vb, points, image); });
        },
        nb::arg("va"), nb::arg("vb"), nb::arg("pixels"), nb::arg("vertices"), nb::arg("depth"), nb::arg("valid"),
        nb::arg("cam"), "E(A, B) of SPEC 3.1: the 3-D distances of the valid pixels of the raster line AB to AB.");
    m.def(
        "line_pixel",
        [](index_t r0, index_t c0, index_t r1, index_t c1, index_t k) {
            // (2 k n of a line much longer than 2^30 overflows int64)
            for (const index_t x : {r0, c0, r1, c1})
                check_input(-LINE_REACH <= x && x <= LINE_REACH, "line_pixel: endpoints within 2^29 of the origin");
            check_input(0 <= k && k <= std::max(std::llabs(r1 - r0), std::llabs(c1 - c0)),
                        "line_pixel: k from 0 to the line's length");
            const Pixel p = line_pixel(r0, c0, r1, c1, k);
            return nb::make_tuple(p.r, p.c);
        },
        nb::arg("r0"), nb::arg("c0"), nb::arg("r1"), nb::arg("c1"), nb::arg("k"),
        "Pixel ``k`` (from the first endpoint) of the Bresenham line (r0, c0) -> (r1, c1).");
    m.def(
        "lift",
        [](index_t r, index_t c, double d, In1<double> cam) {
            const Span<const double> packed = span(cam);
            const bool rays = packed.size >= CAMERA_HEADER && packed[0] == RAYS;
            if (packed.size < CAMERA_HEADER || (rays && !rays_pixel(packed, r, c)))
                throw nb::value_error("lift: a packed camera, and a pixel of its image for a per-pixel camera");
            const Vec3 p = lift(span(cam), r, c, d);
            return to_numpy(std::vector<double>{p.x, p.y, p.z});
        },
        nb::arg("r"), nb::arg("c"), nb::arg("d"), nb::arg("cam"),
        "The 3-D point (x, y, z), a (3,) float64 array, of pixel (r, c) with stored depth d under the packed "
        "camera ``cam``.");
}

}  // namespace rangemesh::bind
