// Overlap detection (paper 2.4): AABB candidates + exact 2D tests, and the
// growth of the removed set into a topological disk.
#include <faultmesh/errors.hpp>
#include <faultmesh/overlap.hpp>
#include <faultmesh/predicates.hpp>

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>

namespace faultmesh {

namespace detail {
namespace {

constexpr const char* kFn = "overlapping_triangles";

// ------------------------------------------------------------ exact helpers
inline bool same_point(const double* p, const double* q) { return p[0] == q[0] && p[1] == q[1]; }

// r strictly between p and q, given that p, q, r are collinear and p != q.
inline bool strictly_between(const double* p, const double* q, const double* r) {
    if (p[0] != q[0]) return (p[0] < r[0] && r[0] < q[0]) || (q[0] < r[0] && r[0] < p[0]);
    return (p[1] < r[1] && r[1] < q[1]) || (q[1] < r[1] && r[1] < p[1]);
}
// r on the closed segment pq, given collinearity.
inline bool on_closed(const double* p, const double* q, const double* r) {
    return std::min(p[0], q[0]) <= r[0] && r[0] <= std::max(p[0], q[0]) &&
           std::min(p[1], q[1]) <= r[1] && r[1] <= std::max(p[1], q[1]);
}

// Closed segments pq and rs share a point.
bool segments_meet(const double* p, const double* q, const double* r, const double* s) {
    const int o1 = orient2d_sign(p, q, r), o2 = orient2d_sign(p, q, s);
    const int o3 = orient2d_sign(r, s, p), o4 = orient2d_sign(r, s, q);
    if (o1 * o2 < 0 && o3 * o4 < 0) return true;
    if (o1 == 0 && on_closed(p, q, r)) return true;
    if (o2 == 0 && on_closed(p, q, s)) return true;
    if (o3 == 0 && on_closed(r, s, p)) return true;
    if (o4 == 0 && on_closed(r, s, q)) return true;
    return false;
}

// Closed segment pq meets the open triangle abc (counter-clockwise, non-zero
// area). Separating axes: a triangle edge with p and q on its closed outer
// side, or the segment's line with a, b, c on one closed side.
bool segment_meets_open_triangle(const double* p, const double* q, const double* a, const double* b,
                                 const double* c) {
    const double* t[3] = {a, b, c};
    for (int e = 0; e < 3; ++e) {
        const double* u = t[e];
        const double* v = t[(e + 1) % 3];
        if (orient2d_sign(u, v, p) <= 0 && orient2d_sign(u, v, q) <= 0) return false;
    }
    const int oa = orient2d_sign(p, q, a), ob = orient2d_sign(p, q, b), oc = orient2d_sign(p, q, c);
    if (oa >= 0 && ob >= 0 && oc >= 0) return false;
    if (oa <= 0 && ob <= 0 && oc <= 0) return false;
    return true;
}

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

// ------------------------------------------------------------ the region
struct Seg {
    double p[2], q[2];
};

class Region {
public:
    Region(const double* ring_xy, const std::int64_t* ring_offsets, std::size_t n_rings);

    bool empty() const { return edges_.empty(); }
    const Box2& bounds() const { return bounds_; }

    // The open triangle abc (CCW, non-zero area) meets R's interior.
    bool meets_open_triangle(const double* a, const double* b, const double* c) const {
        const Box2 tb{std::min({a[0], b[0], c[0]}), std::min({a[1], b[1], c[1]}),
                      std::max({a[0], b[0], c[0]}), std::max({a[1], b[1], c[1]})};
        if (!boxes_meet(tb, bounds_)) return false;
        if (tree_.any_of(tb, [&](std::int64_t i) {
                const Seg& s = edges_[static_cast<std::size_t>(i)];
                return segment_meets_open_triangle(s.p, s.q, a, b, c);
            }))
            return true;
        return wedge_parity(a, b);
    }

    // Parity (1 = inside R) of the points just counter-clockwise of the
    // direction a -> b, arbitrarily close to a.
    bool wedge_parity(const double* a, const double* b) const;

