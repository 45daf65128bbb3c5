// The nearest segment to each point (nearest_segment.hpp).
#include <faultmesh/nearest_segment.hpp>
#include <faultmesh/segments.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace faultmesh {

SegmentIndex::SegmentIndex(const double* starts, const double* ends, std::size_t m, std::size_t stride)
    : ab_(4 * m), order_(m), sorted_cx_(m) {
    std::vector<double> cx(m);
    for (std::size_t j = 0; j < m; ++j) {
        ab_[4 * j] = starts[j * stride];
        ab_[4 * j + 1] = starts[j * stride + 1];
        ab_[4 * j + 2] = ends[j * stride];
        ab_[4 * j + 3] = ends[j * stride + 1];
        cx[j] = 0.5 * (ab_[4 * j] + ab_[4 * j + 2]);
        half_w_ = std::max(half_w_, 0.5 * std::fabs(ab_[4 * j + 2] - ab_[4 * j]));
    }
    std::iota(order_.begin(), order_.end(), std::size_t{0});
    std::stable_sort(order_.begin(), order_.end(), [&](std::size_t i, std::size_t j) { return cx[i] < cx[j]; });
    for (std::size_t k = 0; k < m; ++k) sorted_cx_[k] = cx[order_[k]];
}

std::int64_t SegmentIndex::nearest(const double* p, double& d2_out) const {
    const std::size_t m = order_.size();
    double best = std::numeric_limits<double>::infinity();  // squared
    std::size_t best_j = m;
    auto visit = [&](std::size_t j) {
        const double d2 = segment_distance2(&ab_[4 * j], &ab_[4 * j + 2], p);
        if (d2 < best || (d2 == best && j < best_j)) {
            best = d2;
            best_j = j;
        }
    };
    // The walk's bound: a segment whose centre lies dx away in x is at least
    // dx - half_w away. Compared squared with a margin of one part in 1e12
    // so that rounding of the bound never skips a segment that ties the best
    // (the tie rule: the lowest index).
    auto beyond = [&](double dx) {
        const double lo = dx - half_w_;
        return lo > 0.0 && lo * lo > best * (1.0 + 1e-12);
    };
    const std::size_t start =
        static_cast<std::size_t>(std::lower_bound(sorted_cx_.begin(), sorted_cx_.end(), p[0]) - sorted_cx_.begin());
    std::size_t r = start;
    std::size_t l = start;  // the next to the left is l - 1
    bool right_open = r < m, left_open = l > 0;
    while (right_open || left_open) {
        if (right_open) {
            if (beyond(sorted_cx_[r] - p[0])) {
                right_open = false;
            } else {
                visit(order_[r]);
                right_open = ++r < m;
            }
        }
        if (left_open) {
            if (beyond(p[0] - sorted_cx_[l - 1])) {
                left_open = false;
            } else {
                visit(order_[l - 1]);
                left_open = --l > 0;
            }
        }
    }
    d2_out = best;
    return best_j == m ? -1 : static_cast<std::int64_t>(best_j);
}

NearestSegment nearest_segment(const double* points, std::size_t n, const double* starts, const double* ends,
                               std::size_t m, std::size_t stride) {
    NearestSegment out;
    out.index.assign(n, -1);
    out.distance.assign(n, std::numeric_limits<double>::infinity());
    if (m == 0 || n == 0) return out;
    const SegmentIndex index(starts, ends, m, stride);
    for (std::size_t i = 0; i < n; ++i) {
        double d2;
        out.index[i] = index.nearest(points + i * stride, d2);
        out.distance[i] = std::sqrt(d2);
    }
    return out;
}

}  // namespace faultmesh
