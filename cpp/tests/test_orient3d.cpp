// orient3d (predicates.hpp): exact signs on near-coplanar inputs.
#include <faultmesh/predicates.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "test_support.hpp"

using faultmesh::orient3d;
using faultmesh::orient3d_sign;

// d = (x, y, 0) with x, y a few ulps around 0.5, against the plane z = x - y
// through a, b, c (counter-clockwise seen from +z). x - y is exact
// (Sterbenz), so d is above the plane iff y > x: orient3d < 0.
TEST(Orient3d, UlpGridAgainstPlaneMatchesExactSign) {
    const double a[3] = {12.0, 12.0, 0.0}, b[3] = {24.0, 12.0, 12.0}, c[3] = {12.0, 24.0, -12.0};
    for (int i = 0; i < 48; ++i) {
        for (int j = 0; j < 48; ++j) {
            double d[3] = {0.5, 0.5, 0.0};
            for (int k = 0; k < i; ++k) d[0] = std::nextafter(d[0], 1.0);
            for (int k = 0; k < j; ++k) d[1] = std::nextafter(d[1], 1.0);
            const int expected = (d[0] > d[1]) - (d[0] < d[1]);  // below <=> x > y
            EXPECT_EQ(orient3d_sign(a, b, c, d), expected) << i << "," << j;
        }
    }
}

// Points on z = x + 2y at UTM-like magnitudes (every value an integer, so
// exactly on the plane); d moved by one ulp in z leaves it.
TEST(Orient3d, UtmCoplanarIsZeroAndOneUlpDecides) {
    const double x0 = 550000.0, y0 = 7820000.0;
    const double a[3] = {x0, y0, x0 + 2 * y0};
    const double b[3] = {x0 + 7, y0 + 1, x0 + 7 + 2 * (y0 + 1)};
    const double c[3] = {x0 + 3, y0 + 9, x0 + 3 + 2 * (y0 + 9)};
    for (double t : {0.0, 1.0, 123.0, -4096.0}) {
        double d[3] = {x0 + t, y0 + 5, x0 + t + 2 * (y0 + 5)};
        EXPECT_EQ(orient3d_sign(a, b, c, d), 0) << t;
        const double z = d[2];
        d[2] = std::nextafter(z, 1e300);
        EXPECT_EQ(orient3d_sign(a, b, c, d), -1) << t;  // above
        d[2] = std::nextafter(z, -1e300);
        EXPECT_EQ(orient3d_sign(a, b, c, d), 1) << t;  // below
    }
}

// Swapping two of a, b, c flips the sign; cyclic shifts and the cyclic
// relabelling of the axes keep it, on random near-coplanar quadruples at
// UTM offsets (differences inexact, so the exact stage is exercised).
TEST(Orient3d, SymmetriesOnRandomNearCoplanar) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    int zero = 0;
    for (int t = 0; t < 20000; ++t) {
        const double s[3] = {551234.123, 7817654.321, -10234.5};
        double a[3], b[3], c[3], d[3];
        for (int k = 0; k < 3; ++k) {
            a[k] = s[k] + 100 * u(rng);
            b[k] = s[k] + 100 * u(rng);
            c[k] = s[k] + 100 * u(rng);
        }
        const double w1 = 0.5 * (u(rng) + 1), w2 = 0.5 * (1 - w1) * (u(rng) + 1);
        for (int k = 0; k < 3; ++k) d[k] = a[k] + w1 * (b[k] - a[k]) + w2 * (c[k] - a[k]);
        const int s1 = orient3d_sign(a, b, c, d);
        zero += s1 == 0;
        EXPECT_EQ(orient3d_sign(b, a, c, d), -s1);
        EXPECT_EQ(orient3d_sign(b, c, a, d), s1);
        EXPECT_EQ(orient3d_sign(a, c, b, d), -s1);
        const double ra[3] = {a[1], a[2], a[0]}, rb[3] = {b[1], b[2], b[0]}, rc[3] = {c[1], c[2], c[0]},
                     rd[3] = {d[1], d[2], d[0]};
        EXPECT_EQ(orient3d_sign(ra, rb, rc, rd), s1);
    }
    EXPECT_LT(zero, 20000);  // rounded points are rarely exactly coplanar
}

TEST(Orient3d, ValueApproximatesSixTimesVolume) {
    const double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, c[3] = {0, 1, 0}, d[3] = {0, 0, -3};
    EXPECT_DOUBLE_EQ(orient3d(a, b, c, d), 3.0);
}

// Tiny coordinates: every product of three differences underflows (s = 1e-200:
// s^3 is far below the smallest subnormal), so the float stages see 0; the
// exact-integer fallback decides (as for orient2d / incircle). A one-ulp lift
// of a coplanar point at scale 2^-1000 keeps its sign too.
TEST(Orient3d, TinyCoordinatesKeepExactSigns) {
    for (const double s : {1e-120, 1e-200, 2.0e-300, 4.9406564584124654e-324}) {
        const double a[3] = {s, 0, 0}, b[3] = {0, s, 0}, c[3] = {0, 0, 0};
        const double below[3] = {0, 0, -s}, above[3] = {0, 0, s}, on[3] = {s, -s, 0};
        EXPECT_EQ(orient3d_sign(a, b, c, below), 1) << s;
        EXPECT_EQ(orient3d_sign(a, b, c, above), -1) << s;
        EXPECT_EQ(orient3d_sign(a, b, c, on), 0) << s;
        EXPECT_NE(orient3d(a, b, c, below), 0.0) << s;
    }
    const double u = std::ldexp(1.0, -1000);
    const double a[3] = {0, 0, u}, b[3] = {u, 0, u}, c[3] = {0, u, u};
    const double d[3] = {u / 4, u / 4, std::nextafter(u, 0.0)};  // just below the plane z = u
    EXPECT_EQ(orient3d_sign(a, b, c, d), 1);
}

// Small integers times tiny scales (products of three differences underflow
// or lose bits) against the determinant in 64-bit integers.
TEST(Orient3d, TinyScaledIntegerPointsMatchIntegerDeterminant) {
    std::mt19937_64 rng(11);
    std::uniform_int_distribution<long long> U(-9, 9);
    for (double scale : {0x1p-1070, 0x1p-700, 0x1p-400, 0x1p-300, 0x1p-250}) {
        for (int t = 0; t < 3000; ++t) {
            long long P[4][3];
            double D[4][3];
            faultmesh::test::scaled_integer_points(rng, U, scale, P, D);
            long long r[3][3];
            for (int i = 0; i < 3; ++i)
                for (int k = 0; k < 3; ++k) r[i][k] = P[i][k] - P[3][k];
            const long long det = r[0][2] * (r[1][0] * r[2][1] - r[2][0] * r[1][1]) +
                                  r[1][2] * (r[2][0] * r[0][1] - r[0][0] * r[2][1]) +
                                  r[2][2] * (r[0][0] * r[1][1] - r[1][0] * r[0][1]);
            ASSERT_EQ(orient3d_sign(D[0], D[1], D[2], D[3]), (det > 0) - (det < 0)) << scale;
        }
    }
}
