// faultmesh/predicates.hpp -- exact orientation and in-circle tests.
//
// Every geometric decision in faultmesh (which side of a line or of a plane,
// inside a circumcircle, segment crossing) goes through these functions. They are
// Shewchuk's adaptive-precision predicates ("Adaptive Precision Floating-Point
// Arithmetic and Fast Robust Geometric Predicates", 1997), written for this
// library: a floating-point filter answers almost every call; only when the
// rounded result is too close to zero to trust its sign does the code fall
// back to exact expansion arithmetic. The sign returned is always the sign of
// the exact determinant of the double inputs.
//
// Requirements: IEEE-754 double arithmetic with round-to-nearest and no fused
// multiply-add contraction (the library is compiled with -ffp-contract=off and
// exports that flag to consumers, because the error bounds below assume every
// product and sum is rounded separately).
#pragma once

#include <cmath>

namespace faultmesh {

namespace detail {
// Error-bound constants of Shewchuk's paper with epsilon = 2^-53.
constexpr double kEpsilon = 1.1102230246251565e-16;
constexpr double kCcwErrBoundA = (3.0 + 16.0 * kEpsilon) * kEpsilon;
constexpr double kIccErrBoundA = (10.0 + 96.0 * kEpsilon) * kEpsilon;

double orient2d_adapt(const double* pa, const double* pb, const double* pc, double detsum);
double incircle_adapt(const double* pa, const double* pb, const double* pc, const double* pd,
                      double permanent);
}  // namespace detail

// Twice the signed area of triangle (a, b, c): > 0 if a, b, c are in
// counter-clockwise order, < 0 if clockwise, exactly 0 if collinear.
inline double orient2d(const double* pa, const double* pb, const double* pc) {
    const double detleft = (pa[0] - pc[0]) * (pb[1] - pc[1]);
    const double detright = (pa[1] - pc[1]) * (pb[0] - pc[0]);
    const double det = detleft - detright;
    double detsum;
    if (detleft > 0.0) {
        if (detright <= 0.0) return det;
        detsum = detleft + detright;
    } else if (detleft < 0.0) {
        if (detright >= 0.0) return det;
        detsum = -detleft - detright;
    } else {
        return det;
    }
    const double errbound = detail::kCcwErrBoundA * detsum;
    if (det >= errbound || -det >= errbound) return det;
    return detail::orient2d_adapt(pa, pb, pc, detsum);
}

// > 0 if d lies inside the circle through a, b, c (given counter-clockwise),
// < 0 if outside, exactly 0 if the four points are cocircular.
inline double incircle(const double* pa, const double* pb, const double* pc, const double* pd) {
    const double adx = pa[0] - pd[0], bdx = pb[0] - pd[0], cdx = pc[0] - pd[0];
    const double ady = pa[1] - pd[1], bdy = pb[1] - pd[1], cdy = pc[1] - pd[1];

    const double bdxcdy = bdx * cdy, cdxbdy = cdx * bdy;
    const double alift = adx * adx + ady * ady;
    const double cdxady = cdx * ady, adxcdy = adx * cdy;
    const double blift = bdx * bdx + bdy * bdy;
    const double adxbdy = adx * bdy, bdxady = bdx * ady;
    const double clift = cdx * cdx + cdy * cdy;

    const double det = alift * (bdxcdy - cdxbdy) + blift * (cdxady - adxcdy) +
                       clift * (adxbdy - bdxady);
    const double permanent = (std::fabs(bdxcdy) + std::fabs(cdxbdy)) * alift +
                             (std::fabs(cdxady) + std::fabs(adxcdy)) * blift +
                             (std::fabs(adxbdy) + std::fabs(bdxady)) * clift;
    const double errbound = detail::kIccErrBoundA * permanent;
    if (det > errbound || -det > errbound) return det;
    return detail::incircle_adapt(pa, pb, pc, pd, permanent);
}

// Lexicographic order (x, then y): the order of the symbolic perturbation below.
inline bool lex_less(const double* a, const double* b) {
    return a[0] < b[0] || (a[0] == b[0] && a[1] < b[1]);
}

namespace detail {
int incircle_perturbed_tie(const double* pa, const double* pb, const double* pc, const double* pd);
}  // namespace detail

// In-circle test with symbolic perturbation for exact ties, so that every
// configuration has one answer and the Delaunay triangulation is unique
// (canonical for any insertion order, and the same as CGAL's
// Delaunay_triangulation_2, which perturbs the same way). (a, b, c)
// counter-clockwise; > 0 if d is inside or perturbed inside, < 0 outside;
// never 0 for four distinct points with a, b, c not collinear.
//
// The perturbation: point p_i is lifted by eps^(rank of p_i in lex order),
// eps infinitesimal. When the exact determinant is 0, the sign is that of the
// first non-vanishing coefficient, taking the points from the lexicographically
// largest down: if that point is d, d is outside; if it is one of a, b, c, the
// coefficient is the orientation of the triangle with d in that point's place.
// Two points suffice (Devillers & Teillaud, "Perturbations for Delaunay and
// weighted Delaunay 3D triangulations", 2011).
inline int incircle_perturbed(const double* pa, const double* pb, const double* pc, const double* pd) {
    const double det = incircle(pa, pb, pc, pd);
    if (det > 0.0) return 1;
    if (det < 0.0) return -1;
    return detail::incircle_perturbed_tie(pa, pb, pc, pd);
}

// Sign helpers: -1, 0 or +1.
inline int orient2d_sign(const double* pa, const double* pb, const double* pc) {
    const double d = orient2d(pa, pb, pc);
    return (d > 0.0) - (d < 0.0);
}
inline int incircle_sign(const double* pa, const double* pb, const double* pc, const double* pd) {
    const double d = incircle(pa, pb, pc, pd);
    return (d > 0.0) - (d < 0.0);
}


// ---------------------------------------------------------------------------
// orient3d (Shewchuk 1997, section 4 and predicates.c: orient3d/orient3dadapt).
// The same adaptive scheme as orient2d: a floating-point filter (stage A),
// exact products of the rounded differences (B), a first-order correction
// by the differences' rounding errors (C), and the exact determinant on the
// differences carried as two-term expansions when C cannot decide.
namespace detail {
constexpr double kO3dErrBoundA = (7.0 + 56.0 * kEpsilon) * kEpsilon;
double orient3d_adapt(const double* pa, const double* pb, const double* pc, const double* pd,
                      double permanent);
}  // namespace detail

// Six times the signed volume of the tetrahedron (a, b, c, d), with Shewchuk's
// sign convention: > 0 if d lies BELOW the plane through a, b, c, where
// "below" is the side from which a, b, c appear clockwise (a, b, c
// counter-clockwise seen from above, i.e. from +z); < 0 above; exactly 0 if
// the four points are coplanar. The sign is always that of the exact
// determinant of the double inputs. A cyclic relabelling of the axes
// (x, y, z) -> (y, z, x) leaves the value unchanged, so "above" may be read
// along any axis k with a, b, c counter-clockwise in the plane of the axes
// (k + 1) % 3, (k + 2) % 3 (faultmesh/fault_side.hpp uses this).
inline double orient3d(const double* pa, const double* pb, const double* pc, const double* pd) {
    const double adx = pa[0] - pd[0], bdx = pb[0] - pd[0], cdx = pc[0] - pd[0];
    const double ady = pa[1] - pd[1], bdy = pb[1] - pd[1], cdy = pc[1] - pd[1];
    const double adz = pa[2] - pd[2], bdz = pb[2] - pd[2], cdz = pc[2] - pd[2];

    const double bdxcdy = bdx * cdy, cdxbdy = cdx * bdy;
    const double cdxady = cdx * ady, adxcdy = adx * cdy;
    const double adxbdy = adx * bdy, bdxady = bdx * ady;

    const double det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady);
    const double permanent = (std::fabs(bdxcdy) + std::fabs(cdxbdy)) * std::fabs(adz) +
                             (std::fabs(cdxady) + std::fabs(adxcdy)) * std::fabs(bdz) +
                             (std::fabs(adxbdy) + std::fabs(bdxady)) * std::fabs(cdz);
    const double errbound = detail::kO3dErrBoundA * permanent;
    if (det > errbound || -det > errbound) return det;
    return detail::orient3d_adapt(pa, pb, pc, pd, permanent);
}

inline int orient3d_sign(const double* pa, const double* pb, const double* pc, const double* pd) {
    const double d = orient3d(pa, pb, pc, pd);
    return (d > 0.0) - (d < 0.0);
}
// ---------------------------------------------------------------------------

}  // namespace faultmesh
