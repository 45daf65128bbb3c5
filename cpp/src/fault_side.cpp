// Side of a fault surface (see faultmesh/fault_side.hpp for the method).
#include <faultmesh/fault_side.hpp>

#include <faultmesh/aabb_tree.hpp>
#include <faultmesh/errors.hpp>
#include <faultmesh/predicates.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "owned_boundary.hpp"

namespace faultmesh {
namespace detail {

using Index = std::int64_t;

// The fault TIN projected along `axis`: 2D copies (u, v) of the vertices, the
// triangles with a non-zero projected area and their orientation signs.
class ProjectedFault {
public:
    // Copies of the vertices and triangles: the object outlives the call.
    ProjectedFault(const double* xyz, std::size_t n, const Index* tri, std::size_t m, int axis)
        : xyz_(xyz, xyz + 3 * n), tri_(tri, tri + 3 * m), uv_(2 * n), sign_(m, 0) {
        const int iu = (axis + 1) % 3, iv = (axis + 2) % 3;
        for (std::size_t i = 0; i < n; ++i) {
            uv_[2 * i] = xyz[3 * i + iu];
            uv_[2 * i + 1] = xyz[3 * i + iv];
        }
        std::vector<Box2> boxes;
        for (std::size_t t = 0; t < m; ++t) {
            const double* a = uv(tri[3 * t]);
            const double* b = uv(tri[3 * t + 1]);
            const double* c = uv(tri[3 * t + 2]);
            const int o = orient2d_sign(a, b, c);
            if (o == 0) continue;  // vertical in the projection: no height there
            sign_[t] = static_cast<std::int8_t>(o);
            live_.push_back(static_cast<Index>(t));
            boxes.push_back({std::min({a[0], b[0], c[0]}), std::min({a[1], b[1], c[1]}),
                             std::max({a[0], b[0], c[0]}), std::max({a[1], b[1], c[1]})});
        }
        if (live_.empty())
            throw GeometryError("fault_side: no fault triangle has a non-zero area in the projection along " +
                                std::string(1, "xyz"[axis]) + " (choose another axis)");
        tree_ = AabbTree(boxes);
        // Boundary edges of the live triangles and their owners: the planes
        // that continue the surface past its edges.
        boundary_ = detail::OwnedBoundary(detail::owned_boundary_edges(tri_.data(), live_),
                                          [this](Index v) { return uv(v); });
    }

    const double* uv(Index v) const { return uv_.data() + 2 * v; }
    const double* xyz(Index v) const { return xyz_.data() + 3 * v; }
    std::size_t n_triangles() const { return sign_.size(); }

    // The smallest-index triangle whose closed projection contains q (u, v), or -1.
    Index locate(const double* q) const {
        Index best = -1;
        tree_.visit(Box2{q[0], q[1], q[0], q[1]}, [&](std::int64_t k) {
            const Index t = live_[static_cast<std::size_t>(k)];
            if (best >= 0 && t >= best) return;
            if (contains(t, q)) best = t;
        });
        return best;
    }

    // Owner of the boundary edge nearest to q in the projection (distances in
    // floating point: this only chooses which plane continues the surface; the
    // side against that plane is exact).
    Index nearest_boundary_owner(const double* q) const {
        double best;
        return boundary_.nearest_owner(q, live_.front(), best);
    }

    // +1 if p lies on the +axis side of triangle t's plane, -1 on the other, 0 on it.
    int plane_side(Index t, const double* p) const {
        const int o = orient3d_sign(xyz(tri_[3 * t]), xyz(tri_[3 * t + 1]), xyz(tri_[3 * t + 2]), p);
        return -o * sign_[static_cast<std::size_t>(t)];
    }

private:
    bool contains(Index t, const double* q) const {
        const double* a = uv(tri_[3 * t]);
        const double* b = uv(tri_[3 * t + 1]);
        const double* c = uv(tri_[3 * t + 2]);
        const int s = sign_[static_cast<std::size_t>(t)];
        return s * orient2d_sign(a, b, q) >= 0 && s * orient2d_sign(b, c, q) >= 0 &&
               s * orient2d_sign(c, a, q) >= 0;
    }

