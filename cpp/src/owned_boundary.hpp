// Private helper of fault_side.cpp and cutting.cpp: the boundary edges of a
// subset of a triangle list with the triangle that owns each, and the owner
// of the edge nearest to a point -- how both continue a fault surface past
// its projection (the plane of the nearest boundary triangle).
#pragma once

#include <faultmesh/nearest_segment.hpp>
#include <faultmesh/segments.hpp>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

namespace faultmesh::detail {

struct OwnedEdge {
    std::int64_t a, b, owner;
};

// Edges used by exactly one of the triangles `rows` of `tri` (3 indices per
// row), each with its triangle. The surfaces are small (one fault): a sort
// of the edges is enough. An edge used more than twice is not a boundary.
inline std::vector<OwnedEdge> owned_boundary_edges(const std::int64_t* tri, const std::vector<std::int64_t>& rows) {
    std::vector<std::pair<std::pair<std::int64_t, std::int64_t>, std::int64_t>> edges;
    edges.reserve(3 * rows.size());
    for (std::int64_t t : rows)
        for (int i = 0; i < 3; ++i) {
            const std::int64_t a = tri[3 * t + i], b = tri[3 * t + (i + 1) % 3];
            edges.push_back({{std::min(a, b), std::max(a, b)}, t});
        }
    std::sort(edges.begin(), edges.end());
    std::vector<OwnedEdge> out;
    for (std::size_t i = 0; i < edges.size();) {
        std::size_t j = i;
        while (j < edges.size() && edges[j].first == edges[i].first) ++j;
        if (j - i == 1) out.push_back({edges[i].first.first, edges[i].first.second, edges[i].second});
        i = j;
    }
    return out;
}

// The boundary edges with their owners, indexed for nearest-edge queries
// (nearest_segment.hpp; built once per surface).
struct OwnedBoundary {
    std::vector<OwnedEdge> edges;
    SegmentIndex index;

    OwnedBoundary() = default;
    // `point(v)` gives vertex v's x, y.
    template <class Point>
    OwnedBoundary(std::vector<OwnedEdge> e, Point point) : edges(std::move(e)) {
        std::vector<double> a(2 * edges.size()), b(2 * edges.size());
        for (std::size_t k = 0; k < edges.size(); ++k) {
            const double* pa = point(edges[k].a);
            const double* pb = point(edges[k].b);
            a[2 * k] = pa[0];
            a[2 * k + 1] = pa[1];
            b[2 * k] = pb[0];
            b[2 * k + 1] = pb[1];
        }
        index = SegmentIndex(a.data(), b.data(), edges.size());
    }

    // Owner of the edge nearest to p in XY (squared distance in `best`);
    // `fallback` when there is no edge. Distances in floating point: this
    // only chooses which plane continues the surface. Ties: the first edge.
    std::int64_t nearest_owner(const double* p, std::int64_t fallback, double& best) const {
        const std::int64_t k = index.nearest(p, best);
        return k < 0 ? fallback : edges[static_cast<std::size_t>(k)].owner;
    }
};

}  // namespace faultmesh::detail
