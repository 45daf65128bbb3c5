// Stitching fault patches into a layer TIN: local overlap + growth, gap
// polygons, ear clipping, local merge. See stitch.hpp for the algorithm.
#include <faultmesh/aabb_tree.hpp>
#include <faultmesh/boundary.hpp>
#include <faultmesh/ear_clipping.hpp>
#include <faultmesh/errors.hpp>
#include <faultmesh/predicates.hpp>
#include <faultmesh/stitch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <utility>

namespace faultmesh {

namespace detail {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr std::size_t kBlock = 8;  // triangles per leaf box of the stitcher's AABB tree

std::string fmt_point(const double* p) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "(%.10g, %.10g)", p[0], p[1]);
    return buf;
}

inline std::int64_t next_h(std::int64_t h) { return h % 3 == 2 ? h - 2 : h + 1; }
inline std::int64_t prev_h(std::int64_t h) { return h % 3 == 0 ? h + 2 : h - 1; }

// ------------------------------------------------------------ exact 2D tests
// True iff p lies on the closed segment [a, b] (exact).
bool on_segment(const double* a, const double* b, const double* p) {
    if (orient2d(a, b, p) != 0.0) return false;
    return std::min(a[0], b[0]) <= p[0] && p[0] <= std::max(a[0], b[0]) &&
           std::min(a[1], b[1]) <= p[1] && p[1] <= std::max(a[1], b[1]);
}

// True iff the closed segments [a, b] and [c, d] share a point (exact).
bool segments_meet(const double* a, const double* b, const double* c, const double* d) {
    const int o1 = orient2d_sign(a, b, c), o2 = orient2d_sign(a, b, d);
    const int o3 = orient2d_sign(c, d, a), o4 = orient2d_sign(c, d, b);
    if (o1 * o2 < 0 && o3 * o4 < 0) return true;
    if (o1 == 0 && on_segment(a, b, c)) return true;
    if (o2 == 0 && on_segment(a, b, d)) return true;
    if (o3 == 0 && on_segment(c, d, a)) return true;
    if (o4 == 0 && on_segment(c, d, b)) return true;
    return false;
}

// True iff p lies in the closed triangle (a, b, c), any orientation, possibly
// degenerate (then: on one of its sides).
bool in_closed_triangle(const double* p, const double* a, const double* b, const double* c) {
    const int o = orient2d_sign(a, b, c);
    if (o == 0) return on_segment(a, b, p) || on_segment(b, c, p) || on_segment(c, a, p);
    const int s1 = orient2d_sign(a, b, p), s2 = orient2d_sign(b, c, p), s3 = orient2d_sign(c, a, p);
    return s1 * o >= 0 && s2 * o >= 0 && s3 * o >= 0;
}

Box2 tri_box(const double* a, const double* b, const double* c) {
    return {std::min(a[0], std::min(b[0], c[0])), std::min(a[1], std::min(b[1], c[1])),
            std::max(a[0], std::max(b[0], c[0])), std::max(a[1], std::max(b[1], c[1]))};
}

// Closed rings in XY (even-odd rule) with an AABB tree over their edges.
class Rings {
public:
    Rings() = default;
    // xy: interleaved points; offsets: n_rings + 1.
    Rings(std::vector<double> xy, std::vector<std::int64_t> offsets)
        : xy_(std::move(xy)), off_(std::move(offsets)) {
        const std::size_t nr = off_.size() - 1;
        for (std::size_t r = 0; r < nr; ++r) {
            const std::int64_t b = off_[r], e = off_[r + 1];
            for (std::int64_t i = b; i < e; ++i) {
                seg_.push_back(i);
                seg_.push_back(i + 1 < e ? i + 1 : b);
            }
        }
        box_ = {kInf, kInf, -kInf, -kInf};
        for (std::size_t i = 0; i < xy_.size() / 2; ++i) {
            box_.xmin = std::min(box_.xmin, xy_[2 * i]);
            box_.xmax = std::max(box_.xmax, xy_[2 * i]);
            box_.ymin = std::min(box_.ymin, xy_[2 * i + 1]);
            box_.ymax = std::max(box_.ymax, xy_[2 * i + 1]);
        }
        tree_ = AabbTree::from_segments(xy_.data(), xy_.size() / 2, 2, seg_.data(), seg_.size() / 2);
    }
    const Box2& box() const { return box_; }
    std::size_t n_rings() const { return off_.size() - 1; }
    const double* pt(std::int64_t i) const { return xy_.data() + 2 * i; }
    std::size_t n_edges() const { return seg_.size() / 2; }
    const double* edge_a(std::size_t e) const { return pt(seg_[2 * e]); }
    const double* edge_b(std::size_t e) const { return pt(seg_[2 * e + 1]); }
    const AabbTree& tree() const { return tree_; }

    // Parity of p (which must not lie on an edge): true = inside.
    bool inside(const double* p) const {
        bool in = false;
        tree_.visit(Box2{p[0], p[1], kInf, p[1]}, [&](std::int64_t e) {
            const double* u = edge_a(static_cast<std::size_t>(e));
            const double* v = edge_b(static_cast<std::size_t>(e));
            const bool uy = u[1] > p[1], vy = v[1] > p[1];
            if (uy == vy) return;
            const double o = orient2d(u, v, p);
            // Upward edge (u below): the edge is right of p iff p is left of u->v.
            if (vy ? o > 0.0 : o < 0.0) in = !in;
        });
        return in;
    }
    // True iff p lies on an edge.
    bool on_edge(const double* p) const {
        bool hit = false;
        tree_.visit(Box2{p[0], p[1], p[0], p[1]}, [&](std::int64_t e) {
            if (!hit && on_segment(edge_a(static_cast<std::size_t>(e)),
                                   edge_b(static_cast<std::size_t>(e)), p))
                hit = true;
        });
        return hit;
    }
    // Euclidean XY distance from p to the nearest edge, if below `limit`
    // (otherwise returns limit).
    double distance(const double* p, double limit) const {
        double best = limit;
        tree_.visit(Box2{p[0] - limit, p[1] - limit, p[0] + limit, p[1] + limit}, [&](std::int64_t e) {
            const double* u = edge_a(static_cast<std::size_t>(e));
            const double* v = edge_b(static_cast<std::size_t>(e));
            const double dx = v[0] - u[0], dy = v[1] - u[1];
            const double L2 = dx * dx + dy * dy;
            double t = L2 > 0.0 ? ((p[0] - u[0]) * dx + (p[1] - u[1]) * dy) / L2 : 0.0;
            t = std::min(1.0, std::max(0.0, t));
            best = std::min(best, std::hypot(p[0] - (u[0] + t * dx), p[1] - (u[1] + t * dy)));
        });
        return best;
    }
    // True iff the closed triangle meets the closed region.
    bool closed_triangle_meets(const double* a, const double* b, const double* c) const {
        const Box2 tb = tri_box(a, b, c);
        if (!boxes_meet(tb, box_)) return false;
        bool hit = false;
        tree_.visit(tb, [&](std::int64_t e) {
            if (hit) return;
            const double* u = edge_a(static_cast<std::size_t>(e));
            const double* v = edge_b(static_cast<std::size_t>(e));
            if (in_closed_triangle(u, a, b, c) || segments_meet(u, v, a, b) ||
                segments_meet(u, v, b, c) || segments_meet(u, v, c, a))
                hit = true;
        });
        if (hit) return true;
        // No boundary contact: the triangle is inside R, or a ring is inside
        // the triangle, or they are disjoint.
        if (inside(a)) return true;
        for (std::size_t r = 0; r < n_rings(); ++r)
            if (off_[r + 1] > off_[r] && in_closed_triangle(pt(off_[r]), a, b, c)) return true;
        return false;
    }

private:
    std::vector<double> xy_;
    std::vector<std::int64_t> off_;
    std::vector<std::int64_t> seg_;
    Box2 box_{};
    AabbTree tree_;
};

double ring_area2(const std::vector<const double*>& pts) {
    // Twice the signed area, relative to the first point (less cancellation
    // at large coordinates).
    double s = 0.0;
    const double* o = pts[0];
    for (std::size_t i = 1; i + 1 < pts.size(); ++i) {
        const double* p = pts[i];
        const double* q = pts[i + 1];
        s += (p[0] - o[0]) * (q[1] - o[1]) - (p[1] - o[1]) * (q[0] - o[0]);
    }
    return s;
}