    std::vector<double> xyz_;
    std::vector<Index> tri_;
    std::vector<double> uv_;
    std::vector<std::int8_t> sign_;
    std::vector<Index> live_;
    detail::OwnedBoundary boundary_;
    AabbTree tree_;
};

}  // namespace detail

FaultSide::FaultSide(const double* vertices, std::size_t n_vertices, const std::int64_t* triangles,
                     std::size_t n_triangles, int axis, int hanging_sign, const std::uint8_t* extent)
    : FaultSide("FaultSide", vertices, n_vertices, triangles, n_triangles, axis, hanging_sign, extent) {}

FaultSide::FaultSide(const char* fn, const double* vertices, std::size_t n_vertices, const std::int64_t* triangles,
                     std::size_t n_triangles, int axis, int hanging_sign, const std::uint8_t* extent)
    : hanging_sign_(hanging_sign), axis_(axis) {
    using Index = std::int64_t;
    const std::string f(fn);
    if (axis < 0 || axis > 2)
        throw std::invalid_argument(f + ": axis must be 0 (x), 1 (y) or 2 (z), got " + std::to_string(axis));
    if (hanging_sign != 1 && hanging_sign != -1)
        throw std::invalid_argument(f + ": hanging_sign must be +1 or -1, got " + std::to_string(hanging_sign));
    for (std::size_t t = 0; t < n_triangles; ++t)
        for (int i = 0; i < 3; ++i) {
            const Index v = triangles[3 * t + i];
            if (v < 0 || static_cast<std::size_t>(v) >= n_vertices)
                throw std::invalid_argument(f + ": triangles row " + std::to_string(t) + " has vertex index " +
                                            std::to_string(v) + " outside [0, " + std::to_string(n_vertices) + ")");
        }
    // All three coordinates enter orient2d (projected) and orient3d.
    check_coordinates(vertices, n_vertices, 3, 3, fn, "vertices");
    if (n_triangles == 0) throw GeometryError(f + ": the fault surface has no triangle");
    fault_ = std::make_unique<detail::ProjectedFault>(vertices, n_vertices, triangles, n_triangles, axis);
    if (extent != nullptr) extent_.assign(extent, extent + n_triangles);
}

FaultSide::~FaultSide() = default;
FaultSide::FaultSide(FaultSide&&) noexcept = default;
FaultSide& FaultSide::operator=(FaultSide&&) noexcept = default;

std::size_t FaultSide::n_triangles() const { return fault_->n_triangles(); }

FaultSideResult FaultSide::sides(const double* points, std::size_t n_points) const {
    check_coordinates(points, n_points, 3, 3, "FaultSide.sides", "points");
    return query(points, n_points);
}

FaultSideResult FaultSide::query(const double* points, std::size_t n_points) const {
    using Index = std::int64_t;
    const detail::ProjectedFault& fault = *fault_;
    const int iu = (axis_ + 1) % 3, iv = (axis_ + 2) % 3;
    FaultSideResult out;
    out.side.resize(n_points);
    out.extended.resize(n_points);
    out.triangle.resize(n_points);
    out.located.resize(n_points);
    for (std::size_t i = 0; i < n_points; ++i) {
        const double* p = points + 3 * i;
        const double q[2] = {p[iu], p[iv]};
        Index t = fault.locate(q);
        const bool located = t >= 0;
        if (!located) t = fault.nearest_boundary_owner(q);
        const auto s = static_cast<std::int8_t>(hanging_sign_ * fault.plane_side(t, p));
        const bool inside = located && (extent_.empty() || extent_[static_cast<std::size_t>(t)] != 0);
        out.extended[i] = s;
        out.side[i] = inside ? s : kBeyondFault;
        out.triangle[i] = t;
        out.located[i] = located ? 1 : 0;
    }
    return out;
}

FaultSideResult fault_side(const double* vertices, std::size_t n_vertices, const std::int64_t* triangles,
                           std::size_t n_triangles, const double* points, std::size_t n_points, int axis,
                           int hanging_sign, const std::uint8_t* extent) {
    const FaultSide fault("fault_side", vertices, n_vertices, triangles, n_triangles, axis, hanging_sign, extent);
    check_coordinates(points, n_points, 3, 3, "fault_side", "points");
    return fault.query(points, n_points);
}

}  // namespace faultmesh
