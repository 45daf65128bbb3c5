// Bindings for stitch: the LayerStitcher class (many faults into one layer),
// the one-shot stitch() and triangles_touching_region().
#include <faultmesh/layer_tin.hpp>
#include <faultmesh/stitch.hpp>

#include <pybind11/native_enum.h>
#include <pybind11/stl.h>  // patch_names: std::vector<std::string> -> list

#include "common.hpp"

namespace faultmesh::bindings {

namespace {

// The keyword argument area=: a StudyArea or None (nullptr).
const StudyArea* optional_study_area(const py::object& area_obj, const char* fn) {
    if (area_obj.is_none()) return nullptr;
    if (!py::isinstance<StudyArea>(area_obj))
        throw py::type_error(std::string(fn) + ": area must be a StudyArea or None");
    return area_obj.cast<const StudyArea*>();
}

// A LayerStitcher shared with Python (common.hpp). It is not thread-safe and
// stitch() runs with the GIL released, so two Python threads could otherwise
// stitch into one layer at the same time (a data race on its arrays):
// stitch() takes the lock exclusively, mesh() and the accessors share it.
using PyStitcher = Shared<LayerStitcher>;

StitchOptions make_options(bool refine, const std::string& order, const std::string& bridge,
                           double tol, double clearance, const char* fn) {
    StitchOptions o;
    o.ear_clip.refine = refine;
    if (order == "quality") o.ear_clip.order = EarOrder::quality;
    else if (order == "plain") o.ear_clip.order = EarOrder::plain;
    else throw std::invalid_argument(std::string(fn) + ": order must be 'quality' or 'plain', got '" + order + "'");
    if (bridge == "extreme" || bridge == "extreme_point") o.ear_clip.bridge = BridgeMethod::extreme_point;
    else if (bridge == "eberly") o.ear_clip.bridge = BridgeMethod::eberly;
    else throw std::invalid_argument(std::string(fn) + ": bridge must be 'extreme' or 'eberly', got '" + bridge + "'");
    o.boundary_tolerance = tol;
    if (!(clearance >= 0.0)) throw std::invalid_argument(std::string(fn) + ": clearance must be >= 0");
    o.clearance = clearance;
    return o;
}

// The typed results as Python sees them: the C++ vectors handed to numpy
// once (no copy), as attributes of small record classes.
struct PyStitchGap {
    std::int64_t id, n_vertices, n_holes, n_interior;
    py::array_t<std::int64_t> triangles, patches, merged_gaps;
};

struct PyStitchReport {
    std::int64_t patch_id, patch_vertex_offset, patch_triangle_offset, n_candidates, grow_rounds;
    std::string patch_name;
    bool patch_flipped;
    py::list gaps;
    py::array_t<std::int64_t> removed, merged_gaps;
};

struct PyStitchedMesh {
    py::array_t<double> vertices;
    py::array_t<std::int64_t> triangles;
    py::array_t<std::int8_t> kinds;
    py::array_t<std::int64_t> owners, vertex_map, triangle_map;
};

PyStitchReport to_python(StitchReport&& r, const std::string& name) {
    PyStitchReport p{r.patch_id, r.patch_vertex_offset, r.patch_triangle_offset, r.n_candidates, r.grow_rounds,
                     name, r.patch_flipped, py::list(), to_numpy(std::move(r.removed)),
                     to_numpy(std::move(r.merged_gaps))};
    for (auto& g : r.gaps)
        p.gaps.append(PyStitchGap{g.id, g.n_vertices, g.n_holes, g.n_interior, to_numpy(std::move(g.triangles)),
                                  to_numpy(std::move(g.patches)), to_numpy(std::move(g.merged_gaps))});
    return p;
}

PyStitchedMesh to_python(StitchedMesh&& m) {
    return {to_numpy(std::move(m.vertices), 3), to_numpy(std::move(m.triangles), 3), to_numpy(std::move(m.kinds)),
            to_numpy(std::move(m.owners)), to_numpy(std::move(m.vertex_map)), to_numpy(std::move(m.triangle_map))};
}

void bind_results(py::module_& m) {
    py::native_enum<TriangleKind>(m, "TriangleKind", "enum.IntEnum",
                                  "Kind of a triangle of a stitched layer (StitchedMesh.kinds, Surface.kinds):\n"
                                  "layer (the original TIN), patch (a fault patch; owner = patch id) or gap\n"
                                  "(ear-clipped between the hole and the patch; owner = gap id).")
        .value("layer", TriangleKind::layer)
        .value("patch", TriangleKind::patch)
        .value("gap", TriangleKind::gap)
        .finalize();

    py::class_<PyStitchGap>(m, "StitchGap", "One gap polygon created by a stitch (Stitcher.stitch).")
        .def_readonly("id", &PyStitchGap::id, "gap id: the owner of its triangles")
        .def_readonly("triangles", &PyStitchGap::triangles,
                      "(g,) int64 rows of its triangles in the stitcher's (uncompacted) numbering; "
                      "StitchedMesh.triangle_map maps them")
        .def_readonly("n_vertices", &PyStitchGap::n_vertices, "vertices of the gap polygon, counted per ring")
        .def_readonly("n_holes", &PyStitchGap::n_holes,
                      "holes of the gap polygon (ear clipping gives n_vertices + 2 n_holes - 2 triangles)")
        .def_readonly("n_interior", &PyStitchGap::n_interior,
                      "removed layer data put back inside the gap (2 more triangles each)")
        .def_readonly("patches", &PyStitchGap::patches, "int64 ids of the patches whose outline is part of it")
        .def_readonly("merged_gaps", &PyStitchGap::merged_gaps, "int64 ids of earlier gaps it swallowed")
        .def("__repr__", [](const PyStitchGap& g) {
            return "StitchGap(id=" + std::to_string(g.id) + ", triangles=" + std::to_string(g.triangles.size()) +
                   ", n_vertices=" + std::to_string(g.n_vertices) + ", n_holes=" + std::to_string(g.n_holes) + ")";
        });

    py::class_<PyStitchReport>(m, "StitchReport", "What one Stitcher.stitch did.")
        .def_readonly("patch_id", &PyStitchReport::patch_id,
                      "id of the stitched patch (the order of stitch calls from 0): the owner of its triangles")
        .def_readonly("patch_name", &PyStitchReport::patch_name)
        .def_readonly("patch_vertex_offset", &PyStitchReport::patch_vertex_offset,
                      "patch vertex i is stitcher vertex patch_vertex_offset + i")
        .def_readonly("patch_triangle_offset", &PyStitchReport::patch_triangle_offset,
                      "stitcher row of the patch's first triangle")
        .def_readonly("patch_flipped", &PyStitchReport::patch_flipped,
                      "a piece of the patch was re-oriented (its outline was clockwise)")
        .def_readonly("gaps", &PyStitchReport::gaps, "list of StitchGap: the gap polygons created")
        .def_readonly("removed", &PyStitchReport::removed, "(k,) int64 layer rows removed, sorted")
        .def_readonly("merged_gaps", &PyStitchReport::merged_gaps,
                      "int64 ids of earlier gaps swallowed (they no longer exist)")
        .def_readonly("n_candidates", &PyStitchReport::n_candidates, "AABB candidates of the overlap step")
        .def_readonly("grow_rounds", &PyStitchReport::grow_rounds, "rounds of the growth step")
        .def("__repr__", [](const PyStitchReport& r) {
            return "StitchReport(patch_id=" + std::to_string(r.patch_id) + ", patch_name='" + r.patch_name +
                   "', gaps=" + std::to_string(r.gaps.size()) + ", removed=" + std::to_string(r.removed.size()) +
                   ", merged_gaps=" + std::to_string(r.merged_gaps.size()) + ")";
        });

    py::class_<PyStitchedMesh>(m, "StitchedMesh", "The compacted surface of a Stitcher (Stitcher.mesh()).")
        .def_readonly("vertices", &PyStitchedMesh::vertices, "(n, 3) float64")
        .def_readonly("triangles", &PyStitchedMesh::triangles, "(m, 3) int64")
        .def_readonly("kinds", &PyStitchedMesh::kinds, "(m,) int8 TriangleKind values")
        .def_readonly("owners", &PyStitchedMesh::owners, "(m,) int64: patch id / gap id / -1 (layer)")
        .def_readonly("vertex_map", &PyStitchedMesh::vertex_map,
                      "(stitcher vertices,) int64: compacted vertex or -1 if unused")
        .def_readonly("triangle_map", &PyStitchedMesh::triangle_map,
                      "(stitcher rows,) int64: compacted row or -1 if removed")
        .def("__repr__", [](const PyStitchedMesh& mm) {
            return "StitchedMesh(vertices=" + std::to_string(mm.vertices.shape(0)) +
                   ", triangles=" + std::to_string(mm.triangles.shape(0)) + ")";
        });
}

}  // namespace

void bind_stitch(py::module_& m) {
    bind_results(m);
    py::class_<PyStitcher>(m, "Stitcher", R"doc(
Stitches fault patches into one layer surface, one after another (paper 2.4-2.6).

Stitcher(vertices (n, 3), triangles (m, 3) CCW TIN, boundary=None (k, 2) study area,
         halfedges=None (3m,) opposite half-edges (Tin.halfedges) to skip the adjacency
         build, name="layer", refine=True, order="quality", bridge="extreme",
         boundary_tolerance=-1 (auto), clearance=0.0 (grow the removed region until its
         boundary vertices are at least this far from the patch outline))

Each stitch() is local to the patch's neighbourhood: AABB candidates, exact
closed-region overlap, growth of the removed set to a disk strictly containing the
patch outline (earlier gaps are merged, earlier patches become holes), gap polygons
(with the study-area boundary for a fault that reaches it), ear clipping in XY,
local merge with shared vertices. mesh() returns the compacted surface.
)doc")
        .def(py::init([](const py::handle& vertices, const py::handle& triangles, const py::handle& boundary,
                         const py::handle& halfedges, const std::string& name, bool refine,
                         const std::string& order, const std::string& bridge, double tol, double clearance) {
                 const char* fn = "Stitcher";
                 auto V = as_points(vertices, fn, "vertices", 3, 3);
                 auto T = as_indices(triangles, fn, "triangles", 3);
                 std::vector<double> bxy;
                 if (!boundary.is_none()) {
                     auto B = as_points(boundary, fn, "boundary", 2, 2);
                     bxy.assign(B.data(), B.data() + 2 * B.shape(0));
                 }
                 IndexArray H;
                 const bool has_h = !halfedges.is_none();
                 if (has_h) H = as_links(halfedges, fn, "halfedges", 3 * T.shape(0));
                 const std::int64_t* he = has_h ? H.data() : nullptr;
                 StitchOptions opt = make_options(refine, order, bridge, tol, clearance, fn);
                 py::gil_scoped_release release;
                 return new PyStitcher(LayerStitcher(V.data(), static_cast<std::size_t>(V.shape(0)), T.data(),
                                                     static_cast<std::size_t>(T.shape(0)),
                                                     bxy.empty() ? nullptr : bxy.data(), bxy.size() / 2, he, name, opt));
             }),
             py::arg("vertices"), py::arg("triangles"), py::arg("boundary") = py::none(),
             py::arg("halfedges") = py::none(), py::arg("name") = "layer", py::arg("refine") = true,
             py::arg("order") = "quality", py::arg("bridge") = "extreme", py::arg("boundary_tolerance") = -1.0,
             py::arg("clearance") = 0.0)
        .def_static(
            "from_layer_tin",
            [](const Shared<LayerTin>& layer, bool refine, const std::string& order, const std::string& bridge,
               double tol, double clearance) {
                StitchOptions opt = make_options(refine, order, bridge, tol, clearance, "Stitcher.from_layer_tin");
                // The layer is read under its shared lock, the GIL released.
                return read_locked(layer, [&](const LayerTin& l) { return std::make_unique<PyStitcher>(l, opt); });
            },
            py::arg("layer"), py::kw_only(), py::arg("refine") = true, py::arg("order") = "quality",
            py::arg("bridge") = "extreme", py::arg("boundary_tolerance") = -1.0, py::arg("clearance") = 0.0,
            "The Stitcher of a LayerTin: its mesh inside the study area (with half-edges), its study\n"
            "area as the boundary and its name, taken over in C++ without going through arrays;\n"
            "the options as for the constructor. The LayerTin is not changed.")
        .def(
            "stitch",
            [](PyStitcher& p, const py::handle& pv, const py::handle& pt, const std::string& name) {
                const char* fn = "Stitcher.stitch";
                auto V = as_points(pv, fn, "patch_vertices", 3, 3);
                auto T = as_indices(pt, fn, "patch_triangles", 3);
                StitchReport r;
                r = write_locked(p, [&](LayerStitcher& st) {
                    return st.stitch(V.data(), static_cast<std::size_t>(V.shape(0)), T.data(),
                                     static_cast<std::size_t>(T.shape(0)), name);
                });
                return to_python(std::move(r), name);
            },
            py::arg("patch_vertices"), py::arg("patch_triangles"), py::arg("name") = "patch",
            "Stitch one patch (vertices (n, 3), triangles (m, 3), consistently oriented; several\n"
            "disjoint components allowed). Returns a StitchReport: patch_id, patch_name,\n"
            "patch_vertex_offset, patch_triangle_offset, patch_flipped, gaps (list of StitchGap: id,\n"
            "triangles (stitcher rows), n_vertices, n_holes, n_interior, patches, merged_gaps), removed,\n"
            "merged_gaps, n_candidates, grow_rounds. Raises GeometryError (naming both) if the patch\n"
            "overlaps or touches an earlier patch; nothing changes on error.")
        .def(
            "mesh",
            [](const PyStitcher& p) {
                StitchedMesh mm = read_locked(p, [](const LayerStitcher& st) { return st.mesh(); });
                return to_python(std::move(mm));
            },
            "The compacted surface: a StitchedMesh with vertices (n, 3), triangles (m, 3), kinds (m,)\n"
            "int8 (TriangleKind: layer, patch, gap), owners (m,) (patch id / gap id / -1), vertex_map\n"
            "and triangle_map (stitcher numbering -> compacted, -1 if gone).")
        .def_property_readonly("n_vertices",
                               [](const PyStitcher& p) { return read_locked(p, [](const LayerStitcher& st) { return st.n_vertices(); }); })
        .def_property_readonly("n_triangles",
                               [](const PyStitcher& p) { return read_locked(p, [](const LayerStitcher& st) { return st.n_triangles(); }); })
        .def_property_readonly("n_live_triangles", [](const PyStitcher& p) {
            return read_locked(p, [](const LayerStitcher& st) { return st.n_live_triangles(); });
        })
        .def_property_readonly("name", [](const PyStitcher& p) { return p.obj.name(); })  // set once, never changed
        .def_property_readonly("patch_names", [](const PyStitcher& p) {
            return read_locked(p, [](const LayerStitcher& st) { return st.patch_names(); });  // a copy
        });

    m.def(
        "stitch",
        [](const py::handle& vertices, const py::handle& triangles, const py::handle& patch_vertices,
           const py::handle& patch_triangles, const py::handle& boundary, bool refine, const std::string& order,
           const std::string& bridge, double clearance) {
            const char* fn = "stitch";
            auto V = as_points(vertices, fn, "vertices", 3, 3);
            auto T = as_indices(triangles, fn, "triangles", 3);
            auto PV = as_points(patch_vertices, fn, "patch_vertices", 3, 3);
            auto PT = as_indices(patch_triangles, fn, "patch_triangles", 3);
            std::vector<double> bxy;
            if (!boundary.is_none()) {
                auto B = as_points(boundary, fn, "boundary", 2, 2);
                bxy.assign(B.data(), B.data() + 2 * B.shape(0));
            }
            StitchOptions opt = make_options(refine, order, bridge, -1.0, clearance, fn);
            StitchResult r;
            {
                py::gil_scoped_release release;
                r = stitch(V.data(), static_cast<std::size_t>(V.shape(0)), T.data(),
                           static_cast<std::size_t>(T.shape(0)), PV.data(), static_cast<std::size_t>(PV.shape(0)),
                           PT.data(), static_cast<std::size_t>(PT.shape(0)), bxy.empty() ? nullptr : bxy.data(),
                           bxy.size() / 2, opt);
            }
            return py::make_tuple(to_numpy(std::move(r.mesh.vertices), 3), to_numpy(std::move(r.mesh.triangles), 3),
                                  to_numpy(std::move(r.gap_rows)));
        },
        py::arg("vertices"), py::arg("triangles"), py::arg("patch_vertices"), py::arg("patch_triangles"),
        py::arg("boundary") = py::none(), py::arg("refine") = true, py::arg("order") = "quality",
        py::arg("bridge") = "extreme", py::arg("clearance") = 0.0,
        "Stitch one fault patch into a layer TIN (one-shot Stitcher). Returns (vertices (n, 3),\n"
        "triangles (m, 3), gap_rows (g,)): the merged surface with shared vertices and the rows\n"
        "of its gap triangles. boundary: the study area (default: the mesh's outer boundary).");

    m.def(
        "triangles_touching_region",
        [](const py::handle& vertices, const py::handle& triangles, const py::handle& rings) {
            const char* fn = "triangles_touching_region";
            auto V = as_points(vertices, fn, "vertices", 2, 3);
            auto T = as_indices(triangles, fn, "triangles", 3);
            RingsData R = as_rings(rings, fn, 2, 0);
            const std::vector<double>& xy = R.xy;
            const std::vector<std::int64_t>& off = R.offsets;
            std::vector<std::int64_t> out;
            {
                py::gil_scoped_release release;
                out = triangles_touching_region(V.data(), static_cast<std::size_t>(V.shape(0)),
                                                static_cast<std::size_t>(V.shape(1)), T.data(),
                                                static_cast<std::size_t>(T.shape(0)), xy.data(), off.data(),
                                                off.size() - 1);
            }
            return to_numpy(std::move(out));
        },
        py::arg("vertices"), py::arg("triangles"), py::arg("rings"),
        "Rows (int64) of the triangles whose closed XY projection meets the closed region given\n"
        "by rings (list of (k, 2) arrays, even-odd rule). Exact (orient2d).");

    // Immutable after construction (it owns a copy of the rings), so
    // concurrent queries with the GIL released are safe.
    py::class_<TouchingRegion>(m, "TouchingRegion",
                               "The closed region of triangles_touching_region built once for many\n"
                               "queries: touching(vertices, triangles) equals\n"
                               "triangles_touching_region(vertices, triangles, rings). Keeps a copy of\n"
                               "the rings.")
        .def(py::init([](const py::handle& rings) {
                 RingsData R = as_rings(rings, "TouchingRegion", 2, 0);
                 py::gil_scoped_release release;
                 return TouchingRegion(R.xy.data(), R.offsets.data(), R.n_rings());
             }),
             py::arg("rings"))
        .def_property_readonly("n_rings", &TouchingRegion::n_rings, "Number of rings it was built from.")
        .def(
            "touching",
            [](const TouchingRegion& self, const py::handle& vertices, const py::handle& triangles) {
                const char* fn = "TouchingRegion.touching";
                auto V = as_points(vertices, fn, "vertices", 2, 3);
                auto T = as_indices(triangles, fn, "triangles", 3);
                std::vector<std::int64_t> out;
                {
                    py::gil_scoped_release release;
                    out = self.touching(V.data(), static_cast<std::size_t>(V.shape(0)),
                                        static_cast<std::size_t>(V.shape(1)), T.data(),
                                        static_cast<std::size_t>(T.shape(0)));
                }
                return to_numpy(std::move(out));
            },
            py::arg("vertices"), py::arg("triangles"),
            "Rows (int64) of the triangles whose closed XY projection meets the region. Exact.");

    m.def(
        "triangles_not_covered_once",
        [](const py::handle& vertices, const py::handle& triangles, const py::object& area_obj, bool outline) {
            const char* fn = "triangles_not_covered_once";
            const StudyArea* area = optional_study_area(area_obj, fn);
            auto V = as_points(vertices, fn, "vertices", 2, 3);
            auto T = as_indices(triangles, fn, "triangles", 3, V.shape(0));
            std::vector<std::int64_t> out;
            {
                py::gil_scoped_release release;
                out = triangles_not_covered_once(V.data(), static_cast<std::size_t>(V.shape(0)),
                                                 static_cast<std::size_t>(V.shape(1)), T.data(),
                                                 static_cast<std::size_t>(T.shape(0)), area, outline);
            }
            return to_numpy(std::move(out));
        },
        py::arg("vertices"), py::arg("triangles"), py::kw_only(), py::arg("area") = py::none(), py::arg("outline") = true,
        "Rows (int64) of the triangles where the surface does not cover the XY plane exactly once\n"
        "with orientation (+1 per containing triangle oriented like its piece, -1 per one oriented\n"
        "against it: a fold's strip): at its centroid the cover is not 1, or an outline edge enters\n"
        "its open interior (with ``area``, a StudyArea, outline edges along one of its sides are\n"
        "exempt: a fold carried onto the boundary overlaps itself there; ``outline=False``: the\n"
        "centroids only). Exact (orient2d,\n"
        "simulation of simplicity on edges). A folded patch whose sheets end at different places\n"
        "reaches out of its outline where this is not 1.");

    m.def(
        "triangles_at_outline_crossings",
        [](const py::handle& vertices, const py::handle& triangles, const py::object& area_obj) {
            const char* fn = "triangles_at_outline_crossings";
            const StudyArea* area = optional_study_area(area_obj, fn);
            auto V = as_points(vertices, fn, "vertices", 2, 3);
            auto T = as_indices(triangles, fn, "triangles", 3, V.shape(0));
            std::vector<std::int64_t> out;
            {
                py::gil_scoped_release release;
                out = triangles_at_outline_crossings(V.data(), static_cast<std::size_t>(V.shape(0)),
                                                     static_cast<std::size_t>(V.shape(1)), T.data(),
                                                     static_cast<std::size_t>(T.shape(0)), area);
            }
            return to_numpy(std::move(out));
        },
        py::arg("vertices"), py::arg("triangles"), py::kw_only(), py::arg("area") = py::none(),
        "Rows (int64, sorted) of the triangles whose outline edges meet another outline edge in XY,\n"
        "where the stitcher needs the outline simple (its own test): edges that share no vertex must\n"
        "not share a point, edges that share one must not fold back onto each other there. With\n"
        "``area`` (a StudyArea), pairs of edges that both run along one of its sides are exempt (a\n"
        "reverse fault that runs out of the area folds along it). The outline is the triangles'\n"
        "boundary loops (open chains are not tested). Exact (orient2d).");
}

}  // namespace faultmesh::bindings
