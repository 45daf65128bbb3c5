// GoogleTest: ear clipping of polygons with holes and the CDT flips.
#include <faultmesh/ear_clipping.hpp>
#include <faultmesh/errors.hpp>
#include <faultmesh/polygon_cdt.hpp>
#include <faultmesh/predicates.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace fm = faultmesh;

namespace {

struct Poly {
    std::vector<double> xy;
    std::vector<std::int64_t> off{0};
    void ring(const std::vector<std::pair<double, double>>& r) {
        for (auto [x, y] : r) {
            xy.push_back(x);
            xy.push_back(y);
        }
        off.push_back(off.back() + static_cast<std::int64_t>(r.size()));
    }
    std::size_t n_rings() const { return off.size() - 1; }
};

// Minimal reader for the earcut fixtures: [[[x, y], ...], ...].
Poly load_fixture(const std::string& name) {
    std::ifstream in(std::string(FAULTMESH_TEST_DATA) + "/earcut/" + name + ".json");
    EXPECT_TRUE(in.good()) << name;
    std::stringstream ss;
    ss << in.rdbuf();
    const std::string s = ss.str();
    Poly p;
    int depth = 0;
    std::vector<std::pair<double, double>> ring;
    std::vector<double> nums;
    for (std::size_t i = 0; i < s.size(); ++i) {
        const char c = s[i];
        if (c == '[') {
            ++depth;
            nums.clear();
        } else if (c == ']') {
            if (depth == 3 && nums.size() >= 2) ring.push_back({nums[0], nums[1]});
            if (depth == 2) {
                p.ring(ring);
                ring.clear();
            }
            --depth;
        } else if (c == '-' || (c >= '0' && c <= '9')) {
            std::size_t used = 0;
            nums.push_back(std::stod(s.substr(i), &used));
            i += used - 1;
        }
    }
    return p;
}

// Twice the exact-ish area: long double shoelace (tests compare with a bound).
long double twice_area_rings(const Poly& p) {
    long double total = 0;
    for (std::size_t r = 0; r < p.n_rings(); ++r) {
        long double s = 0;
        const auto b = p.off[r], e = p.off[r + 1];
        for (auto k = b; k < e; ++k) {
            const auto j = (k + 1 == e) ? b : k + 1;
            s += static_cast<long double>(p.xy[2 * k]) * p.xy[2 * j + 1] -
                 static_cast<long double>(p.xy[2 * j]) * p.xy[2 * k + 1];
        }
        total += r == 0 ? std::fabs(s) : -std::fabs(s);
    }
    return total;
}

long double twice_area_tris(const Poly& p, const std::vector<std::int64_t>& t) {
    long double s = 0;
    for (std::size_t i = 0; i < t.size(); i += 3) {
        const double* a = &p.xy[2 * t[i]];
        const double* b = &p.xy[2 * t[i + 1]];
        const double* c = &p.xy[2 * t[i + 2]];
        s += (static_cast<long double>(b[0]) - a[0]) * (static_cast<long double>(c[1]) - a[1]) -
             (static_cast<long double>(b[1]) - a[1]) * (static_cast<long double>(c[0]) - a[0]);
    }
    return s;
}

// Outer ring of a random star: n vertices at sorted random angles, radius
// uniform in [r_lo, 1].
std::vector<std::pair<double, double>> random_star_ring(std::mt19937_64& rng, int n, double r_lo) {
    std::uniform_real_distribution<double> U(0.0, 1.0);
    std::vector<double> ang(n);
    for (auto& a : ang) a = U(rng) * 2 * M_PI;
    std::sort(ang.begin(), ang.end());
    std::vector<std::pair<double, double>> outer;
    for (double a : ang) {
        const double r = r_lo + (1.0 - r_lo) * U(rng);
        outer.push_back({r * std::cos(a), r * std::sin(a)});
    }
    return outer;
}

// The triangles cover the rings' net area (long double sums, relative 1e-12).
void expect_area_kept(const Poly& p, const std::vector<std::int64_t>& t) {
    const long double a = twice_area_rings(p), b = twice_area_tris(p, t);
    EXPECT_LE(std::fabs(static_cast<double>((a - b) / a)), 1e-12);
}

void expect_ccw(const Poly& p, const std::vector<std::int64_t>& t) {
    for (std::size_t i = 0; i < t.size(); i += 3)
        ASSERT_GT(fm::orient2d(&p.xy[2 * t[i]], &p.xy[2 * t[i + 1]], &p.xy[2 * t[i + 2]]), 0.0) << "triangle " << i / 3;
}

std::vector<std::int64_t> ring_edges(const Poly& p) {
    std::vector<std::int64_t> e;
    for (std::size_t r = 0; r < p.n_rings(); ++r)
        for (auto k = p.off[r]; k < p.off[r + 1]; ++k) {
            e.push_back(k);
            e.push_back(k + 1 == p.off[r + 1] ? p.off[r] : k + 1);
        }
    return e;
}

}  // namespace

