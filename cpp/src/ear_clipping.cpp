// Ear clipping of polygons with holes (see ear_clipping.hpp for the contract).
//
// Structure of this file:
//   input       -- validate arguments, drop consecutive duplicates, orient rings
//   SegGrid     -- uniform grid over ring and bridge segments (bridge visibility)
//   Joiner      -- doubly linked node list, hole bridges (extreme points, Eberly)
//   Clipper     -- ear clipping with a uniform grid over reflex vertices
//   check       -- polygon validity (strict mode and tests)
#include <faultmesh/ear_clipping.hpp>

#include <faultmesh/errors.hpp>
#include <faultmesh/polygon_cdt.hpp>
#include <faultmesh/predicates.hpp>
#include <faultmesh/segments.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <atomic>
#include <exception>
#include <queue>
#include <system_error>
#include <thread>
#include <stdexcept>
#include <string>
#include <utility>

namespace faultmesh {
namespace detail {
namespace {

using I64 = std::int64_t;

inline int sgn(double v) { return (v > 0.0) - (v < 0.0); }

// orient2d with one well-predicted branch on the common path: Shewchuk's
// error bound A holds for |detleft| + |detright| whatever their signs, so a
// determinant beyond it has the exact sign; otherwise the full exact
// predicate decides. Same sign as orient2d always.
inline double orient2d_quick(const double* pa, const double* pb, const double* pc) {
    const double detleft = (pa[0] - pc[0]) * (pb[1] - pc[1]);
    const double detright = (pa[1] - pc[1]) * (pb[0] - pc[0]);
    const double det = detleft - detright;
    const double err = kCcwErrBoundA * (std::fabs(detleft) + std::fabs(detright));
    if (std::fabs(det) > err) return det;
    return orient2d(pa, pb, pc);
}

// ----------------------------------------------------------------- input

struct Rings {
    // Cleaned rings: vertex indices into xy, consecutive duplicates removed.
    std::vector<std::vector<I64>> v;
};

Rings read_rings(const char* fn, const double* xy, std::size_t n_points, const I64* ring_vertices,
                 const I64* ring_offsets, std::size_t n_rings) {
    if (n_rings > 0 && ring_offsets == nullptr)
        throw std::invalid_argument(std::string(fn) + ": ring_offsets is null");
    if (n_rings > 0 && xy == nullptr && n_points > 0)
        throw std::invalid_argument(std::string(fn) + ": xy is null");
    if (n_points >= (std::size_t(1) << 31))
        throw std::invalid_argument(std::string(fn) + ": more than 2^31 points are not supported");
    Rings out;
    out.v.resize(n_rings);
    if (n_rings == 0) return out;
    if (ring_offsets[0] != 0)
        throw std::invalid_argument(std::string(fn) + ": ring_offsets[0] must be 0, got " +
                                    std::to_string(ring_offsets[0]));
    for (std::size_t r = 0; r < n_rings; ++r) {
        const I64 b = ring_offsets[r], e = ring_offsets[r + 1];
        if (e < b)
            throw std::invalid_argument(std::string(fn) + ": ring_offsets must be non-decreasing (ring " +
                                        std::to_string(r) + ": " + std::to_string(b) + " > " +
                                        std::to_string(e) + ")");
        if (ring_vertices == nullptr && static_cast<std::size_t>(e) > n_points)
            throw std::invalid_argument(std::string(fn) + ": ring " + std::to_string(r) + " ends at " +
                                        std::to_string(e) + ", past the " + std::to_string(n_points) +
                                        " points");
        auto& ring = out.v[r];
        ring.reserve(static_cast<std::size_t>(e - b));
        for (I64 k = b; k < e; ++k) {
            const I64 i = ring_vertices ? ring_vertices[k] : k;
            if (i < 0 || static_cast<std::size_t>(i) >= n_points)
                throw std::invalid_argument(std::string(fn) + ": ring " + std::to_string(r) +
                                            " position " + std::to_string(k - b) + " has vertex index " +
                                            std::to_string(i) + " out of range [0, " +
                                            std::to_string(n_points) + ")");
            const double x = xy[2 * i], y = xy[2 * i + 1];
            if (!coordinate_in_range(x) || !coordinate_in_range(y))
                throw_coordinate_error(fn, "ring " + std::to_string(r) + " vertex " + std::to_string(k - b) +
                                           " (point " + std::to_string(i) + ")",
                                       coordinate_in_range(x) ? 1 : 0, coordinate_in_range(x) ? y : x);
            if (!ring.empty()) {
                const I64 j = ring.back();
                if (xy[2 * j] == x && xy[2 * j + 1] == y) continue;  // consecutive duplicate
            }
            ring.push_back(i);
        }
        // A closing point equal to the first (GeoJSON style) is a duplicate too.
        while (ring.size() > 1) {
            const I64 f = ring.front(), l = ring.back();
            if (xy[2 * f] == xy[2 * l] && xy[2 * f + 1] == xy[2 * l + 1])
                ring.pop_back();
            else
                break;
        }
    }
    return out;
}

// +1 counter-clockwise, -1 clockwise, 0 degenerate (fewer than 3 vertices or
// zero area). The shoelace sum decides when it is far above its rounding
// error (for a self-crossing ring it gives the net orientation, as earcut
// uses). Otherwise the exact orient2d at the lexicographically smallest
// vertex decides: a simple ring is strictly convex there.
int ring_orientation(const double* xy, const std::vector<I64>& r, double* area2 = nullptr, double* mag2 = nullptr) {
    const std::size_t n = r.size();
    if (n < 3) return 0;
    double s = 0, mag = 0;
    const double x0 = xy[2 * r[0]], y0 = xy[2 * r[0] + 1];
    std::size_t m = 0;
    for (std::size_t k = 0; k < n; ++k) {
        const double* p = xy + 2 * r[k];
        const double* q = xy + 2 * r[k + 1 == n ? 0 : k + 1];
        const double t = (p[0] - x0) * (q[1] - y0) - (q[0] - x0) * (p[1] - y0);
        s += t;
        mag += std::fabs(t);
        const double* b = xy + 2 * r[m];
        if (p[0] < b[0] || (p[0] == b[0] && p[1] < b[1])) m = k;
    }
    // Each term carries a relative error of a few 1e-16 of the magnitude
    // (the differences to the first point are rounded), and summing n terms
    // adds at most n * 1.1e-16 of it: 1e-9 of the magnitude is far above the
    // accumulated error for any ring below a million vertices.
    if (area2) *area2 = s;
    if (mag2) *mag2 = mag;
    if (s > 1e-9 * mag) return 1;
    if (s < -1e-9 * mag) return -1;
    const double* a = xy + 2 * r[(m + n - 1) % n];
    const double* b = xy + 2 * r[m];
    const double* c = xy + 2 * r[(m + 1) % n];
    const int o = orient2d_sign(a, b, c);
    if (o != 0) return o;
    return (s > 0) - (s < 0);
}

// ----------------------------------------------------------------- segment grid

// Uniform grid over segments (pairs of vertex indices). Used for the
// visibility of bridge candidates and for the validity check. The traversal
// walks the cells along a segment in its major direction; the minor-direction
// range of each column is widened by a margin that covers the rounding of the
// interpolation, so every cell the exact segment meets is visited.
// Frame of a uniform grid over a box: about `target` cells shaped like the
// box (at most max_side per side), and the cell of a coordinate, monotone
// (all that conservative traversals need; negatives are clamped before the
// truncation, as std::floor is a library call without SSE4.1). Shared by the
// segment grid, the clipper's reflex grid and its live-edge grid.
struct GridFrame {
    double x0 = 0, y0 = 0, cw = 1, ch = 1, icw = 1, ich = 1;
    int nx = 1, ny = 1;
    void shape(double xmin, double ymin, double xmax, double ymax, double target, double max_side) {
        x0 = xmin;
        y0 = ymin;
        const double w = std::max(xmax - xmin, 0.0), h = std::max(ymax - ymin, 0.0);
        target = std::max(1.0, target);
        if (w > 0 && h > 0) {
            nx = static_cast<int>(std::clamp(std::sqrt(target * w / h), 1.0, max_side));
            ny = static_cast<int>(std::clamp(std::sqrt(target * h / w), 1.0, max_side));
        } else {
            nx = w > 0 ? static_cast<int>(std::clamp(target, 1.0, max_side)) : 1;
            ny = h > 0 ? static_cast<int>(std::clamp(target, 1.0, max_side)) : 1;
        }
        cw = w > 0 ? w / nx : 1.0;
        ch = h > 0 ? h / ny : 1.0;
        icw = 1.0 / cw;
        ich = 1.0 / ch;
    }
    int col(double x) const {
        const double c = (x - x0) * icw;
        return c < 1.0 ? 0 : (c >= nx ? nx - 1 : static_cast<int>(c));
    }
    int row(double y) const {
        const double r = (y - y0) * ich;
        return r < 1.0 ? 0 : (r >= ny ? ny - 1 : static_cast<int>(r));
    }
};

struct SegGrid : GridFrame {
    const double* xy = nullptr;
    double margin_x = 0, margin_y = 0;
    std::vector<I64> seg;  // 2 vertex indices per segment
    // Segment ids per cell (CSR), built on the first query over the
    // segments inserted so far; later ones (bridges) are scanned directly.
    std::vector<int> cstart, citems;
    std::size_t n_built = 0;
    bool built = false;
    std::vector<unsigned> mark;
    unsigned epoch = 0;

    void init(const double* pts, double xmin, double ymin, double xmax, double ymax, std::size_t n_seg) {
        xy = pts;
        // About one cell per segment, shaped like the bounding box.
        shape(xmin, ymin, xmax, ymax, static_cast<double>(n_seg), 4096.0);
        // Rounding of the interpolated coordinate is a few ulps of the
        // coordinates' magnitude; 1e-6 of a cell plus 64 ulps of the largest
        // magnitude is far above it.
        const double mag = std::max({std::fabs(xmin), std::fabs(xmax), std::fabs(ymin), std::fabs(ymax)});
        margin_x = 1e-6 * cw + 64 * kEpsilon * mag;
        margin_y = 1e-6 * ch + 64 * kEpsilon * mag;
        built = false;
        n_built = 0;
        seg.clear();
        mark.clear();
        seg.reserve(2 * n_seg + 16);
    }
    template <class F>
    void for_cells(const double* p, const double* q, F&& f) const {
        double ax = p[0], ay = p[1], bx = q[0], by = q[1];
        if (std::fabs(bx - ax) >= std::fabs(by - ay)) {
            if (ax > bx) { std::swap(ax, bx); std::swap(ay, by); }
            const int c0 = col(ax - margin_x), c1 = col(bx + margin_x);
            for (int c = c0; c <= c1; ++c) {
                double xl = std::max(ax, x0 + c * cw), xr = std::min(bx, x0 + (c + 1) * cw);
                if (xl > xr) xl = xr = (c == c0 ? ax : bx);
                double yl = ay, yr = by;
                if (bx > ax) {
                    const double s = (by - ay) / (bx - ax);
                    yl = ay + (xl - ax) * s;
                    yr = ay + (xr - ax) * s;
                }
                const int r0 = row(std::min(yl, yr) - margin_y), r1 = row(std::max(yl, yr) + margin_y);
                for (int r = r0; r <= r1; ++r) f(static_cast<std::size_t>(c) * ny + r);
            }
        } else {
            if (ay > by) { std::swap(ax, bx); std::swap(ay, by); }
            const int r0 = row(ay - margin_y), r1 = row(by + margin_y);
            for (int r = r0; r <= r1; ++r) {
                double yl = std::max(ay, y0 + r * ch), yr = std::min(by, y0 + (r + 1) * ch);
                if (yl > yr) yl = yr = (r == r0 ? ay : by);
                const double s = (bx - ax) / (by - ay);
                const double xl = ax + (yl - ay) * s, xr = ax + (yr - ay) * s;
                const int c0 = col(std::min(xl, xr) - margin_x), c1 = col(std::max(xl, xr) + margin_x);
                for (int c = c0; c <= c1; ++c) f(static_cast<std::size_t>(c) * ny + r);
            }
        }
    }
    void insert(I64 a, I64 b) {
        seg.push_back(a);
        seg.push_back(b);
        mark.push_back(0);
    }
    // Cells of one segment: its bounding box when that is small (a short
    // ring edge: one to a few cells), else the traversal.
    template <class F>
    void seg_cells(const double* p, const double* q, F&& f) const {
        const int c0 = col(std::min(p[0], q[0]) - margin_x), c1 = col(std::max(p[0], q[0]) + margin_x);
        const int r0 = row(std::min(p[1], q[1]) - margin_y), r1 = row(std::max(p[1], q[1]) + margin_y);
        if ((c1 - c0 + 1) * (r1 - r0 + 1) <= 12) {
            for (int c = c0; c <= c1; ++c)
                for (int r = r0; r <= r1; ++r) f(static_cast<std::size_t>(c) * ny + r);
        } else {
            int last = -1;
            for_cells(p, q, [&](std::size_t cell) {
                if (static_cast<int>(cell) != last) f(cell);
                last = static_cast<int>(cell);
            });
        }
    }
    void build() {
        const std::size_t ncell = static_cast<std::size_t>(nx) * ny;
        n_built = seg.size() / 2;
        cstart.assign(ncell + 1, 0);
        for (std::size_t id = 0; id < n_built; ++id)
            seg_cells(xy + 2 * seg[2 * id], xy + 2 * seg[2 * id + 1], [&](std::size_t cell) { ++cstart[cell + 1]; });
        for (std::size_t c = 1; c <= ncell; ++c) cstart[c] += cstart[c - 1];
        citems.resize(static_cast<std::size_t>(cstart[ncell]));
        std::vector<int> fill(cstart.begin(), cstart.end() - 1);
        for (std::size_t id = 0; id < n_built; ++id)
            seg_cells(xy + 2 * seg[2 * id], xy + 2 * seg[2 * id + 1],
                      [&](std::size_t cell) { citems[fill[cell]++] = static_cast<int>(id); });
        built = true;
    }
    // Calls f(segment id) once for each segment in a cell met by p-q; stops
    // early when f returns true (and then returns true).
    template <class F>
    bool any(const double* p, const double* q, F&& f) {
        if (++epoch == 0) {
            std::fill(mark.begin(), mark.end(), 0u);
            epoch = 1;
        }
        if (!built) build();
        for (std::size_t id = n_built; id < seg.size() / 2; ++id)
            if (f(static_cast<int>(id))) return true;
        bool hit = false;
        for_cells(p, q, [&](std::size_t cell) {
            if (hit) return;
            for (int k = cstart[cell], e = cstart[cell + 1]; k < e; ++k) {
                const int id = citems[k];
                if (mark[id] == epoch) continue;
                mark[id] = epoch;
                if (f(id)) { hit = true; return; }
            }
        });
        return hit;
    }
};

// same_point and strictly_between (collinear q strictly inside a-b): segments.hpp.
// Collinear p, q1, q2 (checked by the caller): do q1 and q2 lie on the same side of p?
inline bool same_direction(const double* p, const double* q1, const double* q2) {
    if (q1[0] != p[0] || q2[0] != p[0]) return (q1[0] > p[0]) == (q2[0] > p[0]) && q1[0] != p[0] && q2[0] != p[0];
    return (q1[1] > p[1]) == (q2[1] > p[1]);
}

// Does segment (p0, p1) meet segment (q0, q1) anywhere other than at an
// endpoint they share? (Shared endpoint with collinear overlap counts as meeting.)
bool segments_conflict(const double* p0, const double* p1, const double* q0, const double* q1) {
    const bool s00 = same_point(p0, q0), s01 = same_point(p0, q1);
    const bool s10 = same_point(p1, q0), s11 = same_point(p1, q1);
    if ((s00 || s01) && (s10 || s11)) return true;  // the same segment twice
    if (s00 || s01 || s10 || s11) {
        const double* x = (s00 || s01) ? p0 : p1;              // shared point
        const double* po = (x == p0) ? p1 : p0;                // other end of p
        const double* qo = (s00 || s10) ? q1 : q0;             // other end of q
        return orient2d(x, po, qo) == 0.0 && same_direction(x, po, qo);
    }
    const double o1 = orient2d(p0, p1, q0), o2 = orient2d(p0, p1, q1);
    const double o3 = orient2d(q0, q1, p0), o4 = orient2d(q0, q1, p1);
    if (sgn(o1) * sgn(o2) < 0 && sgn(o3) * sgn(o4) < 0) return true;
    if (o1 == 0.0 && strictly_between(p0, p1, q0)) return true;
    if (o2 == 0.0 && strictly_between(p0, p1, q1)) return true;
    if (o3 == 0.0 && strictly_between(q0, q1, p0)) return true;
    if (o4 == 0.0 && strictly_between(q0, q1, p1)) return true;
    return false;
}

// ----------------------------------------------------------------- linked list

struct Node {
    double x, y;  // first: &x is a (x, y) point for the predicates
    int v;        // vertex index into the caller's points (fewer than 2^31, checked)
    int prev, next;
    int twin;     // next node with identical coordinates (circular; self if none)
    int ring;     // input ring
    bool removed, reflex;
    bool not_ear = false;  // plain order: known not to be an ear since its neighbours last changed
};

inline const double* P(const Node& n) { return &n.x; }

struct Polygon {
    const double* xy = nullptr;
    std::size_t n_points = 0;
    std::vector<Node> nodes;
    int start = -1;                    // a node of the outer list (after joining)
    std::vector<I64> bridges;          // 2 per bridge
    std::vector<I64> skipped;          // rings not joined
    std::vector<std::vector<I64>> rings;  // cleaned, oriented rings (outer CCW, holes CW)
    bool touching = false;                // two ring vertices share a position
    bool forced_bridge = false;           // a hole was joined without a visible bridge, or left out (invalid input)
    double net_area2 = 0, area_mag2 = 0;  // twice the rings' net area (outer - holes), sum of |terms|

