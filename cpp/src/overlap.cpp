// Overlap detection (paper 2.4): AABB candidates + exact 2D tests, and the
// growth of the removed set into a topological disk. The region and the
// grower are shared with the stitcher (overlap_growth.hpp).
#include <faultmesh/errors.hpp>
#include <faultmesh/overlap.hpp>
#include <faultmesh/predicates.hpp>
#include <faultmesh/segments.hpp>
#include <faultmesh/triangle_adjacency.hpp>

#include "overlap_growth.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace faultmesh {

namespace detail {
namespace {

constexpr const char* kFn = "overlapping_triangles";
constexpr double kInf = std::numeric_limits<double>::infinity();

// Angular order of directions around a point o, from the +x axis
// counter-clockwise, angles in [0, 2 pi). Exact: half-plane, then orient2d.
inline int half_of(const double* o, const double* x) {
    return (x[1] > o[1] || (x[1] == o[1] && x[0] > o[0])) ? 0 : 1;
}
inline bool angle_is_zero(const double* o, const double* x) { return x[1] == o[1] && x[0] > o[0]; }
// angle(o->x) < angle(o->y)
inline bool angle_less(const double* o, const double* x, const double* y) {
    const int hx = half_of(o, x), hy = half_of(o, y);
    if (hx != hy) return hx < hy;
    return orient2d_sign(o, x, y) > 0;
}

Box2 seg_box(const Seg& s) {
    return {std::min(s.p[0], s.q[0]), std::min(s.p[1], s.q[1]), std::max(s.p[0], s.q[0]),
            std::max(s.p[1], s.q[1])};
}
void extend(Box2& b, const Box2& x) {
    b.xmin = std::min(b.xmin, x.xmin);
    b.ymin = std::min(b.ymin, x.ymin);
    b.xmax = std::max(b.xmax, x.xmax);
    b.ymax = std::max(b.ymax, x.ymax);
}

}  // namespace
// ------------------------------------------------------------ the region
Region::Region(const double* ring_xy, const std::int64_t* ring_offsets, std::size_t n_rings) {
    // 1. Ring edges, without consecutive duplicates or a repeated closing point.
    std::vector<Seg> raw;
    std::vector<const double*> verts;
    for (std::size_t r = 0; r < n_rings; ++r) {
        const std::int64_t b = ring_offsets[r], e = ring_offsets[r + 1];
        if (b < 0 || e < b)
            throw std::invalid_argument(std::string(kFn) + ": ring offsets must be non-negative and "
                                        "non-decreasing (ring " + std::to_string(r) + ")");
        std::vector<const double*> ring;
        for (std::int64_t i = b; i < e; ++i) {
            const double* p = ring_xy + 2 * i;
            for (int k = 0; k < 2; ++k)
                if (!coordinate_in_range(p[k]))
                    throw_coordinate_error(kFn, "ring " + std::to_string(r) + " point " + std::to_string(i - b), k, p[k]);
            if (ring.empty() || !same_point(ring.back(), p)) ring.push_back(p);
        }
        while (ring.size() > 1 && same_point(ring.front(), ring.back())) ring.pop_back();
        if (ring.size() < 2) {
            // A ring of one point bounds nothing, but it is drawn.
            if (ring.size() == 1) {
                Seg s;
                s.p[0] = s.q[0] = ring[0][0];
                s.p[1] = s.q[1] = ring[0][1];
                extra_.push_back(s);
            }
            continue;
        }
        for (std::size_t i = 0; i < ring.size(); ++i) {
            const double* p = ring[i];
            const double* q = ring[(i + 1) % ring.size()];
            Seg s;
            s.p[0] = p[0];
            s.p[1] = p[1];
            s.q[0] = q[0];
            s.q[1] = q[1];
            raw.push_back(s);
            verts.push_back(p);
        }
    }
    std::vector<Box2> boxes;
    if (!raw.empty()) {
        // 2. Split every edge at the ring vertices in its relative interior.
        boxes.resize(raw.size());
        for (std::size_t i = 0; i < raw.size(); ++i) boxes[i] = seg_box(raw[i]);
        std::vector<std::vector<const double*>> splits(raw.size());
        {
            AabbTree rt(boxes);
            std::vector<std::int64_t> hits;
            for (const double* v : verts) {
                hits.clear();
                rt.query(Box2{v[0], v[1], v[0], v[1]}, hits);
                for (std::int64_t h : hits) {
                    const Seg& s = raw[static_cast<std::size_t>(h)];
                    if (orient2d_sign(s.p, s.q, v) == 0 && strictly_between(s.p, s.q, v))
                        splits[static_cast<std::size_t>(h)].push_back(v);
                }
            }
        }
        // Pieces in the direction of their ring edge; `lo` is each piece's
        // lexicographically smaller end (the key that finds equal pieces).
        std::vector<Seg> pieces;
        std::vector<char> reversed;  // piece runs from its larger to its smaller end
        for (std::size_t i = 0; i < raw.size(); ++i) {
            const bool rev = lex_less(raw[i].q, raw[i].p);
            auto& sp = splits[i];
            // Collinear points on the open segment: lexicographic order is the
            // order along the segment from its smaller end.
            std::sort(sp.begin(), sp.end(), [](const double* x, const double* y) { return lex_less(x, y); });
            sp.erase(std::unique(sp.begin(), sp.end(), [](const double* x, const double* y) { return same_point(x, y); }),
                     sp.end());
            if (rev) std::reverse(sp.begin(), sp.end());
            const double* prev = raw[i].p;
            for (std::size_t j = 0; j <= sp.size(); ++j) {
                const double* nx = j < sp.size() ? sp[j] : raw[i].q;
                Seg s;
                s.p[0] = prev[0];
                s.p[1] = prev[1];
                s.q[0] = nx[0];
                s.q[1] = nx[1];
                pieces.push_back(s);
                reversed.push_back(rev);
                prev = nx;
            }
        }
        // 3. Equal pieces cancel in pairs (they do not change the parity); what
        // cancels stays drawn.
        auto lo = [&](std::size_t i) { return reversed[i] ? pieces[i].q : pieces[i].p; };
        auto hi = [&](std::size_t i) { return reversed[i] ? pieces[i].p : pieces[i].q; };
        std::vector<std::size_t> order(pieces.size());
        for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
        auto key_less = [&](std::size_t x, std::size_t y) {
            const double *xl = lo(x), *yl = lo(y), *xh = hi(x), *yh = hi(y);
            if (xl[0] != yl[0]) return xl[0] < yl[0];
            if (xl[1] != yl[1]) return xl[1] < yl[1];
            if (xh[0] != yh[0]) return xh[0] < yh[0];
            return xh[1] < yh[1];
        };
        auto key_eq = [&](std::size_t x, std::size_t y) {
            return same_point(lo(x), lo(y)) && same_point(hi(x), hi(y));
        };
        std::stable_sort(order.begin(), order.end(), key_less);
        for (std::size_t i = 0; i < order.size();) {
            std::size_t j = i + 1;
            while (j < order.size() && key_eq(order[i], order[j])) ++j;
            ((j - i) % 2 == 1 ? edges_ : extra_).push_back(pieces[order[i]]);
            i = j;
        }
    }
    // 4. Trees over dR and over the other drawn pieces, and slabs for the
    // crossing count.
    bounds_ = {kInf, kInf, -kInf, -kInf};
    boxes.resize(edges_.size());
    for (std::size_t i = 0; i < edges_.size(); ++i) {
        boxes[i] = seg_box(edges_[i]);
        extend(bounds_, boxes[i]);
    }
    drawn_bounds_ = bounds_;
    if (!extra_.empty()) {
        std::vector<Box2> eb(extra_.size());
        for (std::size_t i = 0; i < extra_.size(); ++i) {
            eb[i] = seg_box(extra_[i]);
            extend(drawn_bounds_, eb[i]);
        }
        extra_tree_ = AabbTree(eb);
    }
    if (edges_.empty()) return;
    tree_ = AabbTree(boxes);
    y0_ = bounds_.ymin;
    y1_ = bounds_.ymax;
    // About two edges per slab; fewer slabs if long edges would make the
    // lists much longer than the edge count (worst case stays O(E * slabs)).
    nslab_ = std::max<std::size_t>(1, std::min<std::size_t>(edges_.size() / 2, 1 << 16));
    for (;;) {
        scale_ = y1_ > y0_ ? static_cast<double>(nslab_) / (y1_ - y0_) : 0.0;
        if (!std::isfinite(scale_)) scale_ = 0.0;
        std::size_t total = 0;
        for (const Box2& b : boxes) total += slab_of(b.ymax) - slab_of(b.ymin) + 1;
        if (total <= 16 * edges_.size() + nslab_ || nslab_ == 1) break;
        nslab_ = std::max<std::size_t>(1, nslab_ / 2);
    }
    slab_start_.assign(nslab_ + 1, 0);
    for (const Box2& b : boxes)
        for (std::size_t s = slab_of(b.ymin), e = slab_of(b.ymax); s <= e; ++s) ++slab_start_[s + 1];
    for (std::size_t s = 0; s < nslab_; ++s) slab_start_[s + 1] += slab_start_[s];
    slab_edges_.resize(slab_start_[nslab_]);
    std::vector<std::uint32_t> fill(slab_start_.begin(), slab_start_.end() - 1);
    for (std::size_t i = 0; i < boxes.size(); ++i)
        for (std::size_t s = slab_of(boxes[i].ymin), e = slab_of(boxes[i].ymax); s <= e; ++s)
            slab_edges_[fill[s]++] = static_cast<std::uint32_t>(i);
}

std::size_t Region::slab_of(double y) const {
    double f = (y - y0_) * scale_;
    if (!(f >= 0)) f = 0;
    auto s = static_cast<std::size_t>(std::min(f, static_cast<double>(nslab_ - 1)));
    return std::min(s, nslab_ - 1);
}

bool Region::meets_open_triangle(const double* a, const double* b, const double* c) const {
    const Box2 tb = triangle_box(a, b, c);
    if (edges_.empty() || !boxes_meet(tb, bounds_)) return false;
    if (tree_.any_of(tb, [&](std::int64_t i) {
            const Seg& s = edges_[static_cast<std::size_t>(i)];
            return segment_meets_open_triangle(s.p, s.q, a, b, c);
        }))
        return true;
    return wedge_parity(a, b);
}

bool Region::meets_closed_triangle(const double* a, const double* b, const double* c) const {
    const Box2 tb = triangle_box(a, b, c);
    if (nothing_drawn() || !boxes_meet(tb, drawn_bounds_)) return false;
    auto touches = [&](const std::vector<Seg>& segs) {
        return [&, a, b, c](std::int64_t i) {
            const Seg& s = segs[static_cast<std::size_t>(i)];
            return segment_meets_closed_triangle(s.p, s.q, a, b, c);
        };
    };
    if (!edges_.empty() && tree_.any_of(tb, touches(edges_))) return true;
    if (!extra_.empty() && extra_tree_.any_of(tb, touches(extra_))) return true;
    // No contact: the triangle lies in one face of dR's arrangement, inside R
    // iff its vertex a is (a is off dR: the wedge parity is a's own).
    return wedge_parity(a, b);
}

bool Region::segment_meets_closure(const double* p, const double* q) const {
    const Box2 sb{std::min(p[0], q[0]), std::min(p[1], q[1]), std::max(p[0], q[0]), std::max(p[1], q[1])};
    if (edges_.empty() || !boxes_meet(sb, bounds_)) return false;
    if (tree_.any_of(sb, [&](std::int64_t i) {
            const Seg& s = edges_[static_cast<std::size_t>(i)];
            return segments_meet(p, q, s.p, s.q);
        }))
        return true;
    // Not touching dR: the segment is in R iff its endpoint is (p is off
    // dR, so the wedge parity in any direction is the parity of p).
    return wedge_parity(p, q);
}

double Region::distance(const double* p, double limit) const {
    double best = limit;
    const Box2 q{p[0] - limit, p[1] - limit, p[0] + limit, p[1] + limit};
    auto visit = [&](const std::vector<Seg>& segs) {
        return [&](std::int64_t i) {
            const Seg& s = segs[static_cast<std::size_t>(i)];
            const double* u = s.p;
            const double* v = s.q;
            const double dx = v[0] - u[0], dy = v[1] - u[1];
            const double L2 = dx * dx + dy * dy;
            double t = L2 > 0.0 ? ((p[0] - u[0]) * dx + (p[1] - u[1]) * dy) / L2 : 0.0;
            t = std::min(1.0, std::max(0.0, t));
            best = std::min(best, std::hypot(p[0] - (u[0] + t * dx), p[1] - (u[1] + t * dy)));
        };
    };
    if (!edges_.empty()) tree_.visit(q, visit(edges_));
    if (!extra_.empty()) extra_tree_.visit(q, visit(extra_));
    return best;
}

bool Region::wedge_parity(const double* a, const double* b) const {
    if (edges_.empty() || a[1] < y0_ || a[1] > y1_) return false;
    // The point a + eps (1, eta), 0 < eta << 1, eps -> 0: its horizontal ray
    // crosses the edges not through a exactly as the half-open PNPoly rule
    // says for a itself; edges through a are never crossed (they meet the ray
    // line left of the point). Rotating from that point's direction to the
    // wedge just counter-clockwise of a -> b crosses every arm of dR leaving
    // a with an angle in (0, angle(a -> b)].
    const std::size_t s = slab_of(a[1]);
    bool parity = false;
    for (std::uint32_t k = slab_start_[s]; k < slab_start_[s + 1]; ++k) {
        const Seg& e = edges_[slab_edges_[k]];
        const double* p = e.p;
        const double* q = e.q;
        const bool p_at = same_point(p, a), q_at = same_point(q, a);
        int o = 2;  // not computed
        bool through = p_at || q_at;
        if (!through && std::min(p[1], q[1]) <= a[1] && a[1] <= std::max(p[1], q[1])) {
            o = orient2d_sign(p, q, a);
            through = o == 0 && in_segment_box(p, q, a);
        }
        if (through) {
            // Arms: to q if a is p, to p if a is q, both if a is inside.
            const double* arms[2] = {nullptr, nullptr};
            if (p_at)
                arms[0] = q;
            else if (q_at)
                arms[0] = p;
            else {
                arms[0] = p;
                arms[1] = q;
            }
            for (const double* x : arms)
                if (x && !angle_is_zero(a, x) && !angle_less(a, b, x)) parity = !parity;
            continue;
        }
        // Half-open rule: the edge straddles the line y = a.y (an endpoint
        // at that height counts as below), crossing it right of a.
        const bool pu = p[1] > a[1], qu = q[1] > a[1];
        if (pu == qu) continue;
        if (o == 2) o = orient2d_sign(p, q, a);
        // Going up (q above): a is left of p -> q iff the crossing is to the right.
        if ((qu && o > 0) || (pu && o < 0)) parity = !parity;
    }
    return parity;
}

// ------------------------------------------------------------ removed set
const std::vector<std::int64_t>& GrowthHooks::group(std::int64_t g) const {
    throw std::logic_error("GrowthHooks::group(" + std::to_string(g) + "): no atomic groups");
}

GrowthHooks& RemovedSet::no_hooks() {
    static GrowthHooks none;  // stateless: the defaults only
    return none;
}

// ------------------------------------------------------------ growth
Grower::Grower(const GrowthMesh& mesh, RemovedSet& set, const Region& region, const GrowthRules& rules,
               std::string fn)
    : m_(mesh), S_(set), R_(region), rules_(rules), fn_(std::move(fn)) {
    // The paper's rules look at the whole mesh: vertex degrees (fan walks)
    // and mesh-boundary vertices, one O(m) pass.
    const bool paper = rules_.pinch == PinchRule::keep_largest_kept_fan ||
                       rules_.holes == HoleRule::absorb_kept_islands || !rules_.allow_mesh_boundary;
    if (!paper) return;
    degree_.assign(m_.n_vertices, 0);
    boundary_vertex_.assign(m_.n_vertices, 0);
    for (std::size_t h = 0; h < 3 * m_.n_triangles; ++h) {
        ++degree_[static_cast<std::size_t>(m_.triangles[h])];
        if (m_.twins[h] < 0) {
            boundary_vertex_[static_cast<std::size_t>(m_.triangles[h])] = 1;
            boundary_vertex_[static_cast<std::size_t>(m_.triangles[next_halfedge(static_cast<std::int64_t>(h))])] = 1;
        }
    }
}

template <class F>
int Grower::walk_fan(std::int64_t v, std::int64_t t0, int slot, std::size_t max_steps, F&& f) const {
    std::int64_t t = t0;
    for (std::size_t step = 0; step < max_steps; ++step) {
        const std::int64_t o = m_.twins[3 * t + slot];
        if (o < 0) return 0;
        const std::int64_t u = o / 3;
        if (u == t0) return 1;
        f(u);
        // The other edge of u at v: the one before v's corner if v starts the
        // edge we came in by, else the one after.
        const int a = static_cast<int>(o % 3);
        slot = vtx(u, a) == v ? (a + 2) % 3 : (a + 1) % 3;
        t = u;
    }
    return 2;
}

void Grower::close_groups(std::size_t from) {
    GrowthHooks& hooks = S_.hooks();
    for (std::size_t i = from; i < S_.size(); ++i) {
        const std::int64_t g = hooks.group_of(S_.members()[i]);
        if (g < 0 || !merged_set_.insert(g).second) continue;
        merged_.push_back(g);
        for (std::int64_t q : hooks.group(g)) S_.add(q);
    }
}

const Grower::Boundary& Grower::boundary() {
    if (bnd_size_ == S_.size()) return bnd_;
    bnd_.halfedges.clear();
    bnd_.leaving.clear();
    bnd_.pinches.clear();
    for (std::int64_t r : S_.members())
        for (int k = 0; k < 3; ++k) {
            const std::int64_t h = 3 * r + k;
            const std::int64_t o = m_.twins[h];
            if (o >= 0 && in(o / 3)) continue;
            bnd_.halfedges.push_back(h);
            if (!bnd_.leaving.emplace(m_.triangles[h], h).second) bnd_.pinches.push_back(h);
        }
    bnd_size_ = S_.size();
    return bnd_;
}

void Grower::check_mesh_boundary() const {
    for (std::int64_t t : S_.members())
        for (int c = 0; c < 3; ++c)
            if (boundary_vertex_[static_cast<std::size_t>(vtx(t, c))])
                throw GeometryError(fn_ + ": the removed set reaches the mesh boundary at vertex " +
                                    std::to_string(vtx(t, c)) +
                                    " (the region reaches the study-area boundary), so it cannot be a "
                                    "disk strictly inside the mesh; pass allow_mesh_boundary=True");
}

// Add the kept neighbour across every boundary edge of S whose closed
// segment meets the closure of R (R must be in S's interior).
bool Grower::grow_touching() {
    const std::size_t before = S_.size();
    std::vector<std::int64_t> add_list;
    for (std::int64_t t : S_.members())
        for (int e = 0; e < 3; ++e) {
            const std::int64_t u = nb(t, e);
            if (u >= 0 && in(u)) continue;
            if (u < 0) continue;  // mesh boundary: handled by check_mesh_boundary / allowed
            if (R_.segment_meets_closure(pt(vtx(t, e)), pt(vtx(t, (e + 1) % 3)))) add_list.push_back(u);
        }
    for (std::int64_t u : add_list) S_.add(u);
    return S_.size() != before;
}

// Join edge-connected components of S along shortest dual paths.
bool Grower::join_components() {
    const std::size_t before = S_.size(), m = m_.n_triangles;
    for (;;) {
        std::vector<std::int64_t> comp(m, -1);
        std::int64_t ncomp = 0;
        std::vector<std::int64_t> q;
        for (std::int64_t s : S_.members()) {
            if (comp[static_cast<std::size_t>(s)] >= 0) continue;
            comp[static_cast<std::size_t>(s)] = ncomp;
            q.assign(1, s);
            while (!q.empty()) {
                const std::int64_t t = q.back();
                q.pop_back();
                for (int e = 0; e < 3; ++e) {
                    const std::int64_t u = nb(t, e);
                    if (u >= 0 && in(u) && comp[static_cast<std::size_t>(u)] < 0) {
                        comp[static_cast<std::size_t>(u)] = ncomp;
                        q.push_back(u);
                    }
                }
            }
            ++ncomp;
        }
        if (ncomp <= 1) return S_.size() != before;
        // BFS from component 0 through kept triangles to the nearest triangle
        // of another component.
        std::vector<std::int64_t> from(m, -2);
        std::deque<std::int64_t> bq;
        for (std::int64_t s : S_.members())
            if (comp[static_cast<std::size_t>(s)] == 0) {
                from[static_cast<std::size_t>(s)] = -1;
                bq.push_back(s);
            }
        std::int64_t hit = -1, hit_from = -1;
        while (!bq.empty() && hit < 0) {
            const std::int64_t t = bq.front();
            bq.pop_front();
            for (int e = 0; e < 3 && hit < 0; ++e) {
                const std::int64_t u = nb(t, e);
                if (u < 0 || from[static_cast<std::size_t>(u)] != -2) continue;
                if (in(u)) {
                    if (comp[static_cast<std::size_t>(u)] != 0) {
                        hit = u;
                        hit_from = t;
                    }
                    continue;
                }
                from[static_cast<std::size_t>(u)] = t;
                bq.push_back(u);
            }
        }
        if (hit < 0)
            throw GeometryError(fn_ + ": the region's parts lie in different "
                                "connected pieces of the mesh; the removed set cannot be one disk");
        for (std::int64_t t = hit_from; t >= 0 && !in(t); t = from[static_cast<std::size_t>(t)]) S_.add(t);
    }
}

// The star of v (t0: a triangle at v) in fan order; cyclic tells whether it
// closes. False if the triangles at v are not one fan (a pinch of the mesh
// itself).
bool Grower::star(std::int64_t v, std::int64_t t0, std::vector<std::int64_t>& fan, bool& cyclic) const {
    const std::size_t deg = degree_[static_cast<std::size_t>(v)];
    fan.clear();
    cyclic = false;
    // w0: the first corner of t0 that is not v; the edges of t0 at v are
    // {v, w0} and {v, x0}.
    int cv = 0;
    while (cv < 3 && vtx(t0, cv) != v) ++cv;
    int cw0 = 0;
    while (vtx(t0, cw0) == v) ++cw0;
    const int s_w0 = (cw0 == (cv + 1) % 3) ? cv : cw0;        // slot of edge {v, w0}
    const int s_x0 = s_w0 == cv ? (cv + 2) % 3 : cv;          // slot of edge {v, x0}
    std::vector<std::int64_t> fwd, bwd;
    auto push = [](std::vector<std::int64_t>& out) { return [&out](std::int64_t u) { out.push_back(u); }; };
    // Forward: leave t0 across {v, x0}; more triangles than v's degree means
    // the walk does not come back (not one fan).
    const int end = walk_fan(v, t0, s_x0, deg + 1, push(fwd));
    cyclic = end == 1;
    if (end == 2) return false;
    if (cyclic) {
        fan.push_back(t0);
        fan.insert(fan.end(), fwd.begin(), fwd.end());
    } else {
        // Backward: leave t0 across {v, w0}.
        if (walk_fan(v, t0, s_w0, deg + 1, push(bwd)) == 2) return false;
        fan.assign(bwd.rbegin(), bwd.rend());
        fan.push_back(t0);
        fan.insert(fan.end(), fwd.begin(), fwd.end());
    }
    return fan.size() == deg;
}

// Around each vertex on S's boundary, S and the kept triangles must each be
// at most one fan; the smaller gaps are absorbed into S.
bool Grower::keep_largest_kept_fans() {
    const std::size_t before = S_.size();
    // (vertex, a triangle of S at it) for the vertices of S's boundary edges.
    std::vector<std::pair<std::int64_t, std::int64_t>> verts;
    for (std::int64_t t : S_.members())
        for (int e = 0; e < 3; ++e) {
            const std::int64_t u = nb(t, e);
            if (u >= 0 && in(u)) continue;
            verts.push_back({vtx(t, e), t});
            verts.push_back({vtx(t, (e + 1) % 3), t});
        }
    std::sort(verts.begin(), verts.end());
    verts.erase(std::unique(verts.begin(), verts.end(),
                            [](const auto& x, const auto& y) { return x.first == y.first; }),
                verts.end());
    std::vector<std::int64_t> fan;
    std::vector<std::int64_t> to_add;
    for (const auto& [v, t0] : verts) {
        bool cyclic;
        if (!star(v, t0, fan, cyclic))
            throw GeometryError(fn_ + ": grow_to_disk needs a manifold mesh, but vertex " +
                                std::to_string(v) + " is a pinch of the mesh itself (its triangles form "
                                "more than one fan)");
        const std::size_t d = fan.size();
        // Runs of equal membership along the fan.
        struct Run {
            std::size_t begin, len;
            bool in;
        };
        std::vector<Run> runs;
        std::size_t start = 0;
        if (cyclic) {
            // Rotate so that a run starts at position 0.
            std::size_t i = 0;
            while (i < d && in(fan[i]) == in(fan[(i + d - 1) % d])) ++i;
            if (i == d) continue;  // all one kind
            start = i;
        }
        for (std::size_t k = 0; k < d; ++k) {
            const bool inside = in(fan[(start + k) % d]);
            if (runs.empty() || runs.back().in != inside)
                runs.push_back({k, 1, inside});
            else
                ++runs.back().len;
        }
        std::size_t n_in = 0;
        for (const Run& r : runs) n_in += r.in;
        if (n_in == 0) continue;
        auto fill = [&](const Run& r) {
            for (std::size_t k = 0; k < r.len; ++k) to_add.push_back(fan[(start + r.begin + k) % d]);
        };
        if (cyclic) {
            if (n_in < 2) continue;
            // Keep the largest kept run, absorb the others (ties: the first).
            std::size_t keep = runs.size();
            for (std::size_t i = 0; i < runs.size(); ++i)
                if (!runs[i].in && (keep == runs.size() || runs[i].len > runs[keep].len)) keep = i;
            for (std::size_t i = 0; i < runs.size(); ++i)
                if (!runs[i].in && i != keep) fill(runs[i]);
        } else {
            // Path (mesh-boundary vertex): absorb kept runs between S runs,
            // then, if kept runs remain at both ends, the smaller one.
            std::size_t first_in = runs.size(), last_in = 0;
            for (std::size_t i = 0; i < runs.size(); ++i)
                if (runs[i].in) {
                    first_in = std::min(first_in, i);
                    last_in = i;
                }
            for (std::size_t i = first_in; i < last_in; ++i)
                if (!runs[i].in) fill(runs[i]);
            if (first_in > 0 && last_in + 1 < runs.size()) {
                const Run& l = runs.front();
                const Run& r = runs.back();
                fill(l.len <= r.len ? l : r);
            }
        }
    }
    for (std::int64_t t : to_add) S_.add(t);
    return S_.size() != before;
}

// The stitcher's star of the vertex that half-edge h0 leaves: every
// triangle around it (frozen ones stay out), walking clockwise from h0 (across
// the edge arriving at the vertex), then counter-clockwise (across h0's edge).
void Grower::pull_star(std::int64_t h0) {
    const std::int64_t v = m_.triangles[h0], t0 = h0 / 3;
    const int k = static_cast<int>(h0 % 3);
    // 100000 triangles around one vertex: a guard, never reached by a TIN.
    constexpr std::size_t kMaxFan = 100000;
    S_.add(t0);
    walk_fan(v, t0, (k + 2) % 3, kMaxFan, [&](std::int64_t u) { S_.add(u); });
    walk_fan(v, t0, k, kMaxFan, [&](std::int64_t u) { S_.add(u); });
}

// A vertex where S's boundary meets itself pulls in its star.
bool Grower::pull_pinch_stars() {
    kept_pinches_.clear();
    const Boundary& b = boundary();
    if (b.pinches.empty()) return false;
    const std::size_t before = S_.size();
    const std::vector<std::int64_t> pinches = b.pinches;
    for (std::int64_t h0 : pinches) pull_star(h0);
    if (S_.size() != before) return true;
    // Nothing joined: around every pinch vertex each triangle is in S or
    // frozen. At a mesh-boundary vertex (its fan is a path) that is a frozen
    // piece touching the mesh boundary there and nowhere near (an earlier
    // patch's end clipped to the study area down to one vertex on it,
    // random_ground(704) as v2), S on both of its sides: S is still one
    // region, its outline passes the vertex twice, like the gap that the
    // earlier stitch left there. Around an interior vertex the frozen
    // triangles would be two pieces touching (never stitched), so that stays
    // an error.
    constexpr std::size_t kMaxFan = 100000;  // as pull_star's guard
    for (std::int64_t h0 : pinches) {
        const std::int64_t v = m_.triangles[h0];
        const bool on_mesh_boundary =
            walk_fan(v, h0 / 3, static_cast<int>(h0 % 3), kMaxFan, [](std::int64_t) {}) == 0;
        if (!rules_.keep_frozen_pinches_on_mesh_boundary || !on_mesh_boundary) {
            kept_pinches_.clear();
            char buf[96];
            std::snprintf(buf, sizeof buf, "(%.10g, %.10g)", pt(v)[0], pt(v)[1]);
            throw GeometryError(fn_ + ": the removed region meets itself at vertex " + std::to_string(v) +
                                " " + buf + " and cannot grow there (an earlier fault patch is in the way)");
        }
        kept_pinches_.push_back(v);
    }
    std::sort(kept_pinches_.begin(), kept_pinches_.end());
    kept_pinches_.erase(std::unique(kept_pinches_.begin(), kept_pinches_.end()), kept_pinches_.end());
    return false;
}

std::int64_t Grower::next_boundary_halfedge(std::int64_t h) const {
    // Leave h's triangle by its other edge at the head; while that edge is
    // inside S, cross it and do the same. The walk cannot come back across h
    // (h's other side is not in S), so it ends at a boundary half-edge.
    std::int64_t g = next_halfedge(h);
    for (;;) {
        const std::int64_t o = m_.twins[g];
        if (o < 0 || !in(o / 3)) return g;
        g = next_halfedge(o);
    }
}

long Grower::euler() const {
    // V - E + F of S: E from the half-edges (boundary edges once, interior twice).
    long F = static_cast<long>(S_.size()), bnd = 0;
    std::vector<std::int64_t> vs;
    vs.reserve(3 * S_.size());
    for (std::int64_t t : S_.members())
        for (int e = 0; e < 3; ++e) {
            vs.push_back(vtx(t, e));
            const std::int64_t u = nb(t, e);
            if (u < 0 || !in(u)) ++bnd;
        }
    std::sort(vs.begin(), vs.end());
    const long V = static_cast<long>(std::unique(vs.begin(), vs.end()) - vs.begin());
    const long E = (3 * F + bnd) / 2;
    return V - E + F;
}

// Kept triangles in components that do not reach the mesh boundary
// (islands) are absorbed; with allow_mesh_boundary, every kept component but
// the largest is absorbed. O(m): only run when the local rules are done and
// S is not yet a disk, or S touches the mesh boundary.
bool Grower::absorb_kept_islands() {
    const std::size_t before = S_.size(), m = m_.n_triangles;
    bool touches = false;
    for (std::int64_t t : S_.members())
        for (int c = 0; c < 3; ++c)
            if (boundary_vertex_[static_cast<std::size_t>(vtx(t, c))]) touches = true;
    if (!touches && euler() == 1) return false;
    std::vector<std::int64_t> comp(m, -1);
    std::vector<std::int64_t> size;
    std::vector<char> reaches;
    std::vector<std::int64_t> q;
    for (std::size_t s = 0; s < m; ++s) {
        if (in(static_cast<std::int64_t>(s)) || comp[s] >= 0) continue;
        const auto c = static_cast<std::int64_t>(size.size());
        size.push_back(0);
        reaches.push_back(0);
        comp[s] = c;
        q.assign(1, static_cast<std::int64_t>(s));
        while (!q.empty()) {
            const std::int64_t t = q.back();
            q.pop_back();
            ++size.back();
            for (int e = 0; e < 3; ++e) {
                const std::int64_t u = nb(t, e);
                if (u < 0) {
                    reaches.back() = 1;
                    continue;
                }
                if (in(u) || comp[static_cast<std::size_t>(u)] >= 0) continue;
                comp[static_cast<std::size_t>(u)] = c;
                q.push_back(u);
            }
        }
    }
    std::vector<char> absorb(size.size(), 0);
    if (!touches) {
        for (std::size_t c = 0; c < size.size(); ++c) absorb[c] = !reaches[c];
    } else {
        // Keep the largest component that reaches the mesh boundary (the
        // largest of all if none does).
        std::size_t keep = size.size();
        for (std::size_t c = 0; c < size.size(); ++c)
            if (reaches[c] && (keep == size.size() || size[c] > size[keep])) keep = c;
        if (keep == size.size())
            for (std::size_t c = 0; c < size.size(); ++c)
                if (keep == size.size() || size[c] > size[keep]) keep = c;
        for (std::size_t c = 0; c < size.size(); ++c) absorb[c] = c != keep;
    }
    for (std::size_t t = 0; t < m; ++t)
        if (!in(static_cast<std::int64_t>(t)) && absorb[static_cast<std::size_t>(comp[t])])
            S_.add(static_cast<std::int64_t>(t));
    return S_.size() != before;
}

// Inner (clockwise) boundary loops of S: the triangles they enclose join S,
// frozen ones stay (holes of S). The loops are chained by turning about each
// vertex through S (next_boundary_halfedge): at a kept pinch (level 1 ran
// first, every other pinch is gone) the two wedges stay apart.
bool Grower::fill_inner_loops() {
    const Boundary& b = boundary();
    const std::size_t before = S_.size();
    std::vector<std::vector<std::int64_t>> loops;
    std::vector<double> loop_area;
    std::unordered_set<std::int64_t> used;
    for (std::int64_t h0 : b.halfedges) {
        if (used.count(h0)) continue;
        std::vector<std::int64_t> loop;
        std::int64_t h = h0;
        while (used.insert(h).second) {
            loop.push_back(h);
            h = next_boundary_halfedge(h);
        }
        if (h != h0) throw GeometryError(fn_ + ": internal error: the removed region's boundary is not a loop");
        std::vector<const double*> pts;
        for (std::int64_t e : loop) pts.push_back(pt(m_.triangles[e]));
        loop_area.push_back(ring_area2(pts));
        loops.push_back(std::move(loop));
    }
    GrowthHooks& hooks = S_.hooks();
    for (std::size_t li = 0; li < loops.size(); ++li) {
        if (loop_area[li] >= 0.0) continue;
        std::vector<std::int64_t> stack, enclosed;
        std::unordered_set<std::int64_t> visited;
        for (std::int64_t h : loops[li]) {
            const std::int64_t o = m_.twins[h];
            if (o < 0)
                throw GeometryError(fn_ + ": internal error: a hole of the removed region "
                                    "reaches the mesh boundary");
            if (visited.insert(o / 3).second) stack.push_back(o / 3);
        }
        while (!stack.empty()) {
            const std::int64_t r = stack.back();
            stack.pop_back();
            hooks.verify(r);
            enclosed.push_back(r);
            for (int k = 0; k < 3; ++k) {
                const std::int64_t o = m_.twins[3 * r + k];
                if (o < 0)
                    throw GeometryError(fn_ + ": internal error: a hole of the removed region is "
                                        "not enclosed (triangle " + std::to_string(r) +
                                        " reaches the mesh boundary)");
                const std::int64_t q = o / 3;
                if (!in(q) && visited.insert(q).second) stack.push_back(q);
            }
        }
        for (std::int64_t r : enclosed) S_.add(r);
    }
    return S_.size() != before;
}

// Clearance: the star of every boundary vertex of S (off the mesh boundary)
// that lies closer than the clearance to R's drawn edges joins S.
bool Grower::pull_clearance() {
    const Boundary& b = boundary();
    const std::size_t before = S_.size();
    const std::vector<std::int64_t> halfedges = b.halfedges;
    const double c = rules_.clearance;
    for (std::int64_t h0 : halfedges) {
        if (m_.twins[h0] < 0) continue;  // mesh boundary (the study-area boundary)
        if (R_.distance(pt(m_.triangles[h0]), c) >= c) continue;
        pull_star(h0);
    }
    return S_.size() != before;
}

bool Grower::apply(bool (Grower::*rule)()) {
    if (!(this->*rule)()) return false;
    if (!rules_.allow_mesh_boundary) check_mesh_boundary();
    return true;
}

int Grower::run() {
    if (S_.size() == 0) return 0;
    if (!rules_.allow_mesh_boundary) check_mesh_boundary();
    int rounds = 0;
    for (int round = 0;; ++round) {
        if (rules_.max_rounds > 0 && round >= rules_.max_rounds)
            throw GeometryError(fn_ + ": the removed region did not become a disk after " +
                                std::to_string(round) + " growth rounds");
        rounds = round + 1;
        const std::size_t before = S_.size();
        // Level 1: every rule in turn.
        bool grew = false;
        if (rules_.grow_touching) grew = apply(&Grower::grow_touching) || grew;
        if (rules_.join_components) grew = apply(&Grower::join_components) || grew;
        if (rules_.pinch == PinchRule::keep_largest_kept_fan) grew = apply(&Grower::keep_largest_kept_fans) || grew;
        if (rules_.pinch == PinchRule::pull_star) grew = apply(&Grower::pull_pinch_stars) || grew;
        // Level 2, then level 3, only when nothing before them grew S.
        if (!grew && rules_.holes == HoleRule::absorb_kept_islands) grew = apply(&Grower::absorb_kept_islands);
        if (!grew && rules_.holes == HoleRule::fill_inner_loops) grew = apply(&Grower::fill_inner_loops);
        if (!grew && rules_.clearance > 0.0) grew = apply(&Grower::pull_clearance);
        if (!grew) break;
        close_groups(before);
    }
    if (rules_.verify_disk) verify();
    return rounds;
}

void Grower::verify() const {
    // One component (join_components ran), no pinch (the pinch rule ran last
    // without change), Euler characteristic 1.
    if (S_.size() == m_.n_triangles && !rules_.allow_mesh_boundary)
        throw GeometryError(fn_ + ": the removed set grew to the whole mesh");
    const long chi = euler();
    if (chi != 1)
        throw GeometryError(fn_ + ": the removed set cannot be grown into a disk (Euler "
                            "characteristic " + std::to_string(chi) +
                            "); the region probably surrounds a hole of the mesh");
}

// ------------------------------------------------------------ overlapping_triangles
namespace {

void check_mesh(const double* V, std::size_t n, std::size_t stride, const std::int64_t* T,
                std::size_t m) {
    if (stride != 2 && stride != 3)
        throw std::invalid_argument(std::string(kFn) + ": vertices must have 2 or 3 columns");
    check_coordinates(V, n, stride, 2, kFn, "vertices");
    for (std::size_t t = 0; t < 3 * m; ++t)
        if (T[t] < 0 || static_cast<std::uint64_t>(T[t]) >= n)
            throw std::invalid_argument(std::string(kFn) + ": triangles row " + std::to_string(t / 3) +
                                        " has vertex index " + std::to_string(T[t]) +
                                        " out of range [0, " + std::to_string(n) + ")");
}

std::vector<std::int64_t> run_overlap(const AabbTree* tree, const double* V, std::size_t n,
                                      std::size_t stride, const std::int64_t* T, std::size_t m,
                                      const double* ring_xy, const std::int64_t* ring_offsets,
                                      std::size_t n_rings, const OverlapOptions& opt) {
    check_mesh(V, n, stride, T, m);
    if (n_rings > 0 && ring_offsets == nullptr)
        throw std::invalid_argument(std::string(kFn) + ": ring offsets missing");
    const Region R(ring_xy, ring_offsets, n_rings);
    const bool open = opt.predicate == OverlapPredicate::open_interior;
    std::vector<std::int64_t> out;
    if ((open ? R.empty() : R.nothing_drawn()) || m == 0) return out;
    const Box2 rb = open ? R.bounds() : R.drawn_bounds();
    // Stage 1: candidates whose box meets R's box.
    std::vector<std::int64_t> cand;
    if (tree) {
        if (tree->size() != m)
            throw std::invalid_argument(std::string(kFn) + ": the tree has " + std::to_string(tree->size()) +
                                        " primitives but there are " + std::to_string(m) + " triangles");
        tree->query(rb, cand);
        std::sort(cand.begin(), cand.end());
    } else {
        // One region against one mesh: a linear pass over the triangle boxes
        // is cheaper than building a tree first.
        for (std::size_t t = 0; t < m; ++t) {
            const double* a = V + stride * static_cast<std::size_t>(T[3 * t]);
            const double* b = V + stride * static_cast<std::size_t>(T[3 * t + 1]);
            const double* c = V + stride * static_cast<std::size_t>(T[3 * t + 2]);
            if (boxes_meet(triangle_box(a, b, c), rb)) cand.push_back(static_cast<std::int64_t>(t));
        }
    }
    // Stage 2: exact tests.
    for (std::int64_t t : cand) {
        const double* a = V + stride * static_cast<std::size_t>(T[3 * t]);
        const double* b = V + stride * static_cast<std::size_t>(T[3 * t + 1]);
        const double* c = V + stride * static_cast<std::size_t>(T[3 * t + 2]);
        if (open) {
            const int s = orient2d_sign(a, b, c);
            if (s == 0) continue;  // no interior
            if (s < 0) std::swap(b, c);
        }
        if (R.meets(a, b, c, opt.predicate)) out.push_back(t);
    }
    if (!opt.grow_to_disk) return out;
    // The paper's growth rules (overlap.hpp) on an adjacency that accepts
    // triangles of any orientation.
    const std::vector<std::int64_t> twins =
        halfedge_twins(T, m, n, EdgeOrientation::any, std::string(kFn) + " (grow_to_disk)");
    std::vector<std::uint32_t> marks(m, 0);
    RemovedSet S(marks, 1);
    for (std::int64_t t : out) S.add(t);
    GrowthMesh mesh{V, stride, n, T, twins.data(), m};
    GrowthRules rules;
    rules.grow_touching = true;
    rules.join_components = true;
    rules.pinch = PinchRule::keep_largest_kept_fan;
    rules.holes = HoleRule::absorb_kept_islands;
    rules.allow_mesh_boundary = opt.allow_mesh_boundary;
    rules.verify_disk = true;
    Grower(mesh, S, R, rules, kFn).run();
    out = S.members();
    std::sort(out.begin(), out.end());
    return out;
}

}  // namespace
}  // namespace detail

