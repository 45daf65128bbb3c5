// A surface's elevations at points: see surface_sampling.hpp.
#include <faultmesh/aabb_tree.hpp>
#include <faultmesh/predicates.hpp>
#include <faultmesh/segments.hpp>
#include <faultmesh/surface_sampling.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "linear_interpolation.hpp"

namespace faultmesh {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

void check_mesh(const char* fn, const double* V, std::size_t nv, const std::int64_t* T, std::size_t m) {
    if ((V == nullptr && nv) || (T == nullptr && m)) throw std::invalid_argument(std::string(fn) + ": null array");
    for (std::size_t t = 0; t < m; ++t)
        for (int k = 0; k < 3; ++k) {
            const std::int64_t v = T[3 * t + static_cast<std::size_t>(k)];
            if (v < 0 || static_cast<std::size_t>(v) >= nv)
                throw std::invalid_argument(std::string(fn) + ": triangle " + std::to_string(t) + " has vertex index " +
                                            std::to_string(v) + " outside [0, " + std::to_string(nv) + ")");
            for (int c = 0; c < 3; ++c)
                if (!std::isfinite(V[3 * static_cast<std::size_t>(v) + static_cast<std::size_t>(c)]))
                    throw std::invalid_argument(std::string(fn) + ": vertex " + std::to_string(v) +
                                                " has a non-finite coordinate");
        }
}

// z of p in the non-degenerate triangle (a, b, c), or false if p is outside
// the closed triangle: the one linear interpolation of tin.cpp and cutting.cpp
// (linear_interpolation.hpp: exact containment and weights, a convex
// combination -- a corner's own z at a corner, an edge's two vertices on it,
// never outside the corners' range).
bool z_in_triangle(const double* p, const double* a, const double* b, const double* c, double& z) {
    z = detail::interpolate_in_triangle(a, b, c, p, a[2], b[2], c[2]);
    return z == z;  // the z are finite (check_mesh): NaN means outside
}

void add(SurfaceSamples& s, std::size_t i, double z) {
    if (s.hits[i] == 0) {
        s.z_low[i] = s.z_high[i] = z;
    } else {
        s.z_low[i] = std::min(s.z_low[i], z);
        s.z_high[i] = std::max(s.z_high[i], z);
    }
    ++s.hits[i];
}

}  // namespace

namespace {

// f(i, t, z) for every triangle t whose closed XY projection holds point i
// (x, y at pts + stride * i), with its z there; with reach > 0 also for every
// other triangle within reach (XY) of the point, with the z of its nearest
// edge at the point's projection on it.
template <class F>
void for_each_cover(const double* V, std::size_t nv, const std::int64_t* T, std::size_t m, const double* pts,
                    std::size_t stride, std::size_t n, double reach, F&& f) {
    if (m == 0 || n == 0) return;
    const AabbTree tree = AabbTree::from_triangles(V, nv, 3, T, m);
    std::vector<Box2> q(n);
    for (std::size_t i = 0; i < n; ++i) {
        const double* p = pts + stride * i;
        q[i] = {p[0] - reach, p[1] - reach, p[0] + reach, p[1] + reach};
    }
    const Csr hits = tree.query(q.data(), n, /*sorted=*/false);
    for (std::size_t i = 0; i < n; ++i) {
        const double* p = pts + stride * i;
        // A query beyond the coordinate limit (or NaN / inf) lies outside
        // every triangle (as for Tin.interpolate): NaN, 0 hits.
        if (!coordinate_in_range(p[0]) || !coordinate_in_range(p[1])) continue;
        for (std::int64_t j = hits.offsets[i]; j < hits.offsets[i + 1]; ++j) {
            const std::size_t t = static_cast<std::size_t>(hits.indices[static_cast<std::size_t>(j)]);
            const double* c3[3] = {V + 3 * T[3 * t], V + 3 * T[3 * t + 1], V + 3 * T[3 * t + 2]};
            if (orient2d(c3[0], c3[1], c3[2]) == 0.0) continue;
            double z;
            if (z_in_triangle(p, c3[0], c3[1], c3[2], z)) {
                f(i, t, z);
                continue;
            }
            if (reach == 0.0) continue;
            double best = reach * reach;  // squared
            z = kNaN;
            for (int k = 0; k < 3; ++k) {
                const double* a = c3[k];
                const double* b = c3[(k + 1) % 3];
                double u;
                const double d2 = segment_distance2(a, b, p, &u);
                if (d2 <= best) {
                    best = d2;
                    z = a[2] + u * (b[2] - a[2]);
                }
            }
            if (!std::isnan(z)) f(i, t, z);
        }
    }
}

}  // namespace

SurfaceSamples sample_surface(const double* V, std::size_t nv, const std::int64_t* T, std::size_t m,
                              const double* xy, std::size_t n) {
    check_mesh("sample_surface", V, nv, T, m);
    SurfaceSamples s{std::vector<double>(n, kNaN), std::vector<double>(n, kNaN), std::vector<std::int32_t>(n, 0)};
    for_each_cover(V, nv, T, m, xy, 2, n, 0.0, [&](std::size_t i, std::size_t, double z) { add(s, i, z); });
    return s;
}

