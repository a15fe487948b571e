#include "fans.hpp"

#include <algorithm>
#include <utility>
#include <vector>

#include "../interrupt.hpp"
#include "halfedges.hpp"

namespace rangemesh {

namespace {

// Union-find over triangle corners 3t + k; the smaller root wins a union, so the groups and
// their roots do not depend on the order of the unions.
struct Corners {
    std::vector<index_t> parent;

    explicit Corners(index_t n) {
        const FreeLater late(on_throw, parent);
        parent.reserve(n);
        for (index_t i = 0; i < n; ++i) {
            poll_every(i);
            parent.push_back(i);
        }
    }

    ~Corners() { free_later(parent); }
    Corners(const Corners&) = delete;
    Corners& operator=(const Corners&) = delete;

    void reset() {
        for (index_t i = 0; i < static_cast<index_t>(parent.size()); ++i) {
            poll_every(i);
            parent[i] = i;
        }
    }

    index_t find(index_t i) {
        index_t root = i;
        while (parent[root] != root) root = parent[root];
        while (parent[i] != root) {  // path compression
            const index_t up = parent[i];
            parent[i] = root;
            i = up;
        }
        return root;
    }

    void unite(index_t a, index_t b) {
        const index_t ra = find(a), rb = find(b);
        if (ra < rb)
            parent[rb] = ra;
        else if (rb < ra)
            parent[ra] = rb;
    }
};

// Drop the live triangles with no live neighbour; returns how many.
index_t drop_lonely(LiveTriangles mesh) {
    index_t dropped = 0;
    for (index_t t = 0; t < mesh.simplices.rows; ++t) {
        poll_every(t);
        if (!mesh.alive[t]) continue;
        bool lonely = true;
        for (int k = 0; k < 3; ++k) {
            const index_t nb = mesh.neighbors(t, k);
            if (nb >= 0 && mesh.alive[nb]) lonely = false;
        }
        if (lonely) {
            mesh.alive[t] = false;
            ++dropped;
        }
    }
    return dropped;
}

// Join the corners of live triangles that share an edge and a vertex: the fans.
void join_fans(LiveTriangles mesh, Corners& fans) {
    fans.reset();
    for (index_t t = 0; t < mesh.simplices.rows; ++t) {
        poll_every(t);
        if (!mesh.alive[t]) continue;
        for (int k = 0; k < 3; ++k) {
            const index_t nb = mesh.neighbors(t, k);
            if (nb <= t || !mesh.alive[nb]) continue;
            // the shared edge is the one opposite corner k of t
            for (int m = 1; m <= 2; ++m) {
                const int kk = (k + m) % 3;
                const index_t v = mesh.simplices(t, kk);
                for (int q = 0; q < 3; ++q)
                    if (mesh.simplices(nb, q) == v) fans.unite(3 * t + kk, 3 * nb + q);
            }
        }
    }
}

// Each vertex's largest fan, by the root of its corners and its size (scratch for one round).
struct BestFans {
    std::vector<index_t> size;  // triangles in the fan of each root corner
    std::vector<index_t> best_root, best_size;

