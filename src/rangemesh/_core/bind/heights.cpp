// Python bindings of the least-squares depths of method="refine" (rangemesh.refine.heights).
#include <nanobind/stl/optional.h>

#include <cmath>
#include <cstdint>
#include <numeric>
#include <optional>
#include <stdexcept>
#include <type_traits>
#include <vector>

#include "../heights/fit.hpp"
#include "../heights/median.hpp"
#include "../heights/order.hpp"
#include "../heights/pass.hpp"
#include "../heights/solve.hpp"
#include "bindings.hpp"
#include "numpy.hpp"
#include "release.hpp"

namespace rangemesh::bind {

namespace {

using heights::FaceBlock;

template <class T>
using In3 = nb::ndarray<const T, nb::ndim<3>, nb::c_contig, nb::device::cpu>;

heights::FitImage fit_image(const In2<double>& image, const In2<bool>& valid) { return {grid(image), grid(valid)}; }

// The faces' blocks from the arrays ids (n, 3), block (n, 3, 3) and rhs (n, 3).
std::vector<FaceBlock> blocks_from_arrays(const In2<index_t>& ids, const In3<double>& block, const In2<double>& rhs) {
    const std::size_t n = ids.shape(0);
    require(ids.shape(1) == 3 && block.shape(0) == n && block.shape(1) == 3 && block.shape(2) == 3 &&
                rhs.shape(0) == n && rhs.shape(1) == 3,
            "blocks: ids (n, 3), block (n, 3, 3) and rhs (n, 3)");
    std::vector<FaceBlock> out(n);
    for (std::size_t t = 0; t < n; ++t) {
        for (int j = 0; j < 3; ++j) {
            out[t].ids[j] = ids.data()[3 * t + j];
            out[t].rhs[j] = rhs.data()[3 * t + j];
            for (int k = 0; k < 3; ++k) out[t].m[j][k] = block.data()[9 * t + 3 * j + k];
        }
    }
    return out;
}

template <class T>
using Array = nb::ndarray<nb::numpy, T>;

// The faces' normal equations as arrays (`FaceBlocks`): a face a row.
struct BlockArrays {
    Array<index_t> ids;   // (n, 3): its corners, counter-clockwise
    Array<double> block;  // (n, 3, 3): the sum of w w^T over its kept pixels
    Array<double> rhs;    // (n, 3): the sum of w * value
    index_t used = 0;     // pixels in the system
};

BlockArrays arrays_from_blocks(const std::vector<FaceBlock>& blocks, index_t used) {
    const std::size_t n = blocks.size();
    std::vector<index_t> ids(3 * n);
    std::vector<double> m(9 * n), rhs(3 * n);
    for (std::size_t t = 0; t < n; ++t) {
        for (int j = 0; j < 3; ++j) {
            ids[3 * t + j] = blocks[t].ids[j];
            rhs[3 * t + j] = blocks[t].rhs[j];
            for (int k = 0; k < 3; ++k) m[9 * t + 3 * j + k] = blocks[t].m[j][k];
        }
    }
    auto* owned = new std::vector<double>(std::move(m));
    nb::capsule owner(owned, [](void* p) noexcept { delete static_cast<std::vector<double>*>(p); });
    const std::size_t shape[3] = {n, 3, 3};
    return {to_numpy(std::move(ids), n, 3), Array<double>(owned->data(), 3, shape, owner),
            to_numpy(std::move(rhs), n, 3), used};
}

// fit_heights' outcome: the kernel's, and a value that is not finite (found before it runs).
enum class FitStatus { no_pixels, copied, fitted, not_converged, not_finite };

FitStatus status_of(heights::FitOutcome outcome) {
    switch (outcome) {
        case heights::FitOutcome::no_pixels:
            return FitStatus::no_pixels;
        case heights::FitOutcome::copied:
            return FitStatus::copied;
        case heights::FitOutcome::fitted:
            return FitStatus::fitted;
        case heights::FitOutcome::not_converged:
            return FitStatus::not_converged;
    }
    throw InvariantError("fit_heights: an outcome without a name");
}

// What fit_heights found.
struct HeightFit {
    FitStatus outcome = FitStatus::no_pixels;
    std::optional<Array<double>> values;    // fitted, not_converged
    std::optional<BlockArrays> system;      // not_converged
    std::optional<index_t> not_finite;      // not_finite: the first such vertex
};

// What solve_blocks found.
struct BlockSolution {
    std::vector<double> x;   // the last iterate
    bool converged = false;  // within rtol
};

// Each vertex's (row, col) of a (V, 2) array, as the row and column spans the passes take.
struct VertexPixels {
    std::vector<index_t> rows, cols;
    explicit VertexPixels(const In2<index_t>& pixels) {
        check_input(pixels.shape(1) == 2, "fit: pixels are (V, 2)");
        const std::size_t n = pixels.shape(0);
        rows.resize(n);
        cols.resize(n);
        for (std::size_t i = 0; i < n; ++i) {
            rows[i] = pixels.data()[2 * i];
            cols[i] = pixels.data()[2 * i + 1];
        }
    }
};

heights::FitMesh pixel_mesh(const In2<index_t>& faces, const VertexPixels& at, const In1<double>& values) {
    const index_t n = static_cast<index_t>(at.rows.size());
    return {grid(faces), {at.rows.data(), n}, {at.cols.data(), n}, span(values)};
}

void bind_fit_classes(nb::module_& m) {
    nb::class_<heights::FitSettings>(m, "FitSettings",
                                     "The least-squares fit's settings (``fit_heights``, ``fit_sample_errors``); "
                                     "rangemesh/refine/heights.py holds the library's values and their reasons.")
        .def(nb::init<>())
        .def("__copy__", [](const heights::FitSettings& s) { return heights::FitSettings(s); })
        .def_prop_rw(
            "row_stride", [](const heights::FitSettings& s) { return s.sample.row_stride; },
            [](heights::FitSettings& s, index_t v) { s.sample.row_stride = v; },
            "The sample of errors: rows that are multiples of this ...")
        .def_prop_rw(
            "face_stride", [](const heights::FitSettings& s) { return s.sample.face_stride; },
            [](heights::FitSettings& s, index_t v) { s.sample.face_stride = v; },
            "... of every face_stride-th face in the visiting order.")
        .def_rw("capacity", &heights::FitSettings::capacity, "At most this many sampled errors (the valid pixels).")
        .def_rw("outlier_mads", &heights::FitSettings::outlier_mads, "The outlier bound, robust standard deviations.")
        .def_rw("outlier_floor", &heights::FitSettings::outlier_floor,
                "The share of the value range at or below which the bound keeps the copied values.")
        .def_rw("ridge", &heights::FitSettings::ridge, "The pull towards the copied values.")
        .def_rw("rtol", &heights::FitSettings::rtol, "Conjugate gradients' relative residual ...")
        .def_rw("max_iter", &heights::FitSettings::max_iter, "... and most steps.")
        .def_rw("threads", &heights::FitSettings::threads, "Threads of the pass over the pixels.")
        .def_rw("lo", &heights::FitSettings::lo, "A fitted value below lo is lo ...")
        .def_rw("hi", &heights::FitSettings::hi, "... one above hi is hi.");
    nb::enum_<FitStatus>(m, "FitOutcome", "What ``fit_heights`` found.")
        .value("NO_PIXELS", FitStatus::no_pixels, "The faces own no valid pixel: keep the copied values.")
        .value("COPIED", FitStatus::copied, "The outlier bound sits at its floor: the copied values are the solution.")
        .value("FITTED", FitStatus::fitted, "``values`` holds the solution, within [lo, hi].")
        .value("NOT_CONVERGED", FitStatus::not_converged,
               "Conjugate gradients did not converge: ``system`` holds the equations for a direct solve.")
        .value("NOT_FINITE", FitStatus::not_finite, "Vertex ``not_finite``'s copied value is NaN or infinite.");
    nb::class_<BlockArrays>(m, "FaceBlocks", "The faces' normal equations, a face a row (``fit_blocks``).")
        .def_prop_ro("ids", value_of(&BlockArrays::ids), nb::rv_policy::move,
                     "(n, 3) int64: the face's corners, counter-clockwise.")
        .def_prop_ro("block", value_of(&BlockArrays::block), nb::rv_policy::move,
                     "(n, 3, 3) float64: the sum of w w^T over its kept pixels.")
        .def_prop_ro("rhs", value_of(&BlockArrays::rhs), nb::rv_policy::move, "(n, 3) float64: the sum of w * value.")
        .def_ro("used", &BlockArrays::used, "Pixels in the system.");
    nb::class_<HeightFit>(m, "HeightFit", "What ``fit_heights`` found.")
        .def_ro("outcome", &HeightFit::outcome, "A FitOutcome.")
        .def_prop_ro("values", value_of(&HeightFit::values), nb::rv_policy::move,
                     "(V,) float64 (FITTED: clipped to [lo, hi]; NOT_CONVERGED: the last iterate), else None.")
        .def_prop_ro("system", value_of(&HeightFit::system), nb::rv_policy::move,
                     "NOT_CONVERGED: the FaceBlocks to solve directly, else None.")
        .def_ro("not_finite", &HeightFit::not_finite, "NOT_FINITE: the first vertex whose value is not, else None.");
    nb::class_<BlockSolution>(m, "BlockSolution", "What ``solve_blocks`` found.")
        .def_prop_ro("x", array_of(&BlockSolution::x), nb::rv_policy::reference_internal,
                     "(V,) float64: conjugate gradients' last iterate.")
        .def_ro("converged", &BlockSolution::converged, "Whether the residual reached rtol within max_iter steps.");
    nb::class_<heights::VertexSystem>(m, "VertexSystem", "The fit's system gathered onto the vertices.")
        .def_prop_ro("diag", array_of(&heights::VertexSystem::diag), nb::rv_policy::reference_internal,
                     "(V,) float64: diag(M) + ridge.")
        .def_prop_ro("rhs", array_of(&heights::VertexSystem::rhs), nb::rv_policy::reference_internal,
                     "(V,) float64: b + ridge * h0.")
        .def_prop_ro("ridge", array_of(&heights::VertexSystem::ridge), nb::rv_policy::reference_internal,
                     "(V,) float64: ridge_share * max(diag(M), 1).");
}

// The fit of the vertices' values to `image` from the caller's arrays: faces (F, 3) and
// pixels (V, 2) of an integer type I, each vertex's copied value read from its pixel.
template <class I>
void bind_fit(nb::module_& m) {
    m.def(
        "fit_heights",
        [](In2<I> faces, In2<I> pixels, In2<double> image, In2<bool> valid, std::optional<In1<index_t>> order,
           const heights::FitSettings& settings) {
            check_input(pixels.shape(1) == 2, "fit: pixels are (V, 2)");
            const index_t n = static_cast<index_t>(pixels.shape(0));
            index_t not_finite = -1;  // the first vertex whose value is not finite
            heights::FitResult fit = run_released(
                [&] {
                    const Grid<const double> values = grid(image);
                    std::vector<index_t> rows(n), cols(n);
                    std::vector<double> copied(n);
                    for (index_t i = 0; i < n; ++i) {
                        rows[i] = static_cast<index_t>(pixels.data()[2 * i]);
                        cols[i] = static_cast<index_t>(pixels.data()[2 * i + 1]);
                        if (rows[i] < 0 || rows[i] >= values.rows || cols[i] < 0 || cols[i] >= values.cols)
                            throw std::invalid_argument("fit: a vertex lies outside the image");
                    }
                    for (index_t i = 0; i < n && not_finite < 0; ++i) {
                        copied[i] = values(rows[i], cols[i]);
                        if (!std::isfinite(copied[i])) not_finite = i;
                    }
                    if (not_finite >= 0) return heights::FitResult{};
                    std::vector<index_t> wide;  // the faces in 64 bits, unless they came so
                    const index_t* ids;
                    if constexpr (std::is_same_v<I, index_t>) {
                        ids = faces.data();
                    } else {
                        wide.assign(faces.data(), faces.data() + faces.size());
                        ids = wide.data();
                    }
                    const index_t n_faces = static_cast<index_t>(faces.shape(0));
                    std::vector<index_t> identity;  // the faces as they come, when no order is given
                    Span<const index_t> visit;
                    if (order) {
                        visit = span(*order);
                    } else {
                        identity.resize(n_faces);
                        std::iota(identity.begin(), identity.end(), index_t{0});
                        visit = Span<const index_t>{identity.data(), n_faces};
                    }
                    const heights::FitMesh mesh{{ids, n_faces, static_cast<index_t>(faces.shape(1))},
                                                {rows.data(), n},
                                                {cols.data(), n},
                                                {copied.data(), n}};
                    return heights::fit_heights(mesh, fit_image(image, valid), visit, settings);
                },
                work(image));
            HeightFit out;
            if (not_finite >= 0) {
                out.outcome = FitStatus::not_finite;
                out.not_finite = not_finite;
                return out;
            }
            out.outcome = status_of(fit.outcome);
            if (fit.outcome == heights::FitOutcome::fitted || fit.outcome == heights::FitOutcome::not_converged)
                out.values = to_numpy(std::move(fit.values));
            if (fit.outcome == heights::FitOutcome::not_converged)
                out.system = arrays_from_blocks(fit.blocks, fit.used);
            return out;
        },
        nb::arg("faces"), nb::arg("pixels"), nb::arg("image"), nb::arg("valid"), nb::arg("order").none(),
        nb::arg("settings"),
        "The least-squares fit to ``image`` of the values of the vertices at ``pixels`` (row, column), copied "
        "from their pixels, the faces visited in ``order`` (None: as they come), under ``settings`` (a "
        "FitSettings): a HeightFit, whose ``outcome`` says which of its fields hold. ValueError when a vertex "
        "lies outside the image.");
}

}  // namespace

nb::tuple face_block_arrays(const std::vector<heights::FaceBlock>& blocks) {
    BlockArrays a = arrays_from_blocks(blocks, 0);
    return nb::make_tuple(a.ids, a.block, a.rhs);
}

void bind_heights(nb::module_& m) {
    // below this many faces the fit's pass runs on the calling thread whatever `threads` says
    m.attr("FIT_SPLIT_MIN_FACES") = heights::SPLIT_MIN_FACES;
    bind_fit_classes(m);
    m.def(
        "face_order",
        [](In2<index_t> faces, In1<index_t> rows, In1<index_t> cols, index_t h, index_t w, index_t tile) {
            check_input(faces.shape(1) == 3 && rows.shape(0) == cols.shape(0) && h >= 1 && w >= 1 && tile >= 1,
                        "face_order: faces (F, 3), one row and column a vertex, a non-empty image, tile >= 1");
            std::vector<index_t> order(faces.shape(0));
            run_released([&] {
                heights::face_order(grid(faces), span(rows), span(cols), h, w, tile,
                                    Span<index_t>{order.data(), static_cast<index_t>(order.size())});
            });
            return to_numpy(std::move(order));
        },
        nb::arg("faces"), nb::arg("rows"), nb::arg("cols"), nb::arg("h"), nb::arg("w"), nb::arg("tile"),
        "The faces (F, 3) in the row-major order of the ``tile`` x ``tile`` pixel cells of their smallest "
        "row and column, stable within a cell. ValueError when a vertex lies outside the h x w image.");
    m.def(
        "fit_sample_errors",
        [](In2<index_t> faces, In1<index_t> order, In2<index_t> pixels, In1<double> values, In2<double> image,
           In2<bool> valid, const heights::FitSettings& settings) {
            const VertexPixels at(pixels);
            // at most an error a pixel: a raw call's capacity of 2^62 would only allocate
            std::vector<double> errors(std::min(std::max<index_t>(settings.capacity, 0), work(image)));
            const index_t used = run_released([&] {
                const heights::FitMesh mesh = pixel_mesh(faces, at, values);
                const heights::FitImage img = fit_image(image, valid);
                heights::check_mesh(mesh, img);
                return heights::sample_errors(mesh, img, span(order), settings.sample,
                                              Span<double>{errors.data(), static_cast<index_t>(errors.size())},
                                              settings.threads);
            });
            errors.resize(used);
            return to_numpy(std::move(errors));
        },
        nb::arg("faces"), nb::arg("order"), nb::arg("pixels"), nb::arg("values"), nb::arg("image"), nb::arg("valid"),
        nb::arg("settings"),
        "``|image - mesh|`` at the owned valid pixels of the rows that are multiples of ``settings.row_stride`` "
        "of the faces ``order[::settings.face_stride]``, the mesh at the values of the vertices at ``pixels`` "
        "(at most ``settings.capacity`` of them).");
    m.def(
        "fit_blocks",
        [](In2<index_t> faces, In1<index_t> order, In2<index_t> pixels, In1<double> values, In2<double> image,
           In2<bool> valid, double threshold, int threads) {
            const VertexPixels at(pixels);
            std::vector<FaceBlock> blocks(order.shape(0));
            const index_t used = run_released([&] {
                const heights::FitMesh mesh = pixel_mesh(faces, at, values);
                const heights::FitImage img = fit_image(image, valid);
                heights::check_mesh(mesh, img);
                return heights::fit_blocks(mesh, img, span(order), threshold, threads,
                                           Span<FaceBlock>{blocks.data(), static_cast<index_t>(blocks.size())});
            });
            return arrays_from_blocks(blocks, used);
        },
        nb::arg("faces"), nb::arg("order"), nb::arg("pixels"), nb::arg("values"), nb::arg("image"), nb::arg("valid"),
        nb::arg("threshold"), nb::arg("threads") = 1,
        "The normal equations of the faces in ``order``, as FaceBlocks: row i for face order[i] (its corners "
        "counter-clockwise, the sums over its pixels whose error is at most ``threshold`` of w w^T and "
        "w * value), and the number of pixels used.");
    m.def(
        "gather_blocks",
        [](In2<index_t> ids, In3<double> block, In2<double> rhs, In1<double> h0, double ridge_share) {
            const std::vector<FaceBlock> blocks = blocks_from_arrays(ids, block, rhs);
            return run_released([&] {
                return heights::gather_blocks(Span<const FaceBlock>{blocks.data(), static_cast<index_t>(blocks.size())},
                                              span(h0), ridge_share);
            });
        },
        nb::arg("ids"), nb::arg("block"), nb::arg("rhs"), nb::arg("h0"), nb::arg("ridge_share"),
        "The fit's system per vertex, a VertexSystem: ``ridge = ridge_share * max(diag(M), 1)``, the "
        "diagonal ``diag(M) + ridge`` and right-hand side ``b + ridge * h0``.");
    m.def(
        "solve_blocks",
        [](In2<index_t> ids, In3<double> block, In2<double> rhs, In1<double> h0, double ridge_share, double rtol,
           index_t max_iter) {
            const std::vector<FaceBlock> blocks = blocks_from_arrays(ids, block, rhs);
            BlockSolution out;
            out.x.resize(h0.shape(0));
            out.converged = run_released([&] {
                return heights::solve_blocks(Span<const FaceBlock>{blocks.data(), static_cast<index_t>(blocks.size())},
                                             span(h0), ridge_share, rtol, max_iter,
                                             Span<double>{out.x.data(), static_cast<index_t>(out.x.size())});
            });
            return out;
        },
        nb::arg("ids"), nb::arg("block"), nb::arg("rhs"), nb::arg("h0"), nb::arg("ridge_share"), nb::arg("rtol"),
        nb::arg("max_iter"),
        "A BlockSolution: ``(M + diag(ridge)) x = b + ridge * h0`` by Jacobi-preconditioned conjugate "
        "gradients from h0, M and b gathered from the faces' blocks onto their vertices ``ids``.");
    m.def(
        "median_inplace",
        [](Out1<double> x) {
            require(x.shape(0) > 0, "median: an empty array has no median");
            return run_released([&] { return heights::median_inplace(span(x)); });
        },
        nb::arg("x"), "``np.median(x)`` of a non-empty float64 array, bit for bit; overwrites ``x``.");
    // int64 first: other integer arrays are widened to it, never narrowed to int32
    bind_fit<index_t>(m);
    bind_fit<std::int32_t>(m);
}

}  // namespace rangemesh::bind
