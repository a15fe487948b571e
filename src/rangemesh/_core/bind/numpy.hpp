// NumPy arrays in and out of the kernels: nanobind's ndarray, seen as the kernels' views.
#pragma once

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>

#include <utility>
#include <vector>

#include "../interrupt.hpp"
#include "../views.hpp"

namespace rangemesh::bind {

namespace nb = nanobind;

// C-contiguous arrays on the CPU; nanobind converts other dtypes and layouts on the way in.
template <class T>
using In1 = nb::ndarray<const T, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
template <class T>
using In2 = nb::ndarray<const T, nb::ndim<2>, nb::c_contig, nb::device::cpu>;
// Arrays written in place: the caller's own, never a converted copy.
template <class T>
using Out1 = nb::ndarray<T, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
template <class T>
using Out2 = nb::ndarray<T, nb::ndim<2>, nb::c_contig, nb::device::cpu>;

template <class A>
auto span(const A& a) {
    using T = std::remove_reference_t<decltype(*a.data())>;
    return Span<T>{a.data(), static_cast<index_t>(a.shape(0))};
}

template <class A>
auto grid(const A& a) {
    using T = std::remove_reference_t<decltype(*a.data())>;
    return Grid<T>{a.data(), static_cast<index_t>(a.shape(0)), static_cast<index_t>(a.shape(1))};
}

// Whether two arrays have the same shape.
template <class A, class B>
bool same_shape(const A& a, const B& b) {
    if (a.ndim() != b.ndim()) return false;
    for (std::size_t k = 0; k < a.ndim(); ++k)
        if (a.shape(k) != b.shape(k)) return false;
    return true;
}

// An array's element count: the work `run_released` weighs.
template <class A>
index_t work(const A& a) {
    return static_cast<index_t>(a.size());
}

// A NumPy array that takes over `values` (no copy), shaped (n) or (rows, cols).
template <class T>
nb::ndarray<nb::numpy, T> to_numpy(std::vector<T>&& values, std::size_t rows, std::size_t cols = 0) {
    auto* owned = new std::vector<T>(std::move(values));
    nb::capsule owner(owned, [](void* p) noexcept {
        auto* v = static_cast<std::vector<T>*>(p);
        free_later(*v);  // a gigabyte's pages on a thread of their own: Python is not kept waiting
        delete v;
    });
    if (cols == 0) {
        std::size_t shape[1] = {rows};
        return nb::ndarray<nb::numpy, T>(owned->data(), 1, shape, owner);
    }
    std::size_t shape[2] = {rows, cols};
    return nb::ndarray<nb::numpy, T>(owned->data(), 2, shape, owner);
}

template <class T>
nb::ndarray<nb::numpy, T> to_numpy(std::vector<T>&& values) {
    const std::size_t n = values.size();
    return to_numpy(std::move(values), n);
}

// A NumPy view of a result's values, (n) or (n / cols, cols): the Python object that owns the
// vector keeps it alive (bind it with nb::rv_policy::reference_internal).
template <class T>
nb::ndarray<nb::numpy, T> view_of(std::vector<T>& v) {
    const std::size_t shape[1] = {v.size()};
    return nb::ndarray<nb::numpy, T>(v.data(), 1, shape, nb::handle());
}

template <class T>
nb::ndarray<nb::numpy, T> rows_of(std::vector<T>& v, std::size_t cols) {
    const std::size_t shape[2] = {v.size() / cols, cols};
    return nb::ndarray<nb::numpy, T>(v.data(), 2, shape, nb::handle());
}

// A property's getter of a vector member of C as a NumPy view, (n) or (n / cols, cols): bind it
// with nb::rv_policy::reference_internal, so that the Python object keeps the vector alive.
template <class C, class V>
auto array_of(V C::* member, std::size_t cols = 0) {
    return [member, cols](C& owner) { return cols == 0 ? view_of(owner.*member) : rows_of(owner.*member, cols); };
}

// A property's getter of a member by value, an array (or an optional one) the result holds: bind
// it with nb::rv_policy::move.
template <class C, class V>
auto value_of(V C::* member) {
    return [member](const C& owner) { return owner.*member; };
}

}  // namespace rangemesh::bind
