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

#include "../src/stitch_steps.hpp"

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

// A vertical fault carried onto the study boundary: its footwall and
// hanging-wall cutoffs are two vertices at one XY there, (100, 35), their
// elevations 1 apart; the outline edge between them has length 0 in XY. It
// runs along the side (from the point to itself): classified as inside the
// area, it went into the gap polygon, which touched itself there (fuzz,
// test_derive_fuzz.py::test_vertical_fault_carried_onto_the_boundary_builds).
TEST(Stitch, VerticalFaultCarriedOntoTheStudyBoundaryStitches) {
    Mesh L = grid_tin();
    auto tr = [](double x) {
        std::vector<double> p;
        const double ys[] = {30, 35, 35, 45}, zs[] = {0, 0, -1, -1};
        for (int i = 0; i < 4; ++i) p.insert(p.end(), {x, ys[i], zs[i]});
        return p;
    };
    Mesh P = loft_patch({{75.0, 37.0, 0.0}, tr(85.0), tr(100.0)});
    LayerStitcher st(L.v.data(), L.v.size() / 3, L.t.data(), L.t.size() / 3, kSquare.data(), 4);
    auto rep = st.stitch(P.v.data(), P.v.size() / 3, P.t.data(), P.t.size() / 3, "F1");
    ASSERT_EQ(rep.gaps.size(), 1u);
    EXPECT_EQ(rep.gaps[0].n_holes, 0);
    StitchedMesh m = st.mesh();
    expect_disk(m);
    EXPECT_NEAR(twice_signed_area(m), 2.0 * 100.0 * 100.0, 1e-6);
}

// A patch piece that touches the study boundary at one vertex only (an end
// carried onto the boundary and then clipped: random_ground(704) as v2),
// then a later patch whose removed region swallows that piece's gap: the
// removed region meets itself at the touching vertex, the earlier piece in
// between; it is one region whose outline passes that vertex twice, not a
// failure ("the removed region meets itself ... an earlier fault patch is in
// the way" before).
TEST(Stitch, LaterPatchMergesTheGapAroundAPieceTouchingTheBoundaryAtAVertex) {
    for (double y_touch : {52.0, 50.0}) {  // on a boundary edge of the TIN, and at its vertex
        Mesh L = grid_tin();
        Mesh A;
        A.v = {0.0, y_touch, 1.0, 16.0, 44.0, 1.2, 17.0, 58.0, 1.1};
        A.t = {0, 1, 2};
        LayerStitcher st(L.v.data(), L.v.size() / 3, L.t.data(), L.t.size() / 3, kSquare.data(), 4);
        auto ra = st.stitch(A.v.data(), A.v.size() / 3, A.t.data(), A.t.size() / 3, "A");
        ASSERT_EQ(ra.gaps.size(), 1u);
        // B just east of A's gap: its removed region merges it.
        const Mesh B = loft_patch({{19.0, 40.0, 0.5, 34.0, 40.0, 0.6}, {19.0, 62.0, 0.5, 34.0, 62.0, 0.6}});
        faultmesh::StitchReport rb;
        ASSERT_NO_THROW(rb = st.stitch(B.v.data(), B.v.size() / 3, B.t.data(), B.t.size() / 3, "B"));
        EXPECT_EQ(rb.merged_gaps, (std::vector<std::int64_t>{ra.gaps[0].id}));
        StitchedMesh m = st.mesh();
        expect_disk(m);
        EXPECT_NEAR(twice_signed_area(m), 2.0 * 100.0 * 100.0, 1e-6);
        // Both patches are there whole.
        std::int64_t n_patch = 0;
        for (auto k : m.kinds) n_patch += k == static_cast<std::int8_t>(TriangleKind::patch);
        EXPECT_EQ(n_patch, static_cast<std::int64_t>(A.t.size() / 3 + B.t.size() / 3));
    }
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

TEST(Stitch, TouchingRegionBuiltOnceAnswersLikeTheFunction) {
    // The region is built once from a copy of the rings: changing the
    // caller's ring afterwards changes nothing; each query equals
    // triangles_touching_region; no rings touch nothing.
    std::vector<double> ring = {0, 0, 4, 0, 4, 4, 0, 4};
    const std::int64_t off[] = {0, 4};
    const double v[] = {4, 4, 6, 4, 6, 6,  5, 0, 7, 0, 6, 2,  1, 1, 2, 1, 1, 2,  -1, -1, 9, -1, -1, 9};
    const std::int64_t t[] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11};
    const faultmesh::TouchingRegion region(ring.data(), off, 1);
    const auto want = faultmesh::triangles_touching_region(v, 12, 2, t, 4, ring.data(), off, 1);
    std::fill(ring.begin(), ring.end(), 100.0);
    EXPECT_EQ(region.touching(v, 12, 2, t, 4), want);
    EXPECT_EQ(region.touching(v, 12, 2, t + 6, 2), (std::vector<std::int64_t>{0, 1}));
    const std::int64_t bad[] = {0, 1, 12};
    EXPECT_THROW(region.touching(v, 12, 2, bad, 1), std::invalid_argument);
    const faultmesh::TouchingRegion none(nullptr, off, 0);
    EXPECT_TRUE(none.touching(v, 12, 2, t, 4).empty());
}

