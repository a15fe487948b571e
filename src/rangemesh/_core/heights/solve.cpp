#include "solve.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>

#include "../interrupt.hpp"

namespace rangemesh::heights {

namespace {

// y += (the faces' blocks) x, the matrix never formed: 9 multiply-adds a face (the caller sets
// y to diag(ridge) x first).
void add_block_product(Span<const FaceBlock> blocks, const double* x, double* y) {
    for (const FaceBlock& f : blocks) {
        const index_t a = f.ids[0], b = f.ids[1], c = f.ids[2];
        const double xa = x[a], xb = x[b], xc = x[c];
        y[a] += f.m[0][0] * xa + f.m[0][1] * xb + f.m[0][2] * xc;
        y[b] += f.m[1][0] * xa + f.m[1][1] * xb + f.m[1][2] * xc;
        y[c] += f.m[2][0] * xa + f.m[2][1] * xb + f.m[2][2] * xc;
    }
}

// y += (the faces' packed blocks) x: the product above of symmetric blocks, the same operations
// in the same order on 64 bytes a face instead of 96.
void add_packed_product(Span<const PackedBlock> blocks, const double* x, double* y) {
    for (const PackedBlock& f : blocks) {
        const index_t a = f.ids[0], b = f.ids[1], c = f.ids[2];
        const double xa = x[a], xb = x[b], xc = x[c];
        y[a] += f.m00 * xa + f.m01 * xb + f.m02 * xc;
        y[b] += f.m01 * xa + f.m11 * xb + f.m12 * xc;
        y[c] += f.m02 * xa + f.m12 * xb + f.m22 * xc;
    }
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// The blocks packed into `out`, when each is symmetric bit for bit (the fit's are) and each id
// fits 32 bits; else false.
bool pack(Span<const FaceBlock> blocks, index_t n, PackedBlock* out) {
    if (n > std::numeric_limits<std::int32_t>::max()) return false;
    for (index_t t = 0; t < blocks.size; ++t) {
        const FaceBlock& f = blocks[t];
        if (!same_bits(f.m[1][0], f.m[0][1]) || !same_bits(f.m[2][0], f.m[0][2]) || !same_bits(f.m[2][1], f.m[1][2]))
            return false;
        // (ids in [0, n): gather_into checked them)
        out[t] = PackedBlock{{static_cast<std::int32_t>(f.ids[0]), static_cast<std::int32_t>(f.ids[1]),
                              static_cast<std::int32_t>(f.ids[2])},
                             f.m[0][0],
                             f.m[0][1],
                             f.m[0][2],
                             f.m[1][1],
                             f.m[1][2],
                             f.m[2][2]};
    }
    return true;
}

// The system of `gather_blocks` into diag, rhs and ridge (n each, zeroed by the caller).
void gather_into(Span<const FaceBlock> blocks, Span<const double> h0, double ridge_share, double* diag, double* rhs,
                 double* ridge) {
    const index_t n = h0.size;
    for (const FaceBlock& f : blocks) {
        for (int k = 0; k < 3; ++k) {
            require(0 <= f.ids[k] && f.ids[k] < n, "solve: a block's vertex id is out of range");
            diag[f.ids[k]] += f.m[k][k];
            rhs[f.ids[k]] += f.rhs[k];
        }
    }
    for (index_t i = 0; i < n; ++i) {
        ridge[i] = ridge_share * std::max(diag[i], 1.0);
        rhs[i] += ridge[i] * h0[i];
        diag[i] += ridge[i];
    }
}

}  // namespace

VertexSystem gather_blocks(Span<const FaceBlock> blocks, Span<const double> h0, double ridge_share) {
    const index_t n = h0.size;
    VertexSystem s{std::vector<double>(n, 0.0), std::vector<double>(n, 0.0), std::vector<double>(n, 0.0)};
    gather_into(blocks, h0, ridge_share, s.diag.data(), s.rhs.data(), s.ridge.data());
    return s;
}

bool solve_blocks(Span<const FaceBlock> blocks, Span<const double> h0, double ridge_share, double rtol,
                  index_t max_iter, Span<double> x) {
    const std::unique_ptr<double[]> room(new double[8 * static_cast<std::size_t>(h0.size)]);
    return solve_blocks(blocks, h0, ridge_share, rtol, max_iter, x, room.get(), nullptr);
}

bool solve_blocks(Span<const FaceBlock> blocks, Span<const double> h0, double ridge_share, double rtol,
                  index_t max_iter, Span<double> x, double* room, PackedBlock* packed) {
    require(x.size == h0.size, "solve: one unknown a vertex");
    const std::size_t n = static_cast<std::size_t>(h0.size);
    // the system (diagonal, right-hand side, ridge) and the iterate, residual, preconditioned
    // residual, direction and product in `room`: only the sums start at zero
    double* const sdiag = room;
    double* const rhs = sdiag + n;
    double* const ridge = rhs + n;
    std::fill(sdiag, ridge, 0.0);
    gather_into(blocks, h0, ridge_share, sdiag, rhs, ridge);
    const bool compact = packed != nullptr && pack(blocks, h0.size, packed);
    // y += (the faces' blocks) x
    const auto add_product = [&](const double* in, double* y) {
        if (compact)
            add_packed_product(Span<const PackedBlock>{packed, blocks.size}, in, y);
        else
            add_block_product(blocks, in, y);
    };
    double* const xs = ridge + n;
    double* const r = xs + n;
    double* const z = r + n;
    double* const p = z + n;
    double* const q = p + n;
    std::copy(h0.begin(), h0.end(), xs);
    const double* const diag = sdiag;
    for (std::size_t i = 0; i < n; ++i) r[i] = ridge[i] * xs[i];
    add_product(xs, r);
    // Every sum runs in index order, as a plain dot product would; sums over one loop are
    // independent chains, so fusing them costs one pass of latency, not three.
    double bb = 0.0, rz = 0.0, rr = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        r[i] = rhs[i] - r[i];
        bb += rhs[i] * rhs[i];
        z[i] = r[i] / diag[i];
        p[i] = z[i];
        q[i] = ridge[i] * p[i];
        rz += r[i] * z[i];
        rr += r[i] * r[i];
    }
    const double stop = rtol * std::sqrt(bb);
    bool converged = false;
    for (index_t step = 0;; ++step) {
        if (std::sqrt(rr) <= stop) {
            converged = true;
            break;
        }
        if (step >= max_iter) break;
        poll_interrupt();
        add_product(p, q);  // q = diag(ridge) p, set by the loop before
        double pq = 0.0;
        for (std::size_t i = 0; i < n; ++i) pq += p[i] * q[i];
        if (!(pq > 0.0)) break;  // not positive definite along p (the ridge rules it out), or NaN: stop
        const double alpha = rz / pq;
        double rz_new = 0.0;
        rr = 0.0;
        for (std::size_t i = 0; i < n; ++i) {
            xs[i] += alpha * p[i];
            r[i] -= alpha * q[i];
            z[i] = r[i] / diag[i];
            rz_new += r[i] * z[i];
            rr += r[i] * r[i];
        }
        const double beta = rz_new / rz;
        rz = rz_new;
        for (std::size_t i = 0; i < n; ++i) {
            p[i] = z[i] + beta * p[i];
            q[i] = ridge[i] * p[i];  // the next product's start
        }
    }
    std::copy(xs, xs + n, x.begin());
    return converged;
}

}  // namespace rangemesh::heights
