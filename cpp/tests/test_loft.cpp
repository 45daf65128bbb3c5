// Lofting between polylines: counts, edge use, orientation, optimality.
#include <faultmesh/loft.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

using faultmesh::LoftMethod;
using faultmesh::LoftOptions;

namespace {

using Edge = std::pair<std::int64_t, std::int64_t>;

// Directed edge counts of a triangle list; lookups never insert.
struct Directed {
    std::map<Edge, int> m;
    int operator[](const Edge& e) const {
        auto it = m.find(e);
        return it == m.end() ? 0 : it->second;
    }
    std::size_t count(const Edge& e) const { return m.count(e); }
};
Directed directed(const std::vector<std::int64_t>& t) {
    Directed d;
    for (std::size_t i = 0; i < t.size(); i += 3)
        for (int e = 0; e < 3; ++e) ++d.m[{t[i + e], t[i + (e + 1) % 3]}];
    return d;
}

std::vector<double> polyline(std::mt19937_64& rng, std::size_t n, double y, double z) {
    std::uniform_real_distribution<double> u(0.2, 1.5), w(-0.3, 0.3);
    std::vector<double> p;
    double x = 0;
    for (std::size_t i = 0; i < n; ++i) {
        p.insert(p.end(), {x, y + w(rng), z + w(rng)});
        x += u(rng);
    }
    return p;
}

// Checks shared by both methods for open polylines.
void check_open(const std::vector<std::int64_t>& t, std::size_t k, std::size_t l) {
    ASSERT_EQ(t.size(), 3 * (k + l - 2));
    auto d = directed(t);
    // Every edge of a used once as a -> a+1, every edge of b once as b+1 -> b.
    for (std::size_t i = 0; i + 1 < k; ++i) {
        EXPECT_EQ((d[{std::int64_t(i), std::int64_t(i + 1)}]), 1);
        EXPECT_EQ((d[{std::int64_t(i + 1), std::int64_t(i)}]), 0);
    }
    for (std::size_t j = 0; j + 1 < l; ++j) {
        EXPECT_EQ((d[{std::int64_t(k + j + 1), std::int64_t(k + j)}]), 1);
        EXPECT_EQ((d[{std::int64_t(k + j), std::int64_t(k + j + 1)}]), 0);
    }
    // Consistent orientation: every directed edge at most once; interior
    // rungs appear once in each direction.
    for (auto& [e, c] : d.m) {
        EXPECT_EQ(c, 1);
        const bool rung = (e.first < std::int64_t(k)) != (e.second < std::int64_t(k));
        if (rung && !((e.first == 0 && e.second == std::int64_t(k)) ||
                      (e.second == 0 && e.first == std::int64_t(k)) ||
                      (e.first == std::int64_t(k - 1) && e.second == std::int64_t(k + l - 1)) ||
                      (e.second == std::int64_t(k - 1) && e.first == std::int64_t(k + l - 1))))
            EXPECT_EQ((d.count({e.second, e.first})), 1u) << e.first << "->" << e.second;
    }
}

}  // namespace

TEST(Loft, OpenCountsEdgesOrientationAndOptimality) {
    std::mt19937_64 rng(5);
    for (auto [k, l] : std::vector<std::pair<std::size_t, std::size_t>>{
             {2, 2}, {2, 7}, {9, 3}, {15, 15}, {40, 23}, {1, 6}, {6, 1}, {1, 1}}) {
        const auto a = polyline(rng, k, 0.0, 0.0), b = polyline(rng, l, 3.0, 1.0);
        LoftOptions ma, sd;
        sd.method = LoftMethod::shortest_diagonal;
        const auto t1 = faultmesh::loft(a.data(), k, b.data(), l, 3, ma);
        const auto t2 = faultmesh::loft(a.data(), k, b.data(), l, 3, sd);
        check_open(t1, k, l);
        check_open(t2, k, l);
        const double A1 = faultmesh::loft_area(a.data(), k, b.data(), l, 3, t1);
        const double A2 = faultmesh::loft_area(a.data(), k, b.data(), l, 3, t2);
        // The DP minimum is no larger than the greedy path (small slack for
        // the different summation order of the two totals).
        EXPECT_LE(A1, A2 * (1 + 1e-12)) << k << "x" << l;
    }
}

