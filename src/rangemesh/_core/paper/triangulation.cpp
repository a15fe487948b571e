#include "triangulation.hpp"

#include <algorithm>
#include <cstdint>

#include "../geometry/predicates.hpp"
#include "../interrupt.hpp"

namespace rangemesh::paper {

template <class T>
std::vector<index_t> valid_samples(Grid<const T> samples, Grid<const bool> valid) {
    check_input(samples.cols == 2, "valid_samples: samples are (row, column) pairs");
    const index_t h = valid.rows, w = valid.cols;
    // a mark a pixel: cheaper than sorting the samples, and it leaves them in row-major order
    std::vector<unsigned char> mark;
    std::vector<index_t> out;
    const FreeLater late(mark);
    const FreeLater late_out(on_throw, out);
    fill_polled(mark, h * w, static_cast<unsigned char>(0));
    for (index_t i = 0; i < samples.rows; ++i) {
        poll_every(i);
        const index_t r = samples(i, 0), c = samples(i, 1);
        if (0 <= r && r < h && 0 <= c && c < w && valid(r, c)) mark[r * w + c] = 1;
    }
    for (index_t r = 0; r < h; ++r) {
        poll_interrupt();
        const unsigned char* row = mark.data() + r * w;
        for (index_t c = 0; c < w; ++c)
            if (row[c]) {
                out.push_back(r);
                out.push_back(c);
            }
    }
    return out;
}

template std::vector<index_t> valid_samples(Grid<const std::int32_t>, Grid<const bool>);
template std::vector<index_t> valid_samples(Grid<const index_t>, Grid<const bool>);

void keep_faces(Grid<const index_t> faces, Grid<const index_t> points, Grid<const bool> valid, double max_edge2,
                Span<bool> alive) {
    check_input(faces.cols == 3 && points.cols == 2 && alive.size == faces.rows,
                "keep_faces: faces (F, 3), points (N, 2) and one flag a face");
    const index_t n = points.rows;
    for (index_t t = 0; t < faces.rows; ++t) {
        poll_every(t);
        const index_t a = faces(t, 0), b = faces(t, 1), c = faces(t, 2);
        check_input(std::min({a, b, c}) >= 0 && std::max({a, b, c}) < n, "keep_faces: a point id is out of range");
        // pixels of the image: the sums and squares below stay far from int64's end
        for (const index_t p : {a, b, c})
            check_input(
                0 <= points(p, 0) && points(p, 0) < valid.rows && 0 <= points(p, 1) && points(p, 1) < valid.cols,
                "keep_faces: a face's point lies outside the image");
        const index_t br = floor_div(points(a, 0) + points(b, 0) + points(c, 0) + 1, 3);
        const index_t bc = floor_div(points(a, 1) + points(b, 1) + points(c, 1) + 1, 3);
        check_input(0 <= br && br < valid.rows && 0 <= bc && bc < valid.cols,
                    "keep_faces: a face's barycentre lies outside the image");
        bool keep = valid(br, bc);
        // (d2 <= max_edge2).all(): NumPy compares the int64 squares as float64
        for (int k = 0; k < 3 && keep; ++k) {
            const index_t p = faces(t, k), q = faces(t, (k + 2) % 3);
            const index_t dr = points(p, 0) - points(q, 0), dc = points(p, 1) - points(q, 1);
            keep = static_cast<double>(dr * dr + dc * dc) <= max_edge2;
        }
        alive[t] = keep;
    }
}

CompactMesh compact_faces(Grid<const index_t> faces, Span<const bool> alive, Grid<const index_t> points) {
    check_input(faces.cols == 3 && points.cols == 2 && alive.size == faces.rows,
                "compact_faces: faces (F, 3), points (N, 2) and one flag a face");
    const index_t n = points.rows;
    std::vector<unsigned char> used;
    std::vector<index_t> new_id;
    CompactMesh out;
    const FreeLater late(used, new_id);
    const FreeLater late_out(on_throw, out.faces, out.pixels);
    fill_polled(used, n, static_cast<unsigned char>(0));
    index_t n_kept = 0;
    for (index_t t = 0; t < faces.rows; ++t) {
        poll_every(t);
        if (!alive[t]) continue;
        ++n_kept;
        for (int k = 0; k < 3; ++k) {
            const index_t v = faces(t, k);
            check_input(0 <= v && v < n, "compact_faces: a point id is out of range");
            used[v] = 1;
        }
    }
    // the used points keep their order
    fill_polled(new_id, n, index_t{-1});
    index_t n_used = 0;
    for (index_t v = 0; v < n; ++v) {
        poll_every(v);
        n_used += used[v];
    }
    out.pixels.reserve(2 * n_used);
    for (index_t v = 0, k = 0; v < n; ++v) {
        poll_every(v);
        if (!used[v]) continue;
        // (the pixels come back as int32: a point beyond it would come back as another)
        check_input(0 <= points(v, 0) && points(v, 0) <= INT32_MAX && 0 <= points(v, 1) && points(v, 1) <= INT32_MAX,
                    "compact_faces: a point used is not a pixel (row and column from 0 to 2^31 - 1)");
        new_id[v] = k++;
        out.pixels.push_back(static_cast<std::int32_t>(points(v, 0)));
        out.pixels.push_back(static_cast<std::int32_t>(points(v, 1)));
    }
    out.faces.reserve(3 * n_kept);
    for (index_t t = 0; t < faces.rows; ++t) {
        poll_every(t);
        if (!alive[t]) continue;
        for (int k = 0; k < 3; ++k) out.faces.push_back(static_cast<std::int32_t>(new_id[faces(t, k)]));
    }
    return out;
}

}  // namespace rangemesh::paper
