// The shared argument helpers of common.hpp.
#include "common.hpp"

#include <faultmesh/predicates.hpp>

#include <cmath>
#include <cstring>
#include <limits>

namespace faultmesh::bindings {

namespace {

std::string cols_str(py::ssize_t min_cols, py::ssize_t max_cols) {
    return min_cols == max_cols ? std::to_string(min_cols)
                                : std::to_string(min_cols) + " or " + std::to_string(max_cols);
}

// The array itself if nobody else can reach its buffer -- a fresh result of
// a conversion (it owns its data and only `a` refers to it) -- else a copy.
// ensure() returns the caller's own object (refcount >= 2: the argument
// tuple holds it too) when it is already contiguous with the right dtype, and
// a view sharing memory (OWNDATA unset) for subclasses and buffer objects.
// The copy is one memcpy. Measured on the benchmark sizes (best of 5, this
// machine): delaunay of 1e6 points 1.2 ms of 1017 ms (0.1 %), Tin.interpolate
// of 1e6 queries 1.6 of 673 ms (0.2 %), AabbTree over 2e6 triangles 12.5 of
// 1017 ms (1.2 %), boundary_loops of 2e6 triangles 12 of 220 ms (5.5 %, the
// cheapest kernel per byte).
template <class A>
A as_private(A a) {
    if (a.owndata() && a.ref_count() == 1) return a;
    A c(std::vector<py::ssize_t>(a.shape(), a.shape() + a.ndim()));
    if (a.size() > 0) std::memcpy(c.mutable_data(), a.data(), static_cast<std::size_t>(a.nbytes()));
    return c;
}

std::string row_name(const char* what, py::ssize_t flat, py::ssize_t cols) {
    return std::string(what) + " row " + std::to_string(cols > 0 ? flat / cols : flat);
}

std::string float_str(double v) {
    return py::str(py::float_(v)).cast<std::string>();
}

// The raw array of an index argument, shape checked; its values must be
// integers: an integer dtype, or floats that are all exact integers.
py::array index_source(const py::handle& obj, const char* fn, const char* what, py::ssize_t cols) {
    py::array raw = py::array::ensure(obj);
    if (!raw) {
        PyErr_Clear();
        throw std::invalid_argument(std::string(fn) + ": " + what + " must be convertible to an integer array");
    }
    const bool shape_ok = cols > 0 ? raw.ndim() == 2 && raw.shape(1) == cols : raw.ndim() == 1;
    if (!shape_ok)
        throw std::invalid_argument(std::string(fn) + ": " + what + " must have shape " +
                                    (cols > 0 ? "(m, " + std::to_string(cols) + ")" : std::string("(m,)")) +
                                    ", got " + shape_str(raw));
    const char kind = raw.dtype().kind();
    if (kind == 'f') {
        // forcecast would truncate 0.5 to 0: accept floats only if exact integers.
        DoubleArray f = DoubleArray::ensure(raw);
        if (!f) throw py::error_already_set();
        const double* d = f.data();
        for (py::ssize_t i = 0; i < f.size(); ++i) {
            const double v = d[i];
            // 2^63 is the first double beyond int64.
            if (!(std::isfinite(v) && v == std::floor(v) && std::fabs(v) < 9223372036854775808.0))
                throw std::invalid_argument(std::string(fn) + ": " + row_name(what, i, cols) + " has the value " +
                                            float_str(v) + ", not an integer (indices must be integers)");
        }
    } else if (kind == 'u') {
        if (raw.itemsize() == 8) {
            py::array_t<std::uint64_t, py::array::c_style | py::array::forcecast> u =
                py::array_t<std::uint64_t, py::array::c_style | py::array::forcecast>::ensure(raw);
            const std::uint64_t* d = u.data();
            for (py::ssize_t i = 0; i < u.size(); ++i)
                if (d[i] > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max()))
                    throw std::invalid_argument(std::string(fn) + ": " + row_name(what, i, cols) + " has index " +
                                                std::to_string(d[i]) + ", beyond the int64 range");
        }
    } else if (kind != 'i') {
        throw std::invalid_argument(std::string(fn) + ": " + what + " must hold integers, got dtype " +
                                    py::str(raw.dtype()).cast<std::string>());
    }
    return raw;
}

}  // namespace

