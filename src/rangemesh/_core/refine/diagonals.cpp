#include "diagonals.hpp"

#include <vector>

#include "../geometry/halfedges.hpp"
#include "../geometry/ownership.hpp"
#include "../geometry/predicates.hpp"
#include "../geometry/raster.hpp"
#include "../interrupt.hpp"
#include "keys.hpp"

namespace rangemesh::refine {

double triangle_error(const Image& image, const Point& a, const Point& b, const Point& c, EdgeOwnership own,
                      double base, double stop) {
    const bool stops = stop < std::numeric_limits<double>::infinity();
    // a cheap bound first: only a sum of at least (stop - 0.5) key steps can quantise to stop
    const double cut = stops ? (stop - 0.5) * image.span / KEY_STEPS : std::numeric_limits<double>::infinity();
    double total = 0.0;
    plane_errors(
        image, a, b, c, own, [&](index_t, index_t, double err) { total += err; },
        [&] { return !(base + total >= cut && quantize(base + total, image.span) >= stop); });
    return total;
}

namespace {

// The flips' working state: the mesh, its vertex depths, the stack of edges to test.
class Flipper {
  public:
    Flipper(const Image& image, const FlipMesh& mesh, bool checked = true) : image_(image), m_(mesh) {
        require(mesh.vc.size == mesh.vr.size && mesh.halfedges.size == mesh.triangles.size &&
                    mesh.triangles.size == 3 * mesh.sums.size,
                "flips: one column a vertex, one twin a half-edge, one sum a triangle");
        const FreeLater late(on_throw, vz_, queued_, stack_);  // (no destructor when stopped here)
        const index_t n_v = mesh.vr.size;
        if (!checked) {  // the caller's own arrays, checked when made: the depths alone
            fill_polled(vz_, n_v, 0.0);
            for (index_t v = 0; v < n_v; ++v) {
                poll_every(v);
                if (valid(v)) vz_[v] = image.depth(mesh.vr[v], mesh.vc[v]);
            }
            fill_polled(queued_, mesh.triangles.size, static_cast<unsigned char>(0));
            stack_.reserve(mesh.triangles.size);
            return;
        }
        for (index_t k = 0; k < mesh.triangles.size; ++k) {
            poll_every(k);
            check_input(0 <= mesh.triangles[k] && mesh.triangles[k] < n_v, "flips: a corner id out of range");
        }
        // a flip writes through the twins (`link`): a twin below -1 would write before the array
        const Span<const index_t> tri{mesh.triangles.data, mesh.triangles.size};
        const Span<const index_t> he{mesh.halfedges.data, mesh.halfedges.size};
        for (index_t k = 0; k < mesh.triangles.size; ++k) {
            poll_every(k);
            check_input(twin_ok(tri, he, k),
                        "flips: a twin below -1 or out of range, or twins that do not run back along one edge");
        }
        // the vertex depths; triangles with a background vertex get sum -1 (never flipped)
        fill_polled(vz_, n_v, 0.0);
        for (index_t v = 0; v < n_v; ++v) {
            poll_every(v);
            check_input(0 <= mesh.vr[v] && mesh.vr[v] < image.rows() && 0 <= mesh.vc[v] && mesh.vc[v] < image.cols(),
                        "flips: the vertices must be pixels of the image");
            if (valid(v)) vz_[v] = image.depth(mesh.vr[v], mesh.vc[v]);
        }
        const index_t n_t = mesh.sums.size;
        for (index_t t = 0; t < n_t; ++t) {
            poll_every(t);
            if (!all_valid(t)) mesh.sums[t] = -1.0;
        }
        fill_polled(queued_, mesh.triangles.size, static_cast<unsigned char>(0));
        stack_.reserve(mesh.triangles.size);
    }

    ~Flipper() { free_later(vz_, queued_, stack_); }
    Flipper(const Flipper&) = delete;
    Flipper& operator=(const Flipper&) = delete;

    bool valid(index_t v) const { return image_.valid(m_.vr[v], m_.vc[v]); }
    bool all_valid(index_t t) const {
        return valid(m_.triangles[3 * t]) && valid(m_.triangles[3 * t + 1]) && valid(m_.triangles[3 * t + 2]);
    }

    Point point(index_t v) const { return {m_.vr[v], m_.vc[v], vz_[v]}; }

    bool owns(index_t e, const Point& p, const Point& q) const {
        return own_edge(m_.halfedges[e], p.r, p.c, q.r, q.c, image_.cols());
    }

    // The error sum of triangle t over the pixels it owns.
    double face_error(index_t t) const {
        const index_t e = 3 * t;
        const Point a = point(m_.triangles[e]), b = point(m_.triangles[e + 1]), c = point(m_.triangles[e + 2]);
        return triangle_error(image_, a, b, c, {owns(e, a, b), owns(e + 1, b, c), owns(e + 2, c, a)});
    }

