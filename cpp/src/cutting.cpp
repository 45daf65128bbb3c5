// The surface-cutting baseline (see cutting.hpp for the method and its rules).
#include <faultmesh/cutting.hpp>

#include <faultmesh/aabb_tree.hpp>
#include <faultmesh/ear_clipping.hpp>
#include <faultmesh/errors.hpp>
#include <faultmesh/predicates.hpp>
#include <faultmesh/segments.hpp>
#include <faultmesh/triangle_adjacency.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "linear_interpolation.hpp"
#include "owned_boundary.hpp"

namespace faultmesh {
namespace detail {
namespace {

using Index = std::int64_t;

[[noreturn]] void geometry_error(const std::string& what) {
    throw GeometryError("cut_layer: " + what);
}

// The fault surface as a function F(x, y) over (and a little beyond) its XY
// projection.
class FaultField {
public:
    FaultField(const double* xyz, std::size_t n, const Index* tri, std::size_t m)
        : xyz_(xyz), tri_(tri) {
        // Triangles with a zero-area projection (vertical pieces) carry no
        // height field; they are left out of the location structure.
        std::vector<Box2> boxes;
        for (std::size_t t = 0; t < m; ++t) {
            const double* a = xyz + 3 * tri[3 * t];
            const double* b = xyz + 3 * tri[3 * t + 1];
            const double* c = xyz + 3 * tri[3 * t + 2];
            const double o = orient2d(a, b, c);
            if (o == 0.0) continue;
            live_.push_back(static_cast<Index>(t));
            boxes.push_back({std::min({a[0], b[0], c[0]}), std::min({a[1], b[1], c[1]}),
                             std::max({a[0], b[0], c[0]}), std::max({a[1], b[1], c[1]})});
            bounds_.xmin = std::min(bounds_.xmin, boxes.back().xmin);
            bounds_.ymin = std::min(bounds_.ymin, boxes.back().ymin);
            bounds_.xmax = std::max(bounds_.xmax, boxes.back().xmax);
            bounds_.ymax = std::max(bounds_.ymax, boxes.back().ymax);
        }
        tree_ = AabbTree(boxes);
        // Boundary edges of the live triangles, with the triangle that owns
        // them: the planes that extend F beyond its projection.
        boundary_ = OwnedBoundary(owned_boundary_edges(tri, live_), [this](Index w) { return xyz_ + 3 * w; });
        (void)n;
    }

    bool empty() const { return live_.empty(); }
    const Box2& bounds() const { return bounds_; }

    // F at p (x, y); `inside` tells whether p is in F's closed projection, or
    // within `tol` (XY distance) of it.
    double z_at(const double* p, bool& inside, double tol = 0.0) const {
        Index best = -1;
        const Box2 q{p[0], p[1], p[0], p[1]};
        tree_.visit(q, [&](std::int64_t k) {
            const Index t = live_[static_cast<std::size_t>(k)];
            if (best >= 0 && t >= best) return;  // smallest containing index wins: deterministic
            if (contains(t, p)) best = t;
        });
        inside = best >= 0;
        if (inside) {
            // In the closed triangle: a convex combination of its z (exact
            // predicates, see linear_interpolation.hpp).
            return interpolate_in_triangle(v(best, 0), v(best, 1), v(best, 2), p, v(best, 0)[2], v(best, 1)[2],
                                           v(best, 2)[2]);
        }
        double d2 = 0.0;
        best = nearest_boundary_triangle(p, d2);
        inside = d2 <= tol * tol;
        return plane_z(best, p);
    }

private:
    const double* v(Index t, int i) const { return xyz_ + 3 * tri_[3 * t + i]; }

    bool contains(Index t, const double* p) const { return in_closed_triangle(p, v(t, 0), v(t, 1), v(t, 2)); }

    // Linear extrapolation (p outside t) in the plane of triangle t, by
    // barycentric weights from the three sub-areas.
    double plane_z(Index t, const double* p) const {
        const double* a = v(t, 0);
        const double* b = v(t, 1);
        const double* c = v(t, 2);
        const double wa = orient2d(b, c, p), wb = orient2d(c, a, p), wc = orient2d(a, b, p);
        const double area = orient2d(a, b, c);  // non-zero: t is live
        return (wa * a[2] + wb * b[2] + wc * c[2]) / area;
    }

