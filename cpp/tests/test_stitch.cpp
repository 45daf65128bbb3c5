// GoogleTest: LayerStitcher / stitch() / triangles_touching_region (stitch.hpp).
#include <faultmesh/boundary.hpp>
#include <faultmesh/errors.hpp>
#include <faultmesh/loft.hpp>
#include <faultmesh/predicates.hpp>
#include <faultmesh/stitch.hpp>
#include <faultmesh/tin.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <set>
#include <stdexcept>
#include <vector>

namespace {

using faultmesh::GeometryError;
using faultmesh::LayerStitcher;
using faultmesh::StitchedMesh;
using faultmesh::TriangleKind;

const std::vector<double> kSquare = {0, 0, 100, 0, 100, 100, 0, 100};

struct Mesh {
    std::vector<double> v;         // x, y, z
    std::vector<std::int64_t> t;   // 3 per triangle
};

// A TIN of a jittered grid over the 100 x 100 square (boundary exact).
Mesh grid_tin(int n = 21) {
    std::vector<double> pts;
    std::uint64_t s = 12345;
    auto rnd = [&] {
        s = s * 6364136223846793005ULL + 1442695040888963407ULL;
        return static_cast<double>(s >> 11) / 9007199254740992.0;
    };
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            double x = 100.0 * i / (n - 1), y = 100.0 * j / (n - 1);
            if (i > 0 && i < n - 1 && j > 0 && j < n - 1) {
                x += 1.5 * (rnd() - 0.5);
                y += 1.5 * (rnd() - 0.5);
            }
            pts.insert(pts.end(), {x, y, 0.01 * x + 0.02 * y});
        }
    faultmesh::Tin tin(pts.data(), pts.size() / 3);
    return {tin.vertices(), tin.triangles()};
}

// Section polyline across a reverse fault at ordinate y: the strip runs back.
std::vector<double> reverse_trace(double y, double x0 = 30.0) {
    const double xs[] = {0, 15, 20, 12, 17, 40};
    const double zs[] = {0, 0, 0, -1, 1, 1};
    std::vector<double> p;
    for (int i = 0; i < 6; ++i) p.insert(p.end(), {x0 + xs[i], y, zs[i] + 0.02 * y});
    return p;
}

// Loft consecutive polylines (a single point = a tip) into one patch.
Mesh loft_patch(const std::vector<std::vector<double>>& seq) {
    Mesh m;
    std::size_t off = 0;
    for (std::size_t i = 0; i + 1 < seq.size(); ++i) {
        const std::size_t k = seq[i].size() / 3, l = seq[i + 1].size() / 3;
        auto tri = faultmesh::loft(seq[i].data(), k, seq[i + 1].data(), l, 3);
        // loft indexes a then b, and b follows a in the concatenation.
        for (std::int64_t x : tri) m.t.push_back(static_cast<std::int64_t>(off) + x);
        (void)l;
        off += k;
    }
    for (const auto& p : seq) m.v.insert(m.v.end(), p.begin(), p.end());
    return m;
}

Mesh reverse_patch(double x0 = 30.0, double y0 = 40.0, double y1 = 60.0) {
    return loft_patch({{x0 + 16, y0 - 10, 0.3}, reverse_trace(y0, x0), reverse_trace(y1, x0),
                       {x0 + 16, y1 + 10, 0.3}});
}

double twice_signed_area(const StitchedMesh& m) {
    double s = 0.0;
    for (std::size_t r = 0; r < m.triangles.size() / 3; ++r) {
        const double* a = &m.vertices[3 * m.triangles[3 * r]];
        const double* b = &m.vertices[3 * m.triangles[3 * r + 1]];
        const double* c = &m.vertices[3 * m.triangles[3 * r + 2]];
        s += (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
    }
    return s;
}

void expect_disk(const StitchedMesh& m) {
    auto c = faultmesh::boundary_contours(m.triangles.data(), m.triangles.size() / 3, m.vertices.size() / 3);
    EXPECT_TRUE(c.clean());
    EXPECT_EQ(c.loops.size(), 1u);
    // Euler characteristic V - E + F = 1.
    std::set<std::pair<std::int64_t, std::int64_t>> edges;
    std::set<std::int64_t> used;
    for (std::size_t r = 0; r < m.triangles.size() / 3; ++r)
        for (int k = 0; k < 3; ++k) {
            const std::int64_t a = m.triangles[3 * r + k], b = m.triangles[3 * r + (k + 1) % 3];
            edges.insert({std::min(a, b), std::max(a, b)});
            used.insert(a);
        }
    EXPECT_EQ(used.size(), m.vertices.size() / 3);  // compacted: every vertex used
    const long chi = static_cast<long>(used.size()) - static_cast<long>(edges.size()) +
                     static_cast<long>(m.triangles.size() / 3);
    EXPECT_EQ(chi, 1);
    // No duplicate vertices.
    std::set<std::array<double, 3>> xyz;
    for (std::size_t i = 0; i < m.vertices.size() / 3; ++i)
        xyz.insert({m.vertices[3 * i], m.vertices[3 * i + 1], m.vertices[3 * i + 2]});
    EXPECT_EQ(xyz.size(), m.vertices.size() / 3);
}

}  // namespace

