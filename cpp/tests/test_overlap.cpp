// Overlap detection: exact answers on a grid TIN, growth into a disk.
#include <faultmesh/aabb_tree.hpp>
#include <faultmesh/boundary.hpp>
#include <faultmesh/errors.hpp>
#include <faultmesh/overlap.hpp>
#include <faultmesh/segments.hpp>
#include <faultmesh/stitch.hpp>
#include <faultmesh/triangle_adjacency.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "../src/overlap_growth.hpp"

using faultmesh::OverlapOptions;
using Idx = std::vector<std::int64_t>;

namespace {

// (N+1)^2 grid vertices with z = x*y, two CCW triangles per unit cell:
// triangle 2*(j*N+i) is the lower-right one, 2*(j*N+i)+1 the upper-left.
struct Grid {
    int N;
    std::vector<double> v;  // (x, y, z)
    Idx t;
    explicit Grid(int n) : N(n) {
        for (int j = 0; j <= N; ++j)
            for (int i = 0; i <= N; ++i) v.insert(v.end(), {double(i), double(j), double(i * j)});
        for (int j = 0; j < N; ++j)
            for (int i = 0; i < N; ++i) {
                t.insert(t.end(), {id(i, j), id(i + 1, j), id(i + 1, j + 1)});
                t.insert(t.end(), {id(i, j), id(i + 1, j + 1), id(i, j + 1)});
            }
    }
    std::int64_t id(int i, int j) const { return j * (N + 1) + i; }
    std::size_t nv() const { return v.size() / 3; }
    std::size_t nt() const { return t.size() / 3; }
    Idx cells(int i0, int i1, int j0, int j1) const {  // both triangles of cells in [i0,i1) x [j0,j1)
        Idx r;
        for (int j = j0; j < j1; ++j)
            for (int i = i0; i < i1; ++i) {
                r.push_back(2 * (j * N + i));
                r.push_back(2 * (j * N + i) + 1);
            }
        std::sort(r.begin(), r.end());
        return r;
    }
    Idx overlap(const std::vector<std::vector<double>>& rings, const OverlapOptions& o = {}) const {
        std::vector<double> xy;
        Idx off{0};
        for (auto& r : rings) {
            xy.insert(xy.end(), r.begin(), r.end());
            off.push_back(static_cast<std::int64_t>(xy.size() / 2));
        }
        Idx a = faultmesh::overlapping_triangles(v.data(), nv(), 3, t.data(), nt(), xy.data(), off.data(),
                                                 rings.size(), o);
        // The tree-based entry point must agree.
        faultmesh::AabbTree tree = faultmesh::AabbTree::from_triangles(v.data(), nv(), 3, t.data(), nt());
        Idx b = faultmesh::overlapping_triangles(tree, v.data(), nv(), 3, t.data(), nt(), xy.data(),
                                                 off.data(), rings.size(), o);
        EXPECT_EQ(a, b);
        return a;
    }
};

std::vector<double> rect(double x0, double y0, double x1, double y1, bool ccw = true) {
    if (ccw) return {x0, y0, x1, y0, x1, y1, x0, y1};
    return {x0, y0, x0, y1, x1, y1, x1, y0};
}

// The selected triangles form a disk: one component, one boundary loop, no
// pinch or open chain, Euler characteristic 1.
void expect_disk(const Grid& g, const Idx& sel) {
    Idx sub;
    for (auto s : sel) sub.insert(sub.end(), g.t.begin() + 3 * s, g.t.begin() + 3 * s + 3);
    const auto c = faultmesh::boundary_contours(sub.data(), sel.size(), g.nv());
    EXPECT_TRUE(c.clean());
    EXPECT_EQ(c.loops.size(), 1u);
    std::set<std::int64_t> vs(sub.begin(), sub.end());
    std::set<std::pair<std::int64_t, std::int64_t>> es;
    for (std::size_t i = 0; i < sub.size(); i += 3)
        for (int e = 0; e < 3; ++e)
            es.insert(std::minmax(sub[i + e], sub[i + (e + 1) % 3]));
    EXPECT_EQ(long(vs.size()) - long(es.size()) + long(sel.size()), 1);
}

}  // namespace

