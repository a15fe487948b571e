#include "fit.hpp"

#include <algorithm>
#include <cmath>
#include <memory>

#include "../interrupt.hpp"
#include "median.hpp"
#include "pass.hpp"
#include "solve.hpp"

namespace rangemesh::heights {

FitResult fit_heights(const FitMesh& mesh, const FitImage& image, Span<const index_t> order,
                      const FitSettings& settings) {
    check_mesh(mesh, image);
    require(order.size == mesh.faces.rows, "fit: the order visits every face");
    FitResult result;
    // room for an error a valid pixel, left uninitialised: a sample writes a few thousand of
    // them, and zeroing would touch every page
    // (at most an error a pixel: a larger capacity, a raw call's 2^62, would only allocate)
    const index_t capacity = std::min(std::max<index_t>(settings.capacity, 0), image.values.rows * image.values.cols);
    const std::unique_ptr<double[]> errors(new double[capacity]);
    const Span<double> room{errors.get(), capacity};
    index_t sampled = sample_errors(mesh, image, order, settings.sample, room, settings.threads);
    const bool every_pixel = settings.sample.row_stride == 1 && settings.sample.face_stride == 1;
    if (sampled == 0 && !every_pixel)  // the sample missed every valid pixel
        sampled = sample_errors(mesh, image, order, Sample{}, room, settings.threads);
    if (sampled == 0) return result;
    // a robust sigma of the errors (1.4826 x their median: they centre on 0)
    const double sigma = 1.4826 * median_inplace(Span<double>{errors.get(), sampled});
    require(mesh.values.size > 0, "fit: pixels were sampled, so there are vertices");
    const auto [lo, hi] = std::minmax_element(mesh.values.begin(), mesh.values.end());
    const double floor = settings.outlier_floor * (*hi - *lo);
    result.threshold = settings.outlier_mads * sigma;
    if (result.threshold <= floor) {
        // most pixels fit the copied values exactly, and only those would be kept: the copied
        // values are the least-squares solution
        result.outcome = FitOutcome::copied;
        return result;
    }
    grow_polled(result.blocks, static_cast<std::size_t>(order.size));  // hundreds of MB for millions of faces
    const Span<FaceBlock> blocks{result.blocks.data(), order.size};
    result.used = fit_blocks(mesh, image, order, result.threshold, settings.threads, blocks);
    result.values.resize(mesh.values.size);
    const bool converged =
        solve_blocks(Span<const FaceBlock>{blocks.data, blocks.size}, mesh.values, settings.ridge, settings.rtol,
                     settings.max_iter, Span<double>{result.values.data(), mesh.values.size});
    if (converged)
        for (double& v : result.values) {
            require(std::isfinite(v), "fit: a converged solve is finite");
            // np.minimum(np.maximum(v, lo), hi): the bound when equal, as NumPy's (+-0 alike)
            v = v > settings.lo ? v : settings.lo;
            v = v < settings.hi ? v : settings.hi;
        }
    result.outcome = converged ? FitOutcome::fitted : FitOutcome::not_converged;
    return result;
}

}  // namespace rangemesh::heights
