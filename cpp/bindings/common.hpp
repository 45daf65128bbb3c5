// Array conventions shared by every binding file (one file per algorithm).
//
// In:  points (n, 2|3) float64, triangles (m, 3) int64 -- any dtype or memory
//      layout is accepted. Every array a kernel reads is PRIVATE to the call
//      (or to the object that keeps it): the kernels run with the GIL
//      released, and `forcecast | c_style` does not copy an array that is
//      already contiguous float64 / int64, so another Python thread could
//      write it during the call (or, for an object such as AabbTree, any time
//      later). The helpers below copy such an array once (a memcpy: 0.1-1 %
//      of the kernels' own time on the benchmark inputs, 5 % for the cheapest,
//      boundary_loops; see as_private in common.cpp) and
//      keep converted arrays, which nobody else can reach, as they are.
// Index arrays must hold integers: float input is accepted only if every
//      value is an exact integer, never truncated; negative indices are
//      rejected naming the row (halfedges, where -1 means "none", has its own
//      helper).
// Out: fresh numpy arrays that take ownership of a std::vector (no copy).
// Shapes and values are checked here, before the GIL is released; messages
// name the function, the argument and the row.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <mutex>
#include <shared_mutex>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace faultmesh::bindings {

namespace py = pybind11;

using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;
using IndexArray = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>;

std::string shape_str(const py::array& a);

// A (n, k) float64 array with k in [min_cols, max_cols], private to the caller.
DoubleArray as_points(const py::handle& obj, const char* fn, const char* what, py::ssize_t min_cols,
                      py::ssize_t max_cols);

// as_points, and the first `dims` columns of every row within the coordinate
// limit (faultmesh::check_coordinates: finite, |c| <= kMaxCoordinate; the
// ValueError names fn, what and the row). The one entry check of a kernel's
// coordinate argument.
DoubleArray as_coordinates(const py::handle& obj, const char* fn, const char* what, py::ssize_t min_cols,
                           py::ssize_t max_cols, std::size_t dims);

// A (m, cols) int64 array of non-negative integers (cols == 0: 1-D (m,)),
// private to the caller. n_limit >= 0: every index must also be < n_limit
// ("out of range [0, n_limit)"). Float input must hold exact integers.
IndexArray as_indices(const py::handle& obj, const char* fn, const char* what, py::ssize_t cols,
                      std::int64_t n_limit = -1);

// A 1-D int64 array of half-edge links: each -1 (none) or in [0, n_limit).
IndexArray as_links(const py::handle& obj, const char* fn, const char* what, std::int64_t n_limit);

// A 1-D float64 array, private to the caller.
DoubleArray as_values(const py::handle& obj, const char* fn, const char* what);

// A count argument such as n_vertices: None -> 0 (unset); else a positive
// integer (an int, a numpy integer or a float holding an exact integer),
// otherwise ValueError naming the argument.
std::size_t as_count(const py::handle& obj, const char* fn, const char* what);

// Rings of one region: the points concatenated (x, y), ring r is points
// offsets[r] .. offsets[r+1].
struct RingsData {
    std::vector<double> xy;
    std::vector<std::int64_t> offsets;
    std::size_t n_rings() const { return offsets.size() - 1; }
};
// `rings`: one (k, 2..max_cols) array (a single ring; also a nested list of
// points), a 3-D array (rings of equal length) or a sequence of (k, 2..max_cols)
// arrays. Only x and y are kept. An outer ring (the first) with fewer than
// min_outer rows is a ValueError ("rings[0] (the outer ring) has 0 vertices;
// it needs at least 3"); holes of one or two points are the kernels' business
// (Steiner points in earcut's fixtures).
RingsData as_rings(const py::handle& rings, const char* fn, py::ssize_t max_cols, py::ssize_t min_outer);

// An object shared with Python whose methods run with the GIL released (Tin,
// Stitcher, LayerTin): Python threads may call it concurrently, so readers
// share the lock and anything that changes it takes the lock exclusively.
// The lock is always taken after the GIL is released, and the GIL is never
// needed while it is held, so the two cannot deadlock.
template <class T>
struct Shared {
    template <class... A>
    explicit Shared(A&&... args) : obj(std::forward<A>(args)...) {}
    T obj;
    mutable std::shared_mutex mu;
};

// f(obj) under the shared lock, GIL released.
template <class T, class F>
auto read_locked(const Shared<T>& s, F&& f) {
    py::gil_scoped_release release;
    std::shared_lock<std::shared_mutex> lock(s.mu);
    return f(static_cast<const T&>(s.obj));
}

// f(obj) under the exclusive lock, GIL released.
template <class T, class F>
auto write_locked(Shared<T>& s, F&& f) {
    py::gil_scoped_release release;
    std::unique_lock<std::shared_mutex> lock(s.mu);
    return f(s.obj);
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
