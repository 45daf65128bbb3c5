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
#include <cstddef>
#include <string>

namespace faultmesh {

// ------------------------------------------------------------ coordinate range
// The one coordinate limit of the library: every kernel rejects, on entry, a
// coordinate (x, y, and z where z enters a computation) that is NaN, infinite
// or larger in magnitude than kMaxCoordinate, with std::invalid_argument
// naming the function, the argument, the row and this limit.
//
// Overflow side. The in-circle determinant is the predicate of highest degree:
// 4 in the coordinate differences. With |c| <= 1e60 a difference is at most
// 2e60, a product of four at most 1.6e241, and the largest sum the predicates
// form (the in-circle permanent: 6 such products, times the 2^27 + 1 of
// Dekker's split applied to factors of degree <= 3) stays below 1e250, far
// from DBL_MAX = 1.8e308: no product, sum or expansion component can
// overflow, so the signs stay exact. The same margin covers the kernels' own
// floating-point work (squared lengths, 3D cross products squared: degree 4).
// At 1e78 the in-circle products overflow (NaN), at ~1e154 orient2d's do.
//
// Underflow side: there is no lower limit. Products of tiny coordinate
// differences can underflow (below DBL_MIN = 2.2e-308 they lose bits, below
// 2^-1075 they vanish), which would make the expansion arithmetic inexact.
// The predicates detect every case where that could change a sign -- the
// filter's magnitude (|detleft| + |detright|, or the in-circle / orient3d
// permanent) below 2^-900, or an exact-stage result below 2^-1000, while some
// non-zero coordinate is tiny (below 2^-400 for orient2d, 2^-280 for
// orient3d, 2^-200 for incircle: above those, every non-zero product of the
// exact stages is a normal double) --
// and then decide with exact integer arithmetic on the raw doubles (every
// double is an integer multiple of 2^-1074). The sign is therefore exact for
// every finite input within the range; a returned value whose magnitude is
// below the smallest subnormal is returned as +-4.9e-324, keeping its sign.
constexpr double kMaxCoordinate = 1e60;

// True iff c is a finite number with |c| <= kMaxCoordinate (false for NaN).
inline bool coordinate_in_range(double c) { return std::fabs(c) <= kMaxCoordinate; }

// Throws std::invalid_argument for the first of n points (`stride` doubles
// each; the first `dims` are checked) with a coordinate outside the range:
//   "<fn>: <what> row <i> has a non-finite coordinate (x = nan)" or
//   "<fn>: <what> row <i> has a coordinate beyond +-1e+60 (y = 2e+70), ..."
// naming the limit. O(n), one pass without branches on the common path.
void check_coordinates(const double* points, std::size_t n, std::size_t stride, std::size_t dims,
                       const char* fn, const char* what);

// The message of check_coordinates for one value: `where` names the point
// (e.g. "ring 2 vertex 5"), axis is 0, 1, 2 for x, y, z.
[[noreturn]] void throw_coordinate_error(const std::string& fn, const std::string& where, int axis,
                                         double value);

namespace detail {
// Error-bound constants of Shewchuk's paper with epsilon = 2^-53.
constexpr double kEpsilon = 1.1102230246251565e-16;
constexpr double kCcwErrBoundA = (3.0 + 16.0 * kEpsilon) * kEpsilon;
constexpr double kIccErrBoundA = (10.0 + 96.0 * kEpsilon) * kEpsilon;
// Below this filter magnitude a product may have underflowed (see above).
constexpr double kUnderflowGuard = 0x1p-900;

double orient2d_adapt(const double* pa, const double* pb, const double* pc, double detsum);
double incircle_adapt(const double* pa, const double* pb, const double* pc, const double* pd,
                      double permanent);
// The filter's magnitude is below kUnderflowGuard (or not a number).
double orient2d_small(const double* pa, const double* pb, const double* pc);
double incircle_small(const double* pa, const double* pb, const double* pc, const double* pd);
}  // namespace detail

// Twice the signed area of triangle (a, b, c): > 0 if a, b, c are in
// counter-clockwise order, < 0 if clockwise, exactly 0 if collinear.
inline double orient2d(const double* pa, const double* pb, const double* pc) {
    const double acx = pa[0] - pc[0], bcy = pb[1] - pc[1];
    const double acy = pa[1] - pc[1], bcx = pb[0] - pc[0];
    const double detleft = acx * bcy;
    const double detright = acy * bcx;
    const double det = detleft - detright;
    double detsum;
    // Where the signs of the two products decide, |det| is their magnitude
    // sum; below kUnderflowGuard a product may have underflowed.
    if (detleft > 0.0) {
        if (detright <= 0.0) return det >= detail::kUnderflowGuard ? det : detail::orient2d_small(pa, pb, pc);
        detsum = detleft + detright;
    } else if (detleft < 0.0) {
        if (detright >= 0.0) return -det >= detail::kUnderflowGuard ? det : detail::orient2d_small(pa, pb, pc);
        detsum = -detleft - detright;
    } else {
        if (det >= detail::kUnderflowGuard || -det >= detail::kUnderflowGuard) return det;
        // Both products zero through a zero factor (collinear grid points):
        // exactly 0, no underflow involved. (Differences of doubles are 0
        // only for equal operands.)
        if (det == 0.0 && (acx == 0.0 || bcy == 0.0) && (acy == 0.0 || bcx == 0.0)) return 0.0;
        return detail::orient2d_small(pa, pb, pc);
    }
    if (!(detsum >= detail::kUnderflowGuard)) return detail::orient2d_small(pa, pb, pc);
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
    if (!(permanent >= detail::kUnderflowGuard)) return detail::incircle_small(pa, pb, pc, pd);
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
// The permanent is below kUnderflowGuard (or not a number): the same
// underflow handling as orient2d_small, with exact integers on the raw
// doubles where a coordinate is tiny (below 2^-280: degree 3). det and
// permanent: the filter's values, as orient3d computed them.
double orient3d_small(const double* pa, const double* pb, const double* pc, const double* pd, double det,
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
    if (!(permanent >= detail::kUnderflowGuard)) return detail::orient3d_small(pa, pb, pc, pd, det, permanent);
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
