// An indexed binary max-heap over integer ids, keys stored at heap positions.
//
// Ties go to the smaller id, so equal keys always pop in the same order (SPEC P6): the order
// is strict, and any correct heap pops the same ids. Keys sit beside the ids rather than in an
// array indexed by id, so a comparison reads the heap's own cache lines.
#pragma once

#include <algorithm>
#include <cstdint>

#include "../views.hpp"

namespace rangemesh {

// Whether id `a` with `key_a` goes above id `b` with `key_b`: larger key, ties to smaller id.
inline bool above(double key_a, index_t a, double key_b, index_t b) {
    return key_a > key_b || (key_a == key_b && a < b);
}

// The heap's three arrays: keys[i] and heap[i] at position i, slot[id] the id's position.
struct HeapView {
    Span<double> keys;
    Span<index_t> heap;
    Span<index_t> slot;

    // Id `x` with the key `k` at position `i`.
    void put(index_t i, double k, index_t x) const {
        keys[i] = k;
        heap[i] = x;
        slot[x] = i;
    }

    // Move the entry at position `i` up until its parent is above it; returns its new position.
    index_t sift_up(index_t i) const {
        const double k = keys[i];
        const index_t x = heap[i];
        while (i > 0) {
            const index_t parent = (i - 1) >> 1;
            const double kp = keys[parent];
            const index_t y = heap[parent];
            if (!above(k, x, kp, y)) break;
            put(i, kp, y);
            i = parent;
        }
        put(i, k, x);
        return i;
    }

    // Move the entry at position `i` down (heap of `n` entries) until no child is above it.
    void sift_down(index_t i, index_t n) const {
        const double k = keys[i];
        const index_t x = heap[i];
        for (;;) {
            const index_t left = 2 * i + 1;
            if (left >= n) break;
            index_t best = left;
            double kb = keys[left];
            const index_t right = left + 1;
            if (right < n && above(keys[right], heap[right], kb, heap[left])) {
                best = right;
                kb = keys[right];
            }
            const index_t y = heap[best];
            if (!above(kb, y, k, x)) break;
            put(i, kb, y);
            i = best;
        }
        put(i, k, x);
    }

    // Add id `x` with the key `key` to the heap of `n` entries, which then holds one more:
    // O(log n). The arrays must have room for position n.
    void push(index_t x, double key, index_t& n) const {
        put(n, key, x);
        sift_up(n);
        ++n;
    }

    // Give id `x` the key `key` and restore the heap of `n` entries: O(log n).
    void rekey(index_t x, double key, index_t n) const {
        index_t i = slot[x];
        keys[i] = key;
        i = sift_up(i);
        sift_down(i, n);
    }
};

}  // namespace rangemesh

namespace rangemesh {

// A key and its id, side by side: a comparison reads one place.
struct HeapEntry {
    double key;
    index_t id;
};

// Four entries, one cache line: a 4-ary heap's siblings when the entries start 3 into the lines.
struct alignas(64) HeapLine {
    HeapEntry e[4];
};

// An indexed 4-ary max-heap over integer ids with `above`'s order, so it pops the ids a
// `HeapView` pops (the order is strict). Four children share a cache line and the heap is half
// as deep: a rekey deep in a heap of 10^5 triangles misses the cache about half as often.
struct QuadHeapView {
    HeapEntry* at;  // position i at at[i]; at + 1 + 4 i, the first child of i, starts a line
    index_t* slot;  // each id's position

    // The entries of `lines` (of `HeapLine`s): position 0 three entries in, so siblings share a line.
    static HeapEntry* entries(HeapLine* lines) { return lines->e + 3; }
    // Lines that hold `n` positions.
    static index_t lines_for(index_t n) { return (n + 3 + 3) / 4; }

    // Entry `e` at position `i`.
    void put(index_t i, const HeapEntry& e) const {
        at[i] = e;
        slot[e.id] = i;
    }

    index_t sift_up(index_t i) const {
        const HeapEntry x = at[i];
        while (i > 0) {
            const index_t parent = (i - 1) >> 2;
            const HeapEntry p = at[parent];
            if (!above(x.key, x.id, p.key, p.id)) break;
            put(i, p);
            i = parent;
        }
        put(i, x);
        return i;
    }

    void sift_down(index_t i, index_t n) const {
        const HeapEntry x = at[i];
        for (;;) {
            const index_t first = 4 * i + 1;
            if (first >= n) break;
            const index_t best = best_child(first, std::min(first + 4, n));
            const HeapEntry b = at[best];
            if (!above(b.key, b.id, x.key, x.id)) break;
            put(i, b);
            i = best;
        }
        put(i, x);
    }

    // The best of the children from `first` (at least one, `last` exclusive), chosen without
    // branches: which child wins is a coin toss to the branch predictor.
    index_t best_child(index_t first, index_t last) const {
        if (last - first == 4) {
            const HeapEntry* c = at + first;
#if defined(__GNUC__) || defined(__clang__)
            // the grandchildren, four lines in a row, asked for now: a branch's speculation would
            // have loaded the next level early, and without branches nothing else does
            // (by address, not pointer arithmetic: at the bottom levels they lie past the heap)
            const auto base = reinterpret_cast<std::uintptr_t>(at + first);
            for (std::uintptr_t k = 0; k < 4; ++k)
                __builtin_prefetch(reinterpret_cast<const void*>(
                    base + sizeof(HeapEntry) * (3 * static_cast<std::uintptr_t>(first) + 1 + 4 * k)));
#endif
            const bool u1 = (c[1].key > c[0].key) | ((c[1].key == c[0].key) & (c[1].id < c[0].id));
            const bool u3 = (c[3].key > c[2].key) | ((c[3].key == c[2].key) & (c[3].id < c[2].id));
            const index_t i = u1, j = 2 + static_cast<index_t>(u3);
            const double ki = u1 ? c[1].key : c[0].key, kj = u3 ? c[3].key : c[2].key;
            const index_t di = u1 ? c[1].id : c[0].id, dj = u3 ? c[3].id : c[2].id;
            const bool u = (kj > ki) | ((kj == ki) & (dj < di));
            return first + (u ? j : i);
        }
        index_t best = first;
        for (index_t c = first + 1; c < last; ++c)
            if (above(at[c].key, at[c].id, at[best].key, at[best].id)) best = c;
        return best;
    }

    // Add id `x` with `key` to the heap of `n` entries, which then holds one more.
    void push(index_t x, double key, index_t& n) const {
        put(n, {key, x});
        sift_up(n);
        ++n;
    }

    // Give id `x` the key `key` and restore the heap of `n` entries.
    void rekey(index_t x, double key, index_t n) const {
        index_t i = slot[x];
        at[i].key = key;
        i = sift_up(i);
        sift_down(i, n);
    }
};

}  // namespace rangemesh
