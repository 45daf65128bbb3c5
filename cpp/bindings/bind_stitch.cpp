// Bindings for stitch: the LayerStitcher class (many faults into one layer),
// the one-shot stitch() and triangles_touching_region().
#include <faultmesh/stitch.hpp>

#include <pybind11/stl.h>  // patch_names: std::vector<std::string> -> list

#include <mutex>
#include <shared_mutex>

#include "common.hpp"

namespace faultmesh::bindings {

namespace {

// A LayerStitcher shared with Python. It is not thread-safe and stitch()
// runs with the GIL released, so two Python threads could otherwise stitch
// into one layer at the same time (a data race on its arrays): stitch() takes
// the lock exclusively, mesh() and the accessors share it. As for Tin, the
// lock is taken after the GIL is released and the GIL is never needed while
// it is held.
struct PyStitcher {
    explicit PyStitcher(LayerStitcher&& s) : st(std::move(s)) {}
    LayerStitcher st;
    mutable std::shared_mutex mu;
};

template <class F>
auto read_locked(const PyStitcher& p, F&& f) {
    py::gil_scoped_release release;
    std::shared_lock<std::shared_mutex> lock(p.mu);
    return f(p.st);
}

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

py::array_t<std::int64_t> idx(const std::vector<std::int64_t>& v) {
    return to_numpy(std::vector<std::int64_t>(v));
}

py::dict report_dict(StitchReport&& r) {
    py::dict d;
    d["patch_id"] = r.patch_id;
    d["patch_vertex_offset"] = r.patch_vertex_offset;
    d["patch_triangle_offset"] = r.patch_triangle_offset;
    d["patch_flipped"] = r.patch_flipped;
    py::list gaps;
    for (auto& g : r.gaps) {
        py::dict gd;
        gd["id"] = g.id;
        gd["rows"] = idx(g.triangles);
        gd["n_vertices"] = g.n_vertices;
        gd["n_holes"] = g.n_holes;
        gd["patches"] = idx(g.patches);
        gd["merged_gaps"] = idx(g.merged_gaps);
        gaps.append(gd);
    }
    d["gaps"] = gaps;
    d["removed"] = to_numpy(std::move(r.removed));
    d["merged_gaps"] = to_numpy(std::move(r.merged_gaps));
    d["n_candidates"] = r.n_candidates;
    d["grow_rounds"] = r.grow_rounds;
    return d;
}

py::dict mesh_dict(StitchedMesh&& m) {
    py::dict d;
    d["vertices"] = to_numpy(std::move(m.vertices), 3);
    d["triangles"] = to_numpy(std::move(m.triangles), 3);
    d["kinds"] = to_numpy(std::move(m.kinds));
    d["owners"] = to_numpy(std::move(m.owners));
    d["vertex_map"] = to_numpy(std::move(m.vertex_map));
    d["triangle_map"] = to_numpy(std::move(m.triangle_map));
    return d;
}

}  // namespace

void bind_stitch(py::module_& m) {
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
        .def(
            "stitch",
            [](PyStitcher& p, const py::handle& pv, const py::handle& pt, const std::string& name) {
                const char* fn = "Stitcher.stitch";
                auto V = as_points(pv, fn, "patch_vertices", 3, 3);
                auto T = as_indices(pt, fn, "patch_triangles", 3);
                StitchReport r;
                {
                    py::gil_scoped_release release;
                    std::unique_lock<std::shared_mutex> lock(p.mu);
                    r = p.st.stitch(V.data(), static_cast<std::size_t>(V.shape(0)), T.data(),
                                  static_cast<std::size_t>(T.shape(0)), name);
                }
                return report_dict(std::move(r));
            },
            py::arg("patch_vertices"), py::arg("patch_triangles"), py::arg("name") = "patch",
            "Stitch one patch (vertices (n, 3), triangles (m, 3), consistently oriented; several\n"
            "disjoint components allowed). Returns a dict: patch_id, patch_vertex_offset,\n"
            "patch_triangle_offset, patch_flipped, gaps (list of dicts: id, rows (stitcher rows),\n"
            "n_vertices, n_holes, patches, merged_gaps), removed, merged_gaps, n_candidates,\n"
            "grow_rounds. Raises GeometryError (naming both) if the patch overlaps or touches an\n"
            "earlier patch; nothing changes on error.")
        .def(
            "mesh",
            [](const PyStitcher& p) {
                StitchedMesh mm = read_locked(p, [](const LayerStitcher& st) { return st.mesh(); });
                return mesh_dict(std::move(mm));
            },
            "The compacted surface: dict with vertices (n, 3), triangles (m, 3), kinds (m,) int8\n"
            "(0 layer, 1 patch, 2 gap), owners (m,) (patch id / gap id / -1), vertex_map and\n"
            "triangle_map (stitcher numbering -> compacted, -1 if gone).")
        .def_property_readonly("n_vertices",
                               [](const PyStitcher& p) { return read_locked(p, [](const LayerStitcher& st) { return st.n_vertices(); }); })
        .def_property_readonly("n_triangles",
                               [](const PyStitcher& p) { return read_locked(p, [](const LayerStitcher& st) { return st.n_triangles(); }); })
        .def_property_readonly("n_live_triangles", [](const PyStitcher& p) {
            return read_locked(p, [](const LayerStitcher& st) { return st.n_live_triangles(); });
        })
        .def_property_readonly("name", [](const PyStitcher& p) { return p.st.name(); })  // set once, never changed
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
}

}  // namespace faultmesh::bindings
