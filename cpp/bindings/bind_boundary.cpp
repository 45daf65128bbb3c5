// Bindings for boundary contours: faultmesh.boundary_loops, boundary_contours,
// boundary_edges, sort_segments and the BoundaryContours report; and the
// library's one triangle adjacency, halfedge_twins (triangle_adjacency.hpp).
#include <faultmesh/boundary.hpp>
#include <faultmesh/triangle_adjacency.hpp>

#include "common.hpp"

namespace faultmesh::bindings {

namespace {

py::list loops_to_py(std::vector<std::vector<std::int64_t>>&& loops) {
    py::list out;
    for (auto& l : loops) out.append(to_numpy(std::move(l)));
    return out;
}

// The report as a Python object (attributes are fresh numpy arrays / lists).
struct PyContours {
    BoundaryContours c;
};

}  // namespace

void bind_boundary(py::module_& m) {
    py::class_<PyContours>(m, "BoundaryContours",
                           "Boundary report of a triangle set: closed loops (oriented like the\n"
                           "triangles), open chains, pinch vertices, non-manifold and inconsistent edges.")
        .def_property_readonly("loops", [](const PyContours& s) { auto l = s.c.loops; return loops_to_py(std::move(l)); },
                               "closed loops, list of int64 arrays (first vertex not repeated)")
        .def_property_readonly("open_chains",
                               [](const PyContours& s) { auto l = s.c.open_chains; return loops_to_py(std::move(l)); },
                               "vertex sequences that do not close, list of int64 arrays")
        .def_property_readonly("pinch_vertices",
                               [](const PyContours& s) { auto v = s.c.pinch_vertices; return to_numpy(std::move(v)); },
                               "sorted vertices that lie on the boundary more than once")
        .def_property_readonly("nonmanifold_edges",
                               [](const PyContours& s) {
                                   auto v = s.c.nonmanifold_edges;
                                   return to_numpy(std::move(v), 2);
                               },
                               "(k, 2) edges used by three or more triangles")
        .def_property_readonly("inconsistent_edges",
                               [](const PyContours& s) {
                                   auto v = s.c.inconsistent_edges;
                                   return to_numpy(std::move(v), 2);
                               },
                               "(k, 2) edges used twice in the same direction")
        .def_property_readonly("chain_break_vertices",
                               [](const PyContours& s) {
                                   auto v = s.c.chain_break_vertices;
                                   return to_numpy(std::move(v));
                               },
                               "vertices where sequences were cut (pairing undecidable)")
        .def_property_readonly("clean", [](const PyContours& s) { return s.c.clean(); },
                               "True if there are no open chains, pinches or bad edges")
        .def("__repr__", [](const PyContours& s) {
            return "BoundaryContours(loops=" + std::to_string(s.c.loops.size()) +
                   ", open_chains=" + std::to_string(s.c.open_chains.size()) +
                   ", pinch_vertices=" + std::to_string(s.c.pinch_vertices.size()) + ")";
        });

    m.def(
        "boundary_loops",
        [](const py::handle& triangles, bool strict, const py::object& n_vertices) {
            const std::size_t n = as_count(n_vertices, "boundary_loops", "n_vertices");
            auto T = as_indices(triangles, "boundary_loops", "triangles", 3, n ? static_cast<std::int64_t>(n) : -1);
            std::vector<std::vector<std::int64_t>> loops;
            {
                py::gil_scoped_release release;
                loops = boundary_loops(T.data(), static_cast<std::size_t>(T.shape(0)), n, strict);
            }
            return loops_to_py(std::move(loops));
        },
        py::arg("triangles"), py::kw_only(), py::arg("strict") = true, py::arg("n_vertices") = py::none(),
        "Closed boundary loops of a triangle set (m, 3): edges used by one triangle, sorted into\n"
        "vertex loops (paper 2.5, Algorithm 1) that follow the triangles' orientation (for CCW\n"
        "triangles: outer loop CCW, holes CW). Each loop is an int64 array, first vertex not\n"
        "repeated, starting at its smallest (from, to) edge; loops ordered by that vertex.\n"
        "strict=True raises GeometryError naming a vertex on a pinch vertex, open chain,\n"
        "non-manifold or inconsistently oriented edge; strict=False returns the closed loops\n"
        "(pinches separated through the triangle fans). boundary_contours gives the full report.");
    m.def(
        "boundary_contours",
        [](const py::handle& triangles, const py::object& n_vertices) {
            const std::size_t n = as_count(n_vertices, "boundary_contours", "n_vertices");
            auto T = as_indices(triangles, "boundary_contours", "triangles", 3, n ? static_cast<std::int64_t>(n) : -1);
            PyContours r;
            {
                py::gil_scoped_release release;
                r.c = boundary_contours(T.data(), static_cast<std::size_t>(T.shape(0)), n);
            }
            return r;
        },
        py::arg("triangles"), py::kw_only(), py::arg("n_vertices") = py::none(),
        "Full boundary report (BoundaryContours): loops, open_chains, pinch_vertices,\n"
        "nonmanifold_edges, inconsistent_edges, chain_break_vertices.");
    m.def(
        "boundary_edges",
        [](const py::handle& triangles, const py::object& n_vertices) {
            const std::size_t n = as_count(n_vertices, "boundary_edges", "n_vertices");
            auto T = as_indices(triangles, "boundary_edges", "triangles", 3, n ? static_cast<std::int64_t>(n) : -1);
            std::vector<std::int64_t> e;
            {
                py::gil_scoped_release release;
                e = boundary_edges(T.data(), static_cast<std::size_t>(T.shape(0)), n);
            }
            return to_numpy(std::move(e), 2);
        },
        py::arg("triangles"), py::kw_only(), py::arg("n_vertices") = py::none(),
        "Directed boundary edges (k, 2) int64 (edges used by exactly one triangle, in that\n"
        "triangle's direction), in triangle order.");
    m.def(
        "halfedge_twins",
        [](const py::handle& triangles, const py::object& n_vertices, const std::string& orientation) {
            const std::size_t n = as_count(n_vertices, "halfedge_twins", "n_vertices");
            auto T = as_indices(triangles, "halfedge_twins", "triangles", 3, n ? static_cast<std::int64_t>(n) : -1);
            EdgeOrientation o;
            if (orientation == "any") o = EdgeOrientation::any;
            else if (orientation == "consistent") o = EdgeOrientation::consistent;
            else throw py::value_error("halfedge_twins: orientation must be 'any' or 'consistent', got '" +
                                       orientation + "'");
            std::size_t nv = n;
            if (!nv)
                for (py::ssize_t i = 0; i < T.size(); ++i)
                    nv = std::max<std::size_t>(nv, static_cast<std::size_t>(T.data()[i]) + 1);
            std::vector<std::int64_t> tw;
            {
                py::gil_scoped_release release;
                tw = halfedge_twins(T.data(), static_cast<std::size_t>(T.shape(0)), nv, o, "halfedge_twins");
            }
            return to_numpy(std::move(tw));
        },
        py::arg("triangles"), py::kw_only(), py::arg("n_vertices") = py::none(),
        py::arg("orientation") = "any",
        "Opposite half-edges (3 m,) int64 of a triangle list (m, 3): half-edge 3 t + k of\n"
        "triangle t runs from its corner k to corner k+1; twins[e] is the other triangle's\n"
        "half-edge on the same edge, or -1 on the mesh boundary. orientation='any' pairs the\n"
        "two uses of an edge whatever their directions; 'consistent' raises GeometryError for\n"
        "two in the same direction. An edge of three or more triangles raises GeometryError\n"
        "naming it (triangle_adjacency.hpp).");
    m.def(
        "sort_segments",
        [](const py::handle& segments, const py::object& n_vertices) {
            const std::size_t n = as_count(n_vertices, "sort_segments", "n_vertices");
            auto S = as_indices(segments, "sort_segments", "segments", 2, n ? static_cast<std::int64_t>(n) : -1);
            PyContours r;
            {
                py::gil_scoped_release release;
                r.c = sort_segments(S.data(), static_cast<std::size_t>(S.shape(0)), n);
            }
            return r;
        },
        py::arg("segments"), py::kw_only(), py::arg("n_vertices") = py::none(),
        "Algorithm 1 alone: directed segments (k, 2) sorted into loops and open chains by head\n"
        "and tail insertion (BoundaryContours; pinches paired in input order and reported).");
}

}  // namespace faultmesh::bindings
