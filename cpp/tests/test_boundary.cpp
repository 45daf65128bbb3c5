// Boundary contours: edge frequency + Algorithm 1 sorting.
#include <faultmesh/boundary.hpp>
#include <faultmesh/errors.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>
#include <vector>

using faultmesh::BoundaryContours;
using Loop = std::vector<std::int64_t>;

namespace {

// Grid of (N+1)^2 vertices, 2 CCW triangles per cell, minus the cells for
// which `keep(i, j)` is false.
template <class Keep>
std::vector<std::int64_t> grid(int N, Keep keep) {
    std::vector<std::int64_t> t;
    auto id = [&](int i, int j) { return std::int64_t(j * (N + 1) + i); };
    for (int j = 0; j < N; ++j)
        for (int i = 0; i < N; ++i) {
            if (!keep(i, j)) continue;
            t.insert(t.end(), {id(i, j), id(i + 1, j), id(i + 1, j + 1)});
            t.insert(t.end(), {id(i, j), id(i + 1, j + 1), id(i, j + 1)});
        }
    return t;
}

// Twice the signed area of a loop on the grid of side N.
double area2(const Loop& l, int N) {
    double s = 0;
    for (std::size_t k = 0; k < l.size(); ++k) {
        const auto a = l[k], b = l[(k + 1) % l.size()];
        const double ax = double(a % (N + 1)), ay = double(a / (N + 1));
        const double bx = double(b % (N + 1)), by = double(b / (N + 1));
        s += ax * by - ay * bx;
    }
    return s;
}

}  // namespace

TEST(Boundary, SingleTriangle) {
    const std::int64_t t[] = {4, 7, 9};
    auto loops = faultmesh::boundary_loops(t, 1);
    ASSERT_EQ(loops.size(), 1u);
    EXPECT_EQ(loops[0], (Loop{4, 7, 9}));
    const std::int64_t cw[] = {9, 7, 4};
    loops = faultmesh::boundary_loops(cw, 1);
    EXPECT_EQ(loops[0], (Loop{4, 9, 7}));  // starts at the smallest edge (4, 9)
    EXPECT_EQ(faultmesh::boundary_edges(t, 1), (std::vector<std::int64_t>{4, 7, 9, 4, 7, 9}));  // by smaller vertex
}

TEST(Boundary, GridWithHolesOrientedAndOrderIndependent) {
    const int N = 12;
    auto keep = [](int i, int j) {
        return !((i >= 2 && i < 4 && j >= 2 && j < 5) || (i >= 7 && i < 10 && j >= 6 && j < 8));
    };
    std::vector<std::int64_t> t = grid(N, keep);
    const std::size_t m = t.size() / 3;
    auto loops = faultmesh::boundary_loops(t.data(), m);
    ASSERT_EQ(loops.size(), 3u);
    int outer = 0, holes = 0;
    std::set<std::int64_t> hole_area;
    for (const Loop& l : loops) {
        const double a = area2(l, N);
        if (a > 0) {
            ++outer;
            EXPECT_EQ(a, 2.0 * N * N);
            EXPECT_EQ(l.size(), std::size_t(4 * N));
        } else {
            ++holes;
            hole_area.insert(static_cast<std::int64_t>(-a / 2));
        }
    }
    EXPECT_EQ(outer, 1);
    EXPECT_EQ(holes, 2);
    EXPECT_EQ(hole_area, (std::set<std::int64_t>{6, 6}));  // 2x3 and 3x2 blocks

    // Any triangle order, any rotation of each triangle: the same loops.
    std::mt19937_64 rng(3);
    std::vector<std::array<std::int64_t, 3>> tris(m);
    for (std::size_t i = 0; i < m; ++i) tris[i] = {t[3 * i], t[3 * i + 1], t[3 * i + 2]};
    for (int rep = 0; rep < 5; ++rep) {
        std::shuffle(tris.begin(), tris.end(), rng);
        std::vector<std::int64_t> s;
        for (auto& x : tris) {
            std::rotate(x.begin(), x.begin() + static_cast<long>(rng() % 3), x.end());
            s.insert(s.end(), x.begin(), x.end());
        }
        EXPECT_EQ(faultmesh::boundary_loops(s.data(), m), loops);
    }
}