    Index nearest_boundary_triangle(const double* p, double& best) const {
        return boundary_.nearest_owner(p, live_.front(), best);
    }

    const double* xyz_;
    const Index* tri_;
    std::vector<Index> live_;
    OwnedBoundary boundary_;
    AabbTree tree_;
    Box2 bounds_{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
                 -std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
};

struct Edge {
    Index a, b;           // vertex indices, a < b
    bool crossed = false;  // end points on different sides
    bool active = false;   // crossing point inside the fault's projection
    bool border = false;   // an edge of a single triangle: the layer's boundary
    double t = 0.0;        // crossing parameter from a to b
    double p[3] = {0, 0, 0};
    Index point = -1;      // index of the line point placed on this edge
};

void check_input(const double* xyz, std::size_t n, const Index* tri, std::size_t m, const char* vname,
                 const char* tname) {
    for (std::size_t t = 0; t < m; ++t)
        for (int i = 0; i < 3; ++i) {
            const Index v = tri[3 * t + i];
            if (v < 0 || static_cast<std::size_t>(v) >= n)
                throw std::invalid_argument("cut_layer: " + std::string(tname) + " row " + std::to_string(t) +
                                            " has vertex index " + std::to_string(v) + " outside [0, " +
                                            std::to_string(n) + ")");
            // z enters the side tests and the crossing points: all three are checked.
            const double* q = xyz + 3 * v;
            for (int k = 0; k < 3; ++k)
                if (!coordinate_in_range(q[k]))
                    throw_coordinate_error("cut_layer", std::string(vname) + " row " + std::to_string(v), k, q[k]);
        }
}

}  // namespace
}  // namespace detail

CutResult cut_layer(const double* layer_xyz, std::size_t n_layer_vertices, const std::int64_t* layer_triangles,
                    std::size_t n_layer_triangles, const double* fault_xyz, std::size_t n_fault_vertices,
                    const std::int64_t* fault_triangles, std::size_t n_fault_triangles,
                    const CutOptions& options) {
    using namespace detail;
    using Index = std::int64_t;
    check_input(layer_xyz, n_layer_vertices, layer_triangles, n_layer_triangles, "layer_vertices",
                "layer_triangles");
    check_input(fault_xyz, n_fault_vertices, fault_triangles, n_fault_triangles, "fault_vertices",
                "fault_triangles");
    if (!(options.min_edge_fraction >= 0.0 && options.min_edge_fraction < 0.5))
        throw std::invalid_argument("cut_layer: min_edge_fraction must be in [0, 0.5), got " +
                                    std::to_string(options.min_edge_fraction));
    if (!std::isfinite(options.displacement) || std::isnan(options.taper_length))
        throw std::invalid_argument("cut_layer: displacement and taper_length must be finite numbers");
    if (!(options.extension >= 0.0) || !std::isfinite(options.extension))
        throw std::invalid_argument("cut_layer: extension must be a finite number >= 0, got " +
                                    std::to_string(options.extension));

    CutResult out;
    out.vertices.assign(layer_xyz, layer_xyz + 3 * n_layer_vertices);
    auto unchanged = [&]() {
        out.triangles.assign(layer_triangles, layer_triangles + 3 * n_layer_triangles);
        out.line_offsets = {0};
        return out;
    };
    if (n_fault_triangles == 0 || n_layer_triangles == 0) return unchanged();
    FaultField field(fault_xyz, n_fault_vertices, fault_triangles, n_fault_triangles);
    if (field.empty()) return unchanged();  // a vertical fault has no projection: nothing to cut

    const Index* T = layer_triangles;
    const double* V = layer_xyz;
    auto vx = [&](Index v) { return V + 3 * v; };

    // ---- 1. Examined triangles: XY box meets the fault's XY box. Every
    // triangle that holds an active crossing point does (the point is in the
    // fault's projection), so nothing outside this set can be cut or split.
    Box2 fb = field.bounds();
    fb.xmin -= options.extension;
    fb.ymin -= options.extension;
    fb.xmax += options.extension;
    fb.ymax += options.extension;
    std::vector<Index> cand;
    for (std::size_t t = 0; t < n_layer_triangles; ++t) {
        const double* a = vx(T[3 * t]);
        const double* b = vx(T[3 * t + 1]);
        const double* c = vx(T[3 * t + 2]);
        const Box2 bt{std::min({a[0], b[0], c[0]}), std::min({a[1], b[1], c[1]}), std::max({a[0], b[0], c[0]}),
                      std::max({a[1], b[1], c[1]})};
        if (boxes_meet(bt, fb)) cand.push_back(static_cast<Index>(t));
    }
    out.n_examined_triangles = cand.size();
    const std::size_t nc = cand.size();
    for (std::size_t k = 0; k < nc; ++k) {
        const Index t = cand[k];
        if (orient2d(vx(T[3 * t]), vx(T[3 * t + 1]), vx(T[3 * t + 2])) <= 0.0)
            geometry_error("layer triangle row " + std::to_string(t) +
                           " near the fault is not counter-clockwise in XY (or has zero area)");
    }

    // ---- 2. Sides of the examined triangles' vertices.
    std::vector<Index> verts;
    verts.reserve(3 * nc);
    for (Index t : cand)
        for (int i = 0; i < 3; ++i) verts.push_back(T[3 * t + i]);
    std::sort(verts.begin(), verts.end());
    verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
    out.n_classified_vertices = verts.size();
    std::vector<double> dval(verts.size());
    auto local = [&](Index v) {
        return static_cast<std::size_t>(std::lower_bound(verts.begin(), verts.end(), v) - verts.begin());
    };
    for (std::size_t i = 0; i < verts.size(); ++i) {
        bool inside = false;
        const double* p = vx(verts[i]);
        dval[i] = p[2] - field.z_at(p, inside);
    }

    // ---- 3. Local edges and adjacency of the examined triangles: the twins
    // (triangle_adjacency.hpp) of the examined triangles with their vertices
    // numbered locally; nbr[3 k + i] is the half-edge slot across, -1 if none.
    std::vector<Index> lt(3 * nc);
    for (std::size_t k = 0; k < nc; ++k)
        for (int i = 0; i < 3; ++i) lt[3 * k + i] = static_cast<Index>(local(T[3 * cand[k] + i]));
    AdjacencyLabels labels;
    labels.vertex_ids = verts.data();
    labels.row_ids = cand.data();
    labels.edge_word = "layer edge";
    const std::vector<Index> nbr =
        halfedge_twins(lt.data(), nc, verts.size(), EdgeOrientation::consistent, "cut_layer", labels);
    // One Edge per undirected edge, ordered by its (smaller, larger) vertex.
    std::vector<Edge> edges;
    std::vector<Index> edge_of(3 * nc, -1);
    for (std::size_t h = 0; h < 3 * nc; ++h) {
        if (nbr[h] >= 0 && nbr[h] < static_cast<Index>(h)) continue;
        const Index a = T[3 * cand[h / 3] + h % 3], b = T[3 * cand[h / 3] + (h % 3 + 1) % 3];
        Edge e;
        e.a = std::min(a, b);
        e.b = std::max(a, b);
        e.border = nbr[h] < 0;
        edge_of[h] = static_cast<Index>(edges.size());
        if (nbr[h] >= 0) edge_of[static_cast<std::size_t>(nbr[h])] = edge_of[h];
        edges.push_back(e);
    }
    {
        std::vector<Index> order(edges.size()), rank(edges.size());
        std::iota(order.begin(), order.end(), Index{0});
        std::sort(order.begin(), order.end(), [&](Index x, Index y) {
            return edges[x].a != edges[y].a ? edges[x].a < edges[y].a : edges[x].b < edges[y].b;
        });
        std::vector<Edge> sorted(edges.size());
        for (std::size_t i = 0; i < order.size(); ++i) {
            sorted[i] = edges[order[i]];
            rank[order[i]] = static_cast<Index>(i);
        }
        edges.swap(sorted);
        for (Index& e : edge_of) e = rank[e];
    }

    auto hanging = [&](Index v) { return dval[local(v)] > 0.0; };

    // ---- 4. Crossing points on the edges whose end points differ in side.
    const double frac = options.min_edge_fraction;
    // A crossing point on a line that also carries an edge of the fault's
    // outline (a fault cut off by the study-area boundary: both meshes have
    // edges on the boundary side) lands a few ulps off that edge, on either
    // side. 2^-40 of the coordinates' magnitude (4 micrometres at 4e6 m) is
    // far above such rounding and far below any modelling distance; a point
    // that close to the fault's projection counts as inside it.
    const double on_fault_tol =
        std::ldexp(std::max({std::fabs(fb.xmin), std::fabs(fb.xmax), std::fabs(fb.ymin), std::fabs(fb.ymax), 1.0}),
                   -40);
    for (Edge& e : edges) {
        const bool ha = hanging(e.a), hb = hanging(e.b);
        if (ha == hb) continue;
        e.crossed = true;
        const double* a = vx(e.a);
        const double* b = vx(e.b);
        auto g = [&](double t, bool& inside) {
            const double p[2] = {a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])};
            return (a[2] + t * (b[2] - a[2])) - field.z_at(p, inside);
        };
        // Illinois regula falsi on g, bracketed by the end-point sides.
        double lo = 0.0, hi = 1.0, glo = dval[local(e.a)], ghi = dval[local(e.b)];
        int stale = 0;  // which end stayed put last time: +1 lo, -1 hi
        double t = 0.5;
        for (int it = 0; it < 80 && hi - lo > 1e-13; ++it) {
            t = (glo != ghi) ? (lo * ghi - hi * glo) / (ghi - glo) : 0.5 * (lo + hi);
            if (!(t > lo && t < hi) || it % 8 == 7) t = 0.5 * (lo + hi);  // bisection keeps it safe
            bool inside = false;
            const double gt = g(t, inside);
            if ((gt > 0.0) == (glo > 0.0)) {
                lo = t;
                glo = gt;
                if (stale == -1) ghi *= 0.5;
                stale = -1;
            } else {
                hi = t;
                ghi = gt;
                if (stale == +1) glo *= 0.5;
                stale = +1;
            }
            if (gt == 0.0) break;
        }
        t = std::clamp(t, frac, 1.0 - frac);
        e.t = t;
        for (int c = 0; c < 3; ++c) e.p[c] = a[c] + t * (b[c] - a[c]);
        bool inside = false;
        field.z_at(e.p, inside, on_fault_tol + (e.border ? options.extension : 0.0));
        e.active = inside;
    }