    int add_node(I64 v, int ring) {
        Node n;
        n.x = xy[2 * v];
        n.y = xy[2 * v + 1];
        n.v = static_cast<int>(v);
        n.prev = n.next = n.twin = static_cast<int>(nodes.size());
        n.ring = ring;
        n.removed = false;
        n.reflex = false;
        nodes.push_back(n);
        return static_cast<int>(nodes.size()) - 1;
    }
    int copy_node(int i) {
        Node n = nodes[i];
        const int k = static_cast<int>(nodes.size());
        n.twin = nodes[i].twin;
        nodes.push_back(n);
        nodes[i].twin = k;
        return k;
    }
    // Connect node a to node b by the diagonal a -> b and its copy b2 -> a2
    // (a2, b2: new nodes coincident with a and b): a -> b ... b.prev -> b2 ->
    // a2 -> a.next. On two loops this joins them through a bridge (hole
    // joining); on one loop it splits it in two (the clipper's fallback).
    // Returns {a2, b2}.
    std::pair<int, int> connect(int a, int b) {
        const int a2 = copy_node(a), b2 = copy_node(b);
        const int an = nodes[a].next, bp = nodes[b].prev;
        nodes[a].next = b; nodes[b].prev = a;
        nodes[bp].next = b2; nodes[b2].prev = bp;
        nodes[b2].next = a2; nodes[a2].prev = b2;
        nodes[a2].next = an; nodes[an].prev = a2;
        return {a2, b2};
    }
};

// Link coincident nodes into twin rings with an open-addressing hash on the
// coordinates' bit patterns (exact equality; -0.0 and 0.0 are merged).
//
// Most polygons have no coincident vertices, so a bitmap of 16 bits per node
// (in L1/L2, unlike the hash table) first finds the hash values that occur
// more than once; only the nodes with such a value go into the table (about
// n/32 of them when nothing coincides). The table links the same nodes in
// the same order as inserting every node would.
void link_twins(Polygon& poly) {
    const std::size_t n = poly.nodes.size();
    auto bits = [](double d) {
        if (d == 0.0) d = 0.0;
        std::uint64_t u;
        std::memcpy(&u, &d, sizeof u);
        return u;
    };
    auto hash = [&](const Node& nd) {
        // Full avalanche (splitmix64's finalizer): coordinates with zero
        // low mantissa bits (integers) must not crowd into a few slots.
        std::uint64_t h = bits(nd.x) ^ (bits(nd.y) * 0x9E3779B97F4A7C15ull + 0x632BE59BD9B4E019ull);
        h ^= h >> 33;
        h *= 0xFF51AFD7ED558CCDull;
        h ^= h >> 33;
        h *= 0xC4CEB9FE1A85EC53ull;
        h ^= h >> 33;
        return h;
    };
    int shift = 64 - 6;  // bitmap of 2^(64 - shift) bits, at least 16 per node
    while ((std::size_t(1) << (64 - shift)) < 16 * n && shift > 20) --shift;
    const std::size_t words = (std::size_t(1) << (64 - shift)) / 64;
    std::vector<std::uint64_t> seen(words, 0), repeated(words, 0);
    bool any = false;
    for (std::size_t i = 0; i < n; ++i) {
        const std::uint64_t b = hash(poly.nodes[i]) >> shift;
        const std::uint64_t bit = std::uint64_t(1) << (b & 63);
        std::uint64_t& w = seen[b >> 6];
        if (w & bit) {
            repeated[b >> 6] |= bit;
            any = true;
        }
        w |= bit;
    }
    if (!any) return;
    std::vector<int> members;
    for (std::size_t i = 0; i < n; ++i) {
        const std::uint64_t b = hash(poly.nodes[i]) >> shift;
        if (repeated[b >> 6] & (std::uint64_t(1) << (b & 63))) members.push_back(static_cast<int>(i));
    }
    std::size_t cap = 16;
    while (cap < members.size() + members.size() / 2) cap <<= 1;  // load at most 2/3
    std::vector<int> table(cap, -1);
    for (const int i : members) {
        Node& nd = poly.nodes[i];
        std::size_t s = hash(nd) & (cap - 1);
        while (true) {
            const int j = table[s];
            if (j < 0) { table[s] = i; break; }
            Node& o = poly.nodes[j];
            if (o.x == nd.x && o.y == nd.y) {
                poly.touching = true;
                nd.twin = o.twin;
                o.twin = i;
                break;
            }
            s = (s + 1) & (cap - 1);
        }
    }
}

// ----------------------------------------------------------------- hole joining

class Joiner {
public:
    Joiner(Polygon& p, BridgeMethod m) : poly_(p), method_(m) {}

    void run() {
        auto& N = poly_.nodes;
        const std::size_t n_rings = poly_.rings.size();
        ring_first_.assign(n_rings, -1);
        merged_.assign(n_rings, 0);
        double xmin = std::numeric_limits<double>::infinity(), ymin = xmin, xmax = -xmin, ymax = -xmin;
        std::size_t n_seg = 0;
        for (std::size_t r = 0; r < n_rings; ++r) {
            const auto& ring = poly_.rings[r];
            if (ring.size() < 3) continue;
            int first = -1, last = -1;
            for (I64 v : ring) {
                const int k = poly_.add_node(v, static_cast<int>(r));
                if (first < 0) first = k;
                else { N[last].next = k; N[k].prev = last; }
                last = k;
                xmin = std::min(xmin, N[k].x); xmax = std::max(xmax, N[k].x);
                ymin = std::min(ymin, N[k].y); ymax = std::max(ymax, N[k].y);
            }
            N[last].next = first;
            N[first].prev = last;
            ring_first_[r] = first;
            n_seg += ring.size();
        }
        if (ring_first_.empty() || ring_first_[0] < 0) return;  // no usable outer ring
        poly_.start = ring_first_[0];
        merged_[0] = 1;
        link_twins(poly_);
        if (poly_.touching) {
            // Invalid input only (some ring vertices coincide): cut the
            // zero-width spikes out of the rings before anything is joined.
            for (std::size_t r = 0; r < n_rings; ++r) {
                if (ring_first_[r] < 0) continue;
                ring_first_[r] = drop_spikes(ring_first_[r], poly_.rings[r].size());
                if (ring_first_[r] < 0 && r > 0) poly_.skipped.push_back(static_cast<I64>(r));
            }
            if (ring_first_[0] < 0) {
                poly_.start = -1;  // the outer ring bounds no area
                return;
            }
            poly_.start = ring_first_[0];
        }

        std::vector<int> holes;
        for (std::size_t r = 1; r < n_rings; ++r)
            if (ring_first_[r] >= 0) holes.push_back(static_cast<int>(r));
            else if (!poly_.rings[r].empty()) poly_.skipped.push_back(static_cast<I64>(r));
        if (holes.empty()) return;

        // The segment grid for the visibility tests is built lazily: a few
        // bridges (the usual case: each hole's first extreme-point pair is
        // visible) are cheaper to test against every segment directly.
        box_ = {xmin, ymin, xmax, ymax};
        n_seg_ = n_seg;
        // Extremes of the outer list: (max x, min x, max y, min y), lexicographic.
        ext_ = extremes(ring_first_[0]);
        // Eberly: holes in order of decreasing maximum x.
        std::vector<std::pair<int, int>> order;  // (max-x node, ring)
        // Each hole's own extremes, taken before it is joined (walking the
        // joined list later would cost the whole list per hole).
        hole_ext_.assign(n_rings, {});
        for (int r : holes) {
            hole_ext_[r] = extremes(ring_first_[r]);
            order.push_back({hole_ext_[r][0], r});
        }
        std::sort(order.begin(), order.end(), [&](const auto& a, const auto& b) {
            const Node &p = N[a.first], &q = N[b.first];
            if (p.x != q.x) return p.x > q.x;
            if (p.y != q.y) return p.y > q.y;
            return a.second < b.second;
        });
        for (const auto& [m, r] : order) join_one(r, m);
    }

private:
    Polygon& poly_;
    BridgeMethod method_;
    SegGrid grid_;
    bool grid_built_ = false;
    std::size_t n_seg_ = 0, scanned_ = 0;
    std::array<I64, 2> blocker_{-1, -1};  // the last segment that blocked a candidate bridge
    std::size_t blocker_ring_ = 0;        // the ring it belongs to (direct scans)
    // Ring edges in chunks of kChunk consecutive edges with their bounding
    // boxes (direct visibility scans); chunk_first_[r] is ring r's first.
    static constexpr std::size_t kChunk = 32;
    struct Chunk {
        double x0, y0, x1, y1;
    };
    std::vector<Chunk> chunks_;
    std::vector<std::size_t> chunk_first_;
    void build_chunks() {
        const double* xy = poly_.xy;
        const std::size_t n_rings = poly_.rings.size();
        chunk_first_.assign(n_rings + 1, 0);
        for (std::size_t r = 0; r < n_rings; ++r) {
            const auto& ring = poly_.rings[r];
            const std::size_t n = ring.size();
            chunk_first_[r] = chunks_.size();
            if (n < 3) continue;
            for (std::size_t k0 = 0; k0 < n; k0 += kChunk) {
                const std::size_t k1 = std::min(n, k0 + kChunk);  // edges k0 .. k1-1, points k0 .. k1 (mod n)
                Chunk ch{xy[2 * ring[k0]], xy[2 * ring[k0] + 1], xy[2 * ring[k0]], xy[2 * ring[k0] + 1]};
                for (std::size_t k = k0 + 1; k <= k1; ++k) {
                    const double* q = xy + 2 * ring[k < n ? k : 0];
                    ch.x0 = std::min(ch.x0, q[0]); ch.x1 = std::max(ch.x1, q[0]);
                    ch.y0 = std::min(ch.y0, q[1]); ch.y1 = std::max(ch.y1, q[1]);
                }
                chunks_.push_back(ch);
            }
        }
        chunk_first_[n_rings] = chunks_.size();
    }
    std::array<double, 4> box_{};
    std::vector<int> ring_first_;
    std::vector<char> merged_;
    std::array<int, 4> ext_{};
    std::vector<std::array<int, 4>> hole_ext_;

