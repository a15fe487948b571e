#include "collapse.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "../geometry/halfedges.hpp"
#include "../geometry/heap.hpp"
#include "../geometry/ownership.hpp"
#include "../geometry/predicates.hpp"
#include "../geometry/raster.hpp"
#include "../interrupt.hpp"
#include "diagonals.hpp"
#include "keys.hpp"
#include "plane.hpp"

namespace rangemesh::refine {

namespace {

// The heap key of a vertex that cannot collapse: below every cost.
constexpr double NEVER = -std::numeric_limits<double>::infinity();
// Passes of data-dependent flips at most (the study's limit; most meshes settle in two).
constexpr int MAX_FLIP_PASSES = 5;
// A refit needs this much summed squared weight (as the study's prototype): else u keeps its value.
constexpr double MIN_WEIGHT = 1e-9;

// The mesh being collapsed: its half-edges, each vertex's pixel, value and one half-edge leaving
// it, each live triangle's error sum over the pixels it owns.
struct Work {
    const Image& image;
    std::vector<index_t> vr, vc, out;
    std::vector<double> z, err;
    std::vector<index_t> tri, he;
    std::vector<char> tri_alive, alive;
    std::vector<index_t> mark;  // a stamp a vertex: the link being tested
    index_t stamp = 0, n_alive = 0;
};

// The half-edges leaving a vertex, counter-clockwise; `open` when its fan meets the border.
struct Fan {
    std::vector<index_t> edges;
    bool open = false;
};

// The corners (u, a, b) of one new triangle and whether it owns the pixels on each edge.
struct NewFace {
    Point u, a, b;
    EdgeOwnership own;
};

Point point(const Work& w, index_t v) { return {w.vr[v], w.vc[v], w.z[v]}; }

// Whether the triangle of half-edge e owns the pixels on e: a border edge's are its own.
bool owned(const Work& w, index_t e) {
    if (w.he[e] == -1) return true;
    const index_t a = w.tri[e], b = w.tri[nxt(e)];
    return owns(w.vr[a], w.vc[a], w.vr[b], w.vc[b]);
}

bool owned_inside(const Work& w, index_t a, index_t b) { return owns(w.vr[a], w.vc[a], w.vr[b], w.vc[b]); }

double face_error(const Work& w, index_t t) {
    const index_t e = 3 * t;
    return triangle_error(w.image, point(w, w.tri[e]), point(w, w.tri[e + 1]), point(w, w.tri[e + 2]),
                          {owned(w, e), owned(w, e + 1), owned(w, e + 2)});
}

index_t orientation(const Work& w, index_t a, index_t b, index_t c) {
    return orient(w.vr[a], w.vc[a], w.vr[b], w.vc[b], w.vr[c], w.vc[c]);
}

// v's fan into `f`: rewound clockwise to the border first when there is one.
void fan_of(const Work& w, index_t v, Fan& f) {
    f.edges.clear();
    f.open = false;
    const index_t limit = static_cast<index_t>(w.tri.size());
    index_t e = w.out[v];
    for (index_t n = 0;; ++n) {
        require(n < limit, "collapse: a vertex's fan does not close");
        const index_t t = w.he[e];
        if (t == -1) {
            f.open = true;
            break;
        }
        e = nxt(t);
        if (e == w.out[v]) break;
    }
    const index_t first = e;
    for (index_t n = 0;; ++n) {
        require(n < limit, "collapse: a vertex's fan does not close");
        f.edges.push_back(e);
        const index_t t = w.he[prv(e)];
        if (t == -1 || t == first) break;
        e = t;
    }
}

// v's neighbours: the ends of its fan's half-edges, and the last corner of an open fan.
template <class Visit>
void each_neighbour(const Work& w, const Fan& f, Visit&& visit) {
    for (index_t e : f.edges) visit(w.tri[nxt(e)]);
    if (f.open) visit(w.tri[prv(f.edges.back())]);
}

// Whether fan triangle i of v has u for a corner: it goes when v collapses onto u.
bool has(const Work& w, const Fan& f, index_t i, index_t u) {
    const index_t e = f.edges[i];
    return w.tri[nxt(e)] == u || w.tri[prv(e)] == u;
}

// Fan triangle i of v with u for v, once v collapses onto u. Its edges on the star's outline
// keep their twins and so their ownership (a border's, too: an open fan's v lies straight
// between its ends); its edges from u inside the star are shared by two new triangles.
NewFace new_face(const Work& w, const Fan& f, index_t u, index_t i) {
    const index_t k = static_cast<index_t>(f.edges.size()), e = f.edges[i];
    const index_t a = w.tri[nxt(e)], b = w.tri[prv(e)];
    const index_t before = (i + k - 1) % k, after = (i + 1) % k;
    bool own_ua = owned_inside(w, u, a), own_bu = owned_inside(w, b, u);
    if (f.open && i == 0)
        own_ua = true;
    else if (has(w, f, before, u))
        own_ua = owned(w, nxt(f.edges[before]));
    if (f.open && i == k - 1)
        own_bu = true;
    else if (has(w, f, after, u))
        own_bu = owned(w, nxt(f.edges[after]));
    return {point(w, u), point(w, a), point(w, b), {own_ua, owned(w, nxt(e)), own_bu}};
}

// The neighbours v may collapse onto, into `out`: any of a closed fan's; an open fan's two ends
// when v lies straight between them on the border (the border keeps its line, the region its
// pixels).
void targets(const Work& w, index_t v, const Fan& f, std::vector<index_t>& out) {
    out.clear();
    const index_t k = static_cast<index_t>(f.edges.size());
    if (!f.open) {
        if (k >= 3) each_neighbour(w, f, [&](index_t x) { out.push_back(x); });
        return;
    }
    const index_t first = w.tri[nxt(f.edges[0])], last = w.tri[prv(f.edges[k - 1])];
    const index_t dot =
        (w.vr[first] - w.vr[v]) * (w.vr[last] - w.vr[v]) + (w.vc[first] - w.vc[v]) * (w.vc[last] - w.vc[v]);
    if (k >= 2 && orientation(w, last, v, first) == 0 && dot < 0) out = {first, last};
}

// Whether v (fan `f`, its neighbours marked with `w.stamp`) may collapse onto u: every new
// triangle positive, and u's neighbours among v's only those of the triangles that go (the
// link condition).
bool can_collapse(const Work& w, const Fan& f, index_t u, Fan& scratch) {
    const index_t k = static_cast<index_t>(f.edges.size());
    index_t kept = 0;
    for (index_t i = 0; i < k; ++i) {
        if (has(w, f, i, u)) continue;
        ++kept;
        const index_t e = f.edges[i];
        if (orientation(w, u, w.tri[nxt(e)], w.tri[prv(e)]) <= 0) return false;
    }
    if (kept == 0) return false;
    fan_of(w, u, scratch);
    index_t common = 0;
    each_neighbour(w, scratch, [&](index_t x) { common += w.mark[x] == w.stamp; });
    return common == (f.open ? 1 : 2);
}

// The summed error of v's star collapsed onto u, infinite once it reaches `stop` (key units).
double collapsed_error(const Work& w, const Fan& f, index_t u, double stop) {
    const index_t k = static_cast<index_t>(f.edges.size());
    double total = 0.0;
    for (index_t i = 0; i < k; ++i) {
        if (has(w, f, i, u)) continue;
        const NewFace t = new_face(w, f, u, i);
        total += triangle_error(w.image, t.u, t.a, t.b, t.own, total, stop);
        // at or above the best so far: no better (a tie keeps the earlier candidate)
        if (quantize(total, w.image.span) >= stop) return std::numeric_limits<double>::infinity();
    }
    return total;
}

// The cheapest collapse of a vertex: minus the increase of the summed error, and onto whom.
struct Choice {
    double key = NEVER;  // (the heap pops the largest)
    index_t onto = -1;
};

// Scratch fans and lists of a ranking.
struct Scratch {
    Fan fan, other;
    std::vector<index_t> onto;
};

// `hint`: the neighbour chosen last time, tried first (its sum bounds the others' scans sooner).
Choice best_collapse(Work& w, index_t v, Scratch& s, CollapseCount& count, index_t hint = -1) {
    Choice best;
    if (!w.alive[v] || w.out[v] < 0) return best;
    fan_of(w, v, s.fan);
    targets(w, v, s.fan, s.onto);
    if (s.onto.empty()) return best;
    const auto first = std::find(s.onto.begin(), s.onto.end(), hint);
    if (first != s.onto.end()) std::rotate(s.onto.begin(), first, first + 1);
    ++w.stamp;
    double before = 0.0;
    for (index_t e : s.fan.edges) before += w.err[e / 3];
    each_neighbour(w, s.fan, [&](index_t x) { w.mark[x] = w.stamp; });
    // compared and ranked in key units (`quantize`), as the insertion's keys: the same choices
    // in any depth unit (SPEC P2)
    const double span = w.image.span, q_before = quantize(before, span);
    double least = std::numeric_limits<double>::infinity();
    for (index_t u : s.onto) {
        if (!can_collapse(w, s.fan, u, s.other)) continue;
        ++count.evaluations;
        const double after = collapsed_error(w, s.fan, u, least);
        const double q_after = std::isfinite(after) ? quantize(after, span) : after;
        if (q_after < least) {
            least = q_after;
            best = {q_before - q_after, u};
        }
    }
    return best;
}

// The least-squares value of u over its fan's pixels, the other corners fixed; u's own when
// no pixel weighs on it.
double refit_value(const Work& w, index_t u, const Fan& f) {
    double swr = 0.0, sww = 0.0;
    for (index_t e : f.edges) {
        const Point a = point(w, u), b = point(w, w.tri[nxt(e)]), c = point(w, w.tri[prv(e)]);
        const double inv = 1.0 / static_cast<double>(orient(a.r, a.c, b.r, b.c, c.r, c.c));
        const double f0 = static_cast<double>(b.r - a.r), f1 = static_cast<double>(c.r - b.r),
                     f2 = static_cast<double>(a.r - c.r);
        TriangleRows rows(a.r, a.c, b.r, b.c, c.r, c.c);
        for (index_t r = rows.r0; r <= rows.r1; ++r) {
            if (r > rows.r0) rows.next_row();
            const RowSpan s = rows.columns(owned(w, e), owned(w, nxt(e)), owned(w, prv(e)));
            const double* drow = w.image.depth.row(r);
            const bool* vrow = w.image.valid.row(r);
            double w0 = static_cast<double>(s.w0), w1 = static_cast<double>(s.w1), w2 = static_cast<double>(s.w2);
            for (index_t col = s.first; col <= s.last; ++col) {
                if (vrow[col]) {
                    const double weight = w1 * inv, rest = drow[col] - (w2 * b.z + w0 * c.z) * inv;
                    swr += weight * rest;
                    sww += weight * weight;
                }
                w0 += f0;
                w1 += f1;
                w2 += f2;
            }
        }
    }
    return sww > MIN_WEIGHT ? swr / sww : w.z[u];
}

// Kill triangle t (its half-edges' twins are relinked by the caller).
void kill(Work& w, index_t t) {
    w.tri_alive[t] = 0;
    for (index_t e = 3 * t; e < 3 * t + 3; ++e) w.he[e] = -1;
}

void relink(Work& w, index_t a, index_t b) { link({w.he.data(), static_cast<index_t>(w.he.size())}, a, b); }

// Collapse an inner v onto u = the end of its fan half-edge j: v's two triangles on the edge go,
// its others take u for v, and the twins across the dead triangles are joined.
void collapse_inner(Work& w, const Fan& f, index_t j) {
    const index_t k = static_cast<index_t>(f.edges.size());
    const index_t ej = f.edges[j], before = f.edges[(j + k - 1) % k];  // v -> u, v -> a in (v, a, u)
    const index_t u = w.tri[nxt(ej)], a = w.tri[nxt(before)], b = w.tri[prv(ej)];
    const index_t x1 = w.he[nxt(ej)], y1 = w.he[prv(ej)];     // across u -> b; v -> b beyond
    const index_t x0 = w.he[nxt(before)], y0 = w.he[before];  // across a -> u; a -> v beyond
    for (index_t i = 0; i < k; ++i)
        if (i != j && (i + 1) % k != j) w.tri[f.edges[i]] = u;
    kill(w, ej / 3);
    kill(w, before / 3);
    relink(w, y1, x1);
    relink(w, y0, x0);
    w.out[u] = y1;
    w.out[a] = y0;
    w.out[b] = nxt(y1);
}

// Collapse a border v onto an end u of its open fan: the end triangle on u goes, the others
// take u for v; the border runs straight from the other end to u.
void collapse_border(Work& w, const Fan& f, index_t u) {
    const index_t m = static_cast<index_t>(f.edges.size());
    const bool first = w.tri[nxt(f.edges[0])] == u;
    const index_t dead = first ? f.edges[0] : f.edges[m - 1];
    const index_t across = w.he[nxt(dead)], beyond = first ? w.he[prv(dead)] : w.he[dead];
    for (index_t i = first ? 1 : 0; i < (first ? m : m - 1); ++i) w.tri[f.edges[i]] = u;
    kill(w, dead / 3);
    relink(w, beyond, across);
    if (first) {
        w.out[u] = beyond;               // u -> the next corner
        w.out[w.tri[nxt(beyond)]] = nxt(beyond);
    } else {
        w.out[u] = f.edges[0];           // u -> the first corner, along the border
        w.out[w.tri[beyond]] = beyond;   // the corner before u -> u
    }
}

// Collapse v (fan `f`) onto its neighbour u.
void collapse(Work& w, index_t v, const Fan& f, index_t u) {
    if (f.open) {
        collapse_border(w, f, u);
    } else {
        index_t j = 0;
        while (j < static_cast<index_t>(f.edges.size()) && w.tri[nxt(f.edges[j])] != u) ++j;
        require(j < static_cast<index_t>(f.edges.size()), "collapse: the target left the vertex's fan");
        collapse_inner(w, f, j);
    }
    w.out[v] = -1;
    w.alive[v] = 0;
    --w.n_alive;
}

// The heap of vertices by their cheapest collapse, and onto whom each would go.
struct Ranking {
    std::vector<double> keys;
    std::vector<index_t> heap, slot, onto;

