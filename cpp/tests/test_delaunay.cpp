// Tests of faultmesh::delaunay: validity invariants on random, grid,
// cocircular, collinear and duplicate inputs; canonical-result metamorphic
// tests (input order, translation, power-of-two scaling); errors; and the
// private spatial-sort helper.
#include <faultmesh/delaunay.hpp>
#include <faultmesh/errors.hpp>
#include <faultmesh/predicates.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "../src/delaunay_core.hpp"
#include "../src/spatial_sort.hpp"
#include "test_support.hpp"

namespace fm = faultmesh;

namespace {

using fm::test::Tri;
using fm::test::tri_set;

// Map a triangle set through an index permutation (new index of old index i
// is perm_inv[i]).
std::set<Tri> remap(const std::vector<std::int64_t>& t, const std::vector<std::int64_t>& to) {
    std::vector<std::int64_t> u(t.size());
    for (std::size_t i = 0; i < t.size(); ++i) u[i] = to[t[i]];
    return tri_set(u);
}

// Twice the area of the convex hull, by Andrew's monotone chain with the
// exact orientation predicate (collinear points dropped: the area is the same).
double hull_area2(const std::vector<double>& xy) {
    const std::size_t n = xy.size() / 2;
    std::vector<std::size_t> idx(n);
    std::iota(idx.begin(), idx.end(), 0);
    std::sort(idx.begin(), idx.end(), [&](std::size_t a, std::size_t b) {
        return xy[2 * a] < xy[2 * b] || (xy[2 * a] == xy[2 * b] && xy[2 * a + 1] < xy[2 * b + 1]);
    });
    std::vector<std::size_t> h(2 * n);
    std::size_t k = 0;
    for (std::size_t i = 0; i < n; ++i) {
        while (k >= 2 && fm::orient2d(&xy[2 * h[k - 2]], &xy[2 * h[k - 1]], &xy[2 * idx[i]]) <= 0) --k;
        h[k++] = idx[i];
    }
    for (std::size_t i = n - 1, t = k + 1; i-- > 0;) {
        while (k >= t && fm::orient2d(&xy[2 * h[k - 2]], &xy[2 * h[k - 1]], &xy[2 * idx[i]]) <= 0) --k;
        h[k++] = idx[i];
    }
    double a = 0;
    for (std::size_t i = 0; i + 1 < k; ++i)
        a += xy[2 * h[i]] * xy[2 * h[i + 1] + 1] - xy[2 * h[i + 1]] * xy[2 * h[i] + 1];
    return a;
}

// Every invariant of a valid Delaunay triangulation of xy.
void check_valid(const std::vector<double>& xy, const fm::DelaunayResult& r) {
    const std::size_t n = xy.size() / 2;
    const auto& T = r.triangles;
    const auto& H = r.halfedges;
    ASSERT_EQ(T.size() % 3, 0u);
    ASSERT_EQ(H.size(), T.size());
    ASSERT_EQ(r.vertex_of_input.size(), n);
    const std::size_t m = T.size() / 3;
    auto P = [&](std::int64_t v) { return &xy[2 * static_cast<std::size_t>(v)]; };

    // Duplicates: the map points to the smallest equal row; only
    // representatives are used by triangles.
    std::size_t dups = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const std::int64_t rep = r.vertex_of_input[i];
        ASSERT_GE(rep, 0);
        ASSERT_LE(rep, static_cast<std::int64_t>(i));
        EXPECT_EQ(xy[2 * rep], xy[2 * i]);
        EXPECT_EQ(xy[2 * rep + 1], xy[2 * i + 1]);
        EXPECT_EQ(r.vertex_of_input[rep], rep);
        if (rep != static_cast<std::int64_t>(i)) ++dups;
    }
    EXPECT_EQ(dups, r.n_duplicates);
    const std::size_t nv = n - dups;