NearestSheet nearest_sheet(const double* V, std::size_t nv, const std::int64_t* T, std::size_t m, const double* xyz,
                           std::size_t n, double reach) {
    check_mesh("nearest_sheet", V, nv, T, m);
    if (!(reach >= 0.0) || !std::isfinite(reach))
        throw std::invalid_argument("nearest_sheet: reach must be finite and >= 0, got " + std::to_string(reach));
    NearestSheet out{std::vector<double>(n, kNaN), std::vector<std::int64_t>(n, -1)};
    for_each_cover(V, nv, T, m, xyz, 3, n, reach, [&](std::size_t i, std::size_t t, double z) {
        const double zi = xyz[3 * i + 2], d = std::abs(z - zi), best = std::abs(out.z[i] - zi);
        // Ties (two triangles of a sheet at their shared edge): the lowest row.
        if (out.triangle[i] < 0 || d < best || (d == best && static_cast<std::int64_t>(t) < out.triangle[i])) {
            out.z[i] = z;
            out.triangle[i] = static_cast<std::int64_t>(t);
        }
    });
    return out;
}

SurfaceSamples sample_surface_grid(const double* V, std::size_t nv, const std::int64_t* T, std::size_t m,
                                   double x0, double y0, double hx, double hy, std::size_t nx, std::size_t ny) {
    check_mesh("sample_surface_grid", V, nv, T, m);
    if (!(hx > 0.0) || !(hy > 0.0) || !std::isfinite(hx) || !std::isfinite(hy) || !std::isfinite(x0) ||
        !std::isfinite(y0))
        throw std::invalid_argument("sample_surface_grid: the grid needs a finite origin and spacings > 0");
    // Every grid point within the coordinate limit of predicates.hpp.
    const double far[2] = {x0 + static_cast<double>(nx ? nx - 1 : 0) * hx, y0 + static_cast<double>(ny ? ny - 1 : 0) * hy};
    for (int k = 0; k < 2; ++k) {
        if (!coordinate_in_range(k ? y0 : x0)) throw_coordinate_error("sample_surface_grid", "origin", k, k ? y0 : x0);
        if (!coordinate_in_range(far[k]))
            throw_coordinate_error("sample_surface_grid", "the grid's last point (origin + (shape - 1) * spacing)", k,
                                   far[k]);
    }
    // At most 2^32 nodes: the three output arrays then take 80 GiB, more than
    // any machine this library runs on holds; a larger shape is a mistake
    // (and nx * ny could wrap around size_t, leaving arrays too short for
    // the loops below).
    constexpr std::size_t kMaxGridNodes = std::size_t{1} << 32;
    if (nx != 0 && ny > kMaxGridNodes / nx)
        throw std::invalid_argument("sample_surface_grid: shape (ny, nx) = (" + std::to_string(ny) + ", " +
                                    std::to_string(nx) + ") has more than 2^32 nodes");
    const std::size_t n = nx * ny;
    SurfaceSamples s{std::vector<double>(n, kNaN), std::vector<double>(n, kNaN), std::vector<std::int32_t>(n, 0)};
    auto first = [](double lo, double o, double h, std::size_t cnt) {
        const double u = std::ceil((lo - o) / h);
        return u <= 0.0 ? 0L : static_cast<long>(std::min(u, static_cast<double>(cnt)));
    };
    auto last = [](double hi, double o, double h, std::size_t cnt) {
        const double u = std::floor((hi - o) / h);
        return u < 0.0 ? -1L : static_cast<long>(std::min(u, static_cast<double>(cnt) - 1.0));
    };
    for (std::size_t t = 0; t < m; ++t) {
        const double* a = V + 3 * T[3 * t];
        const double* b = V + 3 * T[3 * t + 1];
        const double* c = V + 3 * T[3 * t + 2];
        const double o = orient2d(a, b, c);
        if (o == 0.0) continue;
        // Grid points of the triangle's box, widened by one point on each
        // side against rounding of the index computation (the exact test
        // decides).
        const long i0 = std::max(0L, first(std::min(a[0], std::min(b[0], c[0])), x0, hx, nx) - 1);
        const long i1 = std::min(static_cast<long>(nx) - 1, last(std::max(a[0], std::max(b[0], c[0])), x0, hx, nx) + 1);
        const long j0 = std::max(0L, first(std::min(a[1], std::min(b[1], c[1])), y0, hy, ny) - 1);
        const long j1 = std::min(static_cast<long>(ny) - 1, last(std::max(a[1], std::max(b[1], c[1])), y0, hy, ny) + 1);
        for (long j = j0; j <= j1; ++j)
            for (long i = i0; i <= i1; ++i) {
                const double p[2] = {x0 + static_cast<double>(i) * hx, y0 + static_cast<double>(j) * hy};
                double z;
                if (z_in_triangle(p, a, b, c, z)) add(s, static_cast<std::size_t>(j) * nx + static_cast<std::size_t>(i), z);
            }
    }
    return s;
}

}  // namespace faultmesh