// Point in polygon (exact parity) for a ring of pointers; p must not be on it.
bool ring_contains(const std::vector<const double*>& ring, const double* p) {
    bool in = false;
    const std::size_t n = ring.size();
    for (std::size_t i = 0; i < n; ++i) {
        const double* u = ring[i];
        const double* v = ring[(i + 1) % n];
        const bool uy = u[1] > p[1], vy = v[1] > p[1];
        if (uy == vy) continue;
        const double o = orient2d(u, v, p);
        if (vy ? o > 0.0 : o < 0.0) in = !in;
    }
    return in;
}

// The study-area boundary: a CCW polygon with arc-length parameters.
struct StudyBoundary {
    std::vector<double> xy;   // k points, CCW
    std::vector<double> cum;  // k + 1 cumulative lengths
    std::vector<double> len;  // k side lengths
    double tol = 0.0;
    Rings rings;

    std::size_t k() const { return len.size(); }
    double perimeter() const { return cum.back(); }

    void init(std::vector<double> pts, double tolerance) {
        for (std::size_t i = 0; i < pts.size(); ++i)
            if (!coordinate_in_range(pts[i]))
                throw_coordinate_error("LayerStitcher", "boundary row " + std::to_string(i / 2), static_cast<int>(i % 2),
                                       pts[i]);
        // Drop a repeated closing point and consecutive duplicates.
        std::vector<double> q;
        const std::size_t n = pts.size() / 2;
        for (std::size_t i = 0; i < n; ++i) {
            if (!q.empty() && q[q.size() - 2] == pts[2 * i] && q[q.size() - 1] == pts[2 * i + 1])
                continue;
            q.push_back(pts[2 * i]);
            q.push_back(pts[2 * i + 1]);
        }
        while (q.size() >= 4 && q[0] == q[q.size() - 2] && q[1] == q[q.size() - 1]) q.resize(q.size() - 2);
        if (q.size() < 6)
            throw std::invalid_argument("LayerStitcher: boundary must have at least 3 distinct points");
        std::vector<const double*> ptrs;
        for (std::size_t i = 0; i < q.size() / 2; ++i) ptrs.push_back(q.data() + 2 * i);
        const double a2 = ring_area2(ptrs);
        if (a2 == 0.0) throw GeometryError("LayerStitcher: the boundary polygon has zero area");
        if (a2 < 0.0) {
            // Reverse to counter-clockwise.
            std::vector<double> r;
            for (std::size_t i = q.size() / 2; i-- > 0;) {
                r.push_back(q[2 * i]);
                r.push_back(q[2 * i + 1]);
            }
            q.swap(r);
        }
        xy = std::move(q);
        const std::size_t kk = xy.size() / 2;
        cum.assign(kk + 1, 0.0);
        len.assign(kk, 0.0);
        double scale = 1.0;
        for (double v : xy) scale = std::max(scale, std::fabs(v));
        for (std::size_t i = 0; i < kk; ++i) {
            const double* a = &xy[2 * i];
            const double* b = &xy[2 * ((i + 1) % kk)];
            len[i] = std::hypot(b[0] - a[0], b[1] - a[1]);
            cum[i + 1] = cum[i] + len[i];
        }
        // Boundary points are computed, not given (densified sides
        // a + t (b - a), trace points converted from (s, z) on a boundary
        // section): each is within a few ulps of the largest coordinate of
        // the exact side, so 64 eps max|c| accepts them with a wide margin
        // while rejecting points 1e-7 m off at UTM magnitudes.
        tol = tolerance >= 0.0 ? tolerance : 64.0 * kEpsilon * scale;
        rings = Rings(xy, std::vector<std::int64_t>{0, static_cast<std::int64_t>(kk)});
    }

    // Sides within tol of p, with the arc parameter along each. A point at a
    // corner is reported once per side and its parameter is snapped to the
    // corner, so that all descriptions of the corner give the same t.
    struct Hit {
        std::size_t side;
        double s;  // along the side, in [0, len]
    };
    void locate(const double* p, std::vector<Hit>& out) const {
        out.clear();
        const Box2 q{p[0] - tol, p[1] - tol, p[0] + tol, p[1] + tol};
        rings.tree().visit(q, [&](std::int64_t e) {
            const std::size_t i = static_cast<std::size_t>(e);
            const double* a = &xy[2 * i];
            const double* b = &xy[2 * ((i + 1) % k())];
            const double dx = b[0] - a[0], dy = b[1] - a[1];
            const double L = len[i];
            double s = ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / L;
            double cx, cy;
            if (s <= 0.0) {
                cx = a[0], cy = a[1];
            } else if (s >= L) {
                cx = b[0], cy = b[1];
            } else {
                cx = a[0] + dx * (s / L), cy = a[1] + dy * (s / L);
            }
            if (std::hypot(p[0] - cx, p[1] - cy) > tol) return;
            if (s <= tol) s = 0.0;
            if (s >= L - tol) s = L;
            out.push_back({i, s});
        });
    }
    double param(const Hit& h) const {
        double t = cum[h.side] + h.s;
        if (h.s == len[h.side]) t = cum[h.side + 1];
        if (t >= perimeter()) t = 0.0;
        return t;
    }
    // Inside or on the study polygon.
    bool contains(const double* p) const {
        std::vector<Hit> hits;
        locate(p, hits);
        if (!hits.empty()) return true;
        return rings.inside(p);
    }
};

}  // namespace

// ---------------------------------------------------------------- state
struct StitcherState {
    std::string name;
    StitchOptions opt;
    std::vector<double> xyz;
    std::vector<std::int64_t> tri;
    std::vector<std::int64_t> adj;   // opposite half-edge or -1
    std::vector<std::int8_t> kind;
    std::vector<std::int64_t> owner;
    std::vector<char> alive;
    std::vector<char> checked;  // base triangles verified (orientation, half-edges)
    std::size_t n_live = 0;
    AabbTree base;
    std::size_t n_base = 0;
    struct Block {
        Box2 box;
        std::int64_t begin, end;
    };
    std::vector<Block> blocks;
    std::unordered_map<std::int64_t, std::vector<std::int64_t>> gap_rows;     // live gaps
    std::unordered_map<std::int64_t, std::vector<std::int64_t>> gap_patches;  // live gaps
    std::int64_t next_gap = 0;
    std::vector<std::string> patch_names;
    StudyBoundary study;
    // Scratch markers with stamps: no O(mesh) clearing per stitch.
    std::vector<std::uint32_t> in_d;
    std::uint32_t stamp = 0;

    std::size_t n_tri() const { return kind.size(); }

    // Verify a base triangle before a stitch relies on it: counter-clockwise
    // with non-zero area in XY, and each half-edge's opposite points back at
    // it with the same two vertices.
    void ensure(std::int64_t r) {
        if (static_cast<std::size_t>(r) >= n_base || checked[static_cast<std::size_t>(r)]) return;
        const std::int64_t* t = &tri[3 * static_cast<std::size_t>(r)];
        if (orient2d(v(t[0]), v(t[1]), v(t[2])) <= 0.0)
            throw GeometryError("LayerStitcher('" + name + "'): triangle row " + std::to_string(r) +
                                " is clockwise or degenerate in XY; the layer mesh must be a "
                                "counter-clockwise TIN");
        for (int k = 0; k < 3; ++k) {
            const std::int64_t h = 3 * r + k, o = adj[static_cast<std::size_t>(h)];
            if (o < 0) continue;
            if (adj[static_cast<std::size_t>(o)] != h || tri[static_cast<std::size_t>(o)] != t[(k + 1) % 3] ||
                tri[static_cast<std::size_t>(next_h(o))] != t[k])
                throw std::invalid_argument("LayerStitcher('" + name + "'): halfedges[" + std::to_string(h) +
                                            "] = " + std::to_string(o) + " is not the opposite half-edge");
        }
        checked[static_cast<std::size_t>(r)] = 1;
    }
    const double* v(std::int64_t i) const { return xyz.data() + 3 * i; }

    void grow_markers() {
        in_d.resize(n_tri(), 0);
    }
    std::uint32_t new_stamp() {
        if (++stamp == 0) {  // wrapped: clear once
            std::fill(in_d.begin(), in_d.end(), 0);
            stamp = 1;
        }
        return stamp;
    }
};

