// Lawson flips to the constrained Delaunay triangulation (see polygon_cdt.hpp).
#include <faultmesh/polygon_cdt.hpp>
#include <faultmesh/predicates.hpp>

#include "edge_key.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace faultmesh {

namespace {

// Vertex indices are checked to fit in 32 bits (the edge keys).
using detail::undirected_edge_key;

struct Mesh {
    std::vector<std::int64_t>& tri;
    std::vector<std::int64_t> opp;  // opposite half-edge or -1
    std::vector<char> cons;         // half-edge lies on a constrained edge
};

// Half-edge h = 3t + k runs from tri[3t + k] to tri[3t + (k + 1) % 3].
inline std::int64_t he_next(std::int64_t h) { return h - h % 3 + (h % 3 + 1) % 3; }
inline std::int64_t he_prev(std::int64_t h) { return h - h % 3 + (h % 3 + 2) % 3; }

void check_inputs(const char* fn, const double* xy, std::size_t n_points, const std::vector<std::int64_t>& triangles,
                  const std::int64_t* constrained_edges, std::size_t n_constrained) {
    check_coordinates(xy, n_points, 2, 2, fn, "xy");
    if (n_points >= (std::size_t(1) << 32))
        throw std::invalid_argument(std::string(fn) + ": more than 2^32 points are not supported");
    if (triangles.size() % 3 != 0)
        throw std::invalid_argument(std::string(fn) + ": triangles must hold 3 indices per triangle");
    for (std::size_t i = 0; i < triangles.size(); ++i)
        if (triangles[i] < 0 || static_cast<std::size_t>(triangles[i]) >= n_points)
            throw std::invalid_argument(std::string(fn) + ": triangles row " + std::to_string(i / 3) +
                                        " has vertex index " + std::to_string(triangles[i]) +
                                        " out of range [0, " + std::to_string(n_points) + ")");
    for (std::size_t i = 0; i < 2 * n_constrained; ++i)
        if (constrained_edges[i] < 0 || static_cast<std::size_t>(constrained_edges[i]) >= n_points)
            throw std::invalid_argument(std::string(fn) + ": constrained_edges row " + std::to_string(i / 2) +
                                        " has vertex index " + std::to_string(constrained_edges[i]) +
                                        " out of range [0, " + std::to_string(n_points) + ")");
}

// Neighbours by sorting half-edges on their undirected key: exactly two
// half-edges of opposite direction make an interior edge; anything else (a
// boundary edge, or three or more uses of one edge in invalid input) is left
// unglued, i.e. treated as fixed.
void build_adjacency(Mesh& m, const std::int64_t* constrained_edges, std::size_t n_constrained) {
    const std::int64_t nh = static_cast<std::int64_t>(m.tri.size());
    m.opp.assign(nh, -1);
    m.cons.assign(nh, 0);
    std::vector<std::pair<std::uint64_t, std::int64_t>> keys(nh);
    for (std::int64_t h = 0; h < nh; ++h) keys[h] = {undirected_edge_key(m.tri[h], m.tri[he_next(h)]), h};
    std::sort(keys.begin(), keys.end());
    std::vector<std::uint64_t> ckeys(n_constrained);
    for (std::size_t i = 0; i < n_constrained; ++i)
        ckeys[i] = undirected_edge_key(constrained_edges[2 * i], constrained_edges[2 * i + 1]);
    std::sort(ckeys.begin(), ckeys.end());
    for (std::size_t i = 0; i < keys.size();) {
        std::size_t j = i;
        while (j < keys.size() && keys[j].first == keys[i].first) ++j;
        const bool constrained = std::binary_search(ckeys.begin(), ckeys.end(), keys[i].first);
        for (std::size_t k = i; k < j; ++k) m.cons[keys[k].second] = constrained;
        if (j - i == 2) {
            const std::int64_t h0 = keys[i].second, h1 = keys[i + 1].second;
            if (m.tri[h0] == m.tri[he_next(h1)] && m.tri[h1] == m.tri[he_next(h0)]) {
                m.opp[h0] = h1;
                m.opp[h1] = h0;
            }
        }
        i = j;
    }
}

// Is the interior edge of half-edge h (not constrained) not locally Delaunay?
inline bool needs_flip(const double* xy, const Mesh& m, std::int64_t h) {
    const std::int64_t g = m.opp[h];
    if (g < 0 || m.cons[h]) return false;
    const std::int64_t a = m.tri[h], b = m.tri[he_next(h)], c = m.tri[he_prev(h)];
    const std::int64_t d = m.tri[he_prev(g)];
    return incircle_perturbed(xy + 2 * a, xy + 2 * b, xy + 2 * c, xy + 2 * d) > 0;
}

}  // namespace