TEST(Stitch, ReversePatchFoldsAndKeepsTheInvariants) {
    Mesh L = grid_tin();
    Mesh P = reverse_patch();
    LayerStitcher st(L.v.data(), L.v.size() / 3, L.t.data(), L.t.size() / 3, kSquare.data(), 4, nullptr, "L");
    auto rep = st.stitch(P.v.data(), P.v.size() / 3, P.t.data(), P.t.size() / 3, "F1");
    ASSERT_EQ(rep.gaps.size(), 1u);
    const auto& g = rep.gaps[0];
    EXPECT_EQ(g.n_holes, 1);
    EXPECT_EQ(static_cast<std::int64_t>(g.triangles.size()), g.n_vertices + 2 * g.n_holes - 2);
    StitchedMesh m = st.mesh();
    expect_disk(m);
    // Signed XY areas add up to the study area although the strip is clockwise.
    EXPECT_NEAR(twice_signed_area(m), 2.0 * 100.0 * 100.0, 1e-6);
    int cw = 0;
    for (std::size_t r = 0; r < m.triangles.size() / 3; ++r)
        if (faultmesh::orient2d(&m.vertices[3 * m.triangles[3 * r]], &m.vertices[3 * m.triangles[3 * r + 1]],
                                &m.vertices[3 * m.triangles[3 * r + 2]]) < 0)
            ++cw;
    EXPECT_GT(cw, 0);
    // Gap triangles are counter-clockwise in XY.
    for (std::size_t r = 0; r < m.kinds.size(); ++r)
        if (m.kinds[r] == static_cast<std::int8_t>(TriangleKind::gap))
            EXPECT_GT(faultmesh::orient2d(&m.vertices[3 * m.triangles[3 * r]], &m.vertices[3 * m.triangles[3 * r + 1]],
                                          &m.vertices[3 * m.triangles[3 * r + 2]]), 0.0);
}

TEST(Stitch, FarTrianglesAreKept) {
    Mesh L = grid_tin(31);
    Mesh P = reverse_patch(10.0, 20.0, 30.0);
    LayerStitcher st(L.v.data(), L.v.size() / 3, L.t.data(), L.t.size() / 3, kSquare.data(), 4);
    auto rep = st.stitch(P.v.data(), P.v.size() / 3, P.t.data(), P.t.size() / 3);
    StitchedMesh m = st.mesh();
    std::set<std::int64_t> removed(rep.removed.begin(), rep.removed.end());
    for (std::size_t r = 0; r < L.t.size() / 3; ++r) {
        const bool gone = removed.count(static_cast<std::int64_t>(r)) > 0;
        EXPECT_EQ(m.triangle_map[r] < 0, gone);
    }
    // Removed triangles lie near the patch.
    for (std::int64_t r : rep.removed) {
        const double* a = &L.v[3 * L.t[3 * r]];
        EXPECT_LT(a[0], 70.0);
        EXPECT_LT(a[1], 50.0);
    }
}

TEST(Stitch, OverlapIsAnErrorAndChangesNothing) {
    Mesh L = grid_tin();
    Mesh P = reverse_patch();
    LayerStitcher st(L.v.data(), L.v.size() / 3, L.t.data(), L.t.size() / 3, kSquare.data(), 4, nullptr, "coal8");
    st.stitch(P.v.data(), P.v.size() / 3, P.t.data(), P.t.size() / 3, "2F4");
    const std::size_t live = st.n_live_triangles(), rows = st.n_triangles();
    Mesh Q = reverse_patch(35.0, 45.0, 65.0);
    try {
        st.stitch(Q.v.data(), Q.v.size() / 3, Q.t.data(), Q.t.size() / 3, "2F1");
        FAIL() << "expected GeometryError";
    } catch (const GeometryError& e) {
        const std::string msg = e.what();
        EXPECT_NE(msg.find("coal8"), std::string::npos);
        EXPECT_NE(msg.find("'2F1'"), std::string::npos);
        EXPECT_NE(msg.find("'2F4'"), std::string::npos);
    }
    EXPECT_EQ(st.n_live_triangles(), live);
    EXPECT_EQ(st.n_triangles(), rows);
    expect_disk(st.mesh());
}

