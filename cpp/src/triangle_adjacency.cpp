// Opposite half-edges of a triangle list (see triangle_adjacency.hpp).
#include <faultmesh/errors.hpp>
#include <faultmesh/triangle_adjacency.hpp>

#include <algorithm>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>

namespace faultmesh {

namespace {

std::string vertex_name(const AdjacencyLabels& l, std::uint64_t v) {
    return std::to_string(l.vertex_ids ? l.vertex_ids[v] : static_cast<std::int64_t>(v));
}
std::string row_name(const AdjacencyLabels& l, std::uint64_t h) {
    const std::uint64_t t = h / 3;
    return std::to_string(l.row_ids ? l.row_ids[t] : static_cast<std::int64_t>(t));
}

}  // namespace

std::vector<std::int64_t> halfedge_twins(const std::int64_t* T, std::size_t m, std::size_t n,
                                         EdgeOrientation orientation, const std::string& fn,
                                         const AdjacencyLabels& labels) {
    constexpr std::uint64_t kLow = 0xffffffffULL;
    if (3 * static_cast<std::uint64_t>(m) > kLow || static_cast<std::uint64_t>(n) > kLow)
        throw std::invalid_argument(fn + ": the adjacency supports up to 1431655765 triangles and "
                                    "4294967295 vertices");
    const std::size_t nh = 3 * m;
    std::vector<std::int64_t> twin(nh, -1);
    if (nh == 0) return twin;
    // Counting sort of the half-edges by their smaller vertex; an entry packs
    // the larger vertex (high 32 bits) and the half-edge (low 32 bits), so a
    // bucket is scanned without touching the triangle array.
    std::vector<std::uint32_t> start(n + 2, 0);
    for (std::size_t h = 0; h < nh; ++h) {
        const auto a = static_cast<std::uint64_t>(T[h]);
        const auto b = static_cast<std::uint64_t>(T[static_cast<std::size_t>(next_halfedge(static_cast<std::int64_t>(h)))]);
        ++start[std::min(a, b) + 2];
    }
    for (std::size_t v = 0; v < n; ++v) start[v + 2] += start[v + 1];
    std::unique_ptr<std::uint64_t[]> ent(new std::uint64_t[nh]);
    for (std::size_t h = 0; h < nh; ++h) {
        const auto a = static_cast<std::uint64_t>(T[h]);
        const auto b = static_cast<std::uint64_t>(T[static_cast<std::size_t>(next_halfedge(static_cast<std::int64_t>(h)))]);
        ent[start[std::min(a, b) + 1]++] = (std::max(a, b) << 32) | h;
    }
    // start[v] .. start[v + 1] is now the bucket of vertex v.
    auto group = [&](std::uint64_t v, const std::uint64_t* g, std::size_t cnt) {
        if (cnt == 1) return;
        const std::uint64_t h = g[0] & kLow, o = g[0] >> 32;
        if (cnt > 2) {
            std::string rows;
            for (std::size_t i = 0; i < cnt; ++i) rows += (i ? ", " : "") + row_name(labels, g[i] & kLow);
            throw GeometryError(fn + ": " + labels.edge_word + " (" + vertex_name(labels, v) + ", " +
                                vertex_name(labels, o) + ") is used by " + std::to_string(cnt) +
                                " triangles (rows " + rows + "): the mesh is not a manifold");
        }
        const std::uint64_t k = g[1] & kLow;
        if (orientation == EdgeOrientation::consistent && T[h] == T[k]) {
            const std::uint64_t to = static_cast<std::uint64_t>(T[next_halfedge(static_cast<std::int64_t>(h))]);
            throw GeometryError(fn + ": " + labels.edge_word + " (" +
                                vertex_name(labels, static_cast<std::uint64_t>(T[h])) + ", " +
                                vertex_name(labels, to) + ") is used twice in the same direction (triangles " +
                                row_name(labels, h) + " and " + row_name(labels, k) +
                                "): inconsistent orientation");
        }
        twin[h] = static_cast<std::int64_t>(k);
        twin[k] = static_cast<std::int64_t>(h);
    };
    std::uint64_t scratch[32];
    for (std::size_t v = 0; v < n; ++v) {
        std::uint64_t* b = ent.get() + start[v];
        const std::size_t d = start[v + 1] - start[v];
        if (d > 32) {
            // A fan centre: sorted by (other vertex, half-edge), each run is one edge.
            std::sort(b, b + d);
            for (std::size_t i = 0; i < d;) {
                std::size_t j = i + 1;
                while (j < d && (b[j] >> 32) == (b[i] >> 32)) ++j;
                group(v, b + i, j - i);
                i = j;
            }
            continue;
        }
        // Small bucket: gather the entries of each other vertex in bucket
        // order (the half-edges in increasing order).
        std::uint32_t done = 0;  // bit i: entry i already grouped
        for (std::size_t i = 0; i < d; ++i) {
            if (done >> i & 1U) continue;
            const std::uint64_t o = b[i] >> 32;
            std::size_t cnt = 0;
            for (std::size_t j = i; j < d; ++j)
                if ((b[j] >> 32) == o) {
                    scratch[cnt++] = b[j];
                    done |= 1U << j;
                }
            group(v, scratch, cnt);
        }
    }
    return twin;
}

}  // namespace faultmesh
