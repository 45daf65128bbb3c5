// Tests of the surface-cutting baseline (cutting.hpp): a jittered grid layer
// cut by planar and bent dipping faults, checked for conformity, the crack
// along the intersection line, the displacement of the hanging wall, area
// preservation and that no triangle crosses the line.
#include <faultmesh/cutting.hpp>
#include <faultmesh/delaunay.hpp>
#include <faultmesh/errors.hpp>
#include <faultmesh/predicates.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <random>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace {

using faultmesh::CutOptions;
using faultmesh::CutResult;
using faultmesh::cut_layer;
using Index = std::int64_t;

struct Mesh {
    std::vector<double> xyz;
    std::vector<Index> tri;
    std::size_t nv() const { return xyz.size() / 3; }
    std::size_t nt() const { return tri.size() / 3; }
};

// Jittered (n+1) x (n+1) grid on [0, size]^2 with z = zfun(x, y), Delaunay in XY.
// The corners and the border points stay on the square (jitter along it only)
// so the study area is exactly the square.
Mesh layer_grid(int n, double size, const std::function<double(double, double)>& zfun, unsigned seed = 7) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-0.3, 0.3);
    Mesh m;
    std::vector<double> xy;
    const double h = size / n;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            double x = i * h, y = j * h;
            const double jx = u(rng) * h, jy = u(rng) * h;
            if (i > 0 && i < n) x += jx;
            if (j > 0 && j < n) y += jy;
            xy.push_back(x);
            xy.push_back(y);
            m.xyz.insert(m.xyz.end(), {x, y, zfun(x, y)});
        }
    m.tri = faultmesh::delaunay(xy.data(), xy.size() / 2).triangles;
    return m;
}

// A fault surface as a (ny+1) x (nd+1) grid over (y, depth): the fault trace
// at depth z is x = x_of(y, z); from y0 to y1 and from z = ztop down to zbot.
Mesh fault_grid(double y0, double y1, int ny, double ztop, double zbot, int nd,
                const std::function<double(double, double)>& x_of) {
    Mesh m;
    for (int j = 0; j <= ny; ++j)
        for (int k = 0; k <= nd; ++k) {
            const double y = y0 + (y1 - y0) * j / ny, z = ztop + (zbot - ztop) * k / nd;
            m.xyz.insert(m.xyz.end(), {x_of(y, z), y, z});
        }
    for (int j = 0; j < ny; ++j)
        for (int k = 0; k < nd; ++k) {
            const Index a = j * (nd + 1) + k, b = a + 1, c = a + (nd + 1), d = c + 1;
            m.tri.insert(m.tri.end(), {a, c, b, b, c, d});
        }
    return m;
}

CutResult cut(const Mesh& layer, const Mesh& fault, const CutOptions& opt = {}) {
    return cut_layer(layer.xyz.data(), layer.nv(), layer.tri.data(), layer.nt(), fault.xyz.data(), fault.nv(),
                     fault.tri.data(), fault.nt(), opt);
}

double area2(const std::vector<double>& v, Index a, Index b, Index c) {
    return faultmesh::orient2d(&v[3 * a], &v[3 * b], &v[3 * c]);
}

using EdgeCount = std::map<std::pair<Index, Index>, int>;
EdgeCount undirected_edges(const std::vector<Index>& tri) {
    EdgeCount ec;
    for (std::size_t t = 0; t < tri.size() / 3; ++t)
        for (int i = 0; i < 3; ++i) {
            const Index a = tri[3 * t + i], b = tri[3 * t + (i + 1) % 3];
            ec[{std::min(a, b), std::max(a, b)}]++;
        }
    return ec;
}

// Proper crossing of the closed segment pq with the open segment ab's interior
// (touching at end points does not count).
bool segments_cross(const double* p, const double* q, const double* a, const double* b) {
    using faultmesh::orient2d_sign;
    const int o1 = orient2d_sign(p, q, a), o2 = orient2d_sign(p, q, b);
    const int o3 = orient2d_sign(a, b, p), o4 = orient2d_sign(a, b, q);
    return o1 * o2 < 0 && o3 * o4 < 0;
}