    // ---- 5. Cut triangles (both sign-change edges active) and chains.
    std::vector<char> in_r(nc, 0);
    std::vector<std::vector<Index>> r_of_edge(edges.size());
    for (std::size_t k = 0; k < nc; ++k) {
        int crossed = 0, active = 0;
        for (int i = 0; i < 3; ++i) {
            const Edge& e = edges[edge_of[3 * k + i]];
            crossed += e.crossed;
            active += e.crossed && e.active;
        }
        if (crossed == 2 && active == 2) {
            in_r[k] = 1;
            for (int i = 0; i < 3; ++i)
                if (edges[edge_of[3 * k + i]].crossed) r_of_edge[edge_of[3 * k + i]].push_back(static_cast<Index>(k));
        }
    }
    auto other_crossed = [&](std::size_t k, Index e) {
        for (int i = 0; i < 3; ++i) {
            const Index f = edge_of[3 * k + i];
            if (f != e && edges[f].crossed) return f;
        }
        return Index{-1};
    };
    struct Chain {
        std::vector<Index> edges;  // crossing edges in order
        std::vector<Index> tris;   // examined-triangle slots between consecutive edges
    };
    std::vector<Chain> chains;
    std::vector<char> used(nc, 0);
    for (std::size_t e0 = 0; e0 < edges.size(); ++e0) {
        if (r_of_edge[e0].size() != 1 || used[r_of_edge[e0][0]]) continue;
        Chain ch;
        Index e = static_cast<Index>(e0);
        std::size_t k = static_cast<std::size_t>(r_of_edge[e0][0]);
        ch.edges.push_back(e);
        while (true) {
            used[k] = 1;
            ch.tris.push_back(static_cast<Index>(k));
            e = other_crossed(k, e);
            ch.edges.push_back(e);
            const auto& rs = r_of_edge[e];
            if (rs.size() == 1) break;
            const std::size_t next = static_cast<std::size_t>(rs[0] == static_cast<Index>(k) ? rs[1] : rs[0]);
            if (used[next]) geometry_error("intersection line visits layer triangle row " +
                                           std::to_string(cand[next]) + " twice");
            k = next;
        }
        chains.push_back(std::move(ch));
    }
    for (std::size_t k = 0; k < nc; ++k)
        if (in_r[k] && !used[k])
            geometry_error("the intersection line with the fault closes on itself (through layer triangle row " +
                           std::to_string(cand[k]) + "); closed lines are not supported");
    if (chains.empty()) return unchanged();

