// Helpers shared by the C++ test files (header-only: the test binary globs
// cpp/tests/*.cpp, each includes what it uses).
#pragma once

#include <array>
#include <cstdint>
#include <set>
#include <vector>

namespace faultmesh::test {

using Tri = std::array<std::int64_t, 3>;

// Triangles (flat, 3 indices each) as a set, each rotated so that its
// smallest index comes first (orientation is kept): comparable whatever the
// order of the triangles and of their corners.
inline std::set<Tri> tri_set(const std::vector<std::int64_t>& t) {
    std::set<Tri> s;
    for (std::size_t i = 0; i + 2 < t.size(); i += 3) {
        Tri a{t[i], t[i + 1], t[i + 2]};
        while (a[0] > a[1] || a[0] > a[2]) a = {a[1], a[2], a[0]};
        s.insert(a);
    }
    return s;
}

}  // namespace faultmesh::test