    static bool lex_gt(const Node& a, const Node& b, bool y_first) {
        if (y_first) return a.y > b.y || (a.y == b.y && a.x > b.x);
        return a.x > b.x || (a.x == b.x && a.y > b.y);
    }
    std::array<int, 4> extremes(int first) const {
        const auto& N = poly_.nodes;
        std::array<int, 4> e{first, first, first, first};
        int p = first;
        do {
            if (lex_gt(N[p], N[e[0]], false)) e[0] = p;
            if (lex_gt(N[e[1]], N[p], false)) e[1] = p;
            if (lex_gt(N[p], N[e[2]], true)) e[2] = p;
            if (lex_gt(N[e[3]], N[p], true)) e[3] = p;
            p = N[p].next;
        } while (p != first);
        return e;
    }

    // A ring that runs out along a line and straight back (issue149: the
    // outer ring's edges 10 -> 0 -> 1 go out and back over the same
    // segment, and 9 -> 10 -> 2 goes down and back up over edge 9 -> 2)
    // has a spike of zero width. Its tip has no region sector that
    // sector_node could decide (both edges leave in the same direction:
    // the tie makes it look inside, and issue149 got its bridge from such a
    // tip, outside the region). The spike bounds no area, so its tip is
    // dropped: a vertex whose neighbours are collinear with it on one side
    // (or coincide), and then a vertex at the same position as its
    // successor; repeated until none is left. Straight-through vertices are
    // kept. Returns the ring's new first node, -1 if fewer than 3 are left
    // (the dropped nodes are marked removed; twin lists skip them).
    int drop_spikes(int first, std::size_t n) {
        auto& N = poly_.nodes;
        // Each drop re-checks the node before it; `clean` counts checks in a
        // row without a drop, so the walk ends after one clean lap.
        std::size_t clean = 0;
        int p = first;
        while (n >= 3 && clean < n) {
            Node& b = N[p];
            const int ia = b.prev, ic = b.next;
            const double* a = P(N[ia]);
            const double* c = P(N[ic]);
            const bool drop =
                same_point(P(b), c) || (orient2d_quick(a, P(b), c) == 0.0 && !strictly_between(a, c, P(b)));
            if (!drop) {
                ++clean;
                p = ic;
                continue;
            }
            N[ia].next = ic;
            N[ic].prev = ia;
            b.removed = true;
            --n;
            clean = 0;
            if (p == first) first = ic;
            p = ia;
        }
        if (n >= 3) return first;
        for (int k = 0, q = first; k < static_cast<int>(n); ++k, q = N[q].next) N[q].removed = true;
        return -1;
    }

    // Among all nodes at the position of node `at` (its twins), the edges
    // leaving that point are sorted clockwise starting from the direction to
    // `target`. The first one reached bounds the sector the direction lies
    // in: if it is an outgoing edge (node -> node.next) the sector is inside
    // the region (the region is on the left of every directed edge) and that
    // node is where a bridge toward `target` must be spliced. Returns -1 if
    // the direction is outside the region or runs along an edge.
    int sector_node(int at, const double* target, int skip = -1) const {
        const auto& N = poly_.nodes;
        const double* p = P(N[at]);
        int best = -1;
        bool best_out = false;
        const double* best_q = nullptr;
        int best_half = 2;
        int t = at;
        do {
            const Node& nd = N[t];
            if (!nd.removed && t != skip) {
                for (int k = 0; k < 2; ++k) {
                    const double* q = P(N[k == 0 ? nd.next : nd.prev]);
                    const double o = orient2d(p, target, q);
                    int half;
                    if (o < 0) half = 0;
                    else if (o > 0) half = 1;
                    else if (same_direction(p, target, q)) return -1;  // along an edge
                    else half = 1;  // opposite direction: angle pi, first of half 1
                    bool better = best < 0 || half < best_half;
                    // Same half: q comes first clockwise iff best_q is clockwise of q.
                    if (best >= 0 && half == best_half) better = orient2d(p, q, best_q) < 0.0;
                    if (better) {
                        best = t;
                        best_out = (k == 0);
                        best_q = q;
                        best_half = half;
                    }
                }
            }
            t = nd.twin;
        } while (t != at);
        return best_out ? best : -1;
    }

    void build_seg_grid() {
        grid_.init(poly_.xy, box_[0], box_[1], box_[2], box_[3], n_seg_);
        for (const auto& ring : poly_.rings) {
            if (ring.size() < 3) continue;
            for (std::size_t k = 0; k < ring.size(); ++k) grid_.insert(ring[k], ring[(k + 1) % ring.size()]);
        }
        for (std::size_t k = 0; k + 1 < poly_.bridges.size(); k += 2)
            if (!same_point(poly_.xy + 2 * poly_.bridges[k], poly_.xy + 2 * poly_.bridges[k + 1]))
                grid_.insert(poly_.bridges[k], poly_.bridges[k + 1]);
        grid_built_ = true;
    }

    // Does the open segment between nodes na and nb avoid every ring and
    // bridge segment?
    bool segment_clear(int na, int nb) {
        const auto& N = poly_.nodes;
        const double* a = P(N[na]);
        const double* b = P(N[nb]);
        const double* xy = poly_.xy;
        // On a jagged ring a blocked candidate is nearly always blocked by an
        // edge near one of its ends: test the list edges around both ends
        // first (every list edge is a ring or bridge segment, so a conflict
        // found here is one the full test below would find).
        {
            const double bx0 = std::min(a[0], b[0]), bx1 = std::max(a[0], b[0]);
            const double by0 = std::min(a[1], b[1]), by1 = std::max(a[1], b[1]);
            auto near_conflict = [&](int u) {
                const double* q0 = P(N[u]);
                const double* q1 = P(N[N[u].next]);
                if (std::max(q0[0], q1[0]) < bx0 || std::min(q0[0], q1[0]) > bx1 ||
                    std::max(q0[1], q1[1]) < by0 || std::min(q0[1], q1[1]) > by1 || same_point(q0, q1))
                    return false;
                return segments_conflict(a, b, q0, q1);
            };
            for (int end : {na, nb}) {
                int f = end, r = N[end].prev;
                for (int k = 0; k < 16; ++k) {
                    if (near_conflict(f) || near_conflict(r)) return false;
                    f = N[f].next;
                    r = N[r].prev;
                }
            }
        }
        const double bx0 = std::min(a[0], b[0]), bx1 = std::max(a[0], b[0]);
        const double by0 = std::min(a[1], b[1]), by1 = std::max(a[1], b[1]);
        auto conflict = [&](I64 u, I64 v) {
            const double* q0 = xy + 2 * u;
            const double* q1 = xy + 2 * v;
            if (std::max(q0[0], q1[0]) < bx0 || std::min(q0[0], q1[0]) > bx1 ||
                std::max(q0[1], q1[1]) < by0 || std::min(q0[1], q1[1]) > by1)
                return false;
            if (!segments_conflict(a, b, q0, q1)) return false;
            blocker_ = {u, v};
            return true;
        };
        // The extreme-point search slides both ends a vertex or two at a
        // time, so the segment that blocked the previous candidate often
        // blocks the next one too (it is one of the tested segments).
        if (blocker_[0] >= 0 && conflict(blocker_[0], blocker_[1])) return false;
        if (!grid_built_ && scanned_ < 8 * n_seg_ + 1024) {
            // Direct scan with a bounding-box reject. Count what is actually
            // scanned: a scan that stops early at a blocker is cheap.
            // The ring of the last blocker first (an unjoined hole in the
            // way tends to block several candidates in a row).
            // Each ring is scanned in chunks of kChunk edges with a
            // precomputed bounding box: a chunk whose box misses the
            // segment's box is skipped whole.
            if (chunks_.empty()) build_chunks();
            const std::size_t n_rings = poly_.rings.size();
            for (std::size_t i = 0; i < n_rings; ++i) {
                const std::size_t r = (i + blocker_ring_) % n_rings;
                const auto& ring = poly_.rings[r];
                const std::size_t n = ring.size();
                if (n < 3) continue;
                for (std::size_t c = chunk_first_[r]; c < chunk_first_[r + 1]; ++c) {
                    const Chunk& ch = chunks_[c];
                    // Counted as if every edge were scanned, as before the
                    // chunks: many queries (invalid input tries many
                    // candidates) should move on to the grid just as soon.
                    scanned_ += kChunk;
                    if (ch.x1 < bx0 || ch.x0 > bx1 || ch.y1 < by0 || ch.y0 > by1) continue;
                    const std::size_t k0 = (c - chunk_first_[r]) * kChunk, k1 = std::min(n, k0 + kChunk);
                    for (std::size_t k = k0; k < k1; ++k) {
                        if (conflict(ring[k], ring[k + 1 < n ? k + 1 : 0])) {
                            blocker_ring_ = r;
                            return false;
                        }
                    }
                }
            }
            for (std::size_t k = 0; k + 1 < poly_.bridges.size(); k += 2)
                if (!same_point(xy + 2 * poly_.bridges[k], xy + 2 * poly_.bridges[k + 1]) &&
                    conflict(poly_.bridges[k], poly_.bridges[k + 1]))
                    return false;
            return true;
        }
        if (!grid_built_) build_seg_grid();
        return !grid_.any(a, b, [&](int id) { return conflict(grid_.seg[2 * id], grid_.seg[2 * id + 1]); });
    }

    // Validate and make the bridge between outer-list node at `o` and hole
    // node at `h` (any twins at those positions). Returns true if made.
    bool try_bridge(int o, int h, int hole) {
        auto& N = poly_.nodes;
        if (same_point(P(N[o]), P(N[h]))) return false;
        const int a = sector_node(o, P(N[h]));
        if (a < 0 || !merged_[N[a].ring]) return false;
        const int b = sector_node(h, P(N[a]));
        if (b < 0 || N[b].ring != hole) return false;
        if (!segment_clear(a, b)) return false;
        splice(a, b);
        return true;
    }

    void splice(int a, int b) {
        auto& N = poly_.nodes;
        poly_.connect(a, b);
        if (grid_built_) grid_.insert(N[a].v, N[b].v);
        poly_.bridges.push_back(N[a].v);
        poly_.bridges.push_back(N[b].v);
    }

    // Eberly's candidate (Appendix of the paper) for hole vertex m: the
    // outer-list node nearest along the ray m + t(1, 0), or the reflex vertex
    // inside triangle (m, I, P) of smallest angle with the ray. -1 if the ray
    // meets nothing.
    int eberly_candidate(int m) const {
        const auto& N = poly_.nodes;
        const Node& M = N[m];
        double best_x = std::numeric_limits<double>::infinity();
        int edge = -1, vert = -1;
        int p = poly_.start;
        do {
            const Node &a = N[p], &b = N[a.next];
            if (a.y == M.y && a.x >= M.x) {
                if (a.x < best_x || (a.x == best_x && vert < 0)) { best_x = a.x; vert = p; edge = -1; }
            } else if ((a.y < M.y && b.y > M.y) || (a.y > M.y && b.y < M.y)) {
                // Exact: does the edge cross the ray's line right of (or at) M?
                const int o = orient2d_sign(P(a), P(b), P(M)) * (b.y > a.y ? 1 : -1);
                if (o >= 0) {
                    double x = a.x + (M.y - a.y) * (b.x - a.x) / (b.y - a.y);
                    x = std::max(x, M.x);  // rounding must not put it left of M
                    if (x < best_x) { best_x = x; edge = p; vert = -1; }
                }
            }
            p = a.next;
        } while (p != poly_.start);
        if (vert >= 0) return vert;
        if (edge < 0) return -1;
        const Node &ea = N[edge], &eb = N[ea.next];
        const int pc = (eb.x > ea.x || (eb.x == ea.x && eb.y > ea.y)) ? ea.next : edge;  // max-x endpoint
        const Node& Pn = N[pc];
        const bool up = Pn.y > M.y;
        const int side_m = orient2d_sign(P(ea), P(eb), P(M));
        int best = -1;
        p = poly_.start;
        do {
            const Node& r = N[p];
            const int nx = r.next;
            if (!same_point(P(r), P(Pn)) && !same_point(P(r), P(M)) && (up ? r.y > M.y : r.y < M.y)) {
                const int se = orient2d_sign(P(ea), P(eb), P(r));
                const int sm = orient2d_sign(P(M), P(Pn), P(r));
                if (se * side_m >= 0 && (up ? sm <= 0 : sm >= 0)) {
                    // Inside (or on the boundary of) triangle M, I, P.
                    if (best < 0) best = p;
                    else {
                        const Node& q = N[best];
                        const int s = orient2d_sign(P(M), P(q), P(r));
                        // Smaller angle with the ray: counter-clockwise order above, clockwise below.
                        const bool smaller = up ? s < 0 : s > 0;
                        bool closer = false;
                        if (s == 0)
                            closer = (r.x != q.x) ? (std::fabs(r.x - M.x) < std::fabs(q.x - M.x))
                                                  : (std::fabs(r.y - M.y) < std::fabs(q.y - M.y));
                        if (smaller || closer) best = p;
                    }
                }
            }
            p = nx;
        } while (p != poly_.start);
        return best >= 0 ? best : pc;
    }

    bool extreme_point_bridge(int hole) {
        // The paper: pair the hole's and the outer polygon's min/max X/Y
        // vertices; if a pair is not mutually visible slide one or two
        // vertices along either ring (both directions) around it.
        const auto& N = poly_.nodes;
        const std::array<int, 4>& he = hole_ext_[hole];
        static const int offsets[] = {0, 1, -1, 2, -2};
        auto walk = [&](int n, int k) {
            for (; k > 0; --k) n = N[n].next;
            for (; k < 0; ++k) n = N[n].prev;
            return n;
        };
        for (int e = 0; e < 4; ++e) {
            for (int sum = 0; sum <= 4; ++sum)
                for (int i : offsets)
                    for (int j : offsets) {
                        if (std::abs(i) + std::abs(j) != sum) continue;
                        if (try_bridge(walk(ext_[e], i), walk(he[e], j), hole)) return true;
                    }
        }
        return false;
    }