TEST(EarClipping, SquareWithHoleAllOptions) {
    Poly p;
    p.ring({{0, 0}, {10, 0}, {10, 10}, {0, 10}});
    p.ring({{3, 3}, {3, 6}, {6, 6}, {6, 3}});
    for (bool refine : {false, true})
        for (auto order : {fm::EarOrder::plain, fm::EarOrder::quality})
            for (auto bridge : {fm::BridgeMethod::extreme_point, fm::BridgeMethod::eberly}) {
                fm::EarClipOptions o;
                o.refine = refine;
                o.order = order;
                o.bridge = bridge;
                const auto t = fm::triangulate_polygon(p.xy.data(), p.off.data(), p.n_rings(), o);
                ASSERT_EQ(t.size(), 3u * 8);
                expect_ccw(p, t);
                EXPECT_EQ(twice_area_tris(p, t), twice_area_rings(p));
            }
}

TEST(EarClipping, ValidFixturesCountAreaAndCdt) {
    for (const char* name : {"building", "dude", "earcut", "eberly-6", "hilbert", "issue35", "issue52"}) {
        const Poly p = load_fixture(name);
        const auto chk = fm::check_polygon(p.xy.data(), p.xy.size() / 2, nullptr, p.off.data(), p.n_rings());
        ASSERT_TRUE(chk.valid) << name << ": " << chk.message;
        // n counts vertices after dropping consecutive duplicates (a closing
        // point equal to the first included).
        std::size_t n = 0;
        for (std::size_t r = 0; r < p.n_rings(); ++r) {
            const auto b = p.off[r], e = p.off[r + 1];
            for (auto k = b; k < e; ++k) {
                const auto j = (k + 1 == e) ? b : k + 1;
                if (p.xy[2 * k] != p.xy[2 * j] || p.xy[2 * k + 1] != p.xy[2 * j + 1]) ++n;
            }
        }
        const std::size_t h = p.n_rings() - 1;
        for (bool refine : {false, true}) {
            fm::EarClipOptions o;
            o.refine = refine;
            const auto t = fm::triangulate_polygon(p.xy.data(), p.off.data(), p.n_rings(), o);
            EXPECT_EQ(t.size() / 3, n + 2 * h - 2) << name;
            expect_ccw(p, t);
            const long double a = twice_area_rings(p), b = twice_area_tris(p, t);
            EXPECT_LE(std::fabs(static_cast<double>((a - b) / a)), 1e-13) << name;
            if (refine) {
                const auto e = ring_edges(p);
                EXPECT_EQ(fm::count_non_delaunay_edges(p.xy.data(), p.xy.size() / 2, t, e.data(), e.size() / 2), 0u)
                    << name;
            }
        }
    }
}

TEST(EarClipping, InvalidFixturesDoNotCrash) {
    for (const char* name : {"water", "water-huge", "issue83", "empty-square", "infinite-loop-jhl", "hourglass",
                             "self-tangent-4", "touching-holes6", "bad-hole", "outside-ring"}) {
        const Poly p = load_fixture(name);
        for (auto order : {fm::EarOrder::plain, fm::EarOrder::quality}) {
            fm::EarClipOptions o;
            o.order = order;
            const auto t = fm::triangulate_polygon(p.xy.data(), p.off.data(), p.n_rings(), o);
            expect_ccw(p, t);
        }
        const auto chk = fm::check_polygon(p.xy.data(), p.xy.size() / 2, nullptr, p.off.data(), p.n_rings());
        EXPECT_FALSE(chk.valid) << name;
        EXPECT_FALSE(chk.message.empty());
        fm::EarClipOptions strict;
        strict.strict = true;
        EXPECT_THROW(fm::triangulate_polygon(p.xy.data(), p.off.data(), p.n_rings(), strict), fm::GeometryError)
            << name;
    }
}

