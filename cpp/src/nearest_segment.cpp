// The nearest segment to each point (nearest_segment.hpp).
#include <faultmesh/nearest_segment.hpp>
#include <faultmesh/segments.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace faultmesh {

NearestSegment nearest_segment(const double* points, std::size_t n, const double* starts, const double* ends,
                               std::size_t m, std::size_t stride) {
    NearestSegment out;
    out.index.assign(n, -1);
    out.distance.assign(n, std::numeric_limits<double>::infinity());
    if (m == 0 || n == 0) return out;
    // Segment j by the x of its box centre; half_w: the widest box's half width.
    std::vector<double> cx(m);
    double half_w = 0.0;
    for (std::size_t j = 0; j < m; ++j) {
        const double a = starts[j * stride], b = ends[j * stride];
        cx[j] = 0.5 * (a + b);
        half_w = std::max(half_w, 0.5 * std::fabs(b - a));
    }
    std::vector<std::size_t> order(m);
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::stable_sort(order.begin(), order.end(), [&](std::size_t i, std::size_t j) { return cx[i] < cx[j]; });
    std::vector<double> sorted_cx(m);
    for (std::size_t k = 0; k < m; ++k) sorted_cx[k] = cx[order[k]];

    for (std::size_t i = 0; i < n; ++i) {
        const double* p = points + i * stride;
        double best = std::numeric_limits<double>::infinity();  // squared
        std::size_t best_j = m;
        auto visit = [&](std::size_t j) {
            const double d2 = segment_distance2(starts + j * stride, ends + j * stride, p);
            if (d2 < best || (d2 == best && j < best_j)) {
                best = d2;
                best_j = j;
            }
        };
        // The walk's bound: a segment whose centre lies dx away in x is at
        // least dx - half_w away. Compared squared with a margin of one part
        // in 1e12 so that rounding of the bound never skips a segment that
        // ties the best (the tie rule: the lowest index).
        auto beyond = [&](double dx) {
            const double lo = dx - half_w;
            return lo > 0.0 && lo * lo > best * (1.0 + 1e-12);
        };
        const std::size_t start =
            static_cast<std::size_t>(std::lower_bound(sorted_cx.begin(), sorted_cx.end(), p[0]) - sorted_cx.begin());
        std::size_t r = start;
        std::size_t l = start;  // the next to the left is l - 1
        bool right_open = r < m, left_open = l > 0;
        while (right_open || left_open) {
            if (right_open) {
                if (beyond(sorted_cx[r] - p[0])) {
                    right_open = false;
                } else {
                    visit(order[r]);
                    right_open = ++r < m;
                }
            }
            if (left_open) {
                if (beyond(p[0] - sorted_cx[l - 1])) {
                    left_open = false;
                } else {
                    visit(order[l - 1]);
                    left_open = --l > 0;
                }
            }
        }
        out.index[i] = static_cast<std::int64_t>(best_j);
        out.distance[i] = std::sqrt(best);
    }
    return out;
}

}  // namespace faultmesh
