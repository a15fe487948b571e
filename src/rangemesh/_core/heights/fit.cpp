#include "fit.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "../interrupt.hpp"
#include "median.hpp"
#include "pass.hpp"
#include "solve.hpp"

namespace rangemesh::heights {

namespace {

// Room for n values of T, kept and grown as asked; uninitialised (plain data).
template <class T>
struct Room {
    std::unique_ptr<T[]> data;
    std::size_t size = 0;

    T* get(std::size_t n) {
        if (n > size) {
            release();  // given back before the larger one is taken: empty, not stale, if new throws
            data.reset(new T[n]);
            size = n;
        }
        return data.get();
    }
    std::size_t bytes() const { return size * sizeof(T); }
    void release() {
        data.reset();
        size = 0;
    }
};

// A fit's buffers. A thread keeps its own from call to call, up to KEPT_BYTES in all: a stream's
// frames then fit in pages already mapped, and a small image's fit allocates nothing.
struct Buffers {
    Room<double> errors;         // the sampled errors: at most `capacity`
    Room<double> median;         // the median's room
    Room<double> solve;          // conjugate gradients' vectors
    Room<PackedBlock> packed;    // the blocks as the solve's products read them
    std::vector<FaceBlock> blocks;  // the faces' normal equations
    bool busy = false;              // a fit on this thread uses them

    // The largest first, until at most KEPT_BYTES remain.
    void trim() {
        constexpr std::size_t KEPT_BYTES = std::size_t{32} << 20;  // a 640 x 480 frame's fit at 10 %: 13 MB
        for (;;) {
            const std::size_t sizes[5] = {errors.bytes(), median.bytes(), solve.bytes(), packed.bytes(),
                                          blocks.capacity() * sizeof(FaceBlock)};
            if (sizes[0] + sizes[1] + sizes[2] + sizes[3] + sizes[4] <= KEPT_BYTES) return;
            switch (std::max_element(sizes, sizes + 5) - sizes) {
                case 0:
                    errors.release();
                    break;
                case 1:
                    median.release();
                    break;
                case 2:
                    solve.release();
                    break;
                case 3:
                    packed.release();
                    break;
                default:
                    std::vector<FaceBlock>().swap(blocks);
            }
        }
    }
};

// This thread's buffers while they are free, else the call's own; trimmed and freed again at its end.
class Lease {
  public:
    Lease() {
        static thread_local Buffers kept;
        buffers_ = kept.busy ? &own_ : &kept;
        buffers_->busy = true;
    }
    ~Lease() {
        buffers_->trim();
        buffers_->busy = false;
    }
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    Buffers& operator*() const { return *buffers_; }

  private:
    Buffers own_;
    Buffers* buffers_;
};

}  // namespace

FitResult fit_heights(const FitMesh& mesh, const FitImage& image, Span<const index_t> order,
                      const FitSettings& settings) {
    check_mesh(mesh, image);
    require(order.size == mesh.faces.rows, "fit: the order visits every face");
    check_order(mesh, order);
    FitResult result;
    const Lease lease;
    Buffers& buffers = *lease;
    // room for an error a valid pixel, left uninitialised: a sample writes a few thousand of
    // them, and zeroing would touch every page
    // (at most an error a pixel: a larger capacity, a raw call's 2^62, would only allocate)
    const index_t capacity = std::min(std::max<index_t>(settings.capacity, 0), image.values.rows * image.values.cols);
    double* const errors = buffers.errors.get(static_cast<std::size_t>(capacity));
    const Span<double> room{errors, capacity};
    index_t sampled = sample_errors_checked(mesh, image, order, settings.sample, room, settings.threads);
    const bool every_pixel = settings.sample.row_stride == 1 && settings.sample.face_stride == 1;
    if (sampled == 0 && !every_pixel)  // the sample missed every valid pixel
        sampled = sample_errors_checked(mesh, image, order, Sample{}, room, settings.threads);
    if (sampled == 0) return result;
    // a robust sigma of the errors (1.4826 x their median: they centre on 0)
    const double sigma =
        1.4826 * median_inplace(Span<double>{errors, sampled}, buffers.median.get(static_cast<std::size_t>(sampled)));
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
    grow_polled(buffers.blocks, static_cast<std::size_t>(order.size));  // hundreds of MB for millions of faces
    const Span<FaceBlock> blocks{buffers.blocks.data(), order.size};
    result.used = fit_blocks_checked(mesh, image, order, result.threshold, settings.threads, blocks);
    result.values.resize(mesh.values.size);
    const std::size_t n = static_cast<std::size_t>(mesh.values.size);
    const bool converged =
        solve_blocks(Span<const FaceBlock>{blocks.data, blocks.size}, mesh.values, settings.ridge, settings.rtol,
                     settings.max_iter, Span<double>{result.values.data(), mesh.values.size}, buffers.solve.get(8 * n),
                     buffers.packed.get(static_cast<std::size_t>(order.size)));
    if (converged)
        for (double& v : result.values) {
            require(std::isfinite(v), "fit: a converged solve is finite");
            // np.minimum(np.maximum(v, lo), hi): the bound when equal, as NumPy's (+-0 alike)
            v = v > settings.lo ? v : settings.lo;
            v = v < settings.hi ? v : settings.hi;
        }
    else  // the system, for a direct solve
        result.blocks.assign(blocks.begin(), blocks.end());
    result.outcome = converged ? FitOutcome::fitted : FitOutcome::not_converged;
    return result;
}

}  // namespace rangemesh::heights
