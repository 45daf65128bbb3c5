// Tests of faultmesh::Tin: incremental insertion equals rebuilding, the
// duplicate policy, point location and linear interpolation.
#include <faultmesh/delaunay.hpp>
#include <faultmesh/errors.hpp>
#include <faultmesh/predicates.hpp>
#include <faultmesh/tin.hpp>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <fstream>
#include <limits>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "test_support.hpp"

namespace fm = faultmesh;

namespace {

using fm::test::tri_set;

// Triangles as sets of vertex coordinates: comparable between Tins whose
// vertex numbering differs.
std::set<std::array<double, 6>> geo_set(const fm::Tin& tin) {
    const auto v = tin.vertices();
    const auto t = tin.triangles();
    std::set<std::array<double, 6>> s;
    for (std::size_t i = 0; i < t.size(); i += 3) {
        std::array<std::array<double, 2>, 3> c;
        for (int k = 0; k < 3; ++k) c[k] = {v[3 * t[i + k]], v[3 * t[i + k] + 1]};
        // rotate the lexicographically smallest corner first (keeps orientation)
        while (c[1] < c[0] || c[2] < c[0]) c = {c[1], c[2], c[0]};
        s.insert({c[0][0], c[0][1], c[1][0], c[1][1], c[2][0], c[2][1]});
    }
    return s;
}

double plane(double x, double y) { return 3.0 + 0.5 * x - 0.25 * y; }

std::vector<double> random_xyz(std::size_t n, unsigned seed, double lo, double hi) {
    std::mt19937_64 g(seed);
    std::uniform_real_distribution<double> u(lo, hi);
    std::vector<double> p(3 * n);
    for (std::size_t i = 0; i < n; ++i) {
        p[3 * i] = u(g);
        p[3 * i + 1] = u(g);
        p[3 * i + 2] = plane(p[3 * i], p[3 * i + 1]);
    }
    return p;
}

}  // namespace

TEST(Tin, InsertEqualsRebuild) {
    const auto all = random_xyz(3000, 1, 0, 100);
    fm::Tin whole(all.data(), 3000);
    fm::Tin grown(all.data(), 500);
    grown.insert(all.data() + 3 * 500, 1000);
    for (std::size_t i = 1500; i < 3000; ++i) grown.insert(all.data() + 3 * i, 1);  // one by one
    EXPECT_EQ(grown.n_vertices(), whole.n_vertices());
    // Same numbering (first appearance, no duplicates), so the index sets match.
    EXPECT_EQ(tri_set(grown.triangles()), tri_set(whole.triangles()));
    EXPECT_EQ(grown.vertices(), whole.vertices());
}

// Inserts leave the compact numbering stale; readers in between (locate,
// interpolate, triangles) must rebuild it and see the current mesh. Regression
// for the lazy rebuild and for single inserts starting at stale samples.
TEST(Tin, OneByOneInsertsInterleavedWithReadsEqualRebuild) {
    const auto all = random_xyz(2000, 7, 0, 100);
    fm::Tin whole(all.data(), 2000);
    fm::Tin grown(all.data(), 100);
    for (std::size_t i = 100; i < 2000; ++i) {
        grown.insert(all.data() + 3 * i, 1);
        if (i % 97 == 0) {
            const double q[2] = {all[3 * i], all[3 * i + 1]};
            const std::int64_t t = grown.locate(q[0], q[1]);
            ASSERT_GE(t, 0);
            ASSERT_LT(static_cast<std::size_t>(t), grown.n_triangles());
            EXPECT_DOUBLE_EQ(grown.interpolate(q, 1)[0], all[3 * i + 2]);
            EXPECT_EQ(grown.triangles().size(), 3 * grown.n_triangles());
        }
    }
    EXPECT_EQ(tri_set(grown.triangles()), tri_set(whole.triangles()));
    EXPECT_EQ(grown.halfedges().size(), whole.halfedges().size());
}

TEST(Tin, InsertOnGridAndOutsideTheHullEqualsRebuild) {
    // A layer TIN on a grid, then study-area corners outside it and edge
    // midpoints (exactly cocircular configurations), as the workflow does.
    std::vector<double> base;
    for (int j = 0; j < 20; ++j)
        for (int i = 0; i < 20; ++i) base.insert(base.end(), {10.0 * i, 10.0 * j, -1.0 * i});
    std::vector<double> extra = {-50, -50, 0, 250, -50, 0, 250, 250, 0, -50, 250, 0};
    for (int i = 0; i < 19; ++i) extra.insert(extra.end(), {10.0 * i + 5, 95.0, 1.0});
    extra.insert(extra.end(), {-20, 95, 0, 300, 95, 0});  // hull edge collinear points
    fm::Tin grown(base.data(), base.size() / 3);
    grown.insert(extra.data(), extra.size() / 3);
    std::vector<double> all = base;
    all.insert(all.end(), extra.begin(), extra.end());
    fm::Tin whole(all.data(), all.size() / 3);
    EXPECT_EQ(tri_set(grown.triangles()), tri_set(whole.triangles()));
    // And equal to plain delaunay of the XY.
    std::vector<double> xy;
    for (std::size_t i = 0; i < all.size(); i += 3) xy.insert(xy.end(), {all[i], all[i + 1]});
    EXPECT_EQ(tri_set(fm::delaunay(xy.data(), xy.size() / 2).triangles), tri_set(whole.triangles()));
}

