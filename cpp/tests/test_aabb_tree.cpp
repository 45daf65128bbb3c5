// AabbTree: answers equal brute force; exact triangle/box test.
#include <faultmesh/aabb_tree.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <stdexcept>
#include <vector>

using faultmesh::AabbTree;
using faultmesh::Box2;

namespace {

std::vector<std::int64_t> brute(const std::vector<Box2>& boxes, const Box2& q) {
    std::vector<std::int64_t> r;
    for (std::size_t i = 0; i < boxes.size(); ++i)
        if (faultmesh::boxes_meet(boxes[i], q)) r.push_back(static_cast<std::int64_t>(i));
    return r;
}

Box2 random_box(std::mt19937_64& rng, double lo, double hi, double maxsize) {
    std::uniform_real_distribution<double> u(lo, hi), s(0.0, maxsize);
    const double x = u(rng), y = u(rng);
    return {x, y, x + s(rng), y + s(rng)};
}

}  // namespace

TEST(AabbTree, RandomBoxesEqualBruteForce) {
    std::mt19937_64 rng(12345);
    for (std::size_t n : {0u, 1u, 3u, 4u, 5u, 17u, 1000u, 5000u}) {
        std::vector<Box2> boxes;
        for (std::size_t i = 0; i < n; ++i) boxes.push_back(random_box(rng, 0, 100, 3));
        AabbTree t(boxes);
        EXPECT_EQ(t.size(), n);
        std::vector<Box2> qs;
        for (int i = 0; i < 300; ++i) qs.push_back(random_box(rng, -5, 105, 10));
        // Queries that touch boxes exactly at their sides.
        for (std::size_t i = 0; i < std::min<std::size_t>(n, 50); ++i)
            qs.push_back({boxes[i].xmax, boxes[i].ymax, boxes[i].xmax + 1, boxes[i].ymax + 1});
        const faultmesh::Csr r = t.query(qs.data(), qs.size());
        ASSERT_EQ(r.offsets.size(), qs.size() + 1);
        for (std::size_t i = 0; i < qs.size(); ++i) {
            std::vector<std::int64_t> got(r.indices.begin() + r.offsets[i], r.indices.begin() + r.offsets[i + 1]);
            EXPECT_EQ(got, brute(boxes, qs[i])) << "n=" << n << " query " << i;
        }
    }
}

TEST(AabbTree, DuplicateAndClusteredBoxes) {
    // All centres equal (equal Morton codes: middle splits) and a tight cluster
    // next to far outliers (deep quadtree splits).
    std::vector<Box2> same(1000, Box2{1, 1, 2, 2});
    AabbTree t(same);
    std::vector<std::int64_t> out;
    t.query(Box2{2, 2, 3, 3}, out);
    EXPECT_EQ(out.size(), 1000u);
    out.clear();
    t.query(Box2{2.5, 2, 3, 3}, out);
    EXPECT_TRUE(out.empty());

    std::mt19937_64 rng(7);
    std::vector<Box2> boxes;
    for (int i = 0; i < 2000; ++i) boxes.push_back(random_box(rng, 0, 1e-9, 1e-10));
    boxes.push_back({-1e300, -1e300, -1e300, -1e300});
    boxes.push_back({1e300, 1e300, 1e300, 1e300});
    AabbTree c(boxes);
    EXPECT_LE(c.depth(), 120);
    for (int i = 0; i < 100; ++i) {
        const Box2 q = random_box(rng, 0, 1e-9, 2e-10);
        out.clear();
        c.query(q, out);
        std::sort(out.begin(), out.end());
        EXPECT_EQ(out, brute(boxes, q));
    }
}

