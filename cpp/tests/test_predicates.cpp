#include <faultmesh/predicates.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "test_support.hpp"

using faultmesh::incircle_sign;
using faultmesh::orient2d_sign;

// Points on the line y = x, nudged by one ulp: the naive formula gets many of
// these wrong (Kettner et al., "Classroom examples of robustness problems").
TEST(Predicates, Orient2dNearlyCollinearMatchesExactSign) {
    const double b[2] = {24.0, 24.0}, c[2] = {12.0, 12.0};
    for (int i = 0; i < 64; ++i) {
        for (int j = 0; j < 64; ++j) {
            double a[2] = {0.5, 0.5};
            for (int k = 0; k < i; ++k) a[0] = std::nextafter(a[0], 1.0);
            for (int k = 0; k < j; ++k) a[1] = std::nextafter(a[1], 1.0);
            // cross(b - a, c - a) = 12 (a.x - a.y) exactly, for b, c on y = x.
            const int expected = (a[0] > a[1]) - (a[0] < a[1]);
            EXPECT_EQ(orient2d_sign(a, b, c), expected) << i << "," << j;
        }
    }
}

TEST(Predicates, Orient2dExactZeroOnCollinearLargeCoordinates) {
    const double a[2] = {550000.0, 7820000.0}, b[2] = {550001.0, 7820001.0}, c[2] = {550002.5, 7820002.5};
    EXPECT_EQ(orient2d_sign(a, b, c), 0);
    EXPECT_EQ(orient2d_sign(a, c, b), 0);
}

TEST(Predicates, IncircleCocircularGridIsZero) {
    // The four corners of a unit grid cell, translated far from the origin.
    for (double off : {0.0, 1e6, 5.5e5, 7.8e6}) {
        const double a[2] = {off, off}, b[2] = {off + 1, off}, c[2] = {off + 1, off + 1}, d[2] = {off, off + 1};
        EXPECT_EQ(incircle_sign(a, b, c, d), 0) << off;
        const double e[2] = {off + 0.5, off + 0.5};
        EXPECT_EQ(incircle_sign(a, b, c, e), 1) << off;
        const double f[2] = {off + 2, off + 2};
        EXPECT_EQ(incircle_sign(a, b, c, f), -1) << off;
    }
}

TEST(Predicates, IncircleAntisymmetricAndConsistentUnderRandomNearDegenerate) {
    std::mt19937_64 rng(12345);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (int t = 0; t < 20000; ++t) {
        // d is a tiny perturbation of a point on the unit circle through a, b, c.
        const double ta = 0.3, tb = 2.1, tc = 4.0, td = u(rng) * 3.14159;
        const double s = 5.5e5;
        double a[2] = {s + std::cos(ta), s + std::sin(ta)}, b[2] = {s + std::cos(tb), s + std::sin(tb)},
               c[2] = {s + std::cos(tc), s + std::sin(tc)}, d[2] = {s + std::cos(td), s + std::sin(td)};
        const int s1 = incircle_sign(a, b, c, d);
        // Swapping two of the circle points flips the sign; cyclic shifts keep it.
        EXPECT_EQ(incircle_sign(b, a, c, d), -s1);
        EXPECT_EQ(incircle_sign(b, c, a, d), s1);
        EXPECT_EQ(incircle_sign(c, a, b, d), s1);
    }
}

// Underflow: products of tiny coordinate differences vanish in double
// arithmetic; the predicates then decide with exact integers. Small integer
// configurations scaled by 2^-1070 (subnormal, exactly representable) must
// keep the signs of the integer configuration.
namespace {
long long orient_int(const long long* a, const long long* b, const long long* c) {
    return (a[0] - c[0]) * (b[1] - c[1]) - (a[1] - c[1]) * (b[0] - c[0]);
}
long long incircle_int(const long long* a, const long long* b, const long long* c, const long long* d) {
    const long long adx = a[0] - d[0], ady = a[1] - d[1], bdx = b[0] - d[0], bdy = b[1] - d[1],
                    cdx = c[0] - d[0], cdy = c[1] - d[1];
    return (adx * adx + ady * ady) * (bdx * cdy - cdx * bdy) + (bdx * bdx + bdy * bdy) * (cdx * ady - adx * cdy) +
           (cdx * cdx + cdy * cdy) * (adx * bdy - bdx * ady);
}
int sgn(long long v) { return (v > 0) - (v < 0); }
}  // namespace

TEST(Predicates, TinyCoordinatesKeepExactSigns) {
    std::mt19937_64 rng(7);
    std::uniform_int_distribution<long long> U(-9, 9);
    for (double scale : {0x1p-1070, 0x1p-700, 0x1p-520, 0x1p-260, 0x1p-180}) {
        for (int t = 0; t < 3000; ++t) {
            long long P[4][2];
            double D[4][2];
            faultmesh::test::scaled_integer_points(rng, U, scale, P, D);
            ASSERT_EQ(orient2d_sign(D[0], D[1], D[2]), sgn(orient_int(P[0], P[1], P[2]))) << scale;
            ASSERT_EQ(incircle_sign(D[0], D[1], D[2], D[3]), sgn(incircle_int(P[0], P[1], P[2], P[3]))) << scale;
        }
    }
    // The value keeps its sign even below the smallest subnormal.
    const double a[2] = {1e-200, 0}, b[2] = {0, 1e-200}, c[2] = {0, 0};
    EXPECT_GT(faultmesh::orient2d(a, b, c), 0.0);
    EXPECT_LT(faultmesh::orient2d(b, a, c), 0.0);
    // A determinant of order 1e-300 beside coordinates of order one and 2^52.
    const double o[2] = {0, 0}, p[2] = {1, 1e-300};
    const double q[2] = {0x1p52, std::nextafter(1e-300 * 0x1p52, 1.0)};
    EXPECT_LT(faultmesh::orient2d(o, q, p), 0.0);
    EXPECT_GT(faultmesh::orient2d(o, p, q), 0.0);
}

TEST(Predicates, CheckCoordinatesNamesFunctionArgumentRowAndLimit) {
    const double pts[6] = {0, 0, 1, 2e60, 3, 4};
    try {
        faultmesh::check_coordinates(pts, 3, 2, 2, "kernel", "xy");
        FAIL() << "expected std::invalid_argument";
    } catch (const std::invalid_argument& e) {
        const std::string m = e.what();
        EXPECT_NE(m.find("kernel: xy row 1 has a coordinate beyond +-1e+60 (y = 2e+60)"), std::string::npos) << m;
        EXPECT_NE(m.find("kMaxCoordinate"), std::string::npos) << m;
    }
    const double nan_pts[3] = {0, 1, std::nan("")};
    EXPECT_THROW(faultmesh::check_coordinates(nan_pts, 1, 3, 3, "k", "xyz"), std::invalid_argument);
    EXPECT_NO_THROW(faultmesh::check_coordinates(nan_pts, 1, 3, 2, "k", "xyz"));  // z not checked
    const double edge[2] = {1e60, -1e60};
    EXPECT_NO_THROW(faultmesh::check_coordinates(edge, 1, 2, 2, "k", "xy"));
}
