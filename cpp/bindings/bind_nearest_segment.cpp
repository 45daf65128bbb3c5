// Binding of the nearest-segment query (nearest_segment.hpp).
#include <faultmesh/nearest_segment.hpp>

#include "common.hpp"

namespace faultmesh::bindings {

void bind_nearest_segment(py::module_& m) {
    m.def(
        "nearest_segment",
        [](const py::handle& points, const py::handle& starts, const py::handle& ends) {
            const char* fn = "nearest_segment";
            // Private copies (common.hpp), finite and within the coordinate limit.
            DoubleArray P = as_coordinates(points, fn, "points", 2, 3, 2);
            DoubleArray A = as_coordinates(starts, fn, "starts", 2, 3, 2);
            DoubleArray B = as_coordinates(ends, fn, "ends", 2, 3, 2);
            if (A.shape(0) != B.shape(0))
                throw std::invalid_argument(std::string(fn) + ": starts and ends must have the same number of "
                                            "rows, got " + std::to_string(A.shape(0)) + " and " +
                                            std::to_string(B.shape(0)));
            // One stride for the kernel: x, y of every array, packed.
            auto xy = [](const DoubleArray& X) {
                const std::size_t k = static_cast<std::size_t>(X.shape(0)), c = static_cast<std::size_t>(X.shape(1));
                std::vector<double> v(2 * k);
                for (std::size_t i = 0; i < k; ++i) {
                    v[2 * i] = X.data()[i * c];
                    v[2 * i + 1] = X.data()[i * c + 1];
                }
                return v;
            };
            const std::vector<double> p = xy(P), a = xy(A), b = xy(B);
            NearestSegment r;
            {
                py::gil_scoped_release release;
                r = nearest_segment(p.data(), p.size() / 2, a.data(), b.data(), a.size() / 2);
            }
            return py::make_tuple(to_numpy(std::move(r.index)), to_numpy(std::move(r.distance)));
        },
        py::arg("points"), py::arg("starts"), py::arg("ends"),
        "The nearest of the segments starts[j] -> ends[j] ((m, 2|3), only x, y used) to each\n"
        "point (n, 2|3), in XY. Returns (index int64 (n,), distance float64 (n,)); with no\n"
        "segment every index is -1 and every distance inf. Among segments at the same distance\n"
        "the lowest index wins. Coordinates must be finite with |c| <= 1e60 (ValueError\n"
        "naming the argument and row otherwise).");
}

}  // namespace faultmesh::bindings