    // The closed segment pq meets the closure of R.
    bool segment_meets_closure(const double* p, const double* q) const {
        const Box2 sb{std::min(p[0], q[0]), std::min(p[1], q[1]), std::max(p[0], q[0]),
                      std::max(p[1], q[1])};
        if (!boxes_meet(sb, bounds_)) return false;
        if (tree_.any_of(sb, [&](std::int64_t i) {
                const Seg& s = edges_[static_cast<std::size_t>(i)];
                return segments_meet(p, q, s.p, s.q);
            }))
            return true;
        // Not touching dR: the segment is in R iff its endpoint is (p is off
        // dR, so the wedge parity in any direction is the parity of p).
        return wedge_parity(p, q);
    }

private:
    std::vector<Seg> edges_;
    AabbTree tree_;
    Box2 bounds_{};
    // Horizontal slabs over [y0, y1] for the crossing count: an edge is listed
    // in every slab its closed y-range touches.
    double y0_ = 0, y1_ = 0, scale_ = 0;
    std::size_t nslab_ = 0;
    std::vector<std::uint32_t> slab_start_, slab_edges_;
    std::size_t slab_of(double y) const {
        double f = (y - y0_) * scale_;
        if (!(f >= 0)) f = 0;
        auto s = static_cast<std::size_t>(std::min(f, static_cast<double>(nslab_ - 1)));
        return std::min(s, nslab_ - 1);
    }
};

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
        if (ring.size() < 2) continue;
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
    if (raw.empty()) return;

    // 2. Split every edge at the ring vertices in its relative interior.
    std::vector<Box2> boxes(raw.size());
    for (std::size_t i = 0; i < raw.size(); ++i)
        boxes[i] = {std::min(raw[i].p[0], raw[i].q[0]), std::min(raw[i].p[1], raw[i].q[1]),
                    std::max(raw[i].p[0], raw[i].q[0]), std::max(raw[i].p[1], raw[i].q[1])};
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
    // Undirected pieces, endpoints in lexicographic order.
    std::vector<Seg> pieces;
    for (std::size_t i = 0; i < raw.size(); ++i) {
        const double* lo = raw[i].p;
        const double* hi = raw[i].q;
        if (lex_less(hi, lo)) std::swap(lo, hi);
        auto& sp = splits[i];
        // Collinear points on the open segment: lexicographic order is the
        // order along the segment from lo to hi.
        std::sort(sp.begin(), sp.end(), [](const double* x, const double* y) { return lex_less(x, y); });
        sp.erase(std::unique(sp.begin(), sp.end(), [](const double* x, const double* y) { return same_point(x, y); }),
                 sp.end());
        const double* prev = lo;
        for (std::size_t j = 0; j <= sp.size(); ++j) {
            const double* nx = j < sp.size() ? sp[j] : hi;
            Seg s;
            s.p[0] = prev[0];
            s.p[1] = prev[1];
            s.q[0] = nx[0];
            s.q[1] = nx[1];
            pieces.push_back(s);
            prev = nx;
        }
    }
    // 3. Equal pieces cancel in pairs (they do not change the parity).
    auto key_less = [](const Seg& x, const Seg& y) {
        if (x.p[0] != y.p[0]) return x.p[0] < y.p[0];
        if (x.p[1] != y.p[1]) return x.p[1] < y.p[1];
        if (x.q[0] != y.q[0]) return x.q[0] < y.q[0];
        return x.q[1] < y.q[1];
    };
    auto key_eq = [](const Seg& x, const Seg& y) {
        return same_point(x.p, y.p) && same_point(x.q, y.q);
    };
    std::sort(pieces.begin(), pieces.end(), key_less);
    for (std::size_t i = 0; i < pieces.size();) {
        std::size_t j = i + 1;
        while (j < pieces.size() && key_eq(pieces[i], pieces[j])) ++j;
        if ((j - i) % 2 == 1) edges_.push_back(pieces[i]);
        i = j;
    }
    if (edges_.empty()) return;