    // Angle measured counter-clockwise from direction r, all from point x:
    // does direction u come strictly before direction v? Directions along r
    // (angle 0) are reported as "not before" by the caller's checks.
    static bool ccw_before(const double* x, const double* r, const double* u, const double* v) {
        auto half = [&](const double* q) {
            const double o = orient2d(x, r, q);
            if (o > 0) return 0;
            if (o < 0) return 1;
            return same_direction(x, r, q) ? -1 : 1;
        };
        const int hu = half(u), hv = half(v);
        if (hu != hv) return hu < hv;
        return orient2d(x, u, v) > 0.0;
    }

    // A hole that shares a point with the outer list is joined there, with
    // no bridge: outer node A and hole node B at the same position become
    // A.prev -> A -> B.next ... B.prev -> B -> A.next. This keeps the polygon
    // weakly simple (the sectors of the two nodes stay disjoint), which a
    // bridge elsewhere would not. Valid only if the hole's wedge at B lies in
    // the region sector of A, with no other edge in between.
    bool touch_join(int any_at, int b) {
        auto& N = poly_.nodes;
        const int bn = N[b].next, bp = N[b].prev;
        const int a1 = sector_node(any_at, P(N[bn]), b);
        if (a1 < 0 || !merged_[N[a1].ring]) return false;
        const int a2 = sector_node(any_at, P(N[bp]), b);
        if (a2 != a1) return false;
        const double* x = P(N[b]);
        const double* r = P(N[N[a1].next]);
        if (!ccw_before(x, r, P(N[bp]), P(N[bn]))) return false;
        const int an = N[a1].next;
        N[a1].next = bn; N[bn].prev = a1;
        N[b].next = an; N[an].prev = b;
        poly_.bridges.push_back(N[a1].v);
        poly_.bridges.push_back(N[b].v);
        return true;
    }
    bool try_touch(int hole) {
        auto& N = poly_.nodes;
        const int first = ring_first_[hole];
        int h = first;
        do {
            for (int t = N[h].twin; t != h; t = N[t].twin)
                if (merged_[N[t].ring] && touch_join(t, h)) return true;
            h = N[h].next;
        } while (h != first);
        return false;
    }

    // Side of point q with respect to the region joined so far (the outer
    // list, holes joined so far cancelling their part): +1 inside (non-zero
    // winding number), -1 outside, 0 on a list edge. Exact orient2d; one
    // pass over the list (only used for holes no visible bridge reaches).
    int region_side(const double* q) const {
        const auto& N = poly_.nodes;
        int wn = 0;
        int p = poly_.start;
        do {
            const Node& na = N[p];
            const double* a = P(na);
            const double* b = P(N[na.next]);
            p = na.next;
            if (same_point(a, q)) return 0;
            if ((a[1] > q[1] && b[1] > q[1]) || (a[1] < q[1] && b[1] < q[1])) continue;
            const double o = orient2d(a, b, q);
            if (o == 0.0 && strictly_between(a, b, q)) return 0;
            if (a[1] <= q[1]) {
                if (b[1] > q[1] && o > 0.0) ++wn;
            } else if (b[1] <= q[1] && o < 0.0) {
                --wn;
            }
        } while (p != poly_.start);
        return wn != 0 ? 1 : -1;
    }
    // Is the (unjoined) hole wholly outside the region: a vertex strictly
    // outside, none strictly inside? The hole's own edges cannot cross the
    // region's boundary then without a vertex inside, unless the hole
    // crosses a region edge between two outside vertices (the region
    // poking through it), which is left to the forced bridge.
    bool outside_region(int hole) const {
        const auto& N = poly_.nodes;
        const int first = ring_first_[hole];
        bool out = false;
        int h = first;
        do {
            const int s = region_side(P(N[h]));
            if (s > 0) return false;
            if (s < 0) out = true;
            h = N[h].next;
        } while (h != first);
        if (!out) return false;
        // A region edge meeting the hole's boundary (the region passing
        // through the hole between outside vertices) keeps it. Only list
        // edges whose box meets the hole's box are tested.
        const std::array<int, 4>& he = hole_ext_[hole];  // max x, min x, max y, min y
        const double hx0 = N[he[1]].x, hx1 = N[he[0]].x, hy0 = N[he[3]].y, hy1 = N[he[2]].y;
        int p = poly_.start;
        do {
            const Node& na = N[p];
            const double* a = P(na);
            const double* b = P(N[na.next]);
            p = na.next;
            if (std::max(a[0], b[0]) < hx0 || std::min(a[0], b[0]) > hx1 || std::max(a[1], b[1]) < hy0 ||
                std::min(a[1], b[1]) > hy1)
                continue;
            h = first;
            do {
                const double* c = P(N[h]);
                const double* d = P(N[N[h].next]);
                if (segments_conflict(a, b, c, d)) return false;
                h = N[h].next;
            } while (h != first);
        } while (p != poly_.start);
        return true;
    }

    void join_one(int hole, int m) {
        auto& N = poly_.nodes;
        bool done = try_touch(hole);
        if (!done && method_ == BridgeMethod::extreme_point) done = extreme_point_bridge(hole);
        if (!done) {
            const int c = eberly_candidate(m);
            if (c >= 0) done = try_bridge(c, m, hole);
        }
        if (!done) {
            // Exact Eberly needs a simple polygon; for touching or invalid
            // rings try every outer-list vertex by distance, then every hole
            // vertex, with the exact visibility test.
            std::vector<std::pair<double, int>> cand;
            int p = poly_.start;
            do {
                const double dx = N[p].x - N[m].x, dy = N[p].y - N[m].y;
                cand.push_back({dx * dx + dy * dy, p});
                p = N[p].next;
            } while (p != poly_.start);
            std::sort(cand.begin(), cand.end());
            for (const auto& c : cand)
                if (try_bridge(c.second, m, hole)) { done = true; break; }
            if (!done) {
                int h = N[m].next;
                while (!done && h != m) {
                    int best = -1;
                    double bd = std::numeric_limits<double>::infinity();
                    for (const auto& c : cand) {
                        const double dx = N[c.second].x - N[h].x, dy = N[c.second].y - N[h].y;
                        if (dx * dx + dy * dy < bd && try_bridge(c.second, h, hole)) { done = true; best = c.second; break; }
                    }
                    (void)best;
                    h = N[h].next;
                }
            }
        }
        if (!done && outside_region(hole)) {
            // No visible bridge, and the hole lies outside the region joined
            // so far (inside another hole, or outside the outer ring): it
            // removes nothing, so it is left out. Any bridge to it would
            // leave the region at its outer-list end and run the list back
            // over itself; on water-huge2 (hole 395 inside hole 47) the
            // clipper then covered a large wedge twice.
            poly_.forced_bridge = true;  // invalid input: the clipper's stricter ears
            poly_.skipped.push_back(hole);
            return;
        }
        if (!done) {
            // No visible bridge: the hole crosses the outer list or another
            // hole (invalid input). Leaving it out would count its whole area
            // as inside; bridging it anyway to Eberly's candidate (or the
            // nearest outer-list vertex) lets the clipper's fallbacks cut most
            // of it out, as earcut's test suite expects.
            int c = eberly_candidate(m);
            if (c < 0 || same_point(P(N[c]), P(N[m]))) {
                c = -1;
                double bd = std::numeric_limits<double>::infinity();
                int p = poly_.start;
                do {
                    const double dx = N[p].x - N[m].x, dy = N[p].y - N[m].y;
                    const double d = dx * dx + dy * dy;
                    if (d > 0 && d < bd) { bd = d; c = p; }
                    p = N[p].next;
                } while (p != poly_.start);
            }
            if (c < 0) {
                poly_.skipped.push_back(hole);
                return;
            }
            poly_.forced_bridge = true;
            splice(c, m);
        }
        merged_[hole] = 1;
        // Update the outer list's extremes with the hole's (its own nodes:
        // of coincident copies made by a bridge, the original is kept).
        const std::array<int, 4>& he = hole_ext_[hole];
        if (lex_gt(N[he[0]], N[ext_[0]], false)) ext_[0] = he[0];
        if (lex_gt(N[ext_[1]], N[he[1]], false)) ext_[1] = he[1];
        if (lex_gt(N[he[2]], N[ext_[2]], true)) ext_[2] = he[2];
        if (lex_gt(N[ext_[3]], N[he[3]], true)) ext_[3] = he[3];
    }
};

// ----------------------------------------------------------------- ear clipping

class Clipper {
public:
    Clipper(Polygon& p, std::vector<I64>& out) : poly_(p), N_(p.nodes), out_(out) {}

    // Clip the loop through `start` (default: the joined polygon's).
    void run(EarOrder order, int start = -1) {
        if (start < 0) start = poly_.start;
        if (start < 0) return;
        if (may_split_ && order == EarOrder::plain && !poly_.touching && split_min_ >= 4 && clip_halves(start))
            return;
        // Count the live list, classify its vertices, take its box (no
        // copy of the list: fresh memory costs page faults at this size).
        std::size_t cnt = 0;
        double xmin = std::numeric_limits<double>::infinity(), ymin = xmin, xmax = -xmin, ymax = -xmin;
        std::vector<int>& reflex = reflex_;
        reflex.clear();
        reflex.reserve(N_.size() / 2 + 16);
        int p = start;
        do {
            Node& n = N_[p];
            n.reflex = orient2d_quick(P(N_[n.prev]), P(n), P(N_[n.next])) <= 0.0;
            if (n.reflex) reflex.push_back(p);
            xmin = std::min(xmin, n.x); xmax = std::max(xmax, n.x);
            ymin = std::min(ymin, n.y); ymax = std::max(ymax, n.y);
            ++cnt;
            p = n.next;
        } while (p != start);
        remaining_ = cnt;
        if (remaining_ < 3) return;
        out_.reserve(out_.size() + 3 * (remaining_ - 2));
        build_grid(reflex, xmin, ymin, xmax, ymax);
        bbox_ = {xmin, ymin, xmax, ymax};
        // Loops still to clip: the joined polygon, plus the pieces split off
        // by the fallback for invalid input (split_by_diagonal).
        if (poly_.touching) cancel_doubled_edges(start);
        else pending_.push_back(start);
        const std::size_t start_count = remaining_;
        while (!pending_.empty()) {
            const int s = pending_.back();
            pending_.pop_back();
            std::size_t cnt = 0;
            if (s == start && !poly_.touching) {
                cnt = start_count;  // counted above
            } else {
                int p = s;
                do {
                    ++cnt;
                    p = N_[p].next;
                } while (p != s);
            }
            remaining_ = cnt;
            cur_ = s;
            if (cnt < 3) continue;
            // A loop of zero area (a hole identical to the outer ring, a
            // piece with every edge doubled) holds no region. A valid input
            // never has one; checking costs one pass, only with holes.
            if (check_empty_ && !(s == poly_.start && joined_area_nonzero()) && remnant_is_empty(s)) continue;
            if (order == EarOrder::quality) clip_quality(s);
            else clip_plain(s);
            if (bailed_) return;
            // Last triangle.
            if (remaining_ == 3) {
                const Node& b = N_[cur_];
                const Node &a = N_[b.prev], &c = N_[b.next];
                if (orient2d(P(a), P(b), P(c)) > 0.0) emit(a, b, c);
            }
        }
    }

    // Invalid input: the quality order defers an ear whose diagonal
    // crosses a live edge (see clip_quality). Set only when no visible
    // bridge reached a hole (Polygon::forced_bridge; touching rings alone
    // do not need it on earcut's fixtures). water-huge2: deviation 0.019 ->
    // 0.0026.
    bool strict_quality_ = false;
    bool check_empty_ = false;
    // The joined loop (every ring joined, no touching rings) has the rings'
    // net area, known from orient_rings: if that is far from zero relative
    // to its rounding (below n eps of the terms' magnitude), the loop holds
    // a region and needs no emptiness pass.
    bool joined_area_nonzero() const {
        return !poly_.touching && poly_.skipped.empty() &&
               std::fabs(poly_.net_area2) > 1e-6 * poly_.area_mag2;
    }
    double tri_area2_ = 0;  // twice the area of the triangles emitted
    // Set once a loop needed a fallback (invalid input): from then on the
    // plain order also rejects an ear whose diagonal crosses or overlaps a
    // live edge, while an ear without such a crossing is left.
    bool strict_ears_ = false;
    // Plain order on input that looks valid: a loop of at least split_min_
    // vertices is cut in two along an inside diagonal and the halves are
    // clipped concurrently (clip_halves). The triangles do not depend on
    // whether a second thread ran: threads_ == 1 clips both halves here.
    bool may_split_ = false;
    std::size_t split_min_ = 0;
    int threads_ = 0;
    // A half met a case that needs the fallbacks (degenerate or invalid
    // input; they may add nodes, which the halves cannot do concurrently):
    // the caller clips the whole polygon again without splitting.
    bool bailed_ = false;
    bool ear_diagonal_clear(int ib, int& loose) {
        const int ia = N_[ib].prev, ic = N_[ib].next;
        if (edge_grid_clear(ia, ic)) return true;
        if (loose < 0) loose = ib;
        return false;
    }

