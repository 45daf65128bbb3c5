// faultmesh/loft.hpp -- triangulation of the strip between two polylines
// (paper section 2.3.2: "contour line triangulation reconstruction" of the
// fault plane and of the hanging-wall / footwall traces between sections).
//
// Points: a has k points, b has l points, `stride` doubles each (2 or 3; a
// missing z is 0). The result indexes the points of a then b: a[i] is i,
// b[j] is k + j.
//
// Open polylines (closed = false): a[0] corresponds to b[0] and a[k-1] to
// b[l-1]. Every triangle uses one polyline edge and two "rungs" (segments
// between a and b); the triangulation is a monotone path in the k x l grid
// of rungs from (0, 0) to (k-1, l-1), so it has exactly k + l - 2 triangles
// and uses every edge of a and of b exactly once. One point on a side (a
// fault tip) gives a fan.
//   LoftMethod::min_area: the optimal triangulation of Fuchs, Kedem and
//     Uselton (1977) for the cost "sum of 3D triangle areas": dynamic
//     programming over the grid, O(k l) time, O(k l) bits for the path.
//   LoftMethod::shortest_diagonal: the greedy rule (Christiansen and
//     Sederberg; Liu et al. 2003): from rung (i, j) advance along the side
//     whose new rung, (i+1, j) or (i, j+1), is shorter in 3D.
//   Ties go to advancing along a (deterministic).
//   Neither method emits a triangle of three distinct points collinear in
//   3D (zero area, decided exactly) where a path without it exists: min_area
//   minimises (number of such triangles, area) lexicographically (a zero
//   triangle costs no area, so the plain DP would prefer it: polylines that
//   share a point, a straight polyline whose partner reaches the shared
//   point early); shortest_diagonal takes the other diagonal, and an open
//   loft whose greedy path still has one takes the min_area path instead.
//   A triangle with a repeated point (polylines sharing a point: a pinch)
//   is not counted; callers drop it.
//
// Closed contours (closed = true): both polylines are closed loops (last
// point not repeated), travelling in the same rotational direction; each has
// one point (a tip: fan) or at least three. The result has e(a) + e(b)
// triangles, e = number of loop edges (k, or 0 for a single point), every
// loop edge, closing edges included, used once. min_area: a[0] is fixed and
// every start b[s] is tried (FKU's multiple-start search, O(k l^2));
// shortest_diagonal starts from the b point nearest to a[0].
//
// Orientation: with a drawn left to right at the bottom and b left to right
// at the top (both in their direction of travel), every triangle is
// counter-clockwise; in 3D the normal of every triangle is on the same side
// of the strip, along t x (b - a) where t is the direction of travel. The
// triangles are (a[i], a[i+1], b[j]) and (a[i], b[j+1], b[j]) (indices as
// above); interior rungs appear once in each direction.
//
// Throws std::invalid_argument if a side is empty, stride is not 2 or 3, or a
// coordinate is not finite.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace faultmesh {

enum class LoftMethod { min_area, shortest_diagonal };

struct LoftOptions {
    LoftMethod method = LoftMethod::min_area;
    bool closed = false;
};

// Triangles (3 indices each) over the points of a then b.
std::vector<std::int64_t> loft(const double* a, std::size_t k, const double* b, std::size_t l,
                               std::size_t stride, const LoftOptions& options = {});

// Sum of the 3D areas of triangles over the points of a then b (the cost
// that min_area minimises), for tests and comparisons.
double loft_area(const double* a, std::size_t k, const double* b, std::size_t l,
                 std::size_t stride, const std::vector<std::int64_t>& triangles);

}  // namespace faultmesh