    // 4. Tree over dR and slabs for the crossing count.
    boxes.resize(edges_.size());
    bounds_ = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
               -std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
    for (std::size_t i = 0; i < edges_.size(); ++i) {
        const Seg& s = edges_[i];
        boxes[i] = {std::min(s.p[0], s.q[0]), std::min(s.p[1], s.q[1]), std::max(s.p[0], s.q[0]),
                    std::max(s.p[1], s.q[1])};
        bounds_.xmin = std::min(bounds_.xmin, boxes[i].xmin);
        bounds_.ymin = std::min(bounds_.ymin, boxes[i].ymin);
        bounds_.xmax = std::max(bounds_.xmax, boxes[i].xmax);
        bounds_.ymax = std::max(bounds_.ymax, boxes[i].ymax);
    }
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
            through = o == 0 && on_closed(p, q, a);
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

// ------------------------------------------------------------ inputs
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

// ------------------------------------------------------------ mesh topology
struct Topo {
    std::vector<std::int32_t> nbr;        // 3 per triangle: across edge (t[e], t[e+1]), -1 = none
    std::vector<char> boundary_vertex;    // on a mesh-boundary edge
    std::vector<std::uint32_t> degree;    // number of triangles at each vertex
};

// Edge adjacency by the same counting sort as boundary.cpp: half-edges go to
// the bucket of their smaller vertex (an 8-byte entry: other vertex, half-edge
// id), and each bucket is matched with an O(d^2) scan (d is about six in a
// TIN; large buckets are sorted).
Topo build_topo(const std::int64_t* T, std::size_t m, std::size_t n) {
    if (m > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()) / 3 ||
        n > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
        throw std::invalid_argument(std::string(kFn) + ": grow_to_disk supports up to 715827882 triangles");
    Topo topo;
    topo.nbr.assign(3 * m, -1);
    topo.degree.assign(n, 0);
    std::vector<std::uint32_t> start(n + 1, 0);
    for (std::size_t t = 0; t < m; ++t) {
        const auto a = static_cast<std::uint32_t>(T[3 * t]), b = static_cast<std::uint32_t>(T[3 * t + 1]),
                   c = static_cast<std::uint32_t>(T[3 * t + 2]);
        ++start[std::min(a, b) + 1];
        ++start[std::min(b, c) + 1];
        ++start[std::min(c, a) + 1];
        ++topo.degree[a];
        ++topo.degree[b];
        ++topo.degree[c];
    }
    for (std::size_t v = 0; v < n; ++v) start[v + 1] += start[v];
    std::unique_ptr<std::uint64_t[]> ent(new std::uint64_t[3 * m + 1]);  // other << 32 | h
    for (std::size_t h = 0; h < 3 * m; ++h) {
        const auto u = static_cast<std::uint64_t>(T[h]), v = static_cast<std::uint64_t>(T[h % 3 == 2 ? h - 2 : h + 1]);
        const std::uint64_t key = u < v ? u : v, other = u < v ? v : u;
        ent[start[key]++] = (other << 32) | h;
    }
    for (std::size_t v = n; v > 0; --v) start[v] = start[v - 1];
    start[0] = 0;
    topo.boundary_vertex.assign(n, 0);
    auto fail = [&](std::size_t v, std::uint64_t other, std::size_t cnt) {
        throw GeometryError(std::string(kFn) + ": grow_to_disk needs a manifold mesh, but edge (" +
                            std::to_string(v) + ", " + std::to_string(other) + ") is used by " +
                            std::to_string(cnt) + " triangles");
    };
    for (std::size_t v = 0; v < n; ++v) {
        std::uint64_t* b = ent.get() + start[v];
        const std::size_t d = start[v + 1] - start[v];
        if (d > 32) {
            // Fan centres: sort by other vertex, then runs are the edges.
            std::sort(b, b + d);
            for (std::size_t i = 0; i < d;) {
                std::size_t j = i + 1;
                while (j < d && (b[j] >> 32) == (b[i] >> 32)) ++j;
                if (j - i == 1) {
                    topo.boundary_vertex[v] = 1;
                    topo.boundary_vertex[static_cast<std::size_t>(b[i] >> 32)] = 1;
                } else if (j - i == 2) {
                    topo.nbr[b[i] & 0xffffffffULL] = static_cast<std::int32_t>((b[i + 1] & 0xffffffffULL) / 3);
                    topo.nbr[b[i + 1] & 0xffffffffULL] = static_cast<std::int32_t>((b[i] & 0xffffffffULL) / 3);
                } else {
                    fail(v, b[i] >> 32, j - i);
                }
                i = j;
            }
            continue;
        }
        for (std::size_t i = 0; i < d; ++i) {
            const std::uint64_t o = b[i] >> 32;
            std::size_t cnt = 0, partner = i;
            for (std::size_t j = 0; j < d; ++j)
                if ((b[j] >> 32) == o) {
                    ++cnt;
                    if (j != i) partner = j;
                }
            if (cnt == 1) {
                topo.boundary_vertex[v] = 1;
                topo.boundary_vertex[static_cast<std::size_t>(o)] = 1;
            } else if (cnt == 2) {
                topo.nbr[b[i] & 0xffffffffULL] = static_cast<std::int32_t>((b[partner] & 0xffffffffULL) / 3);
            } else {
                fail(v, o, cnt);
            }
        }
    }
    return topo;
}

// ------------------------------------------------------------ growth
class Grower {
public:
    Grower(const double* V, std::size_t stride, const std::int64_t* T, std::size_t m, std::size_t n,
           const Region& R, const OverlapOptions& opt, std::vector<char>& in)
        : V_(V), stride_(stride), T_(T), m_(m), n_(n), R_(R), opt_(opt), in_(in),
          topo_(build_topo(T, m, n)) {}