namespace {

std::string patch_label(const StitcherState& s, std::int64_t id) {
    if (id >= 0 && static_cast<std::size_t>(id) < s.patch_names.size())
        return "'" + s.patch_names[static_cast<std::size_t>(id)] + "'";
    return "#" + std::to_string(id);
}

// Opposite half-edges of a triangle list (counting sort by smaller vertex).
std::vector<std::int64_t> build_adjacency(const std::int64_t* tri, std::size_t m, std::size_t n,
                                          const char* fn) {
    const std::size_t nh = 3 * m;
    std::vector<std::int64_t> start(n + 1, 0);
    for (std::size_t h = 0; h < nh; ++h) {
        const std::int64_t a = tri[h], b = tri[next_h(static_cast<std::int64_t>(h))];
        ++start[static_cast<std::size_t>(std::min(a, b)) + 1];
    }
    for (std::size_t i = 0; i < n; ++i) start[i + 1] += start[i];
    std::vector<std::int64_t> bucket(nh), fill(start.begin(), start.end() - 1);
    for (std::size_t h = 0; h < nh; ++h) {
        const std::int64_t a = tri[h], b = tri[next_h(static_cast<std::int64_t>(h))];
        bucket[static_cast<std::size_t>(fill[static_cast<std::size_t>(std::min(a, b))]++)] =
            static_cast<std::int64_t>(h);
    }
    std::vector<std::int64_t> adj(nh, -1);
    for (std::size_t v = 0; v < n; ++v) {
        const std::int64_t b = start[v], e = start[v + 1];
        for (std::int64_t i = b; i < e; ++i) {
            const std::int64_t h = bucket[static_cast<std::size_t>(i)];
            const std::int64_t hf = tri[h], ht = tri[next_h(h)];
            for (std::int64_t j = i + 1; j < e; ++j) {
                const std::int64_t g = bucket[static_cast<std::size_t>(j)];
                const std::int64_t gf = tri[g], gt = tri[next_h(g)];
                if (std::max(gf, gt) != std::max(hf, ht)) continue;
                if (gf == hf)
                    throw GeometryError(std::string(fn) + ": edge (" + std::to_string(hf) + ", " +
                                        std::to_string(ht) + ") is used twice in the same direction "
                                        "(triangles " + std::to_string(h / 3) + " and " +
                                        std::to_string(g / 3) + "): inconsistent orientation");
                if (adj[h] != -1 || adj[g] != -1)
                    throw GeometryError(std::string(fn) + ": edge (" + std::to_string(std::min(hf, ht)) +
                                        ", " + std::to_string(std::max(hf, ht)) +
                                        ") is used by more than two triangles");
                adj[h] = g;
                adj[g] = h;
            }
        }
    }
    return adj;
}

}  // namespace
}  // namespace detail

using detail::StitcherState;

// ---------------------------------------------------------------- ctor
LayerStitcher::LayerStitcher(const double* vertices, std::size_t n_vertices,
                             const std::int64_t* triangles, std::size_t n_triangles,
                             const double* boundary_xy, std::size_t n_boundary,
                             const std::int64_t* halfedges, std::string name,
                             const StitchOptions& options)
    : s_(std::make_unique<StitcherState>()) {
    StitcherState& s = *s_;
    s.name = std::move(name);
    s.opt = options;
    const std::string fn = "LayerStitcher('" + s.name + "')";
    if (n_triangles == 0) throw std::invalid_argument(fn + ": the mesh has no triangles");
    if ((vertices == nullptr && n_vertices) || triangles == nullptr)
        throw std::invalid_argument(fn + ": null array");
    // Room for the patches and gaps to come: appending must not reallocate
    // (and copy) the whole mesh at the first stitch.
    const std::size_t spare_t = n_triangles / 4 + 1024, spare_v = n_vertices / 4 + 1024;
    s.xyz.reserve(3 * (n_vertices + spare_v));
    s.xyz.assign(vertices, vertices + 3 * n_vertices);
    s.tri.reserve(3 * (n_triangles + spare_t));
    s.tri.assign(triangles, triangles + 3 * n_triangles);
    // Eager checks are sequential scans only. What needs random access (the
    // orientation of a triangle, the symmetry of given half-edges) is checked
    // lazily, for each triangle the first time a stitch touches it
    // (StitcherState::ensure): a stitch never relies on an unchecked triangle,
    // and the set-up stays O(mesh) with a small constant.
    for (std::size_t t = 0; t < n_triangles; ++t) {
        const std::int64_t* r = &s.tri[3 * t];
        for (int k = 0; k < 3; ++k)
            if (r[k] < 0 || static_cast<std::size_t>(r[k]) >= n_vertices)
                throw std::invalid_argument(fn + ": triangles row " + std::to_string(t) + " has vertex index " +
                                            std::to_string(r[k]) + " outside [0, " +
                                            std::to_string(n_vertices) + ")");
    }
    // x and y within the coordinate limit of predicates.hpp; z only finite.
    for (std::size_t i = 0; i < 3 * n_vertices; ++i)
        if (i % 3 == 2 ? !std::isfinite(s.xyz[i]) : !coordinate_in_range(s.xyz[i]))
            throw_coordinate_error(fn, "vertices row " + std::to_string(i / 3), static_cast<int>(i % 3), s.xyz[i]);
    s.adj.reserve(3 * (n_triangles + spare_t));
    if (halfedges) {
        s.adj.assign(halfedges, halfedges + 3 * n_triangles);
        const std::int64_t nh = static_cast<std::int64_t>(3 * n_triangles);
        for (std::size_t h = 0; h < 3 * n_triangles; ++h)
            if (s.adj[h] < -1 || s.adj[h] >= nh)
                throw std::invalid_argument(fn + ": halfedges[" + std::to_string(h) + "] = " +
                                            std::to_string(s.adj[h]) + " is outside [-1, " +
                                            std::to_string(nh) + ")");
    } else {
        s.adj = detail::build_adjacency(s.tri.data(), n_triangles, n_vertices, fn.c_str());
        s.adj.reserve(3 * (n_triangles + spare_t));
    }
    s.kind.reserve(n_triangles + spare_t);
    s.kind.assign(n_triangles, static_cast<std::int8_t>(TriangleKind::layer));
    s.owner.reserve(n_triangles + spare_t);
    s.owner.assign(n_triangles, -1);
    s.alive.reserve(n_triangles + spare_t);
    s.alive.assign(n_triangles, 1);
    s.checked.assign(n_triangles, 0);
    s.in_d.reserve(n_triangles + spare_t);
    s.n_live = n_triangles;
    s.n_base = n_triangles;
    // Stage 1 index: an AABB tree over blocks of kBlock consecutive triangles
    // (a Delaunay TIN's rows are spatially coherent: Hilbert-ordered
    // insertion), 1/kBlock of the tree build of one box per triangle; a
    // query then tests the boxes of the block's triangles.
    {
        const std::size_t nb = (n_triangles + detail::kBlock - 1) / detail::kBlock;
        std::vector<Box2> boxes(nb, Box2{detail::kInf, detail::kInf, -detail::kInf, -detail::kInf});
        for (std::size_t t = 0; t < n_triangles; ++t) {
            const std::int64_t* r = &s.tri[3 * t];
            Box2& b = boxes[t / detail::kBlock];
            for (int k = 0; k < 3; ++k) {
                const double* p = s.v(r[k]);
                b.xmin = std::min(b.xmin, p[0]);
                b.ymin = std::min(b.ymin, p[1]);
                b.xmax = std::max(b.xmax, p[0]);
                b.ymax = std::max(b.ymax, p[1]);
            }
        }
        s.base = AabbTree(boxes);
    }
    s.grow_markers();

    std::vector<double> bpts;
    if (boundary_xy && n_boundary) {
        bpts.assign(boundary_xy, boundary_xy + 2 * n_boundary);
    } else {
        // The mesh's own outer boundary: the boundary loop of largest area.
        std::vector<std::int64_t> nxt(n_vertices, -1);
        std::vector<std::int64_t> starts;
        for (std::size_t h = 0; h < s.adj.size(); ++h)
            if (s.adj[h] == -1) {
                nxt[static_cast<std::size_t>(s.tri[h])] = s.tri[detail::next_h(static_cast<std::int64_t>(h))];
                starts.push_back(s.tri[h]);
            }
        double best = 0.0;
        std::vector<char> done(n_vertices, 0);
        for (std::int64_t st : starts) {
            if (done[static_cast<std::size_t>(st)]) continue;
            std::vector<const double*> ring;
            std::vector<double> pts;
            std::int64_t v = st;
            while (v >= 0 && !done[static_cast<std::size_t>(v)]) {
                done[static_cast<std::size_t>(v)] = 1;
                ring.push_back(s.v(v));
                pts.push_back(s.v(v)[0]);
                pts.push_back(s.v(v)[1]);
                v = nxt[static_cast<std::size_t>(v)];
            }
            if (ring.size() < 3) continue;
            const double a = detail::ring_area2(ring);
            if (a > best) {
                best = a;
                bpts = pts;
            }
        }
        if (bpts.empty()) throw GeometryError(fn + ": the mesh has no outer boundary loop");
    }
    s.study.init(std::move(bpts), options.boundary_tolerance);
}

