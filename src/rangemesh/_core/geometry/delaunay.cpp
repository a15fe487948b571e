#include "delaunay.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "../interrupt.hpp"
#include "halfedges.hpp"

namespace rangemesh {

namespace {

// The first triangle of the sweep, counter-clockwise, and its circumcentre (cr, cc).
struct Seed {
    index_t i0 = -1, i1 = -1, i2 = -1;  // i2 == -1: fewer than 3 points, or all collinear
    double cr = 0.0, cc = 0.0;
};

double sq(double x) { return x * x; }

// The circumcentre of (p0, p1, p2) relative to p0, and its squared radius.
struct Circle {
    double dr, dc;

    Circle(const std::vector<double>& fr, const std::vector<double>& fc, index_t p0, index_t p1, index_t p2) {
        const double ar = fr[p1] - fr[p0], ac = fc[p1] - fc[p0];
        const double br = fr[p2] - fr[p0], bc = fc[p2] - fc[p0];
        const double bl = ar * ar + ac * ac;
        const double cl = br * br + bc * bc;
        const double den = 0.5 / (ar * bc - ac * br);
        dr = (bc * bl - ac * cl) * den;
        dc = (ar * cl - br * bl) * den;
    }

    double radius2() const { return dr * dr + dc * dc; }
};

// The id in [0, n) whose key(i) is smallest, ties to the smaller id; `none` when no key is
// below infinity (a key of infinity leaves a point out).
template <class Key>
index_t smallest(index_t n, index_t none, Key key) {
    index_t out = none;
    double best = INFINITY;
    for (index_t i = 0; i < n; ++i) {
        poll_every(i);
        const double d = key(i);
        if (d < best) {
            best = d;
            out = i;
        }
    }
    return out;
}

// i0 nearest the bounding box's centre, i1 nearest i0, i2 making the smallest circumcircle
// with them; ties to the smaller id.
Seed sweep_seed(const PointSet& pts, const std::vector<double>& fr, const std::vector<double>& fc) {
    Seed s;
    const index_t n = pts.size();
    if (n < 3) return s;
    double lo_r = fr[0], hi_r = fr[0], lo_c = fc[0], hi_c = fc[0];
    for (index_t i = 1; i < n; ++i) {
        poll_every(i);
        lo_r = std::min(lo_r, fr[i]);
        hi_r = std::max(hi_r, fr[i]);
        lo_c = std::min(lo_c, fc[i]);
        hi_c = std::max(hi_c, fc[i]);
    }
    const double mr = 0.5 * (lo_r + hi_r), mc = 0.5 * (lo_c + hi_c);
    s.i0 = smallest(n, 0, [&](index_t i) { return sq(fr[i] - mr) + sq(fc[i] - mc); });
    s.i1 = smallest(n, -1, [&](index_t i) -> double {
        if (i == s.i0) return INFINITY;
        return sq(fr[i] - fr[s.i0]) + sq(fc[i] - fc[s.i0]);
    });
    s.i2 = smallest(n, -1, [&](index_t i) -> double {
        if (i == s.i0 || i == s.i1 || pts.orient(s.i0, s.i1, i) == 0) return INFINITY;
        return Circle(fr, fc, s.i0, s.i1, i).radius2();
    });
    if (s.i2 == -1) return s;  // all collinear
    if (pts.orient(s.i0, s.i1, s.i2) < 0) std::swap(s.i1, s.i2);
    const Circle centre(fr, fc, s.i0, s.i1, s.i2);
    s.cr = fr[s.i0] + centre.dr;
    s.cc = fc[s.i0] + centre.dc;
    return s;
}

// The sweep's state: the mesh so far and its convex hull, a counter-clockwise linked list of
// points (next[p] == p once p left it) found by angle around the seed's circumcentre.
class Sweep {
  public:
    Sweep(const PointSet& pts, const std::vector<double>& fr, const std::vector<double>& fc, const Seed& seed)
        : pts_(pts), fr_(fr), fc_(fc), cr_(seed.cr), cc_(seed.cc) {
        const index_t n = pts.size();
        const FreeLater late(on_throw, mesh_.triangles, mesh_.halfedges, stack_, hash_, next_, prev_, tri_);
        const index_t max_t = std::max<index_t>(2 * n - 5, 1);
        // gigabytes for millions of points: filled with polls between strides
        fill_polled(mesh_.triangles, 3 * max_t, index_t{-1});
        fill_polled(mesh_.halfedges, 3 * max_t, index_t{-1});
        fill_polled(stack_, 3 * max_t + 16, index_t{0});
        hash_size_ = std::max<index_t>(static_cast<index_t>(std::ceil(std::sqrt(static_cast<double>(n)))), 1);
        fill_polled(hash_, hash_size_, index_t{-1});
        fill_polled(next_, n, index_t{-1});
        fill_polled(prev_, n, index_t{-1});
        fill_polled(tri_, n, index_t{-1});
        const index_t i0 = seed.i0, i1 = seed.i1, i2 = seed.i2;
        next_[i0] = i1;
        next_[i1] = i2;
        next_[i2] = i0;
        prev_[i0] = i2;
        prev_[i1] = i0;
        prev_[i2] = i1;
        const index_t t = add_triangle(i0, i1, i2, -1, -1, -1);
        tri_[i0] = t;
        tri_[i1] = t + 1;
        tri_[i2] = t + 2;
        hash_[hash_key(i0)] = i0;
        hash_[hash_key(i1)] = i1;
        hash_[hash_key(i2)] = i2;
    }

