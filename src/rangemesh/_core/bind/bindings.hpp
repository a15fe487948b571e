// One binding function per kernel family; module.cpp calls each.
#pragma once

#include <nanobind/nanobind.h>

#include <vector>

namespace rangemesh::heights {
struct FaceBlock;
}

namespace rangemesh::bind {

// A fit's system as arrays ``(ids (n, 3), block (n, 3, 3), rhs (n, 3))``, one row a face (heights.cpp).
nanobind::tuple face_block_arrays(const std::vector<heights::FaceBlock>& blocks);

void bind_geometry(nanobind::module_& m);
void bind_geometry_tests(nanobind::module_& m);
void bind_paper(nanobind::module_& m);
void bind_heights(nanobind::module_& m);
void bind_refine(nanobind::module_& m);
void bind_refine_mesh(nanobind::module_& m);
void bind_regions(nanobind::module_& m);

}  // namespace rangemesh::bind