TEST(Overlap, AlignedSquareTouchingDoesNotCount) {
    Grid g(10);
    EXPECT_EQ(g.overlap({rect(2, 3, 5, 6)}), g.cells(2, 5, 3, 6));
    EXPECT_EQ(g.overlap({rect(2, 3, 5, 6, false)}), g.cells(2, 5, 3, 6));  // orientation irrelevant
    // Repeated closing point and consecutive duplicates are ignored.
    EXPECT_EQ(g.overlap({{2, 3, 5, 3, 5, 3, 5, 6, 2, 6, 2, 3}}), g.cells(2, 5, 3, 6));
}

TEST(Overlap, RegionEqualToOneMeshTriangle) {
    Grid g(6);
    // Lower-right triangle of cell (2, 1): (2,1) (3,1) (3,2).
    EXPECT_EQ(g.overlap({{2, 1, 3, 1, 3, 2}}), (Idx{2 * (1 * 6 + 2)}));
    // Its vertices in the other order (clockwise) and starting elsewhere.
    EXPECT_EQ(g.overlap({{3, 2, 3, 1, 2, 1}}), (Idx{2 * (1 * 6 + 2)}));
}

TEST(Overlap, HolesSeveralOutersAndSharedSides) {
    Grid g(10);
    // A 3x3 block with the centre cell as a hole.
    Idx expect = g.cells(2, 5, 2, 5);
    Idx centre = g.cells(3, 4, 3, 4);
    Idx diff;
    std::set_difference(expect.begin(), expect.end(), centre.begin(), centre.end(), std::back_inserter(diff));
    EXPECT_EQ(g.overlap({rect(2, 2, 5, 5), rect(3, 3, 4, 4, false)}), diff);
    // Hole given with the same orientation as the outer ring: even-odd rule.
    EXPECT_EQ(g.overlap({rect(2, 2, 5, 5), rect(3, 3, 4, 4)}), diff);
    // Two outers sharing a side: the shared side cancels, the union counts.
    EXPECT_EQ(g.overlap({rect(2, 2, 4, 4), rect(4, 2, 6, 4)}), g.cells(2, 6, 2, 4));
    // Two outers sharing only part of a side (collinear overlap).
    Idx a = g.cells(2, 4, 2, 5), b = g.cells(4, 6, 3, 4), uni;
    std::set_union(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(uni));
    EXPECT_EQ(g.overlap({rect(2, 2, 4, 5), rect(4, 3, 6, 4)}), uni);
    // The same ring twice: parity even everywhere, empty interior.
    EXPECT_TRUE(g.overlap({rect(2, 2, 5, 5), rect(2, 2, 5, 5)}).empty());
}

TEST(Overlap, DiagonalEdgesAndVertexContacts) {
    Grid g(6);
    // Region = the diagonal half of the 2x2 block [1,3]^2 below the diagonal
    // y = x: the lower-right triangles of the diagonal cells plus the whole
    // cell (2, 1); upper-left triangles of (1,1), (2,2) only touch along the diagonal.
    const Idx got = g.overlap({{1, 1, 3, 1, 3, 3}});
    const Idx want = {2 * (1 * 6 + 1), 2 * (1 * 6 + 2), 2 * (1 * 6 + 2) + 1, 2 * (2 * 6 + 2)};
    EXPECT_EQ(got, want);
    // A thin triangle inside one mesh triangle, touching its vertex (2,1).
    const Idx tip = g.overlap({{2, 1, 2.9, 1.2, 2.9, 1.5}});
    EXPECT_EQ(tip, (Idx{2 * (1 * 6 + 2)}));
    // A region with a vertex exactly on a mesh vertex, wedge pointing into
    // the upper-left triangle of cell (2, 1) only.
    EXPECT_EQ(g.overlap({{3, 2, 2.2, 1.9, 2.5, 1.95}}), (Idx{2 * (1 * 6 + 2) + 1}));
}

TEST(Overlap, DegenerateTrianglesNeverOverlap) {
    const double v[] = {0, 0, 1, 1, 2, 2, 0, 2};
    const Idx t = {0, 1, 2, 0, 2, 3};
    const double ring[] = {-1, -1, 3, -1, 3, 3, -1, 3};
    const Idx off = {0, 4};
    EXPECT_EQ(faultmesh::overlapping_triangles(v, 4, 2, t.data(), 2, ring, off.data(), 1), (Idx{1}));
}

