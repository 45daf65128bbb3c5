// fault_side (fault_side.hpp): location and side against brute force.
#include <faultmesh/errors.hpp>
#include <faultmesh/fault_side.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

using faultmesh::fault_side;
using faultmesh::FaultSideResult;

namespace {

// A grid TIN of the plane w = f(p, q) (p, q, w are the coordinates in the
// order given by `axis`: w is coordinate `axis`), n x n cells of `h`, two
// triangles per cell with alternating diagonals and orientations.
struct Grid {
    std::vector<double> v;
    std::vector<std::int64_t> t;
};

Grid plane_grid(int axis, int n, double h, double p0, double q0, double (*f)(double, double)) {
    Grid g;
    const int iu = (axis + 1) % 3, iv = (axis + 2) % 3;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            double x[3];
            x[iu] = p0 + i * h;
            x[iv] = q0 + j * h;
            x[axis] = f(x[iu], x[iv]);
            g.v.insert(g.v.end(), x, x + 3);
        }
    auto id = [&](int i, int j) { return static_cast<std::int64_t>(j * (n + 1) + i); };
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const auto a = id(i, j), b = id(i + 1, j), c = id(i + 1, j + 1), d = id(i, j + 1);
            if ((i + j) % 2) {
                g.t.insert(g.t.end(), {a, b, c, a, c, d});  // counter-clockwise
            } else {
                g.t.insert(g.t.end(), {a, d, b, b, d, c});  // clockwise
            }
        }
    return g;
}

// Integer-valued planes at UTM-like offsets: every grid vertex lies exactly on them.
double plane_z(double x, double y) { return -10000.0 + (x - 550000.0) * 2.0 - (y - 7820000.0); }

FaultSideResult run(const Grid& g, const std::vector<double>& p, int axis, int hs,
                    const std::uint8_t* extent = nullptr) {
    return fault_side(g.v.data(), g.v.size() / 3, g.t.data(), g.t.size() / 3, p.data(), p.size() / 3, axis, hs,
                      extent);
}

}  // namespace

TEST(FaultSide, PlaneAlongZMatchesExactSideOfPlane) {
    const Grid g = plane_grid(2, 8, 16.0, 550000.0, 7820000.0, plane_z);
    std::mt19937_64 rng(3);
    std::uniform_int_distribution<int> cell(-8, 8 * 16 + 8);
    std::uniform_int_distribution<int> dz(-2, 2);
    std::vector<double> p;
    std::vector<int> want_side, want_inside;
    for (int k = 0; k < 4000; ++k) {
        // Points on a 1 m lattice (so exactly on the vertices, edges and plane
        // at times), z on, above or below the plane by whole or one-ulp steps.
        const double x = 550000.0 + cell(rng), y = 7820000.0 + cell(rng);
        double z = plane_z(x, y);
        const int s = dz(rng);
        if (s == 2) z = std::nextafter(z, 1e300);
        else if (s == -2) z = std::nextafter(z, -1e300);
        else z += s;
        p.insert(p.end(), {x, y, z});
        want_side.push_back(s > 0 ? 1 : (s < 0 ? -1 : 0));
        want_inside.push_back(x >= 550000.0 && x <= 550128.0 && y >= 7820000.0 && y <= 7820128.0);
    }
    const FaultSideResult r = run(g, p, 2, 1);
    for (std::size_t i = 0; i < want_side.size(); ++i) {
        // The surface continued past its edges is the same plane here.
        EXPECT_EQ(r.extended[i], want_side[i]) << i;
        EXPECT_EQ(r.located[i], want_inside[i]) << i;
        EXPECT_EQ(r.side[i], want_inside[i] ? want_side[i] : faultmesh::kBeyondFault) << i;
    }
    // hanging_sign -1 swaps the walls.
    const FaultSideResult m = run(g, p, 2, -1);
    for (std::size_t i = 0; i < want_side.size(); ++i) EXPECT_EQ(m.extended[i], -want_side[i]);
}

