// GoogleTest: halfedge_twins (triangle_adjacency.hpp), the one adjacency of
// the stitcher, the grower and the cutting baseline.
#include <faultmesh/delaunay.hpp>
#include <faultmesh/errors.hpp>
#include <faultmesh/triangle_adjacency.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

namespace {

using faultmesh::EdgeOrientation;
using faultmesh::GeometryError;
using Idx = std::vector<std::int64_t>;

std::string error_of(const Idx& t, std::size_t n, EdgeOrientation o, const faultmesh::AdjacencyLabels& l = {}) {
    try {
        faultmesh::halfedge_twins(t.data(), t.size() / 3, n, o, "test", l);
    } catch (const GeometryError& e) {
        return e.what();
    }
    return "";
}

}  // namespace

TEST(TriangleAdjacency, EqualsTheDelaunayHalfEdges) {
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(0.0, 100.0);
    std::vector<double> xy;
    for (int i = 0; i < 3000; ++i) {
        const double x = u(rng), y = u(rng);
        if (std::hypot(x - 50.0, y - 50.0) > 1.0) xy.insert(xy.end(), {x, y});
    }
    // A fan centre with 40 neighbours (more than 32 half-edges in its bucket:
    // the sorted path): the centre of a circle of points.
    xy.insert(xy.end(), {50.0, 50.0});
    for (int i = 0; i < 40; ++i) xy.insert(xy.end(), {50.0 + 0.5 * std::cos(i * 0.157), 50.0 + 0.5 * std::sin(i * 0.157)});
    const auto d = faultmesh::delaunay(xy.data(), xy.size() / 2);
    const Idx tw = faultmesh::halfedge_twins(d.triangles.data(), d.triangles.size() / 3, xy.size() / 2,
                                             EdgeOrientation::consistent, "test");
    EXPECT_EQ(tw, d.halfedges);
    // `any` pairs the same edges, whatever the orientation of each triangle.
    Idx flipped = d.triangles;
    for (std::size_t t = 0; t < flipped.size() / 3; t += 2) std::swap(flipped[3 * t + 1], flipped[3 * t + 2]);
    const Idx ta = faultmesh::halfedge_twins(flipped.data(), flipped.size() / 3, xy.size() / 2,
                                             EdgeOrientation::any, "test");
    for (std::size_t h = 0; h < ta.size(); ++h) {
        if (ta[h] < 0) continue;
        EXPECT_EQ(ta[static_cast<std::size_t>(ta[h])], static_cast<std::int64_t>(h));
        const std::int64_t a = flipped[h], b = flipped[static_cast<std::size_t>(faultmesh::next_halfedge(static_cast<std::int64_t>(h)))];
        const std::int64_t c = flipped[static_cast<std::size_t>(ta[h])];
        const std::int64_t e = flipped[static_cast<std::size_t>(faultmesh::next_halfedge(ta[h]))];
        EXPECT_TRUE((a == c && b == e) || (a == e && b == c));
        EXPECT_NE(ta[h] / 3, static_cast<std::int64_t>(h / 3));
    }
    std::size_t paired_c = 0, paired_a = 0;
    for (auto x : tw) paired_c += x >= 0;
    for (auto x : ta) paired_a += x >= 0;
    EXPECT_EQ(paired_a, paired_c);
}

TEST(TriangleAdjacency, ErrorsNameTheEdgeAndTheRows) {
    // Three triangles on edge (0, 1).
    const Idx nm = {0, 1, 2, 1, 0, 3, 0, 1, 4};
    const std::string e1 = error_of(nm, 5, EdgeOrientation::any);
    EXPECT_NE(e1.find("test: edge (0, 1) is used by 3 triangles (rows 0, 1, 2)"), std::string::npos) << e1;
    // Two triangles using edge 1 -> 2 in the same direction.
    const Idx flip = {0, 1, 2, 1, 2, 3};
    const std::string e2 = error_of(flip, 4, EdgeOrientation::consistent);
    EXPECT_NE(e2.find("edge (1, 2) is used twice in the same direction (triangles 0 and 1)"), std::string::npos) << e2;
    EXPECT_EQ(error_of(flip, 4, EdgeOrientation::any), "");
    // Labels: the caller's vertex numbers and rows.
    const Idx vid = {10, 11, 12, 13}, rid = {70, 71};
    faultmesh::AdjacencyLabels l;
    l.vertex_ids = vid.data();
    l.row_ids = rid.data();
    l.edge_word = "layer edge";
    const std::string e3 = error_of(flip, 4, EdgeOrientation::consistent, l);
    EXPECT_NE(e3.find("layer edge (11, 12) is used twice in the same direction (triangles 70 and 71)"),
              std::string::npos) << e3;
}

TEST(TriangleAdjacency, BoundaryAndEmpty) {
    const Idx one = {0, 1, 2};
    EXPECT_EQ(faultmesh::halfedge_twins(one.data(), 1, 3, EdgeOrientation::consistent, "t"), (Idx{-1, -1, -1}));
    EXPECT_TRUE(faultmesh::halfedge_twins(nullptr, 0, 0, EdgeOrientation::consistent, "t").empty());
    const Idx two = {0, 1, 2, 2, 1, 3};
    EXPECT_EQ(faultmesh::halfedge_twins(two.data(), 2, 4, EdgeOrientation::consistent, "t"),
              (Idx{-1, 3, -1, 1, -1, -1}));
}
