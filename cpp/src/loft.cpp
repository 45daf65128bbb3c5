// Lofting between two polylines: FKU minimum-area DP and the greedy
// shortest-diagonal rule.
#include <faultmesh/loft.hpp>
#include <faultmesh/predicates.hpp>

#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

namespace faultmesh {

namespace detail {
namespace {

struct P3 {
    double x, y, z;
};

inline P3 sub(const P3& a, const P3& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline double tri_area(const P3& p, const P3& q, const P3& r) {
    const P3 u = sub(q, p), v = sub(r, p);
    const double cx = u.y * v.z - u.z * v.y, cy = u.z * v.x - u.x * v.z, cz = u.x * v.y - u.y * v.x;
    return 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz);
}
// A triangle of three distinct points that are collinear in 3D: zero area,
// which no loft may emit (the min-area DP would even prefer it, at cost 0).
// Exact: collinear in 3D iff its projections on the XY, YZ and ZX planes
// are all collinear. A repeated point is not counted: lofts between
// polylines that share a point (a pinch) make such triangles on purpose and
// their callers drop them.
inline bool zero_area(const P3& p, const P3& q, const P3& r) {
    auto same = [](const P3& u, const P3& v) { return u.x == v.x && u.y == v.y && u.z == v.z; };
    if (same(p, q) || same(q, r) || same(r, p)) return false;
    const double xy[3][2] = {{p.x, p.y}, {q.x, q.y}, {r.x, r.y}};
    if (orient2d(xy[0], xy[1], xy[2]) != 0.0) return false;
    const double yz[3][2] = {{p.y, p.z}, {q.y, q.z}, {r.y, r.z}};
    if (orient2d(yz[0], yz[1], yz[2]) != 0.0) return false;
    const double zx[3][2] = {{p.z, p.x}, {q.z, q.x}, {r.z, r.x}};
    return orient2d(zx[0], zx[1], zx[2]) == 0.0;
}

// The cost of a loft path: its zero-area triangles first (fewest wins; a
// path without one exists unless the polylines leave no other choice, e.g.
// all on one line), then its area.
struct Cost {
    std::int64_t zero = 0;
    double area = 0.0;
    bool operator<=(const Cost& o) const { return zero < o.zero || (zero == o.zero && area <= o.area); }
    bool operator<(const Cost& o) const { return zero < o.zero || (zero == o.zero && area < o.area); }
};
struct P3s {
    P3 p, q, r;
};
inline Cost operator+(const Cost& c, const P3s& t) {
    return {c.zero + (zero_area(t.p, t.q, t.r) ? 1 : 0), c.area + tri_area(t.p, t.q, t.r)};
}

inline double dist2(const P3& p, const P3& q) {
    const P3 d = sub(p, q);
    return d.x * d.x + d.y * d.y + d.z * d.z;
}

std::vector<P3> read_points(const char* side, const double* p, std::size_t n, std::size_t stride) {
    std::vector<P3> out(n);
    for (std::size_t i = 0; i < n; ++i) {
        const double* q = p + stride * i;
        out[i] = {q[0], q[1], stride == 3 ? q[2] : 0.0};
        // z enters the 3D areas and lengths too: all coordinates are checked.
        const double c[3] = {out[i].x, out[i].y, out[i].z};
        for (int k = 0; k < 3; ++k)
            if (!coordinate_in_range(c[k])) throw_coordinate_error("loft", std::string(side) + " row " + std::to_string(i), k, c[k]);
    }
    return out;
}

// Open loft of A (ka points) and B (kb points). Emits triangles through
// `emit(i_a_or_-1...)`: each step is either "advance a" from rung (i, j) to
// (i+1, j): triangle (A[i], A[i+1], B[j]), or "advance b": (A[i], B[j+1], B[j]).
// Returns the path as a string of steps ('a' / 'b') and its total area.
struct Path {
    std::vector<char> steps;  // 1 = advance a, 0 = advance b
    double area = 0.0;
    std::int64_t zero = 0;  // zero-area triangles on the path
    Cost cost() const { return {zero, area}; }
};

Path min_area_path(const std::vector<P3>& A, const std::vector<P3>& B) {
    const std::size_t k = A.size(), l = B.size();
    Path path;
    if (k * l > (std::size_t{1} << 31))
        throw std::invalid_argument("loft: k * l too large for the min_area table (> 2^31); "
                                    "use method='shortest_diagonal'");
    // choice[i * l + j] = 1 if the best path into (i, j) advanced a.
    std::vector<unsigned char> choice(k * l, 0);
    std::vector<Cost> row(l);
    row[0] = Cost{};
    for (std::size_t j = 1; j < l; ++j) row[j] = row[j - 1] + P3s{A[0], B[j], B[j - 1]};
    for (std::size_t i = 1; i < k; ++i) {
        // row holds costs of row i - 1; update in place left to right.
        row[0] = row[0] + P3s{A[i - 1], A[i], B[0]};
        choice[i * l] = 1;
        for (std::size_t j = 1; j < l; ++j) {
            const Cost via_a = row[j] + P3s{A[i - 1], A[i], B[j]};
            const Cost via_b = row[j - 1] + P3s{A[i], B[j], B[j - 1]};
            if (via_a <= via_b) {
                row[j] = via_a;
                choice[i * l + j] = 1;
            } else {
                row[j] = via_b;
            }
        }
    }
    path.area = row[l - 1].area;
    path.zero = row[l - 1].zero;
    path.steps.resize(k + l - 2);
    std::size_t i = k - 1, j = l - 1, s = k + l - 2;
    while (s > 0) {
        const bool a = choice[i * l + j] != 0;
        path.steps[--s] = a ? 1 : 0;
        if (a)
            --i;
        else
            --j;
    }
    return path;
}

Path shortest_diagonal_path(const std::vector<P3>& A, const std::vector<P3>& B) {
    const std::size_t k = A.size(), l = B.size();
    Path path;
    path.steps.reserve(k + l - 2);
    std::size_t i = 0, j = 0;
    while (i + 1 < k || j + 1 < l) {
        bool adv_a;
        if (i + 1 == k)
            adv_a = false;
        else if (j + 1 == l)
            adv_a = true;
        else {
            // The shorter diagonal, unless its triangle has zero area and
            // the other's has not.
            const bool za = zero_area(A[i], A[i + 1], B[j]), zb = zero_area(A[i], B[j + 1], B[j]);
            adv_a = za != zb ? zb : dist2(A[i + 1], B[j]) <= dist2(A[i], B[j + 1]);
        }
        const P3s t = adv_a ? P3s{A[i], A[i + 1], B[j]} : P3s{A[i], B[j + 1], B[j]};
        path.area += tri_area(t.p, t.q, t.r);
        path.zero += zero_area(t.p, t.q, t.r) ? 1 : 0;
        if (adv_a)
            ++i;
        else
            ++j;
        path.steps.push_back(adv_a ? 1 : 0);
    }
    return path;
}

// Triangles of a path; ia / ib map positions in A / B to output indices.
void emit(const Path& p, const std::vector<std::int64_t>& ia, const std::vector<std::int64_t>& ib,
          std::vector<std::int64_t>& out) {
    std::size_t i = 0, j = 0;
    for (char s : p.steps) {
        if (s) {
            out.insert(out.end(), {ia[i], ia[i + 1], ib[j]});
            ++i;
        } else {
            out.insert(out.end(), {ia[i], ib[j + 1], ib[j]});
            ++j;
        }
    }
}

}  // namespace
}  // namespace detail

std::vector<std::int64_t> loft(const double* a, std::size_t k, const double* b, std::size_t l,
                               std::size_t stride, const LoftOptions& options) {
    if (stride != 2 && stride != 3) throw std::invalid_argument("loft: points must have 2 or 3 columns");
    if (k == 0 || l == 0)
        throw std::invalid_argument(std::string("loft: polyline ") + (k == 0 ? "a" : "b") +
                                    " has no points");
    const std::vector<detail::P3> A = detail::read_points("a", a, k, stride);
    const std::vector<detail::P3> B = detail::read_points("b", b, l, stride);
    const bool min_area = options.method == LoftMethod::min_area;
    std::vector<std::int64_t> out;

    if (!options.closed) {
        std::vector<std::int64_t> ia(k), ib(l);
        for (std::size_t i = 0; i < k; ++i) ia[i] = static_cast<std::int64_t>(i);
        for (std::size_t j = 0; j < l; ++j) ib[j] = static_cast<std::int64_t>(k + j);
        detail::Path p = min_area ? detail::min_area_path(A, B) : detail::shortest_diagonal_path(A, B);
        if (p.zero > 0 && !min_area && k * l <= (std::size_t{1} << 31)) {
            // The greedy rule is forced onto zero-area triangles once it has
            // walked one polyline to its end (b ending on a's straight tail);
            // the min-area path avoids them wherever a path can.
            detail::Path q = detail::min_area_path(A, B);
            if (q.zero < p.zero) p = std::move(q);
        }
        out.reserve(3 * (k + l - 2));
        detail::emit(p, ia, ib, out);
        return out;
    }

    if (k == 2 || l == 2)
        throw std::invalid_argument(std::string("loft: closed contour ") + (k == 2 ? "a" : "b") +
                                    " has 2 points; a closed contour needs 1 (a tip) or >= 3");
    // Unroll: a0 .. a_{k-1}, a0 and b_s .. b_{s+l-1}, b_s; a single point is
    // not repeated (fan).
    auto unroll = [](const std::vector<detail::P3>& P, std::size_t off, std::size_t s,
                     std::vector<detail::P3>& Q, std::vector<std::int64_t>& idx) {
        const std::size_t n = P.size();
        Q.clear();
        idx.clear();
        const std::size_t len = n == 1 ? 1 : n + 1;
        for (std::size_t t = 0; t < len; ++t) {
            const std::size_t p = (s + t) % n;
            Q.push_back(P[p]);
            idx.push_back(static_cast<std::int64_t>(off + p));
        }
    };
    std::vector<detail::P3> UA, UB;
    std::vector<std::int64_t> ia, ib;
    unroll(A, 0, 0, UA, ia);
    std::size_t best_s = 0;
    detail::Path best;
    if (l == 1 || k == 1 || !min_area) {
        if (!min_area && l > 1 && k > 1) {
            double bd = std::numeric_limits<double>::infinity();
            for (std::size_t s = 0; s < l; ++s) {
                const double d = detail::dist2(A[0], B[s]);
                if (d < bd) {
                    bd = d;
                    best_s = s;
                }
            }
        }
        unroll(B, k, best_s, UB, ib);
        best = min_area ? detail::min_area_path(UA, UB) : detail::shortest_diagonal_path(UA, UB);
    } else {
        // FKU multiple start: a0 is matched to every b_s in turn.
        best.area = std::numeric_limits<double>::infinity();
        best.zero = std::numeric_limits<std::int64_t>::max();
        for (std::size_t s = 0; s < l; ++s) {
            unroll(B, k, s, UB, ib);
            detail::Path p = detail::min_area_path(UA, UB);
            if (p.cost() < best.cost()) {
                best = std::move(p);
                best_s = s;
            }
        }
        unroll(B, k, best_s, UB, ib);
    }
    detail::emit(best, ia, ib, out);
    return out;
}

double loft_area(const double* a, std::size_t k, const double* b, std::size_t l, std::size_t stride,
                 const std::vector<std::int64_t>& triangles) {
    if (stride != 2 && stride != 3) throw std::invalid_argument("loft_area: points must have 2 or 3 columns");
    auto pt = [&](std::int64_t i) -> detail::P3 {
        if (i < 0 || static_cast<std::size_t>(i) >= k + l)
            throw std::invalid_argument("loft_area: index " + std::to_string(i) + " out of range");
        const double* q = static_cast<std::size_t>(i) < k ? a + stride * static_cast<std::size_t>(i)
                                                          : b + stride * (static_cast<std::size_t>(i) - k);
        return {q[0], q[1], stride == 3 ? q[2] : 0.0};
    };
    double s = 0.0;
    for (std::size_t t = 0; t + 2 < triangles.size(); t += 3)
        s += detail::tri_area(pt(triangles[t]), pt(triangles[t + 1]), pt(triangles[t + 2]));
    return s;
}

}  // namespace faultmesh