TEST(EarClipping, HourglassGivesItsTwoTriangles) {
    // A ring pinched at (7, 15): two triangles touching at a point.
    const Poly p = load_fixture("hourglass");
    const auto t = fm::triangulate_polygon(p.xy.data(), p.off.data(), p.n_rings());
    EXPECT_EQ(t.size(), 6u);
    EXPECT_EQ(twice_area_tris(p, t), twice_area_rings(p));
}

TEST(EarClipping, HoleTouchingOuterIsJoinedAtTheTouchPoint) {
    Poly p;
    p.ring({{0, 0}, {10, 0}, {10, 10}, {0, 10}});
    p.ring({{0, 0}, {2, 5}, {5, 2}});  // shares (0, 0) with the outer ring
    const auto t = fm::triangulate_polygon(p.xy.data(), p.off.data(), p.n_rings());
    expect_ccw(p, t);
    EXPECT_EQ(twice_area_tris(p, t), twice_area_rings(p));
    const auto j = fm::join_holes(p.xy.data(), p.xy.size() / 2, nullptr, p.off.data(), p.n_rings());
    ASSERT_EQ(j.bridges.size(), 2u);
    EXPECT_EQ(j.bridges[0], 0);  // the touch point of the outer ring
    EXPECT_EQ(j.bridges[1], 4);  // ... and of the hole
    EXPECT_EQ(j.loop.size(), 7u);  // no bridge copies
}

TEST(EarClipping, IndexedRingsShareVertices) {
    // Stitching's view: loops of indices into one vertex array.
    const std::vector<double> xy = {0, 0, 10, 0, 10, 10, 0, 10, 4, 4, 6, 4, 5, 6};
    const std::vector<std::int64_t> rv = {0, 1, 2, 3, 4, 6, 5};
    const std::vector<std::int64_t> off = {0, 4, 7};
    const auto t = fm::triangulate_polygon_indexed(xy.data(), 7, rv.data(), off.data(), 2);
    EXPECT_EQ(t.size(), 3u * (7 + 2 - 2));
    std::set<std::int64_t> used(t.begin(), t.end());
    EXPECT_EQ(used.size(), 7u);
    const std::vector<std::int64_t> bad = {0, 1, 9};
    const std::vector<std::int64_t> off1 = {0, 3};
    EXPECT_THROW(fm::triangulate_polygon_indexed(xy.data(), 7, bad.data(), off1.data(), 1), std::invalid_argument);
}

TEST(EarClipping, MalformedArguments) {
    const std::vector<double> xy = {0, 0, 1, 0, 1, 1};
    const std::vector<std::int64_t> dec = {0, 3, 2};
    EXPECT_THROW(fm::triangulate_polygon(xy.data(), dec.data(), 2), std::invalid_argument);
    const std::vector<std::int64_t> not_zero = {1, 3};
    EXPECT_THROW(fm::triangulate_polygon(xy.data(), not_zero.data(), 1), std::invalid_argument);
    const std::vector<std::int64_t> bad_index = {0, 1, 7};
    const std::vector<std::int64_t> off1 = {0, 3};
    EXPECT_THROW(fm::check_polygon(xy.data(), 3, bad_index.data(), off1.data(), 1), std::invalid_argument);
    const std::vector<double> nan = {0, 0, 1, std::nan(""), 1, 1};
    const std::vector<std::int64_t> ok = {0, 3};
    EXPECT_THROW(fm::triangulate_polygon(nan.data(), ok.data(), 1), std::invalid_argument);
    EXPECT_TRUE(fm::triangulate_polygon(xy.data(), ok.data(), 0).empty());
}