// ---------------------------------------------------------------------------
// The steps of one stitch, each on its own (stitch_steps.hpp)
// ---------------------------------------------------------------------------
namespace {

namespace fd = faultmesh::detail;

struct Steps {
    Mesh L;
    LayerStitcher st;
    fd::StitcherState& s;
    explicit Steps(Mesh layer, faultmesh::StitchOptions opt = {})
        : L(std::move(layer)),
          st(L.v.data(), L.v.size() / 3, L.t.data(), L.t.size() / 3, kSquare.data(), 4, nullptr, "L", opt),
          s(fd::state_of(st)) {}
    std::unique_ptr<fd::StitchJob> job(const Mesh& P, const std::string& name = "P") {
        return std::make_unique<fd::StitchJob>(s, P.v.data(), P.v.size() / 3, P.t, name);
    }
    // A job keeps pointers into the patch's vertices: the patch must outlive it.
    std::unique_ptr<fd::StitchJob> job(Mesh&&, const std::string& = "P") = delete;
    std::unique_ptr<fd::StitchJob> run(Mesh&&, int, const std::string& = "P") = delete;
    // Runs the steps up to and including `last` (1 outline ... 6 link).
    std::unique_ptr<fd::StitchJob> run(const Mesh& P, int last, const std::string& name = "P") {
        auto j = job(P, name);
        if (last >= 1) fd::outline_patch(s, *j);
        if (last >= 2) fd::find_overlap(s, *j);
        if (last >= 3) fd::grow_removed_set(s, *j);
        if (last >= 4) fd::build_gap_polygons(s, *j);
        if (last >= 5) fd::clip_gap_polygons(s, *j);
        if (last >= 6) fd::link_new_triangles(s, *j);
        return j;
    }
    std::vector<std::int64_t> members(const fd::StitchJob& j) const {
        std::vector<std::int64_t> m = j.removed->members();
        std::sort(m.begin(), m.end());
        return m;
    }
};

Mesh boundary_patch() {
    auto tr = [](double x) {
        std::vector<double> p;
        const double ys[] = {30, 35, 38, 45}, zs[] = {0, 0, -1, -1};
        for (int i = 0; i < 4; ++i) p.insert(p.end(), {x, ys[i], zs[i]});
        return p;
    };
    return loft_patch({{75.0, 37.0, 0.0}, tr(85.0), tr(100.0)});
}

Mesh reversed(Mesh m) {
    for (std::size_t r = 0; r < m.t.size() / 3; ++r) std::swap(m.t[3 * r + 1], m.t[3 * r + 2]);
    return m;
}

double patch_area2(const fd::StitchJob& j) {
    double a = 0.0;
    for (std::size_t r = 0; r < j.npt; ++r)
        a += faultmesh::orient2d(j.P(j.ptri[3 * r]), j.P(j.ptri[3 * r + 1]), j.P(j.ptri[3 * r + 2]));
    return a;
}

// The rows form a disk (one clean boundary loop) in the layer's current triangles.
void expect_rows_disk(const fd::StitcherState& s, const std::vector<std::int64_t>& rows) {
    std::vector<std::int64_t> sub;
    for (std::int64_t r : rows) sub.insert(sub.end(), s.tri.begin() + 3 * r, s.tri.begin() + 3 * r + 3);
    auto c = faultmesh::boundary_contours(sub.data(), rows.size(), s.xyz.size() / 3);
    EXPECT_TRUE(c.clean());
    EXPECT_EQ(c.loops.size(), 1u);
}

}  // namespace