TEST(Loft, MinAreaIsOptimalByExhaustiveSearch) {
    // All C(k+l-2, k-1) monotone paths for small k, l.
    std::mt19937_64 rng(9);
    for (int rep = 0; rep < 20; ++rep) {
        const std::size_t k = 2 + rng() % 5, l = 2 + rng() % 5;
        const auto a = polyline(rng, k, 0.0, 0.0), b = polyline(rng, l, 2.0, 0.5);
        const auto t = faultmesh::loft(a.data(), k, b.data(), l, 3);
        const double best = faultmesh::loft_area(a.data(), k, b.data(), l, 3, t);
        const std::size_t steps = k + l - 2;
        double brute = 1e300;
        for (unsigned mask = 0; mask < (1u << steps); ++mask) {
            if (static_cast<std::size_t>(__builtin_popcount(mask)) != k - 1) continue;
            std::vector<std::int64_t> tri;
            std::size_t i = 0, j = 0;
            for (std::size_t s = 0; s < steps; ++s) {
                if (mask >> s & 1) {
                    tri.insert(tri.end(), {std::int64_t(i), std::int64_t(i + 1), std::int64_t(k + j)});
                    ++i;
                } else {
                    tri.insert(tri.end(), {std::int64_t(i), std::int64_t(k + j + 1), std::int64_t(k + j)});
                    ++j;
                }
            }
            brute = std::min(brute, faultmesh::loft_area(a.data(), k, b.data(), l, 3, tri));
        }
        EXPECT_NEAR(best, brute, 1e-12 * brute);
    }
}

// Three distinct points collinear in 3D (exact arithmetic is not needed for
// the inputs below: their coordinates are small integers).
bool collinear3(const double* p, const double* q, const double* r) {
    const double u[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]};
    const double v[3] = {r[0] - p[0], r[1] - p[1], r[2] - p[2]};
    return u[1] * v[2] - u[2] * v[1] == 0.0 && u[2] * v[0] - u[0] * v[2] == 0.0 &&
           u[0] * v[1] - u[1] * v[0] == 0.0;
}
int zero_area_triangles(const std::vector<double>& a, const std::vector<double>& b,
                        const std::vector<std::int64_t>& t) {
    const std::size_t k = a.size() / 3;
    auto pt = [&](std::int64_t i) { return i < std::int64_t(k) ? &a[3 * i] : &b[3 * (i - k)]; };
    int n = 0;
    for (std::size_t i = 0; i < t.size(); i += 3) {
        const double *p = pt(t[i]), *q = pt(t[i + 1]), *r = pt(t[i + 2]);
        const bool repeated = std::equal(p, p + 3, q) || std::equal(q, q + 3, r) || std::equal(r, r + 3, p);
        if (!repeated && collinear3(p, q, r)) ++n;
    }
    return n;
}

TEST(Loft, NoZeroAreaTriangleWhereAnotherPathExists) {
    // A straight polyline a (along y at x = 0, z = -110) and b, which runs at
    // x = 10 and ends on a's last point (an extension that keeps a point
    // already on the study-area boundary). Every triangle (a[i], a[i+1],
    // a[3]) costs no area, so the plain min-area DP walked b to the shared
    // point first and fanned a's straight edges to it: a zero-area triangle
    // (found in faults._assemble on a flat layer, check_surface: "zero
    // area").
    const std::vector<double> a = {0, 0, -110, 0, -3, -110, 0, -6, -110, 0, -9, -110};
    const std::vector<double> b = {10, 0, -110, 10, -4, -110, 0, -9, -110};
    for (LoftMethod m : {LoftMethod::min_area, LoftMethod::shortest_diagonal}) {
        LoftOptions o;
        o.method = m;
        const auto t = faultmesh::loft(a.data(), 4, b.data(), 3, 3, o);
        EXPECT_EQ(t.size(), 3u * (4 + 3 - 2));
        EXPECT_EQ(zero_area_triangles(a, b, t), 0) << "method " << int(m);
    }
    // All points on one line: no other path; the loft still returns one.
    const std::vector<double> c = {0, 0, 0, 1, 0, 0, 2, 0, 0}, d = {0.5, 0, 0, 1.5, 0, 0};
    EXPECT_EQ(faultmesh::loft(c.data(), 3, d.data(), 2, 3).size(), 3u * 3);
}

