// Points put back into a triangulated polygon (gap_points.hpp).
#include <faultmesh/gap_points.hpp>
#include <faultmesh/polygon_cdt.hpp>
#include <faultmesh/predicates.hpp>

#include "edge_key.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <unordered_set>

namespace faultmesh {

namespace {

using detail::undirected_edge_key;

// The triangle of `triangles` whose closed XY projection holds point p
// (exact orient2d): its row, and the orientation signs of p against its
// three edges; -1 when no triangle holds it.
std::ptrdiff_t locate(const double* xy, const std::vector<std::int64_t>& triangles, std::int64_t p, int o[3]) {
    const double* q = xy + 2 * p;
    for (std::size_t t = 0; t < triangles.size() / 3; ++t) {
        const std::int64_t* r = &triangles[3 * t];
        bool out = false;
        for (int k = 0; k < 3 && !out; ++k) {
            o[k] = orient2d_sign(xy + 2 * r[k], xy + 2 * r[(k + 1) % 3], q);
            out = o[k] < 0;
        }
        if (!out) return static_cast<std::ptrdiff_t>(t);
    }
    return -1;
}

// Point p becomes a vertex: 1 -> 3 split of the triangle holding it
// strictly, 2 -> 4 split of the two triangles sharing the (unconstrained)
// edge it lies on. False (nothing changed) when p lies outside, on a
// vertex, on a constrained edge or on a boundary edge.
bool insert_point(const double* xy, std::vector<std::int64_t>& triangles,
                  const std::unordered_set<std::uint64_t>& cons, std::int64_t p) {
    int o[3];
    const std::ptrdiff_t found = locate(xy, triangles, p, o);
    if (found < 0) return false;
    const std::size_t t = static_cast<std::size_t>(found), nt = triangles.size() / 3;
    const int zeros = (o[0] == 0) + (o[1] == 0) + (o[2] == 0);
    if (zeros >= 2) return false;  // on a vertex of t (another point at the same XY)
    std::int64_t* r = &triangles[3 * t];
    const std::int64_t a = r[0], b = r[1], c = r[2];
    if (zeros == 0) {  // strictly inside: (a, b, c) -> (a, b, p), (b, c, p), (c, a, p)
        r[2] = p;
        triangles.insert(triangles.end(), {b, c, p, c, a, p});
        return true;
    }
    // strictly inside edge k = (u, v) of t: split t and its neighbour across it
    const int k = o[0] == 0 ? 0 : (o[1] == 0 ? 1 : 2);
    const std::int64_t u = r[k], v = r[(k + 1) % 3], w = r[(k + 2) % 3];
    if (cons.count(undirected_edge_key(u, v))) return false;
    std::size_t nb = nt;
    int kb = 0;
    for (std::size_t s = 0; s < nt && nb == nt; ++s)
        for (int j = 0; j < 3; ++j)
            if (triangles[3 * s + j] == v && triangles[3 * s + (j + 1) % 3] == u) {
                nb = s;
                kb = j;
                break;
            }
    if (nb == nt) return false;  // a boundary edge that is not constrained: nothing beyond it
    const std::int64_t x = triangles[3 * nb + (kb + 2) % 3];
    // (u, v, w) -> (u, p, w), (p, v, w); (v, u, x) -> (v, p, x), (p, u, x)
    triangles[3 * t] = u; triangles[3 * t + 1] = p; triangles[3 * t + 2] = w;
    triangles[3 * nb] = v; triangles[3 * nb + 1] = p; triangles[3 * nb + 2] = x;
    triangles.insert(triangles.end(), {p, v, w, p, u, x});
    return true;
}

}  // namespace

std::vector<std::int64_t> insert_interior_points(const double* xy, std::size_t n_points,
                                                 std::vector<std::int64_t>& triangles,
                                                 const std::int64_t* constrained_edges, std::size_t n_constrained,
                                                 const std::int64_t* candidates, std::size_t n_candidates) {
    const char* fn = "insert_interior_points";
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

    std::unordered_set<std::uint64_t> cons;
    for (std::size_t i = 0; i < n_constrained; ++i)
        cons.insert(undirected_edge_key(constrained_edges[2 * i], constrained_edges[2 * i + 1]));
    std::unordered_set<std::int64_t> used(triangles.begin(), triangles.end());
    std::vector<std::int64_t> inserted;
    for (std::size_t ci = 0; ci < n_candidates; ++ci) {
        const std::int64_t p = candidates[ci];
        if (used.count(p) || !insert_point(xy, triangles, cons, p)) continue;
        used.insert(p);
        inserted.push_back(p);
    }
    if (!inserted.empty())
        flip_to_constrained_delaunay(xy, n_points, triangles, constrained_edges, n_constrained);
    return inserted;
}

}  // namespace faultmesh