TEST(Tin, DuplicatePolicyKeepsTheExistingVertex) {
    std::vector<double> p = {0, 0, 1, 10, 0, 2, 0, 10, 3, 10, 10, 4, 0, 0, 99};  // row 4 duplicates row 0
    fm::Tin tin(p.data(), 5);
    EXPECT_EQ(tin.n_vertices(), 4u);
    EXPECT_EQ(tin.n_duplicates(), 1u);
    EXPECT_EQ(tin.vertex_of_input(), (std::vector<std::int64_t>{0, 1, 2, 3, 0}));
    EXPECT_EQ(tin.vertices()[2], 1.0) << "first row's z kept";

    std::vector<double> q = {10, 10, -7, 5, 5, 8, 5, 5, 9, 0, 10, 0};
    const auto idx = tin.insert(q.data(), 4);
    EXPECT_EQ(idx, (std::vector<std::int64_t>{3, 4, 4, 2}));
    EXPECT_EQ(tin.n_vertices(), 5u);
    EXPECT_EQ(tin.n_duplicates(), 4u);
    const auto v = tin.vertices();
    EXPECT_EQ(v[3 * 3 + 2], 4.0) << "existing z unchanged";
    EXPECT_EQ(v[3 * 4 + 2], 8.0) << "first row of a new point wins";
    EXPECT_EQ(tin.n_triangles(), 4u);
}

TEST(Tin, LocateAndInterpolate) {
    const auto pts = random_xyz(2000, 3, -100, 100);
    fm::Tin tin(pts.data(), 2000);
    const auto v = tin.vertices();
    const auto t = tin.triangles();
    std::mt19937_64 g(8);
    std::uniform_real_distribution<double> u(-120, 120);
    std::vector<double> q(2 * 5000);
    for (auto& c : q) c = u(g);
    const auto loc = tin.locate(q.data(), 5000);
    const auto z = tin.interpolate(q.data(), 5000);
    int inside = 0;
    for (std::size_t i = 0; i < 5000; ++i) {
        const double* p = &q[2 * i];
        ASSERT_EQ(loc[i], tin.locate(p[0], p[1])) << "batched and single locate agree";
        if (loc[i] < 0) {
            EXPECT_TRUE(std::isnan(z[i]));
            // Outside the hull: strictly right of some hull edge.
            continue;
        }
        ++inside;
        ASSERT_LT(static_cast<std::size_t>(loc[i]), tin.n_triangles());
        for (int k = 0; k < 3; ++k) {
            const double* a = &v[3 * t[3 * loc[i] + k]];
            const double* b = &v[3 * t[3 * loc[i] + (k + 1) % 3]];
            const double aa[2] = {a[0], a[1]}, bb[2] = {b[0], b[1]};
            EXPECT_GE(fm::orient2d(aa, bb, p), 0.0) << "query " << i << " inside its triangle";
        }
        // A plane is reproduced (relative rounding only).
        EXPECT_NEAR(z[i], plane(p[0], p[1]), 1e-11 * 100);
    }
    EXPECT_GT(inside, 3000);
    // Far outside, NaN and infinity.
    const double bad[8] = {1e9, 0, std::numeric_limits<double>::quiet_NaN(), 0, 0,
                           std::numeric_limits<double>::infinity(), -1e200, 1e300};
    const auto lb = tin.locate(bad, 4);
    const auto zb = tin.interpolate(bad, 4);
    for (int i = 0; i < 4; ++i) {
        EXPECT_EQ(lb[i], -1);
        EXPECT_TRUE(std::isnan(zb[i]));
    }
}

TEST(Tin, InterpolationAtVerticesIsExact) {
    std::vector<double> p;
    std::mt19937_64 g(2);
    std::uniform_real_distribution<double> u(0, 1);
    for (int i = 0; i < 500; ++i) p.insert(p.end(), {5.5e5 + 3000 * u(g), 7.8e6 + 3000 * u(g), -9000 - 500 * u(g)});
    fm::Tin tin(p.data(), 500);
    std::vector<double> q;
    for (int i = 0; i < 500; ++i) q.insert(q.end(), {p[3 * i], p[3 * i + 1]});
    const auto z = tin.interpolate(q.data(), 500);
    for (int i = 0; i < 500; ++i) EXPECT_EQ(z[i], p[3 * i + 2]);
}

