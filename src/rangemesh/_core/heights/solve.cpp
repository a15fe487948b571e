#include "solve.hpp"

#include <algorithm>
#include <cmath>

#include "../interrupt.hpp"

namespace rangemesh::heights {

namespace {

// x . y, summed in index order.
double dot(const std::vector<double>& x, const std::vector<double>& y) {
    double s = 0.0;
    for (std::size_t i = 0; i < x.size(); ++i) s += x[i] * y[i];
    return s;
}

// y = (the faces' blocks + diag(ridge)) x, the matrix never formed: 9 multiply-adds a face.
void block_product(Span<const FaceBlock> blocks, const std::vector<double>& ridge, const std::vector<double>& x,
                   std::vector<double>& y) {
    for (std::size_t i = 0; i < x.size(); ++i) y[i] = ridge[i] * x[i];
    for (const FaceBlock& f : blocks) {
        const index_t a = f.ids[0], b = f.ids[1], c = f.ids[2];
        const double xa = x[a], xb = x[b], xc = x[c];
        y[a] += f.m[0][0] * xa + f.m[0][1] * xb + f.m[0][2] * xc;
        y[b] += f.m[1][0] * xa + f.m[1][1] * xb + f.m[1][2] * xc;
        y[c] += f.m[2][0] * xa + f.m[2][1] * xb + f.m[2][2] * xc;
    }
}

}  // namespace

VertexSystem gather_blocks(Span<const FaceBlock> blocks, Span<const double> h0, double ridge_share) {
    const index_t n = h0.size;
    VertexSystem s{std::vector<double>(n, 0.0), std::vector<double>(n, 0.0), std::vector<double>(n, 0.0)};
    for (const FaceBlock& f : blocks) {
        for (int k = 0; k < 3; ++k) {
            require(0 <= f.ids[k] && f.ids[k] < n, "solve: a block's vertex id is out of range");
            s.diag[f.ids[k]] += f.m[k][k];
            s.rhs[f.ids[k]] += f.rhs[k];
        }
    }
    for (index_t i = 0; i < n; ++i) {
        s.ridge[i] = ridge_share * std::max(s.diag[i], 1.0);
        s.rhs[i] += s.ridge[i] * h0[i];
        s.diag[i] += s.ridge[i];
    }
    return s;
}

bool solve_blocks(Span<const FaceBlock> blocks, Span<const double> h0, double ridge_share, double rtol,
                  index_t max_iter, Span<double> x) {
    require(x.size == h0.size, "solve: one unknown a vertex");
    const std::size_t n = static_cast<std::size_t>(h0.size);
    const VertexSystem s = gather_blocks(blocks, h0, ridge_share);
    std::vector<double> xs(h0.begin(), h0.end());  // the iterate, in a vector for the products
    std::vector<double> r(n), z(n), p(n), q(n);
    block_product(blocks, s.ridge, xs, r);
    double bb = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        r[i] = s.rhs[i] - r[i];
        bb += s.rhs[i] * s.rhs[i];
    }
    const double stop = rtol * std::sqrt(bb);
    for (std::size_t i = 0; i < n; ++i) z[i] = r[i] / s.diag[i];
    p = z;
    double rz = dot(r, z);
    bool converged = false;
    for (index_t step = 0;; ++step) {
        if (std::sqrt(dot(r, r)) <= stop) {
            converged = true;
            break;
        }
        if (step >= max_iter) break;
        poll_interrupt();
        block_product(blocks, s.ridge, p, q);
        const double pq = dot(p, q);
        if (pq <= 0.0) break;  // not positive definite along p (the ridge rules it out): stop
        const double alpha = rz / pq;
        for (std::size_t i = 0; i < n; ++i) {
            xs[i] += alpha * p[i];
            r[i] -= alpha * q[i];
            z[i] = r[i] / s.diag[i];
        }
        const double rz_new = dot(r, z);
        const double beta = rz_new / rz;
        rz = rz_new;
        for (std::size_t i = 0; i < n; ++i) p[i] = z[i] + beta * p[i];
    }
    std::copy(xs.begin(), xs.end(), x.begin());
    return converged;
}

}  // namespace rangemesh::heights
