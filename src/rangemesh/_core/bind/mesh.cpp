// Python binding of the whole refine call (refine/mesh.hpp): its request and result as classes
// with named fields, one function between them.
#include <nanobind/stl/optional.h>

// NumPy's C API in this file alone (its table a static of this translation unit), for NumPy 1.26 on
#define NPY_NO_DEPRECATED_API NPY_1_25_API_VERSION
#define NPY_TARGET_VERSION NPY_1_25_API_VERSION
#include <numpy/arrayobject.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <optional>
#include <type_traits>
#include <utility>
#include <vector>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "../geometry/pixels.hpp"
#include "../paper/sampling.hpp"
#include "../refine/mesh.hpp"
#include "../refine/walls.hpp"
#include "bindings.hpp"
#include "numpy.hpp"
#include "release.hpp"

namespace rangemesh::bind {

namespace {

using refine::HeightRule;
using refine::MeshRequest;
using refine::MeshResult;

void bind_request(nb::module_& m) {
    nb::class_<HeightRule>(m, "HeightRule",
                           "The least-squares heights' rules (refine/heights.py holds their values and reasons).")
        .def(nb::init<>())
        .def_rw("outlier_mads", &HeightRule::outlier_mads)
        .def_rw("outlier_floor", &HeightRule::outlier_floor)
        .def_rw("ridge", &HeightRule::ridge)
        .def_rw("rtol", &HeightRule::rtol)
        .def_rw("residual_stride", &HeightRule::residual_stride)
        .def_rw("residual_min", &HeightRule::residual_min)
        .def_rw("residual_sample", &HeightRule::residual_sample)
        .def_rw("order_tile", &HeightRule::order_tile)
        .def_rw("order_min_pixels", &HeightRule::order_min_pixels)
        .def_rw("threads", &HeightRule::threads);
    nb::class_<MeshRequest>(m, "RefineRequest",
                            "What one ``refine_mesh`` call asks for (rangemesh/refine/insertion.py fills it).")
        .def(nb::init<>())
        .def_rw("vertices", &MeshRequest::vertices,
                "Valid vertices wanted (at most n_valid); with max_error or a deviation target, the cap.")
        .def_rw("max_error", &MeshRequest::max_error,
                "The relative error bound, percent of the reference's valid range (negative: none).")
        .def_rw("n_valid", &MeshRequest::n_valid, "The image's valid pixels.")
        .def_rw("lo", &MeshRequest::lo, "Their smallest depth.")
        .def_rw("hi", &MeshRequest::hi, "Their largest depth.")
        .def_rw("n_grid", &MeshRequest::n_grid, "Grid points of the first mesh.")
        .def_rw("sr", &MeshRequest::sr, "Weight of rows in the Delaunay test.")
        .def_rw("sc", &MeshRequest::sc, "Weight of columns in the Delaunay test.")
        .def_rw("strips", &MeshRequest::strips, "Insert as two strips (until a count search needs one).")
        .def_rw("seam_density", &MeshRequest::seam_density, "The seam's vertices for a count (strips.py).")
        .def_rw("seam_error_share", &MeshRequest::seam_error_share, "... and under an error bound.")
        .def_rw("threads", &MeshRequest::threads, "The strips' threads (the mesh is the same for 1 or 2).")
        .def_rw("flip", &MeshRequest::flip, "Each quad's diagonal by the error.")
        .def_rw("fit", &MeshRequest::fit, "Heights by least squares, else copied.")
        .def_rw("walls", &MeshRequest::walls, "Keep the walls of jumps (false: drop them; not with a ray camera).")
        .def_rw("jump", &MeshRequest::jump, "The jump rule's share of the local depth per pixel.")
        .def_rw("pixel_angle", &MeshRequest::pixel_angle, "A ray camera's angle of one pixel (walls false).")
        .def_rw("max_runs", &MeshRequest::max_runs, "Meshings at most.")
        .def_rw("max_bisect_runs", &MeshRequest::max_bisect_runs, "... once a request gave more than the count.")
        .def_rw("heights", &MeshRequest::heights, "The fit's rules (a HeightRule).")
        .def_rw("max_deviation", &MeshRequest::max_deviation,
                "Largest deviation of a covered valid pixel, metres or depth units (negative: none).")
        .def_rw("mean_deviation", &MeshRequest::mean_deviation, "Their mean deviation at most (negative: none).")
        .def_rw("max_edge", &MeshRequest::max_edge, "Longest face edge in the image plane, pixels (0: none).")
        .def_rw("deviation_scale", &MeshRequest::deviation_scale, "Metres of one stored depth unit (1: depth units).")
        .def_rw("deviation_inverse", &MeshRequest::deviation_inverse,
                "The prediction interpolates inverse depth (a pinhole, z-depth rays).")
        .def_rw("max_deviation_share", &MeshRequest::max_deviation_share,
                "The first insertion's summed error: this share of max_deviation a valid pixel.")
        .def_rw("max_error_stop", &MeshRequest::max_error_stop,
                "max_error: the first insertion stops at this many times the bound's summed error.")
        .def_rw("collapse", &MeshRequest::collapse,
                "effort='best' when above 1: mesh this many times the count, then collapse to it (0: fast).");
}

void bind_result(nb::module_& m) {
    nb::class_<MeshResult>(m, "RefineResult", "What ``refine_mesh`` made; arrays are views this object keeps alive.")
        .def_prop_ro(
            "done", [](const MeshResult& r) { return r.outcome == refine::MeshOutcome::done; },
            "False when the call declined: a fit that did not converge with no direct_solve given. "
            "No face (done): no triangle of valid pixels, walls_dropped says whether walls took them.")
        .def_prop_ro("faces", array_of(&MeshResult::faces, 3), nb::rv_policy::reference_internal,
                     "(F, 3) int32, counter-clockwise.")
        .def_prop_ro("pixels", array_of(&MeshResult::pixels, 2), nb::rv_policy::reference_internal,
                     "(V, 2) int32: each vertex's (row, col).")
        .def_prop_ro("vertices", array_of(&MeshResult::vertices, 3), nb::rv_policy::reference_internal,
                     "(V, 3) float64, lifted by the camera.")
        .def_prop_ro(
            "vertex_count", [](const MeshResult& r) { return r.pixels.size() / 2; }, "Vertices of the mesh.")
        .def_ro("edges", &MeshResult::edges, "Distinct edges of the faces.")
        .def_ro("insertions", &MeshResult::insertions, "Vertices of the last insertion, background corners included.")
        .def_ro("flips", &MeshResult::flips, "Edges the last insertion's diagonals flipped.")
        .def_ro("strips", &MeshResult::strips, "Strips of the last insertion (1 or 2).")
        .def_ro("meshings", &MeshResult::meshings, "Meshings the search ran.")
        .def_ro("walls_dropped", &MeshResult::walls_dropped, "Walls dropped from the mesh (walls false).")
        .def_ro("asked", &MeshResult::asked, "The last meshing's vertex request.")
        .def_ro("achieved", &MeshResult::achieved,
                "With max_error: the relative error reached (NaN: no valid "
                "pixel covered).")
        .def_ro("deviation_max", &MeshResult::deviation_max, "After rounds: the largest deviation reached.")
        .def_ro("deviation_mean", &MeshResult::deviation_mean, "... and the mean one.")
        .def_ro("longest_edge", &MeshResult::longest_edge, "After rounds: the longest face edge, pixels.")
        .def_ro("uncovered", &MeshResult::uncovered, "After rounds: valid reference pixels no face covers.")
        .def_ro("rounds", &MeshResult::rounds, "Rounds of insertion after the search's meshing.")
        .def_ro("fitted", &MeshResult::fitted, "Heights fitted (false: copied).")
        .def_ro("fit_seconds", &MeshResult::fit_seconds, "Time fitting the heights.")
        .def_ro("seconds", &MeshResult::seconds, "Time of the whole call.");
}

// The contract of a request on an image of rows x cols pixels and a `camera` (Camera.as_array()).
void check_request(const MeshRequest& req, index_t rows, index_t cols, Span<const double> camera) {
    check_input(0 < req.vertices && req.vertices <= req.n_valid && req.n_valid <= rows * cols,
                "refine_mesh: 0 < vertices <= n_valid <= the image's pixels");
    check_input(req.max_error < 0.0 || (req.max_error > 0.0 && std::isfinite(req.max_error)),
                "refine_mesh: max_error negative (none) or a finite positive percentage");
    check_input((req.max_deviation < 0.0 && req.mean_deviation < 0.0) ||
                    (req.max_error < 0.0 && (req.max_deviation < 0.0 || req.mean_deviation < 0.0)),
                "refine_mesh: max_deviation or mean_deviation alone, with no max_error");
    check_input(!(req.max_deviation > std::numeric_limits<double>::max()) &&
                    !(req.mean_deviation > std::numeric_limits<double>::max()) && !std::isnan(req.max_deviation) &&
                    !std::isnan(req.mean_deviation),
                "refine_mesh: max_deviation and mean_deviation finite (negative: none)");
    check_input(req.max_edge == 0.0 || (req.max_edge >= 1.0 && std::isfinite(req.max_edge)),
                "refine_mesh: max_edge 0 (none) or a finite length of 1 pixel or more");
    check_input(req.deviation_scale > 0.0 && std::isfinite(req.deviation_scale) && req.max_deviation_share > 0.0 &&
                    req.max_deviation_share <= 1.0,
                "refine_mesh: deviation_scale finite and above 0, max_deviation_share in (0, 1]");
    check_input(req.max_error_stop > 0.0 && std::isfinite(req.max_error_stop),
                "refine_mesh: max_error_stop finite and above 0");
    check_input(req.walls || camera[0] != 2.0 || (req.pixel_angle > 0.0 && std::isfinite(req.pixel_angle)),
                "refine_mesh: walls dropped with a ray camera need a finite pixel_angle above 0");
    check_input(req.threads >= 1 && (!req.strips || cols >= 4),
                "refine_mesh: threads at least 1, strips on images of 4 columns or more");
    check_input(req.sr >= 1 && req.sc >= 1 && req.max_runs >= 1 && req.max_bisect_runs >= 1,
                "refine_mesh: sr, sc, max_runs and max_bisect_runs at least 1");
    check_input(req.collapse == 0.0 || (req.collapse >= 1.0 && req.collapse <= 16.0),
                "refine_mesh: collapse 0 (effort='fast') or a factor from 1 to 16");
    check_input(camera.size >= 6 && (camera[0] == 0.0 || camera[0] == 1.0 ||
                                     (camera[0] == 2.0 && camera[1] == rows && camera[2] == cols &&
                                      camera.size == 6 + 3 * rows * cols)),
                "refine_mesh: camera is a Camera.as_array() for the image's shape");
}

// `direct_solve(ids, block, rhs, h0)` as the core's DirectSolve (None: none), the GIL taken
// back for the Python solve, a rare fallback.
refine::DirectSolve direct_of(nb::handle direct_solve) {
    if (direct_solve.is_none()) return {};
    return [direct_solve](const std::vector<heights::FaceBlock>& blocks, const std::vector<double>& h0) {
        nb::gil_scoped_acquire gil;
        const nb::tuple system = face_block_arrays(blocks);
        const nb::object out = direct_solve(system[0], system[1], system[2], to_numpy(std::vector<double>(h0)));
        const auto x = nb::cast<nb::ndarray<const double, nb::ndim<1>, nb::c_contig, nb::device::cpu>>(out);
        return std::vector<double>(x.data(), x.data() + x.shape(0));
    };
}

// Depths whose largest magnitude lies outside [2^-DEPTH_BAND, 2^DEPTH_BAND] are scaled first
// (refine/insertion.py's `depth_exponent`): the kernels' squares overflow from about 1e150.
constexpr int DEPTH_BAND = 64;

// Images of fewer pixels take `refine_image` (rangemesh/refine/small.py's SMALL_PIXELS, its reasons).
constexpr index_t SMALL_IMAGE_PIXELS = 2000;

// `refine_image`'s image: a NumPy array of 2 dimensions, at least 2 x 2 and fewer than
// SMALL_IMAGE_PIXELS pixels, C-contiguous, aligned, in native byte order, of float64, float32
// or an integer type of 1, 2, 4 or 8 bytes; null for anything else (the general path's to
// check). Read through NumPy's C API: a tenth of nanobind's ndarray import on a small call.
PyArrayObject* small_image(nb::handle image) {
    if (!PyArray_Check(image.ptr())) return nullptr;
    auto* a = reinterpret_cast<PyArrayObject*>(image.ptr());
    if (PyArray_NDIM(a) != 2 || !PyArray_IS_C_CONTIGUOUS(a) || !PyArray_ISALIGNED(a) || !PyArray_ISNOTSWAPPED(a))
        return nullptr;
    const npy_intp rows = PyArray_DIM(a, 0), cols = PyArray_DIM(a, 1);
    if (rows < 2 || cols < 2 || rows * cols >= SMALL_IMAGE_PIXELS) return nullptr;
    const char kind = PyArray_DESCR(a)->kind;
    const npy_intp size = PyArray_ITEMSIZE(a);
    const bool ok = kind == 'f' ? size == 8 || size == 4
                                : (kind == 'i' || kind == 'u') && (size == 1 || size == 2 || size == 4 || size == 8);
    return ok ? a : nullptr;
}

// The count and extremes of the valid depths (as `valid_range`: four lanes with no branch). The
// bounds are those of any order but for a zero's sign, which a small call never reads: a range
// holding 0 declines.
class RangeLanes {
  public:
    static constexpr int LANES = 4;