    // Orientation: hanging wall on the left. In a counter-clockwise triangle
    // (v0, v1, v2) whose odd vertex (the one alone on its side) is v_i, a line
    // that enters through edge (v_{i-1}, v_i) and leaves through (v_i, v_{i+1})
    // has v_i on its right -- a topological rule, no arithmetic.
    for (Chain& ch : chains) {
        const Index t = cand[ch.tris[0]];
        int odd = 0;
        for (int i = 0; i < 3; ++i) {
            const bool hi = hanging(T[3 * t + i]);
            if (hi != hanging(T[3 * t + (i + 1) % 3]) && hi != hanging(T[3 * t + (i + 2) % 3])) odd = i;
        }
        const Index prev_edge = edge_of[3 * ch.tris[0] + (odd + 2) % 3];  // (v_{i-1}, v_i)
        const bool odd_right = ch.edges[0] == prev_edge;
        const bool hanging_right = hanging(T[3 * t + odd]) ? odd_right : !odd_right;
        if (hanging_right) {
            std::reverse(ch.edges.begin(), ch.edges.end());
            std::reverse(ch.tris.begin(), ch.tris.end());
        }
    }

    // ---- 6. Line vertices: a footwall and a hanging-wall copy per point, one
    // shared vertex at a tip. A chain end is a tip iff an (uncut) triangle lies
    // across its edge; that triangle is split at the tip.
    auto across = [&](Index e, std::size_t r_tri) -> Index {  // examined slot across edge e from r_tri, or -1
        for (int i = 0; i < 3; ++i)
            if (edge_of[3 * r_tri + i] == e) {
                const Index h = nbr[3 * r_tri + i];
                return h < 0 ? -1 : h / 3;
            }
        return -1;
    };
    std::vector<Index> foot_of_edge(edges.size(), -1), hang_of_edge(edges.size(), -1);
    std::vector<std::pair<Index, Index>> splits;  // (examined slot of the tip triangle, edge)
    out.line_offsets.push_back(0);
    for (const Chain& ch : chains) {
        const std::size_t np = ch.edges.size();
        const Index across0 = across(ch.edges.front(), static_cast<std::size_t>(ch.tris.front()));
        const Index across1 = across(ch.edges.back(), static_cast<std::size_t>(ch.tris.back()));
        const bool tip0 = across0 >= 0, tip1 = across1 >= 0;
        if (tip0) splits.push_back({across0, ch.edges.front()});
        if (tip1) splits.push_back({across1, ch.edges.back()});
        std::vector<double> s(np, 0.0);
        for (std::size_t i = 1; i < np; ++i) {
            const double* p = edges[ch.edges[i - 1]].p;
            const double* q = edges[ch.edges[i]].p;
            s[i] = s[i - 1] + std::hypot(q[0] - p[0], q[1] - p[1]);
        }
        for (std::size_t i = 0; i < np; ++i) {
            Edge& e = edges[ch.edges[i]];
            const bool tip = (i == 0 && tip0) || (i + 1 == np && tip1);
            double dist = std::numeric_limits<double>::infinity();
            if (tip0) dist = std::min(dist, s[i]);
            if (tip1) dist = std::min(dist, s[np - 1] - s[i]);
            double w = tip ? 0.0 : 1.0;
            if (!tip && options.taper_length > 0.0 && std::isfinite(dist)) w = std::min(1.0, dist / options.taper_length);
            const Index foot = static_cast<Index>(out.vertices.size() / 3);
            out.vertices.insert(out.vertices.end(), e.p, e.p + 3);
            Index hang = foot;
            if (!tip) {
                hang = foot + 1;
                out.vertices.insert(out.vertices.end(), {e.p[0], e.p[1], e.p[2] + options.displacement * w});
            }
            foot_of_edge[ch.edges[i]] = foot;
            hang_of_edge[ch.edges[i]] = hang;
            out.footwall_line.push_back(foot);
            out.hanging_line.push_back(hang);
            out.line_weight.push_back(w);
        }
        out.line_offsets.push_back(static_cast<Index>(out.footwall_line.size()));
    }

