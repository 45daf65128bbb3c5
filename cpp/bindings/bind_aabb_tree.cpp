// Bindings for the AABB tree: faultmesh.AabbTree.
#include <faultmesh/aabb_tree.hpp>
#include <faultmesh/overlap.hpp>

#include <algorithm>
#include <memory>

#include "common.hpp"

namespace faultmesh::bindings {

namespace {

// The Python object keeps the arrays it was built from (the exact refinement
// needs the triangles): its own copies (as_points / as_indices), which no
// caller can change -- the tree indexes them for its whole life.
struct PyAabbTree {
    AabbTree tree;
    DoubleArray vertices;  // (n, 2|3), private; empty for a box tree
    IndexArray elems;      // (m, 3) triangles or (m, 2) segments, private
    int per = 0;           // 3, 2, or 0 for boxes
    std::size_t stride = 2;
};

std::vector<Box2> as_boxes(const py::handle& obj, const char* fn) {
    DoubleArray a = as_points(obj, fn, "boxes", 4, 4);
    const std::size_t q = static_cast<std::size_t>(a.shape(0));
    std::vector<Box2> boxes(q);
    const double* d = a.data();
    for (std::size_t i = 0; i < q; ++i) boxes[i] = {d[4 * i], d[4 * i + 1], d[4 * i + 2], d[4 * i + 3]};
    return boxes;
}

std::unique_ptr<PyAabbTree> make_tree(const py::handle& vertices, const py::handle& elems, int per,
                                      const char* fn) {
    auto t = std::make_unique<PyAabbTree>();
    t->vertices = as_points(vertices, fn, "vertices", 2, 3);
    t->elems = as_indices(elems, fn, per == 3 ? "triangles" : "segments", per, t->vertices.shape(0));
    t->per = per;
    t->stride = static_cast<std::size_t>(t->vertices.shape(1));
    const double* V = t->vertices.data();
    const std::int64_t* E = t->elems.data();
    const std::size_t n = static_cast<std::size_t>(t->vertices.shape(0));
    const std::size_t m = static_cast<std::size_t>(t->elems.shape(0));
    {
        py::gil_scoped_release release;
        t->tree = per == 3 ? AabbTree::from_triangles(V, n, t->stride, E, m)
                           : AabbTree::from_segments(V, n, t->stride, E, m);
    }
    return t;
}

py::tuple csr_to_py(Csr&& r) {
    return py::make_tuple(to_numpy(std::move(r.offsets)), to_numpy(std::move(r.indices)));
}

}  // namespace

// Used by bind_overlap.cpp for the `tree=` argument of overlapping_triangles.
const AabbTree* tree_from_py(const py::handle& obj, std::size_t n_triangles) {
    if (obj.is_none()) return nullptr;
    auto& t = obj.cast<PyAabbTree&>();
    if (t.per != 3)
        throw std::invalid_argument("overlapping_triangles: tree must be built over triangles "
                                    "(AabbTree(vertices, triangles))");
    if (t.tree.size() != n_triangles)
        throw std::invalid_argument("overlapping_triangles: tree has " + std::to_string(t.tree.size()) +
                                    " triangles, triangles has " + std::to_string(n_triangles) + " rows");
    return &t.tree;
}

void bind_aabb_tree(py::module_& m) {
    py::class_<PyAabbTree>(m, "AabbTree",
                           "Static 2D AABB tree over the XY boxes of triangles, segments or boxes\n"
                           "(Morton order, flat arrays). Queries use closed boxes: touching counts.")
        .def(py::init([](const py::handle& vertices, const py::handle& triangles) {
                 return make_tree(vertices, triangles, 3, "AabbTree");
             }),
             py::arg("vertices"), py::arg("triangles"),
             "Tree over the XY boxes of triangles: vertices (n, 2|3), triangles (m, 3).")
        .def_static(
            "from_segments",
            [](const py::handle& vertices, const py::handle& segments) {
                return make_tree(vertices, segments, 2, "AabbTree.from_segments");
            },
            py::arg("vertices"), py::arg("segments"),
            "Tree over the XY boxes of segments: vertices (n, 2|3), segments (m, 2).")
        .def_static(
            "from_boxes",
            [](const py::handle& boxes) {
                auto b = as_boxes(boxes, "AabbTree.from_boxes");
                auto t = std::make_unique<PyAabbTree>();
                {
                    py::gil_scoped_release release;
                    t->tree = AabbTree(b);
                }
                return t;
            },
            py::arg("boxes"), "Tree over boxes (m, 4): xmin, ymin, xmax, ymax.")
        .def(
            "query",
            [](const PyAabbTree& self, const py::handle& boxes, bool exact, bool sorted) {
                auto q = as_boxes(boxes, "AabbTree.query");
                if (exact && self.per == 0)
                    throw std::invalid_argument("AabbTree.query: exact=True needs a tree over triangles "
                                                "or segments, not boxes");
                Csr r;
                {
                    py::gil_scoped_release release;
                    if (!exact)
                        r = self.tree.query(q.data(), q.size(), sorted);
                    else if (self.per == 3)
                        r = self.tree.query_triangles_exact(q.data(), q.size(), self.vertices.data(),
                                                            self.stride, self.elems.data(), sorted);
                    else
                        r = self.tree.query_segments_exact(q.data(), q.size(), self.vertices.data(),
                                                           self.stride, self.elems.data(), sorted);
                }
                return csr_to_py(std::move(r));
            },
            py::arg("boxes"), py::arg("exact") = false, py::arg("sorted") = true,
            "Batched box queries. boxes (q, 4): xmin, ymin, xmax, ymax. Returns (offsets (q+1,),\n"
            "indices) int64 CSR: the hits of query i are indices[offsets[i]:offsets[i+1]], sorted\n"
            "ascending if sorted=True. exact=False: primitives whose box meets the query box\n"
            "(closed). exact=True: triangles (segments) that themselves meet the closed box,\n"
            "decided with exact orient2d (what CGAL's AABB_tree answers for a Bbox query).")
        .def(
            "query_polygons",
            [](const PyAabbTree& self, const py::list& regions, bool refine) {
                if (refine && self.per != 3)
                    throw std::invalid_argument("AabbTree.query_polygons: refine=True needs a tree over "
                                                "triangles");
                std::vector<RingsData> rs;
                rs.reserve(regions.size());
                for (const py::handle& r : regions) rs.push_back(as_rings(r, "AabbTree.query_polygons", 3, 0));
                Csr out;
                {
                    py::gil_scoped_release release;
                    out.offsets.assign(1, 0);
                    std::vector<std::int64_t> hits;
                    for (const RingsData& r : rs) {
                        const std::size_t nr = r.offsets.size() - 1;
                        if (refine) {
                            hits = overlapping_triangles(
                                self.tree, self.vertices.data(), static_cast<std::size_t>(self.vertices.shape(0)),
                                self.stride, self.elems.data(), static_cast<std::size_t>(self.elems.shape(0)),
                                r.xy.data(), r.offsets.data(), nr);
                        } else {
                            hits.clear();
                            self.tree.query_polygon(r.xy.data(), r.offsets.data(), nr, hits, true);
                        }
                        out.indices.insert(out.indices.end(), hits.begin(), hits.end());
                        out.offsets.push_back(static_cast<std::int64_t>(out.indices.size()));
                    }
                }
                return csr_to_py(std::move(out));
            },
            py::arg("regions"), py::arg("refine") = false,
            "Polygon queries. regions: a list of regions, each a (k, 2) ring or a list of rings.\n"
            "refine=False: primitives whose box meets the region's box (stage 1 of the overlap\n"
            "test). refine=True (triangle trees): the triangles whose interior meets the region's\n"
            "interior, as overlapping_triangles. Returns (offsets, indices) int64 CSR, sorted.")
        .def("__len__", [](const PyAabbTree& self) { return self.tree.size(); })
        .def_property_readonly("size", [](const PyAabbTree& self) { return self.tree.size(); })
        .def_property_readonly("bounds",
                               [](const PyAabbTree& self) {
                                   const Box2 b = self.tree.bounds();
                                   return py::make_tuple(b.xmin, b.ymin, b.xmax, b.ymax);
                               },
                               "(xmin, ymin, xmax, ymax) of all boxes")
        .def_property_readonly("depth", [](const PyAabbTree& self) { return self.tree.depth(); })
        .def_property_readonly("node_count", [](const PyAabbTree& self) { return self.tree.node_count(); })
        .def_property_readonly("kind", [](const PyAabbTree& self) {
            return self.per == 3 ? "triangles" : self.per == 2 ? "segments" : "boxes";
        });
}

}  // namespace faultmesh::bindings
