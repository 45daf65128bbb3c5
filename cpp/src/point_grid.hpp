// A uniform grid of points in XY for nearest-neighbour and disk queries
// (private to the library). The points given at construction are bucketed
// once by a counting sort (cells hold about `per_cell` points); points added
// later go to per-cell overflow lists. The frame does not change: points
// outside it land in the border cells, which stays correct, only slower.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <unordered_map>
#include <utility>
#include <vector>

namespace faultmesh::detail {

class PointGrid {
public:
    PointGrid() = default;
    // xy: n points with `stride` doubles each (x, y first); the grid keeps a
    // copy of the coordinates.
    PointGrid(const double* xy, std::size_t n, std::size_t stride, double per_cell = 2.0) {
        double x0 = std::numeric_limits<double>::infinity(), y0 = x0, x1 = -x0, y1 = -x0;
        pts_.resize(2 * n);
        for (std::size_t i = 0; i < n; ++i) {
            const double x = xy[stride * i], y = xy[stride * i + 1];
            pts_[2 * i] = x, pts_[2 * i + 1] = y;
            x0 = std::min(x0, x), x1 = std::max(x1, x);
            y0 = std::min(y0, y), y1 = std::max(y1, y);
        }
        if (n == 0) x0 = y0 = 0.0, x1 = y1 = 1.0;
        const double w = std::max(x1 - x0, 1e-300), h = std::max(y1 - y0, 1e-300);
        const double cells = std::max(1.0, static_cast<double>(n) / per_cell);
        const double c = std::sqrt(w * h / cells);
        const double cap = 4.0 * cells + 1.0;  // a degenerate (thin) frame stays small
        nx_ = static_cast<std::size_t>(std::min(cap, std::max(1.0, c > 0.0 ? std::ceil(w / c) : cells)));
        ny_ = static_cast<std::size_t>(std::min(cap, std::max(1.0, c > 0.0 ? std::ceil(h / c) : cells)));
        x0_ = x0, y0_ = y0;
        cw_ = w / static_cast<double>(nx_);
        ch_ = h / static_cast<double>(ny_);
        start_.assign(nx_ * ny_ + 1, 0);
        std::vector<std::uint32_t> cell_of(n);
        for (std::size_t i = 0; i < n; ++i) {
            cell_of[i] = static_cast<std::uint32_t>(cell(pts_[2 * i], pts_[2 * i + 1]));
            ++start_[cell_of[i] + 1];
        }
        for (std::size_t i = 0; i < nx_ * ny_; ++i) start_[i + 1] += start_[i];
        ids_.resize(n);
        std::vector<std::int64_t> fill(start_.begin(), start_.end() - 1);
        for (std::size_t i = 0; i < n; ++i) ids_[static_cast<std::size_t>(fill[cell_of[i]]++)] = static_cast<std::int64_t>(i);
    }

    std::size_t size() const { return pts_.size() / 2; }
    const double* point(std::size_t i) const { return pts_.data() + 2 * i; }

    // Adds a point; returns its index (points are numbered in order of addition).
    std::size_t add(const double* p) {
        const std::size_t id = size();
        pts_.push_back(p[0]);
        pts_.push_back(p[1]);
        extra_[cell(p[0], p[1])].push_back(static_cast<std::int64_t>(id));
        return id;
    }

    // Calls f(index) for every point in the closed disk of radius r about c.
    template <class F>
    void disk(const double* c, double r, F&& f) const {
        const double r2 = r * r;
        const long i0 = cx(c[0] - r), i1 = cx(c[0] + r), j0 = cy(c[1] - r), j1 = cy(c[1] + r);
        for (long j = j0; j <= j1; ++j)
            for (long i = i0; i <= i1; ++i)
                each_in_cell(static_cast<std::size_t>(j) * nx_ + static_cast<std::size_t>(i), [&](std::int64_t id) {
                    const double* p = point(static_cast<std::size_t>(id));
                    const double dx = p[0] - c[0], dy = p[1] - c[1];
                    if (dx * dx + dy * dy <= r2) f(id);
                });
    }