    BestFans(index_t n_t, index_t n_vertices) {
        const FreeLater late(on_throw, size, best_root, best_size);
        fill_polled(size, 3 * n_t, index_t{0});
        fill_polled(best_root, n_vertices, index_t{0});
        fill_polled(best_size, n_vertices, index_t{0});
    }
    ~BestFans() { free_later(size, best_root, best_size); }
    BestFans(const BestFans&) = delete;
    BestFans& operator=(const BestFans&) = delete;
};

// Drop every live triangle with a corner outside its vertex's largest fan; returns how many.
index_t drop_small_fans(LiveTriangles mesh, Corners& fans, BestFans& scratch) {
    const index_t n_t = mesh.simplices.rows;
    std::vector<index_t>& size = scratch.size;
    std::vector<index_t>& best_root = scratch.best_root;
    std::vector<index_t>& best_size = scratch.best_size;
    fill_polled(size, size.size(), index_t{0});
    fill_polled(best_root, best_root.size(), index_t{-1});
    fill_polled(best_size, best_size.size(), index_t{0});
    for (index_t t = 0; t < n_t; ++t) {
        poll_every(t);
        if (mesh.alive[t])
            for (int k = 0; k < 3; ++k) size[fans.find(3 * t + k)] += 1;
    }
    for (index_t t = 0; t < n_t; ++t) {
        poll_every(t);
        if (!mesh.alive[t]) continue;
        for (int k = 0; k < 3; ++k) {
            const index_t i = 3 * t + k;
            if (fans.parent[i] != i) continue;
            const index_t v = mesh.simplices(t, k);
            if (size[i] > best_size[v] || (size[i] == best_size[v] && i < best_root[v])) {
                best_size[v] = size[i];
                best_root[v] = i;
            }
        }
    }
    index_t dropped = 0;
    for (index_t t = 0; t < n_t; ++t) {
        poll_every(t);
        if (!mesh.alive[t]) continue;
        for (int k = 0; k < 3; ++k) {
            if (fans.find(3 * t + k) != best_root[mesh.simplices(t, k)]) {
                mesh.alive[t] = false;
                ++dropped;
                break;
            }
        }
    }
    return dropped;
}

}  // namespace

index_t prune_dangling(LiveTriangles mesh, index_t n_vertices, bool drop_lone) {
    const index_t n_t = mesh.simplices.rows;
    require(mesh.neighbors.rows == n_t && mesh.alive.size == n_t, "prune_dangling: arrays differ in length");
    index_t used = 0;  // the ids in use: a raw call's n_vertices of INT64_MAX would size the table
    for (index_t t = 0; t < n_t; ++t) {
        poll_every(t);
        for (int k = 0; k < 3; ++k) {
            check_input(mesh.simplices(t, k) >= 0 && mesh.simplices(t, k) < n_vertices && -1 <= mesh.neighbors(t, k) &&
                            mesh.neighbors(t, k) < n_t,
                        "prune_dangling: a vertex or neighbour id out of range");
            used = std::max(used, mesh.simplices(t, k) + 1);
        }
    }
    Corners fans(3 * n_t);
    BestFans scratch(n_t, used);
    index_t removed = 0;
    for (bool changed = true; changed;) {
        poll_interrupt();
        const index_t lonely = drop_lone ? drop_lonely(mesh) : 0;
        join_fans(mesh, fans);
        const index_t small = drop_small_fans(mesh, fans, scratch);
        removed += lonely + small;
        changed = lonely + small > 0;
    }
    return removed;
}

namespace {

// The stars of a cut triangulation's vertices, walked by the twins: slot g is the corner of
// vertex triangles[g] in triangle g / 3 (the half-edge leaving it).
class CutStars {
  public:
    CutStars(Span<const index_t> triangles, Span<const index_t> halfedges, Span<bool> alive)
        : tri_(triangles), he_(halfedges), alive_(alive) {}

    // Start a vertex afresh: no fan noted.
    void begin() {
        walk_.clear();
        runs_.clear();
    }

    // Note the fans of the part of a vertex's star through slot `s` (its triangles joined by
    // edges, dead ones included); with `from_start`, `s`'s edge is a border and starts it.
    void add(index_t s, bool from_start) {
        const index_t n = tri_.size;
        index_t first = s;
        if (!from_start) {
            for (index_t steps = 0;; ++steps) {  // back to the part's first slot, or round to s
                require(steps <= n, "prune_cut_fans: a star without end");
                const index_t b = back(first);
                if (b < 0) break;
                if (b == s) {  // a whole disc: s's triangle is dead, so no fan runs through it
                    first = s;
                    break;
                }
                first = b;
            }
        }
        bool open = false;
        for (index_t g = first, steps = 0;; ++steps) {
            require(steps <= n, "prune_cut_fans: a star without end");
            walk_.push_back(g);
            const index_t i = static_cast<index_t>(walk_.size()) - 1;
            if (alive_[g / 3]) {
                if (!open) runs_.push_back(Run{i, i, 0, g});
                open = true;
                Run& r = runs_.back();
                r.end = i + 1;
                r.size += 1;
                r.root = std::min(r.root, g);
            } else {
                open = false;
            }
            const index_t f = fwd(g);
            if (f < 0 || f == first) break;
            g = f;
        }
    }