TEST(EarClipping, RandomStarPolygonsMatchInvariants) {
    std::mt19937_64 rng(12345);
    std::uniform_real_distribution<double> U(0.0, 1.0);
    for (int trial = 0; trial < 40; ++trial) {
        const int n = 3 + static_cast<int>(U(rng) * 200);
        Poly p;
        p.ring(random_star_ring(rng, n, 0.6));
        const int holes = trial % 4;
        for (int h = 0; h < holes; ++h) {
            const double cx = 0.3 * std::cos(2 * M_PI * h / holes), cy = 0.3 * std::sin(2 * M_PI * h / holes);
            p.ring({{cx - 0.05, cy - 0.05}, {cx + 0.05, cy - 0.05}, {cx, cy + 0.05}});
        }
        fm::EarClipOptions o;
        o.order = trial % 2 ? fm::EarOrder::plain : fm::EarOrder::quality;
        const auto t = fm::triangulate_polygon(p.xy.data(), p.off.data(), p.n_rings(), o);
        const auto chk = fm::check_polygon(p.xy.data(), p.xy.size() / 2, nullptr, p.off.data(), p.n_rings());
        if (!chk.valid) continue;  // random angles can coincide to within rounding
        EXPECT_EQ(t.size() / 3, static_cast<std::size_t>(n + 3 * holes + 2 * holes - 2));
        expect_ccw(p, t);
        expect_area_kept(p, t);
        const auto e = ring_edges(p);
        EXPECT_EQ(fm::count_non_delaunay_edges(p.xy.data(), p.xy.size() / 2, t, e.data(), e.size() / 2), 0u);
    }
}

TEST(PolygonCdt, PerturbedIncircleIsConsistentOnCocircularPoints) {
    // The four corners of a square are cocircular: exactly one diagonal is
    // Delaunay under the perturbation, whichever triangle asks.
    const double a[2] = {0, 0}, b[2] = {1, 0}, c[2] = {1, 1}, d[2] = {0, 1};
    EXPECT_EQ(fm::incircle_sign(a, b, c, d), 0);
    const int s1 = fm::incircle_perturbed(a, b, c, d);  // diagonal a-c, is d inside abc?
    const int s2 = fm::incircle_perturbed(c, d, a, b);  // same diagonal from the other side
    EXPECT_NE(s1, 0);
    EXPECT_EQ(s1, s2);
    const int t1 = fm::incircle_perturbed(b, c, d, a);  // diagonal b-d
    EXPECT_EQ(t1, -s1);  // exactly one of the two diagonals gets flipped
    std::vector<std::int64_t> tris = {0, 1, 2, 0, 2, 3};
    const double xy[8] = {0, 0, 1, 0, 1, 1, 0, 1};
    const std::vector<std::int64_t> cons = {0, 1, 1, 2, 2, 3, 3, 0};
    fm::flip_to_constrained_delaunay(xy, 4, tris, cons.data(), 4);
    EXPECT_EQ(fm::count_non_delaunay_edges(xy, 4, tris, cons.data(), 4), 0u);
    std::vector<std::int64_t> other = {1, 2, 3, 1, 3, 0};
    fm::flip_to_constrained_delaunay(xy, 4, other, cons.data(), 4);
    std::set<std::set<std::int64_t>> s, o;
    for (int i = 0; i < 6; i += 3) s.insert({tris[i], tris[i + 1], tris[i + 2]});
    for (int i = 0; i < 6; i += 3) o.insert({other[i], other[i + 1], other[i + 2]});
    EXPECT_EQ(s, o);  // canonical: both starting diagonals end in the same one
}

TEST(PolygonCdt, ConstrainedEdgeIsNeverFlipped) {
    // A thin quad whose Delaunay diagonal is b-d, with a-c constrained.
    const double xy[8] = {0, 0, 5, -0.1, 10, 0, 5, 0.1};
    std::vector<std::int64_t> tris = {0, 1, 2, 0, 2, 3};
    const std::vector<std::int64_t> cons = {0, 2};
    EXPECT_EQ(fm::flip_to_constrained_delaunay(xy, 4, tris, cons.data(), 1), 0u);
    EXPECT_EQ(fm::flip_to_constrained_delaunay(xy, 4, tris, nullptr, 0), 1u);
    EXPECT_THROW(fm::flip_to_constrained_delaunay(xy, 3, tris, nullptr, 0), std::invalid_argument);
}

// Fallbacks for invalid input (ear_clipping.hpp): the area earcut's test
// suite measures (|outer| - sum |holes|) is what the triangles cover.