    // Put e on the stack unless its edge is there already.
    void push(index_t e) {
        const index_t g = m_.halfedges[e];
        if (g >= 0 && !queued_[e] && !queued_[g]) {
            stack_.push_back(e);
            queued_[e] = 1;
        }
    }

    // Every interior edge between two triangles that may flip, popped in order of e.
    void push_all() {
        for (index_t e = m_.triangles.size - 1; e >= 0; --e) {
            poll_every(e);
            const index_t g = m_.halfedges[e];
            if (g > e && m_.sums[e / 3] >= 0.0 && m_.sums[g / 3] >= 0.0) {
                stack_.push_back(e);
                queued_[e] = 1;
            }
        }
    }

    // The half-edges `first`, popped in the order given, their triangles' sums afresh.
    void push_first(Span<const index_t> first) {
        for (const index_t e : first) {
            poll_interrupt();
            check_input(0 <= e && e < m_.triangles.size, "flips: a first half-edge out of range");
            for (const index_t g : {e, m_.halfedges[e]})
                if (g >= 0 && m_.sums[g / 3] >= 0.0) m_.sums[g / 3] = face_error(g / 3);
        }
        for (index_t i = first.size - 1; i >= 0; --i) push(first[i]);
    }

    // Test the edges on the stack, flipping those whose error drops.
    FlipCount run() {
        FlipCount count;
        const index_t max_tests = MAX_TESTS_PER_EDGE * static_cast<index_t>(stack_.size());
        const double span = image_.span;
        const Span<index_t> tri = m_.triangles, he = m_.halfedges;
        while (!stack_.empty() && count.tests < max_tests) {
            if (count.tests % 256 == 0) poll_interrupt();
            const index_t e0 = stack_.back();
            stack_.pop_back();
            queued_[e0] = 0;
            if (he[e0] < 0) continue;
            const Quad q(Span<const index_t>{he.data, he.size}, e0);
            const index_t t0 = q.e0 / 3, t1 = q.e1 / 3;
            if (m_.sums[t0] < 0.0 || m_.sums[t1] < 0.0) continue;
            const double old = quantize(m_.sums[t0] + m_.sums[t1], span);
            if (old == 0.0) continue;  // nothing to gain
            const Point a = point(tri[q.e0]), b = point(tri[q.b0]), c = point(tri[q.c0]), d = point(tri[q.c1]);
            // ABC + BAD -> DCA + CDB: both counter-clockwise only when the quad is convex
            if (orient(d.r, d.c, c.r, c.c, a.r, a.c) <= 0 || orient(c.r, c.c, d.r, d.c, b.r, b.c) <= 0) continue;
            ++count.tests;
            const bool own_dc = rangemesh::owns(d.r, d.c, c.r, c.c);
            // each scan stops once the other diagonal is known to be no better
            const double s0 = triangle_error(image_, d, c, a, {own_dc, owns(q.c0, c, a), owns(q.b1, a, d)}, 0.0, old);
            if (quantize(s0, span) >= old) continue;
            const double s1 = triangle_error(image_, c, d, b, {!own_dc, owns(q.c1, d, b), owns(q.b0, b, c)}, s0, old);
            if (quantize(s0 + s1, span) >= old) continue;
            flip_quad(tri, he, q.e0);
            m_.sums[t0] = s0;
            m_.sums[t1] = s1;
            ++count.flips;
            // the quad's four outer edges: their other triangles now face new ones
            for (const index_t f : {nxt(q.e0), prv(q.e0), nxt(q.e1), prv(q.e1)}) push(f);
        }
        return count;
    }

  private:
    const Image& image_;
    FlipMesh m_;
    std::vector<double> vz_;
    std::vector<unsigned char> queued_;
    std::vector<index_t> stack_;
};

}  // namespace

FlipCount flip_by_error(const Image& image, const FlipMesh& mesh) {
    Flipper f(image, mesh);
    f.push_all();
    return f.run();
}

FlipCount flip_from_edges(const Image& image, const FlipMesh& mesh, Span<const index_t> first, bool checked) {
    Flipper f(image, mesh, checked);
    f.push_first(first);
    return f.run();
}

void face_errors(const Image& image, const FlipMesh& mesh) {
    Flipper f(image, mesh);  // sums -1 where a corner is background
    for (index_t t = 0; t < mesh.sums.size; ++t) {
        poll_interrupt();  // a scan a triangle: a poll is nothing beside it
        mesh.sums[t] = f.all_valid(t) ? f.face_error(t) : 0.0;
    }
}

}  // namespace rangemesh::refine