TEST(StitchSteps, OutlineOrientsThePatchAndFindsItsLoops) {
    Steps f(grid_tin());
    for (bool flip : {false, true}) {
        const Mesh P = flip ? reversed(reverse_patch()) : reverse_patch();
        auto j = f.run(P, 1);
        EXPECT_GT(patch_area2(*j), 0.0);
        EXPECT_EQ(j->report.patch_flipped, patch_area2(*f.job(P)) < 0.0);
        // One outline loop, away from the study boundary, and R is the patch's footprint.
        auto c = faultmesh::boundary_contours(j->ptri.data(), j->npt, j->npv);
        ASSERT_EQ(c.loops.size(), 1u);
        EXPECT_EQ(j->outline.size(), c.loops[0].size());
        for (const auto& e : j->outline) EXPECT_FALSE(e.study);
        // The patch spans x in [30, 70] between the traces at y = 40 and 60.
        const double inside[] = {46.0, 50.0}, i2[] = {46.5, 50.0}, i3[] = {46.0, 50.5};
        EXPECT_DOUBLE_EQ(j->region.distance(inside, 100.0), 16.0);
        EXPECT_TRUE(j->region.meets_open_triangle(inside, i2, i3));
        const double out[] = {10.0, 50.0}, o2[] = {10.5, 50.0}, o3[] = {10.0, 50.5};
        EXPECT_FALSE(j->region.meets_closed_triangle(out, o2, o3));
    }
}

TEST(StitchSteps, OutlineClassifiesEdgesOnTheStudyBoundary) {
    Steps f(grid_tin());
    const Mesh B = boundary_patch();
    auto j = f.run(B, 1);
    int on_side = 0;
    for (const auto& e : j->outline) {
        if (!e.study) continue;
        ++on_side;
        EXPECT_EQ(e.side, 1u);  // x = 100: the square's second side (CCW from (0, 0))
        EXPECT_EQ(j->P(e.a)[0], 100.0);
        EXPECT_EQ(e.sa, j->P(e.a)[1]);  // arc length along the side from (100, 0)
        EXPECT_EQ(e.sb, j->P(e.b)[1]);
    }
    EXPECT_EQ(on_side, 3);
    // Outside the study area: an error naming the vertex.
    Mesh far = reverse_patch();
    for (std::size_t i = 0; i < far.v.size(); i += 3) far.v[i] += 80.0;
    EXPECT_THROW(f.run(far, 1), GeometryError);
}

TEST(StitchSteps, OverlapIsTheClosedContactSet) {
    Mesh L = grid_tin();
    Steps f(L);
    const Mesh P = reverse_patch();
    auto j = f.run(P, 2);
    std::vector<double> ring;
    for (const auto& e : j->outline) ring.insert(ring.end(), {j->P(e.a)[0], j->P(e.a)[1]});
    const std::vector<std::int64_t> off = {0, static_cast<std::int64_t>(ring.size() / 2)};
    const auto want = faultmesh::triangles_touching_region(L.v.data(), L.v.size() / 3, 3, L.t.data(),
                                                           L.t.size() / 3, ring.data(), off.data(), 1);
    EXPECT_EQ(f.members(*j), want);
    EXPECT_GE(j->report.n_candidates, static_cast<std::int64_t>(want.size()));
    EXPECT_LT(j->report.n_candidates, static_cast<std::int64_t>(L.t.size() / 3));
    // An earlier patch touching R is an error of this step.
    f.st.stitch(P.v.data(), P.v.size() / 3, P.t.data(), P.t.size() / 3, "A");
    const Mesh B = reverse_patch(35.0, 45.0, 65.0);
    EXPECT_THROW(f.run(B, 2, "B"), GeometryError);
}

TEST(StitchSteps, GrowthMakesADiskAroundTheOutline) {
    for (double clearance : {0.0, 8.0}) {
        faultmesh::StitchOptions opt;
        opt.clearance = clearance;
        Steps f(grid_tin(), opt);
        const Mesh P = reverse_patch();
        auto seeds = f.members(*f.run(P, 2));
        auto j = f.run(P, 3);
        const auto& D = j->report.removed;
        EXPECT_TRUE(std::is_sorted(D.begin(), D.end()));
        EXPECT_TRUE(std::includes(D.begin(), D.end(), seeds.begin(), seeds.end()));
        EXPECT_GE(j->report.grow_rounds, 1);
        expect_rows_disk(f.s, D);
        // The kept boundary: every half-edge has D on its left, the kept row on its right.
        for (std::int64_t h : j->boundary) {
            EXPECT_TRUE(j->removed->contains(h / 3));
            const std::int64_t o = f.s.adj[static_cast<std::size_t>(h)];
            if (o >= 0) EXPECT_FALSE(j->removed->contains(o / 3));
        }
        if (clearance > 0.0) EXPECT_GT(D.size(), seeds.size());
    }
}