TEST(EarClipping, HoleIdenticalToOuterGivesNoTriangles) {
    Poly p;
    p.ring({{0, 0}, {10, 0}, {10, 10}, {0, 10}});
    p.ring({{0, 0}, {10, 0}, {10, 10}, {0, 10}});
    for (auto order : {fm::EarOrder::plain, fm::EarOrder::quality})
        for (bool refine : {false, true}) {
            fm::EarClipOptions o;
            o.order = order;
            o.refine = refine;
            EXPECT_TRUE(fm::triangulate_polygon(p.xy.data(), p.off.data(), p.n_rings(), o).empty());
        }
}

TEST(EarClipping, HoleSharingEdgesWithOuterLeavesTheNotch) {
    // The hole runs along three edges of the outer square and cuts a notch
    // into the fourth: the polygon is the notch triangle (4,0) (6,0) (5,3).
    Poly p;
    p.ring({{0, 0}, {10, 0}, {10, 10}, {0, 10}});
    p.ring({{0, 0}, {0, 10}, {10, 10}, {10, 0}, {6, 0}, {5, 3}, {4, 0}});
    for (auto order : {fm::EarOrder::plain, fm::EarOrder::quality}) {
        fm::EarClipOptions o;
        o.order = order;
        o.refine = false;
        const auto t = fm::triangulate_polygon(p.xy.data(), p.off.data(), p.n_rings(), o);
        expect_ccw(p, t);
        EXPECT_EQ(twice_area_rings(p), 6.0L);
        EXPECT_EQ(twice_area_tris(p, t), 6.0L);
    }
}

TEST(EarClipping, SelfCrossingFixturesKeepEarcutsDeviation) {
    // earcut lists no error for these (0): self-crossing outer rings and
    // holes crossing the outer ring, covered by splitting along inside
    // diagonals when no ear is left.
    for (const char* name : {"water2", "water3", "water3b", "water4", "issue111", "collinear-diagonal"}) {
        const Poly p = load_fixture(name);
        for (auto order : {fm::EarOrder::plain, fm::EarOrder::quality}) {
            fm::EarClipOptions o;
            o.order = order;
            o.refine = false;
            const auto t = fm::triangulate_polygon(p.xy.data(), p.off.data(), p.n_rings(), o);
            expect_ccw(p, t);
            const long double pa = twice_area_rings(p);
            EXPECT_LE(std::fabs(twice_area_tris(p, t) - pa), 1e-12L * std::fabs(pa)) << name;
        }
    }
}