    std::vector<char> used(n, 0);
    double area2 = 0;
    std::size_t hull_edges = 0;
    for (std::size_t t = 0; t < m; ++t) {
        const std::int64_t a = T[3 * t], b = T[3 * t + 1], c = T[3 * t + 2];
        for (std::int64_t v : {a, b, c}) {
            ASSERT_GE(v, 0);
            ASSERT_LT(v, static_cast<std::int64_t>(n));
            EXPECT_EQ(r.vertex_of_input[v], v) << "triangle uses a merged duplicate";
            used[v] = 1;
        }
        const double o = fm::orient2d(P(a), P(b), P(c));
        EXPECT_GT(o, 0.0) << "triangle " << t << " is not counter-clockwise";
        area2 += o;
    }
    for (std::size_t i = 0; i < n; ++i)
        EXPECT_EQ(used[i] != 0, r.vertex_of_input[i] == static_cast<std::int64_t>(i))
            << "every distinct point is a vertex";

    for (std::size_t e = 0; e < 3 * m; ++e) {
        const std::int64_t o = H[e];
        const std::size_t en = e % 3 == 2 ? e - 2 : e + 1;
        if (o < 0) {
            ++hull_edges;
            continue;
        }
        ASSERT_LT(o, static_cast<std::int64_t>(3 * m));
        EXPECT_EQ(H[o], static_cast<std::int64_t>(e)) << "half-edge symmetry";
        const std::size_t on = o % 3 == 2 ? o - 2 : o + 1;
        EXPECT_EQ(T[e], T[on]);
        EXPECT_EQ(T[en], T[o]);
        // Locally Delaunay: the apex across the edge is not inside the
        // circumcircle -- exactly, and also under the symbolic perturbation
        // that decides cocircular cases.
        const std::size_t t = e / 3, ot = o / 3;
        const std::int64_t d = T[(on % 3 == 2) ? on - 2 : on + 1];  // apex of the twin
        EXPECT_LE(fm::incircle(P(T[3 * t]), P(T[3 * t + 1]), P(T[3 * t + 2]), P(d)), 0.0);
        EXPECT_FALSE(fm::detail::incircle_perturbed(P(T[3 * t]), P(T[3 * t + 1]), P(T[3 * t + 2]), P(d)))
            << "edge " << e << " is not locally Delaunay under the perturbation";
        (void)ot;
    }
    // Euler: V - E + F = 1 for a triangulated disk; m = 2V - h - 2.
    const std::size_t edges = (3 * m + hull_edges) / 2;
    EXPECT_EQ(static_cast<long>(nv) - static_cast<long>(edges) + static_cast<long>(m), 1);
    EXPECT_EQ(m, 2 * nv - hull_edges - 2);
    // The triangles cover the convex hull. Relative tolerance: each orient2d
    // value is the rounded determinant (relative error ~1e-16 each, m terms).
    const double ha = hull_area2(xy);
    EXPECT_NEAR(area2, ha, 1e-12 * std::fabs(ha) * std::sqrt(static_cast<double>(m) + 1));
}

std::vector<double> uniform(std::size_t n, unsigned seed, double lo = 0, double hi = 1) {
    std::mt19937_64 g(seed);
    std::uniform_real_distribution<double> u(lo, hi);
    std::vector<double> xy(2 * n);
    for (auto& v : xy) v = u(g);
    return xy;
}

std::vector<double> grid(int nx, int ny, double step = 1.0, double x0 = 0, double y0 = 0) {
    std::vector<double> xy;
    for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) {
            xy.push_back(x0 + i * step);
            xy.push_back(y0 + j * step);
        }
    return xy;
}

// Points in a permuted order; returns the permuted array and, for each old
// index, its new index.
std::vector<double> shuffled(const std::vector<double>& xy, unsigned seed, std::vector<std::int64_t>& new_of_old) {
    const std::size_t n = xy.size() / 2;
    std::vector<std::int64_t> perm(n);
    std::iota(perm.begin(), perm.end(), 0);
    std::shuffle(perm.begin(), perm.end(), std::mt19937_64(seed));
    std::vector<double> out(2 * n);
    new_of_old.assign(n, -1);
    for (std::size_t k = 0; k < n; ++k) {
        out[2 * k] = xy[2 * perm[k]];
        out[2 * k + 1] = xy[2 * perm[k] + 1];
        new_of_old[perm[k]] = static_cast<std::int64_t>(k);
    }
    return out;
}