    void take(int k, bool ok, double x) {
        count_ += ok ? 1 : 0;
        const double below = ok ? x : INFINITY, above = ok ? x : -INFINITY;
        lo_[k] = below < lo_[k] ? below : lo_[k];
        hi_[k] = above > hi_[k] ? above : hi_[k];
    }
    // Valid depths counted and bounded elsewhere (`mask_float64`'s lanes).
    void add(index_t count, double lo, double hi) {
        count_ += count;
        lo_[0] = lo < lo_[0] ? lo : lo_[0];
        hi_[0] = hi > hi_[0] ? hi : hi_[0];
    }
    DepthRange range() const {
        DepthRange out;
        if (count_ == 0) return out;
        out.count = count_;
        out.lo = lo_[0];
        out.hi = hi_[0];
        for (int k = 1; k < LANES; ++k) {
            if (lo_[k] < out.lo) out.lo = lo_[k];
            if (hi_[k] > out.hi) out.hi = hi_[k];
        }
        return out;
    }

  private:
    double lo_[LANES] = {INFINITY, INFINITY, INFINITY, INFINITY};
    double hi_[LANES] = {-INFINITY, -INFINITY, -INFINITY, -INFINITY};
    index_t count_ = 0;
};

// `mask_image` and the valid range of its result in one loop over the pixels (a third of the
// two passes' instructions on a small image). `mask_image`'s rule on each pixel: NaN, inf and
// `bg` (NaN: none) are invalid, compared as float64 (for an integer type of 4 bytes or less the
// same as its compare as T: such a value is exact in float64).
template <class T>
void mask_as(const void* image, double bg, Grid<double> depth, Grid<bool> valid, RangeLanes& lanes) {
    constexpr double big = std::numeric_limits<double>::max();
    constexpr int LANES = RangeLanes::LANES;
    const auto put = [&](int k, T value, double& d, bool& v) {
        const double x = static_cast<double>(value);
        const bool ok = static_cast<bool>(static_cast<int>(std::abs(x) <= big) & static_cast<int>(x != bg));
        d = ok ? x : 0.0;
        v = ok;
        lanes.take(k, ok, x);
    };
    const T* in = static_cast<const T*>(image);
    for (index_t r = 0; r < depth.rows; ++r) {
        poll_interrupt();
        const T* row = in + r * depth.cols;
        double* d = depth.row(r);
        bool* v = valid.row(r);
        index_t c = 0;
        for (; c + LANES <= depth.cols; c += LANES)
            for (int k = 0; k < LANES; ++k) put(k, row[c + k], d[c + k], v[c + k]);
        for (; c < depth.cols; ++c) put(0, row[c], d[c], v[c]);
    }
}

#if defined(__SSE2__)
// Four pixels' valid flags (bytes 0 or 1, little-endian) from the bits of their two movemasks.
constexpr std::uint32_t FOUR_FLAGS[16] = {0x00000000, 0x00000001, 0x00000100, 0x00000101, 0x00010000, 0x00010001,
                                          0x00010100, 0x00010101, 0x01000000, 0x01000001, 0x01000100, 0x01000101,
                                          0x01010000, 0x01010001, 0x01010100, 0x01010101};

// `mask_as<double>` four pixels at a time in two SSE2 pairs (every x86-64 has SSE2): the same rule
// a pixel, the same depths and flags. Over the image as one row: a small image's buffers and its
// C-contiguous pixels run on from row to row, and its few thousand pixels need no poll.
void mask_float64(const double* in, double bg, Grid<double> depth, Grid<bool> valid, RangeLanes& lanes) {
    const index_t n = depth.rows * depth.cols;
    double* const d = depth.data;
    bool* const v = valid.data;
    const __m128d magnitude = _mm_castsi128_pd(_mm_set1_epi64x(0x7fffffffffffffff));
    const __m128d big = _mm_set1_pd(std::numeric_limits<double>::max()), marker = _mm_set1_pd(bg);
    const __m128d up = _mm_set1_pd(INFINITY), down = _mm_set1_pd(-INFINITY);
    __m128d lo = up, hi = down;
    __m128i count = _mm_setzero_si128();  // (a valid lane's mask, all ones, is -1: subtracted)
    const auto pair = [&](const double* x2, double* d2) {
        const __m128d x = _mm_loadu_pd(x2);
        // |x| <= max (false for NaN) and x != bg (true for a NaN bg: unordered)
        const __m128d ok = _mm_and_pd(_mm_cmple_pd(_mm_and_pd(x, magnitude), big), _mm_cmpneq_pd(x, marker));
        const __m128d kept = _mm_and_pd(ok, x);  // (+0.0 where not valid)
        _mm_storeu_pd(d2, kept);
        count = _mm_sub_epi64(count, _mm_castpd_si128(ok));
        lo = _mm_min_pd(lo, _mm_or_pd(kept, _mm_andnot_pd(ok, up)));
        hi = _mm_max_pd(hi, _mm_or_pd(kept, _mm_andnot_pd(ok, down)));
        return _mm_movemask_pd(ok);
    };
    index_t i = 0;
    for (; i + 4 <= n; i += 4) {
        const int bits = pair(in + i, d + i) | pair(in + i + 2, d + i + 2) << 2;
        std::memcpy(v + i, &FOUR_FLAGS[bits], 4);
    }
    alignas(16) double los[2], his[2];
    alignas(16) std::int64_t counts[2];
    _mm_store_pd(los, lo);
    _mm_store_pd(his, hi);
    _mm_store_si128(reinterpret_cast<__m128i*>(counts), count);
    lanes.add(counts[0] + counts[1], los[0] < los[1] ? los[0] : los[1], his[0] > his[1] ? his[0] : his[1]);
    if (i < n) mask_as<double>(in + i, bg, {d + i, 1, n - i}, {v + i, 1, n - i}, lanes);
}
#endif

// `mask_image` of a `small_image` and its valid range, by its dtype: `float_bg` marks missing depth
// in a float image, `int_bg` in an integer one.
void mask_any(PyArrayObject* image, double int_bg, double float_bg, Grid<double> depth, Grid<bool> valid,
              RangeLanes& lanes) {
    const void* data = PyArray_DATA(image);
    const bool is_signed = PyArray_DESCR(image)->kind == 'i';
    switch (PyArray_DESCR(image)->kind == 'f' ? -PyArray_ITEMSIZE(image) : PyArray_ITEMSIZE(image)) {
        case -8:
#if defined(__SSE2__)
            return mask_float64(static_cast<const double*>(data), float_bg, depth, valid, lanes);
#else
            return mask_as<double>(data, float_bg, depth, valid, lanes);
#endif
        case -4:
            return mask_as<float>(data, float_bg, depth, valid, lanes);
        case 1:
            return is_signed ? mask_as<std::int8_t>(data, int_bg, depth, valid, lanes)
                             : mask_as<std::uint8_t>(data, int_bg, depth, valid, lanes);
        case 2:
            return is_signed ? mask_as<std::int16_t>(data, int_bg, depth, valid, lanes)
                             : mask_as<std::uint16_t>(data, int_bg, depth, valid, lanes);
        case 4:
            return is_signed ? mask_as<std::int32_t>(data, int_bg, depth, valid, lanes)
                             : mask_as<std::uint32_t>(data, int_bg, depth, valid, lanes);
        case 8:
            return is_signed ? mask_as<std::int64_t>(data, int_bg, depth, valid, lanes)
                             : mask_as<std::uint64_t>(data, int_bg, depth, valid, lanes);
        default:
            throw InvariantError("refine_image: small_image let another dtype through");
    }
}

// A small call's masked image, kept by its thread from call to call (at most KEPT_PIXELS): a
// call takes them (none left behind, so a nested or failed call finds none) and gives them back.
struct ImageBuffers {
    static constexpr index_t KEPT_PIXELS = index_t{1} << 13;  // 72 kB; a small image has < 2000 pixels
    std::unique_ptr<double[]> depth;
    std::unique_ptr<bool[]> valid;
    index_t size = 0;