TEST(Stitch, PatchOnTheStudyBoundaryGivesAPolygonWithoutHole) {
    Mesh L = grid_tin();
    auto tr = [](double x) {
        std::vector<double> p;
        const double ys[] = {30, 35, 38, 45}, zs[] = {0, 0, -1, -1};
        for (int i = 0; i < 4; ++i) p.insert(p.end(), {x, ys[i], zs[i]});
        return p;
    };
    Mesh P = loft_patch({{75.0, 37.0, 0.0}, tr(85.0), tr(100.0)});
    LayerStitcher st(L.v.data(), L.v.size() / 3, L.t.data(), L.t.size() / 3, kSquare.data(), 4);
    auto rep = st.stitch(P.v.data(), P.v.size() / 3, P.t.data(), P.t.size() / 3, "F22");
    ASSERT_EQ(rep.gaps.size(), 1u);
    EXPECT_EQ(rep.gaps[0].n_holes, 0);
    EXPECT_EQ(static_cast<std::int64_t>(rep.gaps[0].triangles.size()), rep.gaps[0].n_vertices - 2);
    StitchedMesh m = st.mesh();
    expect_disk(m);
    EXPECT_NEAR(twice_signed_area(m), 2.0 * 100.0 * 100.0, 1e-6);
}

TEST(Stitch, OneShotMatchesTheStitcher) {
    Mesh L = grid_tin();
    Mesh P = reverse_patch();
    auto r = faultmesh::stitch(L.v.data(), L.v.size() / 3, L.t.data(), L.t.size() / 3, P.v.data(),
                               P.v.size() / 3, P.t.data(), P.t.size() / 3, kSquare.data(), 4);
    LayerStitcher st(L.v.data(), L.v.size() / 3, L.t.data(), L.t.size() / 3, kSquare.data(), 4);
    st.stitch(P.v.data(), P.v.size() / 3, P.t.data(), P.t.size() / 3);
    EXPECT_EQ(st.mesh().triangles, r.mesh.triangles);
    EXPECT_EQ(r.gap_rows.size(), r.report.gaps[0].triangles.size());
}

TEST(Stitch, BadInput) {
    Mesh L = grid_tin();
    std::vector<std::int64_t> bad = L.t;
    bad[7] = 100000;
    EXPECT_THROW(LayerStitcher(L.v.data(), L.v.size() / 3, bad.data(), bad.size() / 3, kSquare.data(), 4),
                 std::invalid_argument);
    std::vector<double> nanv = L.v;
    nanv[5] = std::nan("");
    EXPECT_THROW(LayerStitcher(nanv.data(), nanv.size() / 3, L.t.data(), L.t.size() / 3, kSquare.data(), 4),
                 std::invalid_argument);
    // A clockwise mesh is reported when a stitch relies on its triangles.
    std::vector<std::int64_t> cw = L.t;
    for (std::size_t r = 0; r < cw.size() / 3; ++r) std::swap(cw[3 * r + 1], cw[3 * r + 2]);
    LayerStitcher st(L.v.data(), L.v.size() / 3, cw.data(), cw.size() / 3, kSquare.data(), 4);
    Mesh P = reverse_patch();
    EXPECT_THROW(st.stitch(P.v.data(), P.v.size() / 3, P.t.data(), P.t.size() / 3), GeometryError);
    // Patch outside the study area / indices out of range.
    LayerStitcher ok(L.v.data(), L.v.size() / 3, L.t.data(), L.t.size() / 3, kSquare.data(), 4);
    std::vector<double> far = P.v;
    for (std::size_t i = 0; i < far.size(); i += 3) far[i] += 80.0;
    EXPECT_THROW(ok.stitch(far.data(), far.size() / 3, P.t.data(), P.t.size() / 3), GeometryError);
    std::vector<std::int64_t> pt = P.t;
    pt[0] = -1;
    EXPECT_THROW(ok.stitch(P.v.data(), P.v.size() / 3, pt.data(), pt.size() / 3), std::invalid_argument);
}

TEST(Stitch, TrianglesTouchingRegion) {
    const double ring[] = {0, 0, 4, 0, 4, 4, 0, 4};
    const std::int64_t off[] = {0, 4};
    const double v[] = {4, 4, 6, 4, 6, 6,  5, 0, 7, 0, 6, 2,  1, 1, 2, 1, 1, 2,  -1, -1, 9, -1, -1, 9};
    const std::int64_t t[] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11};
    auto got = faultmesh::triangles_touching_region(v, 12, 2, t, 4, ring, off, 1);
    EXPECT_EQ(got, (std::vector<std::int64_t>{0, 2, 3}));
}
