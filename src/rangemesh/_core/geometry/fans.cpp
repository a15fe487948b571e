#include "fans.hpp"

#include <algorithm>
#include <vector>

#include "../interrupt.hpp"

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

}  // namespace rangemesh