TEST(Overlap, AgreesWithBruteForcePredicate) {
    Grid g(12);
    std::mt19937_64 rng(21);
    std::uniform_int_distribution<int> u(0, 24);  // half-integer coordinates: many exact contacts
    for (int rep = 0; rep < 30; ++rep) {
        std::vector<double> ring;
        const int k = 3 + static_cast<int>(rng() % 5);
        // A star-shaped polygon around a centre (simple).
        const double cx = 6, cy = 6;
        std::vector<std::pair<double, std::pair<double, double>>> pts;
        for (int i = 0; i < k; ++i) {
            const double x = u(rng) * 0.5, y = u(rng) * 0.5;
            if (x == cx && y == cy) continue;
            pts.push_back({std::atan2(y - cy, x - cx), {x, y}});
        }
        std::sort(pts.begin(), pts.end());
        for (auto& p : pts) ring.insert(ring.end(), {p.second.first, p.second.second});
        if (ring.size() < 6) continue;
        const Idx got = g.overlap({ring});
        const Idx off = {0, static_cast<std::int64_t>(ring.size() / 2)};
        Idx brute;
        for (std::size_t t = 0; t < g.nt(); ++t) {
            const double* a = &g.v[3 * g.t[3 * t]];
            const double* b = &g.v[3 * g.t[3 * t + 1]];
            const double* c = &g.v[3 * g.t[3 * t + 2]];
            if (faultmesh::triangle_overlaps_region(a, b, c, ring.data(), off.data(), 1))
                brute.push_back(static_cast<std::int64_t>(t));
        }
        EXPECT_EQ(got, brute) << "rep " << rep;
    }
}

TEST(Overlap, GrowToDiskStrictlyContainsTheRegion) {
    Grid g(12);
    OverlapOptions o;
    o.grow_to_disk = true;
    // Aligned square: its sides lie on mesh edges -> must grow past them.
    const Idx s = g.overlap({rect(4, 4, 7, 8)}, o);
    expect_disk(g, s);
    EXPECT_GT(s.size(), g.cells(4, 7, 4, 8).size());
    // No boundary edge of the grown set meets the closed square.
    Idx sub;
    for (auto t : s) sub.insert(sub.end(), g.t.begin() + 3 * t, g.t.begin() + 3 * t + 3);
    const Idx be = faultmesh::boundary_edges(sub.data(), s.size(), g.nv());
    for (std::size_t e = 0; e < be.size(); e += 2) {
        const double* p = &g.v[3 * be[e]];
        const double* q = &g.v[3 * be[e + 1]];
        EXPECT_FALSE(faultmesh::triangle_meets_box(p, q, q, {4, 4, 7, 8}));
    }
    // Two separate squares are joined into one disk; an annulus is filled.
    expect_disk(g, g.overlap({rect(3, 3, 4, 4), rect(8, 8, 9, 9)}, o));
    const Idx ann = g.overlap({rect(3, 3, 9, 9), rect(4, 4, 8, 8)}, o);
    expect_disk(g, ann);
    const Idx hole = g.cells(4, 8, 4, 8);
    EXPECT_TRUE(std::includes(ann.begin(), ann.end(), hole.begin(), hole.end()));
    // A region strictly inside one triangle: that triangle is already a disk.
    EXPECT_EQ(g.overlap({{2.3, 1.1, 2.9, 1.2, 2.9, 1.5}}, o), (Idx{2 * (1 * 12 + 2)}));
}

TEST(Overlap, MeshBoundaryNeedsTheOption) {
    Grid g(10);
    OverlapOptions o;
    o.grow_to_disk = true;
    // A fault strip crossing the study-area boundary on the left.
    const std::vector<double> r = rect(-1, 4, 3, 6);
    try {
        g.overlap({r}, o);
        ADD_FAILURE() << "expected GeometryError";
    } catch (const faultmesh::GeometryError& e) {
        EXPECT_NE(std::string(e.what()).find("allow_mesh_boundary"), std::string::npos);
    }
    o.allow_mesh_boundary = true;
    const Idx s = g.overlap({r}, o);
    expect_disk(g, s);
    // The kept triangles are one piece, without pinch or open chain.
    std::vector<char> in(g.nt(), 0);
    for (auto t : s) in[t] = 1;
    Idx kept;
    for (std::size_t t = 0; t < g.nt(); ++t)
        if (!in[t]) kept.insert(kept.end(), g.t.begin() + 3 * t, g.t.begin() + 3 * t + 3);
    const auto c = faultmesh::boundary_contours(kept.data(), kept.size() / 3, g.nv());
    EXPECT_TRUE(c.clean());
    EXPECT_EQ(c.loops.size(), 1u);
}

