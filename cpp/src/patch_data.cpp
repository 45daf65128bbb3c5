// A layer's data honoured inside a fault patch (patch_data.hpp).
#include <faultmesh/aabb_tree.hpp>
#include <faultmesh/gap_points.hpp>
#include <faultmesh/patch_data.hpp>
#include <faultmesh/predicates.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>

namespace faultmesh {

namespace {

// A datum is placed only where each of its barycentric coordinates in the
// triangle is at least this share (it lies at least this share of the
// triangle's height from every edge), and at least this share of the
// triangle's shortest height from every datum placed in it before. Nearer,
// it would make a sliver: data on the study-area boundary lie a rounding
// (1e-10 m) inside a patch triangle whose edge runs along it, and the
// stitcher's coverage test, at the sliver's rounded centroid, then finds it
// outside its own patch (random grounds as v2 with section picks, seeds 0
// and 4: "the patch does not cover its XY image once"). A share of a
// hundredth loses only data within a hundredth of a loft triangle's height
// (metres at most) of the polylines or of another datum, where the patch
// already passes within that distance.
constexpr double kMinShare = 0.01;

}  // namespace

PatchDataResult insert_patch_data(const double* vertices, std::size_t n_vertices,
                                  const std::int64_t* triangles, std::size_t n_triangles,
                                  const double* points, std::size_t n_points, double max_dz) {
    const char* fn = "insert_patch_data";
    if (!(max_dz >= 0.0))
        throw std::invalid_argument(std::string(fn) + ": max_dz must be >= 0 (or inf), got " +
                                    std::to_string(max_dz));
    check_coordinates(vertices, n_vertices, 3, 3, fn, "vertices");
    check_coordinates(points, n_points, 3, 3, fn, "points");
    for (std::size_t t = 0; t < 3 * n_triangles; ++t)
        if (triangles[t] < 0 || static_cast<std::size_t>(triangles[t]) >= n_vertices)
            throw std::invalid_argument(std::string(fn) + ": triangles row " + std::to_string(t / 3) +
                                        " has vertex index " + std::to_string(triangles[t]) +
                                        " out of range [0, " + std::to_string(n_vertices) + ")");
    PatchDataResult out;
    out.vertices.assign(vertices, vertices + 3 * n_vertices);
    out.triangles.assign(triangles, triangles + 3 * n_triangles);
    out.triangle.assign(n_points, -1);
    if (n_triangles == 0 || n_points == 0) return out;

    auto P = [&](std::int64_t v) { return vertices + 3 * v; };
    // XY orientation of each triangle (exact); 0 for one that is a segment
    // or a point in XY (a vertical strip triangle holds no datum).
    std::vector<double> orient(n_triangles);
    for (std::size_t t = 0; t < n_triangles; ++t) {
        const std::int64_t* r = triangles + 3 * t;
        orient[t] = orient2d(P(r[0]), P(r[1]), P(r[2]));
    }
    const AabbTree tree = AabbTree::from_triangles(vertices, n_vertices, 3, triangles, n_triangles);

    // Each datum's triangle: strictly inside in XY, nearest in z.
    std::map<std::int64_t, std::vector<std::int64_t>> by_triangle;  // ascending rows: deterministic
    for (std::size_t i = 0; i < n_points; ++i) {
        const double* q = points + 3 * i;
        const Box2 box{q[0], q[1], q[0], q[1]};
        std::int64_t best = -1;
        double best_dz = std::numeric_limits<double>::infinity();
        tree.visit(box, [&](std::int64_t t) {
            const double o = orient[static_cast<std::size_t>(t)];
            if (o == 0.0) return;
            const std::int64_t* r = triangles + 3 * t;
            double w[3];
            for (int k = 0; k < 3; ++k) {
                w[k] = orient2d(P(r[(k + 1) % 3]), P(r[(k + 2) % 3]), q);
                if (w[k] == 0.0 || (w[k] > 0.0) != (o > 0.0)) return;  // outside or on an edge
                if (w[k] / o < kMinShare) return;                       // too near an edge
            }
            // The decision above is exact; z is the plane's value (rounded).
            const double z = (w[0] * P(r[0])[2] + w[1] * P(r[1])[2] + w[2] * P(r[2])[2]) / (w[0] + w[1] + w[2]);
            const double dz = std::fabs(z - q[2]);
            if (dz < best_dz || (dz == best_dz && t < best)) {
                best_dz = dz;
                best = t;
            }
        });
        if (best >= 0 && best_dz <= max_dz) by_triangle[best].push_back(static_cast<std::int64_t>(i));
    }

    for (const auto& [t, data] : by_triangle) {
        const std::int64_t* r = triangles + 3 * t;
        // Local numbering: the triangle counter-clockwise (0, 1, 2), then the data.
        const bool ccw = orient[static_cast<std::size_t>(t)] > 0.0;
        const std::int64_t corner[3] = {r[0], ccw ? r[1] : r[2], ccw ? r[2] : r[1]};
        std::vector<double> xy;
        xy.reserve(2 * (3 + data.size()));
        for (std::int64_t c : corner) xy.insert(xy.end(), {P(c)[0], P(c)[1]});
        // The shortest height: twice the area over the longest edge.
        double longest = 0.0;
        for (int k = 0; k < 3; ++k)
            longest = std::max(longest, std::hypot(xy[2 * ((k + 1) % 3)] - xy[2 * k],
                                                   xy[2 * ((k + 1) % 3) + 1] - xy[2 * k + 1]));
        const double min_gap = kMinShare * std::fabs(orient[static_cast<std::size_t>(t)]) / longest;
        std::vector<std::int64_t> cand, datum_of(3, -1);  // datum_of: local vertex -> datum row
        for (std::size_t j = 0; j < data.size(); ++j) {
            const double* q = points + 3 * data[j];
            bool near = false;
            for (std::size_t c = 3; c < xy.size() / 2 && !near; ++c)
                near = std::hypot(xy[2 * c] - q[0], xy[2 * c + 1] - q[1]) < min_gap;
            if (near) continue;
            datum_of.resize(xy.size() / 2, -1);
            datum_of.push_back(data[j]);
            xy.insert(xy.end(), {q[0], q[1]});
            cand.push_back(static_cast<std::int64_t>(xy.size() / 2 - 1));
        }
        std::vector<std::int64_t> local{0, 1, 2};
        const std::int64_t cons[6] = {0, 1, 1, 2, 2, 0};
        const std::vector<std::int64_t> got =
            insert_interior_points(xy.data(), xy.size() / 2, local, cons, 3, cand.data(), cand.size());
        // Global numbers of the local vertices.
        std::vector<std::int64_t> global(xy.size() / 2, -1);
        for (int k = 0; k < 3; ++k) global[static_cast<std::size_t>(k)] = corner[k];
        for (std::int64_t g : got) {
            const std::int64_t d = datum_of[static_cast<std::size_t>(g)];
            global[static_cast<std::size_t>(g)] = static_cast<std::int64_t>(out.vertices.size() / 3);
            out.vertices.insert(out.vertices.end(), points + 3 * d, points + 3 * d + 3);
            out.placed.push_back(d);
            out.triangle[static_cast<std::size_t>(d)] = t;
        }
        // The first new triangle takes the old one's row, the others go last;
        // each in the old one's orientation.
        for (std::size_t k = 0; k < local.size() / 3; ++k) {
            std::int64_t a = global[static_cast<std::size_t>(local[3 * k])];
            std::int64_t b = global[static_cast<std::size_t>(local[3 * k + 1])];
            std::int64_t c = global[static_cast<std::size_t>(local[3 * k + 2])];
            if (!ccw) std::swap(b, c);
            if (k == 0) {
                std::int64_t* row = &out.triangles[3 * static_cast<std::size_t>(t)];
                row[0] = a;
                row[1] = b;
                row[2] = c;
            } else {
                out.triangles.insert(out.triangles.end(), {a, b, c});
            }
        }
    }
    return out;
}

}  // namespace faultmesh