TEST(Boundary, PinchVertexReportedAndResolved) {
    // Two triangles sharing only vertex 0, plus a square with two holes
    // touching at a vertex is covered by the Python tests.
    const std::int64_t t[] = {0, 1, 2, 0, 3, 4};
    EXPECT_THROW(faultmesh::boundary_loops(t, 2), faultmesh::GeometryError);
    try {
        faultmesh::boundary_loops(t, 2);
    } catch (const faultmesh::GeometryError& e) {
        EXPECT_NE(std::string(e.what()).find("vertex 0"), std::string::npos) << e.what();
    }
    BoundaryContours c = faultmesh::boundary_contours(t, 2);
    EXPECT_EQ(c.pinch_vertices, (std::vector<std::int64_t>{0}));
    ASSERT_EQ(c.loops.size(), 2u);
    EXPECT_EQ(c.loops[0], (Loop{0, 1, 2}));
    EXPECT_EQ(c.loops[1], (Loop{0, 3, 4}));
    EXPECT_TRUE(c.open_chains.empty());
    EXPECT_TRUE(c.chain_break_vertices.empty());
    EXPECT_EQ(faultmesh::boundary_loops(t, 2, 0, false).size(), 2u);
}

TEST(Boundary, PinchInsideOneLoopFollowsTheFans) {
    // A hole touching the outer boundary at one vertex.
    const int N = 3;
    // Remove the centre cell (1,1) and the corner cell (2,2): they touch at
    // vertex (2,2) -> the hole and the outer boundary meet there.
    auto keep = [](int i, int j) { return !((i == 1 && j == 1) || (i == 2 && j == 2)); };
    std::vector<std::int64_t> t = grid(N, keep);
    BoundaryContours c = faultmesh::boundary_contours(t.data(), t.size() / 3);
    const std::int64_t v22 = 2 * (N + 1) + 2;
    EXPECT_EQ(c.pinch_vertices, (std::vector<std::int64_t>{v22}));
    EXPECT_TRUE(c.open_chains.empty());
    // The fan walk pairs the edges as the surface does: each of the two
    // triangles at (2,2) enters from the outer boundary and leaves into the
    // hole, so the surface (a disk whose boundary touches itself) has ONE
    // boundary loop of 12 + 4 edges passing (2,2) twice; its signed area is
    // the outer area minus the hole.
    ASSERT_EQ(c.loops.size(), 1u);
    EXPECT_EQ(c.loops[0].size(), 16u);
    EXPECT_EQ(std::count(c.loops[0].begin(), c.loops[0].end(), v22), 2);
    EXPECT_EQ(area2(c.loops[0], N), 2.0 * (9 - 1) - 2.0);
    EXPECT_THROW(faultmesh::boundary_loops(t.data(), t.size() / 3), faultmesh::GeometryError);
}

TEST(Boundary, InconsistentAndNonManifoldReported) {
    // Second triangle flipped: the shared edge (1, 2) is used twice in the same direction.
    const std::int64_t t[] = {0, 1, 2, 1, 2, 3};
    BoundaryContours c = faultmesh::boundary_contours(t, 2);
    EXPECT_EQ(c.inconsistent_edges, (std::vector<std::int64_t>{1, 2}));
    EXPECT_FALSE(c.open_chains.empty());
    EXPECT_THROW(faultmesh::boundary_loops(t, 2), faultmesh::GeometryError);
    // Three triangles on edge (0, 1).
    const std::int64_t nm[] = {0, 1, 2, 1, 0, 3, 0, 1, 4};
    c = faultmesh::boundary_contours(nm, 3);
    EXPECT_EQ(c.nonmanifold_edges, (std::vector<std::int64_t>{0, 1}));
    EXPECT_THROW(faultmesh::boundary_loops(nm, 3), faultmesh::GeometryError);
}

