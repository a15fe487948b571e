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

heights::FitMesh fit_mesh(const In2<index_t>& faces, const In1<index_t>& rows, const In1<index_t>& cols,
                          const In1<double>& values) {
    return {grid(faces), span(rows), span(cols), span(values)};
}

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

// The arrays (ids (n, 3), block (n, 3, 3), rhs (n, 3)) of the faces' blocks.
nb::tuple arrays_from_blocks(const std::vector<FaceBlock>& blocks) {
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
    nb::ndarray<nb::numpy, double> block(owned->data(), 3, shape, owner);
    return nb::make_tuple(to_numpy(std::move(ids), n, 3), block, to_numpy(std::move(rhs), n, 3));
}

const char* outcome_name(heights::FitOutcome outcome) {
    switch (outcome) {
        case heights::FitOutcome::no_pixels: return "no pixels";
        case heights::FitOutcome::copied: return "copied";
        case heights::FitOutcome::fitted: return "fitted";
        case heights::FitOutcome::not_converged: return "not converged";
    }
    return "";
}


// The fit of the vertices' values to `image` from the caller's arrays: faces (F, 3) and
// pixels (V, 2) of an integer type I, each vertex's copied value read from its pixel.
template <class I>
void bind_fit(nb::module_& m) {
    m.def(
        "fit_heights",
        [](In2<I> faces, In2<I> pixels, In2<double> image, In2<bool> valid, std::optional<In1<index_t>> order,
           double lo, double hi, index_t row_stride, index_t face_stride, index_t capacity, double outlier_mads,
           double outlier_floor, double ridge, double rtol, index_t max_iter, int threads) {
            require(pixels.shape(1) == 2, "fit: pixels are (V, 2)");
            const heights::FitSettings settings{heights::Sample{row_stride, face_stride}, capacity, outlier_mads,
                                                outlier_floor, ridge, rtol, max_iter, threads, lo, hi};
            const index_t n = static_cast<index_t>(pixels.shape(0));
            index_t not_finite = -1;  // the first vertex whose value is not finite
            heights::FitResult fit = run_released([&] {
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
            }, work(image));
            if (not_finite >= 0) return nb::make_tuple("not finite", not_finite, nb::none());
            nb::object fitted = nb::none(), system = nb::none();
            if (fit.outcome == heights::FitOutcome::fitted || fit.outcome == heights::FitOutcome::not_converged)
                fitted = nb::cast(to_numpy(std::move(fit.values)));
            if (fit.outcome == heights::FitOutcome::not_converged) system = arrays_from_blocks(fit.blocks);
            return nb::make_tuple(outcome_name(fit.outcome), fitted, system);
        },
        nb::arg("faces"), nb::arg("pixels"), nb::arg("image"), nb::arg("valid"), nb::arg("order").none(),
        nb::arg("lo"), nb::arg("hi"), nb::arg("row_stride"), nb::arg("face_stride"), nb::arg("capacity"),
        nb::arg("outlier_mads"), nb::arg("outlier_floor"), nb::arg("ridge"), nb::arg("rtol"), nb::arg("max_iter"),
        nb::arg("threads"),
        "The least-squares fit to ``image`` of the values of the vertices at ``pixels`` (row, column), copied "
        "from their pixels, the faces visited in ``order`` (None: as they come): ``(outcome, fitted, system)``, "
        "outcome 'no pixels' or 'copied' (keep the values; fitted None), 'fitted' (clipped to [lo, hi]), "
        "'not converged' (system the ``(ids, block, rhs)`` arrays for a direct solve), or 'not finite' (fitted "
        "the first vertex whose value is not; ValueError when one lies outside the image).");
}

}  // namespace

nb::tuple face_block_arrays(const std::vector<heights::FaceBlock>& blocks) { return arrays_from_blocks(blocks); }