TEST(Loft, FanToATip) {
    const double a[] = {0, 0, 0, 1, 0, 0, 2, 0.5, 0, 3, 0, 0};
    const double tip[] = {1.5, 2, 1};
    const auto t = faultmesh::loft(a, 4, tip, 1, 3);
    EXPECT_EQ(t, (std::vector<std::int64_t>{0, 1, 4, 1, 2, 4, 2, 3, 4}));
    const auto u = faultmesh::loft(tip, 1, a, 4, 3);
    EXPECT_EQ(u, (std::vector<std::int64_t>{0, 2, 1, 0, 3, 2, 0, 4, 3}));
}

TEST(Loft, ClosedContours) {
    // Two concentric rings (CCW), different counts; every loop edge once.
    std::vector<double> a, b;
    const std::size_t k = 11, l = 17;
    for (std::size_t i = 0; i < k; ++i) {
        const double t = 6.283185307179586 * double(i) / double(k);
        a.insert(a.end(), {std::cos(t), std::sin(t), 0});
    }
    for (std::size_t j = 0; j < l; ++j) {
        const double t = 6.283185307179586 * (double(j) + 0.3) / double(l);
        b.insert(b.end(), {2 * std::cos(t), 2 * std::sin(t), 1});
    }
    for (auto method : {LoftMethod::min_area, LoftMethod::shortest_diagonal}) {
        LoftOptions o;
        o.method = method;
        o.closed = true;
        const auto t = faultmesh::loft(a.data(), k, b.data(), l, 3, o);
        ASSERT_EQ(t.size(), 3 * (k + l));
        auto d = directed(t);
        for (std::size_t i = 0; i < k; ++i)
            EXPECT_EQ((d[{std::int64_t(i), std::int64_t((i + 1) % k)}]), 1);
        for (std::size_t j = 0; j < l; ++j)
            EXPECT_EQ((d[{std::int64_t(k + (j + 1) % l), std::int64_t(k + j)}]), 1);
        for (auto& [e, c] : d.m) EXPECT_EQ(c, 1);
    }
    // Tip: a closed ring to one point is a fan of l triangles.
    LoftOptions o;
    o.closed = true;
    const double tip[] = {0, 0, 5};
    EXPECT_EQ(faultmesh::loft(tip, 1, b.data(), l, 3, o).size(), 3 * l);
    EXPECT_THROW(faultmesh::loft(a.data(), 2, b.data(), l, 3, o), std::invalid_argument);
}

TEST(Loft, BadInput) {
    const double a[] = {0, 0, 0};
    EXPECT_THROW(faultmesh::loft(a, 0, a, 1, 3), std::invalid_argument);
    EXPECT_THROW(faultmesh::loft(a, 1, a, 1, 4), std::invalid_argument);
    const double nan[] = {0, std::numeric_limits<double>::quiet_NaN(), 0};
    EXPECT_THROW(faultmesh::loft(a, 1, nan, 1, 3), std::invalid_argument);
}

// Regression (issue 10): at 1e100 the 3D areas overflow and loft returned no
// triangles; the coordinate limit of predicates.hpp is checked on entry, z too.
TEST(Loft, CoordinatesBeyondTheLimitAreRejected) {
    std::vector<double> a = {0, 0, 0, 1, 0, 0, 2, 0, 0}, b = {0, 1, 1, 1, 1, 1, 2, 1, 1};
    EXPECT_EQ(faultmesh::loft(a.data(), 3, b.data(), 3, 3).size(), 12u);
    b[5] = 1e100;
    try {
        faultmesh::loft(a.data(), 3, b.data(), 3, 3);
        FAIL();
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("loft: b row 1 has a coordinate beyond +-1e+60 (z = 1e+100)"),
                  std::string::npos)
            << e.what();
    }
}