TEST(Overlap, BadInput) {
    Grid g(3);
    const double ring[] = {0, 0, 1, 0, 1, 1};
    const Idx off = {0, 3};
    Idx bad = g.t;
    bad[4] = 99;
    EXPECT_THROW(faultmesh::overlapping_triangles(g.v.data(), g.nv(), 3, bad.data(), g.nt(), ring, off.data(), 1),
                 std::invalid_argument);
    const Idx off_bad = {0, -1};
    EXPECT_THROW(faultmesh::overlapping_triangles(g.v.data(), g.nv(), 3, g.t.data(), g.nt(), ring,
                                                  off_bad.data(), 1),
                 std::invalid_argument);
    // Non-manifold mesh with grow_to_disk.
    const double v[] = {0, 0, 1, 0, 0, 1, 1, 1, 0, -1};
    const Idx t = {0, 1, 2, 1, 0, 4, 0, 1, 3};
    OverlapOptions o;
    o.grow_to_disk = true;
    EXPECT_THROW(faultmesh::overlapping_triangles(v, 5, 2, t.data(), 3, ring, off.data(), 1, o),
                 faultmesh::GeometryError);
}

// ---------------------------------------------------------------------------
// One region, two predicates (overlap_growth.hpp: Region)
// ---------------------------------------------------------------------------
namespace {

faultmesh::detail::Region region_of(const std::vector<std::vector<double>>& rings) {
    static std::vector<double> xy;  // kept alive: the Region copies what it needs
    Idx off{0};
    xy.clear();
    for (auto& r : rings) {
        xy.insert(xy.end(), r.begin(), r.end());
        off.push_back(static_cast<std::int64_t>(xy.size() / 2));
    }
    return faultmesh::detail::Region(xy.data(), off.data(), rings.size());
}

}  // namespace

TEST(OverlapRegion, ClosedContactCountsTouchingAndDrawnPieces) {
    // A square with a slit (spike) out of its left side: the spike is traced
    // there and back, so it cancels from the boundary but stays drawn.
    const auto R = region_of({{0, 0, 4, 0, 4, 4, 0, 4, 0, 2, -3, 2, 0, 2}});
    const double a[] = {-2, 1.5}, b[] = {-1, 1.5}, c[] = {-1.5, 2.5};  // across the spike
    EXPECT_TRUE(R.meets_closed_triangle(a, b, c));
    EXPECT_FALSE(R.meets_open_triangle(a, b, c));
    const double p[] = {-1.5, 2.2};
    EXPECT_NEAR(R.distance(p, 10.0), 0.2, 1e-12);
    // Touching the square at its corner only: contact, no interior overlap.
    const double d[] = {4, 4}, e[] = {6, 4}, f[] = {5, 6};
    EXPECT_TRUE(R.meets_closed_triangle(d, e, f));
    EXPECT_FALSE(R.meets_open_triangle(d, e, f));
    // Inside: both; far away: neither.
    const double g[] = {1, 1}, h[] = {2, 1}, i[] = {1, 2};
    EXPECT_TRUE(R.meets_closed_triangle(g, h, i));
    EXPECT_TRUE(R.meets_open_triangle(g, h, i));
    const double j[] = {10, 10}, k[] = {11, 10}, l[] = {10, 11};
    EXPECT_FALSE(R.meets_closed_triangle(j, k, l));
    EXPECT_FALSE(R.meets_open_triangle(j, k, l));
    // A triangle containing the whole region (no contact with its edges).
    const double m[] = {-10, -10}, n[] = {20, -10}, o[] = {-10, 20};
    EXPECT_TRUE(R.meets_closed_triangle(m, n, o));
    EXPECT_TRUE(R.meets_closed_triangle(m, o, n));  // closed contact: any orientation
    // A degenerate triangle is its edges.
    const double q0[] = {-1, 1}, q1[] = {1, 1}, q2[] = {3, 1};
    EXPECT_TRUE(R.meets_closed_triangle(q0, q1, q2));
}