// The invariants every cut must keep.
void check_cut(const Mesh& layer, const CutResult& r, double displacement, double taper) {
    const auto& V = r.vertices;
    const std::size_t nt = r.triangles.size() / 3;
    ASSERT_EQ(nt, layer.nt() - r.removed.size() + r.n_created);
    // Vertices: the input ones unchanged.
    for (std::size_t i = 0; i < layer.xyz.size(); ++i) ASSERT_EQ(V[i], layer.xyz[i]);
    // Counter-clockwise, non-degenerate triangles; the XY area is unchanged.
    double a_in = 0, a_out = 0;
    for (std::size_t t = 0; t < layer.nt(); ++t)
        a_in += area2(layer.xyz, layer.tri[3 * t], layer.tri[3 * t + 1], layer.tri[3 * t + 2]);
    for (std::size_t t = 0; t < nt; ++t) {
        const double a = area2(V, r.triangles[3 * t], r.triangles[3 * t + 1], r.triangles[3 * t + 2]);
        ASSERT_GT(a, 0.0) << "triangle " << t;
        a_out += a;
    }
    EXPECT_NEAR(a_out, a_in, 1e-9 * a_in);
    // Conforming: each edge in one or two triangles; edges in one triangle are
    // the layer's own boundary edges (or pieces of them split at a line end)
    // or the two banks of the crack (consecutive line copies).
    const EdgeCount in_edges = undirected_edges(layer.tri);
    std::set<std::pair<Index, Index>> crack;
    for (std::size_t c = 0; c + 1 < r.line_offsets.size(); ++c)
        for (Index i = r.line_offsets[c]; i + 1 < r.line_offsets[c + 1]; ++i) {
            for (const auto* line : {&r.footwall_line, &r.hanging_line}) {
                const Index a = (*line)[i], b = (*line)[i + 1];
                crack.insert({std::min(a, b), std::max(a, b)});
            }
        }
    for (const auto& [e, n] : undirected_edges(r.triangles)) {
        ASSERT_LE(n, 2) << e.first << "-" << e.second;
        if (n == 2) continue;
        if (crack.count(e)) continue;
        const bool old = e.first < static_cast<Index>(layer.nv()) && e.second < static_cast<Index>(layer.nv());
        if (old) {
            auto it = in_edges.find(e);
            ASSERT_TRUE(it != in_edges.end() && it->second == 1) << "interior edge " << e.first << "-" << e.second
                                                                 << " became a boundary edge";
        } else {
            // A piece of a layer boundary edge split at a line end: the new
            // vertex lies on the study-area boundary (x or y is 0 or 100 here).
            const Index nv_ = std::max(e.first, e.second);
            const double x = V[3 * nv_], y = V[3 * nv_ + 1];
            const bool on_border = std::fabs(x) < 1e-9 || std::fabs(y) < 1e-9 || std::fabs(x - 100) < 1e-9 ||
                                   std::fabs(y - 100) < 1e-9;
            ASSERT_TRUE(on_border) << "unexpected boundary edge " << e.first << "-" << e.second;
        }
    }
    // Line copies: same XY; the footwall copy at the layer's z, the hanging
    // copy displaced by displacement * weight; tips are one vertex with weight 0.
    ASSERT_EQ(r.footwall_line.size(), r.hanging_line.size());
    for (std::size_t i = 0; i < r.footwall_line.size(); ++i) {
        const Index f = r.footwall_line[i], h = r.hanging_line[i];
        EXPECT_EQ(V[3 * f], V[3 * h]);
        EXPECT_EQ(V[3 * f + 1], V[3 * h + 1]);
        EXPECT_NEAR(V[3 * h + 2] - V[3 * f + 2], displacement * r.line_weight[i], 1e-9);
        if (f == h) EXPECT_EQ(r.line_weight[i], 0.0);
        if (taper <= 0 && f != h) EXPECT_EQ(r.line_weight[i], 1.0);
    }
    // No triangle crosses the intersection line.
    for (std::size_t t = 0; t < nt; ++t)
        for (std::size_t i = 0; i + 1 < r.footwall_line.size(); ++i) {
            const double* p = &V[3 * r.footwall_line[i]];
            const double* q = &V[3 * r.footwall_line[i + 1]];
            for (int k = 0; k < 3; ++k) {
                const double* a = &V[3 * r.triangles[3 * t + k]];
                const double* b = &V[3 * r.triangles[3 * t + (k + 1) % 3]];
                ASSERT_FALSE(segments_cross(p, q, a, b)) << "triangle " << t << " crosses line segment " << i;
            }
        }
}