TEST(FaultSide, SteepFaultProjectedAlongX) {
    // x = g(y, z): a fault surface that is a function of (y, z).
    auto g_x = [](double y, double z) { return 550000.0 + (y - 7820000.0) - 3.0 * (z + 10000.0); };
    const Grid g = plane_grid(0, 6, 10.0, 7820000.0, -10000.0, +[](double y, double z) {
        return 550000.0 + (y - 7820000.0) - 3.0 * (z + 10000.0);
    });
    std::vector<double> p;
    std::vector<int> want;
    for (int k = 0; k < 60; ++k) {
        const double y = 7820000.0 + k, z = -10000.0 + (k % 50);
        const int s = k % 3 - 1;
        p.insert(p.end(), {g_x(y, z) + s, y, z});
        want.push_back(s);
    }
    const FaultSideResult r = run(g, p, 0, 1);
    for (std::size_t i = 0; i < want.size(); ++i) {
        EXPECT_EQ(r.extended[i], want[i]) << i;
        EXPECT_EQ(r.side[i], want[i]) << i;
    }
}

TEST(FaultSide, ExtentMaskMakesPointsBeyond) {
    const Grid g = plane_grid(2, 2, 10.0, 0.0, 0.0, +[](double x, double) { return -x; });
    std::vector<std::uint8_t> extent(g.t.size() / 3, 1);
    extent[0] = 0;
    // The centroid of triangle 0, above the plane.
    const double* v = g.v.data();
    double c[3] = {0, 0, 0};
    for (int k = 0; k < 3; ++k)
        for (int d = 0; d < 3; ++d) c[d] += v[3 * g.t[k] + d] / 3.0;
    std::vector<double> p = {c[0], c[1], c[2] + 1.0};
    const FaultSideResult r = run(g, p, 2, 1, extent.data());
    EXPECT_EQ(r.side[0], faultmesh::kBeyondFault);
    EXPECT_EQ(r.extended[0], faultmesh::kHangingWall);
    EXPECT_EQ(r.triangle[0], 0);
    EXPECT_EQ(r.located[0], 1);
}

TEST(FaultSide, BadInputIsNamed) {
    const Grid g = plane_grid(2, 1, 1.0, 0.0, 0.0, +[](double, double) { return 0.0; });
    std::vector<double> p = {0.5, 0.5, 1.0};
    EXPECT_THROW(run(g, p, 3, 1), std::invalid_argument);
    EXPECT_THROW(run(g, p, 2, 0), std::invalid_argument);
    std::vector<double> nan = {0.5, std::nan(""), 1.0};
    try {
        run(g, nan, 2, 1);
        FAIL();
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("points row 0"), std::string::npos);
    }
    Grid bad = g;
    bad.t[4] = 99;
    EXPECT_THROW(run(bad, p, 2, 1), std::invalid_argument);
    // A vertical fault has no area in the projection along z.
    const Grid vert = plane_grid(0, 2, 1.0, 0.0, 0.0, +[](double, double) { return 5.0; });
    EXPECT_THROW(run(vert, p, 2, 1), faultmesh::GeometryError);
}

TEST(FaultSide, SetUpOnceAnswersAsTheFunctionAndOwnsItsData) {
    // A curved fault (w = x^2 / 50 on a grid) with a skirt triangle masked out;
    // random points, some beyond the grid (no triangle: nearest boundary edge).
    Grid g = plane_grid(2, 6, 10.0, 0.0, 0.0, +[](double x, double) { return x * x / 50.0; });
    std::vector<std::uint8_t> extent(g.t.size() / 3, 1);
    extent[3] = 0;
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> U(-10.0, 70.0), W(-5.0, 100.0);
    std::vector<double> p;
    for (int i = 0; i < 500; ++i) p.insert(p.end(), {U(rng), U(rng), W(rng)});
    const FaultSideResult want = run(g, p, 2, -1, extent.data());
    faultmesh::FaultSide once(g.v.data(), g.v.size() / 3, g.t.data(), g.t.size() / 3, 2, -1, extent.data());
    // The object keeps copies: the caller's arrays may change or go.
    std::fill(g.v.begin(), g.v.end(), 0.0);
    std::fill(g.t.begin(), g.t.end(), 0);
    std::fill(extent.begin(), extent.end(), 1);
    for (int round = 0; round < 2; ++round) {
        const FaultSideResult got = once.sides(p.data(), p.size() / 3);
        EXPECT_EQ(got.side, want.side);
        EXPECT_EQ(got.extended, want.extended);
        EXPECT_EQ(got.triangle, want.triangle);
        EXPECT_EQ(got.located, want.located);
    }
    EXPECT_EQ(once.n_triangles(), 72u);
    std::vector<double> nan = {0.5, std::nan(""), 1.0};
    EXPECT_THROW(once.sides(nan.data(), 1), std::invalid_argument);
}
