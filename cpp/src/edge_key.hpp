// One key per undirected edge of a triangulation (internal).
#pragma once

#include <cstdint>
#include <utility>

namespace faultmesh::detail {

// (smaller, larger) vertex index packed into 64 bits; callers check that
// vertex indices fit in 32 bits.
inline std::uint64_t undirected_edge_key(std::int64_t a, std::int64_t b) {
    if (a > b) std::swap(a, b);
    return (static_cast<std::uint64_t>(a) << 32) | static_cast<std::uint64_t>(b);
}

}  // namespace faultmesh::detail