    // Push the triangles of every fan noted but the largest (ties: the smallest slot, the root
    // `prune_dangling`'s union-find keeps) onto `drop`.
    void decide(std::vector<index_t>& drop) const {
        if (runs_.size() < 2) return;
        std::size_t best = 0;
        for (std::size_t k = 1; k < runs_.size(); ++k)
            if (runs_[k].size > runs_[best].size ||
                (runs_[k].size == runs_[best].size && runs_[k].root < runs_[best].root))
                best = k;
        for (std::size_t k = 0; k < runs_.size(); ++k)
            if (k != best)
                for (index_t i = runs_[k].begin; i < runs_[k].end; ++i) drop.push_back(walk_[i] / 3);
    }

  private:
    // the slot of the same vertex across g's edge (v -> w), or -1
    index_t back(index_t g) const {
        const index_t t = he_[g];
        return t < 0 ? -1 : nxt(t);
    }
    // ... across the edge (u -> v) before g, or -1
    index_t fwd(index_t g) const { return he_[prv(g)]; }

    struct Run {
        index_t begin, end, size, root;  // walk_[begin, end): one fan
    };
    Span<const index_t> tri_, he_;
    Span<bool> alive_;
    std::vector<index_t> walk_;
    std::vector<Run> runs_;
};

}  // namespace

index_t prune_cut_fans(Span<const index_t> triangles, Span<const index_t> halfedges, Span<bool> alive) {
    const index_t n_he = triangles.size;
    require(halfedges.size == n_he && n_he % 3 == 0 && alive.size == n_he / 3,
            "prune_cut_fans: three ids and three twins a triangle, one flag a triangle");
    std::fill(alive.begin(), alive.end(), true);
    // round one: every vertex with a border has a fan starting at each border half-edge leaving it
    std::vector<std::pair<index_t, index_t>> starts;  // (vertex, half-edge)
    for (index_t e = 0; e < n_he; ++e) {
        poll_every(e);
        if (halfedges[e] < 0) starts.emplace_back(triangles[e], e);
    }
    std::sort(starts.begin(), starts.end());
    CutStars stars(triangles, halfedges, alive);
    std::vector<index_t> drop, next;
    for (std::size_t i = 0; i < starts.size();) {
        std::size_t j = i + 1;
        while (j < starts.size() && starts[j].first == starts[i].first) ++j;
        if (j - i >= 2) {  // two fans or more: all but the largest go
            stars.begin();
            for (std::size_t k = i; k < j; ++k) stars.add(starts[k].second, true);
            stars.decide(drop);
        }
        i = j;
    }
    index_t removed = 0, used = 0;
    std::vector<index_t> stamp;  // the round a vertex was last visited in
    for (index_t round = 1; !drop.empty(); ++round) {
        poll_interrupt();
        next.clear();
        for (const index_t t : drop)
            if (alive[t]) {
                alive[t] = false;
                ++removed;
                next.push_back(t);
            }
        drop.clear();
        if (stamp.empty()) {
            for (const index_t v : triangles) used = std::max(used, v + 1);
            stamp.assign(static_cast<std::size_t>(used), 0);
        }
        // the vertices of the triangles just dropped: their fans may have split
        for (const index_t t : next)
            for (int k = 0; k < 3; ++k) {
                const index_t s = 3 * t + k, v = triangles[s];
                if (stamp[v] == round) continue;
                stamp[v] = round;
                stars.begin();
                stars.add(s, false);
                stars.decide(drop);
            }
    }
    return removed;
}

}  // namespace rangemesh
