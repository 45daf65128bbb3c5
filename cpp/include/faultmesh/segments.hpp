// faultmesh/segments.hpp -- exact tests on points, segments and triangles in XY.
//
// Every decision is a sign of orient2d (predicates.hpp) or a comparison of
// input coordinates: no constructed point, no tolerance. Points may be given
// with any stride (the first two doubles are x, y).
#pragma once

#include <algorithm>

#include <faultmesh/predicates.hpp>

namespace faultmesh {

// True iff p lies on the closed segment [a, b].
inline bool on_segment(const double* a, const double* b, const double* p) {
    if (orient2d(a, b, p) != 0.0) return false;
    return std::min(a[0], b[0]) <= p[0] && p[0] <= std::max(a[0], b[0]) &&
           std::min(a[1], b[1]) <= p[1] && p[1] <= std::max(a[1], b[1]);
}

// True iff the closed segments [a, b] and [c, d] share a point.
inline bool segments_meet(const double* a, const double* b, const double* c, const double* d) {
    const int o1 = orient2d_sign(a, b, c), o2 = orient2d_sign(a, b, d);
    const int o3 = orient2d_sign(c, d, a), o4 = orient2d_sign(c, d, b);
    if (o1 * o2 < 0 && o3 * o4 < 0) return true;
    if (o1 == 0 && on_segment(a, b, c)) return true;
    if (o2 == 0 && on_segment(a, b, d)) return true;
    if (o3 == 0 && on_segment(c, d, a)) return true;
    if (o4 == 0 && on_segment(c, d, b)) return true;
    return false;
}

// True iff p lies in the closed triangle (a, b, c) of either orientation; a
// degenerate triangle is the union of its edges.
inline bool in_closed_triangle(const double* p, const double* a, const double* b, const double* c) {
    const int o = orient2d_sign(a, b, c);
    if (o == 0) return on_segment(a, b, p) || on_segment(b, c, p) || on_segment(c, a, p);
    const int s1 = orient2d_sign(a, b, p), s2 = orient2d_sign(b, c, p), s3 = orient2d_sign(c, a, p);
    return s1 * o >= 0 && s2 * o >= 0 && s3 * o >= 0;
}

}  // namespace faultmesh