// A layer dipping gently east, a planar fault striking north, dipping 60 deg
// east (toward +x), between y = 20 and y = 80 (two tips inside the layer).
const auto kLayerZ = [](double x, double y) { return -50.0 + 0.05 * x + 0.02 * y; };
const auto kPlane60 = [](double, double z) { return 40.0 - z / std::tan(60.0 * M_PI / 180.0); };

TEST(Cutting, PlanarFaultWithTwoTips) {
    const Mesh layer = layer_grid(20, 100.0, kLayerZ);
    const Mesh fault = fault_grid(20.0, 80.0, 6, 0.0, -100.0, 5, kPlane60);
    CutOptions opt;
    opt.displacement = -4.0;
    const CutResult r = cut(layer, fault, opt);
    check_cut(layer, r, opt.displacement, 0.0);
    ASSERT_EQ(r.line_offsets.size(), 2u);  // one line
    EXPECT_GT(r.footwall_line.size(), 8u);  // ~60 m of line through 5 m triangles
    EXPECT_EQ(r.split.size(), 2u);         // two tips, each splitting a triangle
    EXPECT_EQ(r.footwall_line.front(), r.hanging_line.front());
    EXPECT_EQ(r.footwall_line.back(), r.hanging_line.back());
    // Created = faces (n - 2 each) + 2 per split; every cut triangle replaced.
    EXPECT_GE(r.n_created, r.removed.size());
    // The line lies on the fault: x = 40 + (-z) / tan 60 at the layer's z.
    for (Index v : r.footwall_line) {
        const double* p = &r.vertices[3 * v];
        EXPECT_NEAR(p[0], kPlane60(p[1], p[2]), 0.35) << v;  // within the layer's linear interpolation error
        EXPECT_NEAR(p[2], kLayerZ(p[0], p[1]), 1e-9);
    }
    // Hanging wall on the left of the line (east of it, since the line runs
    // south to north... or north to south with the hanging wall to the east).
    const Index n0 = r.footwall_line.front(), n1 = r.footwall_line.back();
    const double dy = r.vertices[3 * n1 + 1] - r.vertices[3 * n0 + 1];
    EXPECT_LT(dy, 0.0) << "hanging wall (east) must be on the left: the line runs north to south";
}