TEST(StitchSteps, GrowthSwallowsAnEarlierGapWholeAndKeepsItsPatch) {
    Steps f(grid_tin());
    const Mesh A = reverse_patch();
    const auto ra = f.st.stitch(A.v.data(), A.v.size() / 3, A.t.data(), A.t.size() / 3, "A");
    ASSERT_EQ(ra.gaps.size(), 1u);
    // A narrow patch just west of A: its removed region reaches A's gap.
    const double xs[] = {0, 4, 6, 3, 5, 10.5};
    auto tr = [&](double y) {
        std::vector<double> p;
        for (double x : xs) p.insert(p.end(), {18.0 + x, y, 0.0});
        return p;
    };
    const Mesh B = loft_patch({{23.0, 35.0, 0.3}, tr(42.0), tr(58.0), {23.0, 65.0, 0.3}});
    auto j = f.run(B, 3, "B");
    EXPECT_EQ(j->report.merged_gaps, (std::vector<std::int64_t>{ra.gaps[0].id}));
    for (std::int64_t r : ra.gaps[0].triangles) EXPECT_TRUE(j->removed->contains(r));
    for (std::size_t r = 0; r < A.t.size() / 3; ++r)
        EXPECT_FALSE(j->removed->contains(ra.patch_triangle_offset + static_cast<std::int64_t>(r)));
    // The merged gap has both patches as holes.
    fd::build_gap_polygons(f.s, *j);
    ASSERT_EQ(j->outers.size(), 1u);
    EXPECT_EQ(j->holes_of[j->outers[0]].size(), 2u);
}

TEST(StitchSteps, ContoursGiveOuterRingsWithTheirHoles) {
    {
        Steps f(grid_tin());
        const Mesh P = reverse_patch();
        auto j = f.run(P, 4);
        ASSERT_EQ(j->rings.size(), 2u);
        ASSERT_EQ(j->outers.size(), 1u);
        const std::size_t o = j->outers[0];
        ASSERT_EQ(j->holes_of[o].size(), 1u);
        EXPECT_GT(j->ring_area[o], 0.0);
        EXPECT_LT(j->ring_area[j->holes_of[o][0]], 0.0);
        // The rings are D's boundary and R's outline (reversed), nothing else.
        EXPECT_EQ(j->gap_edges.size(), j->boundary.size() + j->outline.size());
        for (const auto& e : j->gap_edges)
            EXPECT_EQ(e.tag >= 0, e.a >= j->n_layer_vertices);  // outline edges are tagged with the patch
    }
    {
        Steps f(grid_tin());
        const Mesh B = boundary_patch();
        auto j = f.run(B, 4);
        ASSERT_EQ(j->outers.size(), 1u);
        EXPECT_TRUE(j->holes_of[j->outers[0]].empty());
        EXPECT_FALSE(j->study_keys.empty());  // closed along the study-area boundary
    }
}

TEST(StitchSteps, ClippingGivesNPlus2HMinus2CounterClockwiseTriangles) {
    Steps f(grid_tin());
    const Mesh P = reverse_patch();
    auto j = f.run(P, 5);
    ASSERT_EQ(j->report.gaps.size(), 1u);
    const auto& g = j->report.gaps[0];
    EXPECT_EQ(static_cast<std::int64_t>(g.triangles.size()), g.n_vertices + 2 * g.n_holes - 2);
    EXPECT_EQ(g.patches, (std::vector<std::int64_t>{0}));
    EXPECT_EQ(j->new_kind.size(), P.t.size() / 3 + g.triangles.size());
    for (std::size_t r = 0; r < j->new_kind.size(); ++r) {
        const bool patch = r < P.t.size() / 3;
        EXPECT_EQ(j->new_kind[r], static_cast<std::int8_t>(patch ? TriangleKind::patch : TriangleKind::gap));
        if (!patch)
            EXPECT_GT(faultmesh::orient2d(j->X(j->new_tri[3 * r]), j->X(j->new_tri[3 * r + 1]),
                                          j->X(j->new_tri[3 * r + 2])), 0.0);
    }
}

