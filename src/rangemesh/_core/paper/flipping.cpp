#include "flipping.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "../geometry/halfedges.hpp"
#include "../geometry/heap.hpp"
#include "../geometry/predicates.hpp"
#include "../geometry/vectors.hpp"
#include "../interrupt.hpp"

namespace rangemesh::paper {

namespace {

constexpr double PI = 3.141592653589793;  // Python's math.pi
constexpr double NEG_INF = -std::numeric_limits<double>::infinity();
// Angles closer than this (radians) are equal: flat spans give angles of 0 up to rounding
// noise, and noise must not decide a test (SPEC P2, P6).
constexpr double ANGLE_TOL = 1e-9;

template <class T>
Span<const T> read_only(Span<T> s) {
    return {s.data, s.size};
}

// NS_V: the sum of the unit normals of the triangles around V = triangles[start] but t0 and t1.
// `start` is a half-edge leaving V; the walk turns one way until it closes the fan or meets the
// border, and from a border walks the other way too.
Vec3 span_normal(Span<const index_t> halfedges, Grid<const double> normals, index_t start, index_t t0, index_t t1) {
    Vec3 s;
    auto add = [&](index_t t) {
        if (t == t0 || t == t1) return;
        s.x += normals(t, 0);
        s.y += normals(t, 1);
        s.z += normals(t, 2);
    };
    index_t cur = start;
    bool open_fan = false;
    for (;;) {
        add(cur / 3);
        const index_t twin = halfedges[prv(cur)];
        if (twin == -1) {
            open_fan = true;
            break;
        }
        cur = twin;
        if (cur == start) break;
    }
    if (open_fan) {
        cur = start;
        for (;;) {
            const index_t twin = halfedges[cur];
            if (twin == -1) break;
            cur = nxt(twin);
            add(cur / 3);
        }
    }
    return s;
}

// SPEC 3.4: angle(NS_V, N_T) when NS_V is not zero and the angle is below delta, else pi.
double disparity(const Vec3& span, const Vec3& normal, double delta) {
    if (is_zero(span)) return PI;
    const double a = angle(span, normal);
    return a < delta ? a : PI;
}

// Vertex pairs that were neighbours once (T1): an open-addressing set with linear probing.
class PairSet {
  public:
    explicit PairSet(index_t n_vertices) : n_vertices_(n_vertices) {}
    ~PairSet() { free_later(keys_); }
    PairSet(const PairSet&) = delete;
    PairSet& operator=(const PairSet&) = delete;

    bool contains(index_t a, index_t b) const {
        const index_t key = pair_key(a, b);
        return keys_[slot(keys_, key)] == key;
    }

    void add(index_t a, index_t b) {
        if (2 * (count_ + 1) > static_cast<index_t>(keys_.size())) grow();
        const index_t key = pair_key(a, b);
        index_t& at = keys_[slot(keys_, key)];
        if (at != key) ++count_;
        at = key;
    }

  private:
    index_t pair_key(index_t a, index_t b) const {
        if (a > b) std::swap(a, b);
        return a * n_vertices_ + b;
    }

    // The slot of `key` in `keys`, or the empty slot where it would go.
    static std::size_t slot(const std::vector<index_t>& keys, index_t key) {
        const std::size_t mask = keys.size() - 1;
        std::size_t i = static_cast<std::size_t>(key ^ (key >> 17) ^ (key >> 31)) & mask;
        while (keys[i] != -1 && keys[i] != key) i = (i + 1) & mask;
        return i;
    }

    void grow() {
        std::vector<index_t> bigger(2 * keys_.size(), -1);
        for (const index_t k : keys_)
            if (k != -1) bigger[slot(bigger, k)] = k;
        keys_ = std::move(bigger);
    }

    index_t n_vertices_;
    index_t count_ = 0;
    std::vector<index_t> keys_ = std::vector<index_t>(1024, -1);
};

// The stage's state: one id per undirected edge, the triangles' normals, the edges' errors and
// gains, and the heap of gains.
class FlipStage {
  public:
    FlipStage(const FlipMesh& mesh, const RangeImage& image, const FlipSettings& settings);
    ~FlipStage() { free_later(he_edge_, edge_he_, normals_, err_, gain_, keys_, heap_, slot_); }
    FlipStage(const FlipStage&) = delete;
    FlipStage& operator=(const FlipStage&) = delete;

    // Pop, decide, flip or drop, until no head edge is worth a decision.
    index_t run(const FlipRecord& record);