fm::DelaunayResult run(const std::vector<double>& xy) { return fm::delaunay(xy.data(), xy.size() / 2); }

}  // namespace

TEST(Delaunay, UniformRandomIsValid) {
    for (std::size_t n : {3u, 4u, 10u, 100u, 1000u, 20000u}) {
        SCOPED_TRACE(n);
        const auto xy = uniform(n, 7 + static_cast<unsigned>(n));
        const auto r = run(xy);
        check_valid(xy, r);
        EXPECT_EQ(r.n_duplicates, 0u);
    }
}

TEST(Delaunay, SquareGridIsValidAndCountsMatch) {
    // An n x n grid: every cell is 4 cocircular points. Hull has 4(n-1)
    // vertices, so 2 n^2 - 4(n - 1) - 2 triangles.
    const int n = 60;
    const auto xy = grid(n, n);
    const auto r = run(xy);
    check_valid(xy, r);
    EXPECT_EQ(r.triangles.size() / 3, static_cast<std::size_t>(2 * n * n - 4 * (n - 1) - 2));
}

TEST(Delaunay, CocircularIntegerCircle) {
    // The 12 integer points on x^2 + y^2 = 25 and the centre: all exactly
    // cocircular around the centre -> a canonical fan is still valid.
    std::vector<double> xy = {0, 0};
    const int pts[12][2] = {{5, 0}, {4, 3}, {3, 4}, {0, 5}, {-3, 4}, {-4, 3},
                            {-5, 0}, {-4, -3}, {-3, -4}, {0, -5}, {3, -4}, {4, -3}};
    for (auto& p : pts) {
        xy.push_back(p[0]);
        xy.push_back(p[1]);
    }
    const auto r = run(xy);
    check_valid(xy, r);
    EXPECT_EQ(r.triangles.size() / 3, 12u);
    // Without the centre: 12 cocircular points, 10 triangles, any order.
    std::vector<double> ring(xy.begin() + 2, xy.end());
    const auto r2 = run(ring);
    check_valid(ring, r2);
    EXPECT_EQ(r2.triangles.size() / 3, 10u);
    std::vector<std::int64_t> to;
    const auto sh = shuffled(ring, 3, to);
    EXPECT_EQ(tri_set(run(sh).triangles), remap(r2.triangles, to));
}

TEST(Delaunay, InsertionOrderDoesNotMatter) {
    for (const auto& xy : {uniform(3000, 11), grid(40, 30), grid(17, 17, 0.25, -3, 5)}) {
        const auto ref = run(xy);
        for (unsigned seed : {1u, 2u, 3u}) {
            std::vector<std::int64_t> to;
            const auto sh = shuffled(xy, seed, to);
            EXPECT_EQ(tri_set(run(sh).triangles), remap(ref.triangles, to));
        }
    }
}

TEST(Delaunay, TranslationAndPowerOfTwoScalingGiveTheSameTriangles) {
    // Coordinates are multiples of 2^-10 below 2^10, so adding 1e6 or scaling
    // by 2^k is exact and every predicate sees the same geometry.
    std::mt19937_64 g(5);
    std::uniform_int_distribution<int> u(0, 1 << 14);
    std::vector<double> xy(2 * 2000);
    for (auto& v : xy) v = std::ldexp(static_cast<double>(u(g)), -10);
    const auto g2 = grid(25, 25, 0.5);
    xy.insert(xy.end(), g2.begin(), g2.end());  // plus exact cocircular structure
    const auto ref = tri_set(run(xy).triangles);
    for (double shift : {1e6, -1e6, 5.5e5}) {
        auto t = xy;
        for (std::size_t i = 0; i < t.size(); ++i) t[i] += (i % 2 ? 7.8e6 : shift);
        EXPECT_EQ(tri_set(run(t).triangles), ref) << "shift " << shift;
    }
    for (int k : {-20, -3, 1, 7, 30}) {
        auto t = xy;
        for (auto& v : t) v = std::ldexp(v, k);
        EXPECT_EQ(tri_set(run(t).triangles), ref) << "scale 2^" << k;
    }
}