TEST(StitchSteps, LinkPairsEveryNewEdgeAndCommitIsTheOnlyChange) {
    for (bool at_boundary : {false, true}) {
        Steps f(grid_tin());
        const Mesh P = at_boundary ? boundary_patch() : reverse_patch();
        const std::size_t rows = f.s.n_tri(), live = f.s.n_live, nv = f.s.xyz.size() / 3;
        auto j = f.run(P, 6);
        // Nothing in the layer changed so far.
        EXPECT_EQ(f.s.n_tri(), rows);
        EXPECT_EQ(f.s.n_live, live);
        EXPECT_EQ(f.s.xyz.size() / 3, nv);
        EXPECT_TRUE(f.s.patch_names.empty());
        const std::int64_t base = 3 * j->row0;
        std::size_t open = 0;
        for (std::size_t h = 0; h < j->new_adj.size(); ++h) {
            const std::int64_t o = j->new_adj[h];
            if (o < 0) {
                ++open;  // on the study-area boundary
                continue;
            }
            if (o >= base) EXPECT_EQ(j->new_adj[static_cast<std::size_t>(o - base)], base + static_cast<std::int64_t>(h));
        }
        EXPECT_EQ(open > 0, at_boundary);
        EXPECT_EQ(j->relink.size(), j->dside.size());
        const auto rep = fd::commit(f.s, *j);
        EXPECT_EQ(f.s.n_live, live - rep.removed.size() + j->new_kind.size());
        EXPECT_EQ(f.s.patch_names, (std::vector<std::string>{"P"}));
        // The relinked kept half-edges point at the new rows and back.
        for (const auto& rl : j->relink) {
            EXPECT_EQ(f.s.adj[static_cast<std::size_t>(rl.first)], rl.second);
            EXPECT_EQ(f.s.adj[static_cast<std::size_t>(rl.second)], rl.first);
        }
        expect_disk(f.st.mesh());
    }
}

TEST(Stitch, FoldCarriedOntoTheBoundaryIsExemptFromTheOutlineCoverTest) {
    // A reverse fault running out of the area folds along the side y = 0:
    // its end trace's points lie on the side up to rounding (here 1e-13 m
    // off it, within the study area's tolerance), so the folded outline
    // edges there run through the triangles above by a hair. Along a side
    // that is no sheet reaching past the outline (the stitcher allows the
    // fold there), so with the study area they are exempt.
    std::vector<double> end = reverse_trace(0.0);
    for (std::size_t i = 0; i < end.size() / 3; ++i) end[3 * i + 1] = (i % 2 ? 1e-13 : -1e-13);
    Mesh P = loft_patch({end, reverse_trace(20.0), reverse_trace(40.0), {46.0, 50.0, 0.3}});
    const faultmesh::StudyArea area(kSquare.data(), 4);
    for (std::size_t i = 0; i < end.size() / 3; ++i) ASSERT_TRUE(area.on_boundary(&end[3 * i]));
    const auto without = faultmesh::triangles_not_covered_once(P.v.data(), P.v.size() / 3, 3, P.t.data(),
                                                               P.t.size() / 3);
    EXPECT_FALSE(without.empty());
    EXPECT_TRUE(faultmesh::triangles_not_covered_once(P.v.data(), P.v.size() / 3, 3, P.t.data(), P.t.size() / 3,
                                                      &area)
                    .empty());
}

