// Bindings for overlap detection: faultmesh.overlapping_triangles.
#include <faultmesh/aabb_tree.hpp>
#include <faultmesh/overlap.hpp>
#include <faultmesh/predicates.hpp>

#include "common.hpp"

namespace faultmesh::bindings {

const AabbTree* tree_from_py(const py::handle& obj, std::size_t n_triangles);

void bind_overlap(py::module_& m) {
    m.def(
        "overlapping_triangles",
        [](const py::handle& vertices, const py::handle& triangles, const py::handle& rings,
           bool grow_to_disk, bool allow_mesh_boundary, const py::handle& tree) {
            const char* fn = "overlapping_triangles";
            auto V = as_points(vertices, fn, "vertices", 2, 3);
            auto T = as_indices(triangles, fn, "triangles", 3, V.shape(0));
            RingsData R = as_rings(rings, fn, 3, 0);
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
            RingsData R = as_rings(rings, fn, 3, 0);
            check_coordinates(A.data(), static_cast<std::size_t>(n), static_cast<std::size_t>(A.shape(1)), 2, fn, "a");
            check_coordinates(B.data(), static_cast<std::size_t>(n), static_cast<std::size_t>(B.shape(1)), 2, fn, "b");
            check_coordinates(C.data(), static_cast<std::size_t>(n), static_cast<std::size_t>(C.shape(1)), 2, fn, "c");
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
