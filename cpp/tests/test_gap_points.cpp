// GoogleTest: removed layer vertices put back into a triangulated gap
// polygon (gap_points.hpp).
#include <faultmesh/ear_clipping.hpp>
#include <faultmesh/gap_points.hpp>
#include <faultmesh/polygon_cdt.hpp>
#include <faultmesh/predicates.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <set>
#include <stdexcept>
#include <utility>
#include <vector>

namespace fm = faultmesh;

namespace {

// A polygon (rings of points 0..n_ring-1) followed by the candidate points.
struct Gap {
    std::vector<double> xy;
    std::vector<std::int64_t> off{0};
    std::vector<std::int64_t> cons;  // ring edges
    std::size_t n_ring = 0;
    void ring(const std::vector<std::pair<double, double>>& r) {
        const std::int64_t b = static_cast<std::int64_t>(n_ring);
        for (auto [x, y] : r) {
            xy.push_back(x);
            xy.push_back(y);
        }
        n_ring += r.size();
        off.push_back(static_cast<std::int64_t>(n_ring));
        for (std::size_t i = 0; i < r.size(); ++i) {
            cons.push_back(b + static_cast<std::int64_t>(i));
            cons.push_back(b + static_cast<std::int64_t>((i + 1) % r.size()));
        }
    }
    std::int64_t point(double x, double y) {
        xy.push_back(x);
        xy.push_back(y);
        return static_cast<std::int64_t>(xy.size() / 2 - 1);
    }
    std::vector<std::int64_t> clip() const {
        return fm::triangulate_polygon(xy.data(), off.data(), off.size() - 1);
    }
    const double* P(std::int64_t i) const { return xy.data() + 2 * i; }
};

// What the stitcher relies on: every triangle counter-clockwise with non-zero
// area; every edge used once in each direction at most (manifold, no
// overlap); the ring edges all kept; the area unchanged; a CDT.
void expect_valid(const Gap& g, const std::vector<std::int64_t>& t, double area2) {
    std::map<std::pair<std::int64_t, std::int64_t>, int> used;
    double sum = 0.0;
    for (std::size_t i = 0; i < t.size(); i += 3) {
        const double o = fm::orient2d(g.P(t[i]), g.P(t[i + 1]), g.P(t[i + 2]));
        EXPECT_GT(o, 0.0) << "triangle " << i / 3;
        sum += o;
        for (int k = 0; k < 3; ++k) ++used[{t[i + k], t[i + (k + 1) % 3]}];
    }
    for (const auto& [e, n] : used) EXPECT_EQ(n, 1) << e.first << "->" << e.second;
    for (std::size_t i = 0; i < g.cons.size(); i += 2)
        EXPECT_TRUE(used.count({g.cons[i], g.cons[i + 1]})) << "ring edge " << i / 2 << " lost";
    EXPECT_NEAR(sum, area2, 1e-9 * area2);
    EXPECT_EQ(fm::count_non_delaunay_edges(g.xy.data(), g.xy.size() / 2, t, g.cons.data(), g.cons.size() / 2), 0u);
}

std::set<std::int64_t> vertices_of(const std::vector<std::int64_t>& t) { return {t.begin(), t.end()}; }

}  // namespace

