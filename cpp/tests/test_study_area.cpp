// StudyArea: points on the study-area boundary, placed and found the same way.
#include <faultmesh/errors.hpp>
#include <faultmesh/predicates.hpp>
#include <faultmesh/segments.hpp>
#include <faultmesh/study_area.hpp>

#include <gtest/gtest.h>

#include <array>
#include <map>
#include <utility>
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

namespace {

// A 10 x 10 square with a notch cut from the top side down to the reflex
// corner (5, 4).
StudyArea notched() {
    const std::vector<double> r = {0, 0, 10, 0, 10, 10, 6, 10, 5, 4, 4, 10, 0, 10};
    return StudyArea(r.data(), 7);
}

double xy_area(const faultmesh::ClippedSurface& c) {
    double a = 0.0;
    for (std::size_t i = 0; i < c.triangles.size(); i += 3) {
        const double* p = &c.vertices[3 * c.triangles[i]];
        const double* q = &c.vertices[3 * c.triangles[i + 1]];
        const double* r = &c.vertices[3 * c.triangles[i + 2]];
        a += 0.5 * ((q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]));
    }
    return a;
}

// Every vertex in the area with z = x (the input's linear z), every triangle
// non-degenerate with the given orientation sign and its centroid in the
// area, no outline edge properly crossing a side, each undirected edge in at
// most two triangles and then in opposite directions (conforming).
void expect_clipped_inside(const StudyArea& a, const faultmesh::ClippedSurface& c, int sign) {
    const std::size_t nv = c.vertices.size() / 3;
    for (std::size_t i = 0; i < nv; ++i) {
        EXPECT_TRUE(a.contains(&c.vertices[3 * i])) << "vertex " << i;
        EXPECT_NEAR(c.vertices[3 * i + 2], c.vertices[3 * i], 1e-12) << "vertex " << i;
    }
    std::map<std::pair<std::int64_t, std::int64_t>, int> directed;
    for (std::size_t t = 0; t < c.triangles.size(); t += 3) {
        const double* p[3];
        for (int k = 0; k < 3; ++k) p[k] = &c.vertices[3 * c.triangles[t + k]];
        const double o = faultmesh::orient2d(p[0], p[1], p[2]);
        EXPECT_EQ(o > 0.0 ? 1 : (o < 0.0 ? -1 : 0), sign) << "triangle " << t / 3;
        const double m[2] = {(p[0][0] + p[1][0] + p[2][0]) / 3.0, (p[0][1] + p[1][1] + p[2][1]) / 3.0};
        EXPECT_TRUE(a.contains(m)) << "triangle " << t / 3;
        for (int k = 0; k < 3; ++k) ++directed[{c.triangles[t + k], c.triangles[t + (k + 1) % 3]}];
    }
    for (const auto& [e, n] : directed) {
        EXPECT_EQ(n, 1) << "edge " << e.first << "-" << e.second << " used twice in one direction";
        if (directed.count({e.second, e.first})) continue;
        // An outline edge: no side crossing it properly, except one its end
        // lies on (rounding of a point placed on the side; the stitcher's rule).
        const double *p = &c.vertices[3 * e.first], *q = &c.vertices[3 * e.second];
        std::vector<StudyArea::Hit> hp, hq;
        a.locate(p, hp);
        a.locate(q, hq);
        for (std::size_t k = 0; k < a.n_sides(); ++k) {
            bool on = false;
            for (const auto& h : hp) on |= h.side == k;
            for (const auto& h : hq) on |= h.side == k;
            if (on) continue;
            const double *u = a.corner(k), *w = a.corner(k + 1);
            const int o1 = faultmesh::orient2d_sign(p, q, u), o2 = faultmesh::orient2d_sign(p, q, w);
            const int o3 = faultmesh::orient2d_sign(u, w, p), o4 = faultmesh::orient2d_sign(u, w, q);
            EXPECT_FALSE(o1 * o2 < 0 && o3 * o4 < 0) << "outline edge crosses side " << k;
        }
    }
}

}  // namespace