TEST(OverlapRegion, OnePointRingIsDrawnButBoundsNothing) {
    const auto R = region_of({{10, 10}});
    EXPECT_TRUE(R.empty());
    EXPECT_FALSE(R.nothing_drawn());
    const double a[] = {9, 9}, b[] = {12, 9}, c[] = {9, 12};
    EXPECT_TRUE(R.meets_closed_triangle(a, b, c));
    EXPECT_FALSE(R.meets_open_triangle(a, b, c));
    const double d[] = {11, 11}, e[] = {12, 11}, f[] = {11, 12};
    EXPECT_FALSE(R.meets_closed_triangle(d, e, f));
}

TEST(OverlapRegion, ClosedContactMatchesABruteForceReference) {
    // Closed triangle meets closed region iff it meets a ring edge or a
    // vertex of it lies inside (exact on these half-integer coordinates).
    std::mt19937_64 rng(5);
    std::uniform_int_distribution<int> u(0, 16);
    const std::vector<std::vector<double>> rings = {{1, 1, 6, 1, 6, 6, 1, 6}, {2, 2, 3, 4, 5, 2}};
    const auto R = region_of(rings);
    auto inside = [&](const double* p) {  // even-odd over both rings, p off every edge
        bool in = false;
        for (const auto& r : rings)
            for (std::size_t i = 0; i < r.size() / 2; ++i) {
                const double* a = &r[2 * i];
                const double* b = &r[(2 * i + 2) % r.size()];
                if ((a[1] > p[1]) != (b[1] > p[1]) &&
                    p[0] < a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1]))
                    in = !in;
            }
        return in;
    };
    for (int it = 0; it < 4000; ++it) {
        double t[6];
        for (double& x : t) x = 0.5 * u(rng);
        bool contact = false;
        for (const auto& r : rings)
            for (std::size_t i = 0; i < r.size() / 2; ++i)
                contact = contact || faultmesh::segment_meets_closed_triangle(&r[2 * i], &r[(2 * i + 2) % r.size()],
                                                                             t, t + 2, t + 4);
        const bool want = contact || inside(t);
        EXPECT_EQ(R.meets_closed_triangle(t, t + 2, t + 4), want) << it;
    }
}

TEST(OverlapRegion, PredicateOptionOfTheOverlapQuery) {
    Grid g(10);
    OverlapOptions closed;
    closed.predicate = faultmesh::OverlapPredicate::closed_contact;
    // The aligned square [2,5]x[3,6]: the closed test adds the ring of cells
    // around it, less the two corner triangles that miss its corners.
    const Idx got = g.overlap({rect(2, 3, 5, 6)}, closed);
    Idx want = g.cells(1, 6, 2, 7);
    want.erase(std::find(want.begin(), want.end(), 2 * (2 * 10 + 5)));      // lower-right of cell (5, 2)
    want.erase(std::find(want.begin(), want.end(), 2 * (6 * 10 + 1) + 1));  // upper-left of cell (1, 6)
    EXPECT_EQ(got, want);
    // It is triangles_touching_region, as the stitcher uses it.
    const std::vector<double> r = rect(2, 3, 5, 6);
    const Idx off = {0, 4};
    EXPECT_EQ(got, faultmesh::triangles_touching_region(g.v.data(), g.nv(), 3, g.t.data(), g.nt(), r.data(),
                                                        off.data(), 1));
    // Grown with the paper's rules it is already a disk strictly containing R.
    closed.grow_to_disk = true;
    EXPECT_EQ(g.overlap({rect(2, 3, 5, 6)}, closed), got);
}