  private:
    Verdict decide(index_t x) const;
    void flip(index_t x);
    double gain_of(index_t x) const;
    double edge_error_of(index_t va, index_t vb) const { return edge_error(va, vb, mesh_.points, image_); }
    Grid<const double> normals() const { return {normals_.data(), n_triangles(), 3}; }
    index_t n_triangles() const { return mesh_.triangles.size / 3; }
    index_t n_edges() const { return static_cast<index_t>(edge_he_.size()); }
    HeapView heap() { return {{keys_.data(), n_edges()}, {heap_.data(), n_edges()}, {slot_.data(), n_edges()}}; }
    void set_normal(index_t t, const Vec3& n) {
        normals_[3 * t] = n.x;
        normals_[3 * t + 1] = n.y;
        normals_[3 * t + 2] = n.z;
    }

    FlipMesh mesh_;
    RangeImage image_;
    FlipSettings settings_;
    std::vector<index_t> he_edge_;  // the edge id of each half-edge
    std::vector<index_t> edge_he_;  // one half-edge of each edge
    std::vector<double> normals_;   // F x 3 unit normals
    std::vector<double> err_;       // E(A, B) of each edge
    std::vector<double> gain_;      // G of each edge, -inf when it cannot or may not flip
    std::vector<double> keys_;      // the heap: keys and ids by position, positions by id
    std::vector<index_t> heap_, slot_;
    PairSet former_;                // pairs that were edges before a flip (T1)
};

FlipStage::FlipStage(const FlipMesh& mesh, const RangeImage& image, const FlipSettings& settings)
    : mesh_(mesh), image_(image), settings_(settings), former_(mesh.points.vertices.rows) {
    // stopped half way, no destructor runs: the arrays made so far are freed later all the same
    const FreeLater late(on_throw, he_edge_, edge_he_, normals_, err_, gain_, keys_, heap_, slot_);
    const Span<const index_t> halfedges = read_only(mesh_.halfedges);
    const index_t n_he = mesh_.triangles.size;
    fill_polled(he_edge_, n_he, index_t{-1});
    edge_he_.reserve(n_he);  // untouched beyond the edges: border edges count once
    for (index_t e = 0; e < n_he; ++e) {
        poll_every(e);
        const index_t twin = halfedges[e];
        if (twin == -1 || e < twin) {
            const index_t x = static_cast<index_t>(edge_he_.size());
            he_edge_[e] = x;
            if (twin != -1) he_edge_[twin] = x;
            edge_he_.push_back(e);
        }
    }
    fill_polled(normals_, 3 * n_triangles(), 0.0);
    const Span<index_t> tri = mesh_.triangles;
    for (index_t t = 0; t < n_triangles(); ++t) {
        poll_every(t);
        set_normal(t, unit_normal(mesh_.points.vertices, tri[3 * t], tri[3 * t + 1], tri[3 * t + 2]));
    }
    const index_t n_e = n_edges();
    fill_polled(err_, n_e, 0.0);
    for (index_t x = 0; x < n_e; ++x) {
        if (x % 1024 == 0) poll_interrupt();
        const index_t e = edge_he_[x];
        err_[x] = edge_error_of(tri[e], tri[nxt(e)]);
    }
    fill_polled(gain_, n_e, 0.0);
    for (index_t x = 0; x < n_e; ++x) {
        if (x % 1024 == 0) poll_interrupt();
        gain_[x] = gain_of(x);
    }
    keys_ = copy_polled(Span<const double>{gain_.data(), n_e});
    heap_.reserve(n_e);
    slot_.reserve(n_e);
    for (index_t i = 0; i < n_e; ++i) {
        poll_every(i);
        heap_.push_back(i);
        slot_.push_back(i);
    }
    const HeapView h = heap();
    for (index_t i = 0; i < n_e; ++i) {
        poll_every(i);
        h.sift_up(i);
    }
}

// G = E(A, B) - E(C, D) of an inner edge whose quad is strictly convex, else -inf; rounded to a
// multiple of the quantum, so that gains equal up to rounding noise are equal (SPEC P2).
double FlipStage::gain_of(index_t x) const {
    const index_t e0 = edge_he_[x];
    const index_t e1 = mesh_.halfedges[e0];
    if (e1 == -1) return NEG_INF;
    const Span<index_t> tri = mesh_.triangles;
    const index_t a = tri[e0], b = tri[nxt(e0)], c = tri[prv(e0)], d = tri[prv(e1)];
    const Grid<const index_t> px = mesh_.points.pixels;
    // strictly convex quad A-D-B-C <=> both new triangles DBC and CAD are counter-clockwise
    if (orient<index_t>(px(d, 0), px(d, 1), px(b, 0), px(b, 1), px(c, 0), px(c, 1)) <= 0) return NEG_INF;
    if (orient<index_t>(px(c, 0), px(c, 1), px(a, 0), px(a, 1), px(d, 0), px(d, 1)) <= 0) return NEG_INF;
    const double g = err_[x] - edge_error_of(c, d);
    return std::nearbyint(g / settings_.quantum) * settings_.quantum;  // half to even, as np.round
}

// The verdict on edge x: the edge-length bound, T1 (deadlock), then the flip rule.
Verdict FlipStage::decide(index_t x) const {
    const index_t e0 = edge_he_[x];
    const index_t e1 = mesh_.halfedges[e0];
    const index_t vc = mesh_.triangles[prv(e0)], vd = mesh_.triangles[prv(e1)];
    const Grid<const index_t> px = mesh_.points.pixels;
    const index_t dr = px(vc, 0) - px(vd, 0), dc = px(vc, 1) - px(vd, 1);
    if (static_cast<double>(dr * dr + dc * dc) > settings_.max_edge2) return MAX_EDGE;
    if (former_.contains(vc, vd)) return T1_DEADLOCK;
    if (settings_.rule == RULE_ERROR) return FLIPPED;
    return disparity_verdict(read_only(mesh_.triangles), read_only(mesh_.halfedges), normals(), mesh_.points.vertices,
                             e0, settings_.tests);
}

// Flip edge x (AB -> CD): move the outer edges' ids with their half-edges, then renew the two
// normals, CD's error and the gains of CD and the quad's four outer edges.
void FlipStage::flip(index_t x) {
    const index_t e0 = edge_he_[x];
    const Quad q(read_only(mesh_.halfedges), e0);
    const Span<index_t> tri = mesh_.triangles;
    const index_t va = tri[e0], vb = tri[q.b0], vc = tri[q.c0], vd = tri[q.c1];
    const index_t eb0 = he_edge_[q.b0], ec0 = he_edge_[q.c0];  // BC, CA
    const index_t eb1 = he_edge_[q.b1], ec1 = he_edge_[q.c1];  // AD, DB
    flip_quad(mesh_.triangles, mesh_.halfedges, e0);
    // the outer half-edges moved: CA -> b0, AD -> c0, DB -> b1, BC -> c1
    he_edge_[q.b0] = ec0;
    he_edge_[q.c0] = eb1;
    he_edge_[q.b1] = ec1;
    he_edge_[q.c1] = eb0;
    edge_he_[ec0] = q.b0;
    edge_he_[eb1] = q.c0;
    edge_he_[ec1] = q.b1;
    edge_he_[eb0] = q.c1;
    edge_he_[x] = e0;
    set_normal(e0 / 3, unit_normal(mesh_.points.vertices, vd, vc, va));
    set_normal(q.e1 / 3, unit_normal(mesh_.points.vertices, vc, vd, vb));
    err_[x] = edge_error_of(vc, vd);
    const HeapView h = heap();
    for (const index_t y : {x, eb0, ec0, eb1, ec1}) {
        gain_[y] = gain_of(y);
        h.rekey(y, gain_[y], n_edges());
    }
}

index_t FlipStage::run(const FlipRecord& record) {
    const index_t n_e = n_edges();
    const HeapView h = heap();
    index_t flips = 0;
    index_t logged = 0;
    while (n_e > 0) {
        poll_interrupt();
        const index_t x = heap_[0];
        const double g = gain_[x];
        if (g == NEG_INF || g < settings_.threshold || (settings_.rule == RULE_ERROR && g <= 0.0)) break;
        const Verdict verdict = decide(x);
        const index_t e0 = edge_he_[x];
        const index_t a = mesh_.triangles[e0], b = mesh_.triangles[nxt(e0)];
        if (logged < record.log.rows) {
            record.log(logged, 0) = std::min(a, b);
            record.log(logged, 1) = std::max(a, b);
            record.log(logged, 2) = verdict;
            ++logged;
        }
        record.verdicts[verdict] += 1;
        if (verdict != FLIPPED) {
            gain_[x] = NEG_INF;
            h.rekey(x, NEG_INF, n_e);
            continue;
        }
        former_.add(a, b);
        flip(x);
        ++flips;
    }
    return flips;
}

}  // namespace

Verdict disparity_verdict(Span<const index_t> triangles, Span<const index_t> halfedges, Grid<const double> normals,
                          Grid<const double> vertices, index_t e0, const DisparityTests& tests) {
    require(0 <= e0 && e0 < halfedges.size && halfedges[e0] != -1, "disparity_verdict: e0 must be an inner half-edge");
    require(normals.rows * 3 == triangles.size && normals.cols == 3, "disparity_verdict: one normal a triangle");
    // Spans and normals are computed as late as the tests allow: a value a test does not need is
    // never computed (the verdict is the same as computing all).
    const Quad q(halfedges, e0);
    const index_t t0 = e0 / 3, t1 = q.e1 / 3;
    const index_t va = triangles[e0], vb = triangles[q.b0], vc = triangles[q.c0], vd = triangles[q.c1];
    const Vec3 ns_c = span_normal(halfedges, normals, q.c0, t0, t1);  // C -> A leaves C
    const Vec3 ns_d = span_normal(halfedges, normals, q.c1, t0, t1);  // D -> B leaves D
    const Vec3 n_dca = unit_normal(vertices, vd, vc, va);
    const Vec3 n_cdb = unit_normal(vertices, vc, vd, vb);
    const double disp_ab =
        py_max(disparity(ns_c, row3(normals, t0), tests.delta), disparity(ns_d, row3(normals, t1), tests.delta));
    const Vec3 ns_a = span_normal(halfedges, normals, q.b1, t0, t1);  // A -> D leaves A
    double disp_cd = disparity(ns_a, n_dca, tests.delta);
    Vec3 ns_b;
    bool have_b = false;
    if (disp_cd < PI) {  // else the max is pi whatever NS_B is
        ns_b = span_normal(halfedges, normals, q.b0, t0, t1);  // B -> C leaves B
        have_b = true;
        disp_cd = py_max(disp_cd, disparity(ns_b, n_cdb, tests.delta));
    }
    const double bend = angle(n_dca, n_cdb);
    if (std::fabs(disp_ab - disp_cd) < tests.epsilon) return T2_DISPARITY_CHANGE;
    if (bend < tests.delta && (max_internal_angle(vertices, vd, vc, va) > tests.max_angle ||
                               max_internal_angle(vertices, vc, vd, vb) > tests.max_angle))
        return T3_DEGENERATE;  // a degenerate triangle on a smooth region
    if (!(bend > tests.min_bend)) return T4_BEND;  // no noticeable change of shape
    if (!have_b) ns_b = span_normal(halfedges, normals, q.b0, t0, t1);
    if (angle(ns_c, ns_d) > 2.0 * angle(ns_a, ns_b) + ANGLE_TOL) return T5_CREASE;  // a crease along AB would be lost
    return disp_ab > disp_cd ? FLIPPED : FINAL_TEST;
}

index_t flip_loop(const FlipMesh& mesh, const RangeImage& image, const FlipSettings& settings,
                  const FlipRecord& record) {
    require(mesh.halfedges.size == mesh.triangles.size && mesh.triangles.size % 3 == 0,
            "flip_loop: triangles and halfedges must be 3F long each");
    require(image.consistent() && mesh.points.fit(image), "flip_loop: the vertices' pixels must lie in the image");
    for (index_t e = 0; e < mesh.triangles.size; ++e) {
        poll_every(e);
        check_input(0 <= mesh.triangles[e] && mesh.triangles[e] < mesh.points.size(),
                    "flip_loop: a vertex id out of range");
    }
    // the flips write through the twins and the fans' walks follow them
    for (index_t e = 0; e < mesh.triangles.size; ++e) {
        poll_every(e);
        check_input(twin_ok(read_only(mesh.triangles), read_only(mesh.halfedges), e),
                    "flip_loop: half-edge twins must pair up (he[he[e]] == e, in [-1, len), back along one edge)");
    }
    require(record.verdicts.size == N_VERDICTS, "flip_loop: one counter per verdict");
    // counted on: each decision adds 1, and no call makes 2^62 of them
    for (const index_t count : record.verdicts)
        check_input(0 <= count && count <= index_t{1} << 62, "flip_loop: the verdicts' counts from 0 to 2^62");
    require(record.log.cols == 3, "flip_loop: the log has three columns");
    FlipStage stage(mesh, image, settings);
    return stage.run(record);
}

}  // namespace rangemesh::paper