TEST(Boundary, BadInput) {
    const std::int64_t neg[] = {0, -1, 2};
    EXPECT_THROW(faultmesh::boundary_loops(neg, 1), std::invalid_argument);
    const std::int64_t rep[] = {0, 1, 1};
    EXPECT_THROW(faultmesh::boundary_loops(rep, 1), std::invalid_argument);
    const std::int64_t t[] = {0, 1, 5};
    EXPECT_THROW(faultmesh::boundary_loops(t, 1, 4), std::invalid_argument);
    EXPECT_TRUE(faultmesh::boundary_loops(t, 0).empty());
}

TEST(SortSegments, Algorithm1HeadAndTailInsertion) {
    // A loop 0..9 given in scrambled order, plus an open chain 20 -> 21 -> 22.
    std::vector<std::int64_t> seg;
    for (int i = 0; i < 10; ++i) seg.insert(seg.end(), {i, (i + 1) % 10});
    seg.insert(seg.end(), {21, 22, 20, 21});
    std::mt19937_64 rng(11);
    for (int rep = 0; rep < 5; ++rep) {
        std::vector<std::array<std::int64_t, 2>> s(seg.size() / 2);
        for (std::size_t i = 0; i < s.size(); ++i) s[i] = {seg[2 * i], seg[2 * i + 1]};
        std::shuffle(s.begin(), s.end(), rng);
        std::vector<std::int64_t> flat;
        for (auto& x : s) flat.insert(flat.end(), x.begin(), x.end());
        BoundaryContours c = faultmesh::sort_segments(flat.data(), s.size());
        ASSERT_EQ(c.loops.size(), 1u);
        EXPECT_EQ(c.loops[0], (Loop{0, 1, 2, 3, 4, 5, 6, 7, 8, 9}));
        ASSERT_EQ(c.open_chains.size(), 1u);
        EXPECT_EQ(c.open_chains[0], (Loop{20, 21, 22}));
        EXPECT_TRUE(c.pinch_vertices.empty());
    }
    // A figure eight through vertex 0: pinch paired in input order, reported.
    const std::int64_t eight[] = {0, 1, 1, 2, 2, 0, 0, 3, 3, 4, 4, 0};
    BoundaryContours c = faultmesh::sort_segments(eight, 6);
    EXPECT_EQ(c.pinch_vertices, (std::vector<std::int64_t>{0}));
    std::size_t edges = 0;
    for (auto& l : c.loops) edges += l.size();
    EXPECT_EQ(edges, 6u);
}

// Regression (issue 10): tables were sized by the largest index, so one
// triangle (0, 1, 2^31 - 2) allocated gigabytes (bad_alloc). Indices far
// beyond the triangle count are renumbered internally, the output is the same.
TEST(Boundary, HugeIndicesAreRenumberedNotAllocated) {
    for (std::int64_t big : {std::int64_t{2147483646}, std::int64_t{1} << 40, std::int64_t{1} << 62}) {
        const std::vector<std::int64_t> t = {0, 1, big};
        const auto loops = faultmesh::boundary_loops(t.data(), 1);
        ASSERT_EQ(loops.size(), 1u);
        EXPECT_EQ(loops[0], (Loop{0, 1, big}));
        EXPECT_EQ(faultmesh::boundary_edges(t.data(), 1), (std::vector<std::int64_t>{0, 1, big, 0, 1, big}));  // grouped by smaller vertex
        // With n_vertices the range check still names the row.
        EXPECT_EQ(faultmesh::boundary_loops(t.data(), 1, static_cast<std::size_t>(big) + 1).size(), 1u);
        EXPECT_THROW(faultmesh::boundary_loops(t.data(), 1, 3), std::invalid_argument);
    }
    // A pinch (two triangles sharing vertex 5e15): reported under its own number.
    const std::vector<std::int64_t> pinch = {0, 1, 5000000000000000, 5000000000000000, 7, 8};
    const BoundaryContours c = faultmesh::boundary_contours(pinch.data(), 2);
    EXPECT_EQ(c.pinch_vertices, (std::vector<std::int64_t>{5000000000000000}));
    EXPECT_EQ(c.loops.size(), 2u);
}
