#include "mesh.hpp"

#include <chrono>
#include <cmath>
#include <memory>
#include <numeric>
#include <utility>

#include "../geometry/delaunay.hpp"
#include "../geometry/fans.hpp"
#include "../geometry/halfedges.hpp"
#include "../geometry/pixels.hpp"
#include "../geometry/vectors.hpp"
#include "../heights/order.hpp"
#include "../heights/pass.hpp"
#include "../interrupt.hpp"
#include "diagonals.hpp"
#include "insertion.hpp"

namespace rangemesh::refine {

namespace {

template <class T>
Span<const T> view(const std::vector<T>& v) {
    return {v.data(), static_cast<index_t>(v.size())};
}

template <class T>
Span<const T> view(Span<T> s) {
    return {s.data, s.size};
}

double seconds_since(std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// The first mesh's arrays (start.py's `first_mesh` on the whole image).
struct FirstArrays {
    std::vector<index_t> vr, vc, triangles, halfedges;
    std::vector<double> vz;

    FirstMesh view() const {
        return {refine::view(vr), refine::view(vc), refine::view(vz), refine::view(triangles),
                refine::view(halfedges)};
    }

    // The image rectangle cut in two, (0,0) (H-1,0) (H-1,W-1) and (0,0) (H-1,W-1) (0,W-1).
    void rectangle() {
        triangles = {0, 1, 2, 0, 2, 3};
        halfedges = {-1, -1, 3, 2, -1, -1};
    }
};

// A corner's depth: its own, or the nearest valid pixel's (ties to the smallest (row, col)).
double corner_depth(const Image& image, index_t r, index_t c) {
    if (!image.valid(r, c)) {
        const auto p = nearest_valid(image.valid, r, c);
        check_input(p.r >= 0, "corner_depths: the image has no valid pixel");
        r = p.r;
        c = p.c;
    }
    return image.depth(r, c);
}

// Grid rows (or columns) of the first mesh: Python's int(round(sqrt(a / b))), ties to even.
index_t grid_side(index_t a, index_t b) {
    return static_cast<index_t>(std::nearbyint(std::sqrt(static_cast<double>(a) / static_cast<double>(b))));
}

// The image corners and about `n_grid` valid grid pixels, Delaunay in units sr x sc.
FirstArrays first_mesh(const Image& image, index_t n_grid, index_t sr, index_t sc) {
    const index_t h = image.rows(), w = image.cols();
    FirstArrays f;
    f.vz = {corner_depth(image, 0, 0), corner_depth(image, h - 1, 0), corner_depth(image, h - 1, w - 1),
            corner_depth(image, 0, w - 1)};
    if (n_grid < 4) {  // the image rectangle: a small call's start
        f.vr = {0, h - 1, h - 1, 0};
        f.vc = {0, 0, w - 1, w - 1};
        f.rectangle();
        return f;
    }
    PixelList grid = grid_pixels(image.valid, grid_side(n_grid * h * sr, w * sc), grid_side(n_grid * w * sc, h * sr),
                                 0, w - 1, false);
    f.vr = std::move(grid.rows);
    f.vc = std::move(grid.cols);
    const index_t n = static_cast<index_t>(f.vr.size());
    if (n > 4) {
        std::vector<index_t> r(n), c(n);
        for (index_t i = 0; i < n; ++i) {
            r[i] = f.vr[i] * sr;
            c[i] = f.vc[i] * sc;
        }
        Triangulation t = delaunay_sweep(PointSet{view(r), view(c)});
        require(!t.triangles.empty(), "first_mesh: the image corners cannot be collinear");
        f.triangles = std::move(t.triangles);
        f.halfedges = std::move(t.halfedges);
    } else {
        f.rectangle();
    }
    for (index_t i = 4; i < n; ++i) f.vz.push_back(image.depth(f.vr[i], f.vc[i]));
    return f;
}

// Each vertex keeps its largest fan once the background triangles are gone (SPEC P4); lone
// triangles stay (insertion.py's `_one_fan_each`).
ValidFaces one_fan_each(const Image& image, ValidFaces f) {
    const index_t n_f = static_cast<index_t>(f.faces.size() / 3), n_v = static_cast<index_t>(f.pixels.size() / 2);
    const std::vector<index_t> wide(f.faces.begin(), f.faces.end());
    std::vector<index_t> triangles, halfedges;
    build_halfedges(Grid<const index_t>{wide.data(), n_f, 3}, n_v, triangles, halfedges);
    std::vector<index_t> neighbors(3 * n_f);
    neighbors_from_halfedges(view(halfedges), Grid<index_t>{neighbors.data(), n_f, 3});
    const std::unique_ptr<bool[]> kept(new bool[n_f]);
    std::fill(kept.get(), kept.get() + n_f, true);
    const LiveTriangles live{{wide.data(), n_f, 3}, {neighbors.data(), n_f, 3}, {kept.get(), n_f}};
    if (prune_dangling(live, n_v, false) == 0) return f;
    std::vector<index_t> rows(n_v), cols(n_v), tv;
    for (index_t i = 0; i < n_v; ++i) {
        rows[i] = f.pixels[2 * i];
        cols[i] = f.pixels[2 * i + 1];
    }
    for (index_t t = 0; t < n_f; ++t)
        if (kept[t]) tv.insert(tv.end(), wide.begin() + 3 * t, wide.begin() + 3 * t + 3);
    return valid_faces(view(rows), view(cols), view(tv), image.valid);
}

// One meshing: the insertion's mesh (its diagonals flipped by the error when asked), kept to the
// valid faces with one fan each.
struct Meshing {
    ValidFaces mesh;
    index_t insertions = 0, flips = 0;

    index_t n_vertices() const { return static_cast<index_t>(mesh.pixels.size() / 2); }
};

Meshing mesh_once(const Image& image, const FirstMesh& first, index_t asked, const MeshRequest& req) {
    Insertion ins(image, first, asked, req.sr, req.sc);
    ins.advance(Stop{asked, -1.0});
    Meshing out;
    out.insertions = ins.n_vertices();
    if (req.flip) {
        std::vector<double> sums = ins.sums();
        const FlipMesh mesh{view(ins.vertex_rows()), view(ins.vertex_cols()), ins.triangles(), ins.halfedges(),
                            {sums.data(), static_cast<index_t>(sums.size())}};
        out.flips = flip_by_error(image, mesh).flips;
    }
    const Span<const index_t> tv = view(ins.triangles());
    out.mesh = valid_faces(view(ins.vertex_rows()), view(ins.vertex_cols()), tv, image.valid);
    const index_t n_f = static_cast<index_t>(out.mesh.faces.size() / 3);
    if (0 < n_f && n_f < tv.size / 3) out.mesh = one_fan_each(image, std::move(out.mesh));
    return out;
}

// The search for exactly `want` vertices: vertices left without a triangle (background
// corners' fans) are inserted again as many more; once a request gave more than `want`, the
// requests are bisected between the last one short of it and the first beyond it. The result
// nearest `want` is kept, one not above it first.
class CountSearch {
  public:
    CountSearch(const MeshRequest& req) : req_(req), want_(req.vertices), beyond_(req.n_valid + 1) {}

    // Note meshing `runs` (request `asked`); false when the search ends, else `asked` is the next.
    bool next(Meshing&& m, index_t runs, index_t& asked) {
        const index_t got = m.n_vertices();
        const std::pair<bool, index_t> rank{got > want_, std::abs(got - want_)};
        if (!has_best_ || rank < best_rank_) {
            best_rank_ = rank;
            best_ = std::move(m);
            has_best_ = true;
        }
        if (got == want_ || runs >= (beyond_ > req_.n_valid ? req_.max_runs : req_.max_bisect_runs)) return false;
        if (got < want_)
            short_ = std::max(short_, asked);
        else
            beyond_ = std::min(beyond_, asked);
        index_t nxt = beyond_ > req_.n_valid ? asked + (want_ - got) : (short_ + beyond_) / 2;
        nxt = std::min(nxt, req_.n_valid);
        if (!(short_ < nxt && nxt < beyond_ && nxt != asked)) return false;
        asked = nxt;
        return true;
    }

    Meshing& best() { return best_; }

  private:
    const MeshRequest& req_;
    index_t want_, short_ = 0, beyond_;
    Meshing best_;
    std::pair<bool, index_t> best_rank_{false, 0};
    bool has_best_ = false;
};

// The image the heights are fitted in: depth, or inverse depth before a pinhole (whose flat
// triangles are linear in it), and the range of its valid values (heights.py's `fit_heights`).
struct FitValues {
    std::vector<double> inverse;  // pinhole only
    Grid<const double> values;
    double lo, hi;
};

FitValues fit_values(const Image& image, bool pinhole, const MeshRequest& req) {
    FitValues v{{}, image.depth, req.lo, req.hi};
    if (!pinhole) return v;
    const index_t n = image.rows() * image.cols();
    v.inverse.resize(n);
    for (index_t i = 0; i < n; ++i) v.inverse[i] = 1.0 / image.depth.data[i];
    v.values = {v.inverse.data(), image.rows(), image.cols()};
    if (req.lo > 0.0) {  // (the inverse of the largest depth is the smallest inverse exactly)
        v.lo = 1.0 / req.hi;
        v.hi = 1.0 / req.lo;
    } else if (req.n_valid > 0) {  // depths <= 0 before a pinhole: the inverses' own range
        bool first = true;
        for (index_t i = 0; i < n; ++i) {
            if (!image.valid.data[i]) continue;
            const double x = v.inverse[i];
            v.lo = first || x < v.lo ? x : v.lo;
            v.hi = first || x > v.hi ? x : v.hi;
            first = false;
        }
    }
    return v;
}

// The fit's settings for a mesh of `n_faces` faces and `n_vertices` vertices.
heights::FitSettings fit_settings(const MeshRequest& req, const FitValues& v, index_t n_faces, index_t n_vertices) {
    const HeightRule& rule = req.heights;
    heights::Sample sample{rule.residual_stride, 1};  // heights.py's `sample_strides`
    if (n_faces >= rule.residual_stride * rule.residual_min)
        sample = {1, std::max(rule.residual_stride, n_faces / rule.residual_sample)};
    const int threads = n_faces < heights::SPLIT_MIN_FACES ? 1 : rule.threads;
    return {sample, req.n_valid, rule.outlier_mads, rule.outlier_floor, rule.ridge, rule.rtol,
            10 * n_vertices, threads, v.lo, v.hi};
}

// The vertices' depths fitted by least squares, into `z`; false when the fit must raise (a value
// that is not finite) or solve directly (not converged): the Python path does both.
bool fitted_depths(const Image& image, bool pinhole, const ValidFaces& f, const MeshRequest& req,
                   std::vector<double>& z) {
    const index_t n_f = static_cast<index_t>(f.faces.size() / 3), n_v = static_cast<index_t>(f.pixels.size() / 2);
    const FitValues v = fit_values(image, pinhole, req);
    std::vector<index_t> rows(n_v), cols(n_v);
    std::vector<double> copied(n_v);
    for (index_t i = 0; i < n_v; ++i) {
        rows[i] = f.pixels[2 * i];
        cols[i] = f.pixels[2 * i + 1];
        copied[i] = v.values(rows[i], cols[i]);
        if (!std::isfinite(copied[i])) return false;
    }
    const std::vector<index_t> faces(f.faces.begin(), f.faces.end());
    std::vector<index_t> order(n_f);
    if (image.rows() * image.cols() >= req.heights.order_min_pixels)
        heights::face_order({faces.data(), n_f, 3}, view(rows), view(cols), image.rows(), image.cols(),
                            req.heights.order_tile, {order.data(), n_f});
    else
        std::iota(order.begin(), order.end(), index_t{0});
    const heights::FitMesh mesh{{faces.data(), n_f, 3}, view(rows), view(cols), view(copied)};
    heights::FitResult fit =
        heights::fit_heights(mesh, {v.values, image.valid}, view(order), fit_settings(req, v, n_f, n_v));
    if (fit.outcome == heights::FitOutcome::not_converged) return false;
    if (fit.outcome != heights::FitOutcome::fitted) return true;  // the copied depths are the solution
    if (pinhole)
        for (double& x : fit.values) x = 1.0 / x;
    z = std::move(fit.values);
    return true;
}

// The mesh's vertices lifted to 3-D from depths `z` (camera.py's `backproject`).
std::vector<double> lifted(Span<const double> camera, const ValidFaces& f, const std::vector<double>& z) {
    const index_t n_v = static_cast<index_t>(z.size());
    std::vector<double> out(3 * n_v);
    for (index_t i = 0; i < n_v; ++i) {
        const Vec3 p = lift(camera, f.pixels[2 * i], f.pixels[2 * i + 1], z[i]);
        out[3 * i] = p.x;
        out[3 * i + 1] = p.y;
        out[3 * i + 2] = p.z;
    }
    return out;
}

}  // namespace

MeshResult refine_mesh(const Image& image, Span<const double> camera, const MeshRequest& req) {
    const auto t0 = std::chrono::steady_clock::now();
    MeshResult out;
    const FirstArrays first = first_mesh(image, req.n_grid, req.sr, req.sc);
    CountSearch search(req);
    index_t asked = req.vertices, insertions = 0, flips = 0;
    bool more = true;
    while (more) {
        ++out.meshings;
        Meshing m = mesh_once(image, first.view(), asked, req);
        insertions = m.insertions;
        flips = m.flips;
        more = search.next(std::move(m), out.meshings, asked);
    }
    ValidFaces& mesh = search.best().mesh;
    const index_t n_v = static_cast<index_t>(mesh.pixels.size() / 2);
    if (mesh.faces.empty()) return out;  // declined: the hull's start is Python's
    std::vector<double> z(n_v);
    for (index_t i = 0; i < n_v; ++i) z[i] = image.depth(mesh.pixels[2 * i], mesh.pixels[2 * i + 1]);
    if (req.fit) {
        const auto t1 = std::chrono::steady_clock::now();
        if (!fitted_depths(image, camera[0] == PINHOLE, mesh, req, z)) return out;
        out.fit_seconds = seconds_since(t1);
    }
    out.vertices = lifted(camera, mesh, z);
    out.edges = count_edges(Grid<const std::int32_t>{mesh.faces.data(), static_cast<index_t>(mesh.faces.size() / 3), 3},
                            n_v);
    out.faces = std::move(mesh.faces);
    out.pixels = std::move(mesh.pixels);
    out.insertions = insertions;
    out.flips = flips;
    out.outcome = MeshOutcome::done;
    out.seconds = seconds_since(t0);
    return out;
}

}  // namespace rangemesh::refine
