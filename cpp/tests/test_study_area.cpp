// StudyArea: points on the study-area boundary, placed and found the same way.
#include <faultmesh/errors.hpp>
#include <faultmesh/predicates.hpp>
#include <faultmesh/segments.hpp>
#include <faultmesh/study_area.hpp>

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

using faultmesh::StudyArea;

namespace {

StudyArea rectangle(double x0, double y0, double w, double h, bool clockwise = false) {
    std::vector<double> r = {x0, y0, x0 + w, y0, x0 + w, y0 + h, x0, y0 + h};
    if (clockwise) r = {x0, y0, x0, y0 + h, x0 + w, y0 + h, x0 + w, y0};
    return StudyArea(r.data(), 4);
}

}  // namespace

TEST(StudyArea, RingIsCounterClockwiseAndValidated) {
    StudyArea a = rectangle(0, 0, 10, 5, /*clockwise=*/true);
    const auto& r = a.ring();
    double area2 = 0.0;
    for (std::size_t i = 0; i < a.n_sides(); ++i)
        area2 += r[2 * i] * r[2 * ((i + 1) % 4) + 1] - r[2 * ((i + 1) % 4)] * r[2 * i + 1];
    EXPECT_GT(area2, 0.0);
    EXPECT_DOUBLE_EQ(a.perimeter(), 30.0);
    const std::vector<double> two = {0, 0, 1, 1};
    EXPECT_THROW(StudyArea(two.data(), 2), std::invalid_argument);
    const std::vector<double> flat = {0, 0, 1, 1, 2, 2};
    EXPECT_THROW(StudyArea(flat.data(), 3), faultmesh::GeometryError);
    const std::vector<double> bad = {0, 0, NAN, 1, 2, 0};
    EXPECT_THROW(StudyArea(bad.data(), 3), std::invalid_argument);
}

TEST(StudyArea, PlacedPointsAreOnTheirSideAtAnyOffset) {
    // Axis-parallel sides: the constant coordinate is exact, so the placed
    // point is exactly on the side (orient2d == 0) at any offset.
    for (double off : {0.0, 5e5, 7e6, 4.2e6 + 0.123}) {
        StudyArea a = rectangle(off, off + 1.5, 3059.969, 4550.8023);
        for (std::size_t side = 0; side < 4; ++side) {
            for (double u : {0.0, 1e-9, 0.1234567, 0.5, 0.999999, 1.0}) {
                double p[2];
                a.place(side, u * a.side_length(side), p);
                EXPECT_TRUE(faultmesh::on_segment(a.corner(side), a.corner(side + 1), p))
                    << "offset " << off << " side " << side << " u " << u;
                std::vector<StudyArea::Hit> hits;
                a.locate(p, hits);
                ASSERT_FALSE(hits.empty());
                EXPECT_TRUE(a.contains(p));
            }
        }
    }
}

TEST(StudyArea, SlantedSidesPlaceWithinTheTolerance) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> U(0.0, 1.0);
    for (double off : {0.0, 5e5, 7e6}) {
        // A rotated rectangle and a concave L-shape.
        const double c = std::cos(0.61), s = std::sin(0.61);
        std::vector<double> rot;
        for (auto q : std::vector<std::array<double, 2>>{{0, 0}, {4000, 0}, {4000, 2500}, {0, 2500}}) {
            rot.push_back(off + c * q[0] - s * q[1]);
            rot.push_back(off + 1e6 + s * q[0] + c * q[1]);
        }
        std::vector<double> ell = {off, off, off + 3000, off, off + 3000, off + 1000, off + 1200,
                                   off + 1000, off + 1200, off + 2800, off, off + 2800};
        for (const auto* ring : {&rot, &ell}) {
            StudyArea a(ring->data(), ring->size() / 2);
            for (int i = 0; i < 200; ++i) {
                const std::size_t side = static_cast<std::size_t>(U(rng) * a.n_sides()) % a.n_sides();
                double p[2];
                a.place(side, U(rng) * a.side_length(side), p);
                EXPECT_TRUE(a.on_boundary(p));
                EXPECT_TRUE(a.contains(p));
            }
        }
    }
}

TEST(StudyArea, RayHitIsPlacedOnTheSideAndZeroOnTheBoundary) {
    for (double off : {0.0, 481024.7585, 7786654.0}) {
        StudyArea a = rectangle(off, off, 3000, 2000);
        const double p[2] = {off + 809.6907, off + 1234.5};
        const double down[2] = {0.00396531, -0.99999214};
        const auto h = a.ray_hit(p, down);
        ASSERT_TRUE(std::isfinite(h.t));
        EXPECT_EQ(h.side, 0u);
        double q[2];
        a.place(h.side, h.s, q);
        EXPECT_EQ(q[1], off);  // exactly on the bottom side
        // From a point on the boundary the hit is the point itself.
        const auto h0 = a.ray_hit(q, down);
        EXPECT_EQ(h0.t, 0.0);
        // Rays through a corner hit it exactly.
        const double centre[2] = {off + 1500, off + 1000};
        const double diag[2] = {1500, 1000};
        const auto hc = a.ray_hit(centre, diag);
        double r[2];
        a.place(hc.side, hc.s, r);
        EXPECT_EQ(r[0], off + 3000);
        EXPECT_EQ(r[1], off + 2000);
        // A ray that leaves through nothing (zero direction) misses.
        const double zero[2] = {0, 0};
        EXPECT_TRUE(std::isinf(a.ray_hit(centre, zero).t));
    }
}

TEST(StudyArea, ContainsAndNearest) {
    StudyArea a = rectangle(0, 0, 10, 5);
    const double in[2] = {5, 2}, out[2] = {11, 2}, on[2] = {10, 2.5}, near[2] = {5, -0.01};
    EXPECT_TRUE(a.contains(in));
    EXPECT_FALSE(a.contains(out));
    EXPECT_TRUE(a.contains(on));
    EXPECT_FALSE(a.contains(near));
    const auto n = a.nearest(near, 0.1);
    ASSERT_TRUE(n.found);
    EXPECT_EQ(n.side, 0u);
    EXPECT_DOUBLE_EQ(n.s, 5.0);
    EXPECT_NEAR(n.distance, 0.01, 1e-15);
    EXPECT_FALSE(a.nearest(in, 0.1).found);
}
