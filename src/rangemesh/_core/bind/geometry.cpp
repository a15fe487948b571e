// Python bindings of the shared geometry kernels.
#include <nanobind/stl/array.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/pair.h>

#include <array>
#include <cstdint>
#include <optional>
#include <utility>

#include "../geometry/delaunay.hpp"
#include "../geometry/fans.hpp"
#include "../geometry/halfedges.hpp"
#include "../geometry/heap.hpp"
#include "../geometry/pixels.hpp"
#include "../geometry/raster.hpp"
#include "../geometry/rasterize.hpp"
#include "../simd.hpp"
#include "bindings.hpp"
#include "numpy.hpp"
#include "release.hpp"

namespace rangemesh::bind {

namespace {

PointSet points(const In1<index_t>& r, const In1<index_t>& c) { return PointSet{span(r), span(c)}; }

// mask_image for images of type T: each dtype a kernel of its own, so no converted copy.
template <class T>
void bind_mask_image(nb::module_& m) {
    m.def(
        "mask_image",
        [](In2<T> image, bool has_background, double background, Out2<double> depth, Out2<bool> valid) {
            check_input(same_shape(depth, image) && same_shape(valid, image),
                        "mask_image: depth and valid must have the image's shape");
            run_released([&] { mask_image(grid(image), has_background, background, grid(depth), grid(valid)); },
                         work(image));
        },
        nb::arg("image").noconvert(), nb::arg("has_background"), nb::arg("background"), nb::arg("depth"),
        nb::arg("valid"),
        "Write float depth (0.0 on background) and validity of an (H, W) image into `depth` and `valid`: "
        "NaN, inf and `background` (when `has_background`) are invalid, compared as float64.");
}

void bind_delaunay(nb::module_& m) {
    m.def(
        "delaunay_sweep",
        [](In1<index_t> r, In1<index_t> c) {
            Triangulation t = run_released([&] { return delaunay_sweep(points(r, c)); }, work(r));
            return nb::make_tuple(to_numpy(std::move(t.triangles)), to_numpy(std::move(t.halfedges)));
        },
        nb::arg("r"), nb::arg("c"),
        "The sweep's Delaunay triangulation of distinct integer points as ``(triangles, halfedges)`` "
        "(3F each, counter-clockwise in (r, c)); empty when there are fewer than 3 points or all are "
        "collinear.");
    m.def(
        "legalize_all",
        [](Out1<index_t> triangles, Out1<index_t> halfedges, In1<index_t> r, In1<index_t> c) {
            check_input(r.shape(0) == c.shape(0), "legalize_all: r and c must have one length");
            return run_released([&] { return legalize_all(span(triangles), span(halfedges), points(r, c)); });
        },
        nb::arg("triangles"), nb::arg("halfedges"), nb::arg("r"), nb::arg("c"),
        "Lawson flips, in place, until every edge is Delaunay under Simulation of Simplicity; "
        "returns the number of flips.");
    m.def(
        "canonical_faces",
        [](In1<index_t> triangles, index_t n_vertices) {
            check_input(triangles.shape(0) % 3 == 0 && n_vertices >= 0,
                        "canonical_faces: three vertex ids a triangle, n_vertices not negative");
            std::vector<index_t> faces =
                run_released([&] { return canonical_faces(span(triangles), n_vertices); }, work(triangles));
            const std::size_t n_t = faces.size() / 3;
            return to_numpy(std::move(faces), n_t, 3);
        },
        nb::arg("triangles"), nb::arg("n_vertices"),
        "The (F, 3) faces of flat ``triangles`` (3F ids below ``n_vertices``) in the canonical order: "
        "each starts at its smallest vertex, keeping its turn; sorted by first, second, third vertex.");
    m.def(
        "prune_dangling",
        [](In2<index_t> simplices, In2<index_t> neighbors, Out1<bool> alive, index_t n_vertices, bool drop_lone) {
            check_input(simplices.shape(1) == 3 && neighbors.shape(1) == 3 && n_vertices >= 0,
                        "prune_dangling: simplices and neighbors are (F, 3), n_vertices not negative");
            return run_released([&] {
                return prune_dangling(LiveTriangles{grid(simplices), grid(neighbors), span(alive)}, n_vertices,
                                      drop_lone);
            });
        },
        nb::arg("simplices"), nb::arg("neighbors"), nb::arg("alive"), nb::arg("n_vertices"),
        nb::arg("drop_lone") = true,
        "Drop dangling triangles from `alive` (in place) until every vertex has one fan; returns how "
        "many were dropped. With ``drop_lone=False`` triangles that share no edge are kept.");
    m.def(
        "prune_cut_fans",
        [](In1<index_t> triangles, In1<index_t> halfedges, Out1<bool> alive, index_t n_vertices) {
            const index_t n_he = static_cast<index_t>(triangles.shape(0));
            check_input(n_he % 3 == 0 && static_cast<index_t>(halfedges.shape(0)) == n_he &&
                            static_cast<index_t>(alive.shape(0)) == n_he / 3,
                        "prune_cut_fans: triangles and halfedges are 3F long, alive F");
            const Span<const index_t> tri = span(triangles), he = span(halfedges);
            for (index_t e = 0; e < n_he; ++e)
                check_input(0 <= tri[e] && tri[e] < n_vertices && -1 <= he[e] && he[e] < n_he,
                            "prune_cut_fans: a vertex or twin id out of range");
            for (index_t e = 0; e < n_he; ++e)
                check_input(twin_ok(tri, he, e), "prune_cut_fans: a twin that does not run back along its edge");
            return run_released([&] { return prune_cut_fans(tri, he, span(alive)); });
        },
        nb::arg("triangles"), nb::arg("halfedges"), nb::arg("alive"), nb::arg("n_vertices"),
        "``prune_dangling(..., drop_lone=False)`` with every triangle alive to start, for triangles cut "
        "from a triangulation as flat ``triangles`` (ids below ``n_vertices``) and ``halfedges`` (3F each): sets "
        "`alive` (F) in place "
        "and returns how many were dropped.");
}

// build_halfedges and count_edges on (F, 3) faces of ids of type T.
template <class T>
void bind_face_lists(nb::module_& m) {
    m.def(
        "build_halfedges",
        [](In2<T> faces, index_t n_vertices) {
            check_input(faces.shape(1) == 3 && n_vertices >= 0,
                        "build_halfedges: faces are (F, 3), n_vertices not negative");
            std::vector<index_t> triangles, halfedges;
            run_released([&] { build_halfedges(grid(faces), n_vertices, triangles, halfedges); }, work(faces));
            return nb::make_tuple(to_numpy(std::move(triangles)), to_numpy(std::move(halfedges)));
        },
        nb::arg("faces"), nb::arg("n_vertices"),
        "Flat ``(triangles, halfedges)`` int64 arrays (3F each) of an oriented, edge-manifold (F, 3) "
        "int64 or int32 face list; a border half-edge's twin is -1.");
    m.def(
        "count_edges",
        [](In2<T> faces, index_t n_vertices) {
            check_input(faces.shape(1) == 3 && n_vertices >= 0,
                        "count_edges: faces are (F, 3), n_vertices not negative");
            return run_released([&] { return count_edges(grid(faces), n_vertices); }, work(faces));
        },
        nb::arg("faces"), nb::arg("n_vertices"),
        "Distinct undirected edges of an (F, 3) int64 or int32 face list, any orientation, manifold or not.");
}

void bind_pixels(nb::module_& m) {
    bind_mask_image<double>(m);
    bind_mask_image<float>(m);
    bind_mask_image<std::int8_t>(m);
    bind_mask_image<std::int16_t>(m);
    bind_mask_image<std::int32_t>(m);
    bind_mask_image<std::int64_t>(m);
    bind_mask_image<std::uint8_t>(m);
    bind_mask_image<std::uint16_t>(m);
    bind_mask_image<std::uint32_t>(m);
    bind_mask_image<std::uint64_t>(m);
    m.def(
        "valid_range",
        [](In2<double> depth, In2<bool> valid) {
            check_input(same_shape(depth, valid), "valid_range: depth and valid must have one shape");
            return run_released([&] { return valid_range(grid(depth), grid(valid)); }, work(depth));
        },
        nb::arg("depth"), nb::arg("valid"),
        "The DepthRange of the valid depths: smallest, largest and count (0.0, 0.0 and 0 when there is none).");
    m.def(
        "covered_error",
        [](In2<double> pred, In2<double> depth, In2<bool> valid) {
            check_input(same_shape(pred, depth) && same_shape(valid, depth),
                        "covered_error: pred, depth and valid must have one shape");
            return run_released([&] { return covered_error(grid(pred), grid(depth), grid(valid)); });
        },
        nb::arg("pred"), nb::arg("depth"), nb::arg("valid"),
        "The CoveredError: the sum of |pred - depth| over the valid pixels where `pred` is finite, and their count.");
    m.def(
        "valid_faces",
        [](In1<index_t> vr, In1<index_t> vc, In1<index_t> tv, In2<bool> valid) {
            check_input(tv.shape(0) % 3 == 0, "valid_faces: tv holds three vertex ids a triangle");
            ValidFaces f =
                run_released([&] { return valid_faces(span(vr), span(vc), span(tv), grid(valid)); }, work(tv));
            const std::size_t n_faces = f.faces.size() / 3, n_pixels = f.pixels.size() / 2;
            return nb::make_tuple(to_numpy(std::move(f.faces), n_faces, 3), to_numpy(std::move(f.pixels), n_pixels, 2));
        },
        nb::arg("vr"), nb::arg("vc"), nb::arg("tv"), nb::arg("valid"),
        "``(faces (F, 3) int32, pixels (U, 2) int32)``: the triangles of `tv` whose corners are valid "
        "pixels, numbered over the vertices they use, in order, and those vertices' (row, col).");
    m.def(
        "nearest_valid",
        [](In2<bool> valid, index_t r, index_t c) -> std::optional<std::pair<index_t, index_t>> {
            check_input(0 <= r && r < static_cast<index_t>(valid.shape(0)) && 0 <= c &&
                            c < static_cast<index_t>(valid.shape(1)),
                        "nearest_valid: (r, c) must be a pixel of the image");
            const Pixel p = run_released([&] { return nearest_valid(grid(valid), r, c); }, work(valid));
            if (p.r < 0) return std::nullopt;  // (not the kernel's (-1, -1): no sentinel in Python)
            return std::pair{p.r, p.c};
        },
        nb::arg("valid"), nb::arg("r"), nb::arg("c"),
        "The valid pixel nearest (r, c) as ``(row, col)``, ties to the smallest (row, col); None when the "
        "image has no valid pixel.");
    m.def(
        "grid_pixels",
        [](In2<bool> valid, index_t n_rows, index_t n_cols, index_t c_lo, index_t c_hi, bool inner) {
            check_input(valid.shape(0) >= 1 && 0 <= c_lo && c_lo <= c_hi && c_hi < static_cast<index_t>(valid.shape(1)),
                        "grid_pixels: columns c_lo <= c_hi of a non-empty image");
            return run_released([&] { return grid_pixels(grid(valid), n_rows, n_cols, c_lo, c_hi, inner); },
                                work(valid));
        },
        nb::arg("valid"), nb::arg("n_rows"), nb::arg("n_cols"), nb::arg("c_lo"), nb::arg("c_hi"), nb::arg("inner"),
        "A PixelList: the corners of columns c_lo..c_hi, then row by row the distinct valid centres of an "
        "n_rows x n_cols grid over them (none on the first or last column with `inner`).");
    m.def(
        "rasterize",
        [](In2<double> face_r, In2<double> face_c, In2<double> face_val, Out2<double> out_val, Out2<index_t> out_face) {
            check_input(face_r.shape(1) == 3 && face_c.shape(1) == 3 && face_val.shape(1) == 3,
                        "rasterize: face_r, face_c and face_val are (F, 3)");
            run_released([&] {
                rasterize(FaceValues{grid(face_r), grid(face_c), grid(face_val)},
                          RenderTarget{grid(out_val), grid(out_face)});
            });
        },
        nb::arg("face_r"), nb::arg("face_c"), nb::arg("face_val"), nb::arg("out_val"), nb::arg("out_face"),
        "Interpolate (F, 3) corner values over the pixel centres each triangle covers, into `out_val` "
        "(NaN-filled) and `out_face` (-1-filled); the first triangle to cover a pixel sets it.");
}

}  // namespace

void bind_geometry(nb::module_& m) {
    // the widest span of coordinates (pixels times Delaunay scales) the exact predicates take
    m.attr("EXACT_SPAN") = EXACT_SPAN;
    nb::class_<CoveredError>(m, "CoveredError",
                             "The error of a render over the covered valid pixels (``covered_error``).")
        .def_ro("total", &CoveredError::total, "The sum of |pred - depth|.")
        .def_ro("count", &CoveredError::count, "The valid pixels where pred is finite.");
    nb::class_<PixelList>(m, "PixelList", "Pixels as their rows and columns (``grid_pixels``).")
        .def_prop_ro("rows", array_of(&PixelList::rows), nb::rv_policy::reference_internal, "(n,) int64.")
        .def_prop_ro("cols", array_of(&PixelList::cols), nb::rv_policy::reference_internal, "(n,) int64.");
    nb::class_<DepthRange>(m, "DepthRange", "The valid depths' range and count (``valid_range``).")
        .def_ro("lo", &DepthRange::lo, "The smallest valid depth (0.0 when there is none).")
        .def_ro("hi", &DepthRange::hi, "The largest (0.0 when there is none).")
        .def_ro("count", &DepthRange::count, "Valid pixels.")
        // (an extent (lo, hi, count) as refine.insertion takes it, until it reads the names)
        .def("__len__", [](const DepthRange&) { return 3; })
        // (unpacking through __getitem__ ends in an IndexError thrown and caught: ~15K instructions)
        .def("__iter__", [](const DepthRange& d) { return nb::iter(nb::make_tuple(d.lo, d.hi, d.count)); })
        .def("__getitem__", [](const DepthRange& d, index_t k) -> nb::object {
            switch (k < 0 ? k + 3 : k) {
                case 0:
                    return nb::float_(d.lo);
                case 1:
                    return nb::float_(d.hi);
                case 2:
                    return nb::int_(d.count);
            }
            throw nb::index_error("DepthRange: lo, hi, count are items 0, 1, 2");
        });
    bind_delaunay(m);
    bind_pixels(m);
    bind_face_lists<index_t>(m);
    bind_face_lists<std::int32_t>(m);  // (a mesh's own faces: no int64 copy of millions)
    m.def(
        "neighbors_from_halfedges",
        [](In1<index_t> halfedges) {
            check_input(halfedges.shape(0) % 3 == 0, "neighbors_from_halfedges: three half-edges a triangle");
            for (const index_t g : span(halfedges))
                check_input(-1 <= g && g < static_cast<index_t>(halfedges.shape(0)),
                            "neighbors_from_halfedges: a twin below -1 or out of range");
            const index_t n_t = halfedges.shape(0) / 3;
            std::vector<index_t> out;
            run_released([&] {
                const FreeLater late(on_throw, out);
                fill_polled(out, 3 * n_t, index_t{0});
                neighbors_from_halfedges(span(halfedges), Grid<index_t>{out.data(), n_t, 3});
            });
            return to_numpy(std::move(out), n_t, 3);
        },
        nb::arg("halfedges"),
        "SciPy-style (F, 3) neighbours: entry (t, k) is the triangle across the edge opposite "
        "corner k, -1 on the border.");
}

namespace {

// A heap of `n` entries on these arrays: keys and ids beside each other, ids with a slot each.
void check_heap(const Out1<double>& keys, const Out1<index_t>& heap, const Out1<index_t>& slot, index_t n) {
    check_input(keys.shape(0) == heap.shape(0) && 0 <= n && n <= static_cast<index_t>(heap.shape(0)),
                "heap: one key an entry, at most that many entries");
    for (index_t i = 0; i < n; ++i)
        check_input(0 <= heap(i) && heap(i) < static_cast<index_t>(slot.shape(0)), "heap: an id without a slot");
}

}  // namespace

// The shared primitives that only kernels use, exposed for the tests (names with a leading
// underscore): the heap's moves on NumPy arrays, and a triangle's row scan.
void bind_geometry_tests(nb::module_& m) {
    // whether the four-lane loops run (simd.hpp): the tests run the scalar ones with RANGEMESH_NO_AVX
    m.def("_uses_avx", [] {
#if RANGEMESH_AVX
        return has_avx();
#else
        return false;
#endif
    });
    m.def("_heap_sift_up", [](Out1<double> keys, Out1<index_t> heap, Out1<index_t> slot, index_t i) {
        check_heap(keys, heap, slot, static_cast<index_t>(heap.shape(0)));
        check_input(0 <= i && i < static_cast<index_t>(heap.shape(0)), "heap: the position is in the heap");
        return HeapView{span(keys), span(heap), span(slot)}.sift_up(i);
    });
    m.def("_heap_rekey",
          [](Out1<double> keys, Out1<index_t> heap, Out1<index_t> slot, index_t x, double key, index_t n) {
              check_heap(keys, heap, slot, n);
              check_input(0 <= x && x < static_cast<index_t>(slot.shape(0)) && 0 <= slot(x) && slot(x) < n,
                          "heap: the id is in the heap");
              HeapView{span(keys), span(heap), span(slot)}.rekey(x, key, n);
          });
    // (every `step`-th row from `first` when given, else every row)
    m.def(
        "_triangle_rows",
        [](In2<index_t> corners, std::array<bool, 3> owns, std::optional<index_t> first, index_t step, bool spans) {
            check_input(corners.shape(0) == 3 && corners.shape(1) == 2, "_triangle_rows: corners are (3, 2)");
            // pixels of an image the predicates take, rows walked from near the triangle: a
            // corner at 2^31 (or a step of 2^62) would walk for ever or overflow
            for (std::size_t k = 0; k < 6; ++k)
                check_input(0 <= corners.data()[k] && corners.data()[k] <= EXACT_SPAN,
                            "_triangle_rows: corners are pixels within EXACT_SPAN");
            check_input(
                1 <= step && step <= EXACT_SPAN && (!first || (-EXACT_SPAN <= *first && *first <= 2 * EXACT_SPAN)),
                "_triangle_rows: 1 <= step <= EXACT_SPAN, and the first row within EXACT_SPAN of the image");
            const index_t ar = corners(0, 0), ac = corners(0, 1), br = corners(1, 0), bc = corners(1, 1),
                          cr = corners(2, 0), cc = corners(2, 1);
            std::vector<index_t> out;
            if (spans) {  // TriangleSpans' walk: its rows that hold pixels, every row from the top
                check_input(!first && step == 1, "_triangle_rows: spans walk every row (no first, step 1)");
                check_input(orient(ar, ac, br, bc, cr, cc) > 0,
                            "_triangle_rows: spans of a counter-clockwise triangle");
                TriangleSpans(ar, ac, br, bc, cr, cc, owns[0], owns[1], owns[2])
                    .walk([&](index_t r, index_t lo, index_t hi) {
                        out.insert(out.end(), {r, lo, hi, orient(ar, ac, br, bc, r, lo), orient(br, bc, cr, cc, r, lo),
                                               orient(cr, cc, ar, ac, r, lo)});
                        return true;
                    });
                const std::size_t n = out.size() / 6;
                return to_numpy(std::move(out), n, 6);
            }
            const TriangleRows top(ar, ac, br, bc, cr, cc);
            const index_t r0 = first.value_or(top.r0);
            TriangleRows rows = first ? TriangleRows(ar, ac, br, bc, cr, cc, r0, step) : top;
            for (index_t r = r0; r <= rows.r1; r += first ? step : 1) {
                if (r > r0) rows.next_row();
                const RowSpan s = rows.columns(owns[0], owns[1], owns[2]);
                out.insert(out.end(), {r, s.first, s.last, s.w0, s.w1, s.w2});
            }
            const std::size_t n = out.size() / 6;
            return to_numpy(std::move(out), n, 6);
        },
        nb::arg("corners"), nb::arg("owns"), nb::arg("first") = nb::none(), nb::arg("step") = 1,
        nb::arg("spans") = false,
        "The row spans of triangle ``corners`` (A, B, C as (row, col), counter-clockwise), ``owns`` its edges "
        "AB, BC, CA: an (n, 6) int64 array, a row each: row, first and last column, and the edge functions "
        "w0, w1, w2 at the first column. With ``spans`` the rows that hold pixels as ``TriangleSpans`` walks "
        "them (refine's scans).");
}

}  // namespace rangemesh::bind