TEST(Cutting, HangingWallTrianglesUseHangingCopies) {
    const Mesh layer = layer_grid(16, 100.0, kLayerZ, 11);
    const Mesh fault = fault_grid(10.0, 90.0, 8, 10.0, -120.0, 6, kPlane60);
    CutOptions opt;
    opt.displacement = 6.0;  // reverse
    const CutResult r = cut(layer, fault, opt);
    check_cut(layer, r, opt.displacement, 0.0);
    std::set<Index> hang(r.hanging_line.begin(), r.hanging_line.end()), foot(r.footwall_line.begin(), r.footwall_line.end());
    const std::size_t nt = r.triangles.size() / 3;
    std::size_t with_hang = 0, with_foot = 0;
    for (std::size_t t = nt - r.n_created; t < nt; ++t) {
        bool h = false, f = false;
        double xs = 0;
        for (int k = 0; k < 3; ++k) {
            const Index v = r.triangles[3 * t + k];
            const bool tip = hang.count(v) && foot.count(v);
            if (!tip && hang.count(v)) h = true;
            if (!tip && foot.count(v)) f = true;
            xs += r.vertices[3 * v];
        }
        EXPECT_FALSE(h && f) << "created triangle " << t << " joins both walls";
        // The fault line is near x ~ 69 here; the hanging wall (above the
        // east-dipping fault) is east of it.
        if (h) {
            ++with_hang;
            EXPECT_GT(xs / 3, 60.0);
        }
        if (f) {
            ++with_foot;
            EXPECT_LT(xs / 3, 78.0);
        }
    }
    EXPECT_GT(with_hang, 4u);
    EXPECT_GT(with_foot, 4u);
}

TEST(Cutting, TaperGrowsFromTheTips) {
    const Mesh layer = layer_grid(20, 100.0, kLayerZ, 3);
    const Mesh fault = fault_grid(20.0, 80.0, 6, 0.0, -100.0, 5, kPlane60);
    CutOptions opt;
    opt.displacement = -5.0;
    opt.taper_length = 15.0;
    const CutResult r = cut(layer, fault, opt);
    check_cut(layer, r, opt.displacement, opt.taper_length);
    double wmax = 0;
    for (std::size_t i = 0; i < r.line_weight.size(); ++i) wmax = std::max(wmax, r.line_weight[i]);
    EXPECT_EQ(wmax, 1.0);  // the middle of a 60 m line is more than 15 m from both tips
    EXPECT_LT(r.line_weight[1], 1.0);
    EXPECT_GT(r.line_weight[1], 0.0);
}

TEST(Cutting, FaultThroughTheWholeAreaSplitsTheLayer) {
    // Boundary fault (paper F22): the line runs from border to border, both
    // ends on the layer boundary with two copies, the layer falls in two.
    const Mesh layer = layer_grid(12, 100.0, kLayerZ, 5);
    const Mesh fault = fault_grid(-10.0, 110.0, 8, 10.0, -120.0, 4, kPlane60);
    CutOptions opt;
    opt.displacement = -3.0;
    const CutResult r = cut(layer, fault, opt);
    check_cut(layer, r, opt.displacement, 0.0);
    EXPECT_TRUE(r.split.empty());
    EXPECT_NE(r.footwall_line.front(), r.hanging_line.front());
    EXPECT_NE(r.footwall_line.back(), r.hanging_line.back());
    // Two edge-connected components.
    const std::size_t nt = r.triangles.size() / 3;
    std::map<std::pair<Index, Index>, std::vector<std::size_t>> by_edge;
    for (std::size_t t = 0; t < nt; ++t)
        for (int i = 0; i < 3; ++i) {
            const Index a = r.triangles[3 * t + i], b = r.triangles[3 * t + (i + 1) % 3];
            by_edge[{std::min(a, b), std::max(a, b)}].push_back(t);
        }
    std::vector<int> comp(nt, -1);
    int nc = 0;
    for (std::size_t s = 0; s < nt; ++s) {
        if (comp[s] >= 0) continue;
        std::vector<std::size_t> st{s};
        comp[s] = nc;
        while (!st.empty()) {
            const std::size_t t = st.back();
            st.pop_back();
            for (int i = 0; i < 3; ++i) {
                const Index a = r.triangles[3 * t + i], b = r.triangles[3 * t + (i + 1) % 3];
                for (std::size_t o : by_edge[{std::min(a, b), std::max(a, b)}])
                    if (comp[o] < 0) {
                        comp[o] = nc;
                        st.push_back(o);
                    }
            }
        }
        ++nc;
    }
    EXPECT_EQ(nc, 2);
}