LayerStitcher::~LayerStitcher() = default;
LayerStitcher::LayerStitcher(LayerStitcher&&) noexcept = default;
LayerStitcher& LayerStitcher::operator=(LayerStitcher&&) noexcept = default;

std::size_t LayerStitcher::n_vertices() const { return s_->xyz.size() / 3; }
std::size_t LayerStitcher::n_triangles() const { return s_->n_tri(); }
std::size_t LayerStitcher::n_live_triangles() const { return s_->n_live; }
const std::string& LayerStitcher::name() const { return s_->name; }
const std::vector<std::string>& LayerStitcher::patch_names() const { return s_->patch_names; }

// ---------------------------------------------------------------- stitch
StitchReport LayerStitcher::stitch(const double* pv, std::size_t npv, const std::int64_t* pt,
                                   std::size_t npt, const std::string& patch_name) {
    StitcherState& s = *s_;
    const std::string fn = "stitch: layer '" + s.name + "', patch '" + patch_name + "'";
    if (npt == 0) throw std::invalid_argument(fn + ": the patch has no triangles");
    if (pv == nullptr || pt == nullptr) throw std::invalid_argument(fn + ": null array");
    // All three coordinates: z enters the degeneracy test below.
    for (std::size_t i = 0; i < 3 * npv; ++i)
        if (!coordinate_in_range(pv[i]))
            throw_coordinate_error(fn, "patch_vertices row " + std::to_string(i / 3), static_cast<int>(i % 3), pv[i]);
    std::vector<std::int64_t> ptri(pt, pt + 3 * npt);
    for (std::size_t t = 0; t < npt; ++t)
        for (int k = 0; k < 3; ++k) {
            const std::int64_t i = ptri[3 * t + k];
            if (i < 0 || static_cast<std::size_t>(i) >= npv)
                throw std::invalid_argument(fn + ": patch_triangles row " + std::to_string(t) +
                                            " has vertex index " + std::to_string(i) + " outside [0, " +
                                            std::to_string(npv) + ")");
            // Checked here so that the message names the patch (the outline
            // extraction below would report it as boundary_contours').
            if (i == ptri[3 * t + (k + 1) % 3])
                throw std::invalid_argument(fn + ": patch_triangles row " + std::to_string(t) + " repeats vertex " +
                                            std::to_string(i));
        }
    auto P = [&](std::int64_t i) { return pv + 3 * i; };
    // A triangle whose vertices are collinear in 3D would end up in the layer
    // as a zero-area triangle (fuzzing: a tip point on the line of its trace).
    // Exact: the 3D cross product vanishes iff its three components -- the
    // orientations of the xy, yz and zx projections -- are all zero.
    for (std::size_t t = 0; t < npt; ++t) {
        const double* a = P(ptri[3 * t]);
        const double* b = P(ptri[3 * t + 1]);
        const double* c = P(ptri[3 * t + 2]);
        bool flat = orient2d(a, b, c) == 0.0;
        for (int k = 1; flat && k < 3; ++k) {
            const double pa[2] = {a[k], a[(k + 1) % 3]}, pb[2] = {b[k], b[(k + 1) % 3]}, pc[2] = {c[k], c[(k + 1) % 3]};
            flat = orient2d(pa, pb, pc) == 0.0;
        }
        if (flat)
            throw GeometryError(fn + ": patch_triangles row " + std::to_string(t) +
                                " is degenerate (its vertices are collinear in 3D)");
    }

    StitchReport rep;
    // ---- 1. orientation and outline
    // Each edge-connected component of the patch is oriented on its own so
    // that its signed XY area is positive (its outer outline CCW): the pieces
    // of a fault group may come lofted in opposite directions.
    {
        std::vector<std::int64_t> parent(npt);
        for (std::size_t t = 0; t < npt; ++t) parent[t] = static_cast<std::int64_t>(t);
        auto find = [&](std::int64_t x) {
            while (parent[static_cast<std::size_t>(x)] != x) {
                parent[static_cast<std::size_t>(x)] = parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(x)])];
                x = parent[static_cast<std::size_t>(x)];
            }
            return x;
        };
        std::unordered_map<std::uint64_t, std::int64_t> first;
        first.reserve(3 * npt);
        for (std::size_t t = 0; t < npt; ++t)
            for (int k = 0; k < 3; ++k) {
                const std::int64_t a = ptri[3 * t + k], b = ptri[3 * t + (k + 1) % 3];
                const std::uint64_t key = (static_cast<std::uint64_t>(std::min(a, b)) << 32) ^
                                          static_cast<std::uint64_t>(std::max(a, b));
                auto ins = first.emplace(key, static_cast<std::int64_t>(t));
                if (!ins.second) {
                    const std::int64_t x = find(ins.first->second), y = find(static_cast<std::int64_t>(t));
                    if (x != y) parent[static_cast<std::size_t>(x)] = y;
                }
            }
        std::unordered_map<std::int64_t, double> sum;
        for (std::size_t t = 0; t < npt; ++t)
            sum[find(static_cast<std::int64_t>(t))] +=
                orient2d(P(ptri[3 * t]), P(ptri[3 * t + 1]), P(ptri[3 * t + 2]));
        for (const auto& cs : sum)
            if (cs.second == 0.0)
                throw GeometryError(fn + ": a piece of the patch has zero signed area in XY");
        for (std::size_t t = 0; t < npt; ++t)
            if (sum[find(static_cast<std::int64_t>(t))] < 0.0) {
                std::swap(ptri[3 * t + 1], ptri[3 * t + 2]);
                rep.patch_flipped = true;
            }
    }
    BoundaryContours bc = boundary_contours(ptri.data(), npt, npv);
    if (!bc.nonmanifold_edges.empty())
        throw GeometryError(fn + ": patch edge (" + std::to_string(bc.nonmanifold_edges[0]) + ", " +
                            std::to_string(bc.nonmanifold_edges[1]) + ") is used by more than two triangles");
    if (!bc.inconsistent_edges.empty())
        throw GeometryError(fn + ": patch edge (" + std::to_string(bc.inconsistent_edges[0]) + ", " +
                            std::to_string(bc.inconsistent_edges[1]) +
                            ") is used twice in the same direction (inconsistent orientation)");
    if (!bc.pinch_vertices.empty())
        throw GeometryError(fn + ": patch vertex " + std::to_string(bc.pinch_vertices[0]) + " " +
                            detail::fmt_point(P(bc.pinch_vertices[0])) +
                            " is on the patch outline more than once (pinch)");
    if (!bc.open_chains.empty() || bc.loops.empty())
        throw GeometryError(fn + ": the patch outline does not form closed loops");
    for (std::size_t i = 0; i < npv; ++i)
        if (!s.study.contains(P(static_cast<std::int64_t>(i))))
            throw GeometryError(fn + ": patch vertex " + std::to_string(i) + " " +
                                detail::fmt_point(P(static_cast<std::int64_t>(i))) +
                                " lies outside the study area");

    // Outline edges, classified: on the study boundary (same side) or not.
    struct OEdge {
        std::int64_t a, b;  // patch-local, patch on the left
        bool study;
        std::size_t side;
        double sa, sb;
    };
    std::vector<OEdge> oedges;
    std::vector<double> ring_xy;
    std::vector<std::int64_t> ring_off{0};
    {
        std::unordered_map<std::int64_t, std::vector<detail::StudyBoundary::Hit>> hits;
        std::vector<detail::StudyBoundary::Hit> tmp;
        for (const auto& loop : bc.loops)
            for (std::int64_t vtx : loop) {
                s.study.locate(P(vtx), tmp);
                if (!tmp.empty()) hits[vtx] = tmp;
            }
        for (const auto& loop : bc.loops) {
            for (std::size_t i = 0; i < loop.size(); ++i) {
                const std::int64_t a = loop[i], b = loop[(i + 1) % loop.size()];
                OEdge e{a, b, false, 0, 0.0, 0.0};
                auto ia = hits.find(a), ib = hits.find(b);
                if (ia != hits.end() && ib != hits.end())
                    for (const auto& ha : ia->second)
                        for (const auto& hb : ib->second)
                            if (!e.study && ha.side == hb.side && ha.s != hb.s) {
                                e.study = true;
                                e.side = ha.side;
                                e.sa = ha.s;
                                e.sb = hb.s;
                            }
                oedges.push_back(e);
                ring_xy.push_back(P(a)[0]);
                ring_xy.push_back(P(a)[1]);
            }
            ring_off.push_back(static_cast<std::int64_t>(ring_xy.size() / 2));
        }
    }
    // Simplicity of the outline away from the study boundary.
    {
        std::vector<double> exy(pv, pv + 3 * npv);
        std::vector<std::int64_t> seg;
        for (const auto& e : oedges) {
            seg.push_back(e.a);
            seg.push_back(e.b);
        }
        AabbTree et = AabbTree::from_segments(exy.data(), npv, 3, seg.data(), oedges.size());
        std::vector<std::int64_t> hitsv;
        for (std::size_t i = 0; i < oedges.size(); ++i) {
            const OEdge& e = oedges[i];
            hitsv.clear();
            et.query(et.box(i), hitsv);
            for (std::int64_t j64 : hitsv) {
                const std::size_t j = static_cast<std::size_t>(j64);
                if (j <= i) continue;
                const OEdge& f = oedges[j];
                if (e.study && f.study) continue;
                const double *a = P(e.a), *b = P(e.b), *c = P(f.a), *d = P(f.b);
                std::int64_t shared = -1, ea = -1, fb = -1;
                if (e.a == f.a) shared = e.a, ea = e.b, fb = f.b;
                else if (e.a == f.b) shared = e.a, ea = e.b, fb = f.a;
                else if (e.b == f.a) shared = e.b, ea = e.a, fb = f.b;
                else if (e.b == f.b) shared = e.b, ea = e.a, fb = f.a;
                bool bad;
                if (shared >= 0) {
                    // Adjacent edges may only share their common vertex: bad
                    // if they fold back onto each other (collinear, same side).
                    const double *o = P(shared), *p = P(ea), *q = P(fb);
                    bad = orient2d(o, p, q) == 0.0 &&
                          (p[0] - o[0]) * (q[0] - o[0]) + (p[1] - o[1]) * (q[1] - o[1]) > 0.0;
                } else {
                    bad = detail::segments_meet(a, b, c, d);
                }
                if (bad)
                    throw GeometryError(
                        fn + ": the patch outline is not simple in XY: edges (" + std::to_string(e.a) +
                        ", " + std::to_string(e.b) + ") and (" + std::to_string(f.a) + ", " +
                        std::to_string(f.b) + ") meet near " + detail::fmt_point(a) +
                        " (a reverse fault must end at a pinch-out tip, a zero-throw trace or the "
                        "study-area boundary)");
            }
        }
    }
    detail::Rings region(ring_xy, ring_off);

    // ---- 2. overlap: candidates and exact closed test
    const std::uint32_t stamp = s.new_stamp();
    std::vector<std::int64_t> D;
    std::vector<std::int64_t> merged_gaps;
    std::unordered_set<std::int64_t> merged_gap_set;
    auto add = [&](std::int64_t r) {
        if (s.in_d[static_cast<std::size_t>(r)] == stamp) return;
        s.ensure(r);
        if (s.kind[static_cast<std::size_t>(r)] == static_cast<std::int8_t>(TriangleKind::patch)) return;
        s.in_d[static_cast<std::size_t>(r)] = stamp;
        D.push_back(r);
    };
    auto add_closure = [&](std::size_t from) {
        // Atomic gaps: a triangle of an earlier gap pulls in the whole gap.
        for (std::size_t i = from; i < D.size(); ++i) {
            const std::int64_t r = D[i];
            if (s.kind[static_cast<std::size_t>(r)] != static_cast<std::int8_t>(TriangleKind::gap)) continue;
            const std::int64_t g = s.owner[static_cast<std::size_t>(r)];
            if (!merged_gap_set.insert(g).second) continue;
            merged_gaps.push_back(g);
            for (std::int64_t q : s.gap_rows.at(g)) add(q);
        }
    };
    {
        std::vector<std::int64_t> cand;
        const Box2 rb = region.box();
        s.base.visit(rb, [&](std::int64_t b) {
            const std::size_t r0 = static_cast<std::size_t>(b) * detail::kBlock;
            const std::size_t r1 = std::min(s.n_base, r0 + detail::kBlock);
            for (std::size_t r = r0; r < r1; ++r) {
                const std::int64_t* t = &s.tri[3 * r];
                if (boxes_meet(detail::tri_box(s.v(t[0]), s.v(t[1]), s.v(t[2])), rb))
                    cand.push_back(static_cast<std::int64_t>(r));
            }
        });
        for (const auto& b : s.blocks)
            if (boxes_meet(b.box, region.box()))
                for (std::int64_t r = b.begin; r < b.end; ++r) cand.push_back(r);
        rep.n_candidates = static_cast<std::int64_t>(cand.size());
        std::sort(cand.begin(), cand.end());
        for (std::int64_t r : cand) {
            if (!s.alive[static_cast<std::size_t>(r)]) continue;
            const std::int64_t* t = &s.tri[3 * static_cast<std::size_t>(r)];
            if (!region.closed_triangle_meets(s.v(t[0]), s.v(t[1]), s.v(t[2]))) continue;
            if (s.kind[static_cast<std::size_t>(r)] == static_cast<std::int8_t>(TriangleKind::patch)) {
                throw GeometryError(
                    "stitch: layer '" + s.name + "': fault patch '" + patch_name +
                    "' overlaps (or touches) fault patch " +
                    detail::patch_label(s, s.owner[static_cast<std::size_t>(r)]) +
                    " in XY (triangle " + std::to_string(r) + " of " +
                    detail::patch_label(s, s.owner[static_cast<std::size_t>(r)]) + " near " +
                    detail::fmt_point(s.v(t[0])) + " meets the outline of '" + patch_name +
                    "'); model crossing faults together (same group) or separate them");
            }
            add(r);
        }
        if (D.empty())
            throw GeometryError(fn + ": no triangle of the layer lies under the patch");
        add_closure(0);
    }

    // ---- 3. growth until every component is a disk (holes: earlier patches)
    auto is_in = [&](std::int64_t r) { return r >= 0 && s.in_d[static_cast<std::size_t>(r)] == stamp; };
    // Pull in the free triangles around the vertex that half-edge h0 leaves.
    auto star = [&](std::int64_t h0) {
        for (int dir = 0; dir < 2; ++dir) {
            std::int64_t h = h0;
            for (std::size_t guard = 0; guard < 100000; ++guard) {
                add(h / 3);
                const std::int64_t o = dir == 0 ? s.adj[static_cast<std::size_t>(detail::prev_h(h))]
                                                : s.adj[static_cast<std::size_t>(h)];
                if (o < 0) break;
                h = dir == 0 ? o : detail::next_h(o);
                if (h == h0) break;
            }
        }
    };
    std::vector<std::int64_t> bnd;                       // boundary half-edges of D (D on the left)
    std::unordered_map<std::int64_t, std::int64_t> out;  // vertex -> boundary half-edge leaving it
    std::vector<std::vector<std::int64_t>> loops;
    std::vector<double> loop_area;
    for (int round = 0;; ++round) {
        if (round >= s.opt.max_grow_rounds)
            throw GeometryError(fn + ": the removed region did not become a disk after " +
                                std::to_string(round) + " growth rounds");
        rep.grow_rounds = round + 1;
        const std::size_t before = D.size();
        bnd.clear();
        out.clear();
        std::vector<std::int64_t> pinch;
        for (std::int64_t r : D)
            for (int k = 0; k < 3; ++k) {
                const std::int64_t h = 3 * r + k;
                const std::int64_t o = s.adj[static_cast<std::size_t>(h)];
                if (o >= 0 && is_in(o / 3)) continue;
                bnd.push_back(h);
                if (!out.emplace(s.tri[static_cast<std::size_t>(h)], h).second) pinch.push_back(h);
            }
        if (!pinch.empty()) {
            // A pinch vertex (D meets itself at a vertex) pulls in its star.
            for (std::int64_t h0 : pinch) star(h0);
            add_closure(before);
            if (D.size() == before) {
                const std::int64_t vtx = s.tri[static_cast<std::size_t>(pinch[0])];
                throw GeometryError(fn + ": the removed region meets itself at vertex " +
                                    std::to_string(vtx) + " " + detail::fmt_point(s.v(vtx)) +
                                    " and cannot grow there (an earlier fault patch is in the way)");
            }
            continue;
        }
        // Chain the boundary into loops (each vertex has one leaving half-edge).
        loops.clear();
        loop_area.clear();
        std::unordered_set<std::int64_t> used;
        for (std::int64_t h0 : bnd) {
            if (used.count(h0)) continue;
            std::vector<std::int64_t> loop;
            std::int64_t h = h0;
            while (used.insert(h).second) {
                loop.push_back(h);
                auto it = out.find(s.tri[static_cast<std::size_t>(detail::next_h(h))]);
                if (it == out.end())
                    throw GeometryError(fn + ": internal error: the removed region's boundary is open");
                h = it->second;
            }
            if (h != h0)
                throw GeometryError(fn + ": internal error: the removed region's boundary is not a loop");
            std::vector<const double*> pts;
            for (std::int64_t e : loop) pts.push_back(s.v(s.tri[static_cast<std::size_t>(e)]));
            loop_area.push_back(detail::ring_area2(pts));
            loops.push_back(std::move(loop));
        }
        // Holes of D (clockwise loops): the free triangles they enclose join D;
        // earlier patches stay and become holes of the gap.
        for (std::size_t li = 0; li < loops.size(); ++li) {
            if (loop_area[li] >= 0.0) continue;
            std::vector<std::int64_t> stack, enclosed;
            std::unordered_set<std::int64_t> visited;
            for (std::int64_t h : loops[li]) {
                const std::int64_t o = s.adj[static_cast<std::size_t>(h)];
                if (o < 0)
                    throw GeometryError(fn + ": internal error: a hole of the removed region "
                                        "reaches the mesh boundary");
                if (visited.insert(o / 3).second) stack.push_back(o / 3);
            }
            while (!stack.empty()) {
                const std::int64_t r = stack.back();
                stack.pop_back();
                s.ensure(r);
                enclosed.push_back(r);
                for (int k = 0; k < 3; ++k) {
                    const std::int64_t o = s.adj[static_cast<std::size_t>(3 * r + k)];
                    if (o < 0)
                        throw GeometryError(fn + ": internal error: a hole of the removed region is "
                                            "not enclosed (triangle " + std::to_string(r) +
                                            " reaches the mesh boundary)");
                    const std::int64_t q = o / 3;
                    if (!is_in(q) && visited.insert(q).second) stack.push_back(q);
                }
            }
            for (std::int64_t r : enclosed) add(r);
        }
        if (D.size() == before && s.opt.clearance > 0.0) {
            // Clearance: pull in the star of every boundary vertex of D that
            // lies closer than the clearance to the patch outline.
            for (std::int64_t h0 : bnd) {
                if (s.adj[static_cast<std::size_t>(h0)] < 0) continue;  // study boundary
                const std::int64_t vtx = s.tri[static_cast<std::size_t>(h0)];
                if (region.distance(s.v(vtx), s.opt.clearance) >= s.opt.clearance) continue;
                star(h0);
            }
        }
        if (D.size() == before) break;
        add_closure(before);
    }
    std::sort(D.begin(), D.end());

    // ---- 4. gap polygons
    const std::int64_t nV = static_cast<std::int64_t>(s.xyz.size() / 3);
    const std::int64_t pid = static_cast<std::int64_t>(s.patch_names.size());
    auto X = [&](std::int64_t g) -> const double* { return g < nV ? s.v(g) : P(g - nV); };
    struct GEdge {
        std::int64_t a, b;
        std::int64_t tag;  // patch id whose outline this edge is, or -1
    };
    std::vector<GEdge> gedges;
    std::map<double, std::vector<std::int64_t>> at_t;  // study-boundary position -> vertices
    std::vector<std::pair<double, int>> events;
    const double perim = s.study.perimeter();
    auto tpos = [&](std::size_t side, double sv) {
        return sv == s.study.len[side] ? s.study.cum[side + 1] : s.study.cum[side] + sv;
    };
    auto key_of = [&](double t) { return t >= perim ? 0.0 : t; };
    std::unordered_set<std::uint64_t> study_keys;  // directed gap edges along the study boundary
    auto ekey = [](std::int64_t a, std::int64_t b) {
        return (static_cast<std::uint64_t>(a) << 32) ^ static_cast<std::uint64_t>(b);
    };
    std::unordered_map<std::uint64_t, std::int64_t> dside;  // D interior edge (a,b) -> opposite kept half-edge
    {
        std::vector<detail::StudyBoundary::Hit> ha, hb;
        for (std::int64_t h : bnd) {
            const std::int64_t a = s.tri[static_cast<std::size_t>(h)];
            const std::int64_t b = s.tri[static_cast<std::size_t>(detail::next_h(h))];
            const std::int64_t o = s.adj[static_cast<std::size_t>(h)];
            if (o >= 0) {
                const std::int64_t orow = o / 3;
                const std::int64_t tag =
                    s.kind[static_cast<std::size_t>(orow)] == static_cast<std::int8_t>(TriangleKind::patch)
                        ? s.owner[static_cast<std::size_t>(orow)]
                        : -1;
                gedges.push_back({a, b, tag});
                dside[ekey(a, b)] = o;
                continue;
            }
            s.study.locate(s.v(a), ha);
            s.study.locate(s.v(b), hb);
            bool ok = false;
            for (const auto& x : ha)
                for (const auto& y : hb)
                    if (!ok && x.side == y.side && x.s < y.s) {
                        ok = true;
                        const double t0 = tpos(x.side, x.s), t1 = tpos(y.side, y.s);
                        at_t[key_of(t0)].push_back(a);
                        at_t[key_of(t1)].push_back(b);
                        events.emplace_back(t0, +1);
                        events.emplace_back(t1, -1);
                    }
            if (!ok)
                throw GeometryError(fn + ": mesh boundary edge (" + std::to_string(a) + ", " +
                                    std::to_string(b) + ") near " + detail::fmt_point(s.v(a)) +
                                    " does not run along the study-area boundary");
        }
        for (const auto& e : oedges) {
            const std::int64_t ga = nV + e.a, gb = nV + e.b;
            if (!e.study) {
                gedges.push_back({gb, ga, pid});
                continue;
            }
            const double t0 = tpos(e.side, e.sa), t1 = tpos(e.side, e.sb);
            at_t[key_of(t0)].push_back(ga);
            at_t[key_of(t1)].push_back(gb);
            study_keys.insert(ekey(ga, gb));  // the patch's own boundary edge keeps no neighbour
            if (t0 < t1) {
                events.emplace_back(t0, -1);
                events.emplace_back(t1, +1);
            } else {
                events.emplace_back(t1, +1);
                events.emplace_back(t0, -1);
            }
        }
    }
    if (!events.empty()) {
        std::unordered_set<std::int64_t> chain_ends;
        for (const auto& e : gedges) {
            chain_ends.insert(e.a);
            chain_ends.insert(e.b);
        }
        auto pick = [&](double t) -> std::int64_t {
            auto it = at_t.find(key_of(t));
            if (it == at_t.end()) return -1;
            std::int64_t best = -1;
            int best_score = -1;
            for (std::int64_t vtx : it->second) {
                const int score = (chain_ends.count(vtx) ? 2 : 0) + (vtx >= nV ? 1 : 0);
                if (score > best_score) best = vtx, best_score = score;
            }
            return best;
        };
        std::sort(events.begin(), events.end());
        int cov = 0;
        std::size_t i = 0;
        while (i < events.size()) {
            const double t = events[i].first;
            while (i < events.size() && events[i].first == t) cov += events[i++].second;
            if (cov < 0 || cov > 1)
                throw GeometryError(fn + ": along the study-area boundary the patch is not inside the "
                                    "removed region (coverage " + std::to_string(cov) + " at arc length " +
                                    std::to_string(t) + ")");
            if (cov == 1 && i < events.size()) {
                const double t2 = events[i].first;
                const std::int64_t va = pick(t), vb = pick(t2);
                if (va < 0 || vb < 0 || va == vb)
                    throw GeometryError(fn + ": internal error: no vertex at a gap corner on the study "
                                        "boundary (arc length " + std::to_string(t) + ")");
                gedges.push_back({va, vb, -1});
                study_keys.insert(ekey(va, vb));
            }
        }
        if (cov != 0)
            throw GeometryError(fn + ": internal error: unbalanced coverage along the study boundary");
    }
    // Chain the gap edges into rings.
    std::vector<std::vector<std::int64_t>> rings;  // gap-edge indices
    std::vector<double> ring_area;
    {
        std::unordered_map<std::int64_t, std::size_t> gout;
        std::unordered_map<std::int64_t, int> gin;
        for (std::size_t i = 0; i < gedges.size(); ++i) {
            if (!gout.emplace(gedges[i].a, i).second)
                throw GeometryError(fn + ": the gap polygon touches itself at vertex " +
                                    detail::fmt_point(X(gedges[i].a)) +
                                    " (the fault patch is too close to another patch or to the boundary)");
            if (++gin[gedges[i].b] > 1)
                throw GeometryError(fn + ": the gap polygon touches itself at vertex " +
                                    detail::fmt_point(X(gedges[i].b)));
        }
        std::vector<char> done(gedges.size(), 0);
        for (std::size_t i0 = 0; i0 < gedges.size(); ++i0) {
            if (done[i0]) continue;
            std::vector<std::int64_t> ring;
            std::size_t i = i0;
            while (!done[i]) {
                done[i] = 1;
                ring.push_back(static_cast<std::int64_t>(i));
                auto it = gout.find(gedges[i].b);
                if (it == gout.end())
                    throw GeometryError(fn + ": internal error: the gap boundary is open at vertex " +
                                        detail::fmt_point(X(gedges[i].b)));
                i = it->second;
            }
            if (i != i0) throw GeometryError(fn + ": internal error: the gap boundary is not a loop");
            std::vector<const double*> pts;
            for (std::int64_t e : ring) pts.push_back(X(gedges[static_cast<std::size_t>(e)].a));
            const double a2 = detail::ring_area2(pts);
            if (a2 == 0.0)
                throw GeometryError(fn + ": a gap ring has zero area near " + detail::fmt_point(pts[0]));
            ring_area.push_back(a2);
            rings.push_back(std::move(ring));
        }
    }
    std::vector<std::size_t> outers;
    for (std::size_t r = 0; r < rings.size(); ++r)
        if (ring_area[r] > 0.0) outers.push_back(r);
    std::vector<std::vector<std::size_t>> holes_of(rings.size());
    auto ring_pts = [&](std::size_t r) {
        std::vector<const double*> pts;
        for (std::int64_t e : rings[r]) pts.push_back(X(gedges[static_cast<std::size_t>(e)].a));
        return pts;
    };
    for (std::size_t r = 0; r < rings.size(); ++r) {
        if (ring_area[r] > 0.0) continue;
        const double* p = X(gedges[static_cast<std::size_t>(rings[r][0])].a);
        std::size_t best = rings.size();
        for (std::size_t o : outers)
            if (detail::ring_contains(ring_pts(o), p) && (best == rings.size() || ring_area[o] < ring_area[best]))
                best = o;
        if (best == rings.size())
            throw GeometryError(fn + ": a hole of the gap near " + detail::fmt_point(p) +
                                " lies in no outer ring");
        holes_of[best].push_back(r);
    }

    // ---- 5. ear clipping of each gap polygon (new triangles in local buffers)
    std::vector<std::int64_t> new_tri;  // patch triangles first, then gap triangles
    std::vector<std::int8_t> new_kind;
    std::vector<std::int64_t> new_owner;
    for (std::size_t t = 0; t < npt; ++t) {
        for (int k = 0; k < 3; ++k) new_tri.push_back(nV + ptri[3 * t + k]);
        new_kind.push_back(static_cast<std::int8_t>(TriangleKind::patch));
        new_owner.push_back(pid);
    }
    const std::int64_t row0 = static_cast<std::int64_t>(s.n_tri());
    for (std::size_t o : outers) {
        StitchGap gap;
        gap.id = s.next_gap + static_cast<std::int64_t>(rep.gaps.size());
        std::vector<std::size_t> rs{o};
        rs.insert(rs.end(), holes_of[o].begin(), holes_of[o].end());
        std::vector<std::int64_t> ring_v, ring_off_v{0}, local_to_global;
        std::unordered_map<std::int64_t, std::int64_t> g2l;
        std::vector<double> lxy;
        std::unordered_set<std::int64_t> tags;
        for (std::size_t r : rs) {
            for (std::int64_t e : rings[r]) {
                const GEdge& ge = gedges[static_cast<std::size_t>(e)];
                if (ge.tag >= 0) tags.insert(ge.tag);
                auto ins = g2l.emplace(ge.a, static_cast<std::int64_t>(local_to_global.size()));
                if (ins.second) {
                    local_to_global.push_back(ge.a);
                    lxy.push_back(X(ge.a)[0]);
                    lxy.push_back(X(ge.a)[1]);
                }
                ring_v.push_back(ins.first->second);
            }
            ring_off_v.push_back(static_cast<std::int64_t>(ring_v.size()));
        }
        gap.n_vertices = static_cast<std::int64_t>(ring_v.size());
        gap.n_holes = static_cast<std::int64_t>(rs.size() - 1);
        std::vector<std::int64_t> lt = triangulate_polygon_indexed(
            lxy.data(), local_to_global.size(), ring_v.data(), ring_off_v.data(), rs.size(), s.opt.ear_clip);
        const std::int64_t want = gap.n_vertices + 2 * gap.n_holes - 2;
        if (static_cast<std::int64_t>(lt.size() / 3) != want) {
            PolygonCheck pc = check_polygon(lxy.data(), local_to_global.size(), ring_v.data(),
                                            ring_off_v.data(), rs.size());
            throw GeometryError(fn + ": ear clipping the gap polygon (n = " + std::to_string(gap.n_vertices) +
                                ", h = " + std::to_string(gap.n_holes) + ") gave " +
                                std::to_string(lt.size() / 3) + " triangles instead of " +
                                std::to_string(want) +
                                (pc.valid ? std::string("") : "; the gap polygon is invalid: " + pc.message));
        }
        for (std::size_t t = 0; t < lt.size() / 3; ++t) {
            gap.triangles.push_back(row0 + static_cast<std::int64_t>(new_kind.size()));
            for (int k = 0; k < 3; ++k)
                new_tri.push_back(local_to_global[static_cast<std::size_t>(lt[3 * t + k])]);
            new_kind.push_back(static_cast<std::int8_t>(TriangleKind::gap));
            new_owner.push_back(gap.id);
        }
        gap.patches.assign(tags.begin(), tags.end());
        std::sort(gap.patches.begin(), gap.patches.end());
        rep.gaps.push_back(std::move(gap));
    }
    for (std::int64_t g : merged_gaps) {
        // Give each swallowed gap to the new gap that holds one of its patches.
        const auto& pp = s.gap_patches.at(g);
        for (auto& gap : rep.gaps)
            if (std::any_of(pp.begin(), pp.end(), [&](std::int64_t q) {
                    return std::binary_search(gap.patches.begin(), gap.patches.end(), q);
                })) {
                gap.merged_gaps.push_back(g);
                break;
            }
    }

    // Adjacency of the new triangles (local first: nothing changes on error).
    const std::size_t nnew = new_kind.size();
    std::vector<std::int64_t> new_adj(3 * nnew, -1);
    std::vector<std::pair<std::int64_t, std::int64_t>> relink;  // kept half-edge -> new half-edge
    {
        std::unordered_map<std::uint64_t, std::int64_t> hmap;
        hmap.reserve(6 * nnew);
        for (std::size_t h = 0; h < 3 * nnew; ++h) {
            const std::int64_t a = new_tri[h], b = new_tri[static_cast<std::size_t>(detail::next_h(static_cast<std::int64_t>(h)))];
            if (!hmap.emplace(ekey(a, b), static_cast<std::int64_t>(h)).second)
                throw GeometryError(fn + ": internal error: edge (" + std::to_string(a) + ", " +
                                    std::to_string(b) + ") is used twice in the same direction");
        }
        for (std::size_t h = 0; h < 3 * nnew; ++h) {
            const std::int64_t a = new_tri[h], b = new_tri[static_cast<std::size_t>(detail::next_h(static_cast<std::int64_t>(h)))];
            auto tw = hmap.find(ekey(b, a));
            if (tw != hmap.end()) {
                new_adj[h] = row0 * 3 + tw->second;
                continue;
            }
            auto ds = dside.find(ekey(a, b));
            if (ds != dside.end()) {
                new_adj[h] = ds->second;
                relink.emplace_back(ds->second, row0 * 3 + static_cast<std::int64_t>(h));
                continue;
            }
            if (!study_keys.count(ekey(a, b)))
                throw GeometryError(fn + ": internal error: new edge (" + std::to_string(a) + ", " +
                                    std::to_string(b) + ") near " + detail::fmt_point(X(a)) +
                                    " has no neighbour and is not on the study boundary");
        }
        if (relink.size() != dside.size())
            throw GeometryError(fn + ": internal error: " + std::to_string(dside.size() - relink.size()) +
                                " edges of the hole are not covered by the gap");
    }

    // ---- 6. commit
    s.xyz.insert(s.xyz.end(), pv, pv + 3 * npv);
    Box2 box{detail::kInf, detail::kInf, -detail::kInf, -detail::kInf};
    for (std::int64_t vtx : new_tri) {
        const double* p = X(vtx);
        box.xmin = std::min(box.xmin, p[0]);
        box.ymin = std::min(box.ymin, p[1]);
        box.xmax = std::max(box.xmax, p[0]);
        box.ymax = std::max(box.ymax, p[1]);
    }
    s.tri.insert(s.tri.end(), new_tri.begin(), new_tri.end());
    s.adj.insert(s.adj.end(), new_adj.begin(), new_adj.end());
    for (const auto& rl : relink) s.adj[static_cast<std::size_t>(rl.first)] = rl.second;
    s.kind.insert(s.kind.end(), new_kind.begin(), new_kind.end());
    s.owner.insert(s.owner.end(), new_owner.begin(), new_owner.end());
    s.alive.insert(s.alive.end(), nnew, 1);
    for (std::int64_t r : D) s.alive[static_cast<std::size_t>(r)] = 0;
    s.n_live = s.n_live + nnew - D.size();
    s.blocks.push_back({box, row0, row0 + static_cast<std::int64_t>(nnew)});
    for (std::int64_t g : merged_gaps) {
        s.gap_rows.erase(g);
        s.gap_patches.erase(g);
    }
    for (const auto& gap : rep.gaps) {
        s.gap_rows[gap.id] = gap.triangles;
        s.gap_patches[gap.id] = gap.patches;
    }
    s.next_gap += static_cast<std::int64_t>(rep.gaps.size());
    s.patch_names.push_back(patch_name);
    s.grow_markers();

    rep.patch_id = pid;
    rep.patch_vertex_offset = nV;
    rep.patch_triangle_offset = row0;
    rep.removed = std::move(D);
    rep.merged_gaps = std::move(merged_gaps);
    return rep;
}