TEST(EarClipping, JaggedRingWithManyHolesBridgesAreClear) {
    // A jagged star (thin spike ears, extreme-point pairs often blocked by
    // the ring itself or by holes not yet joined) with a 7 x 7 lattice of
    // small holes: exercises the bridge search's local and blocker-first
    // tests, the chunked scan and the segment grid it falls back to, and the
    // plain order's cache of non-ears. Every bridge must cross no ring edge,
    // and both orders must give n + 2h - 2 counter-clockwise triangles
    // covering the polygon's area.
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> U(0.0, 1.0);
    const int n_outer = 2000;
    std::vector<double> ang(n_outer);
    for (auto& a : ang) a = U(rng) * 2 * M_PI;
    std::sort(ang.begin(), ang.end());
    Poly p;
    std::vector<std::pair<double, double>> outer;
    for (double a : ang) {
        const double r = 1.0 + 0.25 * std::sin(7 * a) + 0.1 * (U(rng) - 0.5);
        outer.push_back({r * std::cos(a), r * std::sin(a)});
    }
    p.ring(outer);
    int holes = 0;
    for (int i = -3; i <= 3; ++i)
        for (int j = -3; j <= 3; ++j) {
            const double cx = 0.14 * i + 0.01 * U(rng), cy = 0.14 * j + 0.01 * U(rng), s = 0.03;
            p.ring({{cx - s, cy - s}, {cx + s, cy - s}, {cx + s, cy + s}, {cx - s, cy + s}});
            ++holes;
        }
    const std::size_t n_pts = p.xy.size() / 2;
    const auto chk = fm::check_polygon(p.xy.data(), n_pts, nullptr, p.off.data(), p.n_rings());
    ASSERT_TRUE(chk.valid) << chk.message;
    const auto edges = ring_edges(p);
    std::vector<std::int64_t> rv(n_pts);
    for (std::size_t i = 0; i < n_pts; ++i) rv[i] = static_cast<std::int64_t>(i);
    for (auto method : {fm::BridgeMethod::extreme_point, fm::BridgeMethod::eberly}) {
        const auto jp = fm::join_holes(p.xy.data(), n_pts, rv.data(), p.off.data(), p.n_rings(), method);
        EXPECT_TRUE(jp.skipped_rings.empty());
        ASSERT_EQ(jp.bridges.size(), 2u * holes);
        for (std::size_t k = 0; k < jp.bridges.size(); k += 2) {
            const double* a = &p.xy[2 * jp.bridges[k]];
            const double* b = &p.xy[2 * jp.bridges[k + 1]];
            for (std::size_t e = 0; e < edges.size(); e += 2) {
                if (edges[e] == jp.bridges[k] || edges[e] == jp.bridges[k + 1] || edges[e + 1] == jp.bridges[k] ||
                    edges[e + 1] == jp.bridges[k + 1])
                    continue;
                const double* u = &p.xy[2 * edges[e]];
                const double* v = &p.xy[2 * edges[e + 1]];
                const int o1 = fm::orient2d_sign(a, b, u), o2 = fm::orient2d_sign(a, b, v);
                const int o3 = fm::orient2d_sign(u, v, a), o4 = fm::orient2d_sign(u, v, b);
                // In a valid polygon no three of these points are collinear
                // here, so meeting means a proper crossing.
                EXPECT_FALSE(o1 * o2 <= 0 && o3 * o4 <= 0) << "bridge " << k / 2 << " meets edge " << e / 2;
            }
        }
    }
    const long double pa = twice_area_rings(p);
    for (auto order : {fm::EarOrder::plain, fm::EarOrder::quality}) {
        fm::EarClipOptions o;
        o.order = order;
        o.refine = false;
        const auto t = fm::triangulate_polygon(p.xy.data(), p.off.data(), p.n_rings(), o);
        EXPECT_EQ(t.size() / 3, n_pts + 2 * holes - 2);
        expect_ccw(p, t);
        EXPECT_LE(std::fabs(twice_area_tris(p, t) - pa), 1e-12L * std::fabs(pa));
    }
}

namespace {

// A jagged star (radius 1000 +- 250 with a 7-fold wave, +-50 noise per
// vertex) with four round holes: the bench polygon's shape.
Poly jagged_star(int n_outer, int n_hole, unsigned seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> U(0.0, 1.0);
    std::vector<double> ang(n_outer);
    for (auto& a : ang) a = U(rng) * 2 * M_PI;
    std::sort(ang.begin(), ang.end());
    Poly p;
    std::vector<std::pair<double, double>> outer;
    for (double a : ang) {
        const double r = 1000.0 * (1.0 + 0.25 * std::sin(7 * a) + 0.1 * (U(rng) - 0.5));
        outer.push_back({r * std::cos(a), r * std::sin(a)});
    }
    p.ring(outer);
    for (int h = 0; h < 4; ++h) {
        const double cx = 350 * std::cos(M_PI / 2 * h + 0.3), cy = 350 * std::sin(M_PI / 2 * h + 0.3);
        std::vector<std::pair<double, double>> hole;
        for (int k = n_hole - 1; k >= 0; --k) {
            const double a = 2 * M_PI * k / n_hole;
            hole.push_back({cx + 120 * std::cos(a), cy + 120 * std::sin(a)});
        }
        p.ring(hole);
    }
    return p;
}

}  // namespace