// An annular gap (a patch hole in a square): points inside it become vertices,
// however close to a ring; points in the hole or outside the square do not;
// 2 more triangles per point.
TEST(GapPoints, AnnulusKeepsItsInteriorPointsOnly) {
    Gap g;
    g.ring({{0, 0}, {10, 0}, {10, 10}, {0, 10}});
    g.ring({{4, 4}, {4, 6}, {6, 6}, {6, 4}});  // the hole, clockwise
    std::vector<std::int64_t> inside, outside;
    for (int i = 0; i < 10; ++i)
        for (int j = 0; j < 10; ++j) {
            const double x = 0.5 + i + 0.013 * j, y = 0.5 + j + 0.007 * i;
            const bool in_hole = x > 4.0 && x < 6.0 && y > 4.0 && y < 6.0;
            (in_hole ? outside : inside).push_back(g.point(x, y));
        }
    outside.push_back(g.point(-1.0, 5.0));   // outside the square
    outside.push_back(g.point(10.2, 3.0));   // just outside the outer ring
    inside.push_back(g.point(9.99, 3.0));    // just inside the outer ring: a thin triangle, kept
    inside.push_back(g.point(5.0, 6.01));    // just outside the hole
    std::vector<std::int64_t> t = g.clip();
    ASSERT_EQ(t.size() / 3, g.n_ring + 2 * 1 - 2);
    std::vector<std::int64_t> cand = inside;
    cand.insert(cand.end(), outside.begin(), outside.end());
    const std::vector<std::int64_t> got = fm::insert_interior_points(
        g.xy.data(), g.xy.size() / 2, t, g.cons.data(), g.cons.size() / 2, cand.data(), cand.size());
    std::vector<std::int64_t> want = inside;
    std::sort(want.begin(), want.end());
    std::vector<std::int64_t> sorted = got;
    std::sort(sorted.begin(), sorted.end());
    EXPECT_EQ(sorted, want);
    EXPECT_EQ(t.size() / 3, g.n_ring + 2 * 1 - 2 + 2 * inside.size());
    const std::set<std::int64_t> vs = vertices_of(t);
    for (std::int64_t p : inside) EXPECT_TRUE(vs.count(p)) << "point " << p;
    for (std::int64_t p : outside) EXPECT_FALSE(vs.count(p)) << "point " << p;
    expect_valid(g, t, 2.0 * (100.0 - 4.0));
}

// A point exactly on the diagonal of a square (whichever the ear clipping
// chose): the two triangles are split into four. A point on a ring edge
// and a point on a ring vertex are not inserted.
TEST(GapPoints, PointOnAnEdgeSplitsBothTriangles) {
    Gap g;
    g.ring({{0, 0}, {4, 0}, {4, 4}, {0, 4}});
    const std::int64_t centre = g.point(2, 2), on_ring = g.point(2, 0), on_vertex = g.point(4, 4);
    std::vector<std::int64_t> t = g.clip();
    ASSERT_EQ(t.size(), 6u);
    const std::vector<std::int64_t> cand{on_ring, on_vertex, centre, centre};
    const std::vector<std::int64_t> got = fm::insert_interior_points(
        g.xy.data(), g.xy.size() / 2, t, g.cons.data(), g.cons.size() / 2, cand.data(), cand.size());
    EXPECT_EQ(got, std::vector<std::int64_t>{centre});
    EXPECT_EQ(t.size() / 3, 4u);
    expect_valid(g, t, 32.0);
}

// Collinear points along a line through the gap, inserted one after the
// other: later points fall on edges made by the earlier ones (exact
// orient2d decides), and all become vertices.
TEST(GapPoints, CollinearPointsAllBecomeVertices) {
    Gap g;
    g.ring({{0, 0}, {8, 0}, {8, 3}, {0, 3}});
    std::vector<std::int64_t> line;
    for (int i = 1; i < 16; ++i) line.push_back(g.point(0.5 * i, 1.25));
    // Also a diagonal row through the corner points' line y = 3x/8.
    for (int i = 1; i < 8; ++i) line.push_back(g.point(i, 3.0 * i / 8.0));
    std::vector<std::int64_t> t = g.clip();
    const std::vector<std::int64_t> got = fm::insert_interior_points(
        g.xy.data(), g.xy.size() / 2, t, g.cons.data(), g.cons.size() / 2, line.data(), line.size());
    EXPECT_EQ(got.size(), line.size());
    EXPECT_EQ(t.size() / 3, 2 + 2 * line.size());
    const std::set<std::int64_t> vs = vertices_of(t);
    for (std::int64_t p : line) EXPECT_TRUE(vs.count(p)) << "point " << p;
    expect_valid(g, t, 48.0);
}

TEST(GapPoints, MalformedArguments) {
    Gap g;
    g.ring({{0, 0}, {4, 0}, {4, 4}});
    std::vector<std::int64_t> t = g.clip();
    const std::int64_t bad[] = {7};
    EXPECT_THROW(fm::insert_interior_points(g.xy.data(), 3, t, g.cons.data(), 3, bad, 1), std::invalid_argument);
}