    HeapView view() {
        const index_t n = static_cast<index_t>(heap.size());
        return {{keys.data(), n}, {heap.data(), n}, {slot.data(), n}};
    }
};

void rank_all(Work& w, Ranking& rank, CollapseCount& count) {
    const index_t n = static_cast<index_t>(w.vr.size());
    rank.keys.assign(n, NEVER);
    rank.heap.resize(n);
    rank.slot.resize(n);
    rank.onto.assign(n, -1);
    Scratch s;
    const HeapView h = rank.view();
    for (index_t v = 0; v < n; ++v) {
        poll_interrupt();
        const Choice c = best_collapse(w, v, s, count);
        rank.onto[v] = c.onto;
        h.keys[v] = c.key;
        h.heap[v] = v;
        h.sift_up(v);
    }
}

// After a collapse onto u: u's value refitted, its triangles' sums again, and u and its
// neighbours, whose stars changed, ranked again at once. (Lazily, when popped, cost tsukuba 1 %
// 0.100 % error against 0.054 % at k = 3, for 0.4x the time: docs/decisions.md.)
void settle(Work& w, Ranking& rank, index_t u, bool refit, Scratch& s, CollapseCount& count) {
    Fan f;
    fan_of(w, u, f);
    if (refit) w.z[u] = refit_value(w, u, f);
    for (index_t e : f.edges) w.err[e / 3] = face_error(w, e / 3);
    std::vector<index_t> near{u};
    each_neighbour(w, f, [&](index_t x) { near.push_back(x); });
    const HeapView h = rank.view();
    for (index_t x : near) {
        const Choice c = best_collapse(w, x, s, count, rank.onto[x]);
        rank.onto[x] = c.onto;
        h.rekey(x, c.key, static_cast<index_t>(rank.heap.size()));
    }
}

// Collapses, cheapest first, until `target` vertices are left; false when none is left to take.
bool collapse_to(Work& w, index_t target, bool refit, CollapseCount& count) {
    Ranking rank;
    rank_all(w, rank, count);
    const HeapView h = rank.view();
    const index_t n = static_cast<index_t>(rank.heap.size());
    Scratch s;
    Fan f;
    while (w.n_alive > target) {
        poll_interrupt();
        const index_t v = h.heap[0], u = rank.onto[v];
        if (h.keys[0] == NEVER) return false;
        fan_of(w, v, f);
        collapse(w, v, f, u);
        ++count.collapses;
        h.rekey(v, NEVER, n);
        settle(w, rank, u, refit, s, count);
    }
    return true;
}

// Flip quad edge e (A -> B) when the other diagonal's two triangles have the smaller summed error.
bool flip_if_better(Work& w, index_t e) {
    const index_t g = w.he[e];
    const Quad q(Span<const index_t>{w.he.data(), static_cast<index_t>(w.he.size())}, e);
    const index_t A = w.tri[e], B = w.tri[nxt(e)], C = w.tri[prv(e)], D = w.tri[prv(g)];
    if (orientation(w, D, C, A) <= 0 || orientation(w, C, D, B) <= 0) return false;
    const double dca = triangle_error(w.image, point(w, D), point(w, C), point(w, A),
                                      {owned_inside(w, D, C), owned(w, q.c0), owned(w, q.b1)});
    const double cdb = triangle_error(w.image, point(w, C), point(w, D), point(w, B),
                                      {owned_inside(w, C, D), owned(w, q.c1), owned(w, q.b0)});
    const double span = w.image.span;
    if (!(quantize(dca + cdb, span) < quantize(w.err[e / 3] + w.err[g / 3], span))) return false;
    flip_quad({w.tri.data(), static_cast<index_t>(w.tri.size())}, {w.he.data(), static_cast<index_t>(w.he.size())}, e);
    w.err[e / 3] = dca;
    w.err[g / 3] = cdb;
    return true;
}

index_t flip_all(Work& w) {
    index_t flips = 0;
    const index_t n_he = static_cast<index_t>(w.he.size());
    for (int pass = 0; pass < MAX_FLIP_PASSES; ++pass) {
        index_t now = 0;
        for (index_t e = 0; e < n_he; ++e) {
            poll_every(e);
            if (!w.tri_alive[e / 3] || w.he[e] < e) continue;  // (each interior edge once)
            now += flip_if_better(w, e);
        }
        flips += now;
        if (now == 0) break;
    }
    return flips;
}

Work build(const Image& values, const CollapseInput& in) {
    const ValidFaces& m = in.mesh;
    const index_t n_v = static_cast<index_t>(m.pixels.size() / 2), n_f = static_cast<index_t>(m.faces.size() / 3);
    Work w{values, {}, {}, {}, in.z, {}, {}, {}, {}, {}, {}, 0, n_v};
    build_halfedges(Grid<const std::int32_t>{m.faces.data(), n_f, 3}, n_v, w.tri, w.he);
    w.vr.resize(n_v);
    w.vc.resize(n_v);
    for (index_t i = 0; i < n_v; ++i) {
        w.vr[i] = m.pixels[2 * i];
        w.vc[i] = m.pixels[2 * i + 1];
    }
    w.out.assign(n_v, -1);
    w.alive.assign(n_v, 1);
    w.mark.assign(n_v, 0);
    w.tri_alive.assign(n_f, 1);
    w.err.resize(n_f);
    for (index_t e = 0; e < 3 * n_f; ++e) {
        w.out[w.tri[e]] = e;
    }
    for (index_t t = 0; t < n_f; ++t) {
        poll_interrupt();
        require(orientation(w, w.tri[3 * t], w.tri[3 * t + 1], w.tri[3 * t + 2]) > 0,
                "collapse: a face is not counter-clockwise");
        w.err[t] = face_error(w, t);
    }
    return w;
}

// The live triangles over the live vertices, renumbered in their order.
void compact(const Work& w, ValidFaces& out) {
    const index_t n_v = static_cast<index_t>(w.vr.size());
    std::vector<std::int32_t> id(n_v, -1);
    out.pixels.clear();
    for (index_t v = 0; v < n_v; ++v) {
        if (!w.alive[v]) continue;
        id[v] = static_cast<std::int32_t>(out.pixels.size() / 2);
        out.pixels.push_back(static_cast<std::int32_t>(w.vr[v]));
        out.pixels.push_back(static_cast<std::int32_t>(w.vc[v]));
    }
    out.faces.clear();
    for (index_t e = 0; e < static_cast<index_t>(w.tri.size()); ++e) {
        if (!w.tri_alive[e / 3]) continue;
        require(id[w.tri[e]] >= 0, "collapse: a live face has a collapsed corner");
        out.faces.push_back(id[w.tri[e]]);
    }
}

}  // namespace

bool collapse_mesh(const Image& values, const CollapseInput& in, ValidFaces& out, CollapseCount& count) {
    const index_t n_v = static_cast<index_t>(in.mesh.pixels.size() / 2);
    check_input(static_cast<index_t>(in.z.size()) == n_v && in.mesh.faces.size() % 3 == 0,
                "collapse_mesh: one value a vertex, three corners a face");
    for (std::int32_t x : in.mesh.faces) check_input(0 <= x && x < n_v, "collapse_mesh: a corner id is out of range");
    if (in.target >= n_v) return false;
    Work w = build(values, in);
    if (!collapse_to(w, in.target, in.refit, count)) return false;
    count.flips = flip_all(w);
    compact(w, out);
    return true;
}

}  // namespace rangemesh::refine