TEST(Delaunay, DuplicatesAreMergedToTheSmallestIndex) {
    auto xy = uniform(500, 3);
    // Rows 500..699 duplicate rows 0..199, some twice.
    for (int i = 0; i < 200; ++i) {
        xy.push_back(xy[2 * i]);
        xy.push_back(xy[2 * i + 1]);
    }
    for (int i = 0; i < 50; ++i) {
        xy.push_back(xy[2 * i]);
        xy.push_back(xy[2 * i + 1]);
    }
    const auto r = run(xy);
    check_valid(xy, r);
    EXPECT_EQ(r.n_duplicates, 250u);
    EXPECT_EQ(r.vertex_of_input[500], 0);
    EXPECT_EQ(r.vertex_of_input[700], 0);
    EXPECT_EQ(r.vertex_of_input[699], 199);
    std::vector<double> uniq(xy.begin(), xy.begin() + 1000);
    EXPECT_EQ(tri_set(r.triangles), tri_set(run(uniq).triangles));
    // A duplicate placed before its original: the smaller index represents it.
    std::vector<double> pre = {xy[2 * 7], xy[2 * 7 + 1]};
    pre.insert(pre.end(), uniq.begin(), uniq.end());
    const auto rp = run(pre);
    EXPECT_EQ(rp.vertex_of_input[8], 0);
    EXPECT_EQ(rp.n_duplicates, 1u);
}

TEST(Delaunay, CollinearPointsWithOneOffLine) {
    // k points on a line and one apex: a fan of k - 1 triangles.
    for (int k : {2, 3, 10, 257}) {
        std::vector<double> xy;
        for (int i = 0; i < k; ++i) {
            xy.push_back(0.5 * i);
            xy.push_back(0.25 * i);
        }
        xy.push_back(1.0);
        xy.push_back(7.0);
        const auto r = run(xy);
        check_valid(xy, r);
        EXPECT_EQ(r.triangles.size() / 3, static_cast<std::size_t>(k - 1));
    }
}

TEST(Delaunay, PointsOnTheHullLineBeyondAndBetween) {
    // Regression: points collinear with a hull edge, inserted outside the
    // segment (the hull edge stays) and inside it (the edge is split).
    std::vector<double> xy = {0, 0, 4, 0, 2, 3, 8, 0, -4, 0, 1, 0, 3, 0, 12, 0, 2, -1};
    const auto r = run(xy);
    check_valid(xy, r);
    std::vector<std::int64_t> to;
    for (unsigned seed = 0; seed < 20; ++seed) {
        const auto sh = shuffled(xy, seed, to);
        EXPECT_EQ(tri_set(run(sh).triangles), remap(r.triangles, to));
    }
}

TEST(Delaunay, ErrorsNameTheProblem) {
    std::vector<double> few = {0, 0, 1, 1};
    EXPECT_THROW(run(few), fm::GeometryError);
    std::vector<double> dup3 = {0, 0, 1, 1, 0, 0, 1, 1, 0, 0};
    try {
        run(dup3);
        FAIL();
    } catch (const fm::GeometryError& e) {
        EXPECT_NE(std::string(e.what()).find("3 distinct"), std::string::npos) << e.what();
    }
    std::vector<double> line = {0, 0, 1, 1, 2, 2, 3, 3, 1, 1};
    try {
        run(line);
        FAIL();
    } catch (const fm::GeometryError& e) {
        EXPECT_NE(std::string(e.what()).find("collinear"), std::string::npos) << e.what();
    }
    std::vector<double> bad = {0, 0, 1, 0, 0, 1, 2, std::numeric_limits<double>::quiet_NaN()};
    try {
        run(bad);
        FAIL();
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("xy row 3"), std::string::npos) << e.what();
    }
    bad[7] = std::numeric_limits<double>::infinity();
    EXPECT_THROW(run(bad), std::invalid_argument);
    bad[7] = -2e60;  // would overflow the exact in-circle evaluation
    try {
        run(bad);
        FAIL();
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("delaunay: xy row 3 has a coordinate beyond"), std::string::npos) << e.what();
    }
    bad[7] = -1e60;  // the largest accepted magnitude
    check_valid(bad, run(bad));
    EXPECT_THROW(fm::delaunay(nullptr, 0), fm::GeometryError);
}