TEST(Stitch, OutlineCrossingsNameTheTrianglesOfBothEdges) {
    // A fan round (50, 50) whose rim turns on past a full turn: the last rim
    // edge crosses the first spoke. triangles_at_outline_crossings gives
    // the triangles of the two edges, and the stitcher, which runs the same
    // test, refuses the patch naming them.
    const double c = 50.0, pi = std::acos(-1.0);
    std::vector<double> V = {c, c, 0.0};
    const double ang[] = {0.0, 90.0, 180.0, 270.0, 405.0}, rad[] = {20.0, 20.0, 20.0, 20.0, 10.0};
    for (int i = 0; i < 5; ++i) {
        V.push_back(c + rad[i] * std::cos(ang[i] * pi / 180.0));
        V.push_back(c + rad[i] * std::sin(ang[i] * pi / 180.0));
        V.push_back(0.5);
    }
    const std::vector<std::int64_t> T = {0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 5};
    EXPECT_EQ(faultmesh::triangles_at_outline_crossings(V.data(), 6, 3, T.data(), 4),
              (std::vector<std::int64_t>{0, 3}));
    Mesh L = grid_tin();
    LayerStitcher st(L.v.data(), L.v.size() / 3, L.t.data(), L.t.size() / 3, kSquare.data(), 4, nullptr, "L");
    try {
        st.stitch(V.data(), 6, T.data(), 4, "fan");
        FAIL() << "no error";
    } catch (const GeometryError& e) {
        EXPECT_NE(std::string(e.what()).find("outline is not simple"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("edges (0, 1) and (4, 5)"), std::string::npos) << e.what();
    }
    EXPECT_EQ(st.n_live_triangles(), L.t.size() / 3);  // nothing changed
    // A fold carried onto the side y = 0 overlaps itself there: its outline
    // edges along the side meet, and with the study area they are exempt.
    std::vector<double> end = reverse_trace(0.0);
    for (std::size_t i = 0; i < end.size() / 3; ++i) end[3 * i + 1] = 0.0;
    Mesh P = loft_patch({end, reverse_trace(20.0), reverse_trace(40.0), {46.0, 50.0, 0.3}});
    const faultmesh::StudyArea area(kSquare.data(), 4);
    EXPECT_FALSE(
        faultmesh::triangles_at_outline_crossings(P.v.data(), P.v.size() / 3, 3, P.t.data(), P.t.size() / 3).empty());
    EXPECT_TRUE(faultmesh::triangles_at_outline_crossings(P.v.data(), P.v.size() / 3, 3, P.t.data(), P.t.size() / 3,
                                                          &area)
                    .empty());
    // Bad input is named.
    const std::vector<std::int64_t> bad = {0, 1, 9};
    EXPECT_THROW(faultmesh::triangles_at_outline_crossings(V.data(), 6, 3, bad.data(), 1), std::invalid_argument);
}

TEST(Stitch, FoldedPatchCoversItsImageOnce) {
    // A valid fold (footwall +, strip -, hanging wall +) covers its image once.
    Mesh P = reverse_patch();
    EXPECT_TRUE(faultmesh::triangles_not_covered_once(P.v.data(), P.v.size() / 3, 3, P.t.data(),
                                                      P.t.size() / 3)
                    .empty());
    // A square with a flap folded back into itself (sweep seed 24): the
    // outline A B E G C D is simple, but the clockwise triangle E G C lies
    // in the notch at G, outside that outline (cover 0 there: + B E C, - E G C),
    // and so does the part of B E C over it: the outline edges E G and G C
    // run through B E C, whose centroid (cover 1) does not show it.
    const double o = 40.0;
    const std::vector<double> V = {o, o, 0, o + 10, o, 0, o + 10, o + 10, 0, o, o + 10, 0,
                                   o + 15, o + 2, 0, o + 12, o + 4, 0};
    enum { A, B, C, D, E, G };
    const std::vector<std::int64_t> T = {A, B, C, A, C, D, B, E, C, E, G, C};
    ASSERT_LT(faultmesh::orient2d(&V[3 * E], &V[3 * G], &V[3 * C]), 0.0);
    EXPECT_EQ(faultmesh::triangles_not_covered_once(V.data(), 6, 3, T.data(), 4),
              (std::vector<std::int64_t>{2, 3}));
    // At the centroids alone, only the flap.
    EXPECT_EQ(faultmesh::triangles_not_covered_once(V.data(), 6, 3, T.data(), 4, nullptr, false),
              (std::vector<std::int64_t>{3}));
    // The stitcher says so instead of laying its gap over the flap.
    Mesh L = grid_tin();
    LayerStitcher st(L.v.data(), L.v.size() / 3, L.t.data(), L.t.size() / 3, kSquare.data(), 4, nullptr, "L");
    try {
        st.stitch(V.data(), 6, T.data(), 4, "flap");
        FAIL() << "no error";
    } catch (const GeometryError& e) {
        EXPECT_NE(std::string(e.what()).find("does not cover its XY image once"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("patch triangle 2"), std::string::npos) << e.what();
    }
    EXPECT_EQ(st.n_live_triangles(), L.t.size() / 3);  // nothing changed
}
