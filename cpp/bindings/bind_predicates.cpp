// Bindings for the exact predicates (batched: one call per array of queries).
#include <faultmesh/predicates.hpp>

#include "common.hpp"

namespace faultmesh::bindings {

void bind_predicates(py::module_& m) {
    m.def(
        "orient2d",
        [](const py::handle& a, const py::handle& b, const py::handle& c) {
            auto pa = as_points(a, "orient2d", "a", 2, 2);
            auto pb = as_points(b, "orient2d", "b", 2, 2);
            auto pc = as_points(c, "orient2d", "c", 2, 2);
            const py::ssize_t n = pa.shape(0);
            if (pb.shape(0) != n || pc.shape(0) != n)
                throw std::invalid_argument("orient2d: a, b and c must have the same number of rows");
            const double *A = pa.data(), *B = pb.data(), *C = pc.data();
            const std::size_t rows = static_cast<std::size_t>(n);
            check_coordinates(A, rows, 2, 2, "orient2d", "a");
            check_coordinates(B, rows, 2, 2, "orient2d", "b");
            check_coordinates(C, rows, 2, 2, "orient2d", "c");
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
            auto pa = as_points(a, "incircle", "a", 2, 2);
            auto pb = as_points(b, "incircle", "b", 2, 2);
            auto pc = as_points(c, "incircle", "c", 2, 2);
            auto pd = as_points(d, "incircle", "d", 2, 2);
            const py::ssize_t n = pa.shape(0);
            if (pb.shape(0) != n || pc.shape(0) != n || pd.shape(0) != n)
                throw std::invalid_argument("incircle: a, b, c and d must have the same number of rows");
            const double *A = pa.data(), *B = pb.data(), *C = pc.data(), *D = pd.data();
            const std::size_t rows = static_cast<std::size_t>(n);
            check_coordinates(A, rows, 2, 2, "incircle", "a");
            check_coordinates(B, rows, 2, 2, "incircle", "b");
            check_coordinates(C, rows, 2, 2, "incircle", "c");
            check_coordinates(D, rows, 2, 2, "incircle", "d");
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
}

}  // namespace faultmesh::bindings
