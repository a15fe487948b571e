#include "insertion.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "../geometry/halfedges.hpp"
#include "../geometry/heap.hpp"
#include "../geometry/ownership.hpp"
#include "../geometry/predicates.hpp"
#include "../interrupt.hpp"
#include "keys.hpp"

namespace rangemesh::refine {

bool Plane::holds(index_t pr, index_t pc, double pz, double span) const {
    const double x = static_cast<double>(pr), y = static_cast<double>(pc);
    const double zp = (orient(r[1], c[1], r[2], c[2], x, y) * z[0] + orient(r[2], c[2], r[0], c[0], x, y) * z[1] +
                       orient(r[0], c[0], r[1], c[1], x, y) * z[2]) /
                      orient(r[0], c[0], r[1], c[1], r[2], c[2]);
    return quantize(std::abs(pz - zp), span) == 0.0;
}

// A thread's arrays of its last insertion of at most KEPT_BYTES, emptied (`full`: held), or none.
// A taken set leaves none behind, so an insertion that throws leaves nothing stale here.
struct Insertion::Kept {
    static constexpr std::size_t KEPT_BYTES = std::size_t{1} << 20;  // a 2000-pixel image's: some 100 kB
    std::vector<index_t> vr, vc;
    std::vector<double> vz;
    std::vector<unsigned char> vbg;
    std::vector<Vertex> vx;
    std::vector<index_t> tv, he;
    std::vector<TriangleKey> keyed;
    std::vector<HeapLine> heap;
    std::vector<index_t> slot, changed, stack, once;
    bool full = false;

