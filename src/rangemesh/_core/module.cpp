// rangemesh._core._ext: the compiled kernels. Python keeps the public API, the checks, I/O
// and the pipeline; this module is the bottom layer and knows nothing above it.
#include <nanobind/nanobind.h>

#include "bind/bindings.hpp"
#include "views.hpp"

NB_MODULE(_ext, m) {
    m.doc() = "The compiled kernels of rangemesh (C++17). Callers check shapes and values.";
    nanobind::register_exception_translator([](const std::exception_ptr& p, void*) {
        try {
            std::rethrow_exception(p);
        } catch (const rangemesh::InvariantError& e) {
            PyErr_Format(PyExc_RuntimeError, "rangemesh core: broken invariant: %s", e.what());
        }
    });
    rangemesh::bind::bind_geometry(m);
    rangemesh::bind::bind_geometry_tests(m);
    rangemesh::bind::bind_paper(m);
    rangemesh::bind::bind_heights(m);
    rangemesh::bind::bind_refine(m);
}