    // Rings that touch along edges (a hole sharing edges with the outer
    // ring, a ring running back over itself) leave pairs of opposite edges
    // u -> v, v -> u in the joined loop. The region lies on both sides of
    // neither, so such a pair is cut out, splitting the loop in two, if
    // both pieces keep a non-negative area (a bridge to a hole would leave
    // the clockwise hole on its own and is kept). The pieces are queued.
    // Only run when some ring vertices coincide (never for valid input).
    void cancel_doubled_edges(int start) {
        struct E {
            double ux, uy, vx, vy;
            int node;
            bool operator<(const E& o) const {
                if (ux != o.ux) return ux < o.ux;
                if (uy != o.uy) return uy < o.uy;
                if (vx != o.vx) return vx < o.vx;
                return vy < o.vy;
            }
        };
        std::vector<E> es;
        std::vector<int> loop;
        int p = start;
        do {
            const Node &a = N_[p], &b = N_[a.next];
            es.push_back({a.x, a.y, b.x, b.y, p});
            loop.push_back(p);
            p = a.next;
        } while (p != start);
        std::sort(es.begin(), es.end());
        // Bridges are opposite edge pairs by construction: never cut them.
        std::vector<std::pair<I64, I64>> bridge_set;
        for (std::size_t k = 0; k + 1 < poly_.bridges.size(); k += 2)
            bridge_set.push_back({std::min(poly_.bridges[k], poly_.bridges[k + 1]),
                                  std::max(poly_.bridges[k], poly_.bridges[k + 1])});
        std::sort(bridge_set.begin(), bridge_set.end());
        auto loop_area = [&](int from, int to_excl_next) {
            // Shoelace of the loop from `from` along next up to node
            // `to_excl_next`, closed back to `from`.
            // NaN if `to_excl_next` is not on the loop of `from` (an
            // earlier cut separated them).
            const double x0 = N_[from].x, y0 = N_[from].y;
            double s2 = 0;
            int q = from;
            std::size_t steps = 0;
            while (q != to_excl_next) {
                if (++steps > loop.size()) return std::numeric_limits<double>::quiet_NaN();
                const Node &a = N_[q], &b = N_[a.next];
                s2 += (a.x - x0) * (b.y - y0) - (b.x - x0) * (a.y - y0);
                q = a.next;
            }
            return s2;
        };
        for (int pi : loop) {
            if (N_[pi].removed) continue;
            const int p1 = N_[pi].next;
            const std::pair<I64, I64> e{std::min(N_[pi].v, N_[p1].v), std::max(N_[pi].v, N_[p1].v)};
            if (std::binary_search(bridge_set.begin(), bridge_set.end(), e)) continue;
            E key{N_[p1].x, N_[p1].y, N_[pi].x, N_[pi].y, 0};
            for (auto it = std::lower_bound(es.begin(), es.end(), key);
                 it != es.end() && !(key < *it); ++it) {
                const int q = it->node;
                if (N_[q].removed || q == pi) continue;
                const int q1 = N_[q].next;
                if (!same_point(P(N_[q]), P(N_[p1])) || !same_point(P(N_[q1]), P(N_[pi]))) continue;
                if (p1 == q) {
                    // u -> v -> u: a zero-width spike; drop its tip.
                    if (remaining_ <= 3) break;
                    remove(p1, false);
                    break;
                }
                // Pieces: p1 ... q.prev (closing at v) and q1 ... pi.prev (closing at u).
                const double a1 = loop_area(p1, q), a2 = loop_area(q1, pi);
                if (!(a1 >= 0) || !(a2 >= 0)) continue;
                const int qp = N_[q].prev, pp = N_[pi].prev;
                N_[qp].next = p1; N_[p1].prev = qp;
                N_[pp].next = q1; N_[q1].prev = pp;
                eg_link(qp, p1);
                eg_link(pp, q1);
                N_[pi].removed = N_[q].removed = true;
                for (int i : {qp, p1, pp, q1}) {
                    Node& n = N_[i];
                    n.reflex = orient2d(P(N_[n.prev]), P(n), P(N_[n.next])) <= 0.0;
                }
                break;
            }
        }
        // Queue every piece left (reflex flags changed: rebuild the grid).
        std::vector<int> reflex;
        std::vector<char> seen(N_.size(), 0);
        for (int i : loop) {
            if (N_[i].removed || seen[i]) continue;
            int q = i;
            do {
                seen[q] = 1;
                if (N_[q].reflex) reflex.push_back(q);
                q = N_[q].next;
            } while (q != i);
            pending_.push_back(i);
        }
        build_grid(reflex, bbox_[0], bbox_[1], bbox_[2], bbox_[3]);
    }

private:
    bool half_ = false;  // this clipper clips one half of a split loop

    // A diagonal that splits the loop (its nodes in order) into two parts
    // of 40-60% each. Candidates: from nodes spread along the loop, to the
    // nearest node 40-60% further on; then each end moves to the node
    // nearest the other end among its 32 neighbours on either side (on a
    // jagged ring a random vertex is hidden between its neighbours; the one
    // reaching furthest towards the other end is usually exposed; n / 16
    // on either side for loops under 512 nodes). The
    // first candidate inside the polygon is taken: strictly inside the
    // angle at both ends and meeting no edge or vertex (then, the polygon
    // being simple, its open segment is interior). Nodes with a coincident
    // twin (bridge ends) are not used. At most four exact full scans; false
    // if none of the candidates qualifies.
    bool find_split(const std::vector<int>& loop, std::size_t& ia, std::size_t& ib) const {
        const std::size_t n = loop.size();
        // Loop position nearest to node t among positions [from, from + len) (mod n); n if none.
        const auto nearest = [&](std::size_t from, std::size_t len, int t) {
            const Node& nt = N_[t];
            std::size_t best = n;
            double bd = std::numeric_limits<double>::infinity();
            for (std::size_t s = 0; s < len; ++s) {
                const std::size_t i = (from + s) % n;
                const Node& nb = N_[loop[i]];
                const double dx = nb.x - nt.x, dy = nb.y - nt.y;
                const double d = dx * dx + dy * dy;
                if (d < bd && nb.twin == loop[i]) {
                    bd = d;
                    best = i;
                }
            }
            return best;
        };
        const std::size_t around = std::min<std::size_t>(32, n / 16);
        int scans = 0;
        for (std::size_t k = 0; k < 16 && scans < 4; ++k) {
            // Start positions 0, n/2, n/4, 3n/4, n/8, ... (spread first).
            const std::size_t r = ((k & 1) << 3) | ((k & 2) << 1) | ((k & 4) >> 1) | ((k & 8) >> 3);
            std::size_t i = r * n / 16;
            std::size_t j = nearest(i + 9 * n / 20, n / 10 + 1, loop[i]);
            if (j == n) continue;
            i = nearest(i + n - around, 2 * around + 1, loop[j]);
            if (i == n) continue;
            j = nearest(j + n - around, 2 * around + 1, loop[i]);
            if (j == n) continue;
            const std::size_t gap = (j + n - i) % n;  // nodes from i to j along the loop
            if (gap < n / 3 || gap > n - n / 3) continue;
            const int a = loop[i], b = loop[j];
            if (same_point(P(N_[a]), P(N_[b]))) continue;
            if (!locally_inside(a, P(N_[b]), true) || !locally_inside(b, P(N_[a]), true)) continue;
            ++scans;
            if (!diagonal_clear(a, a, b)) continue;
            ia = i;
            ib = j;
            return true;
        }
        return false;
    }
    // Split the loop through `start` along find_split's diagonal and clip
    // the two halves: the first here, the second on another thread when the
    // machine has a second core. Each half has its own reflex grid; they
    // share only the node array (disjoint nodes, none added: a half that
    // would need the fallbacks stops and sets bailed_). Whoever comes first
    // claims the second half: if the worker has not started by the time
    // the first half is done, it is clipped here as well. The worker
    // allocates nothing (its buffers are reserved here), and the triangles
    // are the first half's, then the second's, whoever clipped them. False
    // (nothing changed) if the loop has fewer than split_min_ nodes or no
    // diagonal was found.
    bool clip_halves(int start) {
        std::vector<int> loop;
        loop.reserve(N_.size());
        int p = start;
        do {
            loop.push_back(p);
            p = N_[p].next;
        } while (p != start);
        const std::size_t cnt = loop.size();
        if (cnt < split_min_) return false;
        std::size_t i = 0, j = 0;
        if (!find_split(loop, i, j)) return false;
        const int ia = loop[i], ib = loop[j];
        const std::size_t cnt_second = (j + cnt - i) % cnt + 1;  // a2, ia.next ... ib.prev, b2
        out_.reserve(out_.size() + 3 * (cnt - 2));
        const auto [a2, b2] = poly_.connect(ia, ib);
        for (int k : {ia, ib, a2, b2}) {
            Node& nd = N_[k];
            nd.reflex = orient2d(P(N_[nd.prev]), P(nd), P(N_[nd.next])) <= 0.0;
        }
        // Coincident nodes (the split's and the bridges' copies) are linked
        // in twin rings that the ear test and remove() walk: keep only the
        // links within a half, so that neither half reads or writes the
        // other's nodes (each half is a polygon of its own).
        std::vector<char> side(N_.size(), 0);
        std::vector<int> twinned;
        for (const auto& [from, tag] : {std::pair<int, char>{ia, 1}, std::pair<int, char>{a2, 2}}) {
            int q = from;
            do {
                side[q] = tag;
                if (N_[q].twin != q) twinned.push_back(q);
                q = N_[q].next;
            } while (q != from);
        }
        std::vector<int> new_twin(twinned.size());
        for (std::size_t k = 0; k < twinned.size(); ++k) {
            const int q = twinned[k];
            int t = N_[q].twin;
            while (t != q && side[t] != side[q]) t = N_[t].twin;
            new_twin[k] = t;
        }
        for (std::size_t k = 0; k < twinned.size(); ++k) N_[twinned[k]].twin = new_twin[k];
        const auto make_half = [&](Clipper& c) {
            c.half_ = true;
            c.check_empty_ = false;
        };
        // The worker's half, with every buffer it will use reserved here.
        std::vector<I64> out_w;
        Clipper away(poly_, out_w);
        make_half(away);
        std::atomic<int> claim{0};  // 1: the worker clips the second half, 2: this thread does
        std::exception_ptr err_away;
        std::thread worker;
        if (threads_ != 1 && hardware_threads() > 1) {
            away.reserve_for(cnt_second);
            try {
                worker = std::thread([&]() {
                    int expected = 0;
                    if (!claim.compare_exchange_strong(expected, 1)) return;
                    try {
                        away.run(EarOrder::plain, a2);
                    } catch (...) {
                        err_away = std::current_exception();
                    }
                });
            } catch (const std::system_error&) {
                // No thread to be had: both halves are clipped here.
            }
        }
        // Joins the worker on every path out (an exception included).
        struct JoinOnExit {
            std::thread& t;
            ~JoinOnExit() {
                if (t.joinable()) t.join();
            }
        } join_worker{worker};
        Clipper first(poly_, out_);
        make_half(first);
        first.run(EarOrder::plain, ia);
        tri_area2_ = first.tri_area2_;
        bailed_ = first.bailed_;
        int expected = 0;
        if (claim.compare_exchange_strong(expected, 2)) {
            Clipper second(poly_, out_);  // straight after the first half's triangles
            make_half(second);
            second.adopt_buffers(first);
            if (!bailed_) second.run(EarOrder::plain, a2);
            tri_area2_ += second.tri_area2_;
            bailed_ = bailed_ || second.bailed_;
            return true;
        }
        worker.join();
        if (err_away) std::rethrow_exception(err_away);
        tri_area2_ += away.tri_area2_;
        bailed_ = bailed_ || away.bailed_;
        out_.insert(out_.end(), out_w.begin(), out_w.end());
        return true;
    }
    // Reserve every buffer run() fills for a loop of cnt nodes (plain
    // order, no fallbacks), so that it allocates nothing.
    void reserve_for(std::size_t cnt) {
        reflex_.reserve(cnt);
        pending_.reserve(4);
        out_.reserve(out_.size() + 3 * cnt);
        // The reflex grid: at most max(cnt / 2, 2048) cells (GridFrame::shape).
        const std::size_t cells = std::max<std::size_t>(cnt / 2 + 1, 2048) + 2;
        gstart_.reserve(cells + 1);
        gcells_.reserve(cells);
        gslot_.reserve(N_.size());
        gcellof_.reserve(N_.size());
        gitems_.reserve(cnt);
        gids_.reserve(cnt);
    }
    // Take over another clipper's buffers (their memory, not their content).
    void adopt_buffers(Clipper& o) {
        reflex_.swap(o.reflex_);
        gstart_.swap(o.gstart_);
        gcells_.swap(o.gcells_);
        gslot_.swap(o.gslot_);
        gcellof_.swap(o.gcellof_);
        gitems_.swap(o.gitems_);
        gids_.swap(o.gids_);
    }
    static unsigned hardware_threads() {
        static const unsigned n = std::thread::hardware_concurrency();
        return n;
    }

    Polygon& poly_;
    std::vector<Node>& N_;
    std::vector<I64>& out_;
    std::size_t remaining_ = 0;
    int cur_ = -1;
    std::vector<int> pending_;
    std::vector<int> reflex_;  // run(): the loop's reflex nodes
    std::array<double, 4> bbox_{};
    bool resplit_ = false;  // a split happened: the quality heap must be rebuilt
    // Reflex grid (CSR).
    GridFrame rg_;
    // Items are bare points (16 bytes: the scan reads 4 per cache line),
    // their nodes in a parallel array read only for box survivors. A cell's
    // live range [begin, end) is one 8-byte pair (one load per cell).
    struct GItem {
        double x, y;  // &x is a point for the predicates
    };
    struct GCell {
        int begin, end;
    };
    std::vector<int> gstart_, gslot_, gcellof_, gids_;
    std::vector<GCell> gcells_;
    std::vector<GItem> gitems_;

