// Bindings for delaunay() and Tin: validate shapes, release the GIL around the
// C++ work, hand the result vectors to numpy without copying.
#include <faultmesh/delaunay.hpp>
#include <faultmesh/tin.hpp>

#include <memory>

#include "common.hpp"

namespace faultmesh::bindings {

namespace {

// The extra output of delaunay(..., return_info=True).
struct DelaunayInfo {
    py::object triangles, halfedges, vertex_of_input;
    std::size_t n_duplicates = 0;
};

// A Tin shared with Python (common.hpp: readers -- locate, interpolate,
// accessors -- share the lock, insert() and set_z() take it exclusively).
using PyTin = Shared<Tin>;

}  // namespace

void bind_delaunay(py::module_& m) {
    py::class_<DelaunayInfo>(m, "DelaunayInfo",
                             "Result of delaunay(xy, return_info=True).\n\n"
                             "triangles        (m, 3) int64, counter-clockwise, indices into the input rows\n"
                             "halfedges        (3m,) int64: halfedges[e] is the opposite half-edge of e or -1\n"
                             "                 on the hull; half-edge e = 3t + i runs triangles[t, i] ->\n"
                             "                 triangles[t, (i + 1) % 3]\n"
                             "vertex_of_input  (n,) int64: the row each input row was merged into (itself\n"
                             "                 unless it duplicates a smaller-indexed row)\n"
                             "n_duplicates     number of rows merged into another")
        .def_readonly("triangles", &DelaunayInfo::triangles)
        .def_readonly("halfedges", &DelaunayInfo::halfedges)
        .def_readonly("vertex_of_input", &DelaunayInfo::vertex_of_input)
        .def_readonly("n_duplicates", &DelaunayInfo::n_duplicates)
        .def("__repr__", [](const DelaunayInfo& d) {
            return "DelaunayInfo(triangles=" + std::to_string(py::len(d.triangles)) +
                   ", n_duplicates=" + std::to_string(d.n_duplicates) + ")";
        });

    m.def(
        "delaunay",
        [](const py::handle& xy, bool return_info) -> py::object {
            auto pts = as_points(xy, "delaunay", "xy", 2, 2);
            const std::size_t n = static_cast<std::size_t>(pts.shape(0));
            DelaunayResult r;
            {
                py::gil_scoped_release release;
                r = delaunay(pts.data(), n, /*with_halfedges=*/return_info);
            }
            if (!return_info) return to_numpy(std::move(r.triangles), 3);
            DelaunayInfo info;
            info.triangles = to_numpy(std::move(r.triangles), 3);
            info.halfedges = to_numpy(std::move(r.halfedges));
            info.vertex_of_input = to_numpy(std::move(r.vertex_of_input));
            info.n_duplicates = r.n_duplicates;
            return py::cast(std::move(info));
        },
        py::arg("xy"), py::arg("return_info") = false,
        "Delaunay triangulation of the points xy (n, 2).\n\n"
        "Returns triangles (m, 3) int64, counter-clockwise, indices into the rows of xy.\n"
        "Duplicate points are merged: a group of equal rows is represented by its\n"
        "smallest row index. Exactly cocircular points are decided by CGAL's symbolic\n"
        "perturbation, so the result is canonical (independent of the row order) and\n"
        "equal to CGAL's Delaunay_triangulation_2. With return_info=True returns a\n"
        "DelaunayInfo (triangles, halfedges, vertex_of_input, n_duplicates).\n\n"
        "Raises ValueError for a wrong shape or a NaN/inf coordinate or one beyond 1e60 (naming the row),\n"
        "faultmesh.GeometryError for fewer than 3 distinct points or all collinear.");

    py::class_<PyTin>(m, "Tin",
                      "A TIN: Delaunay triangulation in XY of points (n, 3) with z per vertex,\n"
                      "growing by insert() without being rebuilt (the result equals the TIN built\n"
                      "from all points at once).\n\n"
                      "Vertices are numbered in order of first appearance. A point whose XY equals\n"
                      "an existing vertex (or an earlier row) creates no vertex: the existing vertex\n"
                      "and its z are kept, and the row maps to it (vertex_of_input for the\n"
                      "constructor, the return value of insert()). Triangle indices (triangles,\n"
                      "halfedges, locate) are valid until the next insert().")
        .def(py::init([](const py::handle& xyz) {
                 auto pts = as_points(xyz, "Tin", "xyz", 3, 3);
                 const std::size_t n = static_cast<std::size_t>(pts.shape(0));
                 py::gil_scoped_release release;
                 return std::make_unique<PyTin>(pts.data(), n);
             }),
             py::arg("xyz"),
             "Builds the TIN of the points xyz (n, 3). Raises ValueError for a wrong shape or\n"
             "a NaN/inf x or y or one beyond 1e60 (naming the row), faultmesh.GeometryError for fewer than 3\n"
             "distinct XY points or all collinear.")
        .def(
            "insert",
            [](PyTin& t, const py::handle& xyz) {
                auto pts = as_points(xyz, "Tin.insert", "xyz", 3, 3);
                const std::size_t n = static_cast<std::size_t>(pts.shape(0));
                std::vector<std::int64_t> out;
                out = write_locked(t, [&](Tin& tin) { return tin.insert(pts.data(), n); });
                return to_numpy(std::move(out));
            },
            py::arg("xyz"),
            "Inserts the points xyz (k, 3) into the TIN; returns int64 (k,): the vertex each\n"
            "row maps to (a new vertex, or the existing vertex with the same XY, whose z is\n"
            "kept). Raises ValueError for NaN/inf (or beyond 1e60) before changing anything.")
        .def(
            "set_z",
            [](PyTin& t, const py::handle& vertices, const py::handle& z) {
                IndexArray v = as_indices(vertices, "Tin.set_z", "vertices", 0);
                DoubleArray zz = as_values(z, "Tin.set_z", "z");
                if (zz.shape(0) != v.shape(0))
                    throw std::invalid_argument("Tin.set_z: z must have one value per vertex index (" +
                                                std::to_string(v.shape(0)) + "), got " + shape_str(zz));
                const std::size_t n = static_cast<std::size_t>(v.shape(0));
                write_locked(t, [&](Tin& tin) { tin.set_z(v.data(), zz.data(), n); });
            },
            py::arg("vertices"), py::arg("z"),
            "Sets the z of the given vertices (int64 (k,)) to z (float64 (k,)); XY and the\n"
            "triangles are unchanged. Raises ValueError for an index out of range (naming it),\n"
            "before changing anything.")
        .def_property_readonly(
            "z",
            [](const PyTin& t) {
                auto v = read_locked(t, [](const Tin& tin) { return tin.vertices(); });
                std::vector<double> z(v.size() / 3);
                for (std::size_t i = 0; i < z.size(); ++i) z[i] = v[3 * i + 2];
                return to_numpy(std::move(z));
            },
            "float64 (n,): the z of each vertex (a fresh copy; change it with set_z).")
        .def(
            "locate",
            [](const PyTin& t, const py::handle& xy) {
                auto pts = as_points(xy, "Tin.locate", "xy", 2, 3);
                const std::size_t n = static_cast<std::size_t>(pts.shape(0));
                const std::size_t cols = static_cast<std::size_t>(pts.shape(1));
                std::vector<double> q2;
                const double* q = pts.data();
                if (cols == 3) {  // drop z
                    q2.resize(2 * n);
                    for (std::size_t i = 0; i < n; ++i) {
                        q2[2 * i] = q[3 * i];
                        q2[2 * i + 1] = q[3 * i + 1];
                    }
                    q = q2.data();
                }
                auto out = read_locked(t, [&](const Tin& tin) { return tin.locate(q, n); });
                return to_numpy(std::move(out));
            },
            py::arg("xy"),
            "Index of a triangle containing each point xy (k, 2) (z ignored if (k, 3));\n"
            "-1 outside the convex hull or for a NaN/inf query or one beyond 1e60. int64 (k,).")
        .def(
            "interpolate",
            [](const PyTin& t, const py::handle& xy) {
                auto pts = as_points(xy, "Tin.interpolate", "xy", 2, 3);
                const std::size_t n = static_cast<std::size_t>(pts.shape(0));
                const std::size_t cols = static_cast<std::size_t>(pts.shape(1));
                std::vector<double> q2;
                const double* q = pts.data();
                if (cols == 3) {
                    q2.resize(2 * n);
                    for (std::size_t i = 0; i < n; ++i) {
                        q2[2 * i] = q[3 * i];
                        q2[2 * i + 1] = q[3 * i + 1];
                    }
                    q = q2.data();
                }
                auto out = read_locked(t, [&](const Tin& tin) { return tin.interpolate(q, n); });
                return to_numpy(std::move(out));
            },
            py::arg("xy"),
            "z at each point xy (k, 2) (z ignored if (k, 3)) by linear interpolation in the\n"
            "containing triangle; NaN outside the convex hull. float64 (k,). Containment and\n"
            "weights come from the exact predicates: z is a convex combination of the triangle's\n"
            "z (a query equal to a vertex gets that vertex's z exactly, one on an edge depends\n"
            "on the edge's two vertices only).")
        .def_property_readonly(
            "vertices",
            [](const PyTin& t) {
                return to_numpy(read_locked(t, [](const Tin& tin) { return tin.vertices(); }), 3);
            },
            "float64 (n, 3): x, y, z of each vertex (a fresh copy).")
        .def_property_readonly(
            "triangles",
            [](const PyTin& t) {
                return to_numpy(read_locked(t, [](const Tin& tin) { return tin.triangles(); }), 3);
            },
            "int64 (m, 3): the triangles, counter-clockwise, vertex indices.")
        .def_property_readonly(
            "halfedges",
            [](const PyTin& t) {
                return to_numpy(read_locked(t, [](const Tin& tin) { return tin.halfedges(); }));
            },
            "int64 (3m,): opposite half-edge of each half-edge e = 3t + i (which runs\n"
            "triangles[t, i] -> triangles[t, (i + 1) % 3]), or -1 on the convex hull.")
        .def_property_readonly(
            "vertex_of_input",
            [](const PyTin& t) {
                return to_numpy(read_locked(t, [](const Tin& tin) { return tin.vertex_of_input(); }));
            },
            "int64 (n,): the vertex each row of the constructor's xyz maps to.")
        .def_property_readonly(
            "n_vertices", [](const PyTin& t) { return read_locked(t, [](const Tin& tin) { return tin.n_vertices(); }); })
        .def_property_readonly(
            "n_triangles", [](const PyTin& t) { return read_locked(t, [](const Tin& tin) { return tin.n_triangles(); }); })
        .def_property_readonly(
            "n_duplicates",
            [](const PyTin& t) { return read_locked(t, [](const Tin& tin) { return tin.n_duplicates(); }); },
            "Number of rows (constructor and inserts) merged into an existing vertex.")
        .def("__len__", [](const PyTin& t) { return read_locked(t, [](const Tin& tin) { return tin.n_vertices(); }); })
        .def("__repr__", [](const PyTin& t) {
            return read_locked(t, [](const Tin& tin) {
                return "Tin(n_vertices=" + std::to_string(tin.n_vertices()) +
                       ", n_triangles=" + std::to_string(tin.n_triangles()) + ")";
            });
        });
}

}  // namespace faultmesh::bindings