    static ImageBuffers& of_thread() {
        static thread_local ImageBuffers kept;
        return kept;
    }
    void swap(ImageBuffers& o) noexcept {
        depth.swap(o.depth);
        valid.swap(o.valid);
        std::swap(size, o.size);
    }
};

// Buffers for `n` pixels: the thread's kept ones when they are large enough, else new; given back
// at the end when they are at most KEPT_PIXELS and larger than any the thread kept meanwhile.
class ImageLease {
  public:
    explicit ImageLease(index_t n) {
        ImageBuffers& kept = ImageBuffers::of_thread();
        if (kept.size >= n) {
            own_.swap(kept);
            return;
        }
        own_.depth.reset(new double[static_cast<std::size_t>(n)]);
        own_.valid.reset(new bool[static_cast<std::size_t>(n)]);
        own_.size = n;
    }
    ~ImageLease() {
        ImageBuffers& kept = ImageBuffers::of_thread();
        if (own_.size <= ImageBuffers::KEPT_PIXELS && own_.size > kept.size) own_.swap(kept);
    }
    ImageLease(const ImageLease&) = delete;
    ImageLease& operator=(const ImageLease&) = delete;
    double* depth() const { return own_.depth.get(); }
    bool* valid() const { return own_.valid.get(); }

  private:
    ImageBuffers own_;
};

// A new NumPy array of `rows` x `cols` values copied from `values`: a small call's result. Made by
// NumPy's C API, it costs a tenth of a nanobind export (numpy.asarray of a DLPack view, then its
// owner's chain of deallocations): 11K instructions of the 16 x 16 call's three arrays.
template <class T>
nb::object numpy_copy(const std::vector<T>& values, std::size_t rows, std::size_t cols) {
    static_assert(std::is_same_v<T, double> || std::is_same_v<T, std::int32_t>);
    require(values.size() == rows * cols, "numpy_copy: rows x cols values");
    npy_intp dims[2] = {static_cast<npy_intp>(rows), static_cast<npy_intp>(cols)};
    constexpr int type = std::is_same_v<T, double> ? NPY_FLOAT64 : NPY_INT32;
    PyObject* a = PyArray_SimpleNew(2, dims, type);
    if (a == nullptr) throw nb::python_error();
    if (!values.empty())
        std::memcpy(PyArray_DATA(reinterpret_cast<PyArrayObject*>(a)), values.data(), values.size() * sizeof(T));
    return nb::steal(a);
}

double seconds_since(std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// An interned str for each key of a small call's Stats and Mesh, made once (kept for the
// process: a static nb::object would be freed after the interpreter).
struct SmallKeys {
    PyObject *vertices, *sampled_points, *edges, *triangles, *flipped_edges, *flip_tests, *seconds, *target,
        *insertions, *strips, *heights, *faces, *pixels, *image_shape, *stats, *attributes, *prepare, *insertion, *fit,
        *search, *total, *pixel;

    static const SmallKeys& get() {
        static const SmallKeys keys = [] {
            const auto s = [](const char* name) {
                PyObject* o = PyUnicode_InternFromString(name);
                if (o == nullptr) throw nb::python_error();
                return o;
            };
            return SmallKeys{s("vertices"),   s("sampled_points"), s("edges"),     s("triangles"),   s("flipped_edges"),
                             s("flip_tests"), s("seconds"),        s("target"),    s("insertions"),  s("strips"),
                             s("heights"),    s("faces"),          s("pixels"),    s("image_shape"), s("stats"),
                             s("attributes"), s("prepare"),        s("insertion"), s("fit"),         s("search"),
                             s("total"),      s("pixel")};
        }();
        return keys;
    }
};

// d[key] = value, `value` a new reference (null: the error raised making it).
void put(PyObject* d, PyObject* key, PyObject* value) {
    const nb::object owned = nb::steal(value);
    if (!owned.is_valid() || PyDict_SetItem(d, key, owned.ptr()) < 0) throw nb::python_error();
}

nb::object new_with_dict(nb::handle cls, nb::handle fields);
bool dict_class(PyObject* cls);

// A small call's Mesh as `rangemesh.refine.small` made it from the call's values: copies of the
// instance dicts of `made` = (Stats, Mesh, a Stats' fields, a Mesh's fields, the Targets of counts
// met, target_of), the changing fields set. The Target of a count met is made[4][got, meshings]
// when there, else target_of(vertices, got, n_valid, n_pixels, meshings, achieved, asked, want).
nb::object small_mesh(const MeshResult& res, nb::handle vertices, const MeshRequest& asked, index_t n_valid,
                      index_t rows, index_t cols, double prepare, double t0, nb::handle now, nb::handle made) {
    const SmallKeys& k = SmallKeys::get();
    PyObject* const* m = &PyTuple_GET_ITEM(made.ptr(), 0);
    const std::size_t n_v = res.pixels.size() / 2, n_f = res.faces.size() / 3;
    const auto got = static_cast<index_t>(n_v);
    nb::object target;
    if (!vertices.is_none() && got == asked.vertices) {
        const nb::object key = nb::steal(Py_BuildValue("(nn)", got, res.meshings));
        if (!key.is_valid()) throw nb::python_error();
        target = nb::borrow(PyDict_GetItemWithError(m[4], key.ptr()));
        if (!target.is_valid() && PyErr_Occurred()) throw nb::python_error();
    }
    if (!target.is_valid())
        target = nb::borrow(m[5])(vertices, got, n_valid, rows * cols, res.meshings, res.achieved, res.asked,
                                  asked.vertices);
    const double t4 = nb::cast<double>(nb::borrow(now)());
    const nb::object s = nb::steal(PyDict_Copy(m[2]));
    if (!s.is_valid()) throw nb::python_error();
    PyObject* const d = s.ptr();
    put(d, k.vertices, PyLong_FromSsize_t(got));
    put(d, k.sampled_points, PyLong_FromSsize_t(got));
    put(d, k.edges, PyLong_FromSsize_t(res.edges));
    put(d, k.triangles, PyLong_FromSsize_t(static_cast<Py_ssize_t>(n_f)));
    put(d, k.flipped_edges, PyLong_FromSsize_t(res.flips));
    put(d, k.flip_tests, PyDict_New());
    const nb::object seconds = nb::steal(PyDict_New());
    if (!seconds.is_valid()) throw nb::python_error();
    // (Python's float arithmetic, left to right, as the general path's)
    put(seconds.ptr(), k.prepare, PyFloat_FromDouble(prepare));
    put(seconds.ptr(), k.insertion, PyFloat_FromDouble(asked.fit ? res.seconds - res.fit_seconds : res.seconds));
    if (asked.fit) put(seconds.ptr(), k.fit, PyFloat_FromDouble(res.fit_seconds));
    put(seconds.ptr(), k.search, PyFloat_FromDouble(t4 - t0 - prepare - res.seconds));
    put(seconds.ptr(), k.total, PyFloat_FromDouble(t4 - t0));
    put(d, k.seconds, seconds.inc_ref().ptr());
    put(d, k.target, target.inc_ref().ptr());
    put(d, k.insertions, PyLong_FromSsize_t(res.insertions));
    put(d, k.strips, PyLong_FromSsize_t(res.strips));
    put(d, k.heights, nb::borrow(asked.fit && res.fitted ? k.fit : k.pixel).release().ptr());
    const nb::object stats = new_with_dict(m[0], s);
    const nb::object mesh = nb::steal(PyDict_Copy(m[3]));
    if (!mesh.is_valid()) throw nb::python_error();
    PyObject* const e = mesh.ptr();
    put(e, k.vertices, numpy_copy(res.vertices, n_v, 3).release().ptr());
    put(e, k.faces, numpy_copy(res.faces, n_f, 3).release().ptr());
    put(e, k.pixels, numpy_copy(res.pixels, n_v, 2).release().ptr());
    put(e, k.image_shape, Py_BuildValue("(nn)", rows, cols));
    put(e, k.stats, stats.inc_ref().ptr());
    put(e, k.attributes, PyDict_New());
    return new_with_dict(m[1], mesh);
}

// The whole refine call of an orthographic image, unit scales (`rangemesh.refine.small`): the
// preparation (background masked, single-pixel gaps filled, the valid range), `refine_mesh` and
// its Mesh (`small_mesh`) in one call. None (declined) where the library's general path has more
// to do or to say: an image that is no `small_image`, fewer valid pixels than the vertices asked,
// a valid range beyond the float range or holding 0 (a zero marker's warning), a largest depth
// magnitude outside [2^-DEPTH_BAND, 2^DEPTH_BAND] (depths scaled first), no face left, or a call that
// declined. `vertices`: None (the default target; its error bound's reference is the mask before
// the gaps are filled) or the request's count. `masking`: (int_background, float_background,
// fill_gaps), what marks missing depth besides NaN and infinities in an integer image and in a
// float one (NaN: nothing else), and whether single-pixel gaps are filled.
nb::object refine_image(nb::handle image_object, nb::handle vertices, nb::handle masking, const MeshRequest& asked,
                        nb::handle direct_solve, double t0, nb::handle now, nb::handle made) {
    const auto start = std::chrono::steady_clock::now();
    check_input(asked.vertices > 0, "refine_image: the vertices asked above 0");
    PyObject* const mk = masking.ptr();
    check_input(PyTuple_CheckExact(mk) && PyTuple_GET_SIZE(mk) == 3 && PyFloat_CheckExact(PyTuple_GET_ITEM(mk, 0)) &&
                    PyFloat_CheckExact(PyTuple_GET_ITEM(mk, 1)) && PyBool_Check(PyTuple_GET_ITEM(mk, 2)),
                "refine_image: masking (int_background, float_background, fill_gaps): two floats and a bool");
    const double int_background = PyFloat_AS_DOUBLE(PyTuple_GET_ITEM(mk, 0)),
                 float_background = PyFloat_AS_DOUBLE(PyTuple_GET_ITEM(mk, 1));
    const bool fill_gaps = PyTuple_GET_ITEM(mk, 2) == Py_True;
    const double band = std::ldexp(1.0, DEPTH_BAND);
    const bool count = !vertices.is_none();
    const Py_ssize_t n_asked = count && PyLong_CheckExact(vertices.ptr()) ? PyLong_AsSsize_t(vertices.ptr()) : -1;
    PyErr_Clear();  // (an int beyond Py_ssize_t: refused below)
    check_input(!count || n_asked == asked.vertices, "refine_image: vertices None or the request's count");
    PyObject* const m = made.ptr();
    check_input(
        PyTuple_CheckExact(m) && PyTuple_GET_SIZE(m) == 6 && dict_class(PyTuple_GET_ITEM(m, 0)) &&
            dict_class(PyTuple_GET_ITEM(m, 1)) && PyDict_CheckExact(PyTuple_GET_ITEM(m, 2)) &&
            PyDict_CheckExact(PyTuple_GET_ITEM(m, 3)) && PyDict_CheckExact(PyTuple_GET_ITEM(m, 4)) &&
            PyCallable_Check(PyTuple_GET_ITEM(m, 5)) && PyCallable_Check(now.ptr()),
        "refine_image: made (Stats, Mesh: classes new_with_dict takes, two dicts of fields, a dict, a function) "
        "and now a clock");
    const bool reference_before_fill = !count;
    const index_t min_valid = asked.vertices;
    PyArrayObject* const image = small_image(image_object);
    if (image == nullptr) return nb::none();
    const index_t rows = static_cast<index_t>(PyArray_DIM(image, 0)),
                  cols = static_cast<index_t>(PyArray_DIM(image, 1));
    const index_t n = rows * cols;
    const ImageLease buffers(n);
    double* const depth = buffers.depth();
    bool* const valid = buffers.valid();
    std::unique_ptr<bool[]> before;  // the mask before gaps are filled: an error bound's reference
    const Grid<double> d{depth, rows, cols};
    const Grid<bool> v{valid, rows, cols};
    const DepthRange range = run_released(
        [&] {
            RangeLanes lanes;
            mask_any(image, int_background, float_background, d, v, lanes);  // (NaN: no marker)
            DepthRange masked = lanes.range();
            // (with no invalid pixel there is no gap to fill: the mask is the reference)
            if (!fill_gaps || masked.count == n) return masked;
            if (reference_before_fill) {
                before.reset(new bool[static_cast<std::size_t>(n)]);
                std::copy(valid, valid + n, before.get());
            }
            paper::fill_gaps_inplace(d, v);
            return valid_range(Grid<const double>{depth, rows, cols}, Grid<const bool>{valid, rows, cols});
        },
        n);
    const double top = std::max(std::abs(range.lo), std::abs(range.hi));
    if (range.count == 0 || range.count < min_valid || !std::isfinite(range.hi - range.lo) ||
        (top != 0.0 && !(1.0 / band <= top && top <= band)) || (range.lo <= 0.0 && 0.0 <= range.hi))
        return nb::none();
    MeshRequest req = asked;
    req.n_valid = range.count;
    req.lo = range.lo;
    req.hi = range.hi;
    static constexpr double unit[6] = {0.0, 1.0, 1.0, 1.0, 0.0, 0.0};  // Orthographic().as_array()
    const Span<const double> camera{unit, 6};
    check_request(req, rows, cols, camera);
    const refine::Image img{{depth, rows, cols}, {valid, rows, cols}, req.hi - req.lo};
    const refine::Reference ref{img.depth, before ? Grid<const bool>{before.get(), rows, cols} : img.valid};
    const refine::DirectSolve direct = direct_of(direct_solve);
    const double prepare = seconds_since(start);
    MeshResult res = run_released([&] { return refine::refine_mesh(img, camera, ref, req, direct); }, n);
    if (res.outcome != refine::MeshOutcome::done || res.faces.empty()) return nb::none();
    return small_mesh(res, vertices, asked, range.count, rows, cols, prepare, t0, now, made);
}

// A class `new_with_dict` makes instances of: made by object.__new__, not abstract, its instances
// taking a __dict__.
bool dict_class(PyObject* cls) {
    if (!PyType_Check(cls)) return false;
    auto* type = reinterpret_cast<PyTypeObject*>(cls);
    return type->tp_new == PyBaseObject_Type.tp_new && !PyType_HasFeature(type, Py_TPFLAGS_IS_ABSTRACT) &&
           (PyType_HasFeature(type, Py_TPFLAGS_MANAGED_DICT) || type->tp_dictoffset != 0);
}

// An instance of `cls` whose __dict__ is `fields` (not copied), neither __new__ nor __init__
// called: what ``object.__new__(cls)`` and ``object.__setattr__(obj, "__dict__", fields)`` make of
// a class that takes them, at a fifth of their cost (no empty dict made and dropped between).
nb::object new_with_dict(nb::handle cls, nb::handle fields) {
    check_input(PyType_Check(cls.ptr()) && PyDict_CheckExact(fields.ptr()), "new_with_dict: a class and a dict");
    auto* type = reinterpret_cast<PyTypeObject*>(cls.ptr());
    check_input(dict_class(cls.ptr()), "new_with_dict: a class made by object.__new__ whose instances take a __dict__");
    nb::object obj = nb::steal(type->tp_alloc(type, 0));
    if (!obj.is_valid() || PyObject_GenericSetDict(obj.ptr(), fields.ptr(), nullptr) < 0) throw nb::python_error();
    return obj;
}

}  // namespace

void bind_refine_mesh(nb::module_& m) {
    if (PyArray_ImportNumPyAPI() < 0) throw nb::python_error();  // (numpy_copy's table)
    bind_request(m);
    bind_result(m);
    m.def(
        "wall_faces",
        [](In2<index_t> faces, In2<index_t> pixels, In1<double> z, double jump, std::optional<In2<double>> lengths) {
            check_input(faces.shape(1) == 3 && pixels.shape(1) == 2 && z.shape(0) == pixels.shape(0),
                        "wall_faces: faces (F, 3), pixels (V, 2), one depth a vertex");
            check_input(!lengths || (lengths->shape(0) == faces.shape(0) && lengths->shape(1) == 3),
                        "wall_faces: lengths (F, 3), one an edge");
            const index_t n_v = static_cast<index_t>(pixels.shape(0));
            for (index_t i = 0; i < static_cast<index_t>(faces.size()); ++i)
                check_input(0 <= faces.data()[i] && faces.data()[i] < n_v, "wall_faces: a vertex id is out of range");
            const index_t n_f = static_cast<index_t>(faces.shape(0));
            auto* out = new bool[n_f];
            nb::capsule owner(out, [](void* p) noexcept { delete[] static_cast<bool*>(p); });
            run_released(
                [&] {
                    refine::wall_faces(grid(faces), grid(pixels), span(z), jump,
                                       lengths ? grid(*lengths) : Grid<const double>{}, {out, n_f});
                },
                work(faces));
            const std::size_t shape[1] = {static_cast<std::size_t>(n_f)};
            return nb::ndarray<nb::numpy, bool>(out, 1, shape, owner);
        },
        nb::arg("faces"), nb::arg("pixels"), nb::arg("z"), nb::arg("jump"), nb::arg("lengths").none() = nb::none(),
        "Which faces are walls: an edge a -> b (corner k to k + 1) with |za - zb| > jump * min(|za|, |zb|) * "
        "max(L, 1), L ``lengths[t, k]`` (ray angles in pixels) or the distance of its corners' ``pixels``.");
    m.def(
        "ray_lengths",
        [](In1<double> camera, In2<index_t> pixels, In1<index_t> a, In1<index_t> b, double pixel_angle) {
            check_input(camera.shape(0) >= 6 && camera(0) == 2.0 && camera(1) >= 1 && camera(2) >= 1 &&
                            static_cast<double>(camera.shape(0)) == 6 + 3 * camera(1) * camera(2),
                        "ray_lengths: camera is a ray camera's Camera.as_array()");
            check_input(pixels.shape(1) == 2 && a.shape(0) == b.shape(0),
                        "ray_lengths: pixels (V, 2), a and b of one length");
            check_input(pixel_angle > 0.0 && std::isfinite(pixel_angle), "ray_lengths: pixel_angle finite and above 0");
            const index_t n_v = static_cast<index_t>(pixels.shape(0)), n_e = static_cast<index_t>(a.shape(0));
            for (index_t i = 0; i < n_v; ++i)
                check_input(
                    0 <= pixels(i, 0) && pixels(i, 0) < camera(1) && 0 <= pixels(i, 1) && pixels(i, 1) < camera(2),
                    "ray_lengths: a pixel is outside the camera's image");
            for (index_t i = 0; i < n_e; ++i)
                check_input(0 <= a(i) && a(i) < n_v && 0 <= b(i) && b(i) < n_v,
                            "ray_lengths: a vertex id is out of range");
            auto* out = new double[n_e];
            nb::capsule owner(out, [](void* p) noexcept { delete[] static_cast<double*>(p); });
            run_released(
                [&] { refine::ray_lengths(span(camera), grid(pixels), span(a), span(b), pixel_angle, {out, n_e}); },
                work(a));
            const std::size_t shape[1] = {static_cast<std::size_t>(n_e)};
            return nb::ndarray<nb::numpy, double>(out, 1, shape, owner);
        },
        nb::arg("camera"), nb::arg("pixels"), nb::arg("a"), nb::arg("b"), nb::arg("pixel_angle"),
        "Lengths of edges a -> b between vertices' ``pixels`` by the angle of their rays (a ray camera's "
        "``as_array()``), in units of ``pixel_angle``.");
    m.def(
        "refine_mesh",
        [](In2<double> depth, In2<bool> valid, In1<double> camera, const MeshRequest& req,
           std::optional<In2<double>> ref_depth, std::optional<In2<bool>> ref_valid, nb::handle direct_solve) {
            check_input(same_shape(depth, valid), "refine_mesh: depth and valid must have one shape");
            check_input(ref_depth.has_value() == ref_valid.has_value() &&
                            (!ref_depth || (same_shape(*ref_depth, depth) && same_shape(*ref_valid, depth))),
                        "refine_mesh: ref_depth and ref_valid both or neither, of the image's shape");
            check_input(depth.shape(0) >= 2 && depth.shape(1) >= 2, "refine_mesh: an image of at least 2x2 pixels");
            check_request(req, depth.shape(0), depth.shape(1), span(camera));
            const refine::Image image{grid(depth), grid(valid), req.hi - req.lo};
            const refine::Reference ref = ref_depth ? refine::Reference{grid(*ref_depth), grid(*ref_valid)}
                                                    : refine::Reference{image.depth, image.valid};
            const refine::DirectSolve direct = direct_of(direct_solve);
            return run_released([&] { return refine::refine_mesh(image, span(camera), ref, req, direct); },
                                work(depth));
        },
        nb::arg("depth"), nb::arg("valid"), nb::arg("camera"), nb::arg("request"),
        nb::arg("ref_depth").none() = nb::none(), nb::arg("ref_valid").none() = nb::none(),
        nb::arg("direct_solve").none() = nb::none(),
        "The whole refine call on one strip or two: first mesh, insertion, diagonals, valid faces with one fan "
        "each, heights and the lift by ``camera`` (``Camera.as_array()``), searched until "
        "``request.vertices`` vertices or, with ``request.max_error``, the relative error against "
        "``ref_depth``, ``ref_valid`` (default: depth, valid) is met; a fit that does not converge is solved by "
        "``direct_solve(ids, block, rhs, h0)`` (None: the call declines). Returns a RefineResult.");
    m.attr("SMALL_IMAGE_PIXELS") = SMALL_IMAGE_PIXELS;
    m.def("new_with_dict", &new_with_dict, nb::arg("cls"), nb::arg("fields"),
          "An instance of ``cls`` (a class made by ``object.__new__`` whose instances take a __dict__) with "
          "``fields`` (a dict, not copied) as its __dict__, neither __new__ nor __init__ called.");
    m.attr("DEPTH_BAND") = DEPTH_BAND;
    m.def("refine_image", &refine_image, nb::arg("image"), nb::arg("vertices").none(), nb::arg("masking"),
          nb::arg("request"), nb::arg("direct_solve").none(), nb::arg("t0"), nb::arg("now"), nb::arg("made"),
          "The whole refine call of a small image (an (H, W) C-contiguous, aligned, native-order ndarray of float64, "
          "float32 or an integer dtype, H, W >= 2, H * W < SMALL_IMAGE_PIXELS), unit orthographic camera, and its "
          "Mesh: masked by ``masking`` = (int_background, float_background, fill_gaps) (NaN, inf and "
          "``float_background`` in a float image, ``int_background`` in an integer one, unless it is NaN), "
          "single-pixel gaps filled when ``fill_gaps``, then ``refine_mesh`` with ``request`` "
          "(its n_valid, lo and hi set from the image; ``vertices`` None, the default target: the error bound's "
          "reference is the mask before the fill; else the request's count). The Mesh and its Stats are copies of "
          "the fields ``made[2]`` and ``made[3]`` given to ``made[0]`` (Stats) and ``made[1]`` (Mesh), the "
          "changing ones set; ``stats.seconds`` from ``t0`` to ``now()``; ``stats.target`` from the dict "
          "``made[4]`` by ``(vertices, meshings)`` for a count met, else ``made[5](vertices, got, n_valid, "
          "n_pixels, meshings, achieved, asked, want)``. None where the general path has more to do: another "
          "image, fewer valid pixels than ``request.vertices``, a range beyond the float range or holding 0, a "
          "largest depth magnitude outside [2^-DEPTH_BAND, 2^DEPTH_BAND], no face.");
}

}  // namespace rangemesh::bind
