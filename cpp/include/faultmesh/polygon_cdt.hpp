// faultmesh/polygon_cdt.hpp -- constrained-Delaunay refinement of an existing
// triangulation by Lawson edge flips (no new vertices).
//
// Used by triangulate_polygon(refine = true); public because stitching and
// tests use it on their own triangulations too.
//
// An edge is "constrained" if its two vertex indices form one of the given
// constrained edges (undirected). Two triangles are neighbours across an edge
// if one has the directed edge (a, b) and the other (b, a), so two different
// vertex indices with equal coordinates are never glued together.
//
// Exactly cocircular quadrilaterals are decided by a symbolic perturbation:
// the four points are sorted lexicographically by (x, y) and the leading
// non-zero term of the perturbed in-circle determinant decides (the rule of
// CGAL's Delaunay_triangulation_2::side_of_oriented_circle with perturb =
// true). The result is therefore unique: the constrained Delaunay
// triangulation of the same edges and vertices as CGAL computes it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <faultmesh/predicates.hpp>

namespace faultmesh {

// The in-circle test with symbolic perturbation, faultmesh::incircle_perturbed,
// lives in <faultmesh/predicates.hpp> with every other predicate.

// Flip every non-constrained interior edge that is not locally Delaunay until
// none is left. `triangles` (3 indices per triangle, counter-clockwise,
// non-degenerate) is modified in place; triangle slots are kept (a flip
// rewrites the two triangles it touches). constrained_edges: 2 indices per
// edge. Returns the number of flips made. Throws std::invalid_argument on an
// index out of range.
std::size_t flip_to_constrained_delaunay(const double* xy, std::size_t n_points,
                                         std::vector<std::int64_t>& triangles,
                                         const std::int64_t* constrained_edges,
                                         std::size_t n_constrained);

// Number of interior, non-constrained edges of the triangulation that are not
// locally Delaunay under incircle_perturbed (0 for a CDT).
std::size_t count_non_delaunay_edges(const double* xy, std::size_t n_points,
                                     const std::vector<std::int64_t>& triangles,
                                     const std::int64_t* constrained_edges,
                                     std::size_t n_constrained);

}  // namespace faultmesh
