"""An indexed binary max-heap over integer ids keyed by a float array, in Numba.

``heap`` holds ids, ``slot[id]`` is the id's position in ``heap``. Ties go to
the smaller id, so equal keys always pop in the same order (SPEC P6).
"""

from numba import njit


@njit(cache=True)
def higher(gain, a, b):
    """Whether id `a` goes above id `b`: larger key, ties to the smaller id."""
    # Ties go to the smaller edge id: equal gains pop in a fixed order (SPEC P6).
    return gain[a] > gain[b] or (gain[a] == gain[b] and a < b)


@njit(cache=True)
def sift_up(heap, slot, gain, i):
    """Move the id at position `i` up until its parent is higher; returns its new position."""
    x = heap[i]
    while i > 0:
        parent = (i - 1) >> 1
        y = heap[parent]
        if not higher(gain, x, y):
            break
        heap[i] = y
        slot[y] = i
        i = parent
    heap[i] = x
    slot[x] = i
    return i


@njit(cache=True)
def sift_down(heap, slot, gain, i, n):
    """Move the id at position `i` down (heap of `n` ids) until no child is higher."""
    x = heap[i]
    while True:
        left = 2 * i + 1
        if left >= n:
            break
        best = left
        right = left + 1
        if right < n and higher(gain, heap[right], heap[left]):
            best = right
        if not higher(gain, heap[best], x):
            break
        heap[i] = heap[best]
        slot[heap[i]] = i
        i = best
    heap[i] = x
    slot[x] = i


@njit(cache=True)
def rekey(heap, slot, gain, x, n):
    """Restore the heap after gain[x] changed: O(log N)."""
    i = sift_up(heap, slot, gain, slot[x])
    sift_down(heap, slot, gain, i, n)
