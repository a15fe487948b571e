// Non-owning views of the arrays the kernels read and write: a pointer, a length, a row width.
// The kernels take these, never Python objects, so they can run with the GIL released and be
// called from C++ as they are.
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>

namespace rangemesh {

using index_t = std::int64_t;

// A 1-D view of `size` contiguous values.
template <class T>
struct Span {
    T* data = nullptr;
    index_t size = 0;

    T& operator[](index_t i) const { return data[i]; }
    T* begin() const { return data; }
    T* end() const { return data + size; }
};

// A 2-D row-major view: `rows` rows of `cols` contiguous values.
template <class T>
struct Grid {
    T* data = nullptr;
    index_t rows = 0;
    index_t cols = 0;

    T& operator()(index_t r, index_t c) const { return data[r * cols + c]; }
    T* row(index_t r) const { return data + r * cols; }
};

// An invariant of a kernel's own state was broken: a bug, never bad input (the callers check
// that). Raised to Python as RuntimeError rather than left to corrupt memory.
struct InvariantError : std::logic_error {
    using std::logic_error::logic_error;
};

inline void require(bool ok, const char* what) {
    if (!ok) throw InvariantError(what);
}

// Input a kernel cannot work on: arrays of mismatched shapes or lengths, ids out of range (a raw
// call of the kernels; the library's own calls never make one). Raised to Python as ValueError.
inline void check_input(bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(what);
}

}  // namespace rangemesh