// ---------------------------------------------------------------------------
// One grower, rules as options (overlap_growth.hpp: Grower)
// ---------------------------------------------------------------------------
namespace {

using faultmesh::detail::GrowthHooks;
using faultmesh::detail::GrowthMesh;
using faultmesh::detail::GrowthRules;
using faultmesh::detail::Grower;
using faultmesh::detail::RemovedSet;

struct Growth {
    Grid g;
    Idx twins;
    std::vector<std::uint32_t> marks;
    faultmesh::detail::Region none;  // rules that need no region
    explicit Growth(int n) : g(n) {
        twins = faultmesh::halfedge_twins(g.t.data(), g.nt(), g.nv(), faultmesh::EdgeOrientation::consistent, "test");
        marks.assign(g.nt(), 0);
    }
    GrowthMesh mesh() const { return {g.v.data(), 3, g.nv(), g.t.data(), twins.data(), g.nt()}; }
    // The stitcher's rules.
    static GrowthRules stitcher(double clearance = 0.0) {
        GrowthRules r;
        r.pinch = faultmesh::detail::PinchRule::pull_star;
        r.holes = faultmesh::detail::HoleRule::fill_inner_loops;
        r.allow_mesh_boundary = true;
        r.clearance = clearance;
        r.max_rounds = 100;
        return r;
    }
    Idx sorted(const RemovedSet& S) const {
        Idx m = S.members();
        std::sort(m.begin(), m.end());
        return m;
    }
    std::int64_t lower(int i, int j) const { return 2 * (j * g.N + i); }  // lower-right triangle of cell (i, j)
    std::int64_t upper(int i, int j) const { return 2 * (j * g.N + i) + 1; }
};

struct FrozenSet : GrowthHooks {
    std::set<std::int64_t> frozen_rows;
    std::set<std::int64_t> verified;
    Idx group_rows;
    void verify(std::int64_t t) override { verified.insert(t); }
    bool frozen(std::int64_t t) const override { return frozen_rows.count(t) > 0; }
    std::int64_t group_of(std::int64_t t) const override {
        return std::find(group_rows.begin(), group_rows.end(), t) != group_rows.end() ? 7 : -1;
    }
    const Idx& group(std::int64_t) const override { return group_rows; }
};

}  // namespace

TEST(OverlapGrower, PinchVertexPullsInItsStar) {
    Growth f(10);
    RemovedSet S(f.marks, 1);
    // Two triangles that share only the vertex (4, 4): D meets itself there.
    S.add(f.lower(3, 3));
    S.add(f.upper(4, 4));
    Grower grow(f.mesh(), S, f.none, Growth::stitcher(), "test");
    ASSERT_EQ(grow.boundary().pinches.size(), 1u);
    const int rounds = grow.run();
    EXPECT_EQ(rounds, 2);  // one round pulls the star, one finds nothing to do
    expect_disk(f.g, f.sorted(S));
    // Every triangle at (4, 4) joined (its star: 6 triangles in this grid).
    const std::int64_t v = f.g.id(4, 4);
    for (std::size_t t = 0; t < f.g.nt(); ++t)
        if (f.g.t[3 * t] == v || f.g.t[3 * t + 1] == v || f.g.t[3 * t + 2] == v)
            EXPECT_TRUE(S.contains(static_cast<std::int64_t>(t))) << t;
    EXPECT_TRUE(grow.boundary().pinches.empty());
}

TEST(OverlapGrower, FrozenTrianglesStayOutAndAPinchTheyBlockIsAnError) {
    Growth f(10);
    FrozenSet hooks;
    const std::int64_t v = f.g.id(4, 4);
    for (std::size_t t = 0; t < f.g.nt(); ++t)
        if (f.g.t[3 * t] == v || f.g.t[3 * t + 1] == v || f.g.t[3 * t + 2] == v)
            hooks.frozen_rows.insert(static_cast<std::int64_t>(t));
    RemovedSet S(f.marks, 1, &hooks);
    hooks.frozen_rows.erase(f.lower(3, 3));
    hooks.frozen_rows.erase(f.upper(4, 4));
    S.add(f.lower(3, 3));
    S.add(f.upper(4, 4));
    Grower grow(f.mesh(), S, f.none, Growth::stitcher(), "test");
    try {
        grow.run();
        FAIL() << "expected GeometryError";
    } catch (const faultmesh::GeometryError& e) {
        EXPECT_NE(std::string(e.what()).find("test: the removed region meets itself at vertex " + std::to_string(v)),
                  std::string::npos) << e.what();
    }
    // Every triangle the walk looked at was verified first.
    for (std::int64_t t : hooks.frozen_rows) EXPECT_TRUE(hooks.verified.count(t)) << t;
}