std::string shape_str(const py::array& a) {
    std::string s = "(";
    for (py::ssize_t i = 0; i < a.ndim(); ++i) {
        if (i) s += ", ";
        s += std::to_string(a.shape(i));
    }
    if (a.ndim() == 1) s += ",";
    return s + ")";
}

DoubleArray as_points(const py::handle& obj, const char* fn, const char* what, py::ssize_t min_cols,
                      py::ssize_t max_cols) {
    DoubleArray a = DoubleArray::ensure(obj);
    if (!a) {
        PyErr_Clear();
        throw std::invalid_argument(std::string(fn) + ": " + what + " must be convertible to a float64 array");
    }
    if (a.ndim() != 2 || a.shape(1) < min_cols || a.shape(1) > max_cols)
        throw std::invalid_argument(std::string(fn) + ": " + what + " must have shape (n, " +
                                    cols_str(min_cols, max_cols) + "), got " + shape_str(a));
    return as_private(std::move(a));
}

DoubleArray as_coordinates(const py::handle& obj, const char* fn, const char* what, py::ssize_t min_cols,
                           py::ssize_t max_cols, std::size_t dims) {
    DoubleArray a = as_points(obj, fn, what, min_cols, max_cols);
    const std::size_t cols = static_cast<std::size_t>(a.shape(1));
    check_coordinates(a.data(), static_cast<std::size_t>(a.shape(0)), cols, dims < cols ? dims : cols, fn, what);
    return a;
}

IndexArray as_indices(const py::handle& obj, const char* fn, const char* what, py::ssize_t cols,
                      std::int64_t n_limit) {
    py::array raw = index_source(obj, fn, what, cols);
    IndexArray a = IndexArray::ensure(raw);
    if (!a) throw py::error_already_set();
    a = as_private(std::move(a));
    const std::int64_t* d = a.data();
    const py::ssize_t n = a.size();
    // One branch-free pass; the row is searched only on error.
    bool bad = false;
    for (py::ssize_t i = 0; i < n; ++i) bad |= d[i] < 0 || (n_limit >= 0 && d[i] >= n_limit);
    if (bad)
        for (py::ssize_t i = 0; i < n; ++i) {
            if (d[i] < 0)
                throw std::invalid_argument(std::string(fn) + ": " + row_name(what, i, cols) +
                                            " has a negative vertex index " + std::to_string(d[i]));
            if (n_limit >= 0 && d[i] >= n_limit)
                throw std::invalid_argument(std::string(fn) + ": " + row_name(what, i, cols) + " has vertex index " +
                                            std::to_string(d[i]) + " out of range [0, " + std::to_string(n_limit) +
                                            ")");
        }
    return a;
}

IndexArray as_links(const py::handle& obj, const char* fn, const char* what, std::int64_t n_limit) {
    py::array raw = index_source(obj, fn, what, 0);
    if (raw.shape(0) != n_limit)
        throw std::invalid_argument(std::string(fn) + ": " + what + " must have shape (" + std::to_string(n_limit) +
                                    ",), got " + shape_str(raw));
    IndexArray a = IndexArray::ensure(raw);
    if (!a) throw py::error_already_set();
    a = as_private(std::move(a));
    const std::int64_t* d = a.data();
    for (py::ssize_t i = 0; i < a.size(); ++i)
        if (d[i] < -1 || d[i] >= n_limit)
            throw std::invalid_argument(std::string(fn) + ": " + what + "[" + std::to_string(i) + "] = " +
                                        std::to_string(d[i]) + " is outside [-1, " + std::to_string(n_limit) + ")");
    return a;
}

DoubleArray as_values(const py::handle& obj, const char* fn, const char* what) {
    DoubleArray a = DoubleArray::ensure(obj);
    if (!a) {
        PyErr_Clear();
        throw std::invalid_argument(std::string(fn) + ": " + what + " must be convertible to a float64 array");
    }
    if (a.ndim() != 1)
        throw std::invalid_argument(std::string(fn) + ": " + what + " must be a 1-D array, got shape " + shape_str(a));
    return as_private(std::move(a));
}