TEST(Tin, HullBoundaryPointsAreInside) {
    std::vector<double> p = {0, 0, 0, 4, 0, 4, 0, 4, 8};  // z = x + 2y
    fm::Tin tin(p.data(), 3);
    const double q[8] = {2, 0, 0, 2, 2, 2, 2.0000001, 2};
    const auto loc = tin.locate(q, 4);
    EXPECT_EQ(loc, (std::vector<std::int64_t>{0, 0, 0, -1}));
    const auto z = tin.interpolate(q, 4);
    EXPECT_DOUBLE_EQ(z[0], 2.0);
    EXPECT_DOUBLE_EQ(z[1], 4.0);
    EXPECT_DOUBLE_EQ(z[2], 6.0);
    EXPECT_TRUE(std::isnan(z[3]));
}

TEST(Tin, ErrorsAndAtomicInsert) {
    std::vector<double> line = {0, 0, 0, 1, 1, 0, 2, 2, 0};
    EXPECT_THROW(fm::Tin(line.data(), 3), fm::GeometryError);
    std::vector<double> p = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    fm::Tin tin(p.data(), 3);
    std::vector<double> bad = {0.5, 0.5, 0, 0.2, std::numeric_limits<double>::quiet_NaN(), 0};
    try {
        tin.insert(bad.data(), 2);
        FAIL();
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("Tin.insert: xyz row 1"), std::string::npos) << e.what();
    }
    EXPECT_EQ(tin.n_vertices(), 3u) << "nothing inserted on error";
    // NaN z is allowed (only XY must be finite): a layer may lack a value.
    std::vector<double> nz = {0.2, 0.2, std::numeric_limits<double>::quiet_NaN()};
    EXPECT_EQ(tin.insert(nz.data(), 1), (std::vector<std::int64_t>{3}));
}

TEST(Tin, CopyIsIndependent) {
    const auto pts = random_xyz(100, 4, 0, 1);
    fm::Tin a(pts.data(), 100);
    fm::Tin b = a;
    const double q[3] = {0.5, 0.5, 0.0};
    b.insert(q, 1);
    EXPECT_EQ(a.n_vertices() + 1, b.n_vertices());
    EXPECT_EQ(a.triangles().size() + 6, b.triangles().size());
}

TEST(Tin, ClaudiusHorizonGrownEqualsRebuilt) {
    // Real seismic horizon (grid-like, many exactly cocircular cells).
    std::ifstream f(std::string(FAULTMESH_TEST_DATA) + "/claudius/claudius.csv");
    ASSERT_TRUE(f.good());
    std::string line;
    std::getline(f, line);
    std::vector<double> p;
    while (std::getline(f, line)) {
        std::stringstream ss(line);
        std::string cell[6];
        for (auto& c : cell) std::getline(ss, c, ',');
        if (cell[4] != "60.0") continue;
        p.insert(p.end(), {std::stod(cell[1]), std::stod(cell[2]), std::stod(cell[3])});
    }
    const std::size_t n = p.size() / 3;
    ASSERT_GT(n, 5000u);
    fm::Tin whole(p.data(), n);
    fm::Tin grown(p.data(), n / 3);
    grown.insert(p.data() + 3 * (n / 3), n - n / 3);
    EXPECT_EQ(tri_set(grown.triangles()), tri_set(whole.triangles()));
    EXPECT_EQ(geo_set(grown), geo_set(whole));
}

TEST(Tin, SetZChangesHeightsNotTriangles) {
    const auto pts = random_xyz(300, 6, 0, 10);
    fm::Tin tin(pts.data(), 300);
    const auto tri = tin.triangles();
    const std::int64_t idx[3] = {0, 5, 0};
    const double z[3] = {1.0, 2.0, 3.0};
    tin.set_z(idx, z, 3);
    EXPECT_EQ(tin.triangles(), tri);
    const auto v = tin.vertices();
    EXPECT_EQ(v[2], 3.0) << "later entry wins";
    EXPECT_EQ(v[3 * 5 + 2], 2.0);
    const double q[2] = {v[0], v[1]};
    EXPECT_EQ(tin.interpolate(q, 1)[0], 3.0) << "interpolation sees the new z";
    const std::int64_t bad[2] = {1, 300};
    EXPECT_THROW(tin.set_z(bad, z, 2), std::invalid_argument);
    EXPECT_EQ(tin.vertices()[3 * 1 + 2], v[3 * 1 + 2]) << "nothing changed on error";
}
