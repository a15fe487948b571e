// rangemesh._core._ext: the compiled kernels. Python keeps the public API, the checks, I/O
// and the pipeline; this module is the bottom layer and knows nothing above it.
#include <nanobind/nanobind.h>

#include <new>
#include <stdexcept>

#include "bind/bindings.hpp"
#include "views.hpp"

NB_MODULE(_ext, m) {
    m.doc() = "The compiled kernels of rangemesh (C++17). Callers check shapes and values.";
    nanobind::register_exception_translator([](const std::exception_ptr& p, void*) {
        try {
            std::rethrow_exception(p);
        } catch (const rangemesh::InvariantError& e) {
            PyErr_Format(PyExc_RuntimeError, "rangemesh core: broken invariant: %s", e.what());
        } catch (const std::bad_alloc&) {
            // (a size beyond what a vector can hold is the same failure, only larger)
            PyErr_SetString(PyExc_MemoryError,
                            "not enough memory: the compiled core could not allocate its arrays; mesh "
                            "a smaller image, with fewer vertices, or on a larger machine");
        } catch (const std::length_error&) {
            PyErr_SetString(PyExc_MemoryError,
                            "not enough memory: the compiled core could not allocate its arrays; mesh "
                            "a smaller image, with fewer vertices, or on a larger machine");
        }
    });
    rangemesh::bind::bind_geometry(m);
    rangemesh::bind::bind_geometry_tests(m);
    rangemesh::bind::bind_paper(m);
    rangemesh::bind::bind_heights(m);
    rangemesh::bind::bind_refine(m);
    rangemesh::bind::bind_refine_mesh(m);
    rangemesh::bind::bind_regions(m);
}