std::size_t flip_to_constrained_delaunay(const double* xy, std::size_t n_points,
                                         std::vector<std::int64_t>& triangles,
                                         const std::int64_t* constrained_edges,
                                         std::size_t n_constrained) {
    check_inputs("flip_to_constrained_delaunay", xy, n_points, triangles, constrained_edges, n_constrained);
    Mesh m{triangles, {}, {}};
    build_adjacency(m, constrained_edges, n_constrained);
    const std::int64_t nh = static_cast<std::int64_t>(triangles.size());
    std::vector<std::int64_t> stack;
    stack.reserve(nh / 2 + 16);
    for (std::int64_t h = 0; h < nh; ++h)
        if (m.opp[h] > h && !m.cons[h]) stack.push_back(h);

    // Each Lawson flip removes an edge that can never come back (the lifted
    // surface only moves down), so at most n(n-1)/2 flips happen for a valid
    // triangulation. The cap only guards against inconsistent input
    // (overlapping triangles of an invalid polygon) looping for ever.
    const std::size_t cap = n_points * (n_points > 0 ? n_points - 1 : 0) / 2 + 1;
    std::size_t flips = 0;
    while (!stack.empty() && flips < cap) {
        const std::int64_t h = stack.back();
        stack.pop_back();
        if (!needs_flip(xy, m, h)) continue;
        const std::int64_t g = m.opp[h];
        // Triangle t = (a, b, c) with h = a->b; triangle u = (b, a, d) with g = b->a.
        const std::int64_t t = h / 3, u = g / 3;
        const std::int64_t hb = he_next(h), hc = he_prev(h);  // b->c, c->a
        const std::int64_t ga = he_next(g), gd = he_prev(g);  // a->d, d->b
        const std::int64_t a = m.tri[h], b = m.tri[hb], c = m.tri[hc], d = m.tri[gd];
        // The quadrilateral a, d, b, c must be strictly convex for the new
        // diagonal c-d; with a non-Delaunay edge it always is in a valid
        // triangulation, this guards coincident points of invalid input.
        if (orient2d(xy + 2 * c, xy + 2 * a, xy + 2 * d) <= 0.0 ||
            orient2d(xy + 2 * d, xy + 2 * b, xy + 2 * c) <= 0.0)
            continue;
        // Outer half-edges and their flags before rewriting.
        const std::int64_t o_ca = m.opp[hc], o_ad = m.opp[ga], o_db = m.opp[gd], o_bc = m.opp[hb];
        const char c_ca = m.cons[hc], c_ad = m.cons[ga], c_db = m.cons[gd], c_bc = m.cons[hb];
        // New t = (c, a, d): edges c->a, a->d, d->c. New u = (d, b, c): d->b, b->c, c->d.
        const std::int64_t T = 3 * t, U = 3 * u;
        m.tri[T] = c; m.tri[T + 1] = a; m.tri[T + 2] = d;
        m.tri[U] = d; m.tri[U + 1] = b; m.tri[U + 2] = c;
        auto link = [&](std::int64_t he, std::int64_t o, char cflag) {
            m.opp[he] = o;
            m.cons[he] = cflag;
            if (o >= 0) m.opp[o] = he;
        };
        link(T, o_ca, c_ca);
        link(T + 1, o_ad, c_ad);
        link(U, o_db, c_db);
        link(U + 1, o_bc, c_bc);
        m.opp[T + 2] = U + 2;
        m.opp[U + 2] = T + 2;
        m.cons[T + 2] = m.cons[U + 2] = 0;
        ++flips;
        for (std::int64_t e : {T, T + 1, U, U + 1})
            if (m.opp[e] >= 0 && !m.cons[e]) stack.push_back(e);
    }
    return flips;
}

std::size_t count_non_delaunay_edges(const double* xy, std::size_t n_points,
                                     const std::vector<std::int64_t>& triangles,
                                     const std::int64_t* constrained_edges,
                                     std::size_t n_constrained) {
    check_inputs("count_non_delaunay_edges", xy, n_points, triangles, constrained_edges, n_constrained);
    std::vector<std::int64_t> copy = triangles;
    Mesh m{copy, {}, {}};
    build_adjacency(m, constrained_edges, n_constrained);
    std::size_t bad = 0;
    for (std::int64_t h = 0; h < static_cast<std::int64_t>(copy.size()); ++h)
        if (m.opp[h] > h && needs_flip(xy, m, h)) ++bad;
    return bad;
}

}  // namespace faultmesh
