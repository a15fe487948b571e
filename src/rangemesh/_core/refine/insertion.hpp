// Greedy insertion (Garland & Heckbert 1995, the method of hmm and delatin) on a range image:
// a Delaunay mesh refined at its worst pixel, one vertex at a time.
//
// Every triangle knows the pixel to insert next and its key (`TriangleKey`); an indexed max-heap
// orders the triangles. A step inserts the first triangle's pixel, splitting it (or the two
// triangles of the edge the pixel lies on), restores the Delaunay property with Lawson flips
// (rows counting `sr`, columns `sc`), and rescans only the triangles that changed.
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include "../geometry/heap.hpp"
#include "image.hpp"
#include "scan.hpp"

namespace rangemesh::refine {

// The mesh insertion starts from: the four image (or strip) corners first, then valid pixels;
// triangles counter-clockwise in (row, column), Delaunay, with their twin half-edges.
struct FirstMesh {
    Span<const index_t> vr, vc;
    Span<const double> vz;  // a background corner takes the depth of its nearest valid pixel
    Span<const index_t> triangles, halfedges;
};

// When `advance` stops: at `max_vertices` vertices on valid pixels, once the first key is
// below `min_key`, or (no pixel left to cover) once the summed error is at most `max_sum`
// (a negative `max_sum`: never by the sum).
struct Stop {
    index_t max_vertices;
    double max_sum = -1.0;
    double min_key = -std::numeric_limits<double>::infinity();
};

// The corners of a triangle that fits exactly, kept while it is split: no flip may join two
// planes in one triangle.
struct Plane {
    double r[3], c[3], z[3];

    // Whether depth `z` at pixel (r, c) lies on the plane to within half a key step.
    bool holds(index_t r, index_t c, double z, double span) const;
};

// Cache-line aligned: two strips' states advance side by side on two threads, and their
// counters and scratch pointers, written every step, must not share a line.
class alignas(64) Insertion {
  public:
    // Every triangle of `first` scanned and in the heap; room reserved for `reserve` more
    // vertices (the arrays grow beyond it). With `scan` false the room is only reserved here and
    // `scan_first` fills it and scans, on any thread: the memory is this thread's allocator's
    // (a strip's second thread is new each call, and its arena gives the pages back).
    Insertion(const Image& image, const FirstMesh& first, index_t reserve, index_t sr, index_t sc, bool scan = true);
    ~Insertion();
    Insertion(const Insertion&) = delete;
    Insertion& operator=(const Insertion&) = delete;
    Insertion(Insertion&&) = default;
    Insertion& operator=(Insertion&&) = default;

    // The first mesh's triangles scanned and in the heap (once, after a construction with `scan` false).
    void scan_first();

    // Insert worst pixels until `stop` says so, or no pixel is left to insert.
    void advance(const Stop& stop);

    // Insert pixel (r, c), valid and no vertex, into the triangle holding it (found by a walk),
    // as `advance` inserts its worst pixels; false when no triangle holds it or it is a corner.
    // The deviation targets' rounds (deviation.hpp) insert the pixels they pick this way.
    bool insert_at(index_t r, index_t c);

    // The key of the triangle `advance` would split next (-1 when none is left).
    double top_key() const { return n_heap_ > 0 ? keyed_[top()].key : -1.0; }

    index_t n_vertices() const { return static_cast<index_t>(vr_.size()); }
    index_t n_triangles() const { return n_t_; }
    index_t valid_vertices() const { return n_valid_v_; }
    double total() const { return total_; }  // summed error of the valid pixels

    // The mesh: vertex pixels, triangles and twin half-edges (3 per triangle), and each
    // triangle's error sum. Flips may change triangles, halfedges and sums in place (the heap
    // is then stale: do not advance again).
    Span<index_t> vertex_rows() { return {vr_.data(), n_vertices()}; }
    Span<index_t> vertex_cols() { return {vc_.data(), n_vertices()}; }
    Span<const double> vertex_depths() const { return {vz_.data(), n_vertices()}; }
    Span<index_t> triangles() { return {tv_.data(), 3 * n_t_}; }
    Span<index_t> halfedges() { return {he_.data(), 3 * n_t_}; }
    std::vector<double> sums() const;

  private:
    // (only the first four vertices may be background)
    Corner corner(index_t v) const { return {vx_[v].r, vx_[v].c, vx_[v].z, v < 4 && vbg_[v] != 0}; }
    void add_vertex(index_t r, index_t c, double z, bool background);
    TriangleKey scan(index_t t) const;
    void prefetch_rescan(index_t t) const;
    bool fit_child(index_t t, TriangleKey& out) const;
    void make_room();
    void resize_triangles(index_t cap_t);
    void reserve_triangles(index_t cap_t);
    void new_triangle(index_t t, index_t a, index_t b, index_t c);
    struct Corners {
        index_t a, b, c;
    };
    index_t add_pixel_vertex(index_t r, index_t c);
    void split_side(index_t x, index_t y, const Corners& abc, index_t p, index_t h_bc, index_t h_ca);
    void insert(index_t t, index_t p, const Plane* guard);
    void legalize(index_t e0, const Plane* guard);
    bool flat_cavity(index_t t, index_t old_t, const Plane& plane) const;
    bool visited_before(index_t i, bool backwards) const;
    void rekey(index_t t, const TriangleKey& k);
    index_t locate(index_t r, index_t c);
    // the heap over the arrays as they are now (they move when the triangles' room grows)
    QuadHeapView heap() { return {QuadHeapView::entries(heap_.data()), slot_.data()}; }
    index_t top() const { return heap_[0].e[3].id; }  // (position 0: `QuadHeapView::entries`)

    Image image_;
    index_t sr_, sc_;
    // vertices: pixel, depth, background
    std::vector<index_t> vr_, vc_;
    std::vector<double> vz_;
    std::vector<unsigned char> vbg_;
    // ... and each vertex's pixel and depth in one place, as the scans and flips read them
    struct Vertex {
        std::int32_t r, c;  // (an image side is at most EXACT_SPAN)
        double z;
    };
    std::vector<Vertex> vx_;
    // triangles, `n_t_` of them in arrays that may be longer: corners, twins, standing
    index_t n_t_ = 0;
    std::vector<index_t> tv_, he_;
    std::vector<TriangleKey> keyed_;
    // the heap (`QuadHeapView`): keys and ids at heap positions, each id's position
    std::vector<HeapLine> heap_;
    std::vector<index_t> slot_;
    index_t n_heap_ = 0;
    index_t n_valid_v_ = 0;
    index_t first_cap_t_ = 0;  // the triangles' room `scan_first` fills, until it runs
    double total_ = 0.0;
    index_t hint_ = 0;  // where `locate` starts walking: the last triangle it found
    // per step: the triangles it changed (with repeats), the flips still to test
    std::vector<index_t> changed_, stack_;
    std::vector<index_t> once_;  // the positions in `changed_` of its distinct triangles, in scan order

    // The arrays a thread keeps from its last small insertion (insertion.cpp): taken at the
    // start, so a small image's insertion allocates nothing, and given back emptied at the end.
    struct Kept;
    void take_kept() noexcept;
    bool give_back() noexcept;
    template <class F>
    void pair_arrays(Kept& k, F&& f) noexcept;  // f(this insertion's array, k's) for each of the 13
};

}  // namespace rangemesh::refine