// ---------------------------------------------------------------- export
StitchedMesh LayerStitcher::mesh() const {
    const StitcherState& s = *s_;
    StitchedMesh m;
    const std::size_t nv = s.xyz.size() / 3, nt = s.n_tri();
    m.vertex_map.assign(nv, -1);
    m.triangle_map.assign(nt, -1);
    std::int64_t next_v = 0, next_t = 0;
    for (std::size_t r = 0; r < nt; ++r) {
        if (!s.alive[r]) continue;
        m.triangle_map[r] = next_t++;
        for (int k = 0; k < 3; ++k) {
            const std::size_t vtx = static_cast<std::size_t>(s.tri[3 * r + k]);
            if (m.vertex_map[vtx] < 0) m.vertex_map[vtx] = next_v++;
        }
    }
    // Keep the original vertex order (stable): renumber by increasing old index.
    next_v = 0;
    for (std::size_t i = 0; i < nv; ++i)
        if (m.vertex_map[i] >= 0) m.vertex_map[i] = next_v++;
    m.vertices.reserve(3 * static_cast<std::size_t>(next_v));
    for (std::size_t i = 0; i < nv; ++i)
        if (m.vertex_map[i] >= 0) m.vertices.insert(m.vertices.end(), &s.xyz[3 * i], &s.xyz[3 * i] + 3);
    m.triangles.reserve(3 * static_cast<std::size_t>(next_t));
    m.kinds.reserve(static_cast<std::size_t>(next_t));
    m.owners.reserve(static_cast<std::size_t>(next_t));
    for (std::size_t r = 0; r < nt; ++r) {
        if (!s.alive[r]) continue;
        for (int k = 0; k < 3; ++k) m.triangles.push_back(m.vertex_map[static_cast<std::size_t>(s.tri[3 * r + k])]);
        m.kinds.push_back(s.kind[r]);
        m.owners.push_back(s.owner[r]);
    }
    return m;
}

