// Tests of surface_sampling.hpp: a surface's elevations at points, and the
// sheet nearest to a datum where the surface folds. The points lie off the
// triangles' diagonals (a point on one counts once per triangle).
#include <faultmesh/surface_sampling.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <vector>

namespace fm = faultmesh;

namespace {

// A layer repeated by a reverse fault, in profile along x and constant in
// y over [0, 10]: the footwall sheet at z = -10 for x in [0, 6], the
// hanging-wall sheet at z = 0 for x in [4, 10], and the fault strip between
// the two cutoffs, from (6, -10) back over to (4, 0): three sheets over
// x in (4, 6).
struct Folded {
    std::vector<double> V{
        0, 0, -10, 6, 0, -10, 6, 10, -10, 0, 10, -10,  // footwall  0-3
        4, 0, 0,   10, 0, 0,  10, 10, 0,  4, 10, 0,    // hanging wall 4-7
    };
    std::vector<std::int64_t> T{
        0, 1, 2, 0, 2, 3,  // footwall
        4, 5, 6, 4, 6, 7,  // hanging wall
        1, 4, 7, 1, 7, 2,  // fault strip: (6, -10) -> (4, 0), clockwise in XY
    };
    std::size_t nv() const { return V.size() / 3; }
    std::size_t nt() const { return T.size() / 3; }
};

}  // namespace

TEST(SurfaceSampling, AFoldedSurfaceGivesItsLowestAndHighestSheetAndTheirCount) {
    const Folded s;
    const std::vector<double> xy{5.0, 3.0, 2.0, 5.0, 8.0, 5.0, 11.0, 5.0};
    const fm::SurfaceSamples r = fm::sample_surface(s.V.data(), s.nv(), s.T.data(), s.nt(), xy.data(), 4);
    EXPECT_EQ(r.hits[0], 3);
    EXPECT_DOUBLE_EQ(r.z_low[0], -10.0);
    EXPECT_DOUBLE_EQ(r.z_high[0], 0.0);
    EXPECT_EQ(r.hits[1], 1);
    EXPECT_DOUBLE_EQ(r.z_low[1], -10.0);
    EXPECT_EQ(r.hits[2], 1);
    EXPECT_DOUBLE_EQ(r.z_high[2], 0.0);
    EXPECT_EQ(r.hits[3], 0);
    EXPECT_TRUE(std::isnan(r.z_low[3]));
}

// Each datum is compared with the sheet nearest to it: a hole's two tops of
// the repeated layer with their own sheets, a point on the fault strip (z -5
// at x = 5) with the strip, which lowest and highest alone would put 5 m
// off.
TEST(SurfaceSampling, NearestSheetIsTheCoveringTriangleClosestInZ) {
    const Folded s;
    const std::vector<double> pts{
        5.0, 3.0, -9.0,   // near the footwall
        5.0, 3.0, 0.5,    // near the hanging wall
        5.0, 3.0, -5.0,   // on the fault strip
        5.0, 3.0, -4.0,   // nearer the strip (-5) than the hanging wall (0)
        2.0, 5.0, 100.0,  // one sheet only
        11.0, 5.0, 0.0,   // outside
    };
    const fm::NearestSheet r = fm::nearest_sheet(s.V.data(), s.nv(), s.T.data(), s.nt(), pts.data(), 6);
    ASSERT_EQ(r.z.size(), 6u);
    ASSERT_EQ(r.triangle.size(), 6u);
    EXPECT_DOUBLE_EQ(r.z[0], -10.0);
    EXPECT_DOUBLE_EQ(r.z[1], 0.0);
    EXPECT_NEAR(r.z[2], -5.0, 1e-12);
    EXPECT_NEAR(r.z[3], -5.0, 1e-12);
    EXPECT_DOUBLE_EQ(r.z[4], -10.0);
    EXPECT_TRUE(std::isnan(r.z[5]));
    // Triangles 0-1 footwall, 2-3 hanging wall, 4-5 strip.
    EXPECT_LT(r.triangle[0], 2);
    EXPECT_GE(r.triangle[1], 2);
    EXPECT_LT(r.triangle[1], 4);
    EXPECT_GE(r.triangle[2], 4);
    EXPECT_GE(r.triangle[3], 4);
    EXPECT_LT(r.triangle[4], 2);
    EXPECT_EQ(r.triangle[5], -1);
}

TEST(SurfaceSampling, NearestSheetRefusesABadTriangleIndex) {
    Folded s;
    s.T[4] = 99;
    const std::vector<double> pts{5.0, 3.0, 0.0};
    EXPECT_THROW(fm::nearest_sheet(s.V.data(), s.nv(), s.T.data(), s.nt(), pts.data(), 1), std::invalid_argument);
}

// With a reach, a triangle a hair away from the point counts too, with its
// nearest edge's z: a datum placed on a patch's outline lies a rounding off
// it, where only the other sheet covers it exactly.
TEST(SurfaceSampling, NearestSheetWithinReachOfAnOutline) {
    const Folded s;
    // Just beyond the footwall's edge at x = 6 (its outline there), under
    // the hanging wall only; near the footwall's level.
    const std::vector<double> pts{6.0 + 1e-7, 3.0, -9.5};
    const fm::NearestSheet exact = fm::nearest_sheet(s.V.data(), s.nv(), s.T.data(), s.nt(), pts.data(), 1);
    EXPECT_GE(exact.triangle[0], 2);  // the hanging wall or the strip, not the footwall
    const fm::NearestSheet near = fm::nearest_sheet(s.V.data(), s.nv(), s.T.data(), s.nt(), pts.data(), 1, 1e-6);
    EXPECT_LT(near.triangle[0], 2);
    EXPECT_DOUBLE_EQ(near.z[0], -10.0);
    EXPECT_THROW(fm::nearest_sheet(s.V.data(), s.nv(), s.T.data(), s.nt(), pts.data(), 1, -1.0),
                 std::invalid_argument);
}