    // ---- 7. Components of R, their boundary loops, and the faces cut off by
    // the chains.
    std::vector<Index> comp(nc, -1);
    Index n_comp = 0;
    for (std::size_t k = 0; k < nc; ++k) {
        if (!in_r[k] || comp[k] >= 0) continue;
        std::vector<std::size_t> stack{k};
        comp[k] = n_comp;
        while (!stack.empty()) {
            const std::size_t c = stack.back();
            stack.pop_back();
            for (int i = 0; i < 3; ++i) {
                const Index h = nbr[3 * c + i];
                if (h < 0) continue;
                const std::size_t o = static_cast<std::size_t>(h / 3);
                if (in_r[o] && comp[o] < 0) {
                    comp[o] = n_comp;
                    stack.push_back(o);
                }
            }
        }
        ++n_comp;
    }
    auto is_boundary_he = [&](Index h) {  // half-edge slot 3k + i of an R triangle
        const Index o = nbr[h];
        return o < 0 || !in_r[o / 3];
    };
    // Chain end markers by edge: (chain, end) for the chain end lying on edge e.
    std::vector<std::pair<Index, int>> end_on_edge(edges.size(), {-1, -1});
    for (std::size_t c = 0; c < chains.size(); ++c) {
        end_on_edge[chains[c].edges.front()] = {static_cast<Index>(c), 0};
        end_on_edge[chains[c].edges.back()] = {static_cast<Index>(c), 1};
    }

