// GoogleTest: a layer's data honoured inside a fault patch (patch_data.hpp).
#include <faultmesh/patch_data.hpp>
#include <faultmesh/predicates.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <utility>
#include <vector>

namespace fm = faultmesh;

namespace {

double orient_xy(const std::vector<double>& V, const std::int64_t* t) {
    return fm::orient2d(&V[3 * t[0]], &V[3 * t[1]], &V[3 * t[2]]);
}

// Every input triangle's XY area is covered exactly by the output, each
// output triangle keeps the sign of the one it came from, every undirected
// edge is used at most twice (a conforming surface).
void expect_conforming(const std::vector<double>& V0, const std::vector<std::int64_t>& T0,
                       const fm::PatchDataResult& r) {
    double in_pos = 0, in_neg = 0, out_pos = 0, out_neg = 0;
    for (std::size_t t = 0; t < T0.size(); t += 3) {
        const double o = orient_xy(V0, &T0[t]);
        (o > 0 ? in_pos : in_neg) += o;
    }
    std::map<std::pair<std::int64_t, std::int64_t>, int> used;
    for (std::size_t t = 0; t < r.triangles.size(); t += 3) {
        const double o = orient_xy(r.vertices, &r.triangles[t]);
        EXPECT_NE(o, 0.0) << "triangle " << t / 3;
        (o > 0 ? out_pos : out_neg) += o;
        for (int k = 0; k < 3; ++k) {
            std::int64_t a = r.triangles[t + k], b = r.triangles[t + (k + 1) % 3];
            if (a > b) std::swap(a, b);
            const int n_used = ++used[std::make_pair(a, b)];
            EXPECT_LE(n_used, 2) << "edge " << a << "-" << b;
        }
    }
    EXPECT_NEAR(in_pos, out_pos, 1e-9 * (1 + std::fabs(in_pos)));
    EXPECT_NEAR(in_neg, out_neg, 1e-9 * (1 + std::fabs(in_neg)));
}

// z at q's XY of the output triangle of the given orientation that holds
// it (the sheet's), NaN if none does.
double sheet_z(const fm::PatchDataResult& r, bool ccw, const double* q) {
    for (std::size_t t = 0; t < r.triangles.size(); t += 3) {
        const std::int64_t* s = &r.triangles[t];
        const double o = orient_xy(r.vertices, s);
        if (o == 0.0 || (o > 0.0) != ccw) continue;
        double w[3], z = 0.0;
        bool inside = true;
        for (int k = 0; k < 3; ++k) {
            w[k] = fm::orient2d(&r.vertices[3 * s[(k + 1) % 3]], &r.vertices[3 * s[(k + 2) % 3]], q) / o;
            inside = inside && w[k] >= 0.0;
            z += w[k] * r.vertices[3 * s[k] + 2];
        }
        if (inside) return z;
    }
    return std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

TEST(PatchData, DataInsideBecomeVerticesAtTheirElevation) {
    // A flat square patch at z = 0, two triangles.
    const std::vector<double> V{0, 0, 0, 10, 0, 0, 10, 10, 0, 0, 10, 0};
    const std::vector<std::int64_t> T{0, 1, 2, 0, 2, 3};
    // Inside triangle 0, inside triangle 1, on the shared edge, on a vertex,
    // outside, a rounding inside an edge, near the first datum.
    const std::vector<double> P{7, 2, 1.5, 2, 7, -0.5, 5, 5, 3, 10, 10, 4, 12, 5, 0, 5, 1e-10, 1,
                                7.01, 2, 0};
    const auto r = fm::insert_patch_data(V.data(), 4, T.data(), 2, P.data(), 7,
                                         std::numeric_limits<double>::infinity());
    // The data inside first, then those on edges (edge 0-1, then 0-2).
    ASSERT_EQ(r.placed, (std::vector<std::int64_t>{0, 1, 5, 2}));
    EXPECT_EQ(r.triangle, (std::vector<std::int64_t>{0, 1, 0, -1, -1, 0, -1}));
    ASSERT_EQ(r.vertices.size(), 3u * 8);
    EXPECT_EQ(r.vertices[3 * 4 + 2], 1.5);
    EXPECT_EQ(r.vertices[3 * 5 + 2], -0.5);
    // The datum a rounding inside the bottom edge lies on it, with its z
    // (up to that rounding times the slope); the one on the diagonal where
    // it was.
    EXPECT_EQ(r.vertices[3 * 6 + 0], 5.0);
    EXPECT_EQ(r.vertices[3 * 6 + 1], 0.0);
    EXPECT_NEAR(r.vertices[3 * 6 + 2], 1.0, 1e-9);
    EXPECT_EQ(r.vertices[3 * 7 + 0], 5.0);
    EXPECT_EQ(r.vertices[3 * 7 + 1], 5.0);
    EXPECT_EQ(r.vertices[3 * 7 + 2], 3.0);
    // Each datum inside adds two triangles, one on an edge between two
    // triangles two, one on the patch's outline one.
    EXPECT_EQ(r.triangles.size(), 3u * 9);
    expect_conforming(V, T, r);
}

// Data on and near an edge are placed on it: picks on a seismic line lie on
// the edges of a patch whose sections a derivation put on that line. Every
// triangle with the edge is split, on both sheets where the edge is the
// patch's fold; data too near an end or each other are left out.
TEST(PatchData, DataOnAnEdgeSplitItInEveryTriangleThatHasIt) {
    // A fold along x = 10: one sheet counter-clockwise at z = 0, the other
    // folded back over it clockwise, down to z = -20 at (0, 10).
    const std::vector<double> V{0, 0, 0, 10, 0, 0, 10, 10, 0, 0, 10, -20};
    const std::vector<std::int64_t> T{0, 1, 2, 1, 3, 2};
    // On the fold edge (x = 10): three data, the third 0.05 m after the
    // second (within a hundredth of the edge's length); one a millimetre
    // inside the edge; one 0.05 m from its end; and one near the corner
    // (10, 10) of the first triangle, within a hundredth of two edges.
    const std::vector<double> P{10, 3, -1, 10, 6, -2, 10, 6.05, -3, 9.999, 8, -4, 10, 9.95, -5, 9.99, 9.98, -6};
    const auto r = fm::insert_patch_data(V.data(), 4, T.data(), 2, P.data(), 6,
                                         std::numeric_limits<double>::infinity());
    EXPECT_EQ(r.placed, (std::vector<std::int64_t>{0, 1, 3}));
    ASSERT_EQ(r.vertices.size(), 3u * 7);
    EXPECT_EQ(r.vertices[3 * 6 + 0], 10.0);  // projected onto the edge
    // Its z puts its sheet (the nearer in z: the folded one, clockwise)
    // through it at its own XY, 1 mm from the edge.
    EXPECT_NEAR(r.vertices[3 * 6 + 2], -4.0, 0.01);
    EXPECT_NEAR(sheet_z(r, false, &P[9]), -4.0, 1e-9);
    // Each of the two triangles with the edge becomes four.
    EXPECT_EQ(r.triangles.size(), 3u * 8);
    expect_conforming(V, T, r);
    // No triangle has the unsplit edge 1-2 any more.
    for (std::size_t t = 0; t < r.triangles.size(); t += 3)
        for (int k = 0; k < 3; ++k) {
            const std::int64_t a = r.triangles[t + k], b = r.triangles[t + (k + 1) % 3];
            EXPECT_FALSE((a == 1 && b == 2) || (a == 2 && b == 1)) << "triangle " << t / 3;
        }
}

// A triangle with data on two of its edges: its fan's triangles take the
// second split.
TEST(PatchData, ATriangleWithDataOnTwoEdgesIsSplitAlongBoth) {
    const std::vector<double> V{0, 0, 0, 10, 0, 0, 0, 10, 0};
    const std::vector<std::int64_t> T{0, 1, 2};
    const std::vector<double> P{5, 0, 1, 0, 5, 2, 3, 3, 3};
    const auto r = fm::insert_patch_data(V.data(), 3, T.data(), 1, P.data(), 3,
                                         std::numeric_limits<double>::infinity());
    EXPECT_EQ(r.placed.size(), 3u);
    EXPECT_EQ(r.triangles.size(), 3u * 5);  // +2 inside, +1 and +1 on the edges
    expect_conforming(V, T, r);
}

// A datum moved onto an edge of a steep ramp (a patch between a fault's
// cutoffs) is still honoured at its own XY: the vertex takes the z that puts
// the ramp through it there, not the datum's (which would miss it by the
// slope times the move, stress ground 55: 5.6 m). Two data on one edge share
// a fan triangle; the solve takes both.
TEST(PatchData, ADatumMovedOntoAnEdgeOfARampIsHonouredAtItsOwnXY) {
    // z falls 4 m per metre north; the edge y = 0 is 100 m long, the
    // triangle's height over it 100 m.
    const std::vector<double> V{0, 0, 0, 100, 0, 0, 0, 100, -400};
    const std::vector<std::int64_t> T{0, 1, 2};
    // 0.5 m and 0.8 m north of the edge (within a hundredth of its height).
    const std::vector<double> P{50, 0.5, -1, 53, 0.8, -2};
    const auto r = fm::insert_patch_data(V.data(), 3, T.data(), 1, P.data(), 2,
                                         std::numeric_limits<double>::infinity());
    ASSERT_EQ(r.placed, (std::vector<std::int64_t>{0, 1}));
    EXPECT_EQ(r.vertices[3 * 3 + 1], 0.0);  // on the edge
    EXPECT_EQ(r.vertices[3 * 4 + 1], 0.0);
    for (int i = 0; i < 2; ++i) EXPECT_NEAR(sheet_z(r, true, &P[3 * i]), P[3 * i + 2], 1e-9) << "datum " << i;
    // The vertices moved by about the slope times the move (2 and 3.2 m).
    EXPECT_NEAR(r.vertices[3 * 3 + 2], -1 + 2.0, 0.5);
    EXPECT_NEAR(r.vertices[3 * 4 + 2], -2 + 3.2, 0.5);
    expect_conforming(V, T, r);
}

TEST(PatchData, ADatumMovedBesideTheLineToAnotherDatumIsHonouredAtItsOwnXY) {
    // Regression (stress ground 207, tests/test_derive_blocks.py): a datum
    // 0.5 m from the edge x = 0 (the triangle's height over it 100 m) goes
    // onto the edge; a second datum of the triangle, inside it, lies so
    // that the line from the corner (0, 300) through it passes 0.05 m from
    // the first datum's XY. The fan through the edge's new vertex put that
    // line between the vertex and the XY (its weight there 0.09), the
    // vertex kept the datum's z and the patch missed the datum by 8.0 m;
    // the edge opposite the vertex is flipped (flip_towards_moved_data) and
    // the datum honoured at its own XY.
    const std::vector<double> V{0, 0, 0, 100, 0, 0, 0, 300, 0};
    const std::vector<std::int64_t> T{0, 1, 2};
    const std::vector<double> P{2.2, 100, 5, 0.5, 250, 10};
    const auto r = fm::insert_patch_data(V.data(), 3, T.data(), 1, P.data(), 2,
                                         std::numeric_limits<double>::infinity());
    ASSERT_EQ(r.placed.size(), 2u);
    for (int i = 0; i < 2; ++i) EXPECT_NEAR(sheet_z(r, true, &P[3 * i]), P[3 * i + 2], 1e-9) << "datum " << i;
    expect_conforming(V, T, r);
}

TEST(PatchData, ADatumWhoseXYLiesInNoTriangleAtItsVertexIsReachedByAWalkOfFlips) {
    // Regression (tests/data/patches/moved_data_walk.npz, case 3: a random
    // patch of one 100 m triangle at UTM coordinates, 16 data within
    // +-15 m): datum 7 lies 0.96 m from the edge y = 7800000 and goes onto
    // it; the data placed inside the triangle before it left its XY in a
    // triangle without its vertex, and the patch missed it by 1.1 m. The
    // edges between are flipped one after another (flip_towards_moved_data)
    // until its XY lies in a triangle at its vertex that gives it weight.
    const std::vector<double> V{7800000.0, 7800000.0, 0.0, 7800100.0, 7800000.0, 10.0,
                                7800000.0, 7800100.0, 0.0};
    const std::vector<std::int64_t> T{0, 1, 2};
    const std::vector<double> P{
        7800094.034699231, 7799997.58935476, -2.907140295094335,
        7800061.979143877, 7799996.70798523, -6.0417862680602905,
        7800083.619380488, 7800085.2175355675, 5.613260637954529,
        7800047.293032369, 7800001.530177416, -14.728325056981056,
        7800010.529800806, 7800036.861099368, 0.471804009350997,
        7799994.592818077, 7800041.9148837775, 0.914788516320364,
        7800005.689642285, 7800072.245557871, 1.6024659426868624,
        7800082.571110011, 7800000.962341263, 4.3158849103844545,
        7800091.578482755, 7800011.424295635, 13.351611638331008,
        7800007.56560962, 7800041.832197904, -0.9195872184205953,
        7800038.395419625, 7800058.861818689, -11.129277445452159,
        7800055.6652774215, 7800083.199702892, 10.802352068079742,
        7800007.918783607, 7800087.34236542, 7.961471512827892,
        7800059.945977012, 7800004.180451296, 0.5798460910081342,
        7800034.507969169, 7800044.841368891, 8.167790684230063,
        7800013.956486386, 7800077.691510028, 11.973728373847926};
    const auto r = fm::insert_patch_data(V.data(), 3, T.data(), 1, P.data(), P.size() / 3,
                                         std::numeric_limits<double>::infinity());
    std::size_t k = 0;
    while (k < r.placed.size() && r.placed[k] != 7) ++k;
    ASSERT_LT(k, r.placed.size());
    EXPECT_EQ(r.vertices[3 * (3 + k) + 1], 7800000.0);  // on the edge
    EXPECT_NEAR(sheet_z(r, true, &P[3 * 7]), P[3 * 7 + 2], 1e-6);
    expect_conforming(V, T, r);
}

TEST(PatchData, ADatumNearACornerGivesTheCornerItsZ) {
    // Two triangles, z = 0. Datum 0 lies 0.5 m and 0.4 m from the two edges
    // at corner 0 (under a hundredth of the heights, 100 m): a new vertex
    // would make slivers, so corner 0 takes it -- its z puts the patch
    // through the datum at the datum's XY. Datum 1, as near the same
    // corner, is not taken (the first in row order is); datum 2 lies at
    // corner 3's XY and gives it its z. No new vertex, no datum "placed".
    const std::vector<double> V{0, 0, 0, 100, 0, 0, 0, 100, 0, 100, 100, 0};
    const std::vector<std::int64_t> T{0, 1, 2, 1, 3, 2};
    const std::vector<double> P{0.5, 0.4, 7, 0.3, 0.6, -5, 100, 100, 3};
    const auto r = fm::insert_patch_data(V.data(), 4, T.data(), 2, P.data(), 3,
                                         std::numeric_limits<double>::infinity());
    EXPECT_TRUE(r.placed.empty());
    EXPECT_EQ(r.vertices.size(), V.size());
    EXPECT_EQ(r.triangle, (std::vector<std::int64_t>{-1, -1, -1}));
    EXPECT_NEAR(sheet_z(r, true, &P[0]), 7.0, 1e-9);
    EXPECT_NEAR(r.vertices[2], 7.0 / (1.0 - 0.005 - 0.004), 1e-9);
    EXPECT_EQ(r.vertices[3 * 3 + 2], 3.0);
    for (int k : {1, 2}) EXPECT_EQ(r.vertices[3 * k + 2], 0.0);  // the other corners stay
    expect_conforming(V, T, r);
}

TEST(PatchData, ADatumNearOneEdgeByItsEndGivesThatCornerItsZ) {
    // A sliver whose far corner A lies beyond C along edge BC. The datum lies
    // within a hundredth of the triangle's height of edge BC (weight 0.0069
    // of A) but not of edge CA (0.036 of B), and its projection onto BC falls
    // past C: no place on the edge away from its ends, so corner C takes it
    // (stress ground 113's L5 pick, 3.3 m from such a corner of an 830 m
    // long patch triangle, was left out and missed by 6.5 m).
    const std::vector<double> V{0, 0, 0, 100, 0, 0, 1000, 20, 0};  // B, C, A
    const std::vector<std::int64_t> T{0, 1, 2};
    const std::vector<double> P{0.0069 * 1000 + 0.957 * 100, 0.0069 * 20, 5};
    const auto r = fm::insert_patch_data(V.data(), 3, T.data(), 1, P.data(), 1,
                                         std::numeric_limits<double>::infinity());
    EXPECT_TRUE(r.placed.empty());
    EXPECT_EQ(r.vertices.size(), V.size());
    EXPECT_EQ(r.triangle, (std::vector<std::int64_t>{-1}));
    EXPECT_NEAR(sheet_z(r, true, &P[0]), 5.0, 1e-9);
    EXPECT_NE(r.vertices[3 * 1 + 2], 0.0);                                      // C took it
    for (int k : {0, 2}) EXPECT_EQ(r.vertices[3 * k + 2], 0.0);  // the other corners stay
    expect_conforming(V, T, r);
}

TEST(PatchData, FoldedPatchTakesTheNearestSheet) {
    // Two sheets over the same square, 20 m apart, the lower one clockwise in
    // XY (a fold seen from above), as a reverse fault repeats a layer.
    const std::vector<double> V{0, 0, 0, 10, 0, 0, 0, 10, 0, 0, 0, -20, 10, 0, -20, 0, 10, -20};
    const std::vector<std::int64_t> T{0, 1, 2, 3, 5, 4};
    const std::vector<double> P{2, 2, -1, 3, 3, -18, 2.5, 2.5, -9};
    const auto r = fm::insert_patch_data(V.data(), 6, T.data(), 2, P.data(), 3, 5.0);
    EXPECT_EQ(r.triangle, (std::vector<std::int64_t>{0, 1, -1}));  // the third is 9-11 m from both
    expect_conforming(V, T, r);
    for (std::size_t t = 0; t < r.triangles.size(); t += 3) {
        // Every triangle stays within its own sheet.
        const double z0 = r.vertices[3 * r.triangles[t] + 2];
        for (int k = 1; k < 3; ++k) EXPECT_LT(std::fabs(r.vertices[3 * r.triangles[t + k] + 2] - z0), 5.0);
    }
}

TEST(PatchData, ManyDataInOneTriangleAreADelaunayFill) {
    const std::vector<double> V{0, 0, 0, 100, 0, 0, 0, 100, 0};
    const std::vector<std::int64_t> T{0, 1, 2};
    std::vector<double> P;
    for (int i = 1; i < 10; ++i)
        for (int j = 1; i + j < 10; ++j) P.insert(P.end(), {10.0 * i + 0.5, 10.0 * j + 0.25, 0.1 * i * j});
    const std::size_t n = P.size() / 3;
    // A repeated datum (same XY, other z) is left out: one surface, one z.
    P.insert(P.end(), {10.5, 10.25, 7.0});
    const auto r = fm::insert_patch_data(V.data(), 3, T.data(), 1, P.data(), n + 1,
                                         std::numeric_limits<double>::infinity());
    EXPECT_EQ(r.placed.size(), n);
    EXPECT_EQ(r.triangle[n], -1);
    EXPECT_EQ(r.triangles.size(), 3 * (1 + 2 * n));
    expect_conforming(V, T, r);
}

TEST(PatchData, VerticalTrianglesHoldNoDataAndUtmCoordinatesAreExact) {
    // A strip triangle standing vertically (zero XY area) next to a flat one,
    // at UTM-sized coordinates.
    const double x0 = 512345.678, y0 = 7654321.123;
    const std::vector<double> V{x0, y0, 0, x0 + 10, y0, 0, x0 + 10, y0, -5, x0, y0 + 10, 0};
    const std::vector<std::int64_t> T{0, 1, 2, 0, 1, 3};
    const std::vector<double> P{x0 + 3, y0, -2, x0 + 3, y0 + 3, 0.25};
    const auto r = fm::insert_patch_data(V.data(), 4, T.data(), 2, P.data(), 2, 1.0);
    EXPECT_EQ(r.triangle, (std::vector<std::int64_t>{-1, 1}));
    ASSERT_EQ(r.placed.size(), 1u);
    EXPECT_EQ(r.vertices[3 * 4], x0 + 3);
    EXPECT_EQ(r.vertices[3 * 4 + 2], 0.25);
}

TEST(PatchData, BadInputIsNamed) {
    const std::vector<double> V{0, 0, 0, 1, 0, 0, 0, 1, 0};
    const std::vector<std::int64_t> T{0, 1, 3};
    const std::vector<double> P{0.2, 0.2, 0};
    try {
        fm::insert_patch_data(V.data(), 3, T.data(), 1, P.data(), 1, 1.0);
        FAIL() << "no throw";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("triangles row 0"), std::string::npos) << e.what();
    }
    const std::vector<std::int64_t> T2{0, 1, 2};
    EXPECT_THROW(fm::insert_patch_data(V.data(), 3, T2.data(), 1, P.data(), 1, std::nan("")),
                 std::invalid_argument);
    EXPECT_THROW(fm::insert_patch_data(V.data(), 3, T2.data(), 1, P.data(), 1, -1.0), std::invalid_argument);
    const std::vector<double> Pbad{std::nan(""), 0.2, 0};
    EXPECT_THROW(fm::insert_patch_data(V.data(), 3, T2.data(), 1, Pbad.data(), 1, 1.0), std::invalid_argument);
}

// A datum within a micrometre outside the patch's outline lies on it (as
// build.ON_OUTLINE has it): which side of the outline a pick on it falls on
// is the outline's last bits. Farther out it is not the patch's.
TEST(PatchData, ADatumAMicrometreOutsideTheOutlineLiesOnIt) {
    const std::vector<double> V{500000, 7000000, 0, 500010, 7000000, 0, 500000, 7000010, 0};
    const std::vector<std::int64_t> T{0, 1, 2};
    const std::vector<double> P{500005, 7000000 - 4e-7, 1.0, 500005, 7000000 - 1e-5, 2.0};
    const auto r = fm::insert_patch_data(V.data(), 3, T.data(), 1, P.data(), 2,
                                         std::numeric_limits<double>::infinity());
    EXPECT_EQ(r.placed, (std::vector<std::int64_t>{0}));
    EXPECT_EQ(r.triangle, (std::vector<std::int64_t>{0, -1}));
    ASSERT_EQ(r.vertices.size(), 3u * 4);
    EXPECT_EQ(r.vertices[3 * 3 + 1], 7000000.0);  // on the edge
    EXPECT_EQ(r.vertices[3 * 3 + 2], 1.0);
    expect_conforming(V, T, r);
}
