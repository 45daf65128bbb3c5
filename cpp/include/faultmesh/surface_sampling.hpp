// faultmesh/surface_sampling.hpp -- a triangulated surface's elevations at
// points in XY: the evaluation of a model against data or a ground truth
// (accuracy grids, held-out picks, ensemble samples, a model's fit to its
// own data).
//
// A point is covered by every triangle whose closed XY projection holds it
// (exact orient2d); a triangle with zero XY area (a vertical piece of a fault
// strip) carries no elevation. Within a triangle z is the convex combination
// of its corners' z with the weights orient2d(p, b, c), orient2d(a, p, c),
// orient2d(a, b, p) over their sum: exact at the corners, only the two ends
// count on an edge, never outside the corners' range, never NaN.
//
// Where a surface folds (a reverse fault's repetition band: footwall, fault
// strip and hanging wall over the same XY) several triangles cover a point;
// z_low / z_high are the lowest / highest of their values and `hits` counts
// them (a point on an edge shared by two triangles counts twice, with the
// same value). Points no triangle covers get NaN and 0 hits.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace faultmesh {

struct SurfaceSamples {
    std::vector<double> z_low, z_high;
    std::vector<std::int32_t> hits;
};

// At n points (x, y interleaved). vertices: n_vertices x (x, y, z);
// triangles: n_triangles x 3. Throws std::invalid_argument for an index out
// of range or a non-finite coordinate of a used vertex.
SurfaceSamples sample_surface(const double* vertices, std::size_t n_vertices, const std::int64_t* triangles,
                              std::size_t n_triangles, const double* xy, std::size_t n);

// The sheet nearest to each of n points (x, y, z interleaved): of the
// triangles that cover the point's XY, the one whose z there is closest to
// its z, and that z (-1 and NaN where none does; of equals the lowest row). A
// datum's distance to a folded layer: a hole's two tops of a layer that a
// reverse fault repeats lie each on its own sheet, and the fault strip
// between them is a third.
struct NearestSheet {
    std::vector<double> z;
    std::vector<std::int64_t> triangle;
};
// reach (m, XY, >= 0): a triangle within this distance of the point counts
// as covering it, with the z of its nearest edge there -- a datum placed on
// a patch's outline lies a rounding off it (patch_data.hpp).
NearestSheet nearest_sheet(const double* vertices, std::size_t n_vertices, const std::int64_t* triangles,
                           std::size_t n_triangles, const double* xyz, std::size_t n, double reach = 0.0);

// On the regular grid of nx x ny points (x0 + i hx, y0 + j hy), i fastest:
// each triangle visits the grid points of its box, so the cost is about the
// number of triangles plus the covered samples.
SurfaceSamples sample_surface_grid(const double* vertices, std::size_t n_vertices,
                                   const std::int64_t* triangles, std::size_t n_triangles, double x0,
                                   double y0, double hx, double hy, std::size_t nx, std::size_t ny);

}  // namespace faultmesh
