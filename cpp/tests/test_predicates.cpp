#include <faultmesh/predicates.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

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