    void run();

private:
    const double* pt(std::int64_t v) const { return V_ + stride_ * static_cast<std::size_t>(v); }
    std::int64_t vtx(std::int64_t t, int c) const { return T_[3 * static_cast<std::size_t>(t) + static_cast<std::size_t>(c)]; }
    std::int64_t nb(std::int64_t t, int e) const { return topo_.nbr[3 * static_cast<std::size_t>(t) + static_cast<std::size_t>(e)]; }
    void add(std::int64_t t) {
        if (!in_[static_cast<std::size_t>(t)]) {
            in_[static_cast<std::size_t>(t)] = 1;
            members_.push_back(t);
            changed_ = true;
        }
    }
    void refresh_members() {
        members_.clear();
        for (std::size_t t = 0; t < m_; ++t)
            if (in_[t]) members_.push_back(static_cast<std::int64_t>(t));
    }
    bool grow_touching();
    bool join_components();
    bool fix_pinches();
    bool fill_kept_components();
    void check_mesh_boundary() const;
    // The star of v in fan order; cyclic tells whether it closes.
    // The star of v (t0: a triangle at v) in fan order; cyclic tells whether
    // it closes. False if the triangles at v are not one fan (a pinch of the
    // mesh itself).
    bool star(std::int64_t v, std::int64_t t0, std::vector<std::int64_t>& fan, bool& cyclic) const;
    long euler() const;