TEST(Delaunay, WithoutHalfedgesGivesTheSameTriangles) {
    const auto xy = uniform(2000, 12);
    const auto full = run(xy);
    const auto lean = fm::delaunay(xy.data(), 2000, false);
    EXPECT_TRUE(lean.halfedges.empty());
    EXPECT_EQ(lean.triangles, full.triangles);
    EXPECT_EQ(lean.vertex_of_input, full.vertex_of_input);
}

TEST(Delaunay, ClusteredAndTinyExtentInput) {
    // Gaussian clusters of very different scales plus far outliers: the
    // Hilbert quantisation maps many points to one cell, which must only
    // affect speed.
    std::mt19937_64 g(9);
    std::normal_distribution<double> nd(0.0, 1.0);
    std::vector<double> xy;
    const double scales[4] = {1e-9, 1e-4, 1.0, 1e3};
    for (int c = 0; c < 4; ++c)
        for (int i = 0; i < 2000; ++i) {
            xy.push_back(100.0 * c + scales[c] * nd(g));
            xy.push_back(-50.0 * c + scales[c] * nd(g));
        }
    const auto r = run(xy);
    check_valid(xy, r);
}

TEST(Delaunay, GridWithRandomHolesAndJitteredRows) {
    // Regression-style mix of exact cocircular cells and general position.
    auto xy = grid(50, 50);
    std::mt19937_64 g(4);
    std::uniform_real_distribution<double> u(0, 49);
    for (int i = 0; i < 500; ++i) {
        xy.push_back(u(g));
        xy.push_back(std::floor(u(g)));  // on grid rows: many collinear triples
    }
    const auto r = run(xy);
    check_valid(xy, r);
}

TEST(SpatialSort, HilbertIndexVisitsAdjacentCells) {
    for (int levels : {4, 8}) {
        const std::uint32_t side = 1u << levels;
        std::vector<std::pair<std::uint32_t, std::uint32_t>> cell_of(side * side);
        std::vector<char> seen(side * side, 0);
        for (std::uint32_t x = 0; x < side; ++x)
            for (std::uint32_t y = 0; y < side; ++y) {
                const std::uint64_t d = fm::detail::hilbert_index(x, y, levels);
                ASSERT_LT(d, static_cast<std::uint64_t>(side) * side);
                ASSERT_FALSE(seen[d]) << "Hilbert index is a bijection";
                seen[d] = 1;
                cell_of[d] = {x, y};
            }
        for (std::size_t d = 1; d < cell_of.size(); ++d) {
            const long dx = std::labs(static_cast<long>(cell_of[d].first) - static_cast<long>(cell_of[d - 1].first));
            const long dy = std::labs(static_cast<long>(cell_of[d].second) - static_cast<long>(cell_of[d - 1].second));
            EXPECT_EQ(dx + dy, 1) << "cells " << d - 1 << " and " << d << " are neighbours";
        }
    }
}

TEST(SpatialSort, BrioOrderIsAPermutation) {
    const auto xy = uniform(10000, 2);
    auto ord = fm::detail::brio_order(xy.data(), 2, 10000);
    std::sort(ord.begin(), ord.end());
    for (std::uint32_t i = 0; i < 10000; ++i) ASSERT_EQ(ord[i], i);
}
