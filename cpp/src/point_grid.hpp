// A uniform grid of points in XY for nearest-neighbour and disk queries
// (private to the library). Cells hold about `per_cell` points; points may be
// added after construction (they go to the cell of their position; the grid
// frame does not change, so points outside the frame land in the border
// cells, which stays correct, only slower).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

namespace faultmesh::detail {

class PointGrid {
public:
    PointGrid() = default;
    // xy: n points with `stride` doubles each (x, y first). The grid keeps a
    // copy of the coordinates.
    PointGrid(const double* xy, std::size_t n, std::size_t stride, double per_cell = 2.0) {
        double x0 = std::numeric_limits<double>::infinity(), y0 = x0, x1 = -x0, y1 = -x0;
        for (std::size_t i = 0; i < n; ++i) {
            x0 = std::min(x0, xy[stride * i]);
            x1 = std::max(x1, xy[stride * i]);
            y0 = std::min(y0, xy[stride * i + 1]);
            y1 = std::max(y1, xy[stride * i + 1]);
        }
        if (n == 0) x0 = y0 = 0.0, x1 = y1 = 1.0;
        const double w = std::max(x1 - x0, 1e-300), h = std::max(y1 - y0, 1e-300);
        const double cells = std::max(1.0, static_cast<double>(n) / per_cell);
        // Square cells; at most ~4 cells per point along the longer axis.
        double c = std::sqrt(w * h / cells);
        if (!(c > 0.0)) c = std::max(w, h) / cells;
        nx_ = static_cast<std::size_t>(std::min(4.0 * cells + 1.0, std::max(1.0, std::ceil(w / c))));
        ny_ = static_cast<std::size_t>(std::min(4.0 * cells + 1.0, std::max(1.0, std::ceil(h / c))));
        x0_ = x0, y0_ = y0;
        cw_ = w / static_cast<double>(nx_);
        ch_ = h / static_cast<double>(ny_);
        if (!(cw_ > 0.0)) cw_ = 1.0;
        if (!(ch_ > 0.0)) ch_ = 1.0;
        cells_.assign(nx_ * ny_, {});
        pts_.reserve(2 * n);
        for (std::size_t i = 0; i < n; ++i) add(xy + stride * i);
    }

    std::size_t size() const { return pts_.size() / 2; }
    const double* point(std::size_t i) const { return pts_.data() + 2 * i; }

    // Adds a point; returns its index (points are numbered in order of addition).
    std::size_t add(const double* p) {
        const std::size_t id = size();
        pts_.push_back(p[0]);
        pts_.push_back(p[1]);
        cells_[cell(p[0], p[1])].push_back(static_cast<std::int64_t>(id));
        return id;
    }

    // Calls f(index) for every point in the closed disk of radius r about c.
    template <class F>
    void disk(const double* c, double r, F&& f) const {
        const double r2 = r * r;
        box(c[0] - r, c[1] - r, c[0] + r, c[1] + r, [&](std::int64_t i) {
            const double* p = point(static_cast<std::size_t>(i));
            const double dx = p[0] - c[0], dy = p[1] - c[1];
            if (dx * dx + dy * dy <= r2) f(i);
        });
    }

    // The k nearest points of q (fewer if the grid has fewer), nearest first:
    // (index, distance) pairs.
    std::vector<std::pair<std::int64_t, double>> nearest(const double* q, std::size_t k) const {
        std::vector<std::pair<double, std::int64_t>> best;  // (d2, index), max-heap on d2
        if (k == 0 || size() == 0) return {};
        const long cx = clampx(q[0]), cy = clampy(q[1]);
        const long maxr = static_cast<long>(std::max(nx_, ny_));
        for (long r = 0; r <= maxr; ++r) {
            // Ring r of cells around (cx, cy).
            for (long j = cy - r; j <= cy + r; ++j) {
                if (j < 0 || j >= static_cast<long>(ny_)) continue;
                const bool edge_row = (j == cy - r || j == cy + r);
                for (long i = cx - r; i <= cx + r; i += (edge_row || r == 0) ? 1 : 2 * r) {
                    if (i < 0 || i >= static_cast<long>(nx_)) continue;
                    for (std::int64_t id : cells_[static_cast<std::size_t>(j) * nx_ + static_cast<std::size_t>(i)]) {
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
                    }
                }
            }
            // Every point not yet seen lies at least r cells (minus the
            // query's offset in its cell) away.
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
    long clampx(double x) const {
        const double c = std::floor((x - x0_) / cw_);
        return static_cast<long>(std::min(std::max(c, 0.0), static_cast<double>(nx_ - 1)));
    }
    long clampy(double y) const {
        const double c = std::floor((y - y0_) / ch_);
        return static_cast<long>(std::min(std::max(c, 0.0), static_cast<double>(ny_ - 1)));
    }
    std::size_t cell(double x, double y) const {
        return static_cast<std::size_t>(clampy(y)) * nx_ + static_cast<std::size_t>(clampx(x));
    }
    template <class F>
    void box(double xa, double ya, double xb, double yb, F&& f) const {
        const long i0 = clampx(xa), i1 = clampx(xb), j0 = clampy(ya), j1 = clampy(yb);
        for (long j = j0; j <= j1; ++j)
            for (long i = i0; i <= i1; ++i)
                for (std::int64_t id : cells_[static_cast<std::size_t>(j) * nx_ + static_cast<std::size_t>(i)]) f(id);
    }

    std::size_t nx_ = 1, ny_ = 1;
    double x0_ = 0.0, y0_ = 0.0, cw_ = 1.0, ch_ = 1.0;
    std::vector<std::vector<std::int64_t>> cells_;
    std::vector<double> pts_;
};

}  // namespace faultmesh::detail