TEST(Cutting, ExtensionCarriesTheLineToTheStudyBoundary) {
    // The fault stops 0.5 m short of the layer's north border (y = 100).
    const Mesh layer = layer_grid(12, 100.0, kLayerZ, 5);
    const Mesh fault = fault_grid(20.0, 99.5, 8, 10.0, -120.0, 4, kPlane60);
    CutOptions opt;
    opt.displacement = -3.0;
    const CutResult r0 = cut(layer, fault, opt);
    check_cut(layer, r0, opt.displacement, 0.0);
    EXPECT_EQ(r0.split.size(), 2u);  // a tip at each end: the border crossing lies outside the fault
    opt.extension = 1.0;
    const CutResult r1 = cut(layer, fault, opt);
    check_cut(layer, r1, opt.displacement, 0.0);
    ASSERT_EQ(r1.split.size(), 1u);  // only the southern tip is left
    ASSERT_EQ(r1.line_offsets.size(), 2u);
    const Index f = r1.footwall_line.back(), h = r1.hanging_line.back();
    const Index f0 = r1.footwall_line.front(), h0 = r1.hanging_line.front();
    // The northern end is on the border, with two copies.
    const bool north_last = r1.vertices[3 * f + 1] > 99.9;
    EXPECT_TRUE(north_last ? f != h : f0 != h0);
    EXPECT_NEAR(north_last ? r1.vertices[3 * f + 1] : r1.vertices[3 * f0 + 1], 100.0, 1e-9);
    // Line ends inside the layer are not extended: the same southern tip.
    auto south = [](const CutResult& r) {
        Index best = r.footwall_line.front();
        for (Index v : r.footwall_line)
            if (r.vertices[3 * v + 1] < r.vertices[3 * best + 1]) best = v;
        return std::make_pair(r.vertices[3 * best], r.vertices[3 * best + 1]);
    };
    EXPECT_EQ(south(r0), south(r1));
    opt.extension = -1.0;
    EXPECT_THROW(cut(layer, fault, opt), std::invalid_argument);
}

TEST(Cutting, BentFaultAndCoarseFaultMesh) {
    // A listric-like fault (dip steepening upward) with a strike bend.
    const Mesh layer = layer_grid(24, 100.0, kLayerZ, 9);
    auto x_of = [](double y, double z) { return 35.0 + 8.0 * std::sin(y / 15.0) + 0.004 * z * z - 0.2 * z; };
    const Mesh fault = fault_grid(15.0, 85.0, 5, 5.0, -110.0, 3, x_of);
    CutOptions opt;
    opt.displacement = -2.5;
    opt.taper_length = 10.0;
    const CutResult r = cut(layer, fault, opt);
    check_cut(layer, r, opt.displacement, opt.taper_length);
    EXPECT_GT(r.footwall_line.size(), 10u);
}

TEST(Cutting, PlainEarOrderWithoutRefinementGivesTheSameCounts) {
    const Mesh layer = layer_grid(20, 100.0, kLayerZ);
    const Mesh fault = fault_grid(20.0, 80.0, 6, 0.0, -100.0, 5, kPlane60);
    CutOptions q, p;
    p.triangulation.refine = false;
    p.triangulation.order = faultmesh::EarOrder::plain;
    const CutResult rq = cut(layer, fault, q), rp = cut(layer, fault, p);
    check_cut(layer, rp, 0.0, 0.0);
    EXPECT_EQ(rq.n_created, rp.n_created);
    EXPECT_EQ(rq.removed, rp.removed);
}

