// Binding of the fault side test (fault_side.hpp).
#include <faultmesh/fault_side.hpp>

#include "common.hpp"

namespace faultmesh::bindings {

namespace {

std::vector<std::uint8_t> as_extent(const py::object& extent, std::size_t nt, const char* fn) {
    std::vector<std::uint8_t> E;
    if (!extent.is_none()) {
        auto e = py::array_t<bool, py::array::c_style | py::array::forcecast>::ensure(extent);
        if (!e || e.ndim() != 1 || static_cast<std::size_t>(e.shape(0)) != nt)
            throw std::invalid_argument(std::string(fn) + ": extent must be a bool array of shape (" +
                                        std::to_string(nt) + ",), one per triangle");
        E.assign(e.data(), e.data() + nt);
    }
    return E;
}

py::tuple result_to_py(FaultSideResult&& r) {
    return py::make_tuple(to_numpy(std::move(r.side)), to_numpy(std::move(r.extended)),
                          to_numpy(std::move(r.triangle)), to_numpy(std::move(r.located)).attr("astype")("bool"));
}

}  // namespace

void bind_fault_side(py::module_& m) {
    m.attr("HANGING_WALL") = static_cast<int>(kHangingWall);
    m.attr("FOOTWALL") = static_cast<int>(kFootwall);
    m.attr("ON_FAULT") = static_cast<int>(kOnFault);
    m.attr("BEYOND_FAULT") = static_cast<int>(kBeyondFault);
    m.def(
        "fault_side",
        [](const py::handle& vertices, const py::handle& triangles, const py::handle& points, int axis,
           int hanging_sign, const py::object& extent) {
            const char* fn = "fault_side";
            // Private copies (common.hpp); fault_side checks the coordinate limit.
            DoubleArray V = as_points(vertices, fn, "vertices", 3, 3);
            IndexArray T = as_indices(triangles, fn, "triangles", 3, V.shape(0));
            DoubleArray P = as_points(points, fn, "points", 3, 3);
            const std::size_t nv = static_cast<std::size_t>(V.shape(0));
            const std::size_t nt = static_cast<std::size_t>(T.shape(0));
            const std::size_t np = static_cast<std::size_t>(P.shape(0));
            const std::vector<std::uint8_t> E = as_extent(extent, nt, fn);
            FaultSideResult r;
            {
                py::gil_scoped_release release;
                r = fault_side(V.data(), nv, T.data(), nt, P.data(), np, axis, hanging_sign,
                               E.empty() ? nullptr : E.data());
            }
            return result_to_py(std::move(r));
        },
        py::arg("vertices"), py::arg("triangles"), py::arg("points"), py::kw_only(), py::arg("axis") = 2,
        py::arg("hanging_sign") = 1, py::arg("extent") = py::none(),
        "Side of each point (n, 3) relative to a fault TIN (vertices (k, 3), triangles (m, 3))\n"
        "that is a function over the plane of the other two axes when projected along `axis`\n"
        "(0 = x, 1 = y, 2 = z). Exact: location by orient2d on the projected (copied)\n"
        "coordinates, side by orient3d against the located triangle.\n\n"
        "hanging_sign: +1 if the hanging wall is the +axis side (+1 for axis 2: the block\n"
        "above the fault). extent: optional bool (m,), triangles inside the fault's extent.\n\n"
        "Returns (side, extended, triangle, located): side int8 (n,) is HANGING_WALL (+1),\n"
        "FOOTWALL (-1), ON_FAULT (0) or BEYOND_FAULT (2: in no triangle, or in one outside\n"
        "`extent`); extended int8 (n,) the side relative to the surface continued past its\n"
        "edges (the located triangle's plane, or that of the triangle owning the nearest\n"
        "boundary edge); triangle int64 (n,) the triangle that decided it; located bool (n,).");

    // The same test set up once for many queries (the tree over the fault's
    // triangles built in the constructor, from private copies).
    py::class_<FaultSide>(m, "FaultSide",
                          "A fault TIN set up once for fault_side queries (projection, AABB tree,\n"
                          "boundary edges; its own copies of the arrays). sides(points) returns what\n"
                          "fault_side(vertices, triangles, points, ...) returns.")
        .def(py::init([](const py::handle& vertices, const py::handle& triangles, int axis, int hanging_sign,
                         const py::object& extent) {
                 const char* fn = "FaultSide";
                 DoubleArray V = as_points(vertices, fn, "vertices", 3, 3);
                 IndexArray T = as_indices(triangles, fn, "triangles", 3, V.shape(0));
                 const std::size_t nt = static_cast<std::size_t>(T.shape(0));
                 const std::vector<std::uint8_t> E = as_extent(extent, nt, fn);
                 py::gil_scoped_release release;
                 return std::make_unique<FaultSide>(V.data(), static_cast<std::size_t>(V.shape(0)), T.data(), nt,
                                                    axis, hanging_sign, E.empty() ? nullptr : E.data());
             }),
             py::arg("vertices"), py::arg("triangles"), py::kw_only(), py::arg("axis") = 2,
             py::arg("hanging_sign") = 1, py::arg("extent") = py::none())
        .def(
            "sides",
            [](const FaultSide& f, const py::handle& points) {
                DoubleArray P = as_points(points, "FaultSide.sides", "points", 3, 3);
                FaultSideResult r;
                {
                    py::gil_scoped_release release;
                    r = f.sides(P.data(), static_cast<std::size_t>(P.shape(0)));
                }
                return result_to_py(std::move(r));
            },
            py::arg("points"),
            "(side, extended, triangle, located) of each point (n, 3), as fault_side.")
        .def_property_readonly("n_triangles", &FaultSide::n_triangles);
}

}  // namespace faultmesh::bindings