void bind_heights(nb::module_& m) {
    // below this many faces the fit's pass runs on the calling thread whatever `threads` says
    m.attr("FIT_SPLIT_MIN_FACES") = heights::SPLIT_MIN_FACES;
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
        [](In2<index_t> faces, In1<index_t> order, In1<index_t> rows, In1<index_t> cols, In1<double> values,
           In2<double> image, In2<bool> valid, index_t row_stride, index_t face_stride, index_t capacity) {
            // at most an error a pixel: a raw call's capacity of 2^62 would only allocate
            std::vector<double> errors(std::min(std::max<index_t>(capacity, 0), work(image)));
            const index_t used = run_released([&] {
                const heights::FitMesh mesh = fit_mesh(faces, rows, cols, values);
                const heights::FitImage img = fit_image(image, valid);
                heights::check_mesh(mesh, img);
                return heights::sample_errors(mesh, img, span(order), heights::Sample{row_stride, face_stride},
                                              Span<double>{errors.data(), static_cast<index_t>(errors.size())});
            });
            errors.resize(used);
            return to_numpy(std::move(errors));
        },
        nb::arg("faces"), nb::arg("order"), nb::arg("rows"), nb::arg("cols"), nb::arg("values"), nb::arg("image"),
        nb::arg("valid"), nb::arg("row_stride"), nb::arg("face_stride"), nb::arg("capacity"),
        "``|image - mesh|`` at the owned valid pixels of the rows that are multiples of ``row_stride`` of the "
        "faces ``order[::face_stride]``, the mesh at the vertices' ``values`` (at most ``capacity`` of them).");
    m.def(
        "fit_blocks",
        [](In2<index_t> faces, In1<index_t> order, In1<index_t> rows, In1<index_t> cols, In1<double> values,
           In2<double> image, In2<bool> valid, double threshold, int threads) {
            std::vector<FaceBlock> blocks(order.shape(0));
            const index_t used = run_released([&] {
                const heights::FitMesh mesh = fit_mesh(faces, rows, cols, values);
                const heights::FitImage img = fit_image(image, valid);
                heights::check_mesh(mesh, img);
                return heights::fit_blocks(mesh, img, span(order), threshold, threads,
                                           Span<FaceBlock>{blocks.data(), static_cast<index_t>(blocks.size())});
            });
            nb::tuple arrays = arrays_from_blocks(blocks);
            return nb::make_tuple(arrays[0], arrays[1], arrays[2], used);
        },
        nb::arg("faces"), nb::arg("order"), nb::arg("rows"), nb::arg("cols"), nb::arg("values"), nb::arg("image"),
        nb::arg("valid"), nb::arg("threshold"), nb::arg("threads") = 1,
        "The normal equations of the faces in ``order``: ``(ids, block, rhs, used)``, row i for face order[i] "
        "(its corners counter-clockwise, the sums over its pixels whose error is at most ``threshold`` of "
        "w w^T and w * value), and the number of pixels used.");
    m.def(
        "gather_blocks",
        [](In2<index_t> ids, In3<double> block, In2<double> rhs, In1<double> h0, double ridge_share) {
            const std::vector<FaceBlock> blocks = blocks_from_arrays(ids, block, rhs);
            heights::VertexSystem s = run_released([&] {
                return heights::gather_blocks(Span<const FaceBlock>{blocks.data(), static_cast<index_t>(blocks.size())},
                                              span(h0), ridge_share);
            });
            return nb::make_tuple(to_numpy(std::move(s.diag)), to_numpy(std::move(s.rhs)),
                                  to_numpy(std::move(s.ridge)));
        },
        nb::arg("ids"), nb::arg("block"), nb::arg("rhs"), nb::arg("h0"), nb::arg("ridge_share"),
        "``(diag, b, ridge)`` per vertex of the fit's system: ``ridge = ridge_share * max(diag(M), 1)``, the "
        "diagonal ``diag(M) + ridge`` and right-hand side ``b + ridge * h0``.");
    m.def(
        "solve_blocks",
        [](In2<index_t> ids, In3<double> block, In2<double> rhs, In1<double> h0, double ridge_share, double rtol,
           index_t max_iter) {
            const std::vector<FaceBlock> blocks = blocks_from_arrays(ids, block, rhs);
            std::vector<double> x(h0.shape(0));
            const bool converged = run_released([&] {
                return heights::solve_blocks(Span<const FaceBlock>{blocks.data(), static_cast<index_t>(blocks.size())},
                                             span(h0), ridge_share, rtol, max_iter,
                                             Span<double>{x.data(), static_cast<index_t>(x.size())});
            });
            return nb::make_tuple(to_numpy(std::move(x)), converged);
        },
        nb::arg("ids"), nb::arg("block"), nb::arg("rhs"), nb::arg("h0"), nb::arg("ridge_share"), nb::arg("rtol"),
        nb::arg("max_iter"),
        "``(x, converged)``: ``(M + diag(ridge)) x = b + ridge * h0`` by Jacobi-preconditioned conjugate "
        "gradients from h0, M and b gathered from the faces' blocks onto their vertices ``ids``.");
    m.def(
        "median_inplace",
        [](Out1<double> x) {
            require(x.shape(0) > 0, "median: an empty array has no median");
            return run_released([&] { return heights::median_inplace(span(x)); });
        },
        nb::arg("x"),
        "``np.median(x)`` of a non-empty float64 array, bit for bit; overwrites ``x``.");
    // int64 first: other integer arrays are widened to it, never narrowed to int32
    bind_fit<index_t>(m);
    bind_fit<std::int32_t>(m);
}

}  // namespace rangemesh::bind