    void build_grid(const std::vector<int>& reflex, double xmin, double ymin, double xmax, double ymax) {
        rg_.shape(xmin, ymin, xmax, ymax, 0.5 * static_cast<double>(reflex.size()), 2048.0);
        const std::size_t ncell = static_cast<std::size_t>(rg_.nx) * rg_.ny;
        gstart_.assign(ncell + 1, 0);
        gslot_.assign(N_.size(), -1);
        gcellof_.resize(N_.size());
        for (int i : reflex) {
            const Node& n = N_[i];
            const int c = rg_.col(n.x) * rg_.ny + rg_.row(n.y);
            gcellof_[i] = c;
            ++gstart_[c + 1];
        }
        for (std::size_t c = 1; c < gstart_.size(); ++c) gstart_[c] += gstart_[c - 1];
        gitems_.resize(reflex.size());
        gids_.resize(reflex.size());
        gcells_.resize(ncell);
        for (std::size_t c = 0; c < ncell; ++c) gcells_[c] = {gstart_[c], gstart_[c]};
        for (int i : reflex) {
            const int k = gcells_[gcellof_[i]].end++;
            gitems_[k] = {N_[i].x, N_[i].y};
            gids_[k] = i;
            gslot_[i] = k;
        }
    }
    // A vertex that stops being reflex (or is clipped) leaves the grid:
    // swap it with the last item of its cell, so scans see live items only.
    void grid_erase(int i) {
        const int k = gslot_[i];
        if (k < 0) return;
        const int last = --gcells_[gcellof_[i]].end;
        gitems_[k] = gitems_[last];
        gids_[k] = gids_[last];
        gslot_[gids_[k]] = k;
        gslot_[i] = -1;
    }
    void emit(const Node& a, const Node& b, const Node& c) {
        // Twice the covered area, for the invalid-input check in triangulate().
        tri_area2_ += std::fabs((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
        out_.push_back(a.v);
        out_.push_back(b.v);
        out_.push_back(c.v);
    }

    // Corner X of triangle (X, Y, Z) (counter-clockwise): is the direction to
    // q strictly inside the triangle's angle at X?
    static bool in_corner(const double* x, const double* y, const double* z, const double* q) {
        return orient2d(x, y, q) > 0.0 && orient2d(z, x, q) > 0.0;
    }

    // A node coincident with a triangle corner blocks the ear if one of its
    // edges enters the triangle there (region sectors of coincident nodes of
    // a weakly simple polygon are disjoint, so edges are all that matter).
    //
    // At the tip b, a coincident node whose edges are exactly the reverses of
    // the ear's two edges (c -> b' -> a) closes a zero-area remnant around
    // the triangle: the region lies on both sides, i.e. nowhere, so the ear
    // is not part of the polygon (the last step of an hourglass ring).
    bool twins_block(int corner, const double* y, const double* z, bool tip) const {
        const Node& c = N_[corner];
        for (int t = c.twin; t != corner; t = N_[t].twin) {
            const Node& n = N_[t];
            if (n.removed) continue;
            const double* np = P(N_[n.prev]);
            const double* nn = P(N_[n.next]);
            if (in_corner(P(c), y, z, np) || in_corner(P(c), y, z, nn)) return true;
            if (tip && same_point(np, y) && same_point(nn, z)) return true;
        }
        return false;
    }

    // Is node ib an ear tip? Strictly convex, and no other vertex in the
    // closed triangle (only non-convex vertices need testing: if a vertex is
    // inside, a reflex one is).
    __attribute__((flatten)) bool is_ear(int ib) const {
        const Node& b = N_[ib];
        const int ia = b.prev, ic = b.next;
        const Node &a = N_[ia], &c = N_[ic];
        if (orient2d_quick(P(a), P(b), P(c)) <= 0.0) return false;
        if (a.twin != ia && twins_block(ia, P(b), P(c), false)) return false;
        if (b.twin != ib && twins_block(ib, P(c), P(a), true)) return false;
        if (c.twin != ic && twins_block(ic, P(a), P(b), false)) return false;
        const double minx = std::min({a.x, b.x, c.x}), maxx = std::max({a.x, b.x, c.x});
        const double miny = std::min({a.y, b.y, c.y}), maxy = std::max({a.y, b.y, c.y});
        const int c0 = rg_.col(minx), c1 = rg_.col(maxx), r0 = rg_.row(miny), r1 = rg_.row(maxy);
        // Items are first filtered by the ear's box without a branch (about
        // a quarter pass; a branch per item would mispredict often) into a
        // small buffer, whose entries then get the exact tests.
        int cand[64];
        int m = 0;
        // Exact tests of the candidates collected so far; false if one is in the ear.
        auto clear = [&]() {
            for (int j = 0; j < m; ++j) {
                // A point at a corner's position never blocks (the corners
                // themselves, mostly reflex on a jagged ring, are items too);
                // comparing coordinates avoids loading the item's node id.
                const double* q = &gitems_[cand[j]].x;
                if (same_point(q, P(a)) || same_point(q, P(c)) || same_point(q, P(b))) continue;
                if (orient2d_quick(P(a), P(b), q) >= 0.0 && orient2d_quick(P(b), P(c), q) >= 0.0 &&
                    orient2d_quick(P(c), P(a), q) >= 0.0)
                    return false;
            }
            m = 0;
            return true;
        };
        for (int cx = c0; cx <= c1; ++cx) {
            for (int cell = cx * rg_.ny + r0, ce = cx * rg_.ny + r1; cell <= ce; ++cell) {
                const GCell ce_range = gcells_[cell];
                for (int k = ce_range.begin, e = ce_range.end; k < e; ++k) {
                    const GItem& r = gitems_[k];
                    cand[m] = k;
                    m += (r.x >= minx) & (r.x <= maxx) & (r.y >= miny) & (r.y <= maxy);
                    if (m == 64 && !clear()) return false;
                }
            }
        }
        return clear();
    }

    // Minimum-angle proxy of triangle (prev, b, next): sin^2 of the smallest
    // angle = (2 area)^2 / (product of the two longer squared sides). It is
    // monotone in the smallest angle (which is at most 60 degrees).
    double ear_key(int ib) const {
        const Node& b = N_[ib];
        const Node &a = N_[b.prev], &c = N_[b.next];
        const double abx = b.x - a.x, aby = b.y - a.y, bcx = c.x - b.x, bcy = c.y - b.y;
        const double cax = a.x - c.x, cay = a.y - c.y;
        double s1 = abx * abx + aby * aby, s2 = bcx * bcx + bcy * bcy, s3 = cax * cax + cay * cay;
        const double area2 = abx * bcy - aby * bcx;
        const double mn = std::min({s1, s2, s3});
        const double prod = s1 * s2 * s3 / mn;
        return prod > 0 ? area2 * area2 / prod : 0.0;
    }

    void update_reflex(int i) {
        Node& n = N_[i];
        if (n.reflex && orient2d_quick(P(N_[n.prev]), P(n), P(N_[n.next])) > 0.0) {
            n.reflex = false;
            grid_erase(i);
        }
    }

    void remove(int ib, bool emit_triangle) {
        Node& b = N_[ib];
        Node &a = N_[b.prev], &c = N_[b.next];
        if (emit_triangle) emit(a, b, c);
        a.next = b.next;
        c.prev = b.prev;
        eg_link(b.prev, b.next);
        a.not_ear = c.not_ear = false;  // their triangles changed
        // Nodes coincident with a, b or c see their edges in twins_block: a
        // triangle with a corner at such a position may have changed status.
        for (int x : {b.prev, ib, b.next}) {
            for (int t = N_[x].twin; t != x; t = N_[t].twin) {
                Node& tn = N_[t];
                tn.not_ear = N_[tn.prev].not_ear = N_[tn.next].not_ear = false;
            }
        }
        b.removed = true;
        if (b.reflex) grid_erase(ib);
        --remaining_;
        update_reflex(b.prev);
        update_reflex(b.next);
        cur_ = b.next;
    }

    // No ear left (invalid or degenerate input): remove one vertex anyway so
    // that the loop terminates. Prefer a strictly convex vertex whose triangle
    // has no vertex strictly inside, then any strictly convex vertex, then a
    // collinear one (no area lost), then any vertex.
    int forced_vertex(int from) const {
        int convex = -1, flat = -1;
        int p = from;
        do {
            const Node& b = N_[p];
            const double o = orient2d(P(N_[b.prev]), P(b), P(N_[b.next]));
            if (o > 0.0) {
                if (!strictly_occupied(p)) return p;
                if (convex < 0) convex = p;
            } else if (o == 0.0 && flat < 0) {
                flat = p;
            }
            p = b.next;
        } while (p != from);
        if (convex >= 0) return convex;
        if (flat >= 0) return flat;
        return from;
    }
    bool strictly_occupied(int ib) const {
        const Node& b = N_[ib];
        const Node &a = N_[b.prev], &c = N_[b.next];
        for (int p = c.next; p != b.prev; p = N_[p].next) {
            const Node& r = N_[p];
            if (orient2d(P(a), P(b), P(r)) > 0.0 && orient2d(P(b), P(c), P(r)) > 0.0 &&
                orient2d(P(c), P(a), P(r)) > 0.0)
                return true;
        }
        return false;
    }
    // A self-crossing ring (invalid input) can twist locally: edges a-p and
    // q-b of four consecutive nodes a, p, q, b cross. The twist is cut off
    // by triangle (a, p, b) (if counter-clockwise) and p, q are removed, as
    // mapbox/earcut does; this keeps far more of the area than clipping a
    // vertex whose triangle overlaps others.
    bool cure_local_crossing(int from) {
        int p = from;
        do {
            const Node& np = N_[p];
            const int ia = np.prev, iq = np.next, ib = N_[iq].next;
            if (ib != ia && N_[ib].next != ia) {
                const Node &a = N_[ia], &q = N_[iq], &b = N_[ib];
                const int o1 = orient2d_sign(P(a), P(np), P(q)), o2 = orient2d_sign(P(a), P(np), P(b));
                const int o3 = orient2d_sign(P(q), P(b), P(a)), o4 = orient2d_sign(P(q), P(b), P(np));
                if (o1 * o2 < 0 && o3 * o4 < 0) {
                    if (orient2d(P(a), P(np), P(b)) > 0.0) emit(a, np, b);
                    remove(p, false);
                    remove(iq, false);
                    return true;
                }
            }
            p = np.next;
        } while (p != from);
        return false;
    }

    // Signed area of what is left, relative to its size: a remnant whose
    // area is zero up to rounding holds no region (all its edges doubled, as
    // after the real ears of a pinched ring are gone) and is dropped whole.
    bool remnant_is_empty(int from) const {
        const double x0 = N_[from].x, y0 = N_[from].y;
        {
            // Quick pass in double: the long double sums below differ from
            // these by at most err (n + 8 roundings of 2^-53 of every product
            // magnitude, doubled for both computations), so this answers
            // exactly as they would whenever it answers.
            double sd = 0, scd = 0, mag = 0;
            std::size_t n = 0;
            int q = from;
            do {
                const Node &a = N_[q], &b = N_[a.next];
                const double p1 = (a.x - x0) * (b.y - y0), p2 = (b.x - x0) * (a.y - y0);
                const double t = p1 - p2;
                sd += t;
                scd += std::fabs(t);
                mag += std::fabs(p1) + std::fabs(p2);
                ++n;
                q = a.next;
            } while (q != from);
            const double err = 2.0 * (static_cast<double>(n) + 8.0) * kEpsilon * mag * (1.0 + 1e-6);
            if (std::fabs(sd) - err > 1e-12 * (scd + err) * (1.0 + 1e-6)) return false;
        }
        long double s = 0, scale = 0;
        int p = from;
        do {
            const Node &a = N_[p], &b = N_[a.next];
            const long double t = static_cast<long double>(a.x - x0) * (b.y - y0) -
                                  static_cast<long double>(b.x - x0) * (a.y - y0);
            s += t;
            scale += std::fabs(static_cast<double>(t));
            p = a.next;
        } while (p != from);
        // Each term is exact to ~1e-16 relative; 1e-12 of their absolute sum
        // separates rounding from any real area left.
        if (std::fabs(static_cast<double>(s)) > 1e-12 * static_cast<double>(scale)) return false;
        // Near zero: decide exactly. A loop holds no region iff its edges
        // cancel in pairs (every edge u -> v matched by an edge v -> u), as
        // for a hole identical to the outer ring. A thin sliver of tiny but
        // non-zero area is kept.
        struct E {
            double x0, y0, x1, y1;
            int dir;
        };
        std::vector<E> es;
        p = from;
        do {
            const Node &a = N_[p], &b = N_[a.next];
            const bool fwd = a.x < b.x || (a.x == b.x && a.y < b.y);
            es.push_back(fwd ? E{a.x, a.y, b.x, b.y, 1} : E{b.x, b.y, a.x, a.y, -1});
            p = a.next;
        } while (p != from);
        std::sort(es.begin(), es.end(), [](const E& u, const E& v) {
            if (u.x0 != v.x0) return u.x0 < v.x0;
            if (u.y0 != v.y0) return u.y0 < v.y0;
            if (u.x1 != v.x1) return u.x1 < v.x1;
            return u.y1 < v.y1;
        });
        for (std::size_t i = 0; i < es.size();) {
            std::size_t j = i;
            int sum = 0;
            while (j < es.size() && es[j].x0 == es[i].x0 && es[j].y0 == es[i].y0 && es[j].x1 == es[i].x1 &&
                   es[j].y1 == es[i].y1)
                sum += es[j++].dir;
            if (sum != 0) return false;
            i = j;
        }
        return true;
    }
    // Drop vertices that bound no area: a vertex at the same position as
    // its successor, or collinear with its neighbours (a straight-through
    // vertex or the tip of a zero-width spike). Returns whether any was
    // dropped. Only used once no ear is left (invalid or degenerate input).
    bool filter_flat(int from) {
        bool any = false;
        int p = from, stop = from;
        while (remaining_ > 3) {
            const Node& b = N_[p];
            const int nx = b.next;
            if (same_point(P(b), P(N_[nx])) || orient2d(P(N_[b.prev]), P(b), P(N_[nx])) == 0.0) {
                remove(p, false);
                any = true;
                p = stop = cur_;
                continue;
            }
            p = nx;
            if (p == stop) break;
        }
        cur_ = p;
        return any;
    }

    // Uniform grid over the live edges (node u -> node v), for the strict
    // ear test of invalid input: without it every ear would walk the whole
    // loop (O(n^2): 55 ms on earcut's water-huge). Built on first use;
    // every link made afterwards (remove, cut, cancel_doubled_edges) adds its
    // edge, and an entry whose edge is gone (u removed or u.next != v) is
    // skipped. Unlike a walk of the current loop it also sees the edges of
    // the pieces still queued, which an ear's diagonal must not cross either.
    struct EdgeEntry {
        int u, v, next;
    };
    bool eg_built_ = false;
    GridFrame eg_;
    std::vector<int> eg_head_;
    std::vector<EdgeEntry> eg_pool_;
    void eg_cells(const double* p, const double* q, int& c0, int& c1, int& r0, int& r1) const {
        c0 = eg_.col(std::min(p[0], q[0]));
        c1 = eg_.col(std::max(p[0], q[0]));
        r0 = eg_.row(std::min(p[1], q[1]));
        r1 = eg_.row(std::max(p[1], q[1]));
    }
    void eg_insert(int u, int v) {
        int c0, c1, r0, r1;
        eg_cells(P(N_[u]), P(N_[v]), c0, c1, r0, r1);
        for (int cx = c0; cx <= c1; ++cx)
            for (int cy = r0; cy <= r1; ++cy) {
                int& head = eg_head_[static_cast<std::size_t>(cx) * eg_.ny + cy];
                eg_pool_.push_back({u, v, head});
                head = static_cast<int>(eg_pool_.size()) - 1;
            }
    }
    void eg_link(int u, int v) {
        if (eg_built_) eg_insert(u, v);
    }
    void eg_build() {
        std::size_t live = 0;
        for (const Node& n : N_) live += !n.removed;
        eg_.shape(bbox_[0], bbox_[1], bbox_[2], bbox_[3], static_cast<double>(live), 2048.0);
        eg_head_.assign(static_cast<std::size_t>(eg_.nx) * eg_.ny, -1);
        eg_pool_.clear();
        eg_pool_.reserve(2 * live + 16);
        for (std::size_t i = 0; i < N_.size(); ++i)
            if (!N_[i].removed) eg_insert(static_cast<int>(i), N_[i].next);
        eg_built_ = true;
    }
    // Does the open segment between nodes ia and ib avoid every live edge
    // not incident to them? (The grid's version of diagonal_clear.)
    bool edge_grid_clear(int ia, int ib) {
        if (!eg_built_) eg_build();
        const double* pa = P(N_[ia]);
        const double* pb = P(N_[ib]);
        const double x0 = std::min(pa[0], pb[0]), x1 = std::max(pa[0], pb[0]);
        const double y0 = std::min(pa[1], pb[1]), y1 = std::max(pa[1], pb[1]);
        int c0, c1, r0, r1;
        eg_cells(pa, pb, c0, c1, r0, r1);
        for (int cx = c0; cx <= c1; ++cx)
            for (int cy = r0; cy <= r1; ++cy)
                for (int e = eg_head_[static_cast<std::size_t>(cx) * eg_.ny + cy]; e >= 0; e = eg_pool_[e].next) {
                    const EdgeEntry& en = eg_pool_[e];
                    const Node& u = N_[en.u];
                    if (u.removed || u.next != en.v) continue;  // edge gone
                    if (en.u == ia || en.u == ib || en.v == ia || en.v == ib) continue;
                    const Node& v = N_[en.v];
                    if ((u.x < x0 && v.x < x0) || (u.x > x1 && v.x > x1) || (u.y < y0 && v.y < y0) ||
                        (u.y > y1 && v.y > y1))
                        continue;
                    if (segments_conflict(pa, pb, P(u), P(v))) return false;
                }
        return true;
    }

    // Is the direction from node ia to point q strictly inside the region's
    // angle at ia (the region is on the left of the counter-clockwise loop)?
    // not_along_edges: also false if q lies on the line of either edge at ia.
    bool locally_inside(int ia, const double* q, bool not_along_edges = false) const {
        const Node& a = N_[ia];
        const double* pp = P(N_[a.prev]);
        const double* pn = P(N_[a.next]);
        const double l1 = orient2d(pp, P(a), q), l2 = orient2d(P(a), pn, q);
        if (not_along_edges && (l1 == 0.0 || l2 == 0.0)) return false;
        if (orient2d(pp, P(a), pn) > 0.0) return l1 > 0.0 && l2 > 0.0;
        return l1 > 0.0 || l2 > 0.0;
    }
    // Even-odd test of point q against the loop through `from`.
    bool inside_loop(int from, const double* q) const {
        bool in = false;
        int p = from;
        do {
            const Node &u = N_[p], &v = N_[u.next];
            if ((u.y > q[1]) != (v.y > q[1])) {
                // Edge crosses the horizontal line through q: is q left of it?
                const double o = orient2d(P(u), P(v), q);
                if ((o > 0.0) == (v.y > u.y)) in = !in;
            }
            p = u.next;
        } while (p != from);
        return in;
    }
    // Does the open segment between nodes ia and ib avoid every loop edge?
    bool diagonal_clear(int from, int ia, int ib) const {
        const double* pa = P(N_[ia]);
        const double* pb = P(N_[ib]);
        // Segments with disjoint boxes share no point: skip them before the
        // exact test (this runs for every ear in the fallback phase).
        const double x0 = std::min(pa[0], pb[0]), x1 = std::max(pa[0], pb[0]);
        const double y0 = std::min(pa[1], pb[1]), y1 = std::max(pa[1], pb[1]);
        int p = from;
        do {
            const Node& u = N_[p];
            const int iv = u.next;
            const Node& v = N_[iv];
            if ((u.x < x0 && v.x < x0) || (u.x > x1 && v.x > x1) || (u.y < y0 && v.y < y0) ||
                (u.y > y1 && v.y > y1)) {
                p = iv;
                continue;
            }
            if (p != ia && p != ib && iv != ia && iv != ib && segments_conflict(pa, pb, P(u), P(v)))
                return false;
            p = iv;
        } while (p != from);
        return true;
    }

    // Split the loop through `from` in two along a diagonal that lies inside
    // it (locally inside at both ends, crossing no edge, its midpoint inside),
    // as a simple polygon always has one. The first piece continues in this
    // loop (cur_, remaining_), the second is queued. Returns false if no such
    // diagonal exists.
    bool split_by_diagonal(int from) {
        int ia = from;
        do {
            const Node& a = N_[ia];
            for (int ib = N_[a.next].next; ib != a.prev; ib = N_[ib].next) {
                const Node& b = N_[ib];
                if (same_point(P(a), P(b))) continue;
                if (!locally_inside(ia, P(b)) || !locally_inside(ib, P(a))) continue;
                if (!diagonal_clear(from, ia, ib)) continue;
                const double mid[2] = {0.5 * a.x + 0.5 * b.x, 0.5 * a.y + 0.5 * b.y};
                if (!inside_loop(from, mid)) continue;
                cut(ia, ib);
                return true;
            }
            ia = a.next;
        } while (ia != from);
        return false;
    }
    void cut(int ia, int ib) {
        const int bp = N_[ib].prev;
        const auto [a2, b2] = poly_.connect(ia, ib);
        for (int u : {ia, a2, b2, bp}) eg_link(u, N_[u].next);
        for (int i : {ia, ib, a2, b2}) {
            Node& n = N_[i];
            n.reflex = orient2d(P(N_[n.prev]), P(n), P(N_[n.next])) <= 0.0;
            n.not_ear = false;
        }
        // The copies are new nodes: rebuild the reflex grid over every live node.
        std::vector<int> reflex;
        for (std::size_t i = 0; i < N_.size(); ++i)
            if (!N_[i].removed && N_[i].reflex) reflex.push_back(static_cast<int>(i));
        build_grid(reflex, bbox_[0], bbox_[1], bbox_[2], bbox_[3]);
        std::size_t cnt = 0;
        int p = ia;
        do {
            ++cnt;
            p = N_[p].next;
        } while (p != ia);
        pending_.push_back(a2);
        remaining_ = cnt;
        cur_ = ia;
        resplit_ = true;
    }

    // No ear left (invalid or degenerate input). In order: drop a loop of
    // zero area; drop vertices that bound no area; cut off a local twist of
    // a self-crossing ring; split the loop along an inside diagonal; and
    // only then remove one vertex anyway so that the loop terminates.
    void force_one(int from) {
        if (remnant_is_empty(from)) {
            // Drop every remaining vertex without triangles.
            int p = from;
            while (remaining_ > 0) {
                const int nx = N_[p].next;
                N_[p].removed = true;
                if (N_[p].reflex) grid_erase(p);
                --remaining_;
                p = nx;
            }
            return;
        }
        if (filter_flat(from)) return;
        if (cure_local_crossing(from)) return;
        if (split_by_diagonal(from)) return;
        const int v = forced_vertex(from);
        const Node& b = N_[v];
        const bool positive = orient2d(P(N_[b.prev]), P(b), P(N_[b.next])) > 0.0;
        remove(v, positive);
    }

    // Eberly's order: walk the ring and clip each ear as it is found.
    //
    // Clipping an ear changes the ear status of its two neighbours only (for
    // a simple polygon: a vertex u inside the triangle of a non-ear v, with
    // its neighbours outside it, would make u's edges cross the diagonal of
    // v twice, so u is reflex, not an ear). So a vertex found not to be an
    // ear is skipped until one of its neighbours is clipped (Node::not_ear,
    // cleared in remove()): the same ears in the same order, with fewer
    // tests. For invalid input the lemma may fail, so a lap that skipped
    // cached vertices and found no ear is repeated without the cache before
    // falling back to force_one.
    void clip_plain(int start) {
        int p = start;
        int stop = p;
        cur_ = p;
        bool skipped = false;
        int loose = -1;  // fallback phase: an ear whose diagonal crosses an edge
        while (remaining_ > 3) {
            Node& n = N_[p];
            if (n.not_ear) {
                skipped = true;
            } else if (is_ear(p) && (!strict_ears_ || ear_diagonal_clear(p, loose))) {
                remove(p, true);
                p = cur_;
                stop = p;
                skipped = false;
                loose = -1;
                continue;
            } else {
                n.not_ear = true;
            }
            p = n.next;
            if (p == stop) {
                if (skipped) {
                    int q = p;
                    do {
                        N_[q].not_ear = false;
                        q = N_[q].next;
                    } while (q != p);
                    skipped = false;
                    loose = -1;
                    continue;
                }
                if (loose >= 0) {
                    // Only ears crossing an edge are left: clip one anyway.
                    remove(loose, true);
                    loose = -1;
                } else {
                    if (half_) {
                        bailed_ = true;
                        return;
                    }
                    force_one(p);
                    strict_ears_ = true;
                }
                p = cur_;
                stop = p;
            }
        }
        cur_ = p;
    }

    struct Entry {
        double key;
        int node, stamp;
        bool operator<(const Entry& o) const { return key < o.key || (key == o.key && node > o.node); }
    };

    // Quality order: always clip the ear with the largest minimum angle.
    void clip_quality(int start) {
        if (strict_quality_) clip_quality_strict(start);
        else clip_quality_impl<false>(start);
    }
    // Strict: invalid input (strict_quality_). A template parameter, and
    // the strict copy out of line, so that valid input runs the same code
    // as without the test (a run-time check in the loop, or both copies
    // inlined, cost 2-4% on a 1k-vertex polygon).
    __attribute__((noinline)) void clip_quality_strict(int start) { clip_quality_impl<true>(start); }
    template <bool Strict>
    void clip_quality_impl(int start) {
        std::priority_queue<Entry> heap;
        // Version of each node's heap entry (a split adds nodes: grow).
        std::vector<int> stamp(N_.size(), 0);
        auto consider = [&](int i) {
            Node& n = N_[i];
            if (static_cast<std::size_t>(i) >= stamp.size()) stamp.resize(N_.size(), 0);
            ++stamp[i];
            if (!n.removed && is_ear(i)) heap.push({ear_key(i), i, stamp[i]});
        };
        auto consider_all = [&](int from) {
            int p = from;
            do {
                consider(p);
                p = N_[p].next;
            } while (p != from);
        };
        consider_all(start);
        cur_ = start;
        while (remaining_ > 3) {
            if (heap.empty()) {
                // Ear status of non-adjacent vertices does not change for a
                // simple polygon; for weakly simple ones it may, so rescan
                // once before forcing a vertex out.
                consider_all(cur_);
                if (heap.empty()) {
                    resplit_ = false;
                    force_one(cur_);
                    if (remaining_ < 3) break;
                    if (resplit_) {
                        // The loop was cut in two: entries may name nodes of
                        // the queued piece. Start over on this piece.
                        heap = std::priority_queue<Entry>();
                        consider_all(cur_);
                    } else {
                        consider(N_[cur_].prev);
                        consider(cur_);
                    }
                    continue;
                }
            }
            const Entry e = heap.top();
            heap.pop();
            const Node& n = N_[e.node];
            if (n.removed || stamp[e.node] != e.stamp) continue;
            const int a = n.prev, c = n.next;
            if constexpr (Strict) {
                // Invalid input: an ear whose diagonal crosses a live edge
                // goes back below every other ear (keys are in [0, 3/4]),
                // so it is clipped only when no clean ear is left, as in the
                // plain order's fallback phase. Tested when popped, not when
                // pushed (fewer tests: many pushed entries go stale).
                int loose = -1;
                if (e.key >= 0.0 && !ear_diagonal_clear(e.node, loose)) {
                    heap.push({e.key - 2.0, e.node, e.stamp});
                    continue;
                }
            }
            remove(e.node, true);
            consider(a);
            consider(c);
        }
    }
};

void ring_edges(const Polygon& poly, std::vector<I64>& edges) {
    for (std::size_t r = 0; r < poly.rings.size(); ++r) {
        const auto& ring = poly.rings[r];
        if (ring.size() < 3) continue;
        for (std::size_t k = 0; k < ring.size(); ++k) {
            edges.push_back(ring[k]);
            edges.push_back(ring[(k + 1) % ring.size()]);
        }
    }
}

// Build the oriented rings: outer counter-clockwise, holes clockwise;
// degenerate rings (fewer than 3 vertices, zero area) emptied.
void orient_rings(Polygon& poly, Rings&& rings) {
    poly.rings = std::move(rings.v);
    for (std::size_t r = 0; r < poly.rings.size(); ++r) {
        auto& ring = poly.rings[r];
        double a2 = 0, m2 = 0;
        const int o = ring_orientation(poly.xy, ring, &a2, &m2);
        if (o != 0) poly.net_area2 += (r == 0) == (a2 > 0) ? a2 : -a2, poly.area_mag2 += m2;
        if (o == 0) {
            if (!ring.empty()) ring.clear(), poly.skipped.push_back(static_cast<I64>(r));
            continue;
        }
        if ((r == 0 && o < 0) || (r > 0 && o > 0)) std::reverse(ring.begin(), ring.end());
    }
    if (!poly.rings.empty() && poly.rings[0].empty()) {
        // Without an outer ring there is nothing to triangulate.
        for (auto& ring : poly.rings) ring.clear();
    }
}

std::string ring_label(I64 r) { return r == 0 ? std::string("outer ring 0") : "ring " + std::to_string(r); }

// ----------------------------------------------------------------- validity

PolygonCheck check_rings(const double* xy, const std::vector<std::vector<I64>>& rings) {
    PolygonCheck res;
    auto fail = [&](I64 ring, I64 vertex, std::string msg) {
        res.valid = false;
        res.ring = ring;
        res.vertex = vertex;
        res.message = std::move(msg);
        return res;
    };
    if (rings.empty()) return fail(-1, -1, "no rings");
    double xmin = std::numeric_limits<double>::infinity(), ymin = xmin, xmax = -xmin, ymax = -xmin;
    std::size_t n_seg = 0;
    for (std::size_t r = 0; r < rings.size(); ++r) {
        const auto& ring = rings[r];
        if (ring.size() < 3)
            return fail(static_cast<I64>(r), ring.empty() ? -1 : ring[0],
                        ring_label(r) + " has fewer than 3 distinct consecutive vertices");
        if (ring_orientation(xy, ring) == 0)
            return fail(static_cast<I64>(r), ring[0], ring_label(r) + " has zero area");
        for (I64 v : ring) {
            xmin = std::min(xmin, xy[2 * v]); xmax = std::max(xmax, xy[2 * v]);
            ymin = std::min(ymin, xy[2 * v + 1]); ymax = std::max(ymax, xy[2 * v + 1]);
        }
        n_seg += ring.size();
    }
    SegGrid grid;
    grid.init(xy, xmin, ymin, xmax, ymax, n_seg);
    std::vector<std::pair<I64, I64>> owner;  // (ring, position) per segment
    for (std::size_t r = 0; r < rings.size(); ++r)
        for (std::size_t k = 0; k < rings[r].size(); ++k) {
            grid.insert(rings[r][k], rings[r][(k + 1) % rings[r].size()]);
            owner.push_back({static_cast<I64>(r), static_cast<I64>(k)});
        }
    const std::size_t ns = owner.size();
    for (std::size_t s = 0; s < ns; ++s) {
        const double* p0 = xy + 2 * grid.seg[2 * s];
        const double* p1 = xy + 2 * grid.seg[2 * s + 1];
        int other = -1;
        bool touch = false;
        grid.any(p0, p1, [&](int id) {
            if (static_cast<std::size_t>(id) <= s) return false;
            const double* q0 = xy + 2 * grid.seg[2 * id];
            const double* q1 = xy + 2 * grid.seg[2 * id + 1];
            if (segments_conflict(p0, p1, q0, q1)) { other = id; return true; }
            // Valid means strictly simple: the only shared point allowed is
            // the common vertex of two consecutive edges of one ring. Touching
            // rings are triangulated, but their triangle count is not n + 2h - 2.
            const bool shares = same_point(p0, q0) || same_point(p0, q1) || same_point(p1, q0) ||
                                same_point(p1, q1);
            if (shares) {
                const auto [r1, k1] = owner[s];
                const auto [r2, k2] = owner[id];
                const I64 len = static_cast<I64>(rings[r1].size());
                const bool consecutive = r1 == r2 && ((k1 + 1) % len == k2 || (k2 + 1) % len == k1);
                if (!consecutive) { other = id; touch = true; return true; }
            }
            return false;
        });
        if (other >= 0) {
            const auto [r1, k1] = owner[s];
            const auto [r2, k2] = owner[other];
            return fail(r1, grid.seg[2 * s],
                        ring_label(r1) + " edge " + std::to_string(grid.seg[2 * s]) + "-" +
                            std::to_string(grid.seg[2 * s + 1]) + " (position " + std::to_string(k1) +
                            ") meets " + ring_label(r2) + " edge " + std::to_string(grid.seg[2 * other]) +
                            "-" + std::to_string(grid.seg[2 * other + 1]) + " (position " +
                            std::to_string(k2) + (touch ? ") at a vertex (touching rings)"
                                                              : ") other than at a shared vertex"));
        }
    }
    // Nesting. With no edges meeting, a ring is inside another iff any of its
    // vertices not on the other's boundary is.
    auto side = [&](const double* q, const std::vector<I64>& ring) {  // +1 in, -1 out, 0 on
        int wn = 0;
        const std::size_t n = ring.size();
        for (std::size_t k = 0; k < n; ++k) {
            const double* a = xy + 2 * ring[k];
            const double* b = xy + 2 * ring[(k + 1) % n];
            if (same_point(a, q)) return 0;
            const double o = orient2d(a, b, q);
            if (o == 0.0 && strictly_between(a, b, q)) return 0;
            if (a[1] <= q[1]) {
                if (b[1] > q[1] && o > 0.0) ++wn;
            } else if (b[1] <= q[1] && o < 0.0) {
                --wn;
            }
        }
        return wn != 0 ? 1 : -1;
    };
    auto classify = [&](const std::vector<I64>& inner, const std::vector<I64>& outer) {
        for (I64 v : inner) {
            const int s = side(xy + 2 * v, outer);
            if (s != 0) return s;
        }
        return 0;  // every vertex on the other's boundary
    };
    std::vector<std::array<double, 4>> box(rings.size());
    for (std::size_t r = 0; r < rings.size(); ++r) {
        box[r] = {std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
                  -std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
        for (I64 v : rings[r]) {
            box[r][0] = std::min(box[r][0], xy[2 * v]); box[r][1] = std::min(box[r][1], xy[2 * v + 1]);
            box[r][2] = std::max(box[r][2], xy[2 * v]); box[r][3] = std::max(box[r][3], xy[2 * v + 1]);
        }
    }
    for (std::size_t h = 1; h < rings.size(); ++h) {
        const int s = classify(rings[h], rings[0]);
        if (s < 0) return fail(static_cast<I64>(h), rings[h][0], ring_label(h) + " lies outside the outer ring");
        if (s == 0)
            return fail(static_cast<I64>(h), rings[h][0],
                        ring_label(h) + " has every vertex on the outer ring's boundary");
    }
    for (std::size_t h = 1; h < rings.size(); ++h)
        for (std::size_t g = 1; g < rings.size(); ++g) {
            if (g == h) continue;
            const auto &bh = box[h], &bg = box[g];
            if (bh[0] < bg[0] || bh[2] > bg[2] || bh[1] < bg[1] || bh[3] > bg[3]) continue;
            const int s = classify(rings[h], rings[g]);
            if (s > 0)
                return fail(static_cast<I64>(h), rings[h][0],
                            ring_label(h) + " lies inside " + ring_label(g) + " (a hole in a hole)");
            if (s == 0)
                return fail(static_cast<I64>(h), rings[h][0],
                            ring_label(h) + " has every vertex on the boundary of " + ring_label(g));
        }
    return res;
}

std::vector<I64> triangulate(const char* fn, const double* xy, std::size_t n_points, const I64* ring_vertices,
                             const I64* ring_offsets, std::size_t n_rings, const EarClipOptions& opt) {
    Rings rings = read_rings(fn, xy, n_points, ring_vertices, ring_offsets, n_rings);
    if (opt.strict) {
        const PolygonCheck chk = check_rings(xy, rings.v);
        if (!chk.valid) throw GeometryError(std::string(fn) + ": invalid polygon: " + chk.message);
    }
    Polygon poly;
    poly.xy = xy;
    poly.n_points = n_points;
    orient_rings(poly, std::move(rings));
    std::size_t total = 0;
    for (const auto& r : poly.rings) total += r.size();
    poly.nodes.reserve(total + 2 * poly.rings.size() + 4);
    Joiner(poly, opt.bridge).run();
    std::vector<I64> tris;
    // The joiner and clipper consume the node list: a second pass needs the
    // polygon joined again (only on degenerate or invalid input).
    const auto rejoin = [&]() {
        Polygon again;
        again.xy = xy;
        again.n_points = n_points;
        again.rings = poly.rings;
        again.skipped = poly.skipped;
        again.net_area2 = poly.net_area2;
        again.area_mag2 = poly.area_mag2;
        again.nodes.reserve(total + 2 * again.rings.size() + 4);
        Joiner(again, opt.bridge).run();
        poly = std::move(again);
        tris.clear();
    };
    bool bailed = false;
    const auto clip = [&](Polygon& pg, bool strict, bool split) {
        Clipper clipper(pg, tris);
        clipper.check_empty_ = !pg.bridges.empty();
        clipper.strict_ears_ = strict;
        clipper.strict_quality_ = pg.forced_bridge;
        clipper.may_split_ = split;
        clipper.threads_ = opt.threads;
        clipper.split_min_ = opt.split_min;
        clipper.run(opt.order);
        bailed = clipper.bailed_;
        return clipper.tri_area2_;
    };
    const bool looks_valid = !(poly.forced_bridge || poly.touching);
    double covered2 = clip(poly, !looks_valid, looks_valid && opt.order == EarOrder::plain);
    if (bailed) {
        // A half of the split loop needed the fallbacks: clip it whole.
        rejoin();
        covered2 = clip(poly, false, false);
    }
    // For a valid polygon the triangles cover exactly the rings' net area,
    // so the two sums differ by rounding only (relative 1e-16 per term): a
    // 1e-7 relative mismatch is far above that and far below the gaps and
    // overlaps of invalid input. It only decides whether to clip again with
    // stricter ears, which on valid input accept the same ears anyway.
    if (opt.order == EarOrder::plain && !(poly.forced_bridge || poly.touching) && !tris.empty() &&
        std::fabs(covered2 - poly.net_area2) > 1e-7 * (poly.area_mag2 + covered2)) {
        // Invalid input (rings crossing) that the joiner did not notice: the
        // triangles cover more or less than the rings enclose. Clip again
        // with the fallback phase's stricter ear test from the start, which
        // rejects ears whose diagonal crosses an edge while others are left
        // (bad-hole: deviation 0.036 -> 0.013). For a simple polygon it
        // accepts the same ears, so the result is unchanged either way.
        rejoin();
        clip(poly, true, false);
    }
    if (opt.refine && !tris.empty()) {
        std::vector<I64> edges;
        ring_edges(poly, edges);
        flip_to_constrained_delaunay(xy, n_points, tris, edges.data(), edges.size() / 2);
    }
    return tris;
}

}  // namespace
}  // namespace detail

std::vector<std::int64_t> triangulate_polygon(const double* xy, const std::int64_t* ring_offsets,
                                              std::size_t n_rings, const EarClipOptions& options) {
    const std::size_t n_points = n_rings > 0 && ring_offsets ? static_cast<std::size_t>(std::max<std::int64_t>(0, ring_offsets[n_rings])) : 0;
    return detail::triangulate("triangulate_polygon", xy, n_points, nullptr, ring_offsets, n_rings, options);
}

std::vector<std::int64_t> triangulate_polygon_indexed(const double* xy, std::size_t n_points,
                                                      const std::int64_t* ring_vertices,
                                                      const std::int64_t* ring_offsets,
                                                      std::size_t n_rings, const EarClipOptions& options) {
    return detail::triangulate("triangulate_polygon_indexed", xy, n_points, ring_vertices, ring_offsets,
                               n_rings, options);
}

JoinedPolygon join_holes(const double* xy, std::size_t n_points, const std::int64_t* ring_vertices,
                         const std::int64_t* ring_offsets, std::size_t n_rings, BridgeMethod method) {
    detail::Rings rings = detail::read_rings("join_holes", xy, n_points, ring_vertices, ring_offsets, n_rings);
    detail::Polygon poly;
    poly.xy = xy;
    poly.n_points = n_points;
    detail::orient_rings(poly, std::move(rings));
    detail::Joiner(poly, method).run();
    JoinedPolygon out;
    if (poly.start >= 0) {
        int p = poly.start;
        do {
            out.loop.push_back(poly.nodes[p].v);
            p = poly.nodes[p].next;
        } while (p != poly.start);
    }
    out.bridges = std::move(poly.bridges);
    out.skipped_rings = std::move(poly.skipped);
    std::sort(out.skipped_rings.begin(), out.skipped_rings.end());
    return out;
}

PolygonCheck check_polygon(const double* xy, std::size_t n_points, const std::int64_t* ring_vertices,
                           const std::int64_t* ring_offsets, std::size_t n_rings) {
    detail::Rings rings = detail::read_rings("check_polygon", xy, n_points, ring_vertices, ring_offsets, n_rings);
    return detail::check_rings(xy, rings.v);
}

}  // namespace faultmesh