StitchResult stitch(const double* vertices, std::size_t n_vertices, const std::int64_t* triangles,
                    std::size_t n_triangles, const double* patch_vertices, std::size_t n_patch_vertices,
                    const std::int64_t* patch_triangles, std::size_t n_patch_triangles,
                    const double* boundary_xy, std::size_t n_boundary, const StitchOptions& options) {
    LayerStitcher st(vertices, n_vertices, triangles, n_triangles, boundary_xy, n_boundary, nullptr,
                     "layer", options);
    StitchResult res;
    res.report = st.stitch(patch_vertices, n_patch_vertices, patch_triangles, n_patch_triangles, "patch");
    res.mesh = st.mesh();
    for (std::size_t r = 0; r < res.mesh.kinds.size(); ++r)
        if (res.mesh.kinds[r] == static_cast<std::int8_t>(TriangleKind::gap))
            res.gap_rows.push_back(static_cast<std::int64_t>(r));
    return res;
}

std::vector<std::int64_t> triangles_touching_region(const double* vertices, std::size_t n_vertices,
                                                    std::size_t stride, const std::int64_t* triangles,
                                                    std::size_t n_triangles, const double* ring_xy,
                                                    const std::int64_t* ring_offsets, std::size_t n_rings) {
    const char* fn = "triangles_touching_region";
    if (stride != 2 && stride != 3) throw std::invalid_argument(std::string(fn) + ": stride must be 2 or 3");
    if (n_rings == 0) return {};
    if (ring_offsets[0] != 0) throw std::invalid_argument(std::string(fn) + ": ring_offsets[0] must be 0");
    for (std::size_t r = 0; r < n_rings; ++r)
        if (ring_offsets[r + 1] < ring_offsets[r])
            throw std::invalid_argument(std::string(fn) + ": ring_offsets must be non-decreasing");
    const std::size_t np = static_cast<std::size_t>(ring_offsets[n_rings]);
    std::vector<double> xy(ring_xy, ring_xy + 2 * np);
    for (std::size_t i = 0; i < xy.size(); ++i)
        if (!coordinate_in_range(xy[i]))
            throw_coordinate_error(fn, "ring point " + std::to_string(i / 2), static_cast<int>(i % 2), xy[i]);
    std::vector<std::int64_t> off(ring_offsets, ring_offsets + n_rings + 1);
    detail::Rings region(std::move(xy), std::move(off));
    std::vector<std::int64_t> out;
    for (std::size_t t = 0; t < n_triangles; ++t) {
        const std::int64_t* r = triangles + 3 * t;
        for (int k = 0; k < 3; ++k)
            if (r[k] < 0 || static_cast<std::size_t>(r[k]) >= n_vertices)
                throw std::invalid_argument(std::string(fn) + ": triangles row " + std::to_string(t) +
                                            " has vertex index " + std::to_string(r[k]) + " outside [0, " +
                                            std::to_string(n_vertices) + ")");
        const double* a = vertices + stride * static_cast<std::size_t>(r[0]);
        const double* b = vertices + stride * static_cast<std::size_t>(r[1]);
        const double* c = vertices + stride * static_cast<std::size_t>(r[2]);
        for (const double* p : {a, b, c})
            for (int k = 0; k < 2; ++k)
                if (!coordinate_in_range(p[k]))
                    throw_coordinate_error(fn, "vertices row " + std::to_string((p - vertices) / static_cast<std::ptrdiff_t>(stride)) +
                                               " (used by triangles row " + std::to_string(t) + ")", k, p[k]);
        if (region.closed_triangle_meets(a, b, c)) out.push_back(static_cast<std::int64_t>(t));
    }
    return out;
}

}  // namespace faultmesh
