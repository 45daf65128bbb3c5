// Private helper of tin.cpp and cutting.cpp: linear interpolation of z in a
// triangle, decided by the exact predicates.
#pragma once

#include <faultmesh/predicates.hpp>

#include <algorithm>
#include <limits>

namespace faultmesh::detail {

// z at p by linear interpolation in the triangle (a, b, c) (either
// orientation) with vertex values za, zb, zc, for p in the CLOSED triangle.
// The weights are the three orient2d values of p against the triangle's
// edges (the sub-triangle areas: exact signs, values from the adaptive
// predicate) normalised by their sum, so z is a convex combination: exactly
// the vertex's z at a vertex (the other two weights are exactly 0), on an edge
// only the edge's two vertices count, never NaN from the geometry (a sliver
// that the exact predicates accept has a positive weight sum), and never
// outside [min, max] of the contributing vertices' z -- the rounding of the
// weighted sum could overshoot by an ulp, so the result is clamped to that
// range. A NaN z of a contributing vertex gives NaN; p outside the closed
// triangle (mixed signs) or a degenerate triangle gives NaN.
inline double interpolate_in_triangle(const double* a, const double* b, const double* c, const double* p,
                                      double za, double zb, double zc) {
    double w[3] = {orient2d(b, c, p), orient2d(c, a, p), orient2d(a, b, p)};
    if (w[0] < 0.0 || w[1] < 0.0 || w[2] < 0.0)
        for (double& x : w) x = -x;  // a clockwise triangle
    const double z[3] = {za, zb, zc};
    double sum = 0.0;
    for (const double x : w) {
        if (x < 0.0) return std::numeric_limits<double>::quiet_NaN();  // outside
        sum += x;
    }
    if (!(sum > 0.0)) return std::numeric_limits<double>::quiet_NaN();  // degenerate
    double r = 0.0, lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (int i = 0; i < 3; ++i) {
        if (w[i] == 0.0) continue;  // p on the opposite edge: this vertex does not count
        r += (w[i] / sum) * z[i];
        if (z[i] != z[i]) return z[i];
        lo = std::min(lo, z[i]);
        hi = std::max(hi, z[i]);
    }
    if (r != r) return r;  // inf - inf among the z
    return std::min(std::max(r, lo), hi);
}

}  // namespace faultmesh::detail