    ~Sweep() { free_later(mesh_.triangles, mesh_.halfedges, stack_, hash_, next_, prev_, tri_); }
    Sweep(const Sweep&) = delete;
    Sweep& operator=(const Sweep&) = delete;

    // Add point p (outside the hull): triangles to every hull edge it sees, then legalised.
    void insert(index_t p) {
        const index_t start = prev_[hull_near(p)];
        // edge e -> next[e] is visible when p is strictly on its right (outside)
        index_t e = start;
        while (pts_.orient(e, next_[e], p) >= 0) {
            e = next_[e];
            require(e != start, "delaunay_sweep: a point sees no hull edge (duplicate points?)");
        }
        index_t after = next_[e];
        // the first triangle, on the visible edge e -> after: (after, e, p)
        index_t t = add_triangle(after, e, p, tri_[e], -1, -1);
        tri_[e] = t + 1;  // e -> p
        tri_[p] = t + 2;  // p -> after
        legalize(t);
        // forward: after -> q visible too? (q, after, p): q->after twins the hull edge
        // after->q, after->p twins p->after
        for (index_t q = next_[after]; pts_.orient(after, q, p) < 0; q = next_[after]) {
            t = add_triangle(q, after, p, tri_[after], tri_[p], -1);
            tri_[p] = t + 2;  // p -> q
            legalize(t);
            next_[after] = after;  // off the hull
            after = q;
        }
        // backward: q -> e visible? (e, q, p): e->q twins q->e, p->e twins e->p
        if (e == start) {
            for (index_t q = prev_[e]; pts_.orient(q, e, p) < 0; q = prev_[e]) {
                t = add_triangle(e, q, p, tri_[q], -1, tri_[e]);
                tri_[q] = t + 1;  // q -> p
                legalize(t);
                next_[e] = e;
                e = q;
            }
        }
        prev_[p] = e;
        next_[e] = p;
        prev_[after] = p;
        next_[p] = after;
        hash_[hash_key(p)] = p;
        hash_[hash_key(e)] = e;
    }

    // The triangles made, trimmed to their count.
    Triangulation finish() && {
        mesh_.triangles.resize(3 * n_t_);
        mesh_.halfedges.resize(3 * n_t_);
        return std::move(mesh_);
    }

  private:
    // A monotone stand-in for the angle of (dr, dc), in [0, 1).
    static double pseudo_angle(double dr, double dc) {
        const double p = dr / (std::abs(dr) + std::abs(dc));
        return (dc > 0 ? 3.0 - p : 1.0 + p) / 4.0;
    }

    // The hash bucket of point p's angle around the circumcentre.
    index_t hash_key(index_t p) const {
        const double dr = fr_[p] - cr_, dc = fc_[p] - cc_;
        if (dr == 0.0 && dc == 0.0) return 0;
        return floor_mod(static_cast<index_t>(std::floor(pseudo_angle(dr, dc) * static_cast<double>(hash_size_))),
                         hash_size_);
    }

    // A hull point near p's angle, to start looking for the edges p sees.
    index_t hull_near(index_t p) const {
        const index_t key = hash_key(p);
        for (index_t j = 0; j < hash_size_; ++j) {
            const index_t s = hash_[floor_mod(key + j, hash_size_)];
            if (s != -1 && next_[s] != s) return s;
        }
        require(false, "delaunay_sweep: the hull hash is empty");
        return -1;
    }

    // Append triangle (i0, i1, i2) with twins a, b, c of its half-edges; returns its first.
    index_t add_triangle(index_t i0, index_t i1, index_t i2, index_t a, index_t b, index_t c) {
        const index_t t = 3 * n_t_++;
        require(t + 2 < static_cast<index_t>(mesh_.triangles.size()), "delaunay_sweep: too many triangles");
        mesh_.triangles[t] = i0;
        mesh_.triangles[t + 1] = i1;
        mesh_.triangles[t + 2] = i2;
        const Span<index_t> he{mesh_.halfedges.data(), static_cast<index_t>(mesh_.halfedges.size())};
        link(he, t, a);
        link(he, t + 1, b);
        link(he, t + 2, c);
        return t;
    }