TEST(OverlapGrower, InnerLoopsAreFilledExceptFrozenTriangles) {
    for (bool freeze : {false, true}) {
        Growth f(12);
        FrozenSet hooks;
        const Idx hole = f.g.cells(5, 7, 5, 7);
        if (freeze) hooks.frozen_rows.insert(hole.begin(), hole.end());
        RemovedSet S(f.marks, 1, &hooks);
        const Idx block = f.g.cells(4, 8, 4, 8);
        for (std::int64_t t : block)
            if (!std::binary_search(hole.begin(), hole.end(), t)) S.add(t);
        Grower grow(f.mesh(), S, f.none, Growth::stitcher(), "test");
        grow.run();
        if (!freeze) {
            EXPECT_EQ(f.sorted(S), block);  // the hole was filled
            expect_disk(f.g, f.sorted(S));
        } else {
            // An earlier patch stays a hole of the removed region: an annulus.
            EXPECT_EQ(S.size(), block.size() - hole.size());
            for (std::int64_t t : hole) EXPECT_FALSE(S.contains(t));
        }
    }
}

TEST(OverlapGrower, AtomicGroupsJoinWholeAndAreRecorded) {
    Growth f(10);
    FrozenSet hooks;
    hooks.group_rows = {f.lower(1, 1), f.upper(1, 1), f.lower(2, 1)};
    RemovedSet S(f.marks, 1, &hooks);
    S.add(f.upper(1, 1));
    S.add(f.lower(5, 5));
    Grower grow(f.mesh(), S, f.none, Growth::stitcher(), "test");
    grow.close_groups(0);
    EXPECT_EQ(grow.merged_groups(), (Idx{7}));
    for (std::int64_t t : hooks.group_rows) EXPECT_TRUE(S.contains(t));
    grow.close_groups(0);  // a group joins once
    EXPECT_EQ(grow.merged_groups(), (Idx{7}));
    EXPECT_EQ(S.size(), 4u);
}

TEST(OverlapGrower, ClearanceKeepsTheBoundaryAwayFromTheRegion) {
    Growth f(16);
    const auto R = region_of({{7.5, 7.5, 8.4, 7.5, 8.4, 8.4, 7.5, 8.4}});
    auto grow_with = [&](double clearance) {
        std::vector<std::uint32_t> marks(f.g.nt(), 0);
        RemovedSet S(marks, 1);
        for (std::size_t t = 0; t < f.g.nt(); ++t) {
            const std::int64_t* r = &f.g.t[3 * t];
            if (R.meets_closed_triangle(&f.g.v[3 * r[0]], &f.g.v[3 * r[1]], &f.g.v[3 * r[2]]))
                S.add(static_cast<std::int64_t>(t));
        }
        Grower grow(f.mesh(), S, R, Growth::stitcher(clearance), "test");
        grow.run();
        for (std::int64_t h : grow.boundary().halfedges)
            EXPECT_GE(R.distance(&f.g.v[3 * f.g.t[h]], clearance), clearance);
        expect_disk(f.g, f.sorted(S));
        return f.sorted(S);
    };
    const Idx plain = grow_with(0.0), wide = grow_with(2.0);
    EXPECT_TRUE(std::includes(wide.begin(), wide.end(), plain.begin(), plain.end()));
    EXPECT_GT(wide.size(), plain.size());
}

TEST(OverlapGrower, MeshBoundaryIsAnErrorUnlessAllowed) {
    Growth f(8);
    std::vector<std::uint32_t> marks(f.g.nt(), 0);
    RemovedSet S(marks, 1);
    S.add(f.lower(0, 3));
    GrowthRules paper;
    paper.join_components = true;
    try {
        Grower(f.mesh(), S, f.none, paper, "test").run();
        FAIL() << "expected GeometryError";
    } catch (const faultmesh::GeometryError& e) {
        EXPECT_NE(std::string(e.what()).find("test: the removed set reaches the mesh boundary at vertex"),
                  std::string::npos);
    }
    paper.allow_mesh_boundary = true;
    EXPECT_EQ(Grower(f.mesh(), S, f.none, paper, "test").run(), 1);
}

TEST(OverlapGrower, RoundLimit) {
    Growth f(10);
    RemovedSet S(f.marks, 1);
    S.add(f.lower(3, 3));
    S.add(f.upper(4, 4));
    GrowthRules r = Growth::stitcher();
    r.max_rounds = 1;
    EXPECT_THROW(Grower(f.mesh(), S, f.none, r, "test").run(), faultmesh::GeometryError);
}