// A large polygon in plain order is split along an inside diagonal and the
// halves are clipped (concurrently by default): the triangles are the same
// with and without the second thread, differ from the unsplit clipping,
// and keep every invariant.
TEST(EarClipping, SplitHalvesKeepInvariantsAndDoNotDependOnThreads) {
    for (unsigned seed : {1u, 2u, 3u}) {
        const Poly p = jagged_star(9000, 250, seed);
        fm::EarClipOptions o;
        o.refine = false;
        o.order = fm::EarOrder::plain;
        const auto t = fm::triangulate_polygon(p.xy.data(), p.off.data(), p.n_rings(), o);
        o.threads = 1;
        EXPECT_EQ(fm::triangulate_polygon(p.xy.data(), p.off.data(), p.n_rings(), o), t) << seed;
        o.split_min = 0;
        EXPECT_NE(fm::triangulate_polygon(p.xy.data(), p.off.data(), p.n_rings(), o), t)
            << "seed " << seed << ": the polygon was not split";
        ASSERT_TRUE(fm::check_polygon(p.xy.data(), p.xy.size() / 2, nullptr, p.off.data(), p.n_rings()).valid);
        EXPECT_EQ(t.size() / 3, static_cast<std::size_t>(9000 + 4 * 250 + 2 * 4 - 2));
        expect_ccw(p, t);
        expect_area_kept(p, t);
        // Every ring edge is a triangle edge; refined, it is the CDT.
        std::set<std::pair<std::int64_t, std::int64_t>> tri_edges;
        for (std::size_t i = 0; i < t.size(); i += 3)
            for (int k = 0; k < 3; ++k) {
                const auto u = t[i + k], v = t[i + (k + 1) % 3];
                tri_edges.insert({std::min(u, v), std::max(u, v)});
            }
        const auto e = ring_edges(p);
        for (std::size_t k = 0; k < e.size(); k += 2)
            ASSERT_TRUE(tri_edges.count({std::min(e[k], e[k + 1]), std::max(e[k], e[k + 1])})) << "edge " << k / 2;
        auto r = t;
        fm::flip_to_constrained_delaunay(p.xy.data(), p.xy.size() / 2, r, e.data(), e.size() / 2);
        EXPECT_EQ(fm::count_non_delaunay_edges(p.xy.data(), p.xy.size() / 2, r, e.data(), e.size() / 2), 0u);
    }
}

// Small split thresholds exercise the split on every random star polygon.
TEST(EarClipping, SplitOnSmallPolygonsKeepsCounts) {
    std::mt19937_64 rng(777);
    std::uniform_real_distribution<double> U(0.0, 1.0);
    int split = 0, valid = 0;
    for (int trial = 0; trial < 60; ++trial) {
        const int n = 8 + static_cast<int>(U(rng) * 300);
        Poly p;
        p.ring(random_star_ring(rng, n, 0.6));
        if (!fm::check_polygon(p.xy.data(), p.xy.size() / 2, nullptr, p.off.data(), p.n_rings()).valid) continue;
        ++valid;
        fm::EarClipOptions o;
        o.refine = false;
        o.order = fm::EarOrder::plain;
        o.split_min = 4;
        o.threads = trial % 2;
        const auto t = fm::triangulate_polygon(p.xy.data(), p.off.data(), p.n_rings(), o);
        EXPECT_EQ(t.size() / 3, static_cast<std::size_t>(n - 2));
        expect_ccw(p, t);
        expect_area_kept(p, t);
        o.split_min = 0;
        split += fm::triangulate_polygon(p.xy.data(), p.off.data(), p.n_rings(), o) != t;
    }
    EXPECT_GE(valid, 50);
    EXPECT_GE(split, valid * 3 / 4);  // a split diagonal is found on most of them
}

// Regression (issue 10): no coordinate range check (triangles outside the
// polygon at 1e155); an all-empty ring list said "xy is null".
TEST(EarClipping, CoordinateLimitAndEmptyRings) {
    std::vector<double> xy = {0, 0, 1, 0, 1, 1, 0, 1e155};
    const std::vector<std::int64_t> off = {0, 4};
    try {
        fm::triangulate_polygon(xy.data(), off.data(), 1);
        FAIL();
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("triangulate_polygon: ring 0 vertex 3 (point 3) has a coordinate "
                                             "beyond +-1e+60"),
                  std::string::npos)
            << e.what();
    }
    EXPECT_THROW(fm::check_polygon(xy.data(), 4, nullptr, off.data(), 1), std::invalid_argument);
    const std::vector<std::int64_t> empty = {0, 0};
    EXPECT_TRUE(fm::triangulate_polygon(nullptr, empty.data(), 1).empty());
    EXPECT_FALSE(fm::check_polygon(nullptr, 0, nullptr, empty.data(), 1).valid);
}
