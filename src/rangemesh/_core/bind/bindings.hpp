// One binding function per kernel family; module.cpp calls each.
#pragma once

#include <nanobind/nanobind.h>

namespace rangemesh::bind {

void bind_geometry(nanobind::module_& m);
void bind_geometry_tests(nanobind::module_& m);
void bind_paper(nanobind::module_& m);
void bind_heights(nanobind::module_& m);
void bind_refine(nanobind::module_& m);
void bind_refine_mesh(nanobind::module_& m);
void bind_regions(nanobind::module_& m);

}  // namespace rangemesh::bind
