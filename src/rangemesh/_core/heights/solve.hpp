// The fit's linear system, solved without forming its matrix.
//
// (M + diag(ridge)) x = b + ridge * h0, where M and b gather the faces' blocks (`FaceBlock`)
// onto their vertices and ridge = ridge_share * max(diag(M), 1) pulls each vertex towards its
// copied value h0: it keeps a vertex that no kept pixel touches where it was, and the system
// definite.
#pragma once

#include <cstdint>
#include <vector>

#include "../views.hpp"
#include "system.hpp"

namespace rangemesh::heights {

// The system per vertex: its diagonal and right-hand side (both with the ridge), and the ridge.
struct VertexSystem {
    std::vector<double> diag;
    std::vector<double> rhs;
    std::vector<double> ridge;
};

VertexSystem gather_blocks(Span<const FaceBlock> blocks, Span<const double> h0, double ridge_share);

// Conjugate gradients from h0, preconditioned by the diagonal (Jacobi), until the residual is at
// most `rtol` times the right-hand side's norm or `max_iter` steps; the solution into `x`.
// Returns whether it converged.
bool solve_blocks(Span<const FaceBlock> blocks, Span<const double> h0, double ridge_share, double rtol,
                  index_t max_iter, Span<double> x);
// A face's block packed for the solve's products: symmetric, so six sums, and 32-bit ids; a
// cache line.
struct alignas(64) PackedBlock {
    std::int32_t ids[4];
    double m00, m01, m02, m11, m12, m22;
};

// ... in `room`, 8 x h0.size doubles of any contents (buffers kept from call to call), and with
// `packed` (room for blocks.size, or null) on the blocks packed there when they are symmetric
// bit for bit: the same solution, bit for bit.
bool solve_blocks(Span<const FaceBlock> blocks, Span<const double> h0, double ridge_share, double rtol,
                  index_t max_iter, Span<double> x, double* room, PackedBlock* packed);

}  // namespace rangemesh::heights