TEST(Cutting, FaultThroughLayerVerticesKeepsEdgesNonDegenerate) {
    // An exact grid (no jitter) and a fault whose intersection passes through
    // grid vertices: x = 50 exactly on the layer z = -50 (fault plane x = 50 - (z + 50) / 2).
    Mesh layer;
    std::vector<double> xy;
    for (int j = 0; j <= 10; ++j)
        for (int i = 0; i <= 10; ++i) {
            layer.xyz.insert(layer.xyz.end(), {10.0 * i, 10.0 * j, -50.0});
            xy.insert(xy.end(), {10.0 * i, 10.0 * j});
        }
    layer.tri = faultmesh::delaunay(xy.data(), xy.size() / 2).triangles;
    const Mesh fault = fault_grid(25.0, 75.0, 4, 0.0, -100.0, 4, [](double, double z) { return 50.0 - (z + 50.0) / 2; });
    CutOptions opt;
    opt.displacement = -1.0;
    const CutResult r = cut(layer, fault, opt);
    check_cut(layer, r, opt.displacement, 0.0);
    EXPECT_GT(r.footwall_line.size(), 2u);
}

TEST(Cutting, NoCrossingLeavesTheLayerUnchanged) {
    const Mesh layer = layer_grid(8, 100.0, kLayerZ);
    // A fault entirely below the layer.
    const Mesh deep = fault_grid(20.0, 80.0, 3, -200.0, -300.0, 2, kPlane60);
    const CutResult r = cut(layer, deep, {});
    EXPECT_EQ(r.triangles, layer.tri);
    EXPECT_EQ(r.n_created, 0u);
    EXPECT_TRUE(r.removed.empty());
    // A vertical fault has no XY projection: not cut.
    const Mesh vertical = fault_grid(20.0, 80.0, 3, 0.0, -100.0, 2, [](double, double) { return 50.0; });
    const CutResult rv = cut(layer, vertical, {});
    EXPECT_EQ(rv.triangles, layer.tri);
}

TEST(Cutting, ClosedIntersectionLineIsAGeometryError) {
    // A bowl-shaped layer and a gently dipping fault plane spanning the whole
    // area: they meet in a closed curve, which the baseline does not support.
    const Mesh layer = layer_grid(16, 100.0, [](double x, double y) {
        return -60.0 + 0.01 * ((x - 50) * (x - 50) + (y - 50) * (y - 50));
    });
    Mesh fault;
    for (int j = 0; j <= 4; ++j)
        for (int i = 0; i <= 4; ++i) {
            const double x = -10.0 + 30.0 * i, y = -10.0 + 30.0 * j;
            fault.xyz.insert(fault.xyz.end(), {x, y, -45.0 + 0.02 * x});
        }
    for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 4; ++i) {
            const Index a = j * 5 + i;
            fault.tri.insert(fault.tri.end(), {a, a + 1, a + 6, a, a + 6, a + 5});
        }
    try {
        cut(layer, fault);
        FAIL() << "expected a GeometryError";
    } catch (const faultmesh::GeometryError& e) {
        EXPECT_NE(std::string(e.what()).find("closes on itself"), std::string::npos) << e.what();
    }
}

TEST(Cutting, BadInputIsReported) {
    const Mesh layer = layer_grid(6, 100.0, kLayerZ);
    const Mesh fault = fault_grid(20.0, 80.0, 3, 0.0, -100.0, 2, kPlane60);
    Mesh bad = layer;
    bad.tri[7] = 1000;
    EXPECT_THROW(cut(bad, fault), std::invalid_argument);
    Mesh badf = fault;
    badf.tri[0] = -1;
    EXPECT_THROW(cut(layer, badf), std::invalid_argument);
    Mesh nan = layer;
    nan.xyz[2] = std::nan("");
    EXPECT_THROW(cut(nan, fault), std::invalid_argument);
    // Clockwise triangles near the fault.
    Mesh cw = layer;
    for (std::size_t t = 0; t < cw.nt(); ++t) std::swap(cw.tri[3 * t + 1], cw.tri[3 * t + 2]);
    EXPECT_THROW(cut(cw, fault), faultmesh::GeometryError);
    CutOptions o;
    o.min_edge_fraction = 0.7;
    EXPECT_THROW(cut(layer, fault, o), std::invalid_argument);
}

}  // namespace