TEST(ClipToStudyArea, StripAcrossANotchIsCutInTwo) {
    // A strip y in [6, 8] across the whole square: the notch (walls from
    // (5, 4) to (4, 10) and (6, 10)) cuts it in two; the notch's part of it
    // is a trapezoid of widths 2/3 and 4/3: area 2 of 16.
    const StudyArea a = notched();
    const std::vector<double> V = {1, 6, 1, 9, 6, 9, 9, 8, 9, 1, 8, 1};
    const std::vector<std::int64_t> ccw = {0, 1, 2, 0, 2, 3}, cw = {0, 2, 1, 0, 3, 2};
    const auto c = faultmesh::clip_to_study_area(a, V.data(), 4, ccw.data(), 2, "strip");
    EXPECT_EQ(c.n_cut, 2u);
    EXPECT_NEAR(xy_area(c), 14.0, 1e-12);
    expect_clipped_inside(a, c, +1);
    // The new vertices (where the strip's 3 edges cross the notch's 2
    // walls) lie on the walls (found by locate).
    std::size_t n_new = 0;
    for (std::size_t i = 0; i < c.vertex_of.size(); ++i)
        if (c.vertex_of[i] < 0) {
            ++n_new;
            EXPECT_TRUE(a.on_boundary(&c.vertices[3 * i])) << "vertex " << i;
        }
    EXPECT_EQ(n_new, 6u);
    // A clockwise (folded) sheet stays clockwise.
    const auto d = faultmesh::clip_to_study_area(a, V.data(), 4, cw.data(), 2, "strip");
    EXPECT_NEAR(xy_area(d), -14.0, 1e-12);
    expect_clipped_inside(a, d, -1);
}

TEST(ClipToStudyArea, ReflexCornerInsideATriangle) {
    // y in [2, 6]: the notch's tip (5, 4) lies inside a triangle; the notch
    // takes a triangle of width 2/3 and height 2 (area 2/3) of 32.
    const StudyArea a = notched();
    const std::vector<double> V = {1, 2, 1, 9, 2, 9, 9, 6, 9, 1, 6, 1};
    const std::vector<std::int64_t> T = {0, 1, 2, 0, 2, 3};
    const auto c = faultmesh::clip_to_study_area(a, V.data(), 4, T.data(), 2, "strip");
    EXPECT_NEAR(xy_area(c), 32.0 - 2.0 / 3.0, 1e-12);
    expect_clipped_inside(a, c, +1);
    bool tip = false;
    for (std::size_t i = 0; i < c.vertex_of.size(); ++i)
        tip |= c.vertices[3 * i] == 5.0 && c.vertices[3 * i + 1] == 4.0;
    EXPECT_TRUE(tip);
}

TEST(ClipToStudyArea, InsideKeptOutsideDroppedEdgesOnTheBoundaryKept) {
    const StudyArea a = notched();
    // Inside (touching the bottom side along an edge), and wholly outside.
    const std::vector<double> V = {1, 0, 1, 3, 0, 3, 2, 2, 2, 11, 1, 11, 12, 1, 12, 11, 3, 11};
    const std::vector<std::int64_t> T = {0, 1, 2, 3, 4, 5};
    const auto c = faultmesh::clip_to_study_area(a, V.data(), 6, T.data(), 2, "t");
    EXPECT_EQ(c.n_cut, 0u);
    EXPECT_EQ(c.n_dropped, 1u);
    EXPECT_EQ(c.triangles, (std::vector<std::int64_t>{0, 1, 2}));
    EXPECT_EQ(c.vertex_of, (std::vector<std::int64_t>{0, 1, 2}));
    const std::vector<std::int64_t> bad = {0, 1, 6};
    EXPECT_THROW(faultmesh::clip_to_study_area(a, V.data(), 6, bad.data(), 1, "t"), std::invalid_argument);
}