    const double* V_;
    std::size_t stride_;
    const std::int64_t* T_;
    std::size_t m_, n_;
    const Region& R_;
    const OverlapOptions& opt_;
    std::vector<char>& in_;
    Topo topo_;
    std::vector<std::int64_t> members_;
    bool changed_ = false;
};

void Grower::check_mesh_boundary() const {
    if (opt_.allow_mesh_boundary) return;
    for (std::int64_t t : members_)
        for (int c = 0; c < 3; ++c)
            if (topo_.boundary_vertex[static_cast<std::size_t>(vtx(t, c))])
                throw GeometryError(std::string(kFn) + ": the removed set reaches the mesh boundary at vertex " +
                                    std::to_string(vtx(t, c)) +
                                    " (the region reaches the study-area boundary), so it cannot be a "
                                    "disk strictly inside the mesh; pass allow_mesh_boundary=True");
}

// Add the kept neighbour across every boundary edge of S whose closed
// segment meets the closure of R (R must be in S's interior).
bool Grower::grow_touching() {
    changed_ = false;
    std::vector<std::int64_t> add_list;
    for (std::int64_t t : members_)
        for (int e = 0; e < 3; ++e) {
            const std::int64_t u = nb(t, e);
            if (u >= 0 && in_[static_cast<std::size_t>(u)]) continue;
            if (u < 0) continue;  // mesh boundary: handled by check_mesh_boundary / allowed
            if (R_.segment_meets_closure(pt(vtx(t, e)), pt(vtx(t, (e + 1) % 3)))) add_list.push_back(u);
        }
    for (std::int64_t u : add_list) add(u);
    return changed_;
}

// Join edge-connected components of S along shortest dual paths.
bool Grower::join_components() {
    changed_ = false;
    for (;;) {
        std::vector<std::int64_t> comp(m_, -1);
        std::int64_t ncomp = 0;
        std::vector<std::int64_t> q;
        for (std::int64_t s : members_) {
            if (comp[static_cast<std::size_t>(s)] >= 0) continue;
            comp[static_cast<std::size_t>(s)] = ncomp;
            q.assign(1, s);
            while (!q.empty()) {
                const std::int64_t t = q.back();
                q.pop_back();
                for (int e = 0; e < 3; ++e) {
                    const std::int64_t u = nb(t, e);
                    if (u >= 0 && in_[static_cast<std::size_t>(u)] && comp[static_cast<std::size_t>(u)] < 0) {
                        comp[static_cast<std::size_t>(u)] = ncomp;
                        q.push_back(u);
                    }
                }
            }
            ++ncomp;
        }
        if (ncomp <= 1) return changed_;
        // BFS from component 0 through kept triangles to the nearest triangle
        // of another component.
        std::vector<std::int64_t> from(m_, -2);
        std::deque<std::int64_t> bq;
        for (std::int64_t s : members_)
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
                if (in_[static_cast<std::size_t>(u)]) {
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
            throw GeometryError(std::string(kFn) + ": the region's parts lie in different "
                                "connected pieces of the mesh; the removed set cannot be one disk");
        for (std::int64_t t = hit_from; t >= 0 && !in_[static_cast<std::size_t>(t)]; t = from[static_cast<std::size_t>(t)])
            add(t);
        changed_ = true;
    }
}

bool Grower::star(std::int64_t v, std::int64_t t0, std::vector<std::int64_t>& fan, bool& cyclic) const {
    const std::size_t deg = topo_.degree[static_cast<std::size_t>(v)];
    fan.clear();
    cyclic = false;
    // In triangle t, the edge index of {v, w}, and the third vertex.
    auto edge_to = [&](std::int64_t t, std::int64_t w) {
        for (int k = 0; k < 3; ++k) {
            const std::int64_t x = vtx(t, k), y = vtx(t, (k + 1) % 3);
            if ((x == v && y == w) || (x == w && y == v)) return k;
        }
        return -1;
    };
    auto other = [&](std::int64_t t, std::int64_t w) {  // vertex of t that is neither v nor w
        for (int k = 0; k < 3; ++k)
            if (vtx(t, k) != v && vtx(t, k) != w) return vtx(t, k);
        return std::int64_t{-1};
    };
    std::int64_t w0 = -1;
    for (int k = 0; k < 3; ++k)
        if (vtx(t0, k) != v) {
            w0 = vtx(t0, k);
            break;
        }
    // Walk from t0 across {v, w0}'s opposite side to one end (or around).
    // Step: in t, leave across the edge {v, x} where x != the vertex we came over.
    auto walk = [&](std::int64_t t, std::int64_t came, std::vector<std::int64_t>& out) {
        // returns true if the walk came back to t0
        for (;;) {
            const std::int64_t x = other(t, came);
            const int k = edge_to(t, x);
            const std::int64_t u = nb(t, k);
            if (u < 0) return false;
            if (u == t0) return true;
            out.push_back(u);
            if (out.size() > deg) return false;
            came = x;
            t = u;
        }
    };
    std::vector<std::int64_t> fwd, bwd;
    // Forward: leave t0 across {v, other(t0, w0)}.
    cyclic = walk(t0, w0, fwd);
    if (cyclic) {
        fan.push_back(t0);
        fan.insert(fan.end(), fwd.begin(), fwd.end());
    } else {
        // Backward: leave t0 across {v, w0}.
        const std::int64_t x0 = other(t0, w0);
        walk(t0, x0, bwd);
        fan.assign(bwd.rbegin(), bwd.rend());
        fan.push_back(t0);
        fan.insert(fan.end(), fwd.begin(), fwd.end());
    }
    return fan.size() == deg;
}

// Around each vertex on S's boundary, S and the kept triangles must each be
// at most one fan; the smaller gaps are absorbed into S.
bool Grower::fix_pinches() {
    changed_ = false;
    // (vertex, a triangle of S at it) for the vertices of S's boundary edges.
    std::vector<std::pair<std::int64_t, std::int64_t>> verts;
    for (std::int64_t t : members_)
        for (int e = 0; e < 3; ++e) {
            const std::int64_t u = nb(t, e);
            if (u >= 0 && in_[static_cast<std::size_t>(u)]) continue;
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
            throw GeometryError(std::string(kFn) + ": grow_to_disk needs a manifold mesh, but vertex " +
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
            while (i < d && in_[static_cast<std::size_t>(fan[i])] == in_[static_cast<std::size_t>(fan[(i + d - 1) % d])]) ++i;
            if (i == d) continue;  // all one kind
            start = i;
        }
        for (std::size_t k = 0; k < d; ++k) {
            const std::int64_t t = fan[(start + k) % d];
            const bool inside = in_[static_cast<std::size_t>(t)] != 0;
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
    for (std::int64_t t : to_add) add(t);
    return changed_;
}

long Grower::euler() const {
    // V - E + F of S: E from the half-edges (boundary edges once, interior twice).
    long F = static_cast<long>(members_.size()), bnd = 0;
    std::vector<std::int64_t> vs;
    vs.reserve(3 * members_.size());
    for (std::int64_t t : members_)
        for (int e = 0; e < 3; ++e) {
            vs.push_back(vtx(t, e));
            const std::int64_t u = nb(t, e);
            if (u < 0 || !in_[static_cast<std::size_t>(u)]) ++bnd;
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
bool Grower::fill_kept_components() {
    changed_ = false;
    bool touches = false;
    for (std::int64_t t : members_)
        for (int c = 0; c < 3; ++c)
            if (topo_.boundary_vertex[static_cast<std::size_t>(vtx(t, c))]) touches = true;
    if (!touches && euler() == 1) return false;
    std::vector<std::int64_t> comp(m_, -1);
    std::vector<std::int64_t> size;
    std::vector<char> reaches;
    std::vector<std::int64_t> q;
    for (std::size_t s = 0; s < m_; ++s) {
        if (in_[s] || comp[s] >= 0) continue;
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
                if (in_[static_cast<std::size_t>(u)] || comp[static_cast<std::size_t>(u)] >= 0) continue;
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
    for (std::size_t t = 0; t < m_; ++t)
        if (!in_[t] && absorb[static_cast<std::size_t>(comp[t])]) add(static_cast<std::int64_t>(t));
    return changed_;
}

void Grower::run() {
    refresh_members();
    if (members_.empty()) return;
    check_mesh_boundary();
    for (;;) {
        // Local rules to a fixed point, then the global one.
        for (;;) {
            bool local = grow_touching();
            check_mesh_boundary();
            local = join_components() || local;
            local = fix_pinches() || local;
            check_mesh_boundary();
            if (!local) break;
        }
        // Kept components are only inspected once the local rules are done;
        // absorbing one may create new local work, hence the outer loop.
        if (!fill_kept_components()) break;
        check_mesh_boundary();
    }
    // Verify: one component (join_components ran), no pinch (fix_pinches ran
    // last without change), Euler characteristic 1.
    if (members_.size() == m_ && !opt_.allow_mesh_boundary)
        throw GeometryError(std::string(kFn) + ": the removed set grew to the whole mesh");
    const long chi = euler();
    if (chi != 1)
        throw GeometryError(std::string(kFn) + ": the removed set cannot be grown into a disk (Euler "
                            "characteristic " + std::to_string(chi) +
                            "); the region probably surrounds a hole of the mesh");
}

std::vector<std::int64_t> run_overlap(const AabbTree* tree, const double* V, std::size_t n,
                                      std::size_t stride, const std::int64_t* T, std::size_t m,
                                      const double* ring_xy, const std::int64_t* ring_offsets,
                                      std::size_t n_rings, const OverlapOptions& opt) {
    check_mesh(V, n, stride, T, m);
    if (n_rings > 0 && ring_offsets == nullptr)
        throw std::invalid_argument(std::string(kFn) + ": ring offsets missing");
    const Region R(ring_xy, ring_offsets, n_rings);
    std::vector<std::int64_t> out;
    if (R.empty() || m == 0) return out;
    const Box2 rb = R.bounds();
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
            const Box2 tb{std::min({a[0], b[0], c[0]}), std::min({a[1], b[1], c[1]}),
                          std::max({a[0], b[0], c[0]}), std::max({a[1], b[1], c[1]})};
            if (boxes_meet(tb, rb)) cand.push_back(static_cast<std::int64_t>(t));
        }
    }
    // Stage 2: exact tests.
    for (std::int64_t t : cand) {
        const double* a = V + stride * static_cast<std::size_t>(T[3 * t]);
        const double* b = V + stride * static_cast<std::size_t>(T[3 * t + 1]);
        const double* c = V + stride * static_cast<std::size_t>(T[3 * t + 2]);
        const int s = orient2d_sign(a, b, c);
        if (s == 0) continue;  // no interior
        if (s < 0) std::swap(b, c);
        if (R.meets_open_triangle(a, b, c)) out.push_back(t);
    }
    if (!opt.grow_to_disk) return out;
    std::vector<char> in(m, 0);
    for (std::int64_t t : out) in[static_cast<std::size_t>(t)] = 1;
    Grower g(V, stride, T, m, n, R, opt, in);
    g.run();
    out.clear();
    for (std::size_t t = 0; t < m; ++t)
        if (in[t]) out.push_back(static_cast<std::int64_t>(t));
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
