// Points put back into a triangulated polygon (gap_points.hpp).
#include <faultmesh/gap_points.hpp>
#include <faultmesh/polygon_cdt.hpp>
#include <faultmesh/predicates.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <unordered_set>

namespace faultmesh {

namespace {

inline std::uint64_t undirected_key(std::int64_t a, std::int64_t b) {
    if (a > b) std::swap(a, b);
    return (static_cast<std::uint64_t>(a) << 32) | static_cast<std::uint64_t>(b);
}

// Squared XY distance from p to the segment a-b (floating: it only decides
// the clearance, a quality threshold; containment is decided exactly).
double dist2_to_segment(const double* p, const double* a, const double* b) {
    const double dx = b[0] - a[0], dy = b[1] - a[1];
    const double l2 = dx * dx + dy * dy;
    double t = l2 > 0.0 ? ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2 : 0.0;
    t = std::clamp(t, 0.0, 1.0);
    const double ex = a[0] + t * dx - p[0], ey = a[1] + t * dy - p[1];
    return ex * ex + ey * ey;
}

}  // namespace

std::vector<std::int64_t> insert_interior_points(const double* xy, std::size_t n_points,
                                                 std::vector<std::int64_t>& triangles,
                                                 const std::int64_t* constrained_edges, std::size_t n_constrained,
                                                 const std::int64_t* candidates, std::size_t n_candidates,
                                                 double clearance) {
    const char* fn = "insert_interior_points";
    if (!(clearance >= 0.0) || !std::isfinite(clearance))
        throw std::invalid_argument(std::string(fn) + ": clearance must be finite and >= 0");
    if (n_points >= (std::size_t(1) << 32))
        throw std::invalid_argument(std::string(fn) + ": more than 2^32 points are not supported");
    auto check_index = [&](std::int64_t i, const char* what, std::size_t row) {
        if (i < 0 || static_cast<std::size_t>(i) >= n_points)
            throw std::invalid_argument(std::string(fn) + ": " + what + " row " + std::to_string(row) +
                                        " has index " + std::to_string(i) + " out of range [0, " +
                                        std::to_string(n_points) + ")");
    };
    if (triangles.size() % 3 != 0)
        throw std::invalid_argument(std::string(fn) + ": triangles must hold 3 indices per triangle");
    for (std::size_t i = 0; i < triangles.size(); ++i) check_index(triangles[i], "triangles", i / 3);
    for (std::size_t i = 0; i < 2 * n_constrained; ++i) check_index(constrained_edges[i], "constrained_edges", i / 2);
    for (std::size_t i = 0; i < n_candidates; ++i) check_index(candidates[i], "candidates", i);
    auto P = [&](std::int64_t i) { return xy + 2 * i; };

    std::unordered_set<std::uint64_t> cons;
    for (std::size_t i = 0; i < n_constrained; ++i)
        cons.insert(undirected_key(constrained_edges[2 * i], constrained_edges[2 * i + 1]));
    std::unordered_set<std::int64_t> used(triangles.begin(), triangles.end());
    const double c2 = clearance * clearance;
    std::vector<std::int64_t> inserted;
    for (std::size_t ci = 0; ci < n_candidates; ++ci) {
        const std::int64_t p = candidates[ci];
        if (used.count(p)) continue;
        const double* q = P(p);
        bool near = false;
        for (std::size_t e = 0; e < n_constrained && !near; ++e)
            near = dist2_to_segment(q, P(constrained_edges[2 * e]), P(constrained_edges[2 * e + 1])) <= c2;
        if (near) continue;
        const std::size_t nt = triangles.size() / 3;
        for (std::size_t t = 0; t < nt; ++t) {
            std::int64_t* r = &triangles[3 * t];
            int o[3], zeros = 0, neg = 0;
            for (int k = 0; k < 3; ++k) {
                o[k] = orient2d_sign(P(r[k]), P(r[(k + 1) % 3]), q);
                zeros += o[k] == 0;
                neg += o[k] < 0;
            }
            if (neg) continue;
            if (zeros >= 2) break;  // on a vertex of t (another point at the same XY): not inserted
            const std::int64_t a = r[0], b = r[1], c = r[2];
            if (zeros == 0) {  // strictly inside: (a, b, c) -> (a, b, p), (b, c, p), (c, a, p)
                r[2] = p;
                triangles.insert(triangles.end(), {b, c, p, c, a, p});
            } else {  // strictly inside edge k = (u, v) of t: split t and its neighbour across it
                const int k = o[0] == 0 ? 0 : (o[1] == 0 ? 1 : 2);
                const std::int64_t u = r[k], v = r[(k + 1) % 3], w = r[(k + 2) % 3];
                if (cons.count(undirected_key(u, v))) break;
                std::size_t nb = nt;
                int kb = 0;
                for (std::size_t s = 0; s < nt && nb == nt; ++s)
                    for (int j = 0; j < 3; ++j)
                        if (triangles[3 * s + j] == v && triangles[3 * s + (j + 1) % 3] == u) {
                            nb = s;
                            kb = j;
                            break;
                        }
                if (nb == nt) break;  // a boundary edge that is not constrained: nothing beyond it
                const std::int64_t x = triangles[3 * nb + (kb + 2) % 3];
                // (u, v, w) -> (u, p, w), (p, v, w); (v, u, x) -> (v, p, x), (p, u, x)
                triangles[3 * t] = u; triangles[3 * t + 1] = p; triangles[3 * t + 2] = w;
                triangles[3 * nb] = v; triangles[3 * nb + 1] = p; triangles[3 * nb + 2] = x;
                triangles.insert(triangles.end(), {p, v, w, p, u, x});
            }
            used.insert(p);
            inserted.push_back(p);
            break;
        }
    }
    if (!inserted.empty())
        flip_to_constrained_delaunay(xy, n_points, triangles, constrained_edges, n_constrained);
    return inserted;
}

}  // namespace faultmesh