    // The k nearest points of q accepted by keep(index) (fewer if there are
    // fewer), nearest first: (index, distance) pairs.
    template <class Keep>
    std::vector<std::pair<std::int64_t, double>> nearest(const double* q, std::size_t k, Keep&& keep) const {
        std::vector<std::pair<double, std::int64_t>> best;  // max-heap on d2
        if (k == 0 || size() == 0) return {};
        const long qx = cx(q[0]), qy = cy(q[1]);
        const long maxr = static_cast<long>(std::max(nx_, ny_));
        auto visit = [&](long i, long j) {
            if (i < 0 || j < 0 || i >= static_cast<long>(nx_) || j >= static_cast<long>(ny_)) return;
            each_in_cell(static_cast<std::size_t>(j) * nx_ + static_cast<std::size_t>(i), [&](std::int64_t id) {
                if (!keep(id)) return;
                const double* p = point(static_cast<std::size_t>(id));
                const double dx = p[0] - q[0], dy = p[1] - q[1];
                const double d2 = dx * dx + dy * dy;
                if (best.size() < k) {
                    best.emplace_back(d2, id);
                    std::push_heap(best.begin(), best.end());
                } else if (d2 < best.front().first) {
                    std::pop_heap(best.begin(), best.end());
                    best.back() = {d2, id};
                    std::push_heap(best.begin(), best.end());
                }
            });
        };
        for (long r = 0; r <= maxr; ++r) {
            if (r == 0) {
                visit(qx, qy);
            } else {
                for (long i = qx - r; i <= qx + r; ++i) visit(i, qy - r), visit(i, qy + r);
                for (long j = qy - r + 1; j <= qy + r - 1; ++j) visit(qx - r, j), visit(qx + r, j);
            }
            // A point not yet seen lies in ring r + 1 or beyond: at least r
            // cell widths from q (q lies in, or beyond, its clamped cell).
            if (best.size() == k) {
                const double reach = static_cast<double>(r) * std::min(cw_, ch_);
                if (best.front().first <= reach * reach) break;
            }
        }
        std::sort_heap(best.begin(), best.end());
        std::vector<std::pair<std::int64_t, double>> out;
        out.reserve(best.size());
        for (const auto& b : best) out.emplace_back(b.second, std::sqrt(b.first));
        return out;
    }

private:
    long cx(double x) const {
        const double c = std::floor((x - x0_) / cw_);
        return static_cast<long>(std::min(std::max(c, 0.0), static_cast<double>(nx_ - 1)));
    }
    long cy(double y) const {
        const double c = std::floor((y - y0_) / ch_);
        return static_cast<long>(std::min(std::max(c, 0.0), static_cast<double>(ny_ - 1)));
    }
    std::size_t cell(double x, double y) const {
        return static_cast<std::size_t>(cy(y)) * nx_ + static_cast<std::size_t>(cx(x));
    }
    template <class F>
    void each_in_cell(std::size_t c, F&& f) const {
        for (std::int64_t k = start_[c]; k < start_[c + 1]; ++k) f(ids_[static_cast<std::size_t>(k)]);
        if (!extra_.empty()) {
            auto it = extra_.find(c);
            if (it != extra_.end())
                for (std::int64_t id : it->second) f(id);
        }
    }

    std::size_t nx_ = 1, ny_ = 1;
    double x0_ = 0.0, y0_ = 0.0, cw_ = 1.0, ch_ = 1.0;
    std::vector<std::int64_t> start_{0, 0};
    std::vector<std::int64_t> ids_;
    std::unordered_map<std::size_t, std::vector<std::int64_t>> extra_;
    std::vector<double> pts_;
};

}  // namespace faultmesh::detail
