// Bindings for lofting: faultmesh.loft, faultmesh.loft_area.
#include <faultmesh/loft.hpp>

#include <string>

#include "common.hpp"

namespace faultmesh::bindings {

void bind_loft(py::module_& m) {
    m.def(
        "loft",
        [](const py::handle& a, const py::handle& b, const std::string& method, bool closed) {
            auto A = as_points(a, "loft", "a", 2, 3);
            auto B = as_points(b, "loft", "b", 2, 3);
            if (A.shape(1) != B.shape(1))
                throw std::invalid_argument("loft: a and b must have the same number of columns, got " +
                                            shape_str(A) + " and " + shape_str(B));
            LoftOptions opt;
            if (method == "min_area")
                opt.method = LoftMethod::min_area;
            else if (method == "shortest_diagonal")
                opt.method = LoftMethod::shortest_diagonal;
            else
                throw std::invalid_argument("loft: method must be 'min_area' or 'shortest_diagonal', got '" +
                                            method + "'");
            opt.closed = closed;
            std::vector<std::int64_t> t;
            {
                py::gil_scoped_release release;
                t = loft(A.data(), static_cast<std::size_t>(A.shape(0)), B.data(),
                         static_cast<std::size_t>(B.shape(0)), static_cast<std::size_t>(A.shape(1)), opt);
            }
            return to_numpy(std::move(t), 3);
        },
        py::arg("a"), py::arg("b"), py::arg("method") = "min_area", py::kw_only(), py::arg("closed") = false,
        "Triangulate the strip between polylines a (k, 3) and b (l, 3) (paper 2.3.2). Returns\n"
        "(m, 3) int64 indices into the points of a then b (a: 0..k-1, b: k..k+l-1).\n"
        "method='min_area': minimum total 3D area (Fuchs-Kedem-Uselton 1977, dynamic programming);\n"
        "'shortest_diagonal': greedy shortest new rung. Open polylines (a[0]~b[0], a[-1]~b[-1]):\n"
        "m = k + l - 2, every polyline edge used once; one point on a side gives a fan (fault tip).\n"
        "closed=True: closed contours (last point not repeated), m = k + l (FKU multiple start).\n"
        "Orientation: triangles (a[i], a[i+1], b[j]) and (a[i], b[j+1], b[j]); with a at the\n"
        "bottom and b at the top, both drawn left to right, every triangle is counter-clockwise.");
    m.def(
        "loft_area",
        [](const py::handle& a, const py::handle& b, const py::handle& triangles) {
            auto A = as_points(a, "loft_area", "a", 2, 3);
            auto B = as_points(b, "loft_area", "b", 2, 3);
            auto T = as_indices(triangles, "loft_area", "triangles", 3, A.shape(0) + B.shape(0));
            if (A.shape(1) != B.shape(1))
                throw std::invalid_argument("loft_area: a and b must have the same number of columns");
            std::vector<std::int64_t> t(T.data(), T.data() + 3 * T.shape(0));
            return loft_area(A.data(), static_cast<std::size_t>(A.shape(0)), B.data(),
                             static_cast<std::size_t>(B.shape(0)), static_cast<std::size_t>(A.shape(1)), t);
        },
        py::arg("a"), py::arg("b"), py::arg("triangles"),
        "Sum of the 3D areas of triangles indexing the points of a then b.");
}

}  // namespace faultmesh::bindings