std::size_t as_count(const py::handle& obj, const char* fn, const char* what) {
    if (obj.is_none()) return 0;
    const std::string bad = std::string(fn) + ": " + what + " must be a positive integer, got " +
                            py::repr(obj).cast<std::string>();
    if (PyBool_Check(obj.ptr())) throw std::invalid_argument(bad);
    long long v = 0;
    if (PyFloat_Check(obj.ptr())) {
        const double d = PyFloat_AsDouble(obj.ptr());
        if (!(std::isfinite(d) && d == std::floor(d) && d >= 1.0 && d < 9.2e18)) throw std::invalid_argument(bad);
        v = static_cast<long long>(d);
    } else {
        PyObject* idx = PyNumber_Index(obj.ptr());  // int, numpy integer, anything with __index__
        if (!idx) {
            PyErr_Clear();
            throw std::invalid_argument(bad);
        }
        int overflow = 0;
        v = PyLong_AsLongLongAndOverflow(idx, &overflow);
        Py_DECREF(idx);
        if (overflow) throw std::invalid_argument(bad);
    }
    if (v <= 0) throw std::invalid_argument(bad);
    return static_cast<std::size_t>(v);
}

RingsData as_rings(const py::handle& rings, const char* fn, py::ssize_t max_cols, py::ssize_t min_outer) {
    RingsData r;
    r.offsets.assign(1, 0);
    const std::string shape_want = "(k, " + cols_str(2, max_cols) + ")";
    auto add = [&](const py::handle& obj, const std::string& what) {
        DoubleArray a = DoubleArray::ensure(obj);
        if (!a) {
            PyErr_Clear();
            throw std::invalid_argument(std::string(fn) + ": " + what + " must be an array of shape " + shape_want);
        }
        if (a.ndim() != 2 || a.shape(1) < 2 || a.shape(1) > max_cols)
            throw std::invalid_argument(std::string(fn) + ": " + what + " must have shape " + shape_want + ", got " +
                                        shape_str(a));
        const py::ssize_t k = a.shape(0), c = a.shape(1);
        if (r.offsets.size() == 1 && k < min_outer)
            throw std::invalid_argument(std::string(fn) + ": " + what + " (the outer ring) has " + std::to_string(k) +
                                        (k == 1 ? " vertex" : " vertices") + "; it needs at least " +
                                        std::to_string(min_outer));
        // Copied here, with the GIL held: the kernel never sees the caller's buffer.
        const double* d = a.data();
        for (py::ssize_t i = 0; i < k; ++i) {
            r.xy.push_back(d[c * i]);
            r.xy.push_back(d[c * i + 1]);
        }
        r.offsets.push_back(static_cast<std::int64_t>(r.xy.size() / 2));
    };
    const std::string any_form = std::string(fn) + ": rings must be a (k, 2) array or a list of (k, 2) arrays "
                                                   "(outer ring first, then holes)";
    if (py::isinstance<py::array>(rings)) {
        py::array arr = py::reinterpret_borrow<py::array>(rings);
        if (arr.ndim() == 2) {
            add(rings, "rings[0]");
            return r;
        }
        if (arr.ndim() != 3) throw std::invalid_argument(any_form + ", got shape " + shape_str(arr));
    }
    if (!py::isinstance<py::sequence>(rings) || py::isinstance<py::str>(rings) || py::isinstance<py::bytes>(rings))
        throw std::invalid_argument(any_form);
    py::sequence seq = py::reinterpret_borrow<py::sequence>(rings);
    // A plain list of points ([[x, y], ...]) is one ring.
    if (seq.size() > 0) {
        py::object first = seq[0];
        if (!py::isinstance<py::str>(first)) {
            py::array f = py::array::ensure(first);
            if (!f) PyErr_Clear();
            if (f && f.ndim() == 1) {
                add(rings, "rings[0]");
                return r;
            }
        }
    }
    for (py::ssize_t i = 0; i < static_cast<py::ssize_t>(seq.size()); ++i)
        add(seq[i], "rings[" + std::to_string(i) + "]");
    return r;
}

}  // namespace faultmesh::bindings
