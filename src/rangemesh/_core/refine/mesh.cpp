#include "mesh.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include "../geometry/delaunay.hpp"
#include "../geometry/fans.hpp"
#include "../geometry/halfedges.hpp"
#include "../geometry/pixels.hpp"
#include "../geometry/rasterize.hpp"
#include "../geometry/vectors.hpp"
#include "../heights/order.hpp"
#include "../heights/pass.hpp"
#include "../interrupt.hpp"
#include "../parallel.hpp"
#include "collapse.hpp"
#include "deviation.hpp"
#include "diagonals.hpp"
#include "halves.hpp"
#include "insertion.hpp"
#include "start.hpp"
#include "walls.hpp"

namespace rangemesh::refine {

namespace {

double seconds_since(std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

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

// The image corners and about `n_grid` valid grid pixels, Delaunay in units sr x sc.
StartArrays first_mesh(const Image& image, index_t n_grid, index_t sr, index_t sc) {
    const index_t h = image.rows(), w = image.cols();
    StartArrays f;
    f.vz = {corner_depth(image, 0, 0), corner_depth(image, h - 1, 0), corner_depth(image, h - 1, w - 1),
            corner_depth(image, 0, w - 1)};
    if (n_grid < 4) {  // the image rectangle: a small call's start
        f.vr = {0, h - 1, h - 1, 0};
        f.vc = {0, 0, w - 1, w - 1};
        f.rectangle();
        return f;
    }
    PixelList grid = grid_pixels(image.valid, grid_side(n_grid * h * sr, w * sc), grid_side(n_grid * w * sc, h * sr), 0,
                                 w - 1, false);
    f.vr = std::move(grid.rows);
    f.vc = std::move(grid.cols);
    f.triangulate(image, sr, sc);
    return f;
}

// The twins of `valid_faces(vr, vc, tv, valid)`'s faces from the whole mesh's `he`: -1 where the
// twin's triangle is not kept (no vertex on an invalid pixel).
std::vector<index_t> valid_twins(Span<const index_t> vr, Span<const index_t> vc, Span<const index_t> tv,
                                 Span<const index_t> he, Grid<const bool> valid) {
    const index_t n_t = tv.size / 3;
    require(he.size == tv.size, "valid_twins: one twin a half-edge");
    std::vector<index_t> face(n_t);  // the kept face each triangle becomes, or -1
    index_t n_keep = 0;
    for (index_t t = 0; t < n_t; ++t) {
        poll_every(t);
        const index_t a = tv[3 * t], b = tv[3 * t + 1], c = tv[3 * t + 2];
        const bool keep = valid(vr[a], vc[a]) && valid(vr[b], vc[b]) && valid(vr[c], vc[c]);
        face[t] = keep ? n_keep++ : -1;
    }
    std::vector<index_t> twins(3 * n_keep);
    for (index_t t = 0; t < n_t; ++t) {
        poll_every(t);
        if (face[t] < 0) continue;
        for (int k = 0; k < 3; ++k) {
            const index_t g = he[3 * t + k];
            twins[3 * face[t] + k] = g < 0 || face[g / 3] < 0 ? -1 : 3 * face[g / 3] + g % 3;
        }
    }
    return twins;
}

// Each vertex keeps its largest fan once the background triangles are gone (SPEC P4); lone
// triangles stay (insertion.py's `_one_fan_each`). `twins` are the faces' (`valid_twins`): only
// the stars at their borders are walked (`prune_cut_fans`).
ValidFaces one_fan_each(const Image& image, ValidFaces f, const std::vector<index_t>& twins) {
    const index_t n_f = static_cast<index_t>(f.faces.size() / 3), n_v = static_cast<index_t>(f.pixels.size() / 2);
    const std::vector<index_t> wide(f.faces.begin(), f.faces.end());
    require(static_cast<index_t>(twins.size()) == 3 * n_f, "one_fan_each: one twin a half-edge");
    const std::unique_ptr<bool[]> kept(new bool[n_f]);
    if (prune_cut_fans(view(wide), view(twins), {kept.get(), n_f}) == 0) return f;
    std::vector<index_t> rows(n_v), cols(n_v), tv;
    for (index_t i = 0; i < n_v; ++i) {
        rows[i] = f.pixels[2 * i];
        cols[i] = f.pixels[2 * i + 1];
    }
    for (index_t t = 0; t < n_f; ++t) {
        poll_every(t);
        if (kept[t]) tv.insert(tv.end(), wide.begin() + 3 * t, wide.begin() + 3 * t + 3);
    }
    return valid_faces(view(rows), view(cols), view(tv), image.valid);
}

// The walls dropped, then what leaves a vertex with two fans and lone triangles, the faces
// renumbered over the vertices left (insertion.py's `_assemble`, walls.py's `drop_walls`).
// With a ray camera, edge lengths are ray angles in units of `pixel_angle`.
ValidFaces drop_walls(const Image& image, Span<const double> camera, double pixel_angle, ValidFaces f, double jump,
                      index_t& n_walls) {
    const index_t n_f = static_cast<index_t>(f.faces.size() / 3), n_v = static_cast<index_t>(f.pixels.size() / 2);
    const std::vector<index_t> wide(f.faces.begin(), f.faces.end()), pixels(f.pixels.begin(), f.pixels.end());
    std::vector<double> z(n_v);
    for (index_t i = 0; i < n_v; ++i) z[i] = image.depth(pixels[2 * i], pixels[2 * i + 1]);
    std::vector<double> lengths;  // (F, 3): edge k from corner k to k + 1
    if (camera[0] == 2.0) {
        std::vector<index_t> a(3 * n_f), b(3 * n_f);
        for (index_t t = 0; t < n_f; ++t)
            for (int k = 0; k < 3; ++k) {
                a[3 * t + k] = wide[3 * t + k];
                b[3 * t + k] = wide[3 * t + (k + 1) % 3];
            }
        lengths.resize(3 * n_f);
        ray_lengths(camera, {pixels.data(), n_v, 2}, view(a), view(b), pixel_angle, {lengths.data(), 3 * n_f});
    }
    const std::unique_ptr<bool[]> kept(new bool[n_f]);
    wall_faces({wide.data(), n_f, 3}, {pixels.data(), n_v, 2}, view(z), jump,
               lengths.empty() ? Grid<const double>{} : Grid<const double>{lengths.data(), n_f, 3}, {kept.get(), n_f});
    n_walls = 0;
    for (index_t t = 0; t < n_f; ++t) {
        n_walls += kept[t];
        kept[t] = !kept[t];
    }
    if (n_walls == 0) return f;
    if (n_walls < n_f) {
        std::vector<index_t> triangles, halfedges, neighbors(3 * n_f);
        build_halfedges(Grid<const index_t>{wide.data(), n_f, 3}, n_v, triangles, halfedges);
        neighbors_from_halfedges(view(halfedges), Grid<index_t>{neighbors.data(), n_f, 3});
        prune_dangling(LiveTriangles{{wide.data(), n_f, 3}, {neighbors.data(), n_f, 3}, {kept.get(), n_f}}, n_v);
    }
    std::vector<index_t> rows(n_v), cols(n_v), tv;
    for (index_t i = 0; i < n_v; ++i) {
        rows[i] = pixels[2 * i];
        cols[i] = pixels[2 * i + 1];
    }
    for (index_t t = 0; t < n_f; ++t) {
        poll_every(t);
        if (kept[t]) tv.insert(tv.end(), wide.begin() + 3 * t, wide.begin() + 3 * t + 3);
    }
    return valid_faces(view(rows), view(cols), view(tv), image.valid);
}

// One meshing: the insertion's mesh (its diagonals flipped by the error when asked), kept to the
// valid faces with one fan each.
struct Meshing {
    ValidFaces mesh;
    index_t insertions = 0, flips = 0, n_walls = 0;
    index_t edges = -1;  // the distinct edges of `mesh` when its assembly counted them, else -1
    bool error_left = false;  // the insertion's summed error (before any flip) is above 0
    // with rounds to come (`needs_rounds`): the insertion, unflipped, to go on inserting into
    std::shared_ptr<Insertion> ins;

    index_t n_vertices() const { return static_cast<index_t>(mesh.pixels.size() / 2); }
};

// Meshes of at least this many triangles find their valid faces on two threads when there are two.
constexpr index_t SPLIT_VALID_MIN_TRIANGLES = 8000;

// `valid_faces(vr, vc, tv, valid)` on the calling thread and `second`, each taking half the
// triangles and half the vertices in three steps, and into `twins` `valid_twins`' of its faces
// when a triangle is left out: the same faces, pixels and twins, in the same order.
ValidFaces split_valid_faces(Span<const index_t> vr, Span<const index_t> vc, Span<const index_t> tv,
                             Span<const index_t> he, Grid<const bool> valid, Worker* second,
                             std::vector<index_t>& twins) {
    const index_t n_t = tv.size / 3, n_v = vr.size;
    require(vc.size == n_v, "valid_faces: vr and vc differ in length");
    require(he.size == tv.size, "valid_twins: one twin a half-edge");
    const index_t t_mid = n_t / 2, v_mid = n_v / 2;
    const index_t t_end[2] = {t_mid, n_t}, t_begin[2] = {0, t_mid}, v_end[2] = {v_mid, n_v}, v_begin[2] = {0, v_mid};
    const auto on_valid = [&](index_t v) {
        require(0 <= v && v < n_v, "valid_faces: a vertex id out of range");
        require(vr[v] >= 0 && vr[v] < valid.rows && vc[v] >= 0 && vc[v] < valid.cols,
                "valid_faces: a vertex outside the image");
        return valid(vr[v], vc[v]);
    };
    std::vector<index_t> face(n_t);  // a kept triangle's face (first 0), else -1
    std::vector<unsigned char> used[2];  // the vertices each half's kept triangles use
    std::vector<index_t> new_id(n_v, -1);
    index_t n_keep[2] = {0, 0}, n_used[2] = {0, 0};
    ValidFaces out;
    bool all_kept = false;
    // step `step` on half `k`: 0 the kept triangles, 1 the used vertices and kept triangles numbered
    // in order, 2 the faces and twins
    const auto half = [&](int step, int k) {
        if (step == 0) {
            fill_polled(used[k], n_v, static_cast<unsigned char>(0));
            for (index_t v = v_begin[k]; v < v_end[k]; ++v) on_valid(v);  // (every vertex in the image)
            for (index_t t = t_begin[k]; t < t_end[k]; ++t) {
                poll_every(t);
                const index_t a = tv[3 * t], b = tv[3 * t + 1], c = tv[3 * t + 2];
                const bool keep = on_valid(a) && on_valid(b) && on_valid(c);
                face[t] = keep ? 0 : -1;
                if (keep) {
                    used[k][a] = used[k][b] = used[k][c] = 1;
                    ++n_keep[k];
                }
            }
        } else if (step == 1) {
            index_t next = 0;
            if (k == 1)  // (the first half's count, counted again)
                for (index_t v = 0; v < v_mid; ++v) next += used[0][v] | used[1][v];
            for (index_t v = v_begin[k]; v < v_end[k]; ++v) {
                poll_every(v);
                if (!(used[0][v] | used[1][v])) continue;
                out.pixels[2 * next] = static_cast<std::int32_t>(vr[v]);
                out.pixels[2 * next + 1] = static_cast<std::int32_t>(vc[v]);
                new_id[v] = next++;
            }
            n_used[k] = next;
            index_t f = k == 0 ? 0 : n_keep[0];
            for (index_t t = t_begin[k]; t < t_end[k]; ++t)
                if (face[t] == 0) face[t] = f++;
        } else {
            for (index_t t = t_begin[k]; t < t_end[k]; ++t) {
                poll_every(t);
                if (face[t] < 0) continue;
                for (int j = 0; j < 3; ++j) {
                    out.faces[3 * face[t] + j] = static_cast<std::int32_t>(new_id[tv[3 * t + j]]);
                    if (all_kept) continue;
                    const index_t g = he[3 * t + j];
                    twins[3 * face[t] + j] = g < 0 || face[g / 3] < 0 ? -1 : 3 * face[g / 3] + g % 3;
                }
            }
        }
    };
    const auto both = [&](int step) { run_both(second, [&] { half(step, 0); }, [&] { half(step, 1); }); };
    both(0);
    fill_polled(out.faces, 3 * (n_keep[0] + n_keep[1]), std::int32_t{0});
    fill_polled(out.pixels, 2 * n_v, std::int32_t{0});  // (cut to the used ones)
    both(1);
    out.pixels.resize(2 * n_used[1]);
    all_kept = n_keep[0] + n_keep[1] == n_t;
    if (!all_kept) fill_polled(twins, 3 * (n_keep[0] + n_keep[1]), index_t{0});
    both(2);
    return out;
}

// The valid faces of an insertion's mesh (triangles `tv`, twins `he`), with one fan each, its
// walls dropped unless kept (insertion.py's `_assemble`); `n_walls` counts the dropped ones. A
// large mesh's valid faces are found on the calling thread and `second` when given.
// `edges`: the faces' distinct edges when no fan was pruned and the walls are kept (each edge one
// half-edge of a face and its twin, or one with no kept twin: (3 F + untwinned half-edges) / 2),
// else -1.
ValidFaces assemble(const Image& image, Span<const double> camera, Span<const index_t> vr, Span<const index_t> vc,
                    Span<const index_t> tv, Span<const index_t> he, const MeshRequest& req, index_t& n_walls,
                    index_t& edges, Worker* second = nullptr) {
    ValidFaces f;
    std::vector<index_t> twins;
    const bool split = second != nullptr && tv.size / 3 >= SPLIT_VALID_MIN_TRIANGLES;
    if (split)
        f = split_valid_faces(vr, vc, tv, he, image.valid, second, twins);
    else
        f = valid_faces(vr, vc, tv, image.valid);
    const index_t n_f = static_cast<index_t>(f.faces.size() / 3);
    edges = -1;
    if (n_f > 0 && n_f == tv.size / 3 && req.walls && he.size == tv.size)
        edges = (3 * n_f + static_cast<index_t>(std::count(he.begin(), he.end(), index_t{-1}))) / 2;
    if (0 < n_f && n_f < tv.size / 3) {
        if (!split) twins = valid_twins(vr, vc, tv, he, image.valid);
        f = one_fan_each(image, std::move(f), twins);
        if (static_cast<index_t>(f.faces.size() / 3) == n_f && req.walls)  // (no fan pruned: the twins hold)
            edges = (3 * n_f + static_cast<index_t>(std::count(twins.begin(), twins.end(), index_t{-1}))) / 2;
    }
    if (!req.walls && !f.faces.empty()) f = drop_walls(image, camera, req.pixel_angle, std::move(f), req.jump, n_walls);
    return f;
}

// Whether the search's mesh goes on to rounds of insertion (a deviation target, max_edge).
bool needs_rounds(const MeshRequest& req) {
    return req.max_deviation >= 0.0 || req.mean_deviation >= 0.0 || req.max_edge > 0.0;
}

// The meshing of insertion `ins` as it stands: its diagonals flipped by the error when asked,
// assembled. With `keep` the flips work on copies of its triangles, so that it can go on
// inserting (the rounds).
Meshing meshing_of(const Image& image, Span<const double> camera, Insertion& ins, const MeshRequest& req, bool keep) {
    Meshing out;
    out.insertions = ins.n_vertices();
    out.error_left = ins.total() > 0.0;
    std::vector<index_t> tv_copy, he_copy;
    Span<index_t> tv = ins.triangles(), he = ins.halfedges();
    if (keep) {
        tv_copy.assign(tv.begin(), tv.end());
        he_copy.assign(he.begin(), he.end());
        tv = {tv_copy.data(), tv.size};
        he = {he_copy.data(), he.size};
    }
    if (req.flip) {
        std::vector<double> sums = ins.sums();
        out.error_left = std::any_of(sums.begin(), sums.end(), [](double x) { return x > 0.0; });
        const FlipMesh mesh{
            view(ins.vertex_rows()), view(ins.vertex_cols()), tv, he, {sums.data(), static_cast<index_t>(sums.size())}};
        out.flips = flip_by_error(image, mesh, false).flips;  // (the insertion's own arrays)
    }
    out.mesh = assemble(image, camera, view(ins.vertex_rows()), view(ins.vertex_cols()), view(tv), view(he), req,
                        out.n_walls, out.edges);
    return out;
}

// Insertion until `asked` valid vertices or, when `max_sum` is not negative, a summed error of
// at most `max_sum` (insertion.py's `_refine`), then assembled.
Meshing mesh_once(const Image& image, Span<const double> camera, const FirstMesh& first, index_t asked, double max_sum,
                  const MeshRequest& req) {
    if (needs_rounds(req)) {  // the insertion kept for the rounds
        auto ins = std::make_shared<Insertion>(image, first, max_sum < 0.0 ? asked : 0, req.sr, req.sc);
        ins->advance(Stop{asked, max_sum});
        Meshing out = meshing_of(image, camera, *ins, req, true);
        out.ins = std::move(ins);
        return out;
    }
    Insertion ins(image, first, max_sum < 0.0 ? asked : 0, req.sr, req.sc);
    ins.advance(Stop{asked, max_sum});
    return meshing_of(image, camera, ins, req, false);
}

// The same on two strips (`insert_halves`), on the calling thread and `second` (or none).
Meshing mesh_halves(const Image& image, Span<const double> camera, index_t asked, double max_sum,
                    const MeshRequest& req, Worker* second) {
    const HalvesRequest hreq{asked,  max_sum,          req.n_grid,           req.n_valid, req.sr,
                             req.sc, req.seam_density, req.seam_error_share, req.threads, req.flip};
    const Halves halves = insert_halves(image, hreq, second);
    Meshing out;
    out.insertions = static_cast<index_t>(halves.vr.size());
    out.flips = halves.flips;
    out.error_left = halves.total > 0.0;
    out.mesh = assemble(image, camera, view(halves.vr), view(halves.vc), view(halves.triangles), view(halves.halfedges),
                        req, out.n_walls, out.edges, second);
    return out;
}

// Corners of the convex hull of the valid pixels, counter-clockwise in (row, col), none on a hull
// edge; empty when fewer than 3 (start.py's `valid_hull`: each valid row's first and last pixels,
// monotone chain in exact integers).
std::vector<std::pair<index_t, index_t>> valid_hull(Grid<const bool> valid) {
    using Point = std::pair<index_t, index_t>;
    std::vector<Point> pts;
    for (index_t r = 0; r < valid.rows; ++r) {
        index_t first = -1, last = -1;
        for (index_t c = 0; c < valid.cols; ++c)
            if (valid(r, c)) {
                if (first < 0) first = c;
                last = c;
            }
        if (first < 0) continue;
        pts.emplace_back(r, first);
        if (last != first) pts.emplace_back(r, last);
    }
    const auto turn = [](const Point& o, const Point& a, const Point& b) {
        return (a.first - o.first) * (b.second - o.second) - (a.second - o.second) * (b.first - o.first);
    };
    const auto half = [&](auto begin, auto end, std::vector<Point>& out) {
        std::vector<Point> chain;
        for (auto p = begin; p != end; ++p) {
            while (chain.size() >= 2 && turn(chain[chain.size() - 2], chain.back(), *p) <= 0) chain.pop_back();
            chain.push_back(*p);
        }
        if (!chain.empty()) chain.pop_back();
        out.insert(out.end(), chain.begin(), chain.end());
    };
    std::vector<Point> hull;  // (pts is sorted by row, then column, and unique)
    half(pts.begin(), pts.end(), hull);
    half(pts.rbegin(), pts.rend(), hull);
    if (hull.size() < 3) hull.clear();
    return hull;
}

// A first mesh of valid pixels only: at most `limit` corners of their hull, Delaunay in units
// sr x sc (start.py's `hull_mesh`); none when the hull has fewer than 3 corners or `limit` < 3.
std::optional<StartArrays> hull_mesh(const Image& image, index_t limit, index_t sr, index_t sc) {
    const auto hull = valid_hull(image.valid);
    const index_t n = static_cast<index_t>(hull.size());
    if (n < 3 || limit < 3) return std::nullopt;
    StartArrays f;
    const index_t k = std::min(n, limit);
    // np.linspace(0, n, limit, endpoint=False).astype(np.int64): evenly spread corners
    const double step = static_cast<double>(n) / static_cast<double>(limit);
    std::vector<index_t> r(k), c(k);
    for (index_t i = 0; i < k; ++i) {
        const index_t j = n > limit ? static_cast<index_t>(static_cast<double>(i) * step + 0.0) : i;
        f.vr.push_back(hull[j].first);
        f.vc.push_back(hull[j].second);
        f.vz.push_back(image.depth(hull[j].first, hull[j].second));
        r[i] = hull[j].first * sr;
        c[i] = hull[j].second * sc;
    }
    Triangulation t = delaunay_sweep(PointSet{view(r), view(c)});
    require(!t.triangles.empty(), "hull_mesh: the hull's corners cannot be collinear");
    f.triangles = std::move(t.triangles);
    f.halfedges = std::move(t.halfedges);
    return f;
}

// The search for exactly `want` vertices: vertices left without a triangle (background
// corners' fans) are inserted again as many more; once a request gave more than `want`, the
// requests are bisected between the last one short of it and the first beyond it. The result
// nearest `want` is kept, one not above it first.
class CountSearch {
  public:
    CountSearch(const MeshRequest& req, index_t want) : req_(req), want_(want), beyond_(req.n_valid + 1) {}

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

// A pinhole fit's inverse depths: its thread's room, kept from fit to fit, when free and at most
// KEPT_INVERSE values, else the fit's own. A 640 x 480 frame's 2.4 MB, new each fit, were faulted
// in again each time (glibc gives the heap's top back on free); at most 16 MB a thread stays.
constexpr index_t KEPT_INVERSE = index_t{1} << 21;

struct InverseRoom {
    std::vector<double> values;
    bool busy = false;
};

class InverseLease {
  public:
    explicit InverseLease(index_t n) {
        static thread_local InverseRoom kept;
        InverseRoom* const room = n <= KEPT_INVERSE && !kept.busy ? &kept : &own_;
        grow_polled(room->values, static_cast<std::size_t>(n));  // may throw: marked busy after
        room_ = room;
        room_->busy = true;
    }
    ~InverseLease() { room_->busy = false; }
    InverseLease(const InverseLease&) = delete;
    InverseLease& operator=(const InverseLease&) = delete;
    double* data() { return room_->values.data(); }

  private:
    InverseRoom own_;
    InverseRoom* room_;
};

// The image the heights are fitted in: depth, or inverse depth before a pinhole (whose flat
// triangles are linear in it, written into `inverse`), and the range of its valid values
// (heights.py's `fit_heights`).
struct FitValues {
    Grid<const double> values;
    double lo, hi;
};

FitValues fit_values(const Image& image, const MeshRequest& req, InverseLease* inverse) {
    FitValues v{image.depth, req.lo, req.hi};
    if (inverse == nullptr) return v;
    const index_t n = image.rows() * image.cols();
    double* const inv = inverse->data();
    const double* const depth = image.depth.data;
    for (index_t s = 0; s < n; s += POLL_STRIDE) {  // polled by strides: the division vectorises
        poll_interrupt();
        const index_t e = std::min(n, s + POLL_STRIDE);
        for (index_t i = s; i < e; ++i) inv[i] = 1.0 / depth[i];
    }
    v.values = {inv, image.rows(), image.cols()};
    if (req.lo > 0.0) {  // (the inverse of the largest depth is the smallest inverse exactly)
        v.lo = 1.0 / req.hi;
        v.hi = 1.0 / req.lo;
    } else if (req.n_valid > 0) {  // depths <= 0 before a pinhole: the inverses' own range
        bool first = true;
        for (index_t i = 0; i < n; ++i) {
            poll_every(i);
            if (!image.valid.data[i]) continue;
            const double x = inv[i];
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
    return {sample, req.n_valid, rule.outlier_mads, rule.outlier_floor, rule.ridge, rule.rtol, 10 * n_vertices, threads,
            v.lo,   v.hi};
}

// How a fit of the vertices' depths ended: `z` set (fitted, or the copied depths as the
// solution), or not: a vertex value that is not finite (`FitStatus::vertex`), or conjugate
// gradients did not converge and no direct solve was given.
struct FitStatus {
    enum { ok, not_finite, not_converged } outcome = ok;
    index_t vertex = -1;
    explicit operator bool() const { return outcome == ok; }
};

// The vertices' depths fitted by least squares, into `z`; a fit that does not converge is solved
// by `direct` when given, its values clipped to the valid range as the fit clips its own.
FitStatus fitted_depths(const Image& image, bool pinhole, const ValidFaces& f, const MeshRequest& req,
                        std::vector<double>& z, const DirectSolve* direct = nullptr) {
    const index_t n_f = static_cast<index_t>(f.faces.size() / 3), n_v = static_cast<index_t>(f.pixels.size() / 2);
    std::optional<InverseLease> inverse;
    if (pinhole) inverse.emplace(image.rows() * image.cols());
    const FitValues v = fit_values(image, req, inverse ? &*inverse : nullptr);
    // the vertices' rows and columns, the faces (3 a face) and their order, in one allocation:
    // a small mesh's fit is mostly set-up
    std::vector<index_t> ids(2 * n_v + 4 * n_f);
    index_t* const rows = ids.data();
    index_t* const cols = rows + n_v;
    index_t* const faces = cols + n_v;
    index_t* const order = faces + 3 * n_f;
    std::vector<double> copied(n_v);
    for (index_t i = 0; i < n_v; ++i) {
        poll_every(i);
        rows[i] = f.pixels[2 * i];
        cols[i] = f.pixels[2 * i + 1];
        copied[i] = v.values(rows[i], cols[i]);
        if (!std::isfinite(copied[i])) return {FitStatus::not_finite, i};
    }
    std::copy(f.faces.begin(), f.faces.end(), faces);
    const Span<const index_t> vrows{rows, n_v}, vcols{cols, n_v};
    if (image.rows() * image.cols() >= req.heights.order_min_pixels)
        heights::face_order({faces, n_f, 3}, vrows, vcols, image.rows(), image.cols(), req.heights.order_tile,
                            {order, n_f});
    else
        std::iota(order, order + n_f, index_t{0});
    const heights::FitMesh mesh{{faces, n_f, 3}, vrows, vcols, view(copied)};
    heights::FitResult fit = heights::fit_heights(mesh, {v.values, image.valid}, Span<const index_t>{order, n_f},
                                                  fit_settings(req, v, n_f, n_v));
    if (fit.outcome == heights::FitOutcome::not_converged) {  // ill-conditioned: a direct solve
        if (direct == nullptr || !*direct) return {FitStatus::not_converged, -1};
        fit.values = (*direct)(fit.blocks, copied);
        require(static_cast<index_t>(fit.values.size()) == n_v,
                "fitted_depths: the direct solve's values, one a vertex");
        for (double& x : fit.values) {
            if (!std::isfinite(x)) throw InvariantError("fit_heights: the least-squares solve failed");
            x = std::min(std::max(x, v.lo), v.hi);  // (np.minimum(np.maximum(x, lo), hi): NaN-free here)
        }
    } else if (fit.outcome != heights::FitOutcome::fitted) {
        return {};  // the copied depths are the solution
    }
    if (pinhole)
        for (double& x : fit.values) x = 1.0 / x;
    z = std::move(fit.values);
    return {};
}

// The ValueError of a fit that meets a vertex value that is not finite (refine/heights.py's).
[[noreturn]] void not_finite(const Image& image, bool pinhole, const ValidFaces& f, index_t vertex) {
    const index_t r = f.pixels[2 * vertex], c = f.pixels[2 * vertex + 1];
    if (pinhole && image.depth(r, c) == 0.0)
        throw std::invalid_argument("depth 0 at pixel (" + std::to_string(r) + ", " + std::to_string(c) +
                                    ") cannot be fitted with a pinhole camera (its inverse depth is infinite): "
                                    "mark missing depth with background=0, or copy the depths with heights='pixel'");
    throw std::invalid_argument("fit_heights: every vertex must sit on a valid pixel");
}

// The mesh's vertices lifted to 3-D from depths `z` (camera.py's `backproject`).
std::vector<double> lifted(Span<const double> camera, const ValidFaces& f, const std::vector<double>& z) {
    const index_t n_v = static_cast<index_t>(z.size());
    std::vector<double> out(3 * n_v);
    for (index_t i = 0; i < n_v; ++i) {
        poll_every(i);
        const Vec3 p = lift(camera, f.pixels[2 * i], f.pixels[2 * i + 1], z[i]);
        out[3 * i] = p.x;
        out[3 * i + 1] = p.y;
        out[3 * i + 2] = p.z;
    }
    return out;
}

// A render's buffers: its values (set where claimed) and its claims.
struct RenderBuffers {
    std::unique_ptr<double[]> pred;
    std::vector<unsigned char> claimed;
    index_t size = 0;   // the values `pred` holds room for
    bool busy = false;  // a measure of this thread renders into them
};

// Renders of at most KEPT_PIXELS pixels use their thread's buffers, kept from call to call: a
// stream's frames then render into pages already mapped (a 640 x 480 frame's 2.7 MB, new each
// call, were faulted in again each time); at most 19 MB a thread stays. Larger ones are the call's.
constexpr index_t KEPT_PIXELS = index_t{1} << 21;

RenderBuffers& thread_buffers() {
    static thread_local RenderBuffers kept;
    return kept;
}

// The relative error of a mesh against the reference (render.py's `relative_error`): percent of
// the reference's valid depth range, mean over its valid pixels the mesh covers; NaN when none.
class ErrorMeasure {
  public:
    ErrorMeasure(Span<const double> camera, const Reference& ref)
        : camera_(camera), ref_(ref), n_(ref.depth.rows * ref.depth.cols) {}
    ~ErrorMeasure() {
        if (buffers_ != nullptr && buffers_ != &own_) buffers_->busy = false;
    }
    ErrorMeasure(const ErrorMeasure&) = delete;
    ErrorMeasure& operator=(const ErrorMeasure&) = delete;

    double operator()(const ValidFaces& f, const std::vector<double>& vertices) {
        const bool inverse = camera_[0] == PINHOLE;
        bool stored = false;  // a pinhole's inverse depths beyond the float range: stored units
        const std::vector<double> val = corner_values(vertices, stored);
        const index_t n_f = static_cast<index_t>(f.faces.size() / 3), w = ref_.depth.cols;
        std::vector<double> fr, fc, fv;
        fr.reserve(3 * n_f);
        fc.reserve(3 * n_f);
        fv.reserve(3 * n_f);
        for (index_t t = 0; t < n_f; ++t) {
            poll_every(t);
            const FaceCorners corners = face_corners(f, t);
            if (corners.wraps(w)) continue;  // a wrap-around seam face covers no pixel centre
            for (int k = 0; k < 3; ++k) {
                fr.push_back(corners.r[k]);
                fc.push_back(corners.c[k]);
                fv.push_back(val[f.faces[3 * t + k]]);
            }
        }
        // the render's values are read only where claimed: they need no NaN fill (one write of
        // 8 bytes a pixel less)
        RenderBuffers& b = buffers();
        fill_polled(b.claimed, static_cast<std::size_t>(n_), static_cast<unsigned char>(0));
        const index_t n_kept = static_cast<index_t>(fr.size() / 3);
        rasterize({{fr.data(), n_kept, 3}, {fc.data(), n_kept, 3}, {fv.data(), n_kept, 3}},
                  ValueTarget{{b.pred.get(), ref_.depth.rows, w}, {b.claimed.data(), ref_.depth.rows, w}});
        // the valid range on the first render's pass (only an error bound measures: a count's call makes none)
        DepthRange* range = has_range_ ? nullptr : &range_;
        const Grid<const double> pred{b.pred.get(), ref_.depth.rows, w};
        const Grid<const unsigned char> claimed{b.claimed.data(), ref_.depth.rows, w};
        const DepthMap map{!inverse ? DepthMap::same
                           : stored ? DepthMap::inverse
                                    : DepthMap::inverse_scaled,
                           camera_[5]};
        const CoveredError e = claimed_error(pred, claimed, ref_.depth, ref_.valid, map, range);
        has_range_ = true;
        if (e.count == 0) return std::numeric_limits<double>::quiet_NaN();
        return per_span(e.total / static_cast<double>(e.count), range_.hi - range_.lo);
    }

  private:
    // The render's buffers: the thread's when they are free and hold the image, else the
    // measure's own; room for the image's values made on the first render.
    RenderBuffers& buffers() {
        if (buffers_ == nullptr) {
            RenderBuffers& kept = thread_buffers();
            buffers_ = n_ <= KEPT_PIXELS && !kept.busy ? &kept : &own_;
            buffers_->busy = true;
        }
        if (buffers_->size < n_) {
            buffers_->pred.reset(new double[static_cast<std::size_t>(n_)]);
            buffers_->size = n_;
        }
        return *buffers_;
    }

    // The value each vertex interpolates: depth (orthographic), inverse depth (pinhole), range.
    std::vector<double> corner_values(const std::vector<double>& vertices, bool& stored) const {
        const index_t n_v = static_cast<index_t>(vertices.size() / 3);
        std::vector<double> val(n_v);
        for (index_t i = 0; i < n_v; ++i) {
            poll_every(i);
            const double x = vertices[3 * i], y = vertices[3 * i + 1], z = vertices[3 * i + 2];
            if (camera_[0] == ORTHOGRAPHIC) {
                val[i] = z / camera_[3];
            } else if (camera_[0] == PINHOLE) {
                val[i] = 1.0 / z;
                stored = stored || (z != 0.0 && !std::isfinite(val[i]));
            } else {
                val[i] = std::sqrt((x * x + y * y) + z * z) / camera_[3];  // np.linalg.norm's order
            }
        }
        if (stored)
            for (index_t i = 0; i < n_v; ++i) val[i] = camera_[5] / vertices[3 * i + 2];
        return val;
    }

    // x * 100 / span (render.py's `per_span`): 0 for no span, x / span * 100 when 100 / span overflows.
    static double per_span(double x, double span) {
        if (!(span > 0)) return x * 0.0;
        const double factor = 100.0 / span;
        return std::isfinite(factor) ? x * factor : x / span * 100.0;
    }

    Span<const double> camera_;
    Reference ref_;
    DepthRange range_;
    bool has_range_ = false;
    index_t n_;
    RenderBuffers own_;
    RenderBuffers* buffers_ = nullptr;  // own_ or the thread's, from the first render
};

// A meshing with its vertices lifted and, under an error bound, the error they reach.
struct Candidate {
    Meshing meshing;
    std::vector<double> vertices;
    double achieved = 0.0;
    index_t edges = -1;  // the mesh's distinct edges when counted beside its lift, else -1
};

// Meshes of at least this many faces count their edges on the call's second thread while this
// one fits their depths (about 160 instructions a face: below, a thread's start would eat the gain).
constexpr index_t EDGES_BESIDE_MIN_FACES = 2000;

// The call's searches over meshings of one first mesh.
class Refiner {
  public:
    Refiner(const Image& image, Span<const double> camera, const Reference& ref, const MeshRequest& req,
            const DirectSolve& direct)
        : image_(image),
          camera_(camera),
          req_(req),
          ref_(ref),
          measure_(camera, ref),
          direct_(direct),
          strips_(req.strips && !needs_rounds(req)) {}

    // The search; when it leaves no face (every triangle keeps a background image corner), once
    // more from the valid pixels' hull (insertion.py's restart), unless walls were dropped.
    MeshResult run();

  private:
    MeshResult search();
    MeshResult by_count();
    MeshResult best_by_count();
    MeshResult by_error();
    MeshResult by_deviation();
    void rounds(Candidate& c);
    std::vector<double> depths(const ValidFaces& f, bool fit, bool& fitted);
    Meshing with_pixels(const Meshing& m, const std::vector<index_t>& pixels, index_t& inserted);
    Meshing mesh(index_t asked, double max_sum);
    bool lift(const ValidFaces& f, bool fit, std::vector<double>& vertices);
    bool bounded(Candidate& c);
    MeshResult finish(Candidate&& c);
    Meshing counted(index_t want);
    index_t dense_count(index_t want) const;
    Meshing best_of(index_t want);
    bool collapsed(Meshing& m, index_t target);
    MeshResult finish_bounded(Candidate&& c);
    Worker* worker(bool start);
    bool lift_counting_edges(Candidate& c);
    MeshResult no_face(const Meshing& m) {
        empty_ = true;
        empty_walls_ = m.n_walls;
        return MeshResult{};
    }

    const Image& image_;
    Span<const double> camera_;
    const MeshRequest& req_;
    Reference ref_;
    ErrorMeasure measure_;
    const DirectSolve& direct_;
    std::optional<StartArrays> first_;  // one strip's first mesh, made when first needed
    bool strips_;                       // the next meshing is on two strips
    MeshResult out_;
    index_t insertions_ = 0, flips_ = 0;  // of the last meshing
    bool empty_ = false;                  // the search declined: no face left
    index_t empty_walls_ = 0;             // ... and the walls its mesh dropped
    bool rounded_ = false;                // the rounds ran (`finish` runs them otherwise)
    std::optional<Worker> worker_;        // the call's second thread, once a part runs on two
    std::optional<LendWorker> lent_;      // ... which the fit's passes split onto (before it goes)
};

// How each target is met; the searches below are the rules' one place.
//   vertices=N:         `by_count` (CountSearch): meshings at N, then nearer N, until N vertices.
//   max_error=E:        `by_error`: the insertion's summed error stops it, the render decides.
//   max_deviation=D,
//   mean_deviation=D:   `by_deviation`: one insertion stopped by an estimate, then `rounds`.
//   max_edge=L:         `rounds` after any of them (`finish`).
MeshResult Refiner::search() {
    if (req_.max_deviation >= 0.0 || req_.mean_deviation >= 0.0) return by_deviation();
    return req_.max_error < 0.0 ? by_count() : by_error();
}

MeshResult Refiner::run() {
    MeshResult out = search();
    if (!empty_) return out;
    if (req_.walls || empty_walls_ == 0) {
        std::optional<StartArrays> hull = hull_mesh(image_, req_.vertices, req_.sr, req_.sc);
        if (hull) {
            first_ = std::move(hull);
            strips_ = false;
            out_ = MeshResult{};
            empty_ = false;
            rounded_ = false;
            out = search();
            if (!empty_) return out;
        }
    }
    // no triangle of valid pixels: done, with no face (Python names the reason)
    MeshResult none;
    none.outcome = MeshOutcome::done;
    none.meshings = out_.meshings;
    none.walls_dropped = empty_walls_;
    none.fitted = false;
    return none;
}

Meshing Refiner::mesh(index_t asked, double max_sum) {
    ++out_.meshings;
    out_.asked = asked;
    if (!strips_ && !first_) first_ = first_mesh(image_, req_.n_grid, req_.sr, req_.sc);
    Meshing m = strips_ ? mesh_halves(image_, camera_, asked, max_sum, req_, worker(true))
                        : mesh_once(image_, camera_, first_->view(), asked, max_sum, req_);
    insertions_ = m.insertions;
    flips_ = m.flips;
    return m;
}

// The call's second thread (with two threads asked for), started now when `start` and not yet
// running: the strips of each meshing, the edges beside a lift and the fit's two-part passes
// (`LendWorker`) then share one thread.
Worker* Refiner::worker(bool start) {
    if (req_.threads < 2) return nullptr;
    if (!worker_ && start) {
        worker_.emplace();
        lent_.emplace(&*worker_);
    }
    return worker_ ? &*worker_ : nullptr;
}

// `lift` of `c`'s mesh (its fit timed) while the second thread counts the mesh's edges, which
// `finish` reports, unless the assembly counted them: on a large mesh the count overlaps the
// fit's own set-up (one thread else).
bool Refiner::lift_counting_edges(Candidate& c) {
    const ValidFaces& f = c.meshing.mesh;
    const index_t n_f = static_cast<index_t>(f.faces.size() / 3);
    bool lifted = false;
    run_both(
        c.meshing.edges < 0 ? worker(n_f >= EDGES_BESIDE_MIN_FACES) : nullptr,
        [&] {  // (unless the assembly counted them)
            if (c.meshing.edges < 0)
                c.edges = count_edges(Grid<const std::int32_t>{f.faces.data(), n_f, 3}, c.meshing.n_vertices());
        },
        [&] {
            const auto t = std::chrono::steady_clock::now();
            lifted = lift(f, req_.fit, c.vertices);
            if (req_.fit) out_.fit_seconds = seconds_since(t);
        });
    return lifted;
}

// The vertices of `f` lifted from fitted or copied depths; false when the fit declines.
// A fit that meets a value that is not finite raises, unless under rounds (the call then goes
// again with copied heights, `refine_mesh`), as does one not converged under rounds.
bool Refiner::lift(const ValidFaces& f, bool fit, std::vector<double>& vertices) {
    const index_t n_v = static_cast<index_t>(f.pixels.size() / 2);
    std::vector<double> z(n_v);
    for (index_t i = 0; i < n_v; ++i) z[i] = image_.depth(f.pixels[2 * i], f.pixels[2 * i + 1]);
    const bool pinhole = camera_[0] == PINHOLE, rounds = needs_rounds(req_);
    if (fit) {
        const FitStatus status = fitted_depths(image_, pinhole, f, req_, z, rounds ? nullptr : &direct_);
        if (status.outcome == FitStatus::not_finite && !rounds) not_finite(image_, pinhole, f, status.vertex);
        if (!status) return false;
    }
    vertices = lifted(camera_, f, z);
    return true;
}

// insertion.py's `_bounded`: fitted depths first (they meet the bound far more often, so one
// render usually decides), copied ones kept only when they meet it and the fitted do not.
bool Refiner::bounded(Candidate& c) {
    const auto t = std::chrono::steady_clock::now();
    const ValidFaces& f = c.meshing.mesh;
    const bool lifted = lift(f, req_.fit, c.vertices);
    if (req_.fit) out_.fit_seconds += seconds_since(t);  // the fit only: the renders below are the search's
    if (!lifted) return false;
    c.achieved = measure_(f, c.vertices);
    if (req_.fit && c.achieved > req_.max_error) {
        std::vector<double> copied;
        lift(f, false, copied);
        const double copied_error = measure_(f, copied);
        if (copied_error <= req_.max_error) {
            c.vertices = std::move(copied);
            c.achieved = copied_error;
        }
    }
    return true;
}

MeshResult Refiner::finish(Candidate&& c) {
    if (needs_rounds(req_) && !rounded_) {  // max_edge after a count or an error bound
        rounds(c);
        c.edges = -1;  // (new faces)
        if (req_.max_error >= 0.0) c.achieved = measure_(c.meshing.mesh, c.vertices);
    }
    ValidFaces& mesh = c.meshing.mesh;
    const index_t n_f = static_cast<index_t>(mesh.faces.size() / 3);
    // the assembly's count unless rounds or a collapse changed the mesh since, else the one beside
    // the lift
    out_.edges = c.meshing.edges >= 0 && !needs_rounds(req_) && req_.collapse == 0.0 ? c.meshing.edges
                 : c.edges >= 0
                     ? c.edges
                     : count_edges(Grid<const std::int32_t>{mesh.faces.data(), n_f, 3}, c.meshing.n_vertices());
    out_.faces = std::move(mesh.faces);
    out_.pixels = std::move(mesh.pixels);
    out_.vertices = std::move(c.vertices);
    out_.achieved = c.achieved;
    out_.insertions = insertions_;
    out_.flips = flips_;
    out_.walls_dropped = c.meshing.n_walls;
    out_.strips = strips_ ? 2 : 1;
    out_.outcome = MeshOutcome::done;
    return std::move(out_);
}

// The meshing with `want` vertices, or the nearest the count search reaches.
Meshing Refiner::counted(index_t want) {
    CountSearch search(req_, want);
    const index_t start = out_.meshings;
    index_t asked = want;
    for (bool more = true; more;) {
        Meshing m = mesh(asked, -1.0);
        more = search.next(std::move(m), out_.meshings - start, asked);
    }
    return std::move(search.best());
}

// The vertices of `m` collapsed to `target` (collapse.hpp), measured in the values the heights
// are fitted in, from the dense mesh's own heights; false (m untouched) when they cannot be.
bool Refiner::collapsed(Meshing& m, index_t target) {
    if (m.mesh.faces.empty() || m.n_vertices() <= target) return false;
    const bool pinhole = camera_[0] == PINHOLE;
    std::optional<InverseLease> inverse;
    if (pinhole) inverse.emplace(image_.rows() * image_.cols());
    const FitValues v = fit_values(image_, req_, inverse ? &*inverse : nullptr);
    const ValidFaces& f = m.mesh;
    const index_t n_v = m.n_vertices();
    std::vector<double> depth(n_v), z(n_v);
    for (index_t i = 0; i < n_v; ++i) {
        depth[i] = image_.depth(f.pixels[2 * i], f.pixels[2 * i + 1]);
        z[i] = v.values(f.pixels[2 * i], f.pixels[2 * i + 1]);
    }
    if (req_.fit && fitted_depths(image_, pinhole, f, req_, depth))
        for (index_t i = 0; i < n_v; ++i) z[i] = pinhole ? 1.0 / depth[i] : depth[i];
    const Image values{v.values, image_.valid, v.hi - v.lo};
    ValidFaces out;
    CollapseCount count;
    if (!collapse_mesh(values, {f, z, target, req_.fit}, out, count)) return false;
    m.mesh = std::move(out);
    m.edges = -1;
    return true;
}

// The vertices effort="best" meshes to collapse down to `want`: `req_.collapse` times as many,
// at most every valid pixel.
index_t Refiner::dense_count(index_t want) const {
    const double dense = std::ceil(req_.collapse * static_cast<double>(want));
    return dense < static_cast<double>(req_.n_valid) ? static_cast<index_t>(dense) : req_.n_valid;
}

// effort="best": `want` vertices collapsed from `req_.collapse` times as many, or as
// effort="fast" makes them when the collapses cannot reach the count.
Meshing Refiner::best_of(index_t want) {
    const index_t asked = dense_count(want);
    if (asked > want) {
        Meshing m = counted(asked);
        if (collapsed(m, want)) return m;
    }
    return counted(want);
}

// effort="best" under an error bound: the count the search settled on, collapsed from a denser
// mesh; kept when it meets the bound or errs less than the search's own mesh.
MeshResult Refiner::finish_bounded(Candidate&& c) {
    const index_t want = c.meshing.n_vertices(), last_asked = out_.asked, asked = dense_count(want);
    if (req_.collapse <= 1.0 || asked <= want) return finish(std::move(c));
    Candidate b{counted(asked), {}, 0.0};
    out_.asked = last_asked;  // (the record's last request is the search's)
    if (collapsed(b.meshing, want) && bounded(b) && (b.achieved <= req_.max_error || b.achieved < c.achieved))
        return finish(std::move(b));
    return finish(std::move(c));
}

// effort="best" by count: the mesh collapsed from a denser one, or effort="fast"'s own when its
// render errs less (the collapses rank by the fitted values' planes; the render decides), so
// "best" never errs more than "fast" at the same request.
MeshResult Refiner::best_by_count() {
    const index_t want = req_.vertices, asked = dense_count(want);
    Candidate dense{};
    bool has_dense = false;
    index_t dense_ins = 0, dense_flips = 0;
    if (asked > want) {
        dense.meshing = counted(asked);
        has_dense = collapsed(dense.meshing, want) && lift(dense.meshing.mesh, req_.fit, dense.vertices);
        dense_ins = insertions_;
        dense_flips = flips_;
    }
    const index_t dense_asked = out_.asked;
    Candidate c{counted(want), {}, 0.0};
    if (c.meshing.mesh.faces.empty() && !has_dense) return no_face(c.meshing);
    const auto t = std::chrono::steady_clock::now();
    const bool fast_lifted = !c.meshing.mesh.faces.empty() && lift(c.meshing.mesh, req_.fit, c.vertices);
    if (req_.fit) out_.fit_seconds = seconds_since(t);
    if (!fast_lifted && !has_dense) return MeshResult{};
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double fast_error = fast_lifted ? measure_(c.meshing.mesh, c.vertices) : nan;
    const double dense_error = has_dense ? measure_(dense.meshing.mesh, dense.vertices) : nan;
    const bool keep_fast =
        fast_lifted && (!has_dense || fast_error < dense_error || (std::isnan(dense_error) && !std::isnan(fast_error)));
    if (!keep_fast) {
        insertions_ = dense_ins;  // (the record is the kept mesh's)
        flips_ = dense_flips;
        out_.asked = dense_asked;
        return finish(std::move(dense));
    }
    return finish(std::move(c));
}

MeshResult Refiner::by_count() {
    if (req_.collapse > 1.0 && !needs_rounds(req_)) return best_by_count();
    Candidate c{req_.collapse > 1.0 ? best_of(req_.vertices) : counted(req_.vertices), {}, 0.0};
    if (c.meshing.mesh.faces.empty()) return no_face(c.meshing);
    if (needs_rounds(req_)) return finish(std::move(c));  // (the rounds lift the vertices)
    if (!lift_counting_edges(c)) return MeshResult{};
    return finish(std::move(c));
}

// insertion.py's `_greedy` under an error bound: the insertion's own summed error stops it, the
// rendered error decides. A miss tightens the sum by a tenth while the insertion saw error
// left; else (every pixel fits its plane in the kernel's arithmetic while the render rounds
// otherwise) the count is bisected between the last miss and `vertices`.
MeshResult Refiner::by_error() {
    const index_t want = req_.vertices;
    double max_sum =
        req_.max_error_stop * req_.max_error / 100.0 * (req_.hi - req_.lo) * static_cast<double>(req_.n_valid);
    index_t asked = want, few = 0, most = 0;
    bool counted = false;
    Candidate met;  // searching by count: the smallest count that met the bound
    bool has_met = false;
    for (;;) {
        Candidate c{mesh(asked, max_sum), {}, 0.0};
        if (c.meshing.mesh.faces.empty()) return no_face(c.meshing);
        if (!bounded(c)) return MeshResult{};
        const index_t runs = out_.meshings, got = c.meshing.n_vertices();
        if (counted) {
            if (c.achieved <= req_.max_error) {
                most = asked;
                met = std::move(c);
                has_met = true;
            } else {
                few = asked;
            }
            // the last meshing asks for the largest count if no count met the bound yet
            const index_t nxt = runs == req_.max_runs - 1 && !has_met ? want : (few + most) / 2;
            if (runs < req_.max_runs && few < nxt && nxt <= most && nxt != asked && (!has_met || nxt < most)) {
                asked = nxt;
                continue;
            }
            return finish_bounded(has_met ? std::move(met) : std::move(c));
        }
        if (!(c.achieved > req_.max_error && asked > got && runs < req_.max_runs)) return finish_bounded(std::move(c));
        if (c.meshing.error_left) {
            max_sum *= 0.9;  // the running sum is an estimate: tighten and go on
            continue;
        }
        counted = true;
        strips_ = false;  // (strips never insert the seam column's other pixels)
        few = got;
        most = want;
        max_sum = -1.0;
        asked = runs == req_.max_runs - 1 ? want : (got + want) / 2;
    }
}

// A deviation bound: one insertion, stopped once its summed error (in depth units, the
// insertion's plane per triangle) is at most the mean bound, or `max_deviation_share` of the
// largest, times the valid pixels; then `rounds` until the render meets the bound.
MeshResult Refiner::by_deviation() {
    const bool largest = req_.max_deviation >= 0.0;
    const double bound = largest ? req_.max_deviation * req_.max_deviation_share : req_.mean_deviation;
    const double max_sum = bound / req_.deviation_scale * static_cast<double>(req_.n_valid);
    Candidate c{mesh(req_.vertices, std::isnan(max_sum) ? 0.0 : max_sum), {}, 0.0};
    if (c.meshing.mesh.faces.empty()) return no_face(c.meshing);
    rounds(c);
    c.achieved = largest ? out_.deviation_max : out_.deviation_mean;
    return finish(std::move(c));
}

// The vertices' stored depths: copied, or fitted (copied where the fit declines: `fitted` false),
// and under `max_deviation` each kept within the bound of its own pixel, so every vertex pixel
// meets it and the rounds only ever insert pixels that are no vertex.
std::vector<double> Refiner::depths(const ValidFaces& f, bool fit, bool& fitted) {
    const index_t n_v = static_cast<index_t>(f.pixels.size() / 2);
    std::vector<double> z(n_v);
    for (index_t i = 0; i < n_v; ++i) z[i] = image_.depth(f.pixels[2 * i], f.pixels[2 * i + 1]);
    fitted = false;
    if (!fit) return z;
    const auto t = std::chrono::steady_clock::now();
    std::vector<double> copied = z;
    fitted = static_cast<bool>(fitted_depths(image_, camera_[0] == PINHOLE, f, req_, z));
    if (!fitted) z = copied;
    if (fitted && req_.max_deviation >= 0.0) {
        // (a hair inside the bound: the prediction at a vertex rounds through the scale)
        const double reach = req_.max_deviation / req_.deviation_scale * (1.0 - 1e-9);
        for (index_t i = 0; i < n_v; ++i) z[i] = std::min(std::max(z[i], copied[i] - reach), copied[i] + reach);
    }
    out_.fit_seconds += seconds_since(t);
    return z;
}

// `m` with `pixels` (r * W + c, valid, none a vertex) inserted into its insertion, meshed
// again; `inserted` counts those that went in.
Meshing Refiner::with_pixels(const Meshing& m, const std::vector<index_t>& pixels, index_t& inserted) {
    const std::shared_ptr<Insertion> ins = m.ins;
    require(ins != nullptr, "rounds: the meshing keeps no insertion");
    const index_t w = image_.cols();
    inserted = 0;
    for (const index_t p : pixels) {
        poll_every(inserted);
        inserted += ins->insert_at(p / w, p % w);
    }
    Meshing out = meshing_of(image_, camera_, *ins, req_, true);
    out.ins = ins;
    insertions_ = out.insertions;
    flips_ = out.flips;
    return out;
}

// Rounds of insertion until the bounds are met: the mesh's depths (fitted, or copied), its
// render's deviation, and the worst pixel of each face still beyond a bound inserted into the
// insertion (its diagonals chosen and the mesh assembled again), again. Under `max_deviation`
// the copied depths meet the bound first (a fit costs about a meshing), then the fitted ones
// (kept within it at their own pixels). When fitted depths miss a bound with no pixel left to
// insert (the mean's deviation on the vertices' own pixels), copied ones go on. Ends when no
// pixel is left to insert (or none of those picked goes in); every other round inserts one.
void Refiner::rounds(Candidate& c) {
    rounded_ = true;
    const RoundBounds bounds{req_.max_deviation, req_.mean_deviation, req_.max_edge};
    const DeviationRule rule{req_.deviation_scale, req_.deviation_inverse};
    bool fit = req_.fit && req_.max_deviation < 0.0;
    bool copied_only = false;  // fitted depths missed a bound with no pixel left to insert
    const bool capped = req_.max_deviation >= 0.0 || req_.mean_deviation >= 0.0;
    DeviationBuffers deviation_buffers;  // (each round renders the whole image again)
    for (;;) {
        poll_interrupt();
        bool fitted = false;
        std::vector<double> z = depths(c.meshing.mesh, fit, fitted);
        const Deviation d = measure_deviation(image_, ref_, rule, c.meshing.mesh, z, &deviation_buffers);
        std::vector<index_t> adds = round_additions(image_, c.meshing.mesh, d, bounds);
        if (capped && c.meshing.ins) {  // a deviation target stops at the vertex cap
            const index_t room = std::max<index_t>(req_.vertices - c.meshing.ins->valid_vertices(), 0);
            if (static_cast<index_t>(adds.size()) > room) adds.resize(room);
        }
        index_t inserted = 0;
        Meshing next;
        if (!adds.empty()) next = with_pixels(c.meshing, adds, inserted);
        if (inserted == 0) {
            if (req_.fit && !fit && !copied_only) {  // copied depths meet max_deviation: now the fitted ones
                fit = true;
                continue;
            }
            if (fit && !deviation_met(d, bounds)) {  // the vertices' own pixels miss it: copied depths
                fit = false;
                copied_only = true;
                continue;
            }
            c.vertices = lifted(camera_, c.meshing.mesh, z);
            out_.deviation_max = d.max;
            out_.deviation_mean = d.mean();
            out_.uncovered = d.uncovered;
            out_.longest_edge = d.longest_edge;
            out_.fitted = fitted;
            return;
        }
        c.meshing = std::move(next);
        require(!c.meshing.mesh.faces.empty(), "rounds: inserting pixels left no face");
        ++out_.rounds;
    }
}

}  // namespace

MeshResult refine_mesh(const Image& image, Span<const double> camera, const Reference& reference,
                       const MeshRequest& req, const DirectSolve& direct) {
    const auto t0 = std::chrono::steady_clock::now();
    MeshResult out = Refiner(image, camera, reference, req, direct).run();
    if (out.outcome == MeshOutcome::declined && req.fit && needs_rounds(req)) {
        MeshRequest copied = req;  // (the rounds' search with copied heights, from the start)
        copied.fit = false;
        out = Refiner(image, camera, reference, copied, direct).run();
    }
    out.seconds = seconds_since(t0);
    return out;
}

}  // namespace rangemesh::refine