    // Flip the edges opposite the new point w until they are legal; keep tri_ on hull edges.
    //
    //        w                 w
    //      /   \             / | \     a: u -> v in (u, v, w)
    //     u --- v    ->     u  |  v    b: its twin, in (v, u, x)
    //      \   /             \ | /     the diagonal u-v becomes w-x
    //        x                 x
    void legalize(index_t a) {
        const Span<index_t> tri{mesh_.triangles.data(), static_cast<index_t>(mesh_.triangles.size())};
        const Span<index_t> he{mesh_.halfedges.data(), static_cast<index_t>(mesh_.halfedges.size())};
        index_t top = 0;
        for (;;) {
            const index_t b = he[a];
            if (b != -1 && pts_.illegal(tri[a], tri[nxt(a)], tri[prv(a)], tri[prv(b)])) {
                flip_quad(tri, he, a);
                // hull edges among the moved outer half-edges: re-point tri_
                for (const index_t s : {nxt(a), prv(a), nxt(b), prv(b)})
                    if (he[s] == -1) tri_[tri[s]] = s;
                // the edges now opposite the new point are prev(a) (u->x) and next(b) (x->v)
                require(top + 1 < static_cast<index_t>(stack_.size()), "delaunay_sweep: flip stack overflow");
                stack_[top++] = nxt(b);
                a = prv(a);
                continue;
            }
            if (top == 0) return;
            a = stack_[--top];
        }
    }

