// faultmesh/segments.hpp -- exact tests on points, segments and triangles in XY.
//
// Every decision is a sign of orient2d (predicates.hpp) or a comparison of
// input coordinates: no constructed point, no tolerance. Points may be given
// with any stride (the first two doubles are x, y). These are the only copies
// of these tests in the library (overlap, stitching, cutting, ear clipping and
// the study area use them); they are inline, so a hot loop pays nothing for
// the call.
#pragma once

#include <algorithm>

#include <faultmesh/predicates.hpp>

namespace faultmesh {

// p and q have the same x and y.
inline bool same_point(const double* p, const double* q) { return p[0] == q[0] && p[1] == q[1]; }

// p lies in the closed axis-parallel box of a and b. For p collinear with a
// and b (orient2d(a, b, p) == 0, checked by the caller) this is "p on the
// closed segment [a, b]".
inline bool in_segment_box(const double* a, const double* b, const double* p) {
    return std::min(a[0], b[0]) <= p[0] && p[0] <= std::max(a[0], b[0]) &&
           std::min(a[1], b[1]) <= p[1] && p[1] <= std::max(a[1], b[1]);
}

// p strictly between a and b, given that a, b, p are collinear (checked by the
// caller) and a != b: on the open segment (a, b).
inline bool strictly_between(const double* a, const double* b, const double* p) {
    if (a[0] != b[0]) return p[0] > std::min(a[0], b[0]) && p[0] < std::max(a[0], b[0]);
    return p[1] > std::min(a[1], b[1]) && p[1] < std::max(a[1], b[1]);
}

// True iff p lies on the closed segment [a, b].
inline bool on_segment(const double* a, const double* b, const double* p) {
    if (orient2d(a, b, p) != 0.0) return false;
    return in_segment_box(a, b, p);
}

// True iff the closed segments [a, b] and [c, d] share a point.
inline bool segments_meet(const double* a, const double* b, const double* c, const double* d) {
    const int o1 = orient2d_sign(a, b, c), o2 = orient2d_sign(a, b, d);
    const int o3 = orient2d_sign(c, d, a), o4 = orient2d_sign(c, d, b);
    if (o1 * o2 < 0 && o3 * o4 < 0) return true;
    if (o1 == 0 && in_segment_box(a, b, c)) return true;
    if (o2 == 0 && in_segment_box(a, b, d)) return true;
    if (o3 == 0 && in_segment_box(c, d, a)) return true;
    if (o4 == 0 && in_segment_box(c, d, b)) return true;
    return false;
}

// True iff the closed segment [p, q] (p != q) meets the OPEN triangle
// (a, b, c), which must be counter-clockwise with non-zero area. (A single
// point p == q has no line to separate by: test it with orient2d directly.)
// Separating axes: a triangle
// edge with p and q on its closed outer side, or the segment's line with a,
// b, c on one closed side.
inline bool segment_meets_open_triangle(const double* p, const double* q, const double* a,
                                        const double* b, const double* c) {
    const double* t[3] = {a, b, c};
    for (int e = 0; e < 3; ++e) {
        const double* u = t[e];
        const double* v = t[(e + 1) % 3];
        if (orient2d_sign(u, v, p) <= 0 && orient2d_sign(u, v, q) <= 0) return false;
    }
    const int oa = orient2d_sign(p, q, a), ob = orient2d_sign(p, q, b), oc = orient2d_sign(p, q, c);
    if (oa >= 0 && ob >= 0 && oc >= 0) return false;
    if (oa <= 0 && ob <= 0 && oc <= 0) return false;
    return true;
}

// True iff p lies in the closed triangle (a, b, c) of either orientation; a
// degenerate triangle is the union of its edges.
inline bool in_closed_triangle(const double* p, const double* a, const double* b, const double* c) {
    const int o = orient2d_sign(a, b, c);
    if (o == 0) return on_segment(a, b, p) || on_segment(b, c, p) || on_segment(c, a, p);
    const int s1 = orient2d_sign(a, b, p), s2 = orient2d_sign(b, c, p), s3 = orient2d_sign(c, a, p);
    return s1 * o >= 0 && s2 * o >= 0 && s3 * o >= 0;
}

// True iff the closed segment [p, q] meets the closed triangle (a, b, c) of
// either orientation (degenerate triangles included).
inline bool segment_meets_closed_triangle(const double* p, const double* q, const double* a,
                                          const double* b, const double* c) {
    return in_closed_triangle(p, a, b, c) || segments_meet(p, q, a, b) || segments_meet(p, q, b, c) ||
           segments_meet(p, q, c, a);
}

// The one measure here, in floating point (not a decision of the exact kind
// above): the squared XY distance of p from the closed segment [a, b]. Used
// to pick the nearest of several outline edges (which piece a point beyond
// the outlines belongs to), where a rounding tie may go either way. With s,
// also where on the segment the nearest point lies: a + s (b - a), s in
// [0, 1] (0 for a segment of no length).
inline double segment_distance2(const double* a, const double* b, const double* p, double* s_out = nullptr) {
    const double ex = b[0] - a[0], ey = b[1] - a[1];
    const double len2 = ex * ex + ey * ey;
    double s = len2 > 0 ? ((p[0] - a[0]) * ex + (p[1] - a[1]) * ey) / len2 : 0.0;
    s = s < 0.0 ? 0.0 : (s > 1.0 ? 1.0 : s);
    if (s_out != nullptr) *s_out = s;
    const double dx = a[0] + s * ex - p[0], dy = a[1] + s * ey - p[1];
    return dx * dx + dy * dy;
}

}  // namespace faultmesh
