// Array conventions shared by every binding file (one file per algorithm).
//
// In:  points (n, 2|3) float64, triangles (m, 3) int64 -- any dtype or memory
//      layout is accepted with one converting copy (forcecast + c_style).
// Out: fresh numpy arrays that take ownership of a std::vector (no copy).
// Shapes are checked here, before the GIL is released; messages name the
// function and the shape that was wrong.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace faultmesh::bindings {

namespace py = pybind11;

using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;
using IndexArray = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>;

inline std::string shape_str(const py::array& a) {
    std::string s = "(";
    for (py::ssize_t i = 0; i < a.ndim(); ++i) {
        if (i) s += ", ";
        s += std::to_string(a.shape(i));
    }
    if (a.ndim() == 1) s += ",";
    return s + ")";
}

// A (n, k) float64 array with k in [min_cols, max_cols].
inline DoubleArray as_points(const py::handle& obj, const char* fn, const char* what,
                             py::ssize_t min_cols, py::ssize_t max_cols) {
    DoubleArray a = DoubleArray::ensure(obj);
    if (!a) throw std::invalid_argument(std::string(fn) + ": " + what +
                                        " must be convertible to a float64 array");
    if (a.ndim() != 2 || a.shape(1) < min_cols || a.shape(1) > max_cols) {
        std::string cols = min_cols == max_cols ? std::to_string(min_cols)
                                                : std::to_string(min_cols) + " or " + std::to_string(max_cols);
        throw std::invalid_argument(std::string(fn) + ": " + what + " must have shape (n, " + cols +
                                    "), got " + shape_str(a));
    }
    return a;
}

// A (m, k) int64 array.
inline IndexArray as_indices(const py::handle& obj, const char* fn, const char* what, py::ssize_t cols) {
    IndexArray a = IndexArray::ensure(obj);
    if (!a) throw std::invalid_argument(std::string(fn) + ": " + what +
                                        " must be convertible to an int64 array");
    if (a.ndim() != 2 || a.shape(1) != cols)
        throw std::invalid_argument(std::string(fn) + ": " + what + " must have shape (m, " +
                                    std::to_string(cols) + "), got " + shape_str(a));
    return a;
}

// Hand a vector to numpy without copying; shape (size / cols, cols), or 1-D if cols == 0.
template <class T>
py::array_t<T> to_numpy(std::vector<T>&& v, py::ssize_t cols = 0) {
    auto* heap = new std::vector<T>(std::move(v));
    py::capsule owner(heap, [](void* p) { delete static_cast<std::vector<T>*>(p); });
    if (cols == 0) return py::array_t<T>({static_cast<py::ssize_t>(heap->size())}, heap->data(), owner);
    const py::ssize_t rows = static_cast<py::ssize_t>(heap->size()) / cols;
    return py::array_t<T>({rows, cols}, heap->data(), owner);
}

}  // namespace faultmesh::bindings
