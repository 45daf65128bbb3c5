// Binding of the layer data placed in a fault patch (patch_data.hpp).
#include <faultmesh/patch_data.hpp>

#include <limits>
#include <string>

#include "common.hpp"

namespace faultmesh::bindings {

void bind_patch_data(py::module_& m) {
    m.attr("ON_OUTLINE") = kOnOutline;
    m.def(
        "insert_patch_data",
        [](const py::handle& vertices, const py::handle& triangles, const py::handle& points, double max_dz) {
            const char* fn = "insert_patch_data";
            // Private copies (common.hpp); the kernel checks the coordinate limit.
            DoubleArray V = as_points(vertices, fn, "vertices", 3, 3);
            IndexArray T = as_indices(triangles, fn, "triangles", 3, V.shape(0));
            DoubleArray P = as_points(points, fn, "points", 3, 3);
            PatchDataResult r;
            {
                py::gil_scoped_release release;
                r = insert_patch_data(V.data(), static_cast<std::size_t>(V.shape(0)), T.data(),
                                      static_cast<std::size_t>(T.shape(0)), P.data(),
                                      static_cast<std::size_t>(P.shape(0)), max_dz);
            }
            return py::make_tuple(to_numpy(std::move(r.vertices), 3), to_numpy(std::move(r.triangles), 3),
                                  to_numpy(std::move(r.placed)), to_numpy(std::move(r.triangle)));
        },
        py::arg("vertices"), py::arg("triangles"), py::arg("points"), py::kw_only(),
        py::arg("max_dz") = std::numeric_limits<double>::infinity(),
        "A layer's data (points (n, 3)) honoured inside a fault patch (vertices (k, 3),\n"
        "triangles (m, 3)): each datum whose XY lies strictly inside a triangle's XY projection\n"
        "(exact orient2d) becomes a vertex at its own elevation, in the triangle nearest to it\n"
        "in z among those (a folded patch has several sheets), if that is at most max_dz away.\n"
        "Each such triangle is triangulated again on its own (its edges constrained, the data\n"
        "flipped to a constrained Delaunay triangulation), in its own XY orientation; the\n"
        "other triangles are untouched. A datum within a hundredth of the triangle's height of\n"
        "one edge goes onto that edge at its projection, with the z that puts its sheet through\n"
        "it at its own XY, and every triangle with the edge is fanned through it; one within\n"
        "that of a datum placed before is not placed (it would make a sliver), and the corner\n"
        "nearest to one within that of two edges (or of one, by its end) takes the first such\n"
        "datum's z (its XY stays; triangle -1).\n\n"
        "Returns (vertices (k + p, 3), triangles (m + 2p or more, 3), placed int64 (p,) the\n"
        "datum of each new vertex, triangle int64 (n,) the input triangle each datum went into\n"
        "or -1).");
}

}  // namespace faultmesh::bindings
