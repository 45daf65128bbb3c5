// Bindings for sampling a surface: faultmesh.sample_surface, nearest_sheet, sample_surface_grid.
#include <faultmesh/surface_sampling.hpp>

#include "common.hpp"

namespace faultmesh::bindings {

namespace {
py::tuple samples_tuple(SurfaceSamples&& s) {
    return py::make_tuple(to_numpy(std::move(s.z_low)), to_numpy(std::move(s.z_high)), to_numpy(std::move(s.hits)));
}
}  // namespace

void bind_surface_sampling(py::module_& m) {
    m.def(
        "sample_surface",
        [](const py::handle& vertices, const py::handle& triangles, const py::handle& xy) {
            // Private copies (common.hpp); x, y of the vertices within the coordinate limit.
            auto V = as_coordinates(vertices, "sample_surface", "vertices", 3, 3, 2);
            auto T = as_indices(triangles, "sample_surface", "triangles", 3, V.shape(0));
            auto P = as_points(xy, "sample_surface", "xy", 2, 2);
            SurfaceSamples s;
            {
                py::gil_scoped_release release;
                s = sample_surface(V.data(), static_cast<std::size_t>(V.shape(0)), T.data(),
                                   static_cast<std::size_t>(T.shape(0)), P.data(), static_cast<std::size_t>(P.shape(0)));
            }
            return samples_tuple(std::move(s));
        },
        py::arg("vertices"), py::arg("triangles"), py::arg("xy"),
        "Elevations of a TIN at points xy (k, 2): (z_low, z_high, hits). Where a reverse fault\n"
        "folds the surface several triangles cover a point: z_low/z_high are the lowest/highest\n"
        "sheet; NaN and 0 hits where no triangle does (and for a NaN/inf query or one beyond\n"
        "1e60). Containment and weights come from the exact orient2d (surface_sampling.hpp).\n"
        "Vertices: x, y finite within |c| <= 1e60, z finite; triangles: non-negative integer\n"
        "indices below n (ValueError naming the argument and row otherwise).");
    m.def(
        "nearest_sheet",
        [](const py::handle& vertices, const py::handle& triangles, const py::handle& points, double reach) {
            auto V = as_coordinates(vertices, "nearest_sheet", "vertices", 3, 3, 2);
            auto T = as_indices(triangles, "nearest_sheet", "triangles", 3, V.shape(0));
            auto P = as_coordinates(points, "nearest_sheet", "points", 3, 3, 3);
            NearestSheet r;
            {
                py::gil_scoped_release release;
                r = nearest_sheet(V.data(), static_cast<std::size_t>(V.shape(0)), T.data(),
                                  static_cast<std::size_t>(T.shape(0)), P.data(), static_cast<std::size_t>(P.shape(0)),
                                  reach);
            }
            return py::make_tuple(to_numpy(std::move(r.z)), to_numpy(std::move(r.triangle)));
        },
        py::arg("vertices"), py::arg("triangles"), py::arg("points"), py::kw_only(), py::arg("reach") = 0.0,
        "The sheet of a TIN nearest to each of points (k, 3): (z, triangle). Of the triangles\n"
        "whose XY projection holds the point (exact orient2d, as sample_surface), the one whose\n"
        "z there is closest to the point's, and that z; -1 and NaN where none does. Where a\n"
        "reverse fault folds the surface, each of a hole's two tops of the layer is compared\n"
        "with its own sheet. reach (m, >= 0): a triangle within it of a point counts too, with\n"
        "its nearest edge's z (a datum placed on a patch outline lies a rounding off it).\n"
        "Points: finite, within |c| <= 1e60 (ValueError naming the row).");
    m.def(
        "sample_surface_grid",
        [](const py::handle& vertices, const py::handle& triangles, std::pair<double, double> origin,
           std::pair<double, double> spacing, std::pair<std::size_t, std::size_t> shape) {
            auto V = as_coordinates(vertices, "sample_surface_grid", "vertices", 3, 3, 2);
            auto T = as_indices(triangles, "sample_surface_grid", "triangles", 3, V.shape(0));
            SurfaceSamples s;
            {
                py::gil_scoped_release release;
                s = sample_surface_grid(V.data(), static_cast<std::size_t>(V.shape(0)), T.data(),
                                        static_cast<std::size_t>(T.shape(0)), origin.first, origin.second,
                                        spacing.first, spacing.second, shape.second, shape.first);
            }
            const py::ssize_t ny = static_cast<py::ssize_t>(shape.first), nx = static_cast<py::ssize_t>(shape.second);
            py::tuple out = samples_tuple(std::move(s));
            return py::make_tuple(out[0].attr("reshape")(ny, nx), out[1].attr("reshape")(ny, nx),
                                  out[2].attr("reshape")(ny, nx));
        },
        py::arg("vertices"), py::arg("triangles"), py::arg("origin"), py::arg("spacing"), py::arg("shape"),
        "sample_surface on the grid of points origin + (i * spacing[0], j * spacing[1]) for\n"
        "shape = (ny, nx): (z_low, z_high, hits), each (ny, nx) (row j, column i). Every grid\n"
        "point must lie within the coordinate limit 1e60.");
}

}  // namespace faultmesh::bindings
