// Helpers shared by the C++ test files (header-only: the test binary globs
// cpp/tests/*.cpp, each includes what it uses).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <random>
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

// Four points of small integers drawn by U, and the same points times
// `scale` as doubles (exact: the integers need few bits): the tiny-coordinate
// tests compare a predicate on D with the integer determinant of P.
template <std::size_t Dim>
void scaled_integer_points(std::mt19937_64& rng, std::uniform_int_distribution<long long>& U, double scale,
                           long long (&P)[4][Dim], double (&D)[4][Dim]) {
    for (std::size_t i = 0; i < 4; ++i)
        for (std::size_t k = 0; k < Dim; ++k) {
            P[i][k] = U(rng);
            D[i][k] = static_cast<double>(P[i][k]) * scale;
        }
}

}  // namespace faultmesh::test