TEST(AabbTree, EmptyAndNanQueriesMeetNothing) {
    AabbTree t(std::vector<Box2>{{0, 0, 1, 1}});
    std::vector<std::int64_t> out;
    t.query(Box2{1, 0, 0, 1}, out);  // xmin > xmax
    const double nan = std::numeric_limits<double>::quiet_NaN();
    t.query(Box2{nan, 0, 1, 1}, out);
    EXPECT_TRUE(out.empty());
    AabbTree e;
    e.query(Box2{0, 0, 1, 1}, out);
    EXPECT_TRUE(out.empty());
    EXPECT_EQ(e.size(), 0u);
}

TEST(AabbTree, InvalidInputThrows) {
    EXPECT_THROW(AabbTree(std::vector<Box2>{{1, 0, 0, 1}}), std::invalid_argument);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    EXPECT_THROW(AabbTree(std::vector<Box2>{{nan, 0, 1, 1}}), std::invalid_argument);
    const double xy[] = {0, 0, 1, 0, 0, 1};
    const std::int64_t tri[] = {0, 1, 3};
    EXPECT_THROW(AabbTree::from_triangles(xy, 3, 2, tri, 1), std::invalid_argument);
    const std::int64_t neg[] = {0, -1, 2};
    EXPECT_THROW(AabbTree::from_triangles(xy, 3, 2, neg, 1), std::invalid_argument);
}

TEST(AabbTree, TrianglesAndSegments) {
    // 3-column vertices (z ignored), a small grid of triangles.
    const int N = 20;
    std::vector<double> v;
    for (int j = 0; j <= N; ++j)
        for (int i = 0; i <= N; ++i) v.insert(v.end(), {double(i), double(j), 100.0 * i});
    std::vector<std::int64_t> tri;
    auto id = [&](int i, int j) { return std::int64_t(j * (N + 1) + i); };
    for (int j = 0; j < N; ++j)
        for (int i = 0; i < N; ++i) {
            tri.insert(tri.end(), {id(i, j), id(i + 1, j), id(i + 1, j + 1)});
            tri.insert(tri.end(), {id(i, j), id(i + 1, j + 1), id(i, j + 1)});
        }
    const auto m = tri.size() / 3;
    AabbTree t = AabbTree::from_triangles(v.data(), v.size() / 3, 3, tri.data(), m);
    std::vector<std::int64_t> out;
    t.query(Box2{2.5, 2.5, 2.6, 2.6}, out);
    std::sort(out.begin(), out.end());
    EXPECT_EQ(out.size(), 2u);  // both triangles of the cell (boxes are the cell)
    const Box2 b = t.bounds();
    EXPECT_EQ(b.xmin, 0);
    EXPECT_EQ(b.xmax, N);
    out.clear();
    t.query(Box2{5, 5, 5, 5}, out);  // a grid vertex: boxes of 4 cells -> 8 triangles
    EXPECT_EQ(out.size(), 8u);

    std::vector<std::int64_t> seg = {0, 1, 1, 2, 5, 30};
    AabbTree s = AabbTree::from_segments(v.data(), v.size() / 3, 3, seg.data(), 3);
    out.clear();
    s.query(Box2{1, 0, 1, 0}, out);
    std::sort(out.begin(), out.end());
    EXPECT_EQ(out, (std::vector<std::int64_t>{0, 1}));
}

TEST(AabbTree, PolygonQueryUsesTheRingsBox) {
    std::vector<Box2> boxes = {{0, 0, 1, 1}, {5, 5, 6, 6}, {2, 2, 3, 3}};
    AabbTree t(boxes);
    const double ring[] = {1.5, 1.5, 3.5, 1.5, 3.5, 3.5};
    const std::int64_t off[] = {0, 3};
    std::vector<std::int64_t> out;
    t.query_polygon(ring, off, 1, out);
    EXPECT_EQ(out, (std::vector<std::int64_t>{2}));
}

