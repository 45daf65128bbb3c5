// faultmesh/gap_points.hpp -- points put back into a triangulated polygon:
// each candidate point that lies inside the triangulation becomes a vertex
// (1 -> 3 split of the triangle containing it, 2 -> 4 split of the two
// triangles sharing the edge it lies on), then the constrained-Delaunay
// flips of polygon_cdt.hpp restore the quality (constrained edges are never
// split nor flipped).
//
// Used by the stitcher (stitch.hpp, step 5): the layer's vertices inside the
// removed region would otherwise be lost with the triangles removed around
// a fault patch; the gap triangulation keeps them (issue 10, seeds 617, 986).
//
// Every containment decision uses the exact orient2d. A candidate is skipped
// (not inserted) when it lies outside every triangle, on a constrained or
// boundary edge, or on an existing vertex. Each inserted point adds exactly
// two triangles.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace faultmesh {

// xy: 2 coordinates per point (triangulation vertices and candidates alike).
// triangles: counter-clockwise, non-degenerate, 3 indices per triangle;
// modified in place (new triangles appended). constrained_edges: 2 indices
// per edge (undirected), the polygon's ring edges. candidates: indices of
// the points to insert (duplicates and points already used by a triangle
// are skipped). Returns the candidates inserted, in order. Throws
// std::invalid_argument on an index out of range.
std::vector<std::int64_t> insert_interior_points(const double* xy, std::size_t n_points,
                                                 std::vector<std::int64_t>& triangles,
                                                 const std::int64_t* constrained_edges, std::size_t n_constrained,
                                                 const std::int64_t* candidates, std::size_t n_candidates);

}  // namespace faultmesh
