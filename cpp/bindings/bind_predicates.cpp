// Bindings for the exact predicates (batched: one call per array of queries).
#include <faultmesh/predicates.hpp>

#include "common.hpp"

namespace faultmesh::bindings {

void bind_predicates(py::module_& m) {
    m.def(
        "orient2d",
        [](const py::handle& a, const py::handle& b, const py::handle& c) {
            auto pa = as_coordinates(a, "orient2d", "a", 2, 2, 2);
            auto pb = as_coordinates(b, "orient2d", "b", 2, 2, 2);
            auto pc = as_coordinates(c, "orient2d", "c", 2, 2, 2);
            const py::ssize_t n = pa.shape(0);
            if (pb.shape(0) != n || pc.shape(0) != n)
                throw std::invalid_argument("orient2d: a, b and c must have the same number of rows");
            const double *A = pa.data(), *B = pb.data(), *C = pc.data();
            const std::size_t rows = static_cast<std::size_t>(n);
            std::vector<double> out(rows);
            {
                py::gil_scoped_release release;
                for (py::ssize_t i = 0; i < n; ++i) out[i] = orient2d(A + 2 * i, B + 2 * i, C + 2 * i);
            }
            return to_numpy(std::move(out));
        },
        py::arg("a"), py::arg("b"), py::arg("c"),
        "Exact orientation of each row triple (a, b, c), arrays (n, 2): > 0 counter-clockwise,\n"
        "< 0 clockwise, exactly 0 collinear. The value approximates twice the signed area;\n"
        "its sign is always exact (a non-zero value below the smallest subnormal is returned as\n"
        "+-5e-324). Coordinates must be finite with |c| <= 1e60 (ValueError naming the\n"
        "argument and row otherwise); there is no lower limit.");
    m.def(
        "incircle",
        [](const py::handle& a, const py::handle& b, const py::handle& c, const py::handle& d) {
            auto pa = as_coordinates(a, "incircle", "a", 2, 2, 2);
            auto pb = as_coordinates(b, "incircle", "b", 2, 2, 2);
            auto pc = as_coordinates(c, "incircle", "c", 2, 2, 2);
            auto pd = as_coordinates(d, "incircle", "d", 2, 2, 2);
            const py::ssize_t n = pa.shape(0);
            if (pb.shape(0) != n || pc.shape(0) != n || pd.shape(0) != n)
                throw std::invalid_argument("incircle: a, b, c and d must have the same number of rows");
            const double *A = pa.data(), *B = pb.data(), *C = pc.data(), *D = pd.data();
            const std::size_t rows = static_cast<std::size_t>(n);
            std::vector<double> out(rows);
            {
                py::gil_scoped_release release;
                for (py::ssize_t i = 0; i < n; ++i)
                    out[i] = incircle(A + 2 * i, B + 2 * i, C + 2 * i, D + 2 * i);
            }
            return to_numpy(std::move(out));
        },
        py::arg("a"), py::arg("b"), py::arg("c"), py::arg("d"),
        "Exact in-circle test per row: > 0 if d is inside the circle through the\n"
        "counter-clockwise a, b, c; < 0 outside; exactly 0 cocircular. Coordinates must be\n"
        "finite with |c| <= 1e60 (ValueError naming the argument and row otherwise).");
    m.def(
        "orient3d",
        [](const py::handle& a, const py::handle& b, const py::handle& c, const py::handle& d) {
            auto pa = as_coordinates(a, "orient3d", "a", 3, 3, 3);
            auto pb = as_coordinates(b, "orient3d", "b", 3, 3, 3);
            auto pc = as_coordinates(c, "orient3d", "c", 3, 3, 3);
            auto pd = as_coordinates(d, "orient3d", "d", 3, 3, 3);
            const py::ssize_t n = pa.shape(0);
            if (pb.shape(0) != n || pc.shape(0) != n || pd.shape(0) != n)
                throw std::invalid_argument("orient3d: a, b, c and d must have the same number of rows");
            // pa .. pd are private copies (as_points): no other thread can change them
            // while the GIL is released.
            const double *A = pa.data(), *B = pb.data(), *C = pc.data(), *D = pd.data();
            std::vector<double> out(static_cast<std::size_t>(n));
            {
                py::gil_scoped_release release;
                for (py::ssize_t i = 0; i < n; ++i)
                    out[i] = orient3d(A + 3 * i, B + 3 * i, C + 3 * i, D + 3 * i);
            }
            return to_numpy(std::move(out));
        },
        py::arg("a"), py::arg("b"), py::arg("c"), py::arg("d"),
        "Exact orientation of each row quadruple (a, b, c, d), arrays (n, 3): > 0 if d lies\n"
        "below the plane through a, b, c (a, b, c counter-clockwise seen from above, +z),\n"
        "< 0 above, exactly 0 coplanar (Shewchuk's convention). The value approximates six\n"
        "times the signed volume; its sign is always exact (a non-zero value below the smallest\n"
        "subnormal is returned as +-5e-324). Coordinates must be finite with |c| <= 1e60\n"
        "(ValueError naming the argument and row otherwise); there is no lower limit.");
}

}  // namespace faultmesh::bindings
