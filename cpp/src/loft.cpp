// Lofting between two polylines: FKU minimum-area DP and the greedy
// shortest-diagonal rule.
#include <faultmesh/loft.hpp>
#include <faultmesh/predicates.hpp>

#include <cmath>
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
};

Path min_area_path(const std::vector<P3>& A, const std::vector<P3>& B) {
    const std::size_t k = A.size(), l = B.size();
    Path path;
    if (k * l > (std::size_t{1} << 31))
        throw std::invalid_argument("loft: k * l too large for the min_area table (> 2^31); "
                                    "use method='shortest_diagonal'");
    // choice[i * l + j] = 1 if the best path into (i, j) advanced a.
    std::vector<unsigned char> choice(k * l, 0);
    std::vector<double> row(l);
    row[0] = 0.0;
    for (std::size_t j = 1; j < l; ++j) row[j] = row[j - 1] + tri_area(A[0], B[j], B[j - 1]);
    for (std::size_t i = 1; i < k; ++i) {
        // row holds costs of row i - 1; update in place left to right.
        row[0] = row[0] + tri_area(A[i - 1], A[i], B[0]);
        choice[i * l] = 1;
        for (std::size_t j = 1; j < l; ++j) {
            const double via_a = row[j] + tri_area(A[i - 1], A[i], B[j]);
            const double via_b = row[j - 1] + tri_area(A[i], B[j], B[j - 1]);
            if (via_a <= via_b) {
                row[j] = via_a;
                choice[i * l + j] = 1;
            } else {
                row[j] = via_b;
            }
        }
    }
    path.area = row[l - 1];
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
        else
            adv_a = dist2(A[i + 1], B[j]) <= dist2(A[i], B[j + 1]);
        if (adv_a) {
            path.area += tri_area(A[i], A[i + 1], B[j]);
            ++i;
        } else {
            path.area += tri_area(A[i], B[j + 1], B[j]);
            ++j;
        }
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
        const detail::Path p = min_area ? detail::min_area_path(A, B) : detail::shortest_diagonal_path(A, B);
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
        for (std::size_t s = 0; s < l; ++s) {
            unroll(B, k, s, UB, ib);
            detail::Path p = detail::min_area_path(UA, UB);
            if (p.area < best.area) {
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
