#include "strips.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <tuple>

#include "../geometry/predicates.hpp"
#include "../interrupt.hpp"
#include "../parallel.hpp"
#include "diagonals.hpp"
#include "keys.hpp"

namespace rangemesh::refine {

std::vector<index_t> seam_rows(Span<const double> z, Span<const bool> ok, index_t k, double max_sum, double span) {
    require(ok.size == z.size, "seam_rows: one flag a depth");
    std::vector<index_t> rows_ok;
    for (index_t j = 0; j < z.size; ++j)
        if (ok[j]) rows_ok.push_back(j);
    const index_t n_ok = static_cast<index_t>(rows_ok.size());
    if (n_ok == 0) return rows_ok;
    std::vector<unsigned char> chosen(z.size, 0);
    chosen[rows_ok.front()] = chosen[rows_ok.back()] = 1;
    index_t n = n_ok > 1 ? 2 : 1;
    const auto open = [&](index_t j) { return ok[j] && !chosen[j]; };
    while (n < std::min(k, n_ok)) {
        poll_interrupt();
        // the worst pixel against the line between chosen neighbours; when every pixel fits,
        // the valid pixel nearest the middle of the longest gap
        double best_key = -1.0, total = 0.0;
        index_t best_r = -1, long_gap = 0, long_r = -1;
        index_t a = rows_ok[0];
        for (index_t i = 1; i < n_ok; ++i) {
            const index_t r = rows_ok[i];
            if (!chosen[r]) continue;
            if (r - a > 1) {
                for (index_t j = a + 1; j < r; ++j) {
                    if (!open(j)) continue;
                    const double zl = z[a] + (z[r] - z[a]) * static_cast<double>(j - a) / static_cast<double>(r - a);
                    const double e = std::abs(z[j] - zl);
                    total += e;
                    const double key = quantize(e, span);
                    if (key > best_key) {
                        best_key = key;
                        best_r = j;
                    }
                }
                if (r - a > long_gap) {
                    const index_t mid = floor_div(a + r, 2);
                    for (index_t d = 0; d < r - a; ++d) {
                        if (mid + d < r && open(mid + d)) {
                            long_gap = r - a;
                            long_r = mid + d;
                            break;
                        }
                        if (mid - d > a && open(mid - d)) {
                            long_gap = r - a;
                            long_r = mid - d;
                            break;
                        }
                    }
                }
            }
            a = r;
        }
        if (best_r < 0 || total <= max_sum) break;
        const index_t pick = best_key > 0.0 ? best_r : long_r;
        require(pick >= 0, "seam_rows: a gap holds the pixel to choose");
        chosen[pick] = 1;
        ++n;
    }
    std::vector<index_t> out;
    for (index_t j = 0; j < z.size; ++j)
        if (chosen[j]) out.push_back(j);
    return out;
}

void merge_tail(Insertion& a, Insertion& b, index_t n_target, double max_sum) {
    for (;;) {
        const index_t na = a.valid_vertices(), nb = b.valid_vertices();
        if (na + nb >= n_target) break;
        const double ka = a.top_key(), kb = b.top_key();
        if (ka < 0.0 && kb < 0.0) break;
        const double ta = a.total(), tb = b.total();
        if (max_sum >= 0.0 && ta + tb <= max_sum && std::max(ka, kb) <= COVER_KEY) break;
        const index_t rem = n_target - na - nb;
        if (ka >= kb)  // a goes on while its key is at least b's
            a.advance(Stop{na + rem, max_sum >= 0.0 ? max_sum - tb : -1.0, kb});
        else  // b while its key is above a's
            b.advance(Stop{nb + rem, max_sum >= 0.0 ? max_sum - ta : -1.0,
                           std::nextafter(ka, std::numeric_limits<double>::infinity())});
        // neither moved: a NaN key or sum (a raw call's depth of 1e300) would repeat this for ever
        if (a.valid_vertices() == na && b.valid_vertices() == nb) break;
    }
}

namespace {

// Each round aims at ROUND_SHARE of the vertices still to insert, at most ROUND_GROWTH times
// the count; once at most TAIL_SHARE of the request (and at least TAIL_MIN) is left, the rest
// go one at a time.
constexpr double ROUND_SHARE = 0.6;
constexpr double ROUND_GROWTH = 2.0;
constexpr double TAIL_SHARE = 0.03;
constexpr index_t TAIL_MIN = 64;
constexpr int MAX_ROUNDS = 16;
// The power law's exponent (vertices ~ key^-e) before a strip has two rounds to fit it on, and
// its bounds: a small exponent predicts a large step in key and overshoots.
constexpr double EXPONENT = 1.0;
constexpr double EXPONENT_MIN = 0.75, EXPONENT_MAX = 4.0;

}  // namespace

double strip_exponent(double x0, double y0, double x1, double y1) {
    if (std::min({x0, y0, x1, y1}) > 0.0 && (y1 - y0) * (x1 - x0) < 0.0) {
        const double e = std::log(y0 / y1) / std::log(x1 / x0);
        return std::min(std::max(e, EXPONENT_MIN), EXPONENT_MAX);
    }
    return EXPONENT;
}

PowerLaw strip_power_law(const std::vector<std::pair<double, double>>& hist) {
    const auto [n1, k1] = hist.back();
    const double e =
        hist.size() >= 2 ? strip_exponent(hist[hist.size() - 2].second, hist[hist.size() - 2].first, k1, n1) : EXPONENT;
    return {n1, k1, e};
}

double strip_error_target(const std::vector<std::pair<double, double>>& hist, double budget) {
    const auto [n1, t1] = hist.back();
    const double e =
        hist.size() >= 2 ? strip_exponent(hist[hist.size() - 2].first, hist[hist.size() - 2].second, n1, t1) : EXPONENT;
    if (t1 <= budget || t1 <= 0.0) return n1;
    return n1 * std::pow(t1 / std::max(budget, 1e-300), 1.0 / e);
}

double PowerLaw::count_at(double key) const {
    if (key >= k || k <= 0.0) return n;
    return n * std::pow(k / key, e);
}

namespace {

// The key at which the strips' predicted counts add up to `target` (bisection in log).
double threshold(const PowerLaw laws[2], double target) {
    double hi = std::max(laws[0].k, laws[1].k);
    if (hi <= 0.0) return -1.0;
    double lo = hi * 1e-12;
    for (int i = 0; i < 50; ++i) {
        const double mid = std::sqrt(lo * hi);
        if (laws[0].count_at(mid) + laws[1].count_at(mid) > target)
            lo = mid;
        else
            hi = mid;
    }
    return hi;
}

// Advance both strips to common key thresholds until the tail is left. Returns the rounds run
// and whether the last stopped a strip by its cap rather than by the threshold (only then is
// the state not one the one-at-a-time order passes through; it is still the same on any
// number of threads).
std::pair<index_t, bool> rounds(Insertion& a, Insertion& b, const StripRequest& req, Worker* worker) {
    std::vector<std::pair<double, double>> hists[2];
    std::vector<std::pair<double, double>> errors;  // (count, summed error) after each round
    std::optional<double> key = COVER_KEY;           // first, every pixel to cover
    index_t n_rounds = 0;
    bool capped = false;
    Insertion* strips[2] = {&a, &b};
    for (int round = 0; round < MAX_ROUNDS; ++round) {
        const index_t counts[2] = {a.valid_vertices(), b.valid_vertices()};
        const index_t sum = counts[0] + counts[1];
        index_t stop = req.target;
        if (req.budget >= 0.0) {
            const double total = a.total() + b.total();
            errors.emplace_back(static_cast<double>(sum), total);
            if (total <= req.budget) break;
            stop =
                static_cast<index_t>(std::min(static_cast<double>(req.target), strip_error_target(errors, req.budget)));
        }
        const index_t rem = stop - sum;
        if (rem <= std::max(TAIL_MIN, static_cast<index_t>(TAIL_SHARE * static_cast<double>(stop)))) break;
        const bool fitted = !hists[0].empty() && !hists[1].empty();
        PowerLaw laws[2] = {};
        if (fitted) laws[0] = strip_power_law(hists[0]), laws[1] = strip_power_law(hists[1]);
        if (!key) {
            // at most twice the count a round: the law is fitted on the last two rounds, and
            // early on (large triangles) its exponent changes fast
            const double want = std::min(static_cast<double>(sum) + ROUND_SHARE * static_cast<double>(rem),
                                         ROUND_GROWTH * static_cast<double>(sum));
            key = threshold(laws, want);
            if (*key <= 0.0) break;
        }
        // caps that add up to what is left, shared as the predicted growth
        double grow[2] = {1.0, 1.0};
        if (fitted)
            for (int i = 0; i < 2; ++i)
                grow[i] = std::max(laws[i].count_at(*key) - static_cast<double>(counts[i]), 0.0);
        const double f = grow[0] + grow[1] > 0.0 ? grow[0] / (grow[0] + grow[1]) : 0.5;
        const index_t cap_a = counts[0] + static_cast<index_t>(std::nearbyint(f * static_cast<double>(rem)));
        const index_t caps[2] = {cap_a, counts[1] + rem - (cap_a - counts[0])};
        const double k = *key;
        run_both(worker, [&] { a.advance(Stop{caps[0], -1.0, k}); }, [&] { b.advance(Stop{caps[1], -1.0, k}); });
        ++n_rounds;
        capped = false;
        for (int i = 0; i < 2; ++i)
            if (strips[i]->valid_vertices() >= caps[i] && strips[i]->top_key() >= k) capped = true;
        for (int i = 0; i < 2; ++i) {
            const double top = strips[i]->top_key();
            if (top > 0.0) hists[i].emplace_back(static_cast<double>(strips[i]->valid_vertices()), top);
        }
        if (hists[0].empty() || hists[1].empty()) break;  // a strip has nothing left: the tail finishes
        if (!capped) key.reset();
        // else the same threshold again: the strip stopped by count goes on to it
    }
    return {n_rounds, capped};
}

StripMesh finish(Insertion& s, const Image& image, bool flip) {
    StripMesh out;
    out.sums = s.sums();
    if (flip) {
        const Span<index_t> vr = s.vertex_rows(), vc = s.vertex_cols();
        out.flips = flip_by_error(image,
                                  FlipMesh{{vr.data, vr.size},
                                           {vc.data, vc.size},
                                           s.triangles(),
                                           s.halfedges(),
                                           {out.sums.data(), static_cast<index_t>(out.sums.size())}},
                                  false)  // (the insertion's own arrays)
                        .flips;
    }
    out.vr = copy_polled(s.vertex_rows());
    out.vc = copy_polled(s.vertex_cols());
    out.triangles = copy_polled(s.triangles());
    out.halfedges = copy_polled(s.halfedges());
    out.valid_vertices = s.valid_vertices();
    out.total = s.total();
    return out;
}

}  // namespace

Strips strip_insert(const Image& image, const FirstMesh& left, const FirstMesh& right, const StripRequest& req) {
    std::optional<Worker> worker;
    if (req.threads >= 2) worker.emplace();
    return strip_insert(image, [&](int i) { return i == 0 ? left : right; }, req, worker ? &*worker : nullptr);
}

Strips strip_insert(const Image& image, const std::function<FirstMesh(int)>& starts, const StripRequest& request,
                    Worker* second) {
    // from none to every pixel in each strip: a count beyond (a raw call's INT64_MIN or MAX)
    // asks for no more, and would overflow the rounds' arithmetic (target - count, or a cap of
    // the rest as a double that rounds to 2^63)
    StripRequest req = request;
    req.target = std::clamp<index_t>(req.target, 0, 2 * image.rows() * image.cols());
    std::optional<Insertion> a, b;
    // each strip's first mesh, then its first scan (which visits every pixel), on its own thread;
    // the room reserved here between: this thread's allocator keeps its pages from call to call,
    // a new second thread's gave them back (1750-2050 faulted in again a call at 10 %, 640 x 480)
    FirstMesh firsts[2];
    run_both(second, [&] { firsts[0] = starts(0); }, [&] { firsts[1] = starts(1); });
    a.emplace(image, firsts[0], req.reserve, req.sr, req.sc, false);
    b.emplace(image, firsts[1], req.reserve, req.sr, req.sc, false);
    run_both(second, [&] { a->scan_first(); }, [&] { b->scan_first(); });
    Strips out;
    if (req.rounds) std::tie(out.rounds, out.capped) = rounds(*a, *b, req, second);
    merge_tail(*a, *b, req.target, req.budget);
    run_both(second, [&] { out.left = finish(*a, image, req.flip); }, [&] { out.right = finish(*b, image, req.flip); });
    return out;
}

}  // namespace rangemesh::refine