    std::vector<std::int64_t> created;
    std::vector<char> he_seen(3 * nc, 0);
    std::vector<Index> loops_of_comp(static_cast<std::size_t>(n_comp), 0);
    // Ring items: >= 0 a layer vertex, < 0 a chain end marker -(2c + end) - 1.
    std::vector<std::vector<Index>> rings;
    for (std::size_t k = 0; k < nc; ++k) {
        if (!in_r[k]) continue;
        for (int i0 = 0; i0 < 3; ++i0) {
            const Index h0 = static_cast<Index>(3 * k + i0);
            if (he_seen[h0] || !is_boundary_he(h0)) continue;
            if (++loops_of_comp[comp[k]] > 1)
                geometry_error("the region cut by the fault (around layer triangle row " + std::to_string(cand[k]) +
                               ") encloses uncut triangles; the intersection line winds around them");
            std::vector<Index> ring;
            Index h = h0;
            std::size_t guard = 0;
            do {
                he_seen[h] = 1;
                const std::size_t tk = static_cast<std::size_t>(h / 3);
                const int i = static_cast<int>(h % 3);
                ring.push_back(T[3 * cand[tk] + i]);
                const auto mk = end_on_edge[edge_of[h]];
                if (mk.first >= 0) ring.push_back(-(2 * mk.first + mk.second) - 1);
                // Next boundary half-edge leaving the head v of h: turn around
                // v through R's triangles until a boundary half-edge.
                Index g = static_cast<Index>(3 * tk + (i + 1) % 3);
                std::size_t spin = 0;
                while (!is_boundary_he(g)) {
                    const Index o = nbr[g];  // slot of the reversed edge (w -> v) in the next triangle
                    g = (o / 3) * 3 + (o % 3 + 1) % 3;
                    if (++spin > 3 * nc) geometry_error("cannot walk around a vertex of the cut region");
                }
                h = g;
                if (++guard > 3 * nc + 2) geometry_error("boundary walk of the cut region does not close");
            } while (h != h0);
            rings.push_back(std::move(ring));
        }
    }