    const PointSet& pts_;
    const std::vector<double>& fr_;
    const std::vector<double>& fc_;
    double cr_, cc_;
    Triangulation mesh_;
    index_t n_t_ = 0;
    index_t hash_size_ = 1;
    std::vector<index_t> hash_, next_, prev_, tri_;  // tri_[p]: the hull half-edge leaving p
    std::vector<index_t> stack_;
};

// The ids 0..n-1 sorted by `key`, ties in id order: std::stable_sort's order, made as sorted
// runs merged pairwise (each merge stable) so that Ctrl-C is polled between steps of a sort of
// millions of points, which takes seconds; the merges poll every POLL_STRIDE ids too (the last
// one merges all of them).
std::vector<index_t> stable_order(const std::vector<double>& key) {
    const index_t n = static_cast<index_t>(key.size());
    constexpr index_t RUN = index_t{1} << 16;
    const auto less = [&](index_t a, index_t b) { return key[a] < key[b]; };
    std::vector<index_t> order, merged;
    const FreeLater late(merged);
    order.reserve(n);
    for (index_t i = 0; i < n; ++i) {
        poll_every(i);
        order.push_back(i);
    }
    for (index_t lo = 0; lo < n; lo += RUN) {
        poll_interrupt();
        std::stable_sort(order.begin() + lo, order.begin() + std::min(lo + RUN, n), less);
    }
    if (n > RUN) fill_polled(merged, n, index_t{0});
    for (index_t width = RUN; width < n; width *= 2) {
        for (index_t lo = 0; lo < n; lo += 2 * width) {
            // std::merge's order: the first run's id first unless the second's key is smaller
            index_t i = lo, k = lo;
            const index_t mid = std::min(lo + width, n), hi = std::min(lo + 2 * width, n);
            index_t j = mid;
            while (i < mid && j < hi) {
                poll_every(k);
                merged[k++] = less(order[j], order[i]) ? order[j++] : order[i++];
            }
            for (; i < mid; ++i) merged[k++] = order[i];
            for (; j < hi; ++j) merged[k++] = order[j];
        }
        order.swap(merged);
    }
    return order;
}

}  // namespace

Triangulation delaunay_sweep(const PointSet& pts) {
    require(pts.r.size == pts.c.size, "delaunay_sweep: r and c differ in length");
    pts.check_span();
    const index_t n = pts.size();
    std::vector<double> fr, fc, dist;
    const FreeLater late(fr, fc, dist);
    fr.reserve(n);
    fc.reserve(n);
    for (index_t i = 0; i < n; ++i) {
        poll_every(i);
        fr.push_back(static_cast<double>(pts.r[i]));
        fc.push_back(static_cast<double>(pts.c[i]));
    }
    const Seed seed = sweep_seed(pts, fr, fc);
    if (seed.i2 == -1) return {};
    // by distance from the seed's circumcentre; ties keep id order
    dist.reserve(n);
    for (index_t i = 0; i < n; ++i) {
        poll_every(i);
        dist.push_back(sq(fr[i] - seed.cr) + sq(fc[i] - seed.cc));
    }
    std::vector<index_t> order = stable_order(dist);
    const FreeLater late_order(order);
    Sweep sweep(pts, fr, fc, seed);
    for (const index_t p : order) {
        if (p == seed.i0 || p == seed.i1 || p == seed.i2) continue;
        poll_interrupt();
        sweep.insert(p);
    }
    return std::move(sweep).finish();
}

index_t legalize_all(Span<index_t> triangles, Span<index_t> halfedges, const PointSet& pts) {
    require(triangles.size == halfedges.size && triangles.size % 3 == 0, "legalize_all: bad half-edge arrays");
    pts.check_span();
    std::vector<index_t> stack;
    const FreeLater late(stack);
    stack.reserve(triangles.size + 16);
    for (index_t e = 0; e < triangles.size; ++e) {
        poll_every(e);
        check_input(0 <= triangles[e] && triangles[e] < pts.size(), "legalize_all: a vertex id out of range");
    }
    const Span<const index_t> tri{triangles.data, triangles.size}, he{halfedges.data, halfedges.size};
    for (index_t e = 0; e < triangles.size; ++e) {
        poll_every(e);
        check_input(twin_ok(tri, he, e),
                    "legalize_all: a twin half-edge out of range, or twins that do not run back along one edge");
        if (halfedges[e] > e) stack.push_back(e);
    }
    // an edge flipped away never comes back (each flip lowers the lifted surface), so a mesh
    // that needs more flips than there are point pairs is no triangulation of its points
    const index_t n = pts.size();
    const index_t max_flips = n < (index_t{1} << 31) ? n * (n - 1) / 2 : std::numeric_limits<index_t>::max();
    index_t flips = 0;
    for (index_t popped = 1; !stack.empty(); ++popped) {
        poll_every(popped);  // tens of millions of edges to test even when none flips
        const index_t e = stack.back();
        stack.pop_back();
        const index_t t = halfedges[e];
        if (t == -1 || !pts.illegal(triangles[e], triangles[nxt(e)], triangles[prv(e)], triangles[prv(t)])) continue;
        require(flips < max_flips, "legalize_all: more flips than point pairs (a mesh that is no triangulation)");
        flip_quad(triangles, halfedges, e);
        ++flips;
        for (const index_t s : {nxt(e), prv(e), nxt(t), prv(t)}) stack.push_back(s);
    }
    return flips;
}

std::vector<index_t> canonical_faces(Span<const index_t> triangles, index_t n_vertices) {
    const index_t n_t = triangles.size / 3;
    // each face's first corner: its smallest (the first of equal ones, as argmin)
    std::vector<unsigned char> first;
    std::vector<index_t> order, sorted, count, out;
    const FreeLater late(first, order, sorted, count);
    const FreeLater late_out(on_throw, out);
    first.reserve(n_t);
    index_t used = 0;  // the ids in use: a raw call's n_vertices of INT64_MAX would size the counts
    for (index_t t = 0; t < n_t; ++t) {
        poll_every(t);
        const index_t* f = triangles.data + 3 * t;
        check_input(std::min({f[0], f[1], f[2]}) >= 0 && std::max({f[0], f[1], f[2]}) < n_vertices,
                    "canonical_faces: a corner id is out of range");
        used = std::max(used, std::max({f[0], f[1], f[2]}) + 1);
        first.push_back(static_cast<unsigned char>(f[1] < f[0] ? (f[2] < f[1] ? 2 : 1) : (f[2] < f[0] ? 2 : 0)));
    }
    n_vertices = used;
    const auto corner = [&](index_t t, int k) { return triangles[3 * t + (first[t] + k) % 3]; };
    // a stable counting sort by the third corner, then the second, then the first: lexsort's order
    order.reserve(n_t);
    for (index_t t = 0; t < n_t; ++t) {
        poll_every(t);
        order.push_back(t);
    }
    fill_polled(sorted, n_t, index_t{0});
    for (int k = 2; k >= 0; --k) {
        fill_polled(count, n_vertices + 1, index_t{0});
        for (index_t i = 0; i < n_t; ++i) {
            poll_every(i);
            count[corner(order[i], k) + 1] += 1;
        }
        for (index_t v = 0; v < n_vertices; ++v) {
            poll_every(v);
            count[v + 1] += count[v];
        }
        for (index_t i = 0; i < n_t; ++i) {
            poll_every(i);
            sorted[count[corner(order[i], k)]++] = order[i];
        }
        order.swap(sorted);
    }
    out.reserve(3 * n_t);
    for (index_t i = 0; i < n_t; ++i) {
        poll_every(i);
        for (int k = 0; k < 3; ++k) out.push_back(corner(order[i], k));
    }
    return out;
}

}  // namespace rangemesh
