// faultmesh/delaunay.hpp -- 2D Delaunay triangulation with exact predicates.
//
// Incremental Bowyer-Watson insertion (paper section 2.3.1): each new point
// removes the cavity of triangles whose circumcircle contains it and
// re-triangulates that cavity as a star around the point. Points are inserted
// in a biased randomized insertion order (BRIO) whose rounds are sorted along a
// Hilbert curve, and each point is located by a visibility walk that starts in
// the last triangle created. The convex hull is closed by an infinite vertex
// (ghost triangles), so no numeric super-triangle ever influences the result.
//
// The triangulation is canonical: four exactly cocircular points are decided
// by a symbolic perturbation on the points' lexicographic (x, then y) order --
// the perturbation of CGAL's Delaunay_triangulation_2 -- so the result does not
// depend on the input order and equals CGAL's triangle for triangle (grids,
// seismic horizons). Every orientation and in-circle decision goes through the
// exact predicates of <faultmesh/predicates.hpp>.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace faultmesh {

struct DelaunayResult {
    // 3 per triangle, counter-clockwise, indices into the INPUT points. A group
    // of duplicate points is represented by its smallest input index.
    std::vector<std::int64_t> triangles;
    // halfedges[e] = the opposite half-edge, or -1 on the convex hull. Half-edge
    // e runs triangles[e] -> triangles[e % 3 == 2 ? e - 2 : e + 1].
    std::vector<std::int64_t> halfedges;
    // For every input point: the input index of the point it was merged into
    // (itself when it has no duplicate; the smallest index of its group).
    std::vector<std::int64_t> vertex_of_input;
    // Number of input points merged into an earlier-indexed duplicate.
    std::size_t n_duplicates = 0;
};

// Delaunay triangulation of n points given interleaved as x0, y0, x1, y1, ...
// Throws std::invalid_argument if a coordinate is NaN, infinite or beyond
// faultmesh::kMaxCoordinate = 1e60 (predicates.hpp: where the exact
// predicates could overflow), naming the row, or if n is beyond the supported
// size (3e8 points), and faultmesh::GeometryError if there are fewer than 3
// distinct points or all points are collinear. With with_halfedges = false
// the halfedges vector is left empty (saves time and memory when only the
// triangles are needed). There is no lower limit: tiny coordinates are
// decided exactly too (predicates.hpp, underflow side).
DelaunayResult delaunay(const double* xy, std::size_t n, bool with_halfedges = true);

}  // namespace faultmesh