    // Faces: walk a ring; at a chain end marker follow the chain to its other
    // end and continue the ring there. The face is on the left of every step.
    std::vector<double> fxy;
    std::vector<Index> face;
    const Index n_chain_marks = static_cast<Index>(2 * chains.size());
    for (const auto& ring : rings) {
        const std::size_t L = ring.size();
        std::vector<std::size_t> pos_of_mark(static_cast<std::size_t>(n_chain_marks), L);
        for (std::size_t p = 0; p < L; ++p)
            if (ring[p] < 0) pos_of_mark[static_cast<std::size_t>(-ring[p] - 1)] = p;
        std::vector<char> seen(L, 0);
        for (std::size_t p0 = 0; p0 < L; ++p0) {
            if (ring[p0] < 0 || seen[p0]) continue;
            face.clear();
            int side = -1;  // 1 hanging, 0 footwall; from the face's layer vertices
            std::size_t p = p0;
            std::size_t guard = 0;
            do {
                seen[p] = 1;
                if (ring[p] >= 0) {
                    const int s = hanging(ring[p]) ? 1 : 0;
                    if (side >= 0 && s != side)
                        geometry_error("a face of the cut region has vertices on both walls (layer vertex " +
                                       std::to_string(ring[p]) + ")");
                    side = s;
                    face.push_back(ring[p]);
                    p = (p + 1) % L;
                } else {
                    const Index mark = -ring[p] - 1;
                    const Chain& ch = chains[static_cast<std::size_t>(mark / 2)];
                    const bool forward = mark % 2 == 0;  // entering at the chain's start
                    // Along the chain's direction the hanging wall is on the left.
                    const int s = forward ? 1 : 0;
                    if (side >= 0 && s != side)
                        geometry_error("a face of the cut region lies on both walls of the intersection line");
                    side = s;
                    const std::size_t np = ch.edges.size();
                    for (std::size_t j = 0; j < np; ++j) {
                        const Index e = ch.edges[forward ? j : np - 1 - j];
                        face.push_back(s ? hang_of_edge[e] : foot_of_edge[e]);
                    }
                    const Index other = forward ? mark + 1 : mark - 1;
                    const std::size_t q = pos_of_mark[static_cast<std::size_t>(other)];
                    if (q >= L) geometry_error("an intersection line leaves its cut region");
                    seen[q] = 1;
                    p = (q + 1) % L;
                }
                if (++guard > 2 * L + 2 * out.footwall_line.size()) geometry_error("face walk does not close");
            } while (p != p0);
            // Triangulate the face (its points copied out; a vertex may repeat
            // at a pinch of the region's boundary).
            fxy.clear();
            for (Index v : face) {
                fxy.push_back(out.vertices[3 * v]);
                fxy.push_back(out.vertices[3 * v + 1]);
            }
            const std::int64_t offs[2] = {0, static_cast<std::int64_t>(face.size())};
            const std::vector<std::int64_t> tri = triangulate_polygon(fxy.data(), offs, 1, options.triangulation);
            if (tri.size() != 3 * (face.size() - 2))
                geometry_error("a face of the cut region with " + std::to_string(face.size()) + " vertices gave " +
                               std::to_string(tri.size() / 3) + " triangles instead of " +
                               std::to_string(face.size() - 2) + " (it is not a simple polygon)");
            for (std::int64_t x : tri) created.push_back(face[static_cast<std::size_t>(x)]);
        }
    }

    // Tip triangles: split at the tip point (fan from the opposite vertex).
    for (const auto& sp : splits) {
        const std::size_t k = static_cast<std::size_t>(sp.first);
        const Index t = cand[k];
        int i = 0;
        while (edge_of[3 * k + i] != sp.second) ++i;
        const Index a = T[3 * t + i], b = T[3 * t + (i + 1) % 3], w = T[3 * t + (i + 2) % 3];
        const Index q = foot_of_edge[sp.second];
        created.insert(created.end(), {a, q, w, q, b, w});
        out.split.push_back(t);
    }

    // ---- 8. Assemble: kept input triangles in order, then the created ones.
    for (std::size_t k = 0; k < nc; ++k)
        if (in_r[k]) out.removed.push_back(cand[k]);
    out.removed.insert(out.removed.end(), out.split.begin(), out.split.end());
    std::sort(out.removed.begin(), out.removed.end());
    std::sort(out.split.begin(), out.split.end());
    out.triangles.reserve(3 * (n_layer_triangles - out.removed.size()) + created.size());
    std::size_t r = 0;
    for (std::size_t t = 0; t < n_layer_triangles; ++t) {
        if (r < out.removed.size() && out.removed[r] == static_cast<Index>(t)) {
            ++r;
            continue;
        }
        out.triangles.insert(out.triangles.end(), T + 3 * t, T + 3 * t + 3);
    }
    out.triangles.insert(out.triangles.end(), created.begin(), created.end());
    out.n_created = created.size() / 3;
    return out;
}

}  // namespace faultmesh