    static Kept& of_thread() {
        static thread_local Kept kept;
        return kept;
    }
};

template <class F>
void Insertion::pair_arrays(Kept& k, F&& f) noexcept {
    f(vr_, k.vr), f(vc_, k.vc), f(vz_, k.vz), f(vbg_, k.vbg), f(vx_, k.vx), f(tv_, k.tv), f(he_, k.he);
    f(keyed_, k.keyed), f(heap_, k.heap), f(slot_, k.slot), f(changed_, k.changed), f(stack_, k.stack);
    f(once_, k.once);
}

void Insertion::take_kept() noexcept {
    Kept& k = Kept::of_thread();
    if (!k.full) return;
    pair_arrays(k, [](auto& mine, auto& kept) { mine.swap(kept); });
    k.full = false;
}

// This insertion's arrays, emptied, as the thread's kept ones when they are small and the thread
// keeps none; false when not (a moved-from insertion has none to give).
bool Insertion::give_back() noexcept {
    Kept& k = Kept::of_thread();
    std::size_t bytes = 0;
    pair_arrays(k, [&bytes](auto& mine, auto&) { bytes += mine.capacity() * sizeof(mine[0]); });
    if (k.full || bytes == 0 || bytes > Kept::KEPT_BYTES) return false;
    // (k's arrays are empty while it holds none: those a taker left)
    pair_arrays(k, [](auto& mine, auto& kept) {
        mine.clear();
        mine.swap(kept);
    });
    k.full = true;
    return true;
}

Insertion::Insertion(const Image& image, const FirstMesh& first, index_t reserve, index_t sr, index_t sc, bool scan)
    : image_(image), sr_(sr), sc_(sc) {
    take_kept();
    // stopped half way, no destructor runs: the arrays made so far are freed later all the same
    const FreeLater late(on_throw, vr_, vc_, vz_, vbg_, vx_, tv_, he_, keyed_, heap_, slot_);
    // (compared by division: (rows - 1) * sr overflows for a huge scale)
    check_input(sr >= 1 && sc >= 1 && image.rows() - 1 <= EXACT_SPAN / sr && image.cols() - 1 <= EXACT_SPAN / sc,
                "greedy_insert: the image, times its Delaunay scales sr and sc (>= 1), within EXACT_SPAN a side");
    const index_t n_v = first.vr.size;
    require(first.vc.size == n_v && first.vz.size == n_v, "first mesh: one row, column and depth a vertex");
    require(first.triangles.size % 3 == 0 && first.halfedges.size == first.triangles.size,
            "first mesh: three corners and three twins a triangle");
    for (index_t i = 0; i < n_v; ++i)
        require(0 <= first.vr[i] && first.vr[i] < image.rows() && 0 <= first.vc[i] && first.vc[i] < image.cols(),
                "first mesh: vertices on the image's pixels");
    for (index_t k = 0; k < first.triangles.size; ++k)
        require(0 <= first.triangles[k] && first.triangles[k] < n_v, "first mesh: corners in range");
    // the flips follow the twins and the splits need area: twins that do not pair up, or a
    // triangle turned the wrong way, make an insertion that never ends (its arrays growing)
    for (index_t k = 0; k < first.triangles.size; ++k) {
        poll_every(k);
        check_input(twin_ok(first.triangles, first.halfedges, k),
                    "greedy_insert: the first mesh's twins must pair up (he[he[e]] == e, in [-1, len), back along "
                    "one edge)");
    }
    for (index_t k = 0; k < first.triangles.size; k += 3) {
        poll_every(k);
        const index_t a = first.triangles[k], b = first.triangles[k + 1], c = first.triangles[k + 2];
        check_input(orient(first.vr[a], first.vc[a], first.vr[b], first.vc[b], first.vr[c], first.vc[c]) > 0,
                    "greedy_insert: the first mesh's triangles must be counter-clockwise in (row, column)");
    }
    n_t_ = first.triangles.size / 3;
    // no more vertices than pixels: a larger reserve (a raw call's INT64_MAX) buys nothing
    reserve = std::min(std::max<index_t>(reserve, 0), image.rows() * image.cols());
    // a small floor: the triangle arrays are zeroed, and on a small image that costs more than the work
    const index_t cap_v = std::max({index_t(16), 2 * n_v, n_v + reserve + 8});
    const index_t cap_t = 2 * cap_v + 8;
    vr_.reserve(cap_v);
    vc_.reserve(cap_v);
    vz_.reserve(cap_v);
    vbg_.reserve(cap_v);
    vx_.reserve(cap_v);
    for (index_t i = 0; i < n_v; ++i) {
        const bool background = !image.valid(first.vr[i], first.vc[i]);
        if (background && i >= 4)
            throw std::invalid_argument("greedy_insert: only the first four vertices may be background");
        add_vertex(first.vr[i], first.vc[i], first.vz[i], background);
        if (!background) ++n_valid_v_;
    }
    tv_.assign(first.triangles.begin(), first.triangles.end());
    he_.assign(first.halfedges.begin(), first.halfedges.end());
    first_cap_t_ = cap_t;
    if (scan)
        scan_first();
    else
        reserve_triangles(cap_t);
}

void Insertion::scan_first() {
    require(first_cap_t_ > 0, "insertion: the first mesh is scanned once");
    resize_triangles(first_cap_t_);
    first_cap_t_ = 0;
    const QuadHeapView heap = this->heap();
    for (index_t t = 0; t < n_t_; ++t) {
        poll_interrupt();
        keyed_[t] = scan(t);
        total_ += keyed_[t].sum;
        heap.push(t, keyed_[t].key, n_heap_);
    }
}

void Insertion::add_vertex(index_t r, index_t c, double z, bool background) {
    vr_.push_back(r);
    vc_.push_back(c);
    vz_.push_back(z);
    vbg_.push_back(background);
    vx_.push_back(Vertex{static_cast<std::int32_t>(r), static_cast<std::int32_t>(c), z});
}

// Under an error bound the arrays reach gigabytes: freed on a thread of their own.
Insertion::~Insertion() {
    if (!give_back()) free_later(vr_, vc_, vz_, vbg_, vx_, tv_, he_, keyed_, heap_, slot_);
}

TriangleKey Insertion::scan(index_t t) const {
    const index_t e = 3 * t;
    const Corner a = corner(tv_[e]), b = corner(tv_[e + 1]), c = corner(tv_[e + 2]);
    // pixels on an edge: the image border's always, a shared edge's by one side only
    const index_t w = image_.cols();
    const EdgeOwnership own{own_edge(he_[e], a.r, a.c, b.r, b.c, w), own_edge(he_[e + 1], b.r, b.c, c.r, c.c, w),
                            own_edge(he_[e + 2], c.r, c.c, a.r, a.c, w)};
    return scan_triangle(image_, a, b, c, own);
}

// Ask the caches for what a rescan of triangle t reads and writes: the depth and valid rows of
// its bounding box and its key row. A step rescans about six small triangles scattered over the
// image, a few rows each, and each met its lines cold, one wait after the other; asked for all
// at once, the waits overlap. (Inlined: a call of its own cost more than its branches.)
inline void Insertion::prefetch_rescan(index_t t) const {
#if defined(__GNUC__) || defined(__clang__)
    __builtin_prefetch(&keyed_[t], 1);
    const Vertex &a = vx_[tv_[3 * t]], &b = vx_[tv_[3 * t + 1]], &c = vx_[tv_[3 * t + 2]];
    // (ternaries, not std::min of a list: those compile to branches that mispredict)
    const std::int32_t rab0 = a.r < b.r ? a.r : b.r, rab1 = a.r < b.r ? b.r : a.r;
    const std::int32_t cab0 = a.c < b.c ? a.c : b.c, cab1 = a.c < b.c ? b.c : a.c;
    const index_t r0 = rab0 < c.r ? rab0 : c.r, r1 = rab1 < c.r ? c.r : rab1;
    const index_t c0 = cab0 < c.c ? cab0 : c.c, c1 = cab1 < c.c ? c.c : cab1;
    if (r1 - r0 > 32) return;  // a large triangle: its rows are long, streamed by the hardware
    const index_t w = image_.cols();
    const double* d = image_.depth.row(r0);
    const bool* v = image_.valid.row(r0);
    for (index_t r = r0; r <= r1; ++r, d += w, v += w) {
        __builtin_prefetch(d + c0);
        __builtin_prefetch(d + c1);
        __builtin_prefetch(v + c0);
    }
#else
    (void)t;
#endif
}

// A child of an exactly fitting triangle split at its centroid fits the parent's plane: its key
// is `spread_key` and its pixel its centroid, no scan needed. False when that centroid is no
// valid inside pixel (the child must then be scanned).
bool Insertion::fit_child(index_t t, TriangleKey& out) const {
    const index_t ia = tv_[3 * t], ib = tv_[3 * t + 1], ic = tv_[3 * t + 2];
    const Pixel p = centroid_pixel(vr_[ia], vc_[ia], vr_[ib], vc_[ib], vr_[ic], vc_[ic], image_.valid);
    if (p.r < 0) return false;
    out.key = spread_key(orient(vr_[ia], vc_[ia], vr_[ib], vc_[ib], vr_[ic], vc_[ic]), image_.rows(), image_.cols());
    out.r = static_cast<std::int32_t>(p.r);
    out.c = static_cast<std::int32_t>(p.c);
    out.sum = 0.0;
    out.fits = true;
    return true;
}

// Room for one more vertex and up to two more triangles: the arrays double when full.
void Insertion::make_room() {
    if (vr_.size() == vr_.capacity()) {
        const std::size_t cap_v = 2 * vr_.capacity();
        reserve_polled(vr_, cap_v);
        reserve_polled(vc_, cap_v);
        reserve_polled(vz_, cap_v);
        reserve_polled(vbg_, cap_v);
        reserve_polled(vx_, cap_v);
    }
    const index_t cap_t = static_cast<index_t>(keyed_.size());
    if (n_t_ + 2 <= cap_t) return;
    resize_triangles(2 * cap_t);
}

// Every per-triangle array sized for `cap_t` triangles; new slots hold no triangle. Hundreds of
// megabytes for millions of vertices: grown with polls, so Ctrl-C is not kept waiting.
void Insertion::resize_triangles(index_t cap_t) {
    grow_polled(tv_, 3 * cap_t, index_t{0});
    grow_polled(he_, 3 * cap_t, index_t{-1});
    grow_polled(keyed_, cap_t);
    grow_polled(heap_, static_cast<std::size_t>(QuadHeapView::lines_for(cap_t)));
    grow_polled(slot_, cap_t, index_t{0});
}

// Room for `cap_t` triangles in every per-triangle array, none of it written.
void Insertion::reserve_triangles(index_t cap_t) {
    reserve_polled(tv_, static_cast<std::size_t>(3 * cap_t));
    reserve_polled(he_, static_cast<std::size_t>(3 * cap_t));
    reserve_polled(keyed_, static_cast<std::size_t>(cap_t));
    reserve_polled(heap_, static_cast<std::size_t>(QuadHeapView::lines_for(cap_t)));
    reserve_polled(slot_, static_cast<std::size_t>(cap_t));
}

void Insertion::new_triangle(index_t t, index_t a, index_t b, index_t c) {
    tv_[3 * t] = a;
    tv_[3 * t + 1] = b;
    tv_[3 * t + 2] = c;
    he_[3 * t] = he_[3 * t + 1] = he_[3 * t + 2] = -1;
}

// A new vertex at valid pixel (r, c), with room made for the triangles its insertion adds.
index_t Insertion::add_pixel_vertex(index_t r, index_t c) {
    // vertices are distinct pixels: one more than the pixels is a mesh gone wrong
    require(n_vertices() < image_.rows() * image_.cols(), "insertion: more vertices than pixels");
    make_room();
    const index_t p = n_vertices();
    add_vertex(r, c, image_.depth(r, c), false);
    ++n_valid_v_;
    return p;
}

// One side of an edge A -> B split at `p`: triangle `x` (was ABC) becomes APC and `y` is PBC,
// linked to the outer half-edges `h_bc` (B -> C's twin) and `h_ca` and to each other.
void Insertion::split_side(index_t x, index_t y, const Corners& abc, index_t p, index_t h_bc, index_t h_ca) {
    const Span<index_t> he{he_.data(), static_cast<index_t>(he_.size())};
    new_triangle(x, abc.a, p, abc.c);
    new_triangle(y, p, abc.b, abc.c);
    link(he, 3 * x + 2, h_ca);
    link(he, 3 * y + 1, h_bc);
    link(he, 3 * x + 1, 3 * y + 2);
    changed_.insert(changed_.end(), {x, y});
}

// Insert vertex `p`, inside triangle `t` or on one of its edges, then legalize the edges
// opposite p. Records the triangles made or flipped in `changed_`; `n_t_` grows by 2 (inside,
// or on an inner edge) or 1 (on a hull edge).
void Insertion::insert(index_t t, index_t p, const Plane* guard) {
    const Span<index_t> he{he_.data(), static_cast<index_t>(he_.size())};
    const index_t e = 3 * t;
    // the flips below test the far corner of each neighbour: asked for at once, their cache
    // misses overlap instead of waiting one after the other in legalize's loop
#if defined(__GNUC__) || defined(__clang__)
    for (int k = 0; k < 3; ++k) {
        const index_t h = he_[e + k];
        if (h >= 0) __builtin_prefetch(&vx_[tv_[prv(h)]]);
    }
#endif
    const index_t pr = vr_[p], pc = vc_[p];
    int on = -1;
    for (int k = 0; k < 3; ++k) {
        const index_t a = tv_[e + k], b = tv_[e + (k + 1) % 3];
        if (orient<index_t>(vx_[a].r, vx_[a].c, vx_[b].r, vx_[b].c, pr, pc) == 0) on = k;
    }
    changed_.clear();
    if (on < 0) {  // ABC -> ABP, BCP, CAP
        const index_t a = tv_[e], b = tv_[e + 1], c = tv_[e + 2];
        const index_t h_ab = he_[e], h_bc = he_[e + 1], h_ca = he_[e + 2];
        const index_t t1 = n_t_, t2 = n_t_ + 1;
        new_triangle(t, a, b, p);
        new_triangle(t1, b, c, p);
        new_triangle(t2, c, a, p);
        link(he, 3 * t, h_ab);
        link(he, 3 * t1, h_bc);
        link(he, 3 * t2, h_ca);
        link(he, 3 * t + 1, 3 * t1 + 2);
        link(he, 3 * t1 + 1, 3 * t2 + 2);
        link(he, 3 * t2 + 1, 3 * t + 2);
        changed_.insert(changed_.end(), {t, t1, t2});
        n_t_ += 2;
        for (const index_t s : {3 * t, 3 * t1, 3 * t2}) legalize(s, guard);
        return;
    }
    // on the edge A -> B of t, opposite C: ABC -> APC, PBC (and its twin's BAD -> BPD, PAD)
    const index_t ea = e + on;
    const index_t a = tv_[ea], b = tv_[e + (on + 1) % 3], c = tv_[e + (on + 2) % 3];
    const index_t h_bc = he_[e + (on + 1) % 3], h_ca = he_[e + (on + 2) % 3];
    const index_t tw = he_[ea];
    const index_t t1 = n_t_;
    split_side(t, t1, {a, b, c}, p, h_bc, h_ca);
    index_t outer[4] = {3 * t + 2, 3 * t1 + 1, -1, -1};
    int n_outer = 2;
    n_t_ += 1;
    if (tw >= 0) {
        const index_t u = tw / 3;
        const index_t d = tv_[prv(tw)];
        const index_t h_ad = he_[nxt(tw)], h_db = he_[prv(tw)];
        const index_t t3 = n_t_;
        split_side(u, t3, {b, a, d}, p, h_ad, h_db);
        link(he, 3 * u, 3 * t1);  // B -> P with P -> B
        link(he, 3 * t3, 3 * t);  // P -> A with A -> P
        outer[2] = 3 * u + 2;
        outer[3] = 3 * t3 + 1;
        n_outer = 4;
        n_t_ += 1;
    }
    for (int i = 0; i < n_outer; ++i) legalize(outer[i], guard);
}

namespace {

// `nxt` and `prv` in arithmetic, no branch: which slot a twin half-edge takes is a coin toss
// to the branch predictor.
inline index_t next_he(index_t e) { return e + 1 - 3 * static_cast<index_t>(e % 3 == 2); }
inline index_t prev_he(index_t e) { return e - 1 + 3 * static_cast<index_t>(e % 3 == 0); }

}  // namespace

// Lawson flips from half-edge `e0`, whose opposite vertex is the new point P. Half-edge a runs
// A -> B in triangle ABC (C = P), its twin b runs B -> A in BAD:
//
//            C                          C
//          /   .                      / | .
//        /   a   .                  /   |   .
//      A ---------> B     flip    A  a  |  b  B
//        .   b   /       ----->     .   |   /
//          .   /                      . | /
//            D                          D
//
// The flip is `flip_quad`'s: afterwards slot a runs D -> C in triangle DCA, slot b C -> D in
// CDB (the new diagonal keeps the old one's slots), prv(a) A -> D and nxt(b) D -> B are the edges
// now opposite C. With `guard` (the split triangle fits exactly, its corners in the plane), an edge whose
// far triangle fits exactly or holds no pixel to insert is flipped only when D lies on that
// plane: flipping it would join two planes in one triangle.
void Insertion::legalize(index_t e0, const Plane* guard) {
    const Span<index_t> he{he_.data(), static_cast<index_t>(he_.size())};
    stack_.clear();
    stack_.push_back(e0);
    // each flip gives the new point an edge: more flips than triangles is a mesh gone wrong
    index_t flips = 0;
    while (!stack_.empty()) {
        const index_t a = stack_.back();
        stack_.pop_back();
        const index_t b = he_[a];
        if (b < 0) continue;
        const index_t al = next_he(a), ar = prev_he(a), bn = next_he(b), bp = prev_he(b);
        const Vertex& pa = vx_[tv_[a]];
        const Vertex& pb = vx_[tv_[al]];
        const Vertex& pc = vx_[tv_[ar]];
        const Vertex& pd = vx_[tv_[bp]];
        if (incircle<index_t>(sr_ * pa.r, sc_ * pa.c, sr_ * pb.r, sc_ * pb.c, sr_ * pc.r, sc_ * pc.c, sr_ * pd.r,
                              sc_ * pd.c) <= 0)
            continue;
        if (guard && keyed_[b / 3].key < SMALL_KEY && !guard->holds(pd.r, pd.c, pd.z, image_.span)) continue;
        require(++flips <= n_t_, "insertion: more flips around a new vertex than triangles");
        flip_quad({tv_.data(), static_cast<index_t>(tv_.size())}, he, a);
        changed_.push_back(a / 3);
        changed_.push_back(b / 3);
        stack_.push_back(bn);  // (C, D, B): D -> B is opposite C
        stack_.push_back(ar);  // (D, C, A): A -> D is opposite C, tested first
    }
}

// Whether an exact split left only triangles that fit exactly, so none needs a scan: the
// triangles it changed tile what it replaced (the split triangle and the flipped neighbours,
// which keep their ids below `old_t`); when each of those fitted exactly and every corner of
// the new ones lies on the split triangle's plane, every new triangle fits too.
bool Insertion::flat_cavity(index_t t, index_t old_t, const Plane& plane) const {
    for (std::size_t i = 3; i < changed_.size(); ++i) {
        const index_t s = changed_[i];
        if (s != t && s < old_t && !(0.0 < keyed_[s].key && keyed_[s].key < SMALL_KEY)) return false;
    }
    for (const index_t s : changed_)
        for (int k = 0; k < 3; ++k) {
            const index_t v = tv_[3 * s + k];
            if (!plane.holds(vr_[v], vc_[v], vz_[v], image_.span)) return false;
        }
    return true;
}

// Whether changed_[i] was met before it, visiting the list backwards when `backwards`: a step
// changes about ten triangles, and a search of that short list stays in cache where a stamp
// per triangle cost a cache miss a triangle.
bool Insertion::visited_before(index_t i, bool backwards) const {
    const index_t s = changed_[i], n = static_cast<index_t>(changed_.size());
    for (index_t j = backwards ? i + 1 : 0; j < (backwards ? n : i); ++j)
        if (changed_[j] == s) return true;
    return false;
}

void Insertion::rekey(index_t t, const TriangleKey& k) {
    keyed_[t] = k;
    heap().rekey(t, k.key, n_heap_);
}

void Insertion::advance(const Stop& stop) {
    while (n_heap_ > 0 && n_valid_v_ < stop.max_vertices) {
        poll_interrupt();
        const index_t t = top();
        const double key = keyed_[t].key;
        // (a negative max_sum is no stop: the running sum of huge errors may round below 0)
        if (key < 0.0 || key < stop.min_key || (key <= COVER_KEY && stop.max_sum >= 0.0 && total_ <= stop.max_sum))
            break;
        const index_t p = add_pixel_vertex(keyed_[t].r, keyed_[t].c);
        const index_t old_t = n_t_;
        // the centroid of a triangle that fits exactly: its three children fit too
        const bool split_fit = keyed_[t].fits;
        Plane plane{};
        const bool guard = 0.0 < key && key < SMALL_KEY;  // an exact split: keep it exact
        if (guard)
            for (int k = 0; k < 3; ++k) {
                const index_t v = tv_[3 * t + k];
                plane.r[k] = static_cast<double>(vr_[v]);
                plane.c[k] = static_cast<double>(vc_[v]);
                plane.z[k] = vz_[v];
            }
        insert(t, p, guard ? &plane : nullptr);
        // ... and so does every triangle the flips made, when each triangle they replaced
        // fitted exactly and every corner lies on the split triangle's plane
        const bool flat = split_fit && flat_cavity(t, old_t, plane);
        // new triangles join the heap once keyed below (its order is strict, so when an entry
        // joins does not change what it pops); their sums start at 0 for the running total
        for (index_t s = old_t; s < n_t_; ++s) keyed_[s].sum = 0.0;
        // each changed triangle once, in the order the scans add to the running total: the
        // flipped triangles (listed after the three) first after an exact split, whose
        // children are keyed without a scan unless a flip changed them
        const index_t n_changed = static_cast<index_t>(changed_.size());
        once_.clear();
        for (index_t j = 0; j < n_changed; ++j) {
            const index_t i = split_fit ? n_changed - 1 - j : j;
            if (!visited_before(i, split_fit)) once_.push_back(i);  // changed twice: one scan is enough
        }
        for (const index_t i : once_) prefetch_rescan(changed_[i]);
        const QuadHeapView h = heap();
        for (const index_t i : once_) {
            const index_t s = changed_[i];
            TriangleKey k;
            if (!((flat || (split_fit && i < 3)) && fit_child(s, k))) k = scan(s);
            total_ += k.sum - keyed_[s].sum;
            keyed_[s] = k;
            if (s >= old_t)
                h.push(s, k.key, n_heap_);
            else
                h.rekey(s, k.key, n_heap_);
        }
    }
}

// The triangle holding pixel (r, c) (on its edge or inside), or -1: a walk across the edge
// the pixel lies beyond, from the last triangle found; a triangle by triangle search when the
// walk does not end (the guarded flips leave the mesh not quite Delaunay).
index_t Insertion::locate(index_t r, index_t c) {
    const auto holds = [&](index_t t, int& beyond) {
        beyond = -1;
        for (int k = 0; k < 3; ++k) {
            const index_t a = tv_[3 * t + k], b = tv_[3 * t + (k + 1) % 3];
            if (orient(vr_[a], vc_[a], vr_[b], vc_[b], r, c) < 0) {
                beyond = k;
                return false;
            }
        }
        return true;
    };
    index_t t = hint_ < n_t_ ? hint_ : 0;
    int beyond = -1;
    for (index_t steps = 0; steps < 4 * n_t_ + 8; ++steps) {
        if (holds(t, beyond)) return hint_ = t;
        const index_t twin = he_[3 * t + beyond];
        if (twin < 0) break;
        t = twin / 3;
    }
    for (t = 0; t < n_t_; ++t) {
        poll_every(t);
        if (holds(t, beyond)) return hint_ = t;
    }
    return -1;
}

bool Insertion::insert_at(index_t r, index_t c) {
    const index_t t = locate(r, c);
    if (t < 0) return false;
    for (int k = 0; k < 3; ++k)
        if (vr_[tv_[3 * t + k]] == r && vc_[tv_[3 * t + k]] == c) return false;
    // as `advance` inserts a worst pixel, without the shortcuts of an exact split
    const index_t p = add_pixel_vertex(r, c);
    const index_t old_t = n_t_;
    insert(t, p, nullptr);
    for (index_t s = old_t; s < n_t_; ++s) {
        keyed_[s].key = -1.0;
        keyed_[s].sum = 0.0;
        heap().push(s, -1.0, n_heap_);
    }
    for (index_t i = 0; i < static_cast<index_t>(changed_.size()); ++i) {
        const index_t s = changed_[i];
        if (visited_before(i, false)) continue;
        const TriangleKey k = scan(s);
        total_ += k.sum - keyed_[s].sum;
        rekey(s, k);
    }
    return true;
}

std::vector<double> Insertion::sums() const {
    std::vector<double> out;
    out.reserve(n_t_);
    for (index_t t = 0; t < n_t_; ++t) {
        poll_every(t);
        out.push_back(keyed_[t].sum);
    }
    return out;
}

}  // namespace rangemesh::refine
