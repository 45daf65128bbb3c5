// Bindings for overlap detection: faultmesh.overlapping_triangles.
#include <faultmesh/aabb_tree.hpp>
#include <faultmesh/overlap.hpp>

#include "common.hpp"

namespace faultmesh::bindings {

struct RingsData {
    std::vector<double> xy;
    std::vector<std::int64_t> offsets;
};
const AabbTree* tree_from_py(const py::handle& obj, std::size_t n_triangles);

// A region: one (k, 2|3) array (a single ring) or a sequence of such arrays
// (outer rings and holes, any orientation; even-odd rule). Only x and y are used.
RingsData parse_rings(const py::handle& obj, const char* fn) {
    RingsData r;
    r.offsets.push_back(0);
    auto add_ring = [&](const py::handle& h, std::size_t idx) {
        DoubleArray a = DoubleArray::ensure(h);
        if (!a || a.ndim() != 2 || a.shape(1) < 2 || a.shape(1) > 3)
            throw std::invalid_argument(std::string(fn) + ": ring " + std::to_string(idx) +
                                        " must be an array of shape (k, 2) or (k, 3)" +
                                        (a ? ", got " + shape_str(a) : std::string()));
        const std::size_t k = static_cast<std::size_t>(a.shape(0)), c = static_cast<std::size_t>(a.shape(1));
        const double* d = a.data();
        for (std::size_t i = 0; i < k; ++i) {
            r.xy.push_back(d[c * i]);
            r.xy.push_back(d[c * i + 1]);
        }
        r.offsets.push_back(static_cast<std::int64_t>(r.xy.size() / 2));
    };
    // A numpy array (or nested list) of 2 dimensions is one ring; otherwise
    // a sequence of rings.
    if (py::isinstance<py::array>(obj)) {
        py::array arr = py::reinterpret_borrow<py::array>(obj);
        if (arr.ndim() == 2) {
            add_ring(obj, 0);
            return r;
        }
        if (arr.ndim() != 3)
            throw std::invalid_argument(std::string(fn) + ": rings must be a (k, 2) array or a list of "
                                        "(k, 2) arrays, got shape " + shape_str(arr));
    }
    if (!py::isinstance<py::sequence>(obj) || py::isinstance<py::str>(obj))
        throw std::invalid_argument(std::string(fn) + ": rings must be a (k, 2) array or a list of (k, 2) arrays");
    py::sequence seq = py::reinterpret_borrow<py::sequence>(obj);
    // A plain list of points ([[x, y], ...]) is one ring too.
    if (seq.size() > 0) {
        py::array first = py::array::ensure(seq[0]);
        if (first && first.ndim() == 1) {
            add_ring(obj, 0);
            return r;
        }
    }
    std::size_t i = 0;
    for (const py::handle& h : seq) add_ring(h, i++);
    return r;
}

void bind_overlap(py::module_& m) {
    m.def(
        "overlapping_triangles",
        [](const py::handle& vertices, const py::handle& triangles, const py::handle& rings,
           bool grow_to_disk, bool allow_mesh_boundary, const py::handle& tree) {
            const char* fn = "overlapping_triangles";
            auto V = as_points(vertices, fn, "vertices", 2, 3);
            auto T = as_indices(triangles, fn, "triangles", 3);
            RingsData R = parse_rings(rings, fn);
            const std::size_t n = static_cast<std::size_t>(V.shape(0)), mt = static_cast<std::size_t>(T.shape(0));
            const AabbTree* t = tree_from_py(tree, mt);
            OverlapOptions opt;
            opt.grow_to_disk = grow_to_disk;
            opt.allow_mesh_boundary = allow_mesh_boundary;
            std::vector<std::int64_t> out;
            {
                py::gil_scoped_release release;
                const std::size_t stride = static_cast<std::size_t>(V.shape(1));
                out = t ? overlapping_triangles(*t, V.data(), n, stride, T.data(), mt, R.xy.data(),
                                                R.offsets.data(), R.offsets.size() - 1, opt)
                        : overlapping_triangles(V.data(), n, stride, T.data(), mt, R.xy.data(),
                                                R.offsets.data(), R.offsets.size() - 1, opt);
            }
            return to_numpy(std::move(out));
        },
        py::arg("vertices"), py::arg("triangles"), py::arg("rings"), py::arg("grow_to_disk") = false,
        py::arg("allow_mesh_boundary") = false, py::arg("tree") = py::none(),
        "Sorted int64 indices of the triangles whose interior meets the interior of the region\n"
        "given by `rings` (one (k, 2) ring or a list of rings; even-odd rule, so outer rings and\n"
        "holes in any orientation). Touching along an edge or at a vertex does not count. Stage 1:\n"
        "AABB candidates (pass tree=AabbTree(vertices, triangles) to reuse a tree); stage 2:\n"
        "exact orient2d tests.\n"
        "grow_to_disk=True grows the set by neighbouring triangles until it is a topological disk\n"
        "(edge-connected, no pinch vertex, no enclosed kept island) strictly containing the\n"
        "region. If it reaches the mesh boundary a GeometryError is raised unless\n"
        "allow_mesh_boundary=True (a fault at the study-area boundary): then the kept triangles\n"
        "stay one pinch-free piece.");
    m.def(
        "triangle_overlaps_region",
        [](const py::handle& a, const py::handle& b, const py::handle& c, const py::handle& rings) {
            const char* fn = "triangle_overlaps_region";
            auto A = as_points(a, fn, "a", 2, 3), B = as_points(b, fn, "b", 2, 3), C = as_points(c, fn, "c", 2, 3);
            const py::ssize_t n = A.shape(0);
            if (B.shape(0) != n || C.shape(0) != n)
                throw std::invalid_argument("triangle_overlaps_region: a, b and c must have the same number of rows");
            RingsData R = parse_rings(rings, fn);
            std::vector<std::uint8_t> out(static_cast<std::size_t>(n));
            {
                py::gil_scoped_release release;
                const std::size_t sa = static_cast<std::size_t>(A.shape(1)), sb = static_cast<std::size_t>(B.shape(1)),
                                  sc = static_cast<std::size_t>(C.shape(1));
                for (py::ssize_t i = 0; i < n; ++i)
                    out[static_cast<std::size_t>(i)] = triangle_overlaps_region(
                        A.data() + sa * static_cast<std::size_t>(i), B.data() + sb * static_cast<std::size_t>(i),
                        C.data() + sc * static_cast<std::size_t>(i), R.xy.data(), R.offsets.data(),
                        R.offsets.size() - 1);
            }
            py::array_t<bool> res(n);
            auto* d = res.mutable_data();
            for (py::ssize_t i = 0; i < n; ++i) d[i] = out[static_cast<std::size_t>(i)] != 0;
            return res;
        },
        py::arg("a"), py::arg("b"), py::arg("c"), py::arg("rings"),
        "Exact per-row test (brute force over the ring edges, no tree): does the open triangle\n"
        "(a[i], b[i], c[i]) meet the region's interior? Arrays (n, 2|3); returns bool (n,).");
}

}  // namespace faultmesh::bindings