std::vector<std::int64_t> overlapping_triangles(const double* vertices, std::size_t n_vertices,
                                                std::size_t stride, const std::int64_t* triangles,
                                                std::size_t n_triangles, const double* ring_xy,
                                                const std::int64_t* ring_offsets, std::size_t n_rings,
                                                const OverlapOptions& options) {
    return detail::run_overlap(nullptr, vertices, n_vertices, stride, triangles, n_triangles, ring_xy,
                               ring_offsets, n_rings, options);
}

std::vector<std::int64_t> overlapping_triangles(const AabbTree& tree, const double* vertices,
                                                std::size_t n_vertices, std::size_t stride,
                                                const std::int64_t* triangles, std::size_t n_triangles,
                                                const double* ring_xy, const std::int64_t* ring_offsets,
                                                std::size_t n_rings, const OverlapOptions& options) {
    return detail::run_overlap(&tree, vertices, n_vertices, stride, triangles, n_triangles, ring_xy,
                               ring_offsets, n_rings, options);
}

bool triangle_overlaps_region(const double* a, const double* b, const double* c, const double* ring_xy,
                              const std::int64_t* ring_offsets, std::size_t n_rings) {
    const double* abc[3] = {a, b, c};
    for (int v = 0; v < 3; ++v)
        for (int k = 0; k < 2; ++k)
            if (!coordinate_in_range(abc[v][k]))
                throw_coordinate_error("triangle_overlaps_region", std::string(1, "abc"[v]), k, abc[v][k]);
    const int s = orient2d_sign(a, b, c);
    if (s == 0) return false;
    if (s < 0) std::swap(b, c);
    const detail::Region R(ring_xy, ring_offsets, n_rings);
    if (R.empty()) return false;
    return R.meets_open_triangle(a, b, c);
}

}  // namespace faultmesh
