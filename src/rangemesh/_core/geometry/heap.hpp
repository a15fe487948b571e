// An indexed binary max-heap over integer ids, keys stored at heap positions.
//
// Ties go to the smaller id, so equal keys always pop in the same order (SPEC P6): the order
// is strict, and any correct heap pops the same ids. Keys sit beside the ids rather than in an
// array indexed by id, so a comparison reads the heap's own cache lines.
#pragma once

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

    // Move the entry at position `i` up until its parent is above it; returns its new position.
    index_t sift_up(index_t i) const {
        const double k = keys[i];
        const index_t x = heap[i];
        while (i > 0) {
            const index_t parent = (i - 1) >> 1;
            const double kp = keys[parent];
            const index_t y = heap[parent];
            if (!above(k, x, kp, y)) break;
            keys[i] = kp;
            heap[i] = y;
            slot[y] = i;
            i = parent;
        }
        keys[i] = k;
        heap[i] = x;
        slot[x] = i;
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
            keys[i] = kb;
            heap[i] = y;
            slot[y] = i;
            i = best;
        }
        keys[i] = k;
        heap[i] = x;
        slot[x] = i;
    }

    // Add id `x` with the key `key` to the heap of `n` entries, which then holds one more:
    // O(log n). The arrays must have room for position n.
    void push(index_t x, double key, index_t& n) const {
        keys[n] = key;
        heap[n] = x;
        slot[x] = n;
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