TEST(TriangleMeetsBox, ExactCases) {
    using faultmesh::triangle_meets_box;
    const double a[] = {0, 0}, b[] = {4, 0}, c[] = {0, 4};
    EXPECT_TRUE(triangle_meets_box(a, b, c, {1, 1, 2, 2}));     // inside
    EXPECT_TRUE(triangle_meets_box(a, b, c, {-1, -1, 5, 5}));   // contains the triangle
    EXPECT_TRUE(triangle_meets_box(a, b, c, {2, 2, 3, 3}));     // corner (2,2) on the hypotenuse
    EXPECT_FALSE(triangle_meets_box(a, b, c, {2.5, 2.5, 3, 3})); // beyond the hypotenuse
    EXPECT_TRUE(triangle_meets_box(a, b, c, {4, 0, 5, 1}));     // touches vertex b
    EXPECT_TRUE(triangle_meets_box(c, b, a, {1, 1, 2, 2}));     // clockwise input
    // Hypotenuse x + y = 4 with a corner at (2 + 2^-50, 2): just outside.
    const double eps = 1.0 / (1ull << 50);
    EXPECT_FALSE(triangle_meets_box(a, b, c, {2 + eps, 2, 3, 3}));
    // Degenerate triangle: a segment crossing the box, and one passing beside it.
    const double p[] = {0, 0}, q[] = {10, 10}, r[] = {5, 5};
    EXPECT_TRUE(triangle_meets_box(p, q, r, {4, 3, 6, 4}));
    EXPECT_FALSE(triangle_meets_box(p, q, r, {4, 1, 6, 3.5}));
    EXPECT_TRUE(triangle_meets_box(p, p, p, {0, 0, 0, 0}));
}

TEST(AabbTree, BatchedExactTriangleQueriesEqualBruteForce) {
    // Random triangles (some degenerate), > 64 queries so that the batch is
    // processed in Morton order and put back in input order.
    std::mt19937_64 rng(99);
    std::uniform_int_distribution<int> u(0, 60);
    std::vector<double> xy;
    for (int i = 0; i < 600; ++i) xy.insert(xy.end(), {double(u(rng)), double(u(rng))});
    std::vector<std::int64_t> tri;
    for (int t = 0; t < 500; ++t) {
        const std::int64_t a = static_cast<std::int64_t>(rng() % 600);
        tri.insert(tri.end(), {a, (a + 1 + static_cast<std::int64_t>(rng() % 5)) % 600,
                               (a + 7 + static_cast<std::int64_t>(rng() % 9)) % 600});
    }
    tri.insert(tri.end(), {0, 0, 0});  // a point
    const std::size_t m = tri.size() / 3;
    AabbTree t = AabbTree::from_triangles(xy.data(), 600, 2, tri.data(), m);
    std::vector<Box2> qs;
    for (int i = 0; i < 400; ++i) {
        const double x = u(rng), y = u(rng);
        qs.push_back({x, y, x + u(rng) % 7, y + u(rng) % 7});
    }
    const faultmesh::Csr r = t.query_triangles_exact(qs.data(), qs.size(), xy.data(), 2, tri.data());
    const faultmesh::Csr c = t.query(qs.data(), qs.size(), false);
    for (std::size_t i = 0; i < qs.size(); ++i) {
        std::vector<std::int64_t> want;
        for (std::size_t k = 0; k < m; ++k)
            if (faultmesh::triangle_meets_box(&xy[2 * tri[3 * k]], &xy[2 * tri[3 * k + 1]], &xy[2 * tri[3 * k + 2]], qs[i]))
                want.push_back(static_cast<std::int64_t>(k));
        std::vector<std::int64_t> got(r.indices.begin() + r.offsets[i], r.indices.begin() + r.offsets[i + 1]);
        EXPECT_EQ(got, want) << "query " << i;
        std::vector<std::int64_t> cand(c.indices.begin() + c.offsets[i], c.indices.begin() + c.offsets[i + 1]);
        std::sort(cand.begin(), cand.end());
        EXPECT_EQ(cand, brute([&] {
                      std::vector<Box2> b;
                      for (std::size_t k = 0; k < m; ++k) b.push_back(t.box(k));
                      return b;
                  }(), qs[i]));
    }
}
